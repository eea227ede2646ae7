"""Datasets: CSV upload (multipart, text/csv), JSON, list/get/delete, malformed uploads leave
nothing behind, size limit, and persistence across restarts on the same SQLite file."""
import json
from concurrent.futures import ThreadPoolExecutor

import httpx
import pytest

from api_conftest import (CLEAN_IDS, LEAK_IDS, SAMPLE_IDS, api, assert_field_error, client,  # noqa: F401
                          db_path, live_server, model, n_datasets, sample_csv_text, small_csv)


def _upload(c, text, filename="rig.csv", **fields):
    return c.post("/api/datasets", files={"file": (filename, text, "text/csv")},
                  data={k: str(v) for k, v in fields.items()})


def _json_meas(n=12, **extra):
    return {"t": [i * 0.001 for i in range(n)], "u": [0.0] * n, "p_a": [1.2e5] * n, **extra}


# ------------------------------------------------------------------------------ samples
def test_samples_are_seeded_and_listed_first(client):
    ds = client.get("/api/datasets").json()
    assert [d["id"] for d in ds] == SAMPLE_IDS
    for d in ds:
        assert d["sample"] and d["n_samples"] == 1001 and d["description"]
        assert set(d["signals"]) >= {"p_a", "p_b"}
        assert "locked" in d["scenario"] and "x0" in d["scenario"]
        assert "measurement" not in d  # the list is metadata only


def test_get_sample_dataset_in_si_units(client):
    d = client.get(f"/api/datasets/{LEAK_IDS[1]}").json()
    m = d["measurement"]
    assert len(m["t"]) == len(m["p_a"]) == len(m["x"]) == d["n_samples"]
    # CSV in bar and mm, stored in Pa and m: ambient ~1e5 Pa, x0 = 50 mm -> 0.05 m
    assert 0.9e5 < m["p_a"][0] < 1.2e5
    assert m["x"][0] == pytest.approx(0.05, abs=1e-3)  # 12-bit acquisition quantum << 1 mm


# ------------------------------------------------------------------------------ uploads
def test_multipart_csv_upload_then_listed_and_retrievable(client):
    n0 = n_datasets(client)
    r = _upload(client, small_csv(), locked="true", x0=0.01, description="bench rig")
    assert r.status_code == 201, r.text[:500]
    info = r.json()
    assert info.pop("import")["format"] == "csv"   # the upload's import report (not stored)
    assert info["name"] == "rig" and info["n_samples"] == 20 and info["sample"] is None
    assert info["signals"] == ["p_a", "x"]
    assert info["scenario"] == {"locked": True, "x0": 0.01}
    assert info["description"] == "bench rig"
    assert n_datasets(client) == n0 + 1
    listed = {d["id"]: d for d in client.get("/api/datasets").json()}
    assert listed[info["id"]] == info
    d = client.get(f"/api/datasets/{info['id']}").json()
    assert {k: d[k] for k in info} == info
    m = d["measurement"]
    # units converted from the headers: p_a[bar] -> Pa, x[mm] -> m
    assert m["p_a"][:3] == pytest.approx([1.0e5, 1.01e5, 1.02e5], rel=1e-12)  # float rounding
    assert m["x"][:3] == pytest.approx([0.010, 0.011, 0.012], rel=1e-12)
    assert m["u"][4:7] == [0.0, 1.0, 1.0]


def test_multipart_name_and_scenario_fields(client):
    r = _upload(client, small_csv(), name="hold test", scenario=json.dumps({"locked": True, "x0": 0.1}))
    assert r.status_code == 201
    assert r.json()["name"] == "hold test" and r.json()["scenario"] == {"locked": True, "x0": 0.1}


def test_text_csv_body(client):
    n0 = n_datasets(client)
    r = client.post("/api/datasets?name=plain&locked=1&x0=0.02", content=small_csv(),
                    headers={"content-type": "text/csv"})
    assert r.status_code == 201, r.text[:500]
    info = r.json()
    assert info["name"] == "plain" and info["scenario"] == {"locked": True, "x0": 0.02}
    assert n_datasets(client) == n0 + 1
    # 10 mm -> 0.01 m (default rel 1e-6: float rounding of the scale factor)
    assert client.get(f"/api/datasets/{info['id']}").json()["measurement"]["x"][0] == pytest.approx(0.01)


