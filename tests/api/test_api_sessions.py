"""Refinement sessions: versions with their errors, list/get/delete, 404s, persistence."""
import pytest

from api_conftest import (LEAK_IDS, api, assert_field_error, client, db_path,  # noqa: F401
                          inline_experiment, model, sample_csv_text)

LEAK = [{"dataset_id": i} for i in LEAK_IDS]


def _with_leak(g=8e-11):
    m = model()
    m["effects"] = {"piston_leakage": {"conductance": g}}
    return m


def _create(c, **body):
    r = c.post("/api/sessions", json={"name": "leak hunt", "model": model(), "experiments": LEAK, **body})
    assert r.status_code == 201, r.text[:500]
    return r.json()


def test_create_gives_version_0_with_errors(client):
    s = _create(client)
    assert s["name"] == "leak hunt" and len(s["id"]) > 0
    assert s["experiments"] == LEAK
    (v0,) = s["versions"]
    assert v0["version"] == 0 and v0["label"] == "base" and v0["added"] is None
    assert set(v0["errors"]) == {"p_a", "p_b", "x"}
    # the base model misses the leak: percent-level errors
    assert 0.005 < v0["overall"] < 0.05
    assert v0["model"]["jack"] == model()["jack"]
    assert v0["model"]["effects"] == {}


def test_add_version_recomputes_errors(client):
    s = _create(client)
    r = client.post(f"/api/sessions/{s['id']}/versions", json={
        "model": _with_leak(), "added": "piston_leakage", "params": {"conductance": 8e-11},
        "note": "fitted by diagnose"})
    assert r.status_code == 201, r.text[:500]
    s1 = r.json()
    v0, v1 = s1["versions"]
    assert v1["version"] == 1 and v1["label"] == "+ piston_leakage"
    assert v1["added"] == "piston_leakage" and v1["params"] == {"conductance": 8e-11}
    assert v1["note"] == "fitted by diagnose"
    assert v1["model"]["effects"] == {"piston_leakage": {"conductance": 8e-11}}
    # with the hidden leak in the model the error drops by an order of magnitude
    assert v1["overall"] < v0["overall"] / 5
    for k in ("p_a", "p_b"):
        assert v1["errors"][k] < v0["errors"][k]
    # the errors are those /api/compare gives for the same model and experiments
    ref = client.post("/api/compare", json={"model": _with_leak(), "experiments": LEAK}).json()
    assert v1["overall"] == pytest.approx(ref["overall"], rel=1e-12)  # same computation
    r = client.post(f"/api/sessions/{s['id']}/versions", json={"model": _with_leak(9e-11)})
    v2 = r.json()["versions"][2]
    assert v2["version"] == 2 and v2["label"] == "version 2" and v2["added"] is None


def test_get_and_list(client):
    a = _create(client, name="a")
    b = _create(client, name="b")
    client.post(f"/api/sessions/{a['id']}/versions", json={"model": _with_leak(), "added": "piston_leakage"})
    got = client.get(f"/api/sessions/{a['id']}")
    assert got.status_code == 200
    assert [v["label"] for v in got.json()["versions"]] == ["base", "+ piston_leakage"]
    lst = client.get("/api/sessions").json()
    assert [(x["id"], x["name"], x["n_versions"]) for x in lst] == [(a["id"], "a", 2), (b["id"], "b", 1)]


def test_session_without_experiments(client):
    r = client.post("/api/sessions", json={"model": model()})
    assert r.status_code == 201
    s = r.json()
    assert s["name"] == "session" and s["experiments"] == []
    assert s["versions"][0]["errors"] == {} and s["versions"][0]["overall"] is None
    r = client.post(f"/api/sessions/{s['id']}/versions", json={"model": _with_leak()})
    assert r.status_code == 201 and r.json()["versions"][1]["overall"] is None


def test_session_with_inline_experiment(client):
    e = inline_experiment("piston-leak", "locked-hold", [("p_a", 3)])
    s = _create(client, experiments=[e])
    assert s["versions"][0]["overall"] > 0
    r = client.post(f"/api/sessions/{s['id']}/versions", json={"model": _with_leak()})
    assert r.status_code == 201
    v0, v1 = r.json()["versions"]
    assert v1["overall"] < v0["overall"]


def test_delete_then_404(client):
    s = _create(client)
    r = client.delete(f"/api/sessions/{s['id']}")
    assert r.status_code == 204 and r.content == b""
    assert client.get(f"/api/sessions/{s['id']}").status_code == 404
    assert client.delete(f"/api/sessions/{s['id']}").status_code == 404
    assert client.post(f"/api/sessions/{s['id']}/versions", json={"model": model()}).status_code == 404
    assert s["id"] not in [x["id"] for x in client.get("/api/sessions").json()]


def test_unknown_session_404(client):
    for r in (client.get("/api/sessions/nope"), client.delete("/api/sessions/nope"),
              client.post("/api/sessions/nope/versions", json={"model": model()})):
        assert r.status_code == 404 and "nope" in r.json()["detail"]


