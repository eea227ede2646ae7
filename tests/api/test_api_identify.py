"""POST /api/identify/valve and /api/identify/friction (issue 29's contract), and their jobs."""
import math
import time

import numpy as np
import pytest

from api_conftest import JOB_WAIT_S, client, db_path  # noqa: F401
from pneucore import model_preset
from pneucore.physics.flow import FLOW_LAWS
from pneucore.physics.friction import coulomb_level, sliding_friction, viscous_coefficient
from pneucore.physics.gas import P_ATM
from pneucore.description.model import Model

DM3_S_BAR = 1e-3 / 1e5     # 1 dm^3/(s bar) in m^3/(s Pa)


def _points(u_c_b=((0.0, 0.0, 0.3), (0.3, 0.4, 0.4), (0.6, 0.8, 0.35), (1.0, 1.2, 0.3))):
    law = FLOW_LAWS["iso6358"]
    return [{"opening": u, "p_up": p, "p_down": r * p, "T_up": 293.15,
             "flow": law(p, 293.15, r * p, 293.15, c * DM3_S_BAR, b)}
            for u, c, b in u_c_b for p in (4e5, 7e5) for r in (0.2, 0.6, 0.8, 0.95)]


def test_valve_contract_and_the_model_written(client):
    model = model_preset("paper-4way")
    r = client.post("/api/identify/valve", json={"edge": "P-A", "points": _points(), "model": model})
    assert r.status_code == 200, r.text[:500]
    out = r.json()
    assert out["edge"]["opening"] == [0.0, 0.3, 0.6, 1.0]
    # exact points: C back in the model's unit to 1e-6 (the fit's tolerance), b to 1e-6
    assert out["edge"]["C"][1:] == pytest.approx([0.4 * DM3_S_BAR, 0.8 * DM3_S_BAR, 1.2 * DM3_S_BAR], rel=1e-6)
    assert out["edge"]["b"][1:] == pytest.approx([0.4, 0.35, 0.3], abs=1e-6)
    assert out["closed"] == [True, False, False, False] and out["null_band"]["high"] == 0.0
    assert len(out["points"]) == len(_points()) and "residual" in out["points"][0]
    assert len(out["C_se"]) == 4
    # the model with the table written in is accepted by the other routes as it is
    assert out["model"]["valve"]["ports"]["P-A"]["C"] == out["edge"]["C"]
    sim = client.post("/api/simulate", json={"model": out["model"],
                                             "scenario": {"duration": 0.05, "command": [[0, 0.5]]},
                                             "series": ["x"]})
    assert sim.status_code == 200, sim.text[:500]


def test_a_fixed_orifice_gives_one_C_and_b(client):
    pts = [{k: v for k, v in p.items() if k != "opening"} for p in _points(((None, 2.0, 0.3),))]
    out = client.post("/api/identify/valve", json={"points": pts}).json()
    assert out["fixed_orifice"] and len(out["edge"]["C"]) == 1 and len(out["edge"]["b"]) == 1
    assert out["edge"]["C"][0] == pytest.approx(2 * DM3_S_BAR, rel=1e-6)
    assert out["table"]["C"] == [out["edge"]["C"][0]] * 2   # the model's form: held over the range


@pytest.mark.parametrize("change, field", [
    ({"p_down": 9e5}, "points[0].p_down"),
    ({"flow": -1e-4}, "points[0].flow"),
    ({"opening": 2.0}, "points[0].opening"),
])
def test_valve_bad_points_are_422_naming_the_field(client, change, field):
    pts = _points()
    pts[0].update(change)
    r = client.post("/api/identify/valve", json={"edge": "P-A", "points": pts})
    assert r.status_code == 422
    assert r.json()["detail"][0]["field"] == field, r.json()


def test_valve_too_few_points_says_which(client):
    r = client.post("/api/identify/valve", json={"edge": "P-A", "points": _points()[8:9]})  # one point at 0.3
    assert r.status_code == 422 and "C and b" in r.json()["detail"][0]["msg"]
    r = client.post("/api/identify/valve", json={"edge": "Z-Q", "points": _points()})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "edge"


