"""``calibrate(model, experiments, parameters)`` recovers known parameters from synthetic data.

Truth: paper-4way with h = 40 W/(m^2 K), extension Coulomb friction 12 N and
a 2.5 kg moving mass; the fit starts from the preset (25, 8 N, 2 kg). The data
are the two diagnostic experiments (locked hold, free pulses) of
:func:`pneucore.data.synthetic.synthetic_experiments`.
"""
import functools
import json
import math

import numpy as np
import pytest

from pneucore import Model, model_preset
from pneucore.analysis.calibrate import calibrate
from pneucore.description.paths import set_values
from pneucore.data.synthetic import synthetic_experiments

TRUE = {"heat.coefficient": 40.0, "friction.extend.fc0": 12.0, "jack.moving_mass": 2.5}
BOUNDS = {"heat.coefficient": {"min": 0.1, "max": 200.0},
          "friction.extend.fc0": {"min": 0.0, "max": 100.0},
          "jack.moving_mass": {"min": 0.5, "max": 20.0}}

#: Recovered values within 2 % of the truth: with ~5000 samples at ~1 LSB noise the standard
#: errors are below 0.1 % of each value, so 2 % only fails on a wrong optimum or a biased model.
REL_TOL = 0.02
#: "Within a few standard errors": 4 sigma, probability 6e-5 per parameter for a Gaussian
#: estimate whose standard error is right.
N_SIGMA = 4.0


def truth_model():
    m = model_preset("paper-4way")
    m["heat"]["coefficient"] = TRUE["heat.coefficient"]
    m["friction"]["extend"]["fc0"] = TRUE["friction.extend.fc0"]
    m["jack"]["moving_mass"] = TRUE["jack.moving_mass"]
    return m


@functools.lru_cache(maxsize=None)
def data(seed):
    return synthetic_experiments(truth_model(), seed=seed)


@functools.lru_cache(maxsize=None)
def fitted(seed):
    return calibrate(model_preset("paper-4way"), data(seed), BOUNDS)


# ----------------------------------------------------------------- recovery

@pytest.mark.parametrize("seed", [0, 1, 2])
def test_recovers_known_parameters(seed):
    cal = fitted(seed)
    assert cal.success, cal.message
    assert set(cal.values) == set(TRUE)
    for path, want in TRUE.items():
        v = cal.values[path]
        assert abs(v["value"] - want) <= REL_TOL * want, (path, v)
        assert v["stderr"] > 0.0 and math.isfinite(v["stderr"]), (path, v)
        assert abs(v["value"] - want) <= N_SIGMA * v["stderr"], (path, v, want)
        assert v["min"] == BOUNDS[path]["min"] and v["max"] == BOUNDS[path]["max"]
        assert v["at_bound"] is False
    # the calibrated model carries the values
    m = cal.model
    assert m.heat.coefficient == cal.values["heat.coefficient"]["value"]
    assert m.friction.extend.fc0 == cal.values["friction.extend.fc0"]["value"]
    assert m.jack.moving_mass == cal.values["jack.moving_mass"]["value"]
    # untouched: the retraction friction
    assert m.friction.retract.fc0 == model_preset("paper-4way")["friction"]["retract"]["fc0"]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_error_after_is_below_error_before(seed):
    cal = fitted(seed)
    assert cal.error_after.overall < cal.error_before.overall
    # the truth sits at the noise floor; the start (3 parameters off by 25-60 %) far above it
    assert cal.error_after.overall < 0.1 * cal.error_before.overall
    for s in cal.error_after.errors:
        assert cal.error_after.errors[s] < cal.error_before.errors[s], s
    assert cal.aic < cal.aic_before and cal.bic < cal.bic_before


def test_correlations_symmetric_with_unit_diagonal():
    cal = fitted(0)
    paths = list(TRUE)
    assert set(cal.correlations) == set(paths)
    for a in paths:
        assert set(cal.correlations[a]) == set(paths)
        # a correlation matrix computed in floating point: symmetric and unit diagonal to 1e-9
        assert cal.correlations[a][a] == pytest.approx(1.0, abs=1e-9)
        for b in paths:
            assert cal.correlations[a][b] == pytest.approx(cal.correlations[b][a], abs=1e-9)
            assert -1.0 - 1e-9 <= cal.correlations[a][b] <= 1.0 + 1e-9


