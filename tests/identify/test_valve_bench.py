"""The valve flow bench (ISO 6358-1, paper Eq. 4-5, Fig. 2): SMC's catalogue example and a
synthetic bench with known C(u), b(u) tables recovered."""
import math
import numpy as np
import pytest

from pneucore import model_preset
from pneucore.identify import identify_valve
from pneucore.physics.flow import FLOW_LAWS
from pneucore.physics.gas import RHO_REF
from pneucore.description.model import Model
from pneucore.description.validation import FieldError

#: 1 dm^3/(s bar) in the model's unit m^3/(s Pa)
DM3_S_BAR = 1e-3 / 1e5
#: 1 dm^3/min (ANR) in kg/s
DM3_MIN_ANR = RHO_REF * 1e-3 / 60.0


def test_smc_catalogue_example():
    # SMC, "Flow-rate characteristics" (ISO 6358): C = 2 dm^3/(s bar), b = 0.3; upstream
    # 0.4 MPa gauge, downstream 0.3 MPa gauge, 20 degC: 420 dm^3/min (ANR); choked: 600.
    # SMC's worked figures take the atmosphere as 0.1 MPa; the catalogue rounds to 10
    # dm^3/min, so 0.5 % is the tolerance its figures allow
    law = FLOW_LAWS["iso6358"]
    C = 2 * DM3_S_BAR
    sub = law(0.5e6, 293.15, 0.4e6, 293.15, C, 0.3) / DM3_MIN_ANR
    choked = law(0.5e6, 293.15, 0.1e6, 293.15, C, 0.3) / DM3_MIN_ANR
    assert sub == pytest.approx(420.0, rel=0.005)
    assert choked == pytest.approx(600.0, rel=0.005)
    # and the bench gives back SMC's C and b from its own two figures plus a third point
    pts = [{"p_up": 0.5e6, "p_down": pd, "T_up": 293.15,
            "flow": law(0.5e6, 293.15, pd, 293.15, C, 0.3)} for pd in (0.1e6, 0.4e6, 0.45e6)]
    r = identify_valve(pts, "P-A")
    assert r.fixed_orifice and len(r.C) == 1
    assert r.C[0] == pytest.approx(C, rel=1e-6) and r.b[0] == pytest.approx(0.3, abs=1e-6)


#: The known tables of the synthetic bench: a 4/2 spool's P-A edge with a 15 % overlap
#: (paper Fig. 2): closed below 0.15, C rising to 1.2 dm^3/(s bar), b falling from 0.45
U = [0.0, 0.1, 0.2, 0.4, 0.6, 0.8, 1.0]
C_TRUE = [0.0, 0.0, 0.2, 0.55, 0.85, 1.05, 1.2]
B_TRUE = [0.3, 0.3, 0.45, 0.4, 0.35, 0.32, 0.3]


def _bench(noise=0.01, seed=0):
    """Points at every table opening: 1-7 bar gauge upstream, ratios 0.2-0.97 downstream;
    1 % flow-meter noise (a good thermal mass-flow meter's)."""
    rng = np.random.default_rng(seed)
    law = FLOW_LAWS["iso6358"]
    pts = []
    for u, c, b in zip(U, C_TRUE, B_TRUE):
        for p_up in (3e5, 5e5, 8e5):
            for ratio in (0.2, 0.4, 0.6, 0.75, 0.85, 0.93, 0.97):
                q = law(p_up, 293.15, ratio * p_up, 293.15, c * DM3_S_BAR, b)
                pts.append({"opening": u, "p_up": p_up, "p_down": ratio * p_up, "T_up": 293.15,
                            "flow": max(q * (1 + noise * rng.normal()), 0.0)})
    return pts


def test_synthetic_bench_recovers_the_tables_within_their_errors():
    r = identify_valve(_bench(), "P-A")
    assert r.opening == U
    for j, u in enumerate(U):
        if C_TRUE[j] == 0.0:
            assert r.closed[j] and not r.b_fitted[j]
            continue
        # 4 standard errors: a fixed seed; a wrong law or unit misses by far more
        assert abs(r.C[j] - C_TRUE[j] * DM3_S_BAR) < 4 * r.C_se[j], (u, r.C[j], r.C_se[j])
        assert abs(r.b[j] - B_TRUE[j]) < 4 * r.b_se[j], (u, r.b[j], r.b_se[j])
        # and the errors mean something: 1 % noise on 21 points pins C to 1 %, b to 0.03
        assert r.C_se[j] < 0.01 * C_TRUE[j] * DM3_S_BAR and r.b_se[j] < 0.03
    # the overlap band: closed at 0 and 0.1; C(u) from 0.2 and 0.4 extrapolates to zero at
    # 0.2 - 0.2 * 0.2 / 0.35 = 0.086 (the true edge opens between 0.1 and 0.2)
    assert r.null_band["low"] == 0.0 and r.null_band["high"] == 0.1
    assert 0.05 < r.null_band["onset_high"] < 0.15
    # every point has its residual, about the noise
    assert len(r.points) == len(_bench())
    rel = [abs(p["residual"]) / p["flow"] for p in r.points if p["flow"] > 0]
    assert np.median(rel) < 0.02


