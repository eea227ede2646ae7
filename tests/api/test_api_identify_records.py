"""POST /api/identify/friction/records (issue 29): friction-bench files as the rig writes them
(no header, ms, raw volts beside engineering units, no p_b column, the logger's time jump) read
by the CLI's reader into records that POST /api/identify/friction takes as they are; hostile
files refused with a 422 naming the file, line and column (or 413 beyond the body limit).

Synthetic rig files (always run) are written from a known law (Eq. 17, the model's friction
functions, 0.2 N load-cell noise: tests/api/test_api_identify.py's generator). The real rig's
files (``shared/data/friction-bench``, E. Zillen, TU Delft 2021, CC0) are skipped when shared/
is not beside the checkout: through the API and through ``pneucore identify friction`` the
identified coefficients must be the same floats.
"""
import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from api_conftest import api, client, db_path  # noqa: E402,F401
from test_api_identify import _record  # noqa: E402

from pneucore import model_preset  # noqa: E402
from pneucore.cli import main as cli_main  # noqa: E402
from pneucore.identify import identify_friction, read_bench_file  # noqa: E402
from pneucore.physics.gas import P_ATM  # noqa: E402
from pneucore.description.model import Model  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "friction-bench"
URL = "/api/identify/friction/records"


@pytest.fixture(scope="module")
def truth():
    d = model_preset("paper-4way")
    d["effects"] = {}
    d["friction"] = {"extend": {"fc0": 10.0, "fc_a": 2e-5, "kv0": 100.0, "kv_a": 1e-4},
                     "retract": {"fc0": 15.0, "fc_a": 1e-5, "kv0": 200.0, "kv_a": 0.0}}
    return Model.from_dict(d)


def _rig_text(rec):
    """A record as the TU Delft rig writes it: t [ms], three voltages, position [mm] growing
    as the piston moves into chamber A (-x), pressure [bar gauge], force [N]; whitespace, no
    header, the logger's 270 ms start after the first row."""
    t = np.asarray(rec["t"]) * 1e3
    t[1:] += 270.0
    rows = []
    for k in range(len(t)):
        pos = -1e3 * rec["x"][k]
        bar = (rec["p_a"][k] - P_ATM) / 1e5
        rows.append(f"{t[k]:.3f}\t{0.1 * pos:.4f}\t{0.5 * bar:.4f}\t{0.01 * rec['F'][k]:.5f}\t"
                    f"{pos!r}\t{bar!r}\t{rec['F'][k]!r}")
    return "\n".join(rows) + "\n"


def _files(*texts):
    return [("file", (f"rig {k + 1}.txt", t.encode(), "text/plain")) for k, t in enumerate(texts)]


def test_rig_files_as_they_come_become_records_the_friction_route_takes(client, truth):
    start = truth.to_dict()
    start["friction"] = {"extend": {}, "retract": {}}      # the preset's defaults
    recs = [_record(truth, p, i) for i, p in enumerate((1, 3, 7))]
    texts = [_rig_text(r) for r in recs]
    r = client.post(URL, files=_files(*texts))
    assert r.status_code == 200, r.text[:800]
    out = r.json()
    assert [f["name"] for f in out["files"]] == ["rig 1", "rig 2", "rig 3"]
    assert [f["samples"] for f in out["files"]] == [2000] * 3
    assert any("no p_b column: chamber B is taken at ambient" in w for w in out["warnings"])
    assert out["columns"] == ["t[ms]", None, None, None, "-x[mm]", "p_a[bar(g)]", "F[N]"]
    # the one reader: the answer's records are read_bench_file's floats, the rig's time jump kept
    for text, got in zip(texts, out["records"]):
        ref = read_bench_file(text.encode(), name=got["name"])
        for key in ("t", "x", "p_a", "p_b", "F"):
            assert got[key] == getattr(ref, key).tolist(), key
        # 10 ms + the 270 ms start; 1e-9 s: the text holds ms to 3 decimals, read back / 1e3
        assert got["t"][1] - got["t"][0] == pytest.approx(0.28, abs=1e-9)
        assert set(got["p_b"]) == {P_ATM}
    fit = client.post("/api/identify/friction", json={"model": start, "experiments": out["records"][:2],
                                                      "validate": out["records"][2:]})
    assert fit.status_code == 200, fit.text[:800]
    ans = fit.json()
    # the Coulomb levels to 5 % (0.2 N noise on 4000 samples; test_api_identify's bound)
    assert ans["model"]["friction"]["extend"]["fc0"] == pytest.approx(10.0, rel=0.05)
    assert ans["model"]["friction"]["retract"]["fc0"] == pytest.approx(15.0, rel=0.05)
    # chamber B at ambient: its coefficients not determined, held at the model's value, said why
    for side in ("extend", "retract"):
        for key in ("fc_b", "kv_b"):
            p = ans["parameters"][f"friction.{side}.{key}"]
            assert p["identified"] is False and p["status"] == "not determined", p
            assert "is not identifiable" in p["reason"] and p["se"] is None
    # the same numbers as the Python call on the same files
    direct = identify_friction(Model.from_dict(start), [read_bench_file(t.encode()) for t in texts[:2]])
    for name, p in direct.parameters.items():
        assert ans["parameters"][name]["value"] == p["value"], name
    # predicted at 7 bar within a few times the 0.2 N noise (the position is written to 1e-3 um)
    assert ans["validation"][0]["rms"] < 0.5


