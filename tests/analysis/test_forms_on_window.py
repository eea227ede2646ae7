"""A candidate's structural forms compared on the records' window (issue 26).

On long records every fit starts with a fit on the records' first seconds
(:func:`pneucore.analysis.calibrate.window`). The diagnosis fits each structural form of a
candidate (a line lumped, a line in segments) on that window, drops a form whose window's fit
ends materially above the best's (:data:`pneucore.analysis.diagnosis.stages.FORM_MARGIN`), and
fits only the others on the full records, from those window fits
(:func:`pneucore.analysis.diagnosis.stages.forms_on_window`). On a 1 s hold + 60 s cyclic
record that dropped a refit of 53 replays of a line in segments (87 s -> 27 s a round).
"""
from types import SimpleNamespace

import numpy as np
import pytest

from pneucore.analysis import calibrate as C
from pneucore.analysis.diagnosis import stages as S
from pneucore.data.experiment import as_experiments
from pneucore.data.synthetic import synthetic_experiments
from pneucore.description.model import Model
from pneucore.description.paths import ParameterSpec
from pneucore.description.presets import model_preset

MODEL = Model.from_dict(model_preset("paper-4way"))
#: The 1 m probe line at 1 kHz: its delay spans three samples (tests/description/test_effect_forms.py)
SEGMENTED = {"segments": 3}
#: The stubbed null's error and noise floor [-] (:func:`_stub_refits`' fits remove most of it)
NULL = {"error": 0.02, "floor_overall": 0.001}


def _experiments():
    return as_experiments(synthetic_experiments(model_preset("paper-4way"), seed=1))


def _quiet(fraction, step):
    pass


def _stub_refits(monkeypatch, window_rss):
    """Stub the fits: the window's fit of each form ends at ``window_rss[segments]``; each fit on
    the full records records the form it is asked for and the window fit handed to it."""
    made, asked = [], []

    def window_fit(model, short, specs, *args, **kwargs):
        seg = model.effects["tubing"].get("segments", 1)
        made.append(seg)
        return SimpleNamespace(rss_after=[("e", "p_a", window_rss[seg], 1)], seg=seg)

    def full(model, exps, null, name, start, max_nfev, report, form=None, sample_period=0.0,
             prefit=None, held=()):
        asked.append((dict(form or {}), None if prefit is None else prefit.seg))
        values = {**start, **(form or {})}
        # every form removes most of the null's excess (NULL: 2 % against a 0.1 % floor), so
        # the default form shows the effect and a finer one is worth its fit
        return SimpleNamespace(model=SimpleNamespace(effects={name: values}),
                               rss_after=[("e", "p_a", 1.0, 1)],
                               error_after=SimpleNamespace(overall=0.005))
    monkeypatch.setattr(C, "window_fit", window_fit)
    monkeypatch.setattr(S, "_joint_refit_from", full)
    return made, asked


@pytest.mark.parametrize("window_rss,fitted", [
    # the line in segments 30 % above the lumped line on the window: lumped alone goes on
    ({1: 1.0, 3: 1.3}, [({}, 1)]),
    # within the margin (1 %): the window does not tell them apart, both go on
    ({1: 1.0, 3: 1.01}, [({}, 1), (SEGMENTED, 3)]),
    # the lumped line far behind: the line in segments alone
    ({1: 2.0, 3: 1.0}, [(SEGMENTED, 3)]),
])
def test_a_form_far_behind_on_the_window_is_not_fitted_on_the_full_records(
        monkeypatch, window_rss, fitted):
    exps = _experiments()
    # two records of 1 s each: long once the window is shorter than they are
    monkeypatch.setattr(C, "PREFIT_SECONDS", 1.0)
    made, asked = _stub_refits(monkeypatch, window_rss)
    null = SimpleNamespace(specs_start=[], prior=None, **NULL)
    S.joint_refit(MODEL, exps, null, "tubing", 30, _quiet, SEGMENTED)
    assert made == [1, 3]           # each form's window fit, once
    assert asked == fitted          # the kept forms, each from its own window fit


def test_records_fitted_whole_compare_no_forms_on_a_window(monkeypatch):
    exps = _experiments()
    made, asked = _stub_refits(monkeypatch, {1: 1.0, 3: 9.0})
    S.joint_refit(MODEL, exps, SimpleNamespace(specs_start=[], prior=None, **NULL), "tubing",
                  30, _quiet, SEGMENTED)
    assert made == []
    assert asked == [({}, None), (SEGMENTED, None)]


