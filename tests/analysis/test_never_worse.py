"""Refine and calibrate never return a result worse than their start (issue 39, item 3).

On the synthetic record shaped like the real one (a vertical 25 mm jack, short pulses of a 3/2
valve, B vented, chamber A's pressure only, the command where the valve switched): a round
whose proposal raises the overall error, even by less than a percent, is said and not taken;
an initial state that raises it is not taken either; a calibration whose fitted values raise
the overall error keeps the model as given and says so.
"""
from types import SimpleNamespace

import pytest

import pneucore.analysis.history as H
from loop_record import effective_edges, record, truth_dict
from pneucore.analysis.calibrate import calibrate
from pneucore.analysis.compare import compare
from pneucore.data.experiment import Experiment
from pneucore.description.model import Model


def _experiments():
    cmd = [[0.0, 0.0]]
    for a, b in effective_edges():
        cmd += [[a, 1.0], [b, 0.0]]
    return [Experiment(record(), {"command": cmd}, "vertical-25mm")]


def _fake_diagnosis(model, initial_state=()):
    return SimpleNamespace(verdict=None, recalibrate=["supply.pressure"], model=model,
                           initial_state=list(initial_state), message="fake round.", dropped=[],
                           ranking=[], remaining={})


def _start():
    d = truth_dict()
    d["supply"]["pressure"] *= 0.97          # a little off: the error above the floor
    return Model.from_dict(d)


def test_a_proposal_worse_by_less_than_a_percent_is_not_taken(monkeypatch):
    exps = _experiments()
    start = _start()
    e0 = compare(start, exps).overall
    # a proposal a hair worse (0.9997 of the start's supply moves the error up a little)
    prop = start.copy()
    prop.supply.pressure *= 0.9997
    e1 = compare(prop, exps).overall
    assert e0 < e1 < 1.01 * e0        # the premise: within the old 1 % tolerance
    monkeypatch.setattr(H, "diagnose", lambda *a, **k: _fake_diagnosis(prop.copy()))
    final, history, diags = H.refine(start, exps, max_rounds=2, validated=True)
    assert final.supply.pressure == start.supply.pressure
    assert len(history.versions) == 1
    assert "Not applied" in diags[-1].message and "keeps the better" in diags[-1].message


def test_an_initial_state_that_raises_the_error_is_not_taken(monkeypatch):
    exps = _experiments()
    start = _start()
    # a "fitted" initial chamber pressure far from the record's first samples
    bad = [{"experiment": "vertical-25mm", "path": "initial.p_a", "after": 4.0e5,
            "label": "p_a(0)"}]
    d = _fake_diagnosis(None, bad)
    d.recalibrate = []
    monkeypatch.setattr(H, "diagnose", lambda *a, **k: d)
    final, history, diags = H.refine(start, exps, max_rounds=2, validated=True)
    assert len(history.versions) == 1 and "Not applied" in diags[-1].message


def test_calibrate_answers_the_start_when_the_fit_raised_the_error(monkeypatch):
    import pneucore.analysis.calibrate as C
    exps = _experiments()
    start = Model.from_dict(truth_dict())
    real_fit = C.fit

    def worse_fit(model, experiments, specs, **kw):
        # the fit as it is, its point then moved off (the optimiser stopped by its budget on a
        # point its weighted objective prefers and Eq. 25 does not)
        cal = real_fit(model, experiments, specs, **kw)
        cal.model = model.copy()
        cal.model.supply.pressure *= 0.9
        cal.error_after = compare(cal.model, experiments)
        cal.values["supply.pressure"]["value"] = cal.model.supply.pressure
        return cal

    monkeypatch.setattr(C, "fit", worse_fit)
    cal = calibrate(start, exps, {"supply.pressure": {"min": 2e5, "max": 8e5}}, max_nfev=3)
    s = cal.summary()
    assert s["error_after"]["overall"] <= s["error_before"]["overall"]
    assert s["kept_start"] and "the model as given is kept" in s["message"]
    assert s["values"]["supply.pressure"]["value"] == start.supply.pressure
    assert s["values"]["supply.pressure"]["fitted"] == pytest.approx(0.9 * start.supply.pressure)
    assert s["model"] == start.to_dict()


def test_kept_better_on_a_worse_fit():
    from pneucore.analysis.calibrate import Calibration, kept_better
    start = Model.from_dict(truth_dict())
    worse = start.copy()
    worse.supply.pressure *= 0.8
    before = SimpleNamespace(overall=0.05, errors={}, phases={}, piston_phases={}, windows=[])
    after = SimpleNamespace(overall=0.07, errors={}, phases={}, piston_phases={}, windows=[])
    cal = Calibration(worse, {"supply.pressure": {"value": 4.6e5, "initial": 5.8e5}}, {}, before,
                      after, 1.0, 2.0, 0.0, 10, 1, False, "did not converge", 4,
                      aic_before=0.5, bic_before=1.5)
    out = kept_better(start, cal)
    assert out.kept_start and out.model is start and out.error_after is before
    assert out.values["supply.pressure"] == {"value": 5.8e5, "initial": 5.8e5, "fitted": 4.6e5}
    assert "5.00 % to 7.00 %" in out.message and out.bic == 1.5
