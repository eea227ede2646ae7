"""A recalibration at a bound, or far beyond a catalogue error, is a symptom (issue 22, item 3):
the catalog effects are weighed again with that parameter held at its catalogue value before
the recalibration is accepted, and it is called implausible when it stays."""
import functools
import math
from types import SimpleNamespace

import pytest

from pneucore import Model, model_preset
from pneucore.analysis.compare import compare
from pneucore.analysis.diagnosis import stages as S
from pneucore.analysis.diagnose import diagnose
from pneucore.analysis.history import refine
from pneucore.analysis import hypotheses as H
from pneucore.analysis.hypotheses import BASE_HYPOTHESES, IMPLAUSIBLE, plausibility
from pneucore.data.experiment import as_experiments
from pneucore.data.synthetic import RIG_CASES, rig_case
from pneucore.description.paths import ParameterSpec, get_value

EXHAUST = "valve.ports.*-R.C"


@functools.lru_cache(maxsize=None)
def case(name):
    c = rig_case(name, **dict(RIG_CASES)[name])
    return c, as_experiments(c.experiments), compare(c.truth, c.experiments).overall


# ------------------------------------------------------------------ the rule itself

def test_a_factor_is_as_implausible_below_the_catalogue_as_above():
    m = Model.from_dict(model_preset("paper-4way"))
    typical = BASE_HYPOTHESES[EXHAUST].typical
    # just beyond IMPLAUSIBLE typical errors, counted on the logarithm, either way
    f = math.exp(1.01 * IMPLAUSIBLE * math.log1p(typical))
    assert plausibility(m, EXHAUST, f) and plausibility(m, EXHAUST, 1.0 / f)
    g = math.exp(0.99 * IMPLAUSIBLE * math.log1p(typical))
    assert plausibility(m, EXHAUST, g) == "" and plausibility(m, EXHAUST, 1.0 / g) == ""
    # the case: exhaust edges at 0.38 of the catalogue (7 typical errors of 15 %)
    assert "7 times" in plausibility(m, EXHAUST, 0.382)


def test_held_in_turn_the_values_at_a_bound_first_then_all():
    at_bound = {"path": "heat.coefficient", "reason": "at its fit bound: ..."}
    far = {"path": EXHAUST, "reason": "7 times the typical catalogue error of ..."}
    assert S.holdings([far, at_bound]) == [[at_bound], [far, at_bound]]
    assert S.holdings([far]) == [[far]]
    assert S.holdings([at_bound]) == [[at_bound]]
    assert S.holdings([]) == []


def test_implausible_lists_only_the_null_fit_s_own_choices():
    m = Model.from_dict(model_preset("paper-4way"))
    specs = [ParameterSpec("heat.coefficient", 25.0, 0.5, 250.0, True, "W/(m^2 K)"),
             ParameterSpec("supply.pressure", 7e5, 4.9e5, 9.1e5, True, "Pa")]
    fit = SimpleNamespace(values={
        "heat.coefficient": {"value": 250.0, "at_bound": True, "unit": "W/(m^2 K)"},
        "supply.pressure": {"value": 7.1e5, "at_bound": False, "unit": "Pa"},
        "jack.load_force": {"value": 60.0, "at_bound": False, "unit": "N"}})
    null = SimpleNamespace(fit=fit, auto_specs=specs)
    odd = S.implausible(m, null)
    # the load was the caller's (not among the auto choices): not judged here
    assert [o["path"] for o in odd] == ["heat.coefficient"]
    assert "bound" in odd[0]["reason"] and odd[0]["before"] == 25.0
    assert S.implausible(m, SimpleNamespace(fit=None, auto_specs=specs)) == []


