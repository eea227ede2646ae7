"""Impossible and implausible values are never shown or applied without a word (issue 39,
items 5-6): one check (:func:`pneucore.analysis.shown.value_flag`) on every change a finding
lists, on the vertical 25 mm jack of the real record's shape."""
import copy

import pytest

from loop_record import truth_dict
from pneucore.analysis.shown import flag_changes, value_flag
from pneucore.description.model import Model
from pneucore.description.paths import model_changes


@pytest.fixture(scope="module")
def jack():
    return Model.from_dict(truth_dict())


@pytest.mark.parametrize("path,value,severity,words", [
    ("jack.dead_volume_a", 556e-6, "implausible", "chamber A"),        # 556 cm^3 on 41 cm^3
    ("jack.mounting_angle", -174.0, "impossible", "+-90 deg"),         # outside the field
    ("jack.mounting_angle", -21.1, "implausible", "mounting angle"),   # a vertical jack at -21
    ("jack.moving_mass", 4.08, "implausible", "moving mass"),          # weighed 1.47 kg
    ("jack.moving_mass", -0.3, "impossible", "against its declared direction"),
    ("supply.pressure", 3.9e5, "implausible", "supply pressure"),      # 4.8 bar gauge declared
    ("friction.extend.fc0", 39.9, "implausible", "Coulomb"),           # 8 -> 39.9 N
])
def test_the_issues_values_are_flagged(jack, path, value, severity, words):
    sev, why = value_flag(jack, path, value)
    assert sev == severity and words in why, (sev, why)


@pytest.mark.parametrize("path,value", [("heat.coefficient", 30.0), ("jack.dead_volume_a", 8e-6),
                                        ("jack.moving_mass", 1.6), ("jack.mounting_angle", 88.0)])
def test_ordinary_corrections_are_not(jack, path, value):
    assert value_flag(jack, path, value) == (None, "")


def test_a_recalibration_lists_every_value_it_moves_each_flagged(jack):
    given = truth_dict()
    base = copy.deepcopy(given)
    base["heat"]["coefficient"] = 30.0
    base["jack"]["dead_volume_a"] = 556e-6
    base["jack"]["moving_mass"] = 1.5
    out = flag_changes(jack, model_changes(given, base), known=["jack.moving_mass"])
    got = {c["path"]: c["flag"] for c in out}
    assert got == {"heat.coefficient": None, "jack.dead_volume_a": "implausible",
                   "jack.moving_mass": "known"}


def test_a_known_value_the_data_would_move_beyond_its_field_says_so():
    # issue 39: "fitted alone it would move to about -174 deg" for an angle limited to +-90
    from types import SimpleNamespace

    import numpy as np

    from loop_record import effective_edges, record
    from pneucore.analysis.hypotheses import known_disagreements
    from pneucore.data.experiment import Experiment
    cmd = [[0.0, 0.0]]
    for a, b in effective_edges():
        cmd += [[a, 1.0], [b, 0.0]]
    exps = [Experiment(record(), {"command": cmd}, "v")]
    model = Model.from_dict(truth_dict())
    calls = []

    def weighted(replays):
        # the base residual, then one that the angle's small step lowers a little everywhere:
        # a Gauss-Newton step of hundreds of degrees
        calls.append(1)
        return np.ones(10) if len(calls) == 1 else np.ones(10) - 1e-3
    out = known_disagreements(model, exps, ["jack.mounting_angle"], None,
                              SimpleNamespace(weighted=weighted))
    assert len(out) == 1 and out[0]["flag"] == "impossible"
    assert "outside the field's range" in out[0]["description"]
