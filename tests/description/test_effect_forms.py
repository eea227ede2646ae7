"""Structural forms of an effect (``Effect.forms``): what the diagnosis tries besides the default.

A line's delay ``L / c`` is seen by a record once it spans more than a sample: the tubing
effect is then also tried in segments resolving it to a sample
(:func:`pneucore.physics.line.delay_cells`); other effects have one form.
"""
import math

import pytest

from pneucore.physics.line import delay_cells, sound_speed
from pneucore.physics.tube import MAX_SEGMENTS
from pneucore.description.effects import EFFECTS
from pneucore.description.model import Model
from pneucore.description.presets import model_preset

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


def test_only_a_finer_form_is_fitted_again():
    # more segments resolve more; fewer, or the lumped line, only cost less
    eff = EFFECTS["tubing"]
    assert eff.needs_refit_in({"segments": 5}, {"segments": 3})
    assert not eff.needs_refit_in({"segments": 2}, {"segments": 3})
    assert not eff.needs_refit_in({"segments": 1}, {"segments": 3})
    assert all(EFFECTS[n].needs_refit_in({}, {}) for n in EFFECTS if n != "tubing")


@pytest.mark.parametrize("fitted_length,refitted", [
    (2.0, [{}, {"segments": 3}, {"segments": 6}]),   # found longer: 6 cells resolve its delay
    (0.5, [{}, {"segments": 3}]),                     # found shorter: its 3 cells stay
    (0.2, [{}, {"segments": 3}]),                     # within a sample: the lumped fit stands
])
def test_the_joint_refit_fits_a_line_again_only_in_more_segments(monkeypatch, fitted_length,
                                                                 refitted):
    """:func:`joint_refit` fits the default form and the preferred one (3 segments for the 1 m
    probe at 1 kHz), then, at the fitted length, the form that length calls for only when it
    has more segments (each fit stubbed: the forms it is asked for are recorded)."""
    from types import SimpleNamespace

    from pneucore.analysis.diagnosis import stages as S
    from pneucore.data.experiment import as_experiments
    from pneucore.data.synthetic import synthetic_experiments
    exps = as_experiments(synthetic_experiments(model_preset("paper-4way"), seed=1))
    asked = []

    def fake(model, exps, null, name, start, max_nfev, report, form=None, sample_period=0.0,
             prefit=None, held=()):
        asked.append(dict(form or {}))
        values = {**start, "length_a": fitted_length, "length_b": fitted_length,
                  **(form or {})}
        # the lumped line removes most of the null's excess (2 % against a 0.1 % floor): it
        # shows the effect, so the forms in segments are fitted after it
        return SimpleNamespace(model=SimpleNamespace(effects={name: values}),
                               rss_after=[("e", "p_a", float(len(asked)), 1)],
                               error_after=SimpleNamespace(overall=0.005))
    monkeypatch.setattr(S, "_joint_refit_from", fake)
    null = SimpleNamespace(error=0.02, floor_overall=0.001)
    S.joint_refit(MODEL, exps, null, "tubing", 30, lambda f, s: None, {"segments": 3})
    assert S.sample_period(exps) == pytest.approx(1e-3)
    assert asked == refitted


def test_a_line_that_shows_nothing_lumped_is_not_fitted_in_segments(monkeypatch):
    """A line whose lumped fit removes no material share of the null's excess (a stand-in
    candidate) is not fitted in segments: each such simulation costs 50-100 times the lumped
    line's, and 73 of a 77 s round went to one (set3/T-rig-extleak-spool)."""
    from types import SimpleNamespace

    from pneucore.analysis.diagnosis import stages as S
    from pneucore.data.experiment import as_experiments
    from pneucore.data.synthetic import synthetic_experiments
    exps = as_experiments(synthetic_experiments(model_preset("paper-4way"), seed=1))
    asked = []

    def fake(model, exps, null, name, start, max_nfev, report, form=None, sample_period=0.0,
             prefit=None, held=()):
        asked.append(dict(form or {}))
        return SimpleNamespace(model=SimpleNamespace(effects={name: {**start, **(form or {})}}),
                               rss_after=[("e", "p_a", 1.0, 1)],
                               error_after=SimpleNamespace(overall=0.0195))
    monkeypatch.setattr(S, "_joint_refit_from", fake)
    # 2 % -> 1.95 % against a 0.1 % floor: 5 % of the excess, below EXCESS_MATERIAL (20 %)
    null = SimpleNamespace(error=0.02, floor_overall=0.001)
    S.joint_refit(MODEL, exps, null, "tubing", 30, lambda f, s: None, {"segments": 3})
    assert asked == [{}]