def test_text_csv_crlf_and_gauge_units(client):
    r = client.post("/api/datasets", content=small_csv().replace("\n", "\r\n"),
                    headers={"content-type": "text/csv"})
    assert r.status_code == 201
    csv = "t[ms],u,p_a[barg]\n" + "".join(f"{i},0,0.5\n" for i in range(12))
    r = client.post("/api/datasets", content=csv, headers={"content-type": "text/csv"})
    assert r.status_code == 201
    m = client.get(f"/api/datasets/{r.json()['id']}").json()["measurement"]
    # unit conversions; default rel 1e-6 covers only float rounding of the scale factors
    assert m["t"][1] == pytest.approx(0.001)  # ms -> s
    assert m["p_a"][0] == pytest.approx(0.5e5 + 1.013e5)  # gauge + default ambient


def test_json_body(client):
    n0 = n_datasets(client)
    meas = _json_meas(name="js")
    meas["p_a"][3] = None  # a missing sample
    r = client.post("/api/datasets", json={"name": "json set", "description": "d",
                                           "scenario": {"locked": True, "x0": 0.1},
                                           "measurement": meas})
    assert r.status_code == 201, r.text[:500]
    info = r.json()
    assert info["name"] == "json set" and info["n_samples"] == 12
    assert n_datasets(client) == n0 + 1
    m = client.get(f"/api/datasets/{info['id']}").json()["measurement"]
    assert m["p_a"][3] is None and m["p_a"][4] == 1.2e5


def test_a_huge_integer_in_the_scenario_is_stored_as_the_number_it_is(client):
    # found by tests/fuzz_api.py: an integer of 31 digits passed the check (x0 >= 0, the stroke
    # is checked against a model later) and the store's JSON writer refused it: a 500
    n0 = n_datasets(client)
    r = client.post("/api/datasets", content=json.dumps(
        {"name": "big", "scenario": {"locked": True, "x0": 10 ** 30, "solver": {"max_steps": 10 ** 6}},
         "measurement": _json_meas()}), headers={"content-type": "application/json"})
    assert r.status_code == 201, r.text[:500]
    assert r.json()["scenario"] == {"locked": True, "x0": 1e30, "solver": {"max_steps": 1000000}}
    up = _upload(client, small_csv(), scenario=json.dumps({"x0": 10 ** 40}))
    assert up.status_code == 201 and up.json()["scenario"] == {"x0": 1e40}
    assert n_datasets(client) == n0 + 2
    for info in (r.json(), up.json()):
        assert client.get(f"/api/datasets/{info['id']}").status_code == 200


def test_json_body_without_measurement_name(client):
    # "name" is optional in the measurement schema: leaving it out must not be an error
    r = client.post("/api/datasets", json={"name": "unnamed measurement", "measurement": _json_meas()})
    assert r.status_code == 201, r.text[:500]
    assert r.json()["name"] == "unnamed measurement"