def test_written_into_a_models_valve_tables():
    r = identify_valve(_bench(), "P-A")
    model = Model.from_dict(model_preset("paper-4way"))
    new = r.write_into(model)
    assert new.valve.ports["P-A"].C == pytest.approx(r.C)
    assert new.valve.ports["P-B"].C == model.valve.ports["P-B"].C   # other edges untouched
    with pytest.raises(FieldError, match="edge"):
        type(r)(**{**r.__dict__, "edge": "X-Y"}).write_into(model)


@pytest.mark.parametrize("change, field", [
    ({"p_down": 6e5}, "points[0].p_down"),
    ({"flow": -1e-3}, "points[0].flow"),
    ({"opening": 1.5}, "points[0].opening"),
])
def test_bad_points_are_refused_naming_the_field(change, field):
    pts = _bench()
    pts[0] = {**pts[0], "p_up": 5e5, **change}
    with pytest.raises(FieldError) as e:
        identify_valve(pts, "P-A")
    assert e.value.path == field


def test_too_few_points_say_which_parameter():
    law = FLOW_LAWS["iso6358"]
    one = [{"opening": 0.5, "p_up": 5e5, "p_down": 4e5, "T_up": 293.15,
            "flow": law(5e5, 293.15, 4e5, 293.15, 1e-8, 0.3)}]
    with pytest.raises(FieldError, match="C and b at opening 0.5"):
        identify_valve(one, "P-A")
    choked = [{"opening": 0.5, "p_up": 5e5, "p_down": pd, "T_up": 293.15,
               "flow": law(5e5, 293.15, pd, 293.15, 1e-8, 0.3)} for pd in (1e5, 1.2e5)]
    with pytest.raises(FieldError, match="identify b at opening 0.5: every point is choked"):
        identify_valve(choked, "P-A")


def test_a_scattered_opening_reading_is_one_opening():
    # a spool position read at 0.6 +- 0.002 (a sensor's scatter) is one table opening
    rng = np.random.default_rng(3)
    pts = [p for p in _bench(noise=0.0) if p["opening"] in (0.4, 0.6)]
    for p in pts:
        p["opening"] += rng.uniform(-0.002, 0.002)
    r = identify_valve(pts, "P-A")
    assert len(r.opening) == 2 and abs(r.opening[1] - 0.6) < 0.002
    # C(u) varies by 0.15 dm^3/(s bar) per 0.1 of opening: +-0.002 moves C by at most 0.3 %
    assert r.C[1] == pytest.approx(0.85 * DM3_S_BAR, rel=0.005)


def test_the_model_records_the_tables_came_from_the_bench():
    """Issue 29, step by step: the edge's table paths carry source 'bench', with the table
    scale's relative standard error, the inverse-variance combination of its points' errors."""
    r = identify_valve(_bench(), "P-A")
    new = r.write_into(Model.from_dict(model_preset("paper-4way")))
    entry = new.provenance["valve.ports.P-A.C"]
    assert entry["source"] == "bench" and "ISO 6358" in entry["method"]
    want = 1.0 / math.sqrt(sum((c / s) ** 2 for c, s in zip(r.C, r.C_se) if s and c))
    assert entry["stderr"] == pytest.approx(want, rel=1e-12)   # the same sum, rounding only
    # 1 % noise on many points: the whole table's scale is known far better than 1 %
    assert 0.0 < entry["stderr"] < 0.01
    assert new.provenance["valve.ports.P-A.b"]["source"] == "bench"
    assert set(new.provenance) == {"valve.ports.P-A.C", "valve.ports.P-A.b"}
    back = Model.from_dict(new.to_dict())
    assert back.provenance == new.provenance and back.to_dict() == new.to_dict()