def test_information_criteria_are_finite_and_consistent():
    cal = fitted(0)
    for v in (cal.aic, cal.bic, cal.neg2_loglik, cal.aic_before, cal.bic_before):
        assert math.isfinite(v)
    assert cal.n_params == 3
    assert cal.n_data == sum(e["measurement"].n * len([s for s in ("p_a", "p_b", "x")
                                                      if s in e["measurement"].signals])
                             for e in data(0))
    # AIC = -2lnL + 2k, BIC = -2lnL + k ln N, with k counting one variance per
    # (experiment, signal) series too (5 series here)
    k = cal.n_params + 5
    assert cal.aic == pytest.approx(cal.neg2_loglik + 2 * k, rel=1e-12)
    assert cal.bic == pytest.approx(cal.neg2_loglik + k * math.log(cal.n_data), rel=1e-12)


def test_summary_is_json_with_the_documented_keys():
    s = fitted(0).summary()
    back = json.loads(json.dumps(s, allow_nan=False))
    for key in ("model", "values", "error_before", "error_after", "aic", "bic"):
        assert key in back, key
    for path in TRUE:
        assert {"value", "stderr"} <= set(back["values"][path])
    for key in ("error_before", "error_after"):
        assert {"errors", "overall"} <= set(back[key])
    # the summary's model is a valid model JSON with the calibrated values
    m = Model.from_dict(back["model"])
    assert m.heat.coefficient == pytest.approx(back["values"]["heat.coefficient"]["value"])


# ----------------------------------------------------------------- statistics over seeds

@pytest.mark.parametrize("initial", ["given", "estimated"])
def test_standard_errors_match_the_scatter_over_seeds(initial):
    """Over 10 noise realisations, (estimate - truth) / stderr must scatter like N(0, 1).

    ``given``: the experiments carry the true initial pressures; ``estimated``: the default,
    the initial pressures are taken from the first measured samples. Both describe the same
    data and the same true model, so the standard errors must hold in both.
    """
    z = []
    for seed in range(10):
        exps = synthetic_experiments(truth_model(), seed=100 + seed)
        if initial == "given":
            for e in exps:
                e["scenario"]["initial"] = {"p_a": 1.013e5, "p_b": 1.013e5}
        cal = calibrate(model_preset("paper-4way"), exps, BOUNDS)
        z.append([(cal.values[p]["value"] - TRUE[p]) / cal.values[p]["stderr"] for p in TRUE])
    z = np.array(z)
    rms = np.sqrt(np.mean(z ** 2, axis=0))
    # rms of 10 N(0,1) draws: 1 +- 0.22; below 2 is a 4-sigma bound. |z| <= 4.5: the largest of
    # 30 N(0,1) draws exceeds 4.5 with probability 2e-4.
    assert np.all(rms < 2.0), dict(zip(TRUE, np.round(rms, 2)))
    assert np.all(np.abs(z) <= 4.5), np.round(z, 2).tolist()


