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