def test_json_body_errors(client):
    n0 = n_datasets(client)
    r = client.post("/api/datasets", json={"measurement": _json_meas(name="x", u=[0, "x"] + [0] * 10)})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["body", "measurement", "u", 1]
    r = client.post("/api/datasets", json={"measurement": {"u": [0.0, 0.0], "name": "x"}})
    assert r.status_code == 422 and r.json()["detail"][0]["type"] == "missing"
    # a record without u is accepted (issue 28), but not one with nothing measured
    r = client.post("/api/datasets", json={"measurement": {"t": [0.0, 0.001], "name": "x"}})
    assert_field_error(r, "measurement")
    r = client.post("/api/datasets", json={"measurement": _json_meas(name="x"), "colour": "red"})
    assert r.status_code == 422 and r.json()["detail"][0]["type"] == "extra_forbidden"
    bad_t = _json_meas(name="x")
    bad_t["t"][5] = 0.0
    r = client.post("/api/datasets", json={"measurement": bad_t})
    assert_field_error(r, "measurement", msg_contains=["'t'", "row 6"])
    r = client.post("/api/datasets", content=b"{bad json", headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.json()["detail"][0]["type"] == "json_invalid"
    assert n_datasets(client) == n0


# ------------------------------------------------------------------------------ malformed CSV
def test_non_numeric_cell_names_column_and_row_and_stores_nothing(client):
    n0 = n_datasets(client)
    bad = small_csv().replace("1.03,13", "abc,13")  # data row 4
    for r in (_upload(client, bad),
              client.post("/api/datasets", content=bad, headers={"content-type": "text/csv"})):
        assert r.status_code == 422, r.text[:500]
        err = r.json()["detail"][0]
        assert err["type"] == "measurement_error"
        assert err["column"] == "p_a[bar]" and err["row"] == 4
        assert err["loc"] == ["body", "measurement", "p_a[bar]", 4]
        assert "'abc' is not a number" in err["msg"]
    assert n_datasets(client) == n0


def test_decreasing_time_names_column_and_row_and_stores_nothing(client):
    n0 = n_datasets(client)
    bad = small_csv().replace("0.004,", "0.001,")  # data row 5 goes back in time
    r = _upload(client, bad)
    assert r.status_code == 422
    err = r.json()["detail"][0]
    assert err["column"] == "t[s]" and err["row"] == 5
    assert "increasing" in err["msg"]
    assert n_datasets(client) == n0


def test_decreasing_time_message_prints_plain_numbers(client):
    bad = small_csv().replace("0.004,", "0.001,")
    msg = _upload(client, bad).json()["detail"][0]["msg"]
    assert "np.float64" not in msg and "t = 0.001 s" in msg, msg


@pytest.mark.parametrize("text,column,row", [
    ("t,u,p_a\n" + "".join(f"{i * 0.001},0,\n" for i in range(12)), "p_a", None),
    ("t,u,p_a,p_a\n" + "".join(f"{i * 0.001},0,1e5,1e5\n" for i in range(12)), "p_a", None),
    ("t,u,zz\n" + "".join(f"{i * 0.001},0,1e5\n" for i in range(12)), "zz", None),
    ("t,u,p_a\n" + "".join(f"{i * 0.001},0,1e5,3\n" for i in range(12)), None, 1),
    ("t,u,p_a\n0,0,1e5\n0.001,0,1e5\n", None, None),
    ("", None, None),
])
def test_other_malformed_csv(client, text, column, row):
    n0 = n_datasets(client)
    r = client.post("/api/datasets", content=text, headers={"content-type": "text/csv"})
    assert r.status_code == 422, r.text[:300]
    err = r.json()["detail"][0]
    assert (err["column"], err["row"]) == (column, row), err
    assert n_datasets(client) == n0


def test_multipart_form_errors_store_nothing(client):
    n0 = n_datasets(client)
    r = client.post("/api/datasets", files={"data": ("a.csv", small_csv(), "text/csv")})
    assert_field_error(r, "file")
    assert_field_error(_upload(client, small_csv(), x0="abc"), "x0")
    assert_field_error(_upload(client, small_csv(), scenario="{bad"), "scenario", msg_contains="JSON")
    assert_field_error(_upload(client, small_csv(), scenario="[1, 2]"), "scenario")
    assert n_datasets(client) == n0


# ------------------------------------------------------------------------------ size limit
def test_oversized_upload_413_and_nothing_stored(db_path):
    with api(db_path, max_upload_bytes=2000) as c:
        n0 = n_datasets(c)
        big = small_csv(200)
        assert len(big.encode()) > 2000
        r = _upload(c, big)
        assert r.status_code == 413 and "2000" in r.json()["detail"]
        r = c.post("/api/datasets", content=big, headers={"content-type": "text/csv"})
        assert r.status_code == 413

        def chunks():  # no Content-Length: the limit is enforced while streaming
            data = big.encode()
            for i in range(0, len(data), 256):
                yield data[i:i + 256]
        r = c.post("/api/datasets", content=chunks(), headers={"content-type": "text/csv"})
        assert r.status_code == 413
        r = c.post("/api/datasets", json={"measurement": _json_meas(200, name="x")})
        assert r.status_code == 413
        assert n_datasets(c) == n0
        assert _upload(c, small_csv(20)).status_code == 201  # small uploads still work


def test_explicit_upload_limit_wins_over_env(db_path, monkeypatch):
    # like db_path (PNEUCORE_DB is only the default), an explicit Limits value must not be
    # overwritten by the environment variable
    monkeypatch.setenv("PNEUCORE_MAX_UPLOAD", str(10**9))
    with api(db_path, max_upload_bytes=2000) as c:
        assert c.get("/api/limits").json()["max_upload_bytes"] == 2000
        assert _upload(c, small_csv(200)).status_code == 413


def test_default_upload_limit_from_env(db_path, monkeypatch):
    monkeypatch.setenv("PNEUCORE_MAX_UPLOAD", "1500")
    from app.config import Settings
    from app.main import create_app
    from fastapi.testclient import TestClient
    with TestClient(create_app(Settings(db_path=str(db_path))), base_url="http://127.0.0.1") as c:
        assert c.get("/api/limits").json()["max_upload_bytes"] == 1500
        assert _upload(c, small_csv(200)).status_code == 413


# ------------------------------------------------------------------------------ delete
def test_delete_then_404(client):
    did = _upload(client, small_csv()).json()["id"]
    n0 = n_datasets(client)
    r = client.delete(f"/api/datasets/{did}")
    assert r.status_code == 204 and r.content == b""
    assert n_datasets(client) == n0 - 1
    for r in (client.get(f"/api/datasets/{did}"), client.delete(f"/api/datasets/{did}")):
        assert r.status_code == 404 and did in r.json()["detail"]
    assert_field_error(client.post("/api/compare", json={"model": model(), "experiments": [
        {"dataset_id": did}]}), "experiments[0].dataset_id")


def test_unknown_dataset_404(client):
    assert client.get("/api/datasets/nope").status_code == 404
    assert client.delete("/api/datasets/nope").status_code == 404


# ------------------------------------------------------------------------------ use in analyses
def test_uploaded_csv_usable_by_id(client):
    """The shipped CSV uploaded by a user analyses exactly like the seeded sample."""
    r = _upload(client, sample_csv_text("piston-leak", "free-pulses"), filename="leak.csv",
                locked="false", x0=0.05)
    assert r.status_code == 201
    mine = client.post("/api/compare", json={"model": model(), "experiments": [
        {"dataset_id": r.json()["id"]}]}).json()
    ref = client.post("/api/compare", json={"model": model(), "experiments": [
        {"dataset_id": LEAK_IDS[1]}]}).json()
    assert mine["overall"] == ref["overall"]  # same bytes, same code: identical
    assert mine["experiments"][0]["name"] == "leak"


# ------------------------------------------------------------------------------ persistence
def test_data_survive_restart_and_samples_not_duplicated(db_path):
    with api(db_path) as c:
        assert [d["id"] for d in c.get("/api/datasets").json()] == SAMPLE_IDS
        info = _upload(c, small_csv(), name="kept", locked="true", x0=0.1).json()
        before = c.get(f"/api/datasets/{info['id']}").json()
        gone = _upload(c, small_csv(), name="deleted").json()["id"]
        assert c.delete(f"/api/datasets/{gone}").status_code == 204
        r = c.delete(f"/api/datasets/{CLEAN_IDS[0]}")   # samples are read-only
        assert r.status_code == 403 and "read-only" in r.json()["detail"]
    with api(db_path) as c:
        ids = [d["id"] for d in c.get("/api/datasets").json()]
        assert len(ids) == len(set(ids)) == len(SAMPLE_IDS) + 1
        assert info["id"] in ids and gone not in ids and CLEAN_IDS[0] in ids
        assert c.get(f"/api/datasets/{info['id']}").json() == before
    with api(db_path) as c:
        assert len(c.get("/api/datasets").json()) == len(SAMPLE_IDS) + 1


def test_fresh_databases_are_independent(tmp_path):
    with api(tmp_path / "a.sqlite3") as a, api(tmp_path / "b.sqlite3") as b:
        did = _upload(a, small_csv()).json()["id"]
        assert a.get(f"/api/datasets/{did}").status_code == 200
        assert b.get(f"/api/datasets/{did}").status_code == 404


def test_concurrent_writes_real_server(db_path):
    """16 clients upload, delete, list and send bad CSVs at once: no 500, nothing lost."""
    bad = small_csv().replace("1.03,13", "abc,13")
    with live_server(db_path) as url:
        def worker(i):
            kept, codes = [], []
            with httpx.Client(base_url=url, timeout=120) as c:  # timeout: a hang bound only
                for k in range(6):
                    r = c.post("/api/datasets", files={"file": (f"w{i}-{k}.csv", small_csv(), "text/csv")})
                    codes.append(r.status_code)
                    if k % 2:
                        codes.append(c.delete(f"/api/datasets/{r.json()['id']}").status_code)
                    else:
                        kept.append(r.json()["id"])
                    codes.append(c.get("/api/datasets").status_code)
                    codes.append(c.post("/api/datasets", content=bad,
                                        headers={"content-type": "text/csv"}).status_code)
            return kept, codes
        with ThreadPoolExecutor(16) as ex:
            out = list(ex.map(worker, range(16)))
        codes = [x for _, cs in out for x in cs]
        assert sorted(set(codes)) == [200, 201, 204, 422]
        assert codes.count(201) == 96 and codes.count(204) == 48 and codes.count(422) == 96
        with httpx.Client(base_url=url) as c:
            ids = [d["id"] for d in c.get("/api/datasets").json()]
    kept = {k for ks, _ in out for k in ks}
    assert len(ids) == len(set(ids)) == len(SAMPLE_IDS) + 48
    assert kept <= set(ids)
