"""Autocorrelated residuals (pneucore/autocorrelation.py) and the diagnosis on coloured noise.

Oracle: the integrated autocorrelation time of AR(1) noise with coefficient
phi is (1 + phi) / (1 - phi) (Priestley, Spectral Analysis and Time Series,
1981, Sect. 5.3); white noise has 1. Diagnosis controls: a rig whose noise is
low-pass filtered (correlation time 50 ms) hides no effect, and the diagnosis
must not name one, although the white-noise LR of its best candidate exceeds
the significance threshold; an effect that is there is still named.
"""
import math

import numpy as np
import pytest
from scipy import stats
from scipy.signal import lfilter

from pneucore import model_preset
from pneucore.autocorrelation import (autocorrelation, effective_lr, integrated_time,
                                      times_report)
from pneucore.diagnose import ALPHA, diagnose
from pneucore.synthetic import colored_noise, synthetic_experiments

from test_diagnosis import base_model, describe, truth_model

#: Correlation time of the coloured rig noise [s]: a ~3 Hz first-order transducer filter
CORR_TIME = 0.05


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.9, 0.95])
def test_integrated_time_of_ar1_noise(phi):
    rng = np.random.default_rng(1)
    x = lfilter([1.0], [1.0, -phi], rng.normal(size=400_000))
    tau = (1 + phi) / (1 - phi)
    # the estimator's relative standard error is ~sqrt(4 M / n) with a summation length M of a
    # few tau: 1.5 % at phi = 0.95 on 4e5 samples; 6 % is 4 sigma
    assert integrated_time(x) == pytest.approx(tau, rel=0.06)


def test_integrated_time_edge_cases():
    assert integrated_time(np.full(100, 3.0)) == 1.0          # constant: no information lost
    assert integrated_time([1.0, 2.0]) == 1.0                  # too short to say
    assert integrated_time(np.arange(1000.0)) <= 1000.0        # a ramp: bounded by n
    rho = autocorrelation(np.r_[np.random.default_rng(0).normal(size=500), np.nan])
    assert rho.shape == (500,) and rho[0] == pytest.approx(1.0)


def test_colored_noise_has_its_standard_deviation_and_correlation():
    rng = np.random.default_rng(2)
    e = colored_noise(rng, 300.0, 400_000, 1e-3, 0.02)
    # sampling error of a standard deviation of correlated noise: ~sqrt(tau / 2n) ~ 0.7 %
    assert e.std() == pytest.approx(300.0, rel=0.03)
    assert np.corrcoef(e[:-1], e[1:])[0, 1] == pytest.approx(math.exp(-1e-3 / 0.02), abs=0.005)


def test_effective_lr_counts_each_series_by_n_over_tau():
    rss0 = [("e", "p_a", 4.0, 1000), ("e", "x", 2.0, 500)]
    rss1 = [("e", "p_a", 1.0, 1000), ("e", "x", 2.0, 500)]
    white, n_white = effective_lr(rss0, rss1)
    assert white == pytest.approx(1000 * math.log(4.0)) and n_white == 1500
    taus = [(("e", "p_a"), 20.0), (("e", "x"), 5.0)]
    lr, n_eff = effective_lr(rss0, rss1, taus)
    assert lr == pytest.approx(50 * math.log(4.0)) and n_eff == pytest.approx(150.0)
    with pytest.raises(ValueError):
        effective_lr(rss0, rss1[::-1])
    with pytest.raises(ValueError):
        effective_lr(rss0, rss1, taus[::-1])


def test_times_report_keeps_repeated_experiment_names_apart():
    taus = [(("run", "p_a"), 3.0), (("run", "p_a"), 4.0), (("run", "x"), 1.0)]
    assert times_report(taus) == {"run/p_a": 3.0, "run/p_a#2": 4.0, "run/x": 1.0}


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_coloured_noise_alone_gives_no_verdict(seed):
    m = model_preset("paper-4way")
    exps = synthetic_experiments(m, seed=seed, noise_corr_time=CORR_TIME)
    d = diagnose(m, exps)
    assert d.verdict is None, describe(d)
    best = d.ranking[0]
    k = len(best["params"])
    threshold = stats.chi2.isf(ALPHA / len(d.ranking), k)
    # the data are adversarial: counted as white, the best candidate would pass the LR test
    # (measured LR_white 250-350 against a threshold of ~16)
    assert best["lr_statistic_white"] > threshold
    assert best["lr_statistic"] < best["lr_statistic_white"] / 5
    taus = best["autocorrelation_time"]
    assert all(t > 5.0 for t in taus.values())    # a 50 ms correlation is ~100 samples


@pytest.mark.parametrize("name", ["piston_leakage", "valve_spool_dynamics", "heat_exchange"])
def test_hidden_effect_is_still_named_in_coloured_noise(name):
    exps = synthetic_experiments(truth_model(name), seed=5, noise_corr_time=CORR_TIME)
    d = diagnose(base_model(name), exps)
    assert d.verdict == name, describe(d)


def test_white_noise_counts_every_sample():
    """With white noise the alternative's residual is white: tau ~ 1, LR unchanged."""
    exps = synthetic_experiments(truth_model("piston_leakage"), seed=5)
    d = diagnose(base_model("piston_leakage"), exps)
    best = d.ranking[0]
    assert best["effect"] == "piston_leakage"
    # Geyer's estimate on 1000 white samples is 1.06 +- 0.1 (measured over 200 records)
    assert all(t < 1.5 for t in best["autocorrelation_time"].values())
    assert best["lr_statistic"] > 0.6 * best["lr_statistic_white"]
