"""A diagnosis fit of an effect stays within what the model accepts (``Effect.fit_bounds``)."""
import pytest

from pneucore.description.effects import EFFECTS
from pneucore.description.model import Model
from pneucore.description.presets import model_preset


def test_cushion_fit_keeps_each_cushion_within_half_the_stroke():
    m = Model.from_dict(model_preset("paper-4way"))
    eff = EFFECTS["end_cushion"]
    half = 0.5 * m.jack.stroke
    assert eff.fit_bounds("length_a", m) == (0.0, half)
    assert eff.fit_bounds("length_b", m) == (0.0, half)
    # both cushions at their fit bounds make a model the effect's check accepts (a fit once
    # ended past the stroke, standing in for meter-out throttles, and the diagnosis crashed)
    d = model_preset("paper-4way")
    d["effects"] = {"end_cushion": {"length_a": half, "length_b": half, "C_a": 4e-9, "C_b": 4e-9}}
    Model.from_dict(d)
    d["effects"]["end_cushion"]["length_b"] = eff.param("length_b").max
    with pytest.raises(Exception, match="end_cushion.length_b"):
        Model.from_dict(d)


@pytest.mark.parametrize("name", sorted(n for n, e in EFFECTS.items() if e.fit_max is None))
def test_other_effects_fit_within_their_parameters_bounds(name):
    m = Model.from_dict(model_preset("paper-4way"))
    eff = EFFECTS[name]
    for p in eff.parameters:
        assert eff.fit_bounds(p.name, m) == (p.min, p.max)