def test_a_declared_layout_with_p_b_and_other_units(client, truth):
    rec = _record(truth, 3, 4)
    lines = [f"{t!r},{1e3 * x!r},{pa / 1e3!r},{(pb - P_ATM + 2e5) / 1e5!r},{F / 1e3!r}"
             for t, x, pa, pb, F in zip(rec["t"], rec["x"], rec["p_a"], rec["p_b"], rec["F"])]
    r = client.post(URL, files=_files("\n".join(lines)),
                    data={"columns": "t[s], x[mm], p_a[kPa], p_b[bar(g)], F[kN]", "ambient_pressure": str(P_ATM)})
    assert r.status_code == 200, r.text[:800]
    out = r.json()
    assert not any("p_b" in w for w in out["warnings"])
    got = out["records"][0]
    # unit conversions round once: 1e-12 relative
    assert got["x"] == pytest.approx(rec["x"], rel=1e-12, abs=1e-15)
    assert got["p_b"] == pytest.approx([P_ATM + 2e5] * 2000, rel=1e-12)
    assert got["F"] == pytest.approx(rec["F"], rel=1e-12)
    # the same as a JSON list, and one file as a raw text/plain body
    lst = client.post(URL, files=_files("\n".join(lines)),
                      data={"columns": json.dumps(["t[s]", "x[mm]", "p_a[kPa]", "p_b[bar(g)]", "F[kN]"])})
    assert lst.json()["records"][0]["p_b"] == got["p_b"]
    raw = client.post(URL + "?columns=t[s],x[mm],p_a[kPa],p_b[bar(g)],F[kN]&filename=one",
                      content="\n".join(lines).encode(), headers={"content-type": "text/plain"})
    assert raw.status_code == 200 and raw.json()["records"][0]["F"] == got["F"]


GOOD = "".join(f"{10 * k} 0 0 0 {k * 0.1} 1.0 50\n" for k in range(40))


@pytest.mark.parametrize("text, form, field, words", [
    (GOOD + "400 0 0 0 4.0 1.0\n", {}, "file[0].line[41]", "6 values, the layout has 7"),
    (GOOD.replace("50\n", "5O\n", 1), {}, "file[0].line[1]", "column 7: '5O' is not a number"),
    (GOOD.replace("1.0 50\n", "nan 50\n", 1), {}, "file[0].line[1]", "not a finite number"),
    (GOOD.replace("1.0 50\n", "1e300 50\n", 1), {}, "file[0].line[1]", "check the column's unit"),
    (GOOD + "0 0 0 0 4.0 1.0 50\n", {}, "file[0].line[41]", "sample times must increase"),
    (GOOD.replace("1.0 50\n", "-2 50\n", 1), {}, "file[0].line[1]", "absolute pressures must be > 0"),
    (GOOD[:200], {}, "file[0]", "at least 30 are needed"),
    ("\x00\x01" * 100, {}, "file[0]", "not a text file"),
    (GOOD, {"columns": "t[ms],x[furlong],p_a,F"}, "columns[1]", "unknown unit"),
    (GOOD, {"columns": "t,x,-p_a,F"}, "columns[2]", "only x and F can be negated"),
    (GOOD, {"columns": "t,x,p_a,x,F"}, "columns[3]", "x is already column 2"),
    (GOOD, {"columns": "t,x,p_a,u"}, "columns[3]", "a friction-bench file holds"),
    (GOOD, {"columns": "t,x,p_a"}, "columns", "no column holds F"),
    (GOOD, {"columns": "[1, 2"}, "columns", "is not a JSON list"),
    (GOOD, {"ambient_pressure": "-5"}, "ambient_pressure", "positive"),
    (GOOD, {"ambient_pressure": "1e300"}, "ambient_pressure", "absolute pressure in"),
])
def test_malformed_files_are_422_naming_the_file_line_and_column(client, text, form, field, words):
    r = client.post(URL, files=_files(text), data=form)
    assert r.status_code == 422, r.text[:500]
    d = r.json()["detail"][0]
    assert d["field"] == field and words in d["msg"], d


def test_the_second_file_is_named_and_nothing_is_half_answered(client):
    r = client.post(URL, files=_files(GOOD, GOOD.replace(" 50\n", " x\n", 1)))
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "file[1].line[1]"