def test_invalid_create_stores_nothing(client):
    n0 = len(client.get("/api/sessions").json())
    assert_field_error(client.post("/api/sessions", json={"model": model(**{"jack.rod_a": 0.04}),
                                                          "experiments": LEAK}), "model.jack.rod_a")
    assert_field_error(client.post("/api/sessions", json={"model": model(), "experiments": [
        {"dataset_id": "nope"}]}), "experiments[0].dataset_id")
    r = client.post("/api/sessions", json={"experiments": LEAK})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "model"
    assert len(client.get("/api/sessions").json()) == n0


def test_invalid_version_changes_nothing(client):
    s = _create(client)
    assert_field_error(client.post(f"/api/sessions/{s['id']}/versions",
                                   json={"model": model(**{"jack.rod_a": 0.04})}), "model.jack.rod_a")
    r = client.post(f"/api/sessions/{s['id']}/versions", json={"model": model(), "colour": 1})
    assert r.status_code == 422
    assert len(client.get(f"/api/sessions/{s['id']}").json()["versions"]) == 1


def test_version_after_its_dataset_was_deleted(client):
    mine = client.post("/api/datasets", files={"file": ("leak.csv", sample_csv_text("piston-leak", "free-pulses"),
                                                        "text/csv")}).json()["id"]
    s = _create(client, experiments=[{"dataset_id": LEAK_IDS[0]}, {"dataset_id": mine}])
    assert client.delete(f"/api/datasets/{mine}").status_code == 204
    r = client.post(f"/api/sessions/{s['id']}/versions", json={"model": _with_leak()})
    assert_field_error(r, "experiments[1].dataset_id")
    assert client.get(f"/api/sessions/{s['id']}").status_code == 200


def test_sessions_survive_restart(db_path):
    with api(db_path) as c:
        s = _create(c)
        c.post(f"/api/sessions/{s['id']}/versions", json={"model": _with_leak(), "added": "piston_leakage"})
        before = c.get(f"/api/sessions/{s['id']}").json()
    with api(db_path) as c:
        assert c.get(f"/api/sessions/{s['id']}").json() == before
        r = c.post(f"/api/sessions/{s['id']}/versions", json={"model": _with_leak(7e-11)})
        assert [v["version"] for v in r.json()["versions"]] == [0, 1, 2]


def test_the_session_goes_on_across_a_change_of_its_data(client):
    """Issue 24: one session across dataset changes. A version may bring the session's new set
    of experiments; its errors are computed on them, each version records its set, and the
    versions after it stay on the new set."""
    s = _create(client)
    one = [{"dataset_id": LEAK_IDS[0]}]
    r = client.post(f"/api/sessions/{s['id']}/versions", json={"model": model(), "experiments": one,
                                                               "note": "experiments changed"})
    assert r.status_code == 201, r.text[:300]
    s1 = r.json()
    assert s1["id"] == s["id"] and s1["experiments"] == one
    v0, v1 = s1["versions"]
    assert v0["experiments"] == LEAK and v1["experiments"] == one
    ref = client.post("/api/compare", json={"model": model(), "experiments": one}).json()
    assert v1["overall"] == pytest.approx(ref["overall"], rel=1e-12)   # same computation
    assert set(v1["errors"]) == set(ref["errors"])
    v2 = client.post(f"/api/sessions/{s['id']}/versions", json={"model": _with_leak()}).json()["versions"][2]
    assert v2["experiments"] == one


def test_a_bad_new_set_of_experiments_changes_nothing(client):
    s = _create(client)
    r = client.post(f"/api/sessions/{s['id']}/versions",
                    json={"model": model(), "experiments": [{"dataset_id": "nope"}]})
    assert_field_error(r, "experiments[0].dataset_id")
    after = client.get(f"/api/sessions/{s['id']}").json()
    assert after["experiments"] == LEAK and len(after["versions"]) == 1


def test_a_database_from_before_versions_recorded_their_experiments_opens(db_path):
    """The versions table of an older database lacks the experiments column: it is added on
    opening; old versions read experiments null, new ones record theirs."""
    import sqlite3
    db = sqlite3.connect(db_path)
    db.executescript("""
        CREATE TABLE sessions (id TEXT PRIMARY KEY, name TEXT NOT NULL, created REAL NOT NULL,
                               experiments TEXT NOT NULL);
        CREATE TABLE versions (session TEXT NOT NULL, version INTEGER NOT NULL, label TEXT NOT NULL,
            created REAL NOT NULL, model TEXT NOT NULL, errors TEXT NOT NULL, overall REAL, added TEXT,
            params TEXT NOT NULL, note TEXT NOT NULL DEFAULT '', PRIMARY KEY (session, version));""")
    import json
    db.execute("INSERT INTO sessions VALUES ('old1', 'old', 0, ?)", (json.dumps(LEAK),))
    db.execute("INSERT INTO versions VALUES ('old1', 0, 'base', 0, ?, '{}', NULL, NULL, '{}', '')",
               (json.dumps(model()),))
    db.commit()
    db.close()
    with api(db_path) as c:
        s = c.get("/api/sessions/old1").json()
        assert s["versions"][0]["experiments"] is None
        r = c.post("/api/sessions/old1/versions", json={"model": _with_leak()})
        assert r.status_code == 201, r.text[:300]
        assert r.json()["versions"][1]["experiments"] == LEAK