def _record(model, p_a_g, seed, n=2000, fs=100.0):
    """A bench record from a known law (Eq. 17, the model's friction functions), 0.2 N noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    w = 2 * math.pi * 0.25
    x = 0.02 * np.sin(w * t) + 0.005 * np.sin(2.7 * w * t)
    v = 0.02 * w * np.cos(w * t) + 0.005 * 2.7 * w * np.cos(2.7 * w * t)
    a = -0.02 * w * w * np.sin(w * t) - 0.005 * (2.7 * w) ** 2 * np.sin(2.7 * w * t)
    p_a = np.full(n, P_ATM + p_a_g * 1e5)
    p_b = np.full(n, P_ATM)
    j = model.jack
    F_p = p_a * j.area_a - p_b * j.area_b + P_ATM * (j.rod_area_a - j.rod_area_b)
    Ff = []
    for i in range(n):
        s = model.friction.extend if v[i] > 0 else model.friction.retract
        fc = coulomb_level(s.fc0, s.fc_a, s.fc_b, p_a[i], p_b[i], P_ATM)
        kv = viscous_coefficient(s.kv0, s.kv_a, s.kv_b, p_a[i], p_b[i], P_ATM)
        Ff.append(sliding_friction(v[i], 1.0 if v[i] > 0 else -1.0, fc, kv, 1.0, 0.01))
    F = F_p - np.array(Ff) - j.moving_mass * a + rng.normal(0, 0.2, n)
    return {"name": f"{p_a_g:g} bar", "t": t.tolist(), "x": x.tolist(), "p_a": p_a.tolist(),
            "p_b": p_b.tolist(), "F": F.tolist()}


@pytest.fixture(scope="module")
def truth():
    d = model_preset("paper-4way")
    d["effects"] = {}
    d["friction"] = {"extend": {"fc0": 10.0, "fc_a": 2e-5, "kv0": 100.0, "kv_a": 1e-4},
                     "retract": {"fc0": 15.0, "fc_a": 1e-5, "kv0": 200.0, "kv_a": 0.0}}
    return Model.from_dict(d)


def test_friction_contract_identified_model_and_validation(client, truth):
    start = truth.to_dict()
    start["friction"] = {"extend": {}, "retract": {}}      # the preset's defaults
    body = {"model": start, "experiments": [_record(truth, p, i) for i, p in enumerate((1, 3, 7))],
            "validate": [_record(truth, 5, 9), _record(truth, 2, 8)]}
    body["experiments"][0]["u"] = [0.0] * 2000     # a measurement's other signals: not used
    r = client.post("/api/identify/friction", json=body)
    assert r.status_code == 200, r.text[:800]
    out = r.json()
    ext = out["model"]["friction"]["extend"]
    # the Coulomb levels to 5 % (0.2 N noise on 6000 samples; see tests/identify for the
    # recovery within standard errors)
    assert ext["fc0"] == pytest.approx(10.0, rel=0.05)
    assert out["model"]["friction"]["retract"]["fc0"] == pytest.approx(15.0, rel=0.05)
    assert out["parameters"]["friction.extend.fc_b"]["identified"] is False   # B ambient throughout
    assert [v["name"] for v in out["validation"]] == ["5 bar", "2 bar"]
    for v in out["validation"]:
        assert len(v["force"]) == 2000
        # predicted to about the noise (0.2 N): under 0.5 N rms, per direction too
        assert v["rms"] < 0.5 and v["extend"]["rms"] < 0.5 and v["retract"]["rms"] < 0.5
    # the identified model is accepted as it is by the other routes
    sim = client.post("/api/simulate", json={"model": out["model"],
                                             "scenario": {"duration": 0.05, "command": [[0, 0.5]]},
                                             "series": ["x"]})
    assert sim.status_code == 200, sim.text[:500]


def test_friction_record_without_F_is_422_naming_it(client, truth):
    rec = _record(truth, 3, 1)
    del rec["F"]
    r = client.post("/api/identify/friction", json={"model": truth.to_dict(), "experiments": [rec]})
    assert r.status_code == 422
    assert r.json()["detail"][0]["field"] == "experiments[0].F", r.json()
    nested = {"name": "n", "measurement": {k: v for k, v in _record(truth, 3, 1).items() if k not in ("name", "F")}}
    r = client.post("/api/identify/friction", json={"model": truth.to_dict(), "experiments": [nested]})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "experiments[0].measurement.F"


def test_friction_too_few_points_says_which(client, truth):
    rec = _record(truth, 3, 1, n=300)
    # the first 3 s move one way only (a quarter period of the slow sinusoid, 1 s at 100 Hz)
    rec = {k: (v[:100] if isinstance(v, list) else v) for k, v in rec.items()}
    r = client.post("/api/identify/friction", json={"model": truth.to_dict(), "experiments": [rec]})
    assert r.status_code == 422
    assert "too few points to identify friction." in r.json()["detail"][0]["msg"]


def test_both_as_jobs_with_progress(client, truth):
    r = client.post("/api/jobs/identify/valve", json={"edge": "P-A", "points": _points()})
    assert r.status_code == 202
    body = {"model": truth.to_dict(), "experiments": [_record(truth, p, i) for i, p in enumerate((1, 4))],
            "validate": [_record(truth, 2, 5)]}
    f = client.post("/api/jobs/identify/friction", json=body)
    assert f.status_code == 202
    for jid, key in ((r.json()["id"], "edge"), (f.json()["id"], "validation")):
        deadline = time.monotonic() + JOB_WAIT_S
        while True:
            job = client.get(f"/api/jobs/{jid}").json()
            if job["status"] in ("done", "error") or time.monotonic() > deadline:
                break
            time.sleep(0.1)
        assert job["status"] == "done", job
        assert job["progress"] == 1.0 and key in job["result"]
    # bad input is refused now, not as a failed job
    bad = client.post("/api/jobs/identify/valve", json={"edge": "P-A", "points": [{**_points()[0], "flow": -1.0}]})
    assert bad.status_code == 422


def test_friction_records_uploaded_as_datasets_with_F_in_kN(client, truth):
    """Issue 29: a friction-bench file (no command, the load cell in kN, pressures in bar(g))
    is uploaded as a dataset and identified by its id, as the same records sent inline are."""
    start = truth.to_dict()
    start["friction"] = {"extend": {}, "retract": {}}
    recs = [_record(truth, p, i) for i, p in enumerate((1, 3, 7))]
    ids = []
    for rec in recs:
        # 17 significant digits: the text holds the float; kN -> N and bar(g) -> Pa abs round once
        rows = [f"{t!r},{x!r},{(pa - P_ATM) / 1e5!r},{(pb - P_ATM) / 1e5!r},{F / 1e3!r}"
                for t, x, pa, pb, F in zip(rec["t"], rec["x"], rec["p_a"], rec["p_b"], rec["F"])]
        text = "t[s],x[m],p_a[bar(g)],p_b[bar(g)],F[kN]\n" + "\n".join(rows)
        up = client.post(f"/api/datasets?ambient_pressure={P_ATM}",
                         files={"file": (f"bench {rec['name']}.csv", text.encode(), "text/csv")})
        assert up.status_code in (200, 201), up.text[:500]
        ids.append(up.json()["id"])
    by_id = client.post("/api/identify/friction", json={
        "model": start, "experiments": [{"dataset_id": i} for i in ids]})
    inline = client.post("/api/identify/friction", json={"model": start, "experiments": recs})
    assert by_id.status_code == 200, by_id.text[:800]
    a, b = by_id.json()["parameters"], inline.json()["parameters"]
    for path in ("friction.extend.fc0", "friction.retract.fc0", "friction.extend.kv0"):
        # the unit round trips differ from the inline floats by ~1e-16 relative: a 1e-9 match
        assert a[path]["value"] == pytest.approx(b[path]["value"], rel=1e-9), path
    # and the model records the bench
    assert by_id.json()["model"]["provenance"]["friction.extend.fc0"]["source"] == "bench"
    bad = client.post("/api/identify/friction", json={"model": start,
                                                      "experiments": [{"dataset_id": "nope"}]})
    assert bad.status_code == 422 and "experiments[0].dataset_id" in bad.text
