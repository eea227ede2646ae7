"""The friction bench (paper section 2.3, Eq. 17-20) on records synthesised from known laws.

Each record is a prescribed motion (two sinusoids: every speed from reversal to the peak)
at held chamber pressures; the rod force follows Eq. 17 with the model's friction law
(:mod:`pneucore.physics.friction`), a load-cell offset where said, and white noise on the
force (0.3 N, a good load cell's) and on the position (1 um, an encoder's count). The
identification sees only t, x, p_a, p_b and F.
"""
import math

import numpy as np
import pytest

from pneucore import model_preset
from pneucore.identify import identify_friction, predict_rod_force
from pneucore.identify.friction_bench import FrictionRecord, kinematics
from pneucore.physics.friction import coulomb_level, sliding_friction, viscous_coefficient
from pneucore.physics.gas import P_ATM
from pneucore.description.model import Model
from pneucore.description.validation import FieldError

#: The true law: quadrant and pressure dependent, as the paper's Fig. 4 jack
TRUE = {"extend": {"fc0": 12.0, "fc_a": 2.0e-5, "fc_b": 1.0e-5, "kv0": 150.0, "kv_a": 1.0e-4, "kv_b": 0.0},
        "retract": {"fc0": 18.0, "fc_a": 1.0e-5, "fc_b": 3.0e-5, "kv0": 250.0, "kv_a": 0.0, "kv_b": 2.0e-4}}
#: Held gauge pressures of the records (A, B) [bar]: both chambers vary, independently
LEVELS = [(1.0, 0.0), (3.0, 1.0), (6.0, 2.0), (2.0, 5.0), (0.5, 6.0)]


def _model(**friction):
    d = model_preset("paper-4way")
    d["effects"] = {}
    d["friction"] = friction or {"extend": {}, "retract": {}}
    return Model.from_dict(d)