def test_size_and_count_limits(db_path):  # noqa: F811
    from app.schemas_identify import MAX_FRICTION_RECORDS, MAX_RECORD_SAMPLES
    with api(db_path, max_upload_bytes=64 * 1024, max_request_memory=200_000) as c:
        # the body limit while reading: 413
        big = c.post(URL, files=_files("0 0 0 0 0 0 0\n" * 10_000))
        assert big.status_code == 413
        # under the body limit, over the memory budget: refused before decoding (the CSV
        # estimate, 128 bytes a cell: 2000 lines x 7 cells is 1.8 MB)
        mem = c.post(URL, files=_files("".join(f"{k} 0 0 0 0 1 5\n" for k in range(2000))))
        assert mem.status_code == 422 and "max_request_memory" in mem.text
    with api(db_path) as c:
        many = c.post(URL, files=_files(*[GOOD] * (MAX_FRICTION_RECORDS + 1)))
        assert many.status_code == 422 and many.json()["detail"][0]["field"] == "file"
        rows = c.post(URL, files=_files("".join(f"{k} 0 0 0 0 1 5\n" for k in range(MAX_RECORD_SAMPLES + 1))))
        assert rows.status_code == 422 and f"at most {MAX_RECORD_SAMPLES}" in rows.text
        none = c.post(URL, data={"columns": "t,x,p_a,F"}, files={"other": ("a", b"1", "text/plain")})
        assert none.status_code == 422 and none.json()["detail"][0]["field"] == "file"
        text_field = c.post(URL, data={"file": "0 0 0"})
        assert text_field.status_code == 422
        js = c.post(URL, json={"file": GOOD})
        assert js.status_code == 422 and js.json()["detail"][0]["field"] == "file"
        broken = c.post(URL, content=b"--xx\r\nnonsense", headers={"content-type": "multipart/form-data; boundary=xx"})
        assert broken.status_code in (400, 422)


# ---------------------------------------------------------------------------- the real rig
#: Seal -> bore [m] (the data's README: X-ring257 is a 25.7 mm bore)
SEALS = {"O-ring": 0.025, "NAPN": 0.025, "KDN": 0.025, "X-ring257": 0.0257}
real = pytest.mark.skipif(not (DATA / "O-ring_1bar.csv").exists(),
                          reason=f"friction-bench data not found at {DATA} (shared/ beside the checkout)")


def _rig_model(bore):
    d = model_preset("paper-4way")
    d["jack"].update(bore=bore, rod_a=0.0, rod_b=0.008, moving_mass=0.5)   # tests/identify/test_friction_rig.py's
    d["effects"] = {}
    return d


@real
def test_the_real_rig_through_the_api_is_the_cli_to_the_last_bit(client, tmp_path, capsys):
    table = ["| seal | extend fc0 [N] | extend fc_a [N/bar] | retract fc0 [N] | retract fc_a [N/bar] | "
             "kv0 ext / ret [N s/m] | 5 bar ext / ret mean [N] |", "|---|---|---|---|---|---|---|"]
    for seal, bore in SEALS.items():
        paths = [DATA / f"{seal}_{p}bar.csv" for p in (1, 3, 7, 5)]
        up = client.post(URL, files=[("file", (p.name, p.read_bytes(), "text/plain")) for p in paths])
        assert up.status_code == 200, up.text[:500]
        recs = up.json()["records"]
        assert [f["name"] for f in up.json()["files"]] == [p.stem for p in paths]
        ans = client.post("/api/identify/friction", json={"model": _rig_model(bore), "experiments": recs[:3],
                                                          "validate": recs[3:]})
        assert ans.status_code == 200, ans.text[:500]
        api_out = ans.json()
        mfile = tmp_path / f"{seal}.json"
        mfile.write_text(json.dumps(_rig_model(bore)))
        out = tmp_path / f"{seal}-cli.json"
        assert cli_main(["identify", "friction", "--model", str(mfile), "--fit", *map(str, paths[:3]),
                         "--validate", str(paths[3]), "--json", str(out)]) == 0
        cli = json.loads(out.read_text())
        # identical: the same reader, the same fit, floats through JSON as they are
        for name, p in cli["parameters"].items():
            assert api_out["parameters"][name]["value"] == p["value"], (seal, name)
            assert api_out["parameters"][name]["se"] == p["se"], (seal, name)
            assert api_out["parameters"][name]["status"] == p["status"], (seal, name)
        assert api_out["validation"][0]["force"] == cli["validation"][0]["force"]
        assert api_out["linear_in_pressure"] == cli["linear_in_pressure"]
        # chamber B at ambient on this rig: its coefficients not determined
        for side in ("extend", "retract"):
            for key in ("fc_b", "kv_b"):
                assert api_out["parameters"][f"friction.{side}.{key}"]["status"] == "not determined"
        P = api_out["parameters"]
        v = api_out["validation"][0]
        table.append(f"| {seal} | {P['friction.extend.fc0']['value']:.3f} | {1e5 * P['friction.extend.fc_a']['value']:.3f} | "
                     f"{P['friction.retract.fc0']['value']:.3f} | {1e5 * P['friction.retract.fc_a']['value']:.3f} | "
                     f"{P['friction.extend.kv0']['value']:.1f} / {P['friction.retract.kv0']['value']:.1f} | "
                     f"{v['extend']['mean']:+.2f} / {v['retract']['mean']:+.2f} |")
    capsys.readouterr()
    with capsys.disabled():
        print("\nreal rig through POST /api/identify/friction/records + /friction (== the CLI):\n" + "\n".join(table))