def test_withheld_values_go_back_to_the_catalogue():
    m = Model.from_dict(model_preset("paper-4way"))
    nxt = m.copy()
    nxt.heat.coefficient = 250.0
    recal = [{"path": "heat.coefficient", "label": "heat", "before": 25.0, "after": 250.0,
              "implausible": "at its fit bound"},
             {"path": "supply.pressure", "before": 7e5, "after": 7.1e5}]
    out, back = S.withheld(m, nxt, recal, {"heat.coefficient", "supply.pressure"})
    assert [r["path"] for r in back] == ["heat.coefficient"]
    assert out.heat.coefficient == 25.0
    # a valve scale reads 1 on any model: its table is scaled back by before / after
    scaled = S.withheld(m, m, [{"path": EXHAUST, "before": 1.0, "after": 0.5,
                                "implausible": "x"}], {EXHAUST})[0]
    for edge in ("A-R", "B-R"):
        # round-off of a product
        assert list(scaled.valve.ports[edge].C) == pytest.approx(
            [2.0 * c for c in m.valve.ports[edge].C], rel=1e-12)
    assert list(scaled.valve.ports["P-A"].C) == list(m.valve.ports["P-A"].C)
    # not the fit's own choice: left as the fit found it
    assert S.withheld(m, nxt, recal, {"supply.pressure"})[1] == []


# ------------------------------------------------------------------ on the rigs

@pytest.fixture(scope="module")
def tube_and_throttles():
    c, exps, floor = case("effect/circuit/tubing+meter_out")
    return c, exps, floor, refine(c.start, exps, max_rounds=4)


def test_a_heat_coefficient_at_its_bound_was_a_stand_in_for_the_tubing(tube_and_throttles):
    c, exps, floor, (model, hist, diags) = tube_and_throttles
    first = diags[0]
    held = first.remaining["held_at_catalogue"]
    assert held["taken"] and held["verdict"] == "tubing", first.message
    assert [p["path"] for p in held["parameters"]] == ["heat.coefficient"]
    assert first.verdict == "tubing"
    # the exhaust edges' value beside it (0.35 of the catalogue) is the same symptom: the next
    # model keeps the catalogue's edges, for the next round to weigh
    assert EXHAUST in held["withheld"]
    assert get_value(first.model, EXHAUST) == pytest.approx(1.0)
    assert "was a stand-in" in first.message


def test_the_tube_and_the_throttles_are_both_named_and_the_floor_reached(tube_and_throttles):
    c, exps, floor, (model, hist, diags) = tube_and_throttles
    assert set(model.effects) == {"tubing", "meter_out_throttle"}, [d.message for d in diags]
    # FLOOR_FACTOR of tests/analysis/test_diagnosis_rigs.py: within 20 % of the truth's error
    assert compare(model, exps).overall <= 1.2 * floor
    # the throttles come back within 20 % of the truth (PARAM_RTOL of test_diagnosis.py)
    for p in ("C_a", "C_b"):
        want = c.truth["effects"]["meter_out_throttle"][p]
        assert model.effects["meter_out_throttle"][p] == pytest.approx(want, rel=0.2)


def test_an_undeclared_load_stays_and_is_called_implausible():
    """A 40 N load the catalogue left at 0 is far beyond its typical error, but no catalog
    effect explains the records with it held at 0: the recalibration stands, said so."""
    c, exps, floor = case("base/load")
    d = diagnose(c.start, exps)
    assert d.verdict is None
    held = d.remaining["held_at_catalogue"]
    assert not held["taken"]
    assert "jack.load_force" in [p["path"] for p in held["parameters"]]
    assert "jack.load_force" in [r["path"] for r in d.recalibrate]
    assert "Implausible" in d.message
    # the recalibration it keeps is the one at the floor
    assert compare(d.model, exps).overall <= 1.2 * floor