def test_standard_errors_hold_in_coloured_noise():
    """Low-pass filtered rig noise (correlation time 20 ms, ~40 samples): the standard
    errors account for it through the residuals' autocorrelation time, so over 10 noise
    realisations (estimate - truth) / stderr still scatters like N(0, 1); the white-noise
    errors (stderr / sqrt(tau)) would be several times too small.

    The initial pressures are given: estimated from the quiet window before the first
    command, they carry the correlated noise's error (~300 Pa that does not average out),
    an extra uncertainty the standard errors do not include (measured: rms z of the heat
    coefficient 3.5 instead of 1.5; see the module docstring of pneucore.analysis.calibrate)."""
    z, z_white = [], []
    for seed in range(10):
        exps = synthetic_experiments(truth_model(), seed=200 + seed, noise_corr_time=0.02)
        for e in exps:
            e["scenario"]["initial"] = {"p_a": 1.013e5, "p_b": 1.013e5}
        cal = calibrate(model_preset("paper-4way"), exps, BOUNDS)
        taus = np.array(list(cal.autocorrelation_time.values()))
        assert np.all(taus > 5.0), cal.autocorrelation_time
        # the white-noise error of a joint fit: each series' information scaled back up by tau;
        # with comparable tau across series, stderr / sqrt(mean tau) is that figure
        shrink = math.sqrt(taus.mean())
        z.append([(cal.values[p]["value"] - TRUE[p]) / cal.values[p]["stderr"] for p in TRUE])
        z_white.append([(cal.values[p]["value"] - TRUE[p]) / (cal.values[p]["stderr"] / shrink)
                        for p in TRUE])
    rms = np.sqrt(np.mean(np.square(z), axis=0))
    rms_white = np.sqrt(np.mean(np.square(z_white), axis=0))
    # same bounds as the white-noise test above (rms of 10 N(0,1) draws: 1 +- 0.22), plus a
    # lower bound: errors inflated beyond need would give rms << 1 (0.4 is 3 sigma below 1)
    assert np.all(rms < 2.0) and np.all(rms > 0.4), dict(zip(TRUE, np.round(rms, 2)))
    # and the white count is refuted by the same data: its rms is several times too large
    assert np.all(rms_white > 2.5), dict(zip(TRUE, np.round(rms_white, 2)))


@functools.lru_cache(maxsize=None)
def mixed_scale_fits():
    """A heat coefficient (~25) fitted jointly with a leak conductance (~1e-10), and alone.

    Truth: paper-4way (h = 25) with a 1.5e-10 kg/(s Pa) piston leak; start h = 15, G = 1e-10.
    ``alone`` fits h on the same data with the leak held at the truth.
    """
    truth = model_preset("paper-4way")
    truth["effects"] = {"piston_leakage": {"conductance": 1.5e-10}}
    exps = synthetic_experiments(truth, seed=5)
    start = model_preset("paper-4way")
    start["heat"]["coefficient"] = 15.0
    start["effects"] = {"piston_leakage": {"conductance": 1e-10}}
    joint = calibrate(start, exps, {"heat.coefficient": {"min": 0.1, "max": 200.0},
                                    "effects.piston_leakage.conductance": {}})
    alone = calibrate(start, exps, {"heat.coefficient": {"min": 0.1, "max": 200.0},
                                    "effects.piston_leakage.conductance":
                                        {"value": 1.5e-10, "vary": False}})
    return joint, alone


def test_mixed_scale_parameters_are_recovered():
    joint, _ = mixed_scale_fits()
    assert joint.success, joint.message
    assert joint.values["heat.coefficient"]["value"] == pytest.approx(25.0, rel=REL_TOL)
    assert joint.values["effects.piston_leakage.conductance"]["value"] == \
        pytest.approx(1.5e-10, rel=REL_TOL)


def test_mixed_scale_parameters_get_honest_standard_errors():
    """The standard error of h must not collapse because the other parameter's scale is 1e11
    times smaller: compared with h fitted alone, the joint standard error can only be larger
    (one more free parameter) and, for a correlation well below 1, of the same order (x3)."""
    joint, alone = mixed_scale_fits()
    se_joint = joint.values["heat.coefficient"]["stderr"]
    se_alone = alone.values["heat.coefficient"]["stderr"]
    assert se_alone > 0
    # 0.9: the two standard errors come from Jacobians at slightly different optima
    assert 0.9 * se_alone <= se_joint <= 3.0 * se_alone, (se_joint, se_alone)
    g = joint.values["effects.piston_leakage.conductance"]
    assert abs(g["value"] - 1.5e-10) <= N_SIGMA * g["stderr"] or \
        abs(g["value"] - 1.5e-10) <= 1e-3 * 1.5e-10, g


def test_mixed_scale_correlations_symmetric_with_unit_diagonal():
    joint, _ = mixed_scale_fits()
    c = joint.correlations
    a, b = "heat.coefficient", "effects.piston_leakage.conductance"
    # floating-point correlation matrix: symmetric, unit diagonal, inside [-1, 1], to 1e-9
    assert c[a][b] == pytest.approx(c[b][a], abs=1e-9), c
    assert -1.0 - 1e-9 <= c[a][b] <= 1.0 + 1e-9 and -1.0 - 1e-9 <= c[b][a] <= 1.0 + 1e-9, c
    assert c[a][a] == pytest.approx(1.0, abs=1e-9) and c[b][b] == pytest.approx(1.0, abs=1e-9)


