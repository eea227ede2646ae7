"""Closed-loop robustness over a study's ensemble and tuning over it (issue 42, items 6-7)."""
import pytest

from pneucore.control.models import servo_model
from pneucore.control.robustness import closed_loop_study, tune_controller
from pneucore.description.validation import FieldError


def definition(gains):
    return {"model": servo_model(),
            "scenario": {"duration": 1.0, "x0": 0.1, "initial": {"p_a": 5.3e5, "p_b": 5.3e5},
                         "controller": {"kind": "pid", "gains": gains,
                                        "setpoint": [[0, 0.1], [0.05, 0.11]]}},
            "parameters": {"jack.moving_mass": {"grid": [1.0, 2.0, 4.0]}}}


def test_heavier_loads_overshoot_more_under_the_same_gains():
    out = closed_loop_study(definition({"kp": 15}))
    j = out["metrics"].index("overshoot")
    over = [r[j] for r in out["rows"]]
    # mass 1, 2, 4 kg: the pneumatic spring's frequency falls as 1/sqrt(m) against the same
    # loop gain, so the loop is less damped: overshoot grows with the mass
    assert over[0] < over[1] < over[2]
    assert out["summary"]["stable_fraction"] == 1.0 and out["summary"]["runs"] == 3


def test_tuning_picks_the_gain_with_the_smallest_worst_case():
    out = tune_controller(definition({"kp": 15}), {"kp": [5.0, 10.0, 20.0]}, "overshoot")
    worst = {c["gains"]["kp"]: c["worst"] for c in out["candidates"]}
    assert out["best"]["worst"] == min(w for w in worst.values() if w is not None)
    assert out["best"]["gains"]["kp"] == min(worst, key=lambda k: worst[k] if worst[k] is not None else 1e9)
    with pytest.raises(FieldError) as exc:
        tune_controller(definition({"kp": 15}), {"kp": [5.0]}, "nope")
    assert exc.value.path == "objective"


def coulomb_model(fc0):
    """The servo jack with a Coulomb level ``fc0`` [N] both ways and no pressure terms (so
    that ``friction.*.fc0`` scales the whole of the Coulomb friction)."""
    m = servo_model(coulomb=True)
    for side in ("extend", "retract"):
        m["friction"][side].update(fc0=fc0, fc_a=0.0, fc_b=0.0)
    return m


#: Settled (2 %) within 1 s (twice the 0.52 s measured at nominal friction), and no
#: stick-slip cycle above 0.1 mm (half the 10 mm move's 2 % band: a cycle inside the band
#: would not show in the settling time)
SPEC = {"settling_time": 1.0, "hunting_amplitude": 1e-4}


def test_a_gain_meeting_the_spec_at_nominal_friction_fails_at_plus_50_percent():
    # PID kp 15 1/m, ki 60 1/(m s) on a 10 mm step. Hand-checked, run by run (below, and
    # measured with pneucore.control.closed_loop on a sweep of the Coulomb level): at 10 N the
    # piston sticks inside the 2 % band and stays (settled in 0.52 s, no hunting); from 12 N
    # the integral winds up while the piston sticks, breaks it away past the setpoint and a
    # stick-slip limit cycle remains (0.23 mm at 12 N, 0.47 mm at 15 N, 0.87 mm at 18 N, at
    # about 1 Hz). So +50 % friction (15 N) turns a tuning that meets the spec into one that
    # hunts: the drift the paper's conclusion warns of
    d = {"model": coulomb_model(10.0),
         "scenario": {"duration": 2.0, "x0": 0.1, "initial": {"p_a": 5.3e5, "p_b": 5.3e5},
                      "controller": {"kind": "pid", "gains": {"kp": 15, "ki": 60},
                                     "setpoint": [[0, 0.1], [0.1, 0.11]]}},
         "parameters": {"friction.*.fc0": {"grid": [10.0, 15.0]}}}
    out = closed_loop_study(d, specification=SPEC)
    assert out["meets"] == [True, False]
    assert out["summary"]["meets_fraction"] == 0.5
    assert out["summary"]["stable_fraction"] == 1.0      # hunting, not unstable
    # each run of the pool is the run simulated here on its own
    from pneucore.control.closed_loop import simulate_closed_loop
    for row, fc0 in zip(out["rows"], (10.0, 15.0)):
        scen = dict(d["scenario"])
        c = simulate_closed_loop(coulomb_model(fc0), scen).stats["control"]
        for k, v in zip(out["metrics"], row):
            assert v == (None if c[k] is None else pytest.approx(c[k], rel=1e-12, abs=0)), k
    hunt = out["metrics"].index("hunting_amplitude")
    assert out["rows"][0][hunt] < 1e-6 and out["rows"][1][hunt] > 2e-4
    # a tuning given the same spec over the same ensemble finds a set meeting it on both
    # runs: damping (kd 0.1 s/m) without the integral that winds up while the piston sticks
    tuned = tune_controller(d, {"ki": [0.0, 60.0], "kd": [0.0, 0.1]}, "settling_time",
                            specification=SPEC)
    share = {(c["gains"]["ki"], c["gains"]["kd"]): c["summary"]["meets_fraction"]
             for c in tuned["candidates"]}
    assert share[(60.0, 0.0)] == 0.5
    assert tuned["best"]["meets_fraction"] == 1.0
    assert share[(tuned["best"]["gains"]["ki"], tuned["best"]["gains"]["kd"])] == 1.0


def test_a_study_stops_when_its_progress_raises_and_bad_specs_name_the_field():
    class Stop(Exception):
        pass

    seen = []

    def progress(frac, step):
        seen.append(step)
        if frac > 0:
            raise Stop(step)

    with pytest.raises(Stop):
        closed_loop_study(definition({"kp": 15}), progress=progress, engine={"workers": 1})
    assert seen and "on local process pool" in seen[0]
    for spec, field in (({"overshoot": -1}, "specification.overshoot"),
                        ({"nope": 1}, "specification.nope"),
                        ({"settling_time": float("nan")}, "specification.settling_time")):
        with pytest.raises(FieldError) as exc:
            closed_loop_study(definition({"kp": 15}), specification=spec)
        assert exc.value.path == field
