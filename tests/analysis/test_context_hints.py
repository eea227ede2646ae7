"""A test declared wrongly gets a hint (issue 24): a hold test uploaded as "free" (the measured
position never moves while the model's does), a free test declared "locked"."""
import copy

from pneucore import model_preset
from pneucore.analysis.compare import MOVES_SPREAD, STILL_SPREAD, compare
from pneucore.analysis.diagnose import diagnose
from pneucore.data.samples import load_sample


def _hold_as_free():
    """The shipped hold test with a position channel (constant at the lock, plus the
    acquisition's noise), uploaded without "locked"."""
    import numpy as np
    hold = next(e for e in load_sample("clean") if e["name"] == "locked-hold")
    meas = copy.deepcopy(hold["measurement"])
    rng = np.random.default_rng(3)
    # 0.02 mm noise: an LVDT's, well inside STILL_SPREAD (0.5 mm)
    meas.signals["x"] = 0.125 + 2e-5 * rng.standard_normal(meas.n)
    return {"name": "hold", "scenario": {"x0": 0.125}, "measurement": meas}


def test_a_hold_test_declared_free_gets_the_hint_in_compare_and_diagnose():
    exp = _hold_as_free()
    c = compare(model_preset("paper-4way"), [exp])
    kinds = [h["kind"] for h in c.hints]
    assert kinds == ["declared_free_never_moves"], c.hints
    assert "scenario.locked = true" in c.hints[0]["message"]
    assert c.to_dict()["hints"] == c.hints
    d = diagnose(model_preset("paper-4way"), [exp])
    assert "Check the context: hold:" in d.message
    assert d.to_dict()["hints"][0]["kind"] == "declared_free_never_moves"


def test_correctly_declared_tests_get_no_hint():
    c = compare(model_preset("paper-4way"), load_sample("clean"))
    assert c.hints == []


def test_a_free_test_declared_locked_gets_the_other_hint():
    free = next(e for e in load_sample("clean") if e["name"] == "free-pulses")
    exp = {"name": "pulses", "scenario": {"locked": True, "x0": 0.05},
           "measurement": free["measurement"]}
    c = compare(model_preset("paper-4way"), [exp])
    assert [h["kind"] for h in c.hints] == ["declared_locked_moves"], c.hints


def test_a_piston_that_really_stays_put_is_not_called_locked():
    """A free test in which the model also keeps the piston still (no command): no hint, the
    record agrees with what was declared."""
    exp = _hold_as_free()
    exp["measurement"].signals["u"][:] = 0.0
    c = compare(model_preset("paper-4way"), [exp])
    assert c.hints == [], c.hints
    assert MOVES_SPREAD > 5 * STILL_SPREAD   # the two thresholds stay far apart