# ----------------------------------------------------------------- valve scale paths

def test_valve_edge_conductance_scale():
    """Truth: the P-A edge passes 30 % more than the preset table; fit its scale factor."""
    base = Model.from_dict(model_preset("paper-4way"))
    truth = set_values(base, {"valve.ports.P-A.C": 1.3})
    exps = synthetic_experiments(truth, seed=4)
    cal = calibrate(model_preset("paper-4way"), exps, {"valve.ports.P-A.C": {"min": 0.2, "max": 5.0}})
    assert cal.success, cal.message
    v = cal.values["valve.ports.P-A.C"]
    assert v["unit"] == "-" and v["initial"] == 1.0
    assert v["value"] == pytest.approx(1.3, rel=REL_TOL)
    # the calibrated model's table is the preset table scaled; the other edges are untouched
    got = cal.model.valve.ports["P-A"].C
    want = [v["value"] * c for c in base.valve.ports["P-A"].C]
    assert got == pytest.approx(want, rel=1e-12)
    for edge in ("A-R", "P-B", "B-R"):
        assert cal.model.valve.ports[edge].C == base.valve.ports[edge].C
    assert cal.error_after.overall < cal.error_before.overall


# ----------------------------------------------------------------- errors and budgets

@pytest.mark.parametrize("path", ["jack.nonsense", "effects.no_such_effect.x",
                                  "effects.piston_leakage.nope", "valve.ports.X-Y.C",
                                  "nosection.value"])
def test_unknown_path_names_the_parameter(path):
    with pytest.raises(ValueError, match=r"parameters\." + path.replace(".", r"\.")):
        calibrate(model_preset("paper-4way"), data(0), {path: {}})


@pytest.mark.parametrize("lo, hi", [(50.0, 50.0), (60.0, 50.0)])
def test_bounds_min_not_below_max_raise(lo, hi):
    with pytest.raises(ValueError, match=r"parameters\.heat\.coefficient"):
        calibrate(model_preset("paper-4way"), data(0), {"heat.coefficient": {"min": lo, "max": hi}})


def test_tiny_budget_reports_failure_but_finite_values():
    cal = calibrate(model_preset("paper-4way"), data(0), BOUNDS, max_nfev=1)
    assert cal.success is False
    assert isinstance(cal.message, str) and cal.message
    for path in TRUE:
        v = cal.values[path]
        assert math.isfinite(v["value"]) and math.isfinite(v["stderr"]), (path, v)
        assert BOUNDS[path]["min"] <= v["value"] <= BOUNDS[path]["max"]
    for x in (cal.aic, cal.bic, cal.error_after.overall, cal.error_before.overall):
        assert math.isfinite(x)
    # never worse than the start: the best point found is returned
    assert cal.error_after.overall <= cal.error_before.overall
    s = json.loads(json.dumps(cal.summary(), allow_nan=False))
    assert s["success"] is False
    for path in TRUE:
        assert s["values"][path]["value"] is not None and s["values"][path]["stderr"] is not None


# ----------------------------------------------------------------- long records

def long_records(seconds=8.0, seed=3):
    """The locked hold plus a free record of a machine cycling once a second for ``seconds``."""
    from pneucore.data.synthetic import diagnostic_scenarios, synthesize
    from pneucore.description.scenario import pulse_train
    true = truth_model()
    hold = diagnostic_scenarios(true)["locked-hold"]
    events = [e for k in range(int(seconds)) for e in ((k + 0.1, 0.7), (k + 0.55, -0.7))]
    cyc = {"duration": seconds, "sample_period": 0.001, "command": pulse_train(events, 0.06),
           "locked": False, "x0": 0.05}
    return [{"name": "hold", "scenario": {"locked": True, "x0": hold["x0"]},
             "measurement": synthesize(true, hold, ("p_a", "p_b"), None, 12, seed, "hold")},
            {"name": "cycling", "scenario": {"locked": False, "x0": 0.05},
             "measurement": synthesize(true, cyc, ("p_a", "p_b", "x"), None, 12, seed + 1, "cyc")}]