def test_a_declared_load_that_changes_sign_is_impossible_whatever_its_size():
    """Issue 28: a load recalibrated against its declared direction (a weight that would pull
    the rod up) is not a catalogue error, however small the change."""
    m = Model.from_dict(model_preset("paper-4way"))
    m.jack.load_force = 14.4            # declared: pushing against extension [N]
    assert plausibility(m, "jack.load_force", 14.0) == ""
    why = plausibility(m, "jack.load_force", -0.5)
    assert "changed sign" in why and "declared direction" in why and "N" in why
    # a value of 0 declares no direction: a sign is no symptom there
    m.jack.load_force = 0.0
    assert "changed sign" not in plausibility(m, "jack.load_force", -0.5)


def _vertical(mass=1.47):
    """The issue's rig: a vertical jack (rod up) lifting ``mass`` [kg], no load declared."""
    m = Model.from_dict(model_preset("paper-4way"))
    m.jack.moving_mass, m.jack.mounting_angle = mass, 90.0
    return m


def test_a_load_that_turns_the_weight_along_the_rod_around_is_impossible():
    """Issue 28: "Add dead_volume silently set the load to -51 N (gravity pointing up)". On a
    vertical jack the weight, m g = 14.4 N for 1.47 kg, declares the load's direction even
    with no load given: a fitted load beyond -14.4 N lifts the mass by itself."""
    m = _vertical()
    weight = 1.47 * 9.80665
    why = plausibility(m, "jack.load_force", -51.0)
    assert "declared direction" in why and "weight along the rod" in why
    # ... whatever its size: just past the weight, and even where the fit left it at a bound
    assert "declared direction" in plausibility(m, "jack.load_force", -1.01 * weight)
    assert "declared direction" in plausibility(m, "jack.load_force", -51.0, at_bound=True)
    # a load short of the weight keeps the direction (a counterweight, a cable's pull): it is
    # judged by its size only (0.8 m g is some 10 typical errors of an undeclared load there)
    assert "declared direction" not in plausibility(m, "jack.load_force", -0.8 * weight)
    # a horizontal jack with no load declares no direction: either sign is a size question
    m.jack.mounting_angle = 0.0
    assert "declared direction" not in plausibility(m, "jack.load_force", -51.0)


def test_the_load_given_and_the_weight_declare_the_direction_together():
    m = _vertical()
    m.jack.load_force = -5.0     # a spring helping the lift: 9.42 N towards x = 0 in all
    assert H.against_direction(m, "jack.load_force", -8.0) == ""
    why = H.against_direction(m, "jack.load_force", -20.0)
    assert "the load given and the weight along the rod" in why and "9.42 N" in why
    # the load given turned around is against its own declared sign, too
    assert "changed sign" in H.against_direction(m, "jack.load_force", 3.0)


def test_a_candidate_whose_fit_turns_the_load_around_is_not_determined():
    """A refit's base values (``uncertain_params``) that point against their declared
    direction make the candidate impossible: never significant, never named."""
    m = _vertical()
    fitted = {"heat.coefficient": {"value": 30.0}, "jack.load_force": {"value": -51.0},
              "effects.dead_volume.volume_a": {"value": 1e-5}}
    assert "declared direction" in H.first_against_direction(m, fitted)
    fitted["jack.load_force"]["value"] = -3.0
    assert H.first_against_direction(m, fitted) == ""


def test_the_words_follow_the_fit_returned():
    """Issue 22: "Implausible: Coulomb friction extending 12.8 -> 6e-21 N" came from the fit
    before the sensor's zero was found; the fit returned holds 15.9 N."""
    odd = [{"path": "friction.extend.fc0", "label": "Coulomb friction extending",
            "before": 12.8, "after": 6.4e-21, "unit": "N", "reason": "at its fit bound: ..."}]
    plausible = [{"path": "friction.extend.fc0", "after": 15.9}]
    assert S.still_implausible(odd, plausible) == []
    still = [{"path": "friction.extend.fc0", "after": 80.0, "implausible": "7 times ..."}]
    (o,) = S.still_implausible(odd, still)
    assert o["after"] == 80.0 and o["reason"] == "7 times ..."
    # a value the returned fit did not refit keeps the null fit's words
    assert S.still_implausible(odd, []) == odd