def synth(model, law, p_a_g, p_b_g, seed, *, offset=0.0, stribeck=(1.0, 0.01), duration=20.0,
          amp=0.02, freq=0.3, second=0.3, noise_F=0.3, noise_x=1e-6, fs=100.0):
    """A bench record: Eq. 17 with ``law`` (per-direction coefficient dicts)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 1.0 / fs)
    w1, w2 = 2 * math.pi * freq, 2 * math.pi * 2.7 * freq
    x = amp * np.sin(w1 * t) + second * amp * np.sin(w2 * t)
    v = amp * w1 * np.cos(w1 * t) + second * amp * w2 * np.cos(w2 * t)
    a = -amp * w1 ** 2 * np.sin(w1 * t) - second * amp * w2 ** 2 * np.sin(w2 * t)
    p_a = P_ATM + p_a_g * 1e5 + rng.normal(0, 200.0, t.size)     # a regulator's wander
    p_b = P_ATM + p_b_g * 1e5 + rng.normal(0, 200.0, t.size)
    j = model.jack
    F_p = p_a * j.area_a - p_b * j.area_b + P_ATM * (j.rod_area_a - j.rod_area_b)
    Ff = np.zeros_like(t)
    for i in range(t.size):
        side = law["extend"] if v[i] > 0 else law["retract"]
        fc = coulomb_level(side["fc0"], side["fc_a"], side["fc_b"], p_a[i], p_b[i], P_ATM)
        kv = viscous_coefficient(side["kv0"], side["kv_a"], side["kv_b"], p_a[i], p_b[i], P_ATM)
        Ff[i] = sliding_friction(v[i], 1.0 if v[i] > 0 else -1.0, fc, kv, *stribeck)
    F = F_p - Ff - j.moving_mass * a + offset + rng.normal(0, noise_F, t.size)
    x = x + rng.normal(0, noise_x, t.size)
    return FrictionRecord(t, x, p_a, p_b, F, f"{p_a_g:g}/{p_b_g:g} bar")


def test_kinematics_of_a_sinusoid():
    # the acausal filter has no lag: a 0.3 Hz sinusoid's velocity within 0.5 % of its peak
    # (a cubic over 0.15 s is exact to third order, its error on the sinusoid is of order
    # (omega T)^4 / 1000, 1e-5; a lagging filter would be off by omega x lag, 2 % per 10 ms)
    w = 2 * math.pi * 0.3
    t = np.arange(0, 10, 0.01)
    x = 0.02 * np.sin(w * t)
    v, a, valid = kinematics(t, x)
    peak = 0.02 * w
    assert np.max(np.abs(v - peak * np.cos(w * t))[valid]) < 5e-3 * peak
    assert not valid[0] and not valid[-1] and valid[len(t) // 2]


def test_kinematics_splits_at_a_time_jump():
    # a logger's start (270 ms after the first row) is not differentiated across
    t = np.concatenate([[0.0], 0.27 + np.arange(0, 5, 0.01)])
    x = 0.01 * t
    v, a, valid = kinematics(t, x)
    assert not valid[0]
    assert np.allclose(v[valid], 0.01, rtol=1e-6)


@pytest.fixture(scope="module")
def quadrant_fit():
    model = _model()
    recs = [synth(model, TRUE, pa, pb, seed) for seed, (pa, pb) in enumerate(LEVELS)]
    return model, recs, identify_friction(model, recs, stribeck=False)


def test_quadrant_pressure_law_is_recovered_within_its_standard_errors(quadrant_fit):
    model, recs, r = quadrant_fit
    for side, coeffs in TRUE.items():
        for key, true in coeffs.items():
            p = r.parameters[f"friction.{side}.{key}"]
            assert p["identified"], (side, key, p)
            # 4 standard errors: a fixed seed, and the errors are the fit's own (inflated by
            # the residuals' autocorrelation): a wrong regressor or sign misses by far more
            assert abs(p["value"] - true) < 4 * p["se"], (side, key, p, true)
    # and the standard errors are small enough for that to mean something: the Coulomb
    # levels to 3 % (0.3 N of noise over ~8000 sliding samples)
    for side in TRUE:
        assert r.parameters[f"friction.{side}.fc0"]["se"] < 0.03 * TRUE[side]["fc0"]
    assert r.linear_in_pressure is True
    # the model carries the identified law and is valid as it is
    assert Model.from_dict(r.model.to_dict()).friction.retract.kv0 == pytest.approx(
        r.parameters["friction.retract.kv0"]["value"])


def test_validation_on_a_record_not_fitted(quadrant_fit):
    model, recs, r = quadrant_fit
    new = synth(model, TRUE, 4.0, 3.0, 99)
    pred = predict_rod_force(r.model, new, v_min=r.v_min)
    # the noise is 0.3 N: a law recovered within its errors predicts the force to about that
    assert pred["rms"] < 0.6
    assert abs(pred["extend"]["mean"]) < 0.2 and abs(pred["retract"]["mean"]) < 0.2
    assert len(pred["force"]) == len(new.t)


def test_offset_beside_quadrant_friction_is_not_identified_and_said_so(quadrant_fit):
    model, recs, _ = quadrant_fit
    r = identify_friction(model, recs, extras=["offset"], stribeck=False)
    p = r.parameters["offset"]
    assert p["identified"] is False and "not separable" in p["reason"]
    assert any("offset" in w for w in r.warnings)


def test_offset_and_symmetric_friction_are_recovered():
    law = {"extend": TRUE["extend"], "retract": TRUE["extend"]}
    model = _model()
    recs = [synth(model, law, pa, pb, 10 + seed, offset=4.0) for seed, (pa, pb) in enumerate(LEVELS)]
    r = identify_friction(model, recs, extras=["offset"], quadrant=False, stribeck=False)
    off = r.parameters["offset"]
    assert off["identified"]
    # within 4 standard errors (as above), and known to 0.3 N
    assert abs(off["value"] - 4.0) < 4 * off["se"] and off["se"] < 0.3
    assert abs(r.parameters["friction.extend.fc0"]["value"] - 12.0) < 4 * r.parameters["friction.extend.fc0"]["se"]
    assert r.model.friction.retract.to_dict() == r.model.friction.extend.to_dict()


def test_stribeck_is_found_where_the_data_show_it_and_only_there():
    law = {"extend": dict(TRUE["extend"], fc_a=0.0, fc_b=0.0, kv_a=0.0),
           "retract": dict(TRUE["retract"], fc_a=0.0, fc_b=0.0, kv_b=0.0)}
    model = _model()
    levels = LEVELS[:3]
    recs = [synth(model, law, pa, pb, 20 + s, stribeck=(2.0, 0.008)) for s, (pa, pb) in enumerate(levels)]
    r = identify_friction(model, recs, v_min=0.002)
    assert r.stribeck["kept"] and r.stribeck["shown_by_data"]
    ratio = r.parameters["effects.stribeck_friction.static_ratio"]
    v_s = r.parameters["effects.stribeck_friction.stribeck_velocity"]
    # within 4 standard errors, and the ratio to 10 %
    assert abs(ratio["value"] - 2.0) < max(4 * ratio["se"], 1e-9) and abs(ratio["value"] - 2.0) < 0.2
    assert abs(v_s["value"] - 0.008) < 4 * v_s["se"]
    assert r.model.effects["stribeck_friction"]["static_ratio"] == pytest.approx(ratio["value"])
    # the same records without the breakaway term: not added
    plain = [synth(model, law, pa, pb, 20 + s) for s, (pa, pb) in enumerate(levels)]
    r0 = identify_friction(model, plain, v_min=0.002)
    assert not r0.stribeck["kept"]
    assert "stribeck_friction" not in r0.model.effects


def test_moving_mass_from_the_accelerations():
    model = _model()
    # faster motion: 1.5 Hz, 20 mm, accelerations to 1.8 m/s^2, 3.6 N of inertia on 2 kg;
    # the differentiating window shortened to 60 ms to pass the acceleration whole (the
    # default 150 ms cubic takes several per cent off a 1.5 Hz acceleration)
    recs = [synth(model, TRUE, pa, pb, 30 + s, freq=1.5, second=0.0) for s, (pa, pb) in enumerate(LEVELS)]
    r = identify_friction(model, recs, extras=["mass"], stribeck=False, window=0.06)
    m = r.parameters["mass"]
    # to 2 %: the filter's attenuation of a 1.5 Hz acceleration over 60 ms (omega T = 0.57) is
    # about 1 %, a bias the standard error (0.003 kg) does not hold
    assert abs(m["value"] - model.jack.moving_mass) < 0.02 * model.jack.moving_mass and m["se"] < 0.05
    assert r.model.jack.moving_mass == pytest.approx(m["value"])


def test_nonlinear_friction_is_flagged_not_forced():
    model = _model()
    recs = []
    for s, pa in enumerate((1.0, 3.0, 5.0, 7.0)):
        # the Coulomb level jumps by 30 N above 4 bar: not a line in pressure (a line through
        # the four levels misses the middle two by 9 N, a third of the friction there)
        jump = {side: dict(TRUE[side], fc0=TRUE[side]["fc0"] + (30.0 if pa > 4 else 0.0), fc_b=0.0,
                           kv_b=0.0) for side in TRUE}
        recs.append(synth(model, jump, pa, 0.0, 40 + s))
    r = identify_friction(model, recs, stribeck=False)
    assert r.linear_in_pressure is False
    assert any("not linear in pressure" in w for w in r.warnings)


def test_a_record_without_force_is_refused_naming_it():
    with pytest.raises(FieldError) as e:
        identify_friction(_model(), [{"t": [0, 1], "x": [0, 1], "p_a": [2e5, 2e5], "p_b": [1e5, 1e5]}])
    assert e.value.path == "experiments[0].F"


def test_one_direction_only_is_refused_naming_what_cannot_be_identified():
    model = _model()
    rec = synth(model, TRUE, 2.0, 1.0, 50)
    t = rec.t
    push = FrictionRecord(t, 0.01 * t, rec.p_a, rec.p_b, rec.F, "extension only")
    with pytest.raises(FieldError) as e:
        identify_friction(model, [push], stribeck=False)
    assert e.value.path == "experiments" and "friction.retract" in str(e.value)


def test_the_model_records_the_friction_came_from_the_bench(quadrant_fit):
    """Issue 29, step by step: every identified friction coefficient carries source 'bench'
    and its standard error; the load-cell offset, a bench fact, is no model value."""
    model, recs, r = quadrant_fit
    prov = r.model.provenance
    for side in TRUE:
        for key in TRUE[side]:
            path = f"friction.{side}.{key}"
            assert prov[path]["source"] == "bench", path
            assert prov[path]["stderr"] == r.parameters[path]["se"], path
            assert "Eq. 17-20" in prov[path]["method"]
    assert not any(p.startswith(("offset", "area")) for p in prov)
    assert Model.from_dict(r.model.to_dict()).provenance == prov


def test_a_chamber_held_at_ambient_is_not_determined_however_noisy_its_reading():
    """Issue 29: chamber B at ambient with a 200 Pa reading noise made fc_b and kv_b look
    independent of everything (noise is): they were reported identified, kv_b -0.0006 +- 0.0016.
    A coefficient of a pressure the records do not vary is not determined: it keeps the model's
    value and the answer says why, while chamber A's (1, 3 and 7 bar) are identified."""
    model = _model()
    recs = [synth(model, TRUE, pa, 0.0, k) for k, pa in enumerate((1.0, 3.0, 7.0))]
    r = identify_friction(model, recs, stribeck=False)
    for side in ("extend", "retract"):
        for key in ("fc_b", "kv_b"):
            p = r.parameters[f"friction.{side}.{key}"]
            assert p["identified"] is False and p["status"] == "not determined", p
            assert "chamber B's gauge pressure spans" in p["reason"] and p["held_from"] == "prior"
            assert p["value"] == 0.0 and p["se"] is None            # the model's (default) value
            assert r.model.to_dict()["friction"][side][key] == 0.0
            assert f"friction.{side}.{key}" not in (r.model.to_dict().get("provenance") or {})
        for key in ("fc_a", "kv_a"):
            assert r.parameters[f"friction.{side}.{key}"]["status"] == "identified"
    # one record: chamber A is held too (its 200 Pa noise and 1 bar level), so fc_a is not
    # determined either; the Coulomb and viscous levels at that pressure are
    one = identify_friction(model, recs[1:2], stribeck=False)
    assert one.parameters["friction.extend.fc_a"]["status"] == "not determined"
    assert one.parameters["friction.extend.fc0"]["status"] == "identified"
    assert "not determined" in one.report()