def test_a_fit_from_a_given_window_fit_ends_where_the_fit_would():
    """:func:`fit` handed the window's fit (``prefit``) makes none of its own and returns what
    it returns on its own, to the last bit: the same arithmetic from the same point."""
    true = model_preset("paper-4way")
    true["effects"] = {"piston_leakage": {"conductance": 1.5e-10}}
    exps = as_experiments(synthetic_experiments(true, seed=3))
    m = S.with_effect(MODEL, "piston_leakage", {"conductance": 1e-11})
    specs = [ParameterSpec("effects.piston_leakage.conductance", 1e-11, 0.0, 1e-8, True,
                           "kg/(s Pa)"),
             ParameterSpec("heat.coefficient", MODEL.heat.coefficient, 1.0, 200.0, True,
                           "W/(m^2 K)")]
    saved = C.PREFIT_SECONDS
    C.PREFIT_SECONDS = 1.0
    try:
        short = C.window(exps)
        assert short is not None
        plain = C.fit(m, exps, specs, max_nfev=12, compute_before=False, reweight=True)
        pre = C.window_fit(m, short, specs, 12, reweight=True)
        calls = []
        real = C.window_fit
        C.window_fit = lambda *a, **k: calls.append(1) or real(*a, **k)
        try:
            given = C.fit(m, exps, specs, max_nfev=12, compute_before=False, reweight=True,
                          prefit=pre)
        finally:
            C.window_fit = real
    finally:
        C.PREFIT_SECONDS = saved
    assert calls == []
    for path in plain.values:
        assert given.values[path]["value"] == plain.values[path]["value"]
        assert given.values[path]["stderr"] == plain.values[path]["stderr"]
    assert given.message == plain.message
    # the window's residual energy comes with the point: what the forms are compared by
    assert S._rss(pre) > 0 and np.isfinite(S._rss(pre))


def test_a_line_in_finite_volumes_wins_its_window_and_is_named_on_long_records(monkeypatch):
    """The finite-volume tube rig (2.5 m of 4 mm line on each port in 8 volumes, base
    parameters off, nothing declared), its records counted long (the window 1 s of their 2 s):
    the line in segments is kept on the window and ``tubing`` is named in segments with its
    length, as on the records fitted whole (tests/analysis/test_diagnosis_rigs.py)."""
    from pneucore.analysis.diagnose import diagnose
    from pneucore.data.synthetic import RIG_CASES, rig_case
    name = "effect/circuit/tubing/finite-volume"
    c = rig_case(name, **dict(RIG_CASES)[name])
    exps = as_experiments(c.experiments)
    monkeypatch.setattr(C, "PREFIT_SECONDS", 1.0)
    kept = {}
    real = S.forms_on_window

    def spy(model, exps, null, name, *args, **kwargs):
        out = real(model, exps, null, name, *args, **kwargs)
        if name == "tubing":
            kept["tubing"] = [f for f, _ in out.values()]
        return out
    monkeypatch.setattr(S, "forms_on_window", spy)
    d = diagnose(c.start, exps)
    assert kept["tubing"] and all(f.get("segments", 1) > 1 for f in kept["tubing"]), kept
    assert d.verdict == "tubing", d.message
    fitted = d.model.effects["tubing"]
    # within 10 %, the bound where the data identify a length (0.1 % on the records
    # fitted whole)
    for sfx in ("a", "b"):
        assert fitted[f"length_{sfx}"] == pytest.approx(2.5, rel=0.10)
    assert fitted["segments"] > 1


def test_a_window_left_without_a_measured_sample_is_not_fitted_on(monkeypatch):
    """A held-out fold marks a block of every record missing; where that block is the whole
    window (ten 2 s tests, the window 0.4 s of each, the first of four blocks held out) the
    window's fit had no residual at all and crashed the diagnosis (``need at least one array to
    concatenate``). Such records are fitted whole."""
    from pneucore.analysis.diagnosis.evidence import masked
    true = model_preset("paper-4way")
    true["effects"] = {"piston_leakage": {"conductance": 1.5e-10}}
    exps = as_experiments(synthetic_experiments(true, seed=4))
    monkeypatch.setattr(C, "PREFIT_SECONDS", 0.4)      # the window: the first 0.2 s of each
    held = [masked(e, 0, 4)[0] for e in exps]          # the first quarter of each: missing
    assert C.window(held) is not None and C.prefit_window(held, 1) is None
    assert C.prefit_window(exps, 1) is not None
    m = S.with_effect(MODEL, "piston_leakage", {"conductance": 1e-11})
    spec = ParameterSpec("effects.piston_leakage.conductance", 1e-11, 0.0, 1e-8, True,
                         "kg/(s Pa)")
    cal = C.fit(m, held, [spec], max_nfev=10, compute_before=False, reweight=True)
    found = cal.values[spec.path]["value"]
    # the leak comes back from the three quarters left (white noise on 1,500 samples a signal)
    assert found == pytest.approx(1.5e-10, rel=0.1)