def test_long_records_are_fitted_from_a_window_to_the_same_optimum(monkeypatch):
    """9 s of records (over PREFIT_SECONDS): fitted first on their first seconds, then on the
    full records with Broyden-updated Jacobians; the truth is recovered as with short records,
    and the result is the optimum the plain fit finds on the full records."""
    from pneucore.analysis import calibrate as C
    from pneucore.data.experiment import as_experiments
    exps = long_records()
    assert C.window(as_experiments(exps)) is not None   # the windowed path is taken
    cal = calibrate(model_preset("paper-4way"), exps, BOUNDS)
    assert cal.success, cal.message
    for path, want in TRUE.items():
        v = cal.values[path]
        # within a few standard errors (REL_TOL assumes errors below 0.1 %; here the one hold
        # test leaves h a standard error of 1.6 %)
        assert abs(v["value"] - want) <= N_SIGMA * v["stderr"], (path, v, want)
    monkeypatch.setattr(C, "PREFIT_SECONDS", math.inf)
    plain = calibrate(model_preset("paper-4way"), exps, BOUNDS)
    for path in TRUE:
        a, b = cal.values[path], plain.values[path]
        # the same optimum: within a tenth of a standard error (the optimisers stop at
        # xtol = 1e-8 in scaled units, far inside it; a different optimum is many errors away)
        assert abs(a["value"] - b["value"]) <= 0.1 * b["stderr"], (path, a, b)
        # the covariance is differenced afresh at the end point either way
        assert a["stderr"] == pytest.approx(b["stderr"], rel=0.05), (path, a, b)


def test_a_warm_refit_of_long_records_goes_straight_to_its_polish(monkeypatch):
    """A refit started from a fit's end point on the same long records (``warm``: the diagnosis
    puts back a base parameter a joint fit left within 2 % of its catalogue value and refits
    the rest from there) skips the window's fit and ends at the optimum of the plain fit on the
    full records, at least as near as the windowed fit from the model as given."""
    from pneucore.analysis import calibrate as C
    from pneucore.data.experiment import as_experiments
    from pneucore.description.paths import parse_parameters
    exps = as_experiments(long_records())
    first = C.fit(Model.from_dict(model_preset("paper-4way")), exps,
                  parse_parameters(Model.from_dict(model_preset("paper-4way")), dict(BOUNDS)),
                  compute_before=False)
    # the mass put back 1 % from where the first fit left it (the diagnosis's RECAL_MIN is 2 %)
    # and held there; heat and friction refitted from the first fit's values
    two = {p: BOUNDS[p] for p in ("heat.coefficient", "friction.extend.fc0")}
    held = set_values(Model.from_dict(model_preset("paper-4way")),
                      {"jack.moving_mass": 1.01 * first.values["jack.moving_mass"]["value"]})
    start = set_values(held, {p: first.values[p]["value"] for p in two})
    fits = []
    real_fit = C.fit

    def counting(model, experiments, *a, **k):
        fits.append(sum(e.measurement.duration for e in experiments))
        return real_fit(model, experiments, *a, **k)
    monkeypatch.setattr(C, "fit", counting)
    warm = counting(start, exps, parse_parameters(start, two), compute_before=False, warm=True)
    assert fits == [9.0], fits                    # the full records only: no window's fit
    assert warm.success, warm.message
    fits.clear()
    cold = counting(held, exps, parse_parameters(held, two), compute_before=False)
    assert fits == [9.0, C.PREFIT_SECONDS], fits  # the usual path: the window's fit first
    monkeypatch.setattr(C, "PREFIT_SECONDS", math.inf)
    plain = C.fit(held, exps, parse_parameters(held, two), compute_before=False)
    for path in two:
        w, c, p = (f.values[path]["value"] for f in (warm, cold, plain))
        # the plain fit's optimum: within a tenth of a standard error (a different optimum is
        # many errors away; the polish stops at xtol = 1e-8 in scaled units), and no farther
        # than the windowed fit ends (plus 1 % of an error: the two polishes' own stops)
        se = plain.values[path]["stderr"]
        assert abs(w - p) <= 0.1 * se, (path, w, p, se)
        assert abs(w - p) <= abs(c - p) + 0.01 * se, (path, w, c, p, se)
