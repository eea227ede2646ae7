"""Findings in engineering terms (issue 24: effects reported where they act and in the units they
are checked by: a leak in L/min ANR at working pressure, a dead volume in cm³, a lag in ms)."""
import pytest

from pneucore import Model, model_preset
from pneucore.analysis.diagnose import diagnose
from pneucore.analysis.engineering import IN_WORDS, in_words
from pneucore.data.samples import load_sample
from pneucore.physics.gas import RHO_REF
from pneucore.description.effects import EFFECTS

MODEL = Model.from_dict(model_preset("paper-4way"))


def test_a_piston_leak_is_a_flow_at_the_working_pressure():
    g = 8e-11   # kg/(s Pa)
    dp = MODEL.supply.pressure - MODEL.ambient.pressure
    # q = G dp (the effect's laminar law) as normal litres per minute: by hand 2.42 L/min
    expected = g * dp / RHO_REF * 60e3
    text = in_words("piston_leakage", {"conductance": g}, MODEL)
    assert f"{expected:.3g} L/min ANR" in text and "chamber A ↔ chamber B" in text


def test_a_one_sided_leak_says_which_chamber():
    text = in_words("external_leakage", {"conductance_a": 1e-10, "conductance_b": 1e-13}, MODEL)
    assert "from chamber A to ambient" in text and "chamber B tight" in text
    both = in_words("external_leakage", {"conductance_a": 1e-10, "conductance_b": 7e-11}, MODEL)
    assert "both chambers" in both


def test_lags_in_ms_and_volumes_in_cm3():
    assert "6 ms late" in in_words("valve_spool_dynamics", {"time_constant": 0.006}, MODEL)
    assert "12 cm³" in in_words("dead_volume", {"volume_a": 1.2e-5, "volume_b": 0.0}, MODEL)


def test_every_wording_names_a_registered_effect():
    assert set(IN_WORDS) <= set(EFFECTS)


def test_the_diagnosis_says_it_in_engineering_terms():
    d = diagnose(model_preset("paper-4way"), load_sample("piston-leak"))
    assert d.verdict == "piston_leakage"
    assert "In engineering terms: a leak across the piston seal" in d.message
    assert d.ranking[0]["in_words"] in d.ranking[0]["explanation"]


def test_impossible_values_are_named_and_possible_ones_are_not():
    """Issue 28: a dead volume larger than the chamber, a leak larger than the valve's flow is
    not evidence of the effect (the diagnosis marks such a candidate undetermined)."""
    from pneucore.analysis.engineering import impossible
    import math
    j = MODEL.jack
    swept_a = math.pi / 4 * (j.bore ** 2 - j.rod_a ** 2) * j.stroke
    assert impossible("dead_volume", {"volume_a": 1.01 * swept_a, "volume_b": 0.0}, MODEL)
    assert impossible("dead_volume", {"volume_a": 0.5 * swept_a, "volume_b": 0.0}, MODEL) == ""
    # the valve's choked flow at full opening: C_max p_s rho_ref (ISO 6358 Eq. 4)
    c_max = max(max(e["C"]) for e in MODEL.to_dict()["valve"]["ports"].values())
    q_valve = c_max * MODEL.supply.pressure * RHO_REF
    dp = MODEL.supply.pressure - MODEL.ambient.pressure
    assert "exceed what the valve" in impossible("piston_leakage", {"conductance": 1.1 * q_valve / dp}, MODEL)
    assert impossible("piston_leakage", {"conductance": 8e-11}, MODEL) == ""
    assert "chamber B" in impossible("external_leakage",
                                     {"conductance_a": 0.0, "conductance_b": 2 * q_valve / dp}, MODEL)
