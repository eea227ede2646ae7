"""Where each value came from (issue 29, step by step): a model's ``provenance`` through the API,
bench-identified values held by a later calibration or diagnosis unless ``bench_known`` is
false, and the rig signals F, q, p_s uploaded in a rig's units."""

import pytest

from api_conftest import CLEAN_IDS, LEAK_IDS, api, assert_field_error, client, db_path, model  # noqa: F401

CLEAN = [{"dataset_id": i} for i in CLEAN_IDS]
LEAK = [{"dataset_id": i} for i in LEAK_IDS]
FC0 = "friction.extend.fc0"


def bench_model():
    m = model()
    m["provenance"] = {FC0: {"source": "bench", "stderr": 0.3, "unit": "N",
                             "method": "friction bench (Eq. 17-20)"},
                       "heat.coefficient": {"source": "catalogue", "stderr": None}}
    return m


def _calibrate(client, **extra):
    r = client.post("/api/calibrate", json={
        "model": bench_model(), "experiments": CLEAN[1:],
        "parameters": {FC0: {"min": 0.0, "max": 100.0, "value": 20.0},
                       "jack.moving_mass": {"min": 0.5, "max": 20.0}}, "max_nfev": 8, **extra})
    assert r.status_code == 200, r.text[:800]
    return r.json()


def test_a_bench_friction_value_is_left_alone_by_a_later_calibration(client):
    d = _calibrate(client)
    assert d["bench_held"] == [FC0]
    v = d["values"][FC0]
    # held at the model's (bench) value, not the 20 N starting value the request gave
    assert v["vary"] is False
    assert d["model"]["friction"]["extend"]["fc0"] == bench_model()["friction"]["extend"]["fc0"]
    assert d["values"]["jack.moving_mass"].get("vary", True) is True   # a fitted one has no flag
    # the provenance travels with the fitted model, as given
    assert d["model"]["provenance"] == bench_model()["provenance"]


def test_bench_known_false_fits_it_like_any_other(client):
    d = _calibrate(client, bench_known=False)
    assert d["bench_held"] == [] and d["values"][FC0].get("vary", True) is True


def test_a_diagnosis_holds_a_bench_value_listed_as_uncertain(client):
    r = client.post("/api/diagnose", json={"model": bench_model(), "experiments": LEAK,
                                           "candidates": ["piston_leakage"], "uncertain": [FC0]})
    assert r.status_code == 200, r.text[:800]
    d = r.json()
    assert d["bench_held"] == [FC0] and FC0 in d["known"] and FC0 not in d["uncertain"]


@pytest.mark.parametrize("entry, field", [
    ({"source": "guess"}, "model.provenance.friction.extend.fc0.source"),
    ({"source": "bench", "stderr": -1.0}, "model.provenance.friction.extend.fc0.stderr"),
    ({"source": "bench", "colour": "red"}, "model.provenance.friction.extend.fc0.colour"),
])
def test_a_bad_provenance_entry_is_a_422_naming_its_field(client, entry, field):
    m = model()
    m["provenance"] = {FC0: entry}
    r = client.post("/api/compare", json={"model": m, "experiments": CLEAN[:1]})
    assert_field_error(r, field)


def test_rig_signals_upload_in_rig_units(client):
    # 100 L/min ANR = 0.1 m^3 / 60 s * 1.185 kg/m^3 (RHO_REF) = 1.975e-3 kg/s; 0.2 kN = 200 N;
    # 6 bar(g) at the default ambient 1.013 bar = 7.013e5 Pa abs
    text = "t[s],u[-],x[mm],F[kN],q_s[L/min ANR],p_s[bar(g)]\n" + "".join(
        f"{0.01 * i:.2f},0,{i},0.2,100,6\n" for i in range(20))
    r = client.post("/api/datasets", files={"file": ("rig.csv", text.encode(), "text/csv")})
    assert r.status_code in (200, 201), r.text[:800]
    info = r.json()
    assert {"F", "q_s", "p_s"} <= set(info["signals"])
    meas = client.get(f"/api/datasets/{info['id']}").json()["measurement"]
    # relative 1e-12: one product and quotient in float64, then a JSON round trip
    assert meas["F"][0] == pytest.approx(200.0, rel=1e-12)
    assert meas["q_s"][0] == pytest.approx(1.975e-3, rel=1e-12)
    assert meas["p_s"][0] == pytest.approx(7.013e5, rel=1e-12)
