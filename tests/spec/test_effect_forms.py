"""Structural forms of an effect (``Effect.forms``): what the diagnosis tries besides the default.

A line's delay ``L / c`` is seen by a record once it spans more than a sample: the tubing
effect is then also tried in segments resolving it to a sample
(:func:`pneucore.physics.line.delay_cells`); other effects have one form.
"""
import math

import pytest

from pneucore.physics.line import delay_cells, sound_speed
from pneucore.physics.tube import MAX_SEGMENTS
from pneucore.spec.effects import EFFECTS
from pneucore.spec.model import Model
from pneucore.spec.presets import model_preset

MODEL = Model.from_dict(model_preset("paper-4way"))
T = MODEL.supply.temperature


def test_delay_cells_resolve_the_delay_to_a_sample():
    c = sound_speed(T)
    for length, dt in ((2.5, 1e-3), (1.0, 1e-3), (5.0, 1e-3), (0.7, 1e-3), (2.0, 5e-4)):
        n = delay_cells(length, dt, T)
        # a cell's transit time L / (N c) is at most a sample, and one cell fewer would not be
        assert length / (n * c) <= dt * (1 + 1e-12)
        assert n == 1 or length / ((n - 1) * c) > dt
    assert delay_cells(0.2, 1e-3, T) == 1            # 0.6 ms: within a sample, lumped
    assert delay_cells(50.0, 1e-4, T) == MAX_SEGMENTS   # 1,457 wanted: the most the core takes
    assert delay_cells(0.0, 1e-3, T) == delay_cells(1.0, 0.0, T) == 1


def test_tubing_is_tried_in_segments_where_its_delay_spans_a_sample():
    eff = EFFECTS["tubing"]
    at = eff.probe_values(MODEL)
    n = math.ceil(max(at["length_a"], at["length_b"]) / (sound_speed(T) * 1e-3))
    assert eff.forms_for(at, MODEL, 1e-3) == [{}, {"segments": n}]
    # sampled at 100 Hz the 1 m probe's 2.9 ms delay is within a sample: lumped only
    assert eff.forms_for(at, MODEL, 1e-2) == [{}]


@pytest.mark.parametrize("name", sorted(n for n in EFFECTS if n != "tubing"))
def test_other_effects_have_one_form(name):
    eff = EFFECTS[name]
    assert eff.forms_for(eff.probe_values(), MODEL, 1e-3) == [{}]
