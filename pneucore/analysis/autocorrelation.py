"""Autocorrelated residuals: how many independent samples a residual series is worth.

The likelihood-ratio test and BIC of the diagnosis count every sample as an
independent observation. A rig's noise is rarely white: transducer filters,
drift and vibration make neighbouring samples alike, and then a 1 kHz record
of 1 s holds far fewer than 1000 independent values. Counted as white, such
noise makes any flexible effect look overwhelmingly significant (the LR
statistic is inflated by the integrated autocorrelation time).

The integrated autocorrelation time of a stationary series,

.. math:: \\tau = 1 + 2 \\sum_{k \\ge 1} \\rho_k ,

is the factor by which autocorrelation inflates the variance of a mean
(Priestley, *Spectral Analysis and Time Series*, 1981, Sect. 5.3); ``n / tau``
is the effective sample size. It is estimated with Geyer's initial monotone
sequence estimator (Geyer, "Practical Markov chain Monte Carlo", Statistical
Science 7, 1992, Sect. 3.3), which needs no choice of window: sums of
adjacent autocorrelation pairs are accumulated while they stay positive and
decreasing.
"""
from __future__ import annotations

import math

import numpy as np


def autocorrelation(r):
    """Sample autocorrelation ``rho_k``, k = 0 .. n-1, of a series (mean removed, FFT).

    Parameters
    ----------
    r : array_like
        Series (any unit; non-finite values are dropped)

    Returns
    -------
    rho : ndarray
        Autocorrelation [-], ``rho[0] = 1`` (all zeros for a constant series)
    """
    r = np.asarray(r, float)
    r = r[np.isfinite(r)]
    n = r.shape[0]
    if n == 0:
        return np.zeros(0)
    d = r - r.mean()
    var = float(d @ d)
    if var <= 0.0:
        return np.zeros(n)
    size = 1 << (2 * n - 1).bit_length()
    f = np.fft.rfft(d, size)
    acov = np.fft.irfft(f * np.conj(f), size)[:n]
    return acov / var


def integrated_time(r):
    """Integrated autocorrelation time ``tau = 1 + 2 sum rho_k`` [samples].

    The larger of Geyer's initial monotone sequence estimate and the AR(1)
    value ``(1 + rho_1) / (1 - rho_1)``: on a short record Geyer's sum is
    biased low, which would leave the LR test anti-conservative.

    Parameters
    ----------
    r : array_like
        Series, e.g. measured minus simulated

    Returns
    -------
    tau : float
        In ``[1, n]``; 1 for white noise, ``(1 + phi) / (1 - phi)`` for AR(1)
        noise with coefficient ``phi``; 1 for a constant or too short series

    Examples
    --------
    AR(1) noise with phi = 0.9 has tau = 1.9 / 0.1 = 19:

    >>> rng = np.random.default_rng(0)
    >>> e = rng.normal(size=200_000)
    >>> x = np.empty_like(e); x[0] = e[0]
    >>> for i in range(1, e.size): x[i] = 0.9 * x[i - 1] + e[i]
    >>> round(integrated_time(x))
    19
    """
    rho = autocorrelation(r)
    n = rho.shape[0]
    if n < 4 or rho[0] == 0.0:
        return 1.0
    # AR(1) value from the lag-1 correlation: Geyer's sum is biased low when the record
    # spans few correlation times (measured: 80 instead of 199 for phi = 0.99 and
    # n = 1000), the lag-1 correlation much less (132); the larger of the two is kept
    phi = min(max(rho[1], 0.0), 1.0 - 1e-12)
    tau_ar1 = (1.0 + phi) / (1.0 - phi)
    total = 0.0
    prev = math.inf
    for m in range(n // 2):
        gamma = rho[2 * m] + rho[2 * m + 1]
        if gamma <= 0.0:
            break
        gamma = min(gamma, prev)          # initial monotone sequence
        total += gamma
        prev = gamma
    return float(min(max(2.0 * total - 1.0, tau_ar1, 1.0), n))


def residual_times(replays):
    """``tau`` of each residual series, measured minus simulated, in series order.

    Parameters
    ----------
    replays : list
        Replays of experiments (:func:`pneucore.analysis.compare.replay`)

    Returns
    -------
    taus : list
        ``((experiment name, signal), tau [samples])`` per series, in the order
        of the replays and their measured signals (the order of ``Objective.rss``)
    """
    out = []
    for rp in replays:
        for s in rp.measured:
            d = rp.measured[s] - rp.simulated[s]
            out.append(((rp.experiment.name, s), integrated_time(d)))
    return out


def times_report(taus):
    """``{"experiment/signal": tau}`` for a JSON report (repeated names get ``#k``)."""
    out = {}
    for (e, s), t in taus:
        key = f"{e}/{s}"
        k = 2
        while key in out:
            key = f"{e}/{s}#{k}"
            k += 1
        out[key] = t
    return out


def effective_lr(rss_null, rss_alt, taus=None):
    """Likelihood-ratio statistic with each series counted by its effective sample size.

    With one Gaussian variance per series, ``-2 ln(L0/L1) = sum n log(rss0 / rss1)``;
    here each term is weighted ``n / tau`` (the quasi-likelihood of
    autocorrelated errors, whose information is ``tau`` times smaller).

    Parameters
    ----------
    rss_null, rss_alt : list
        ``(experiment, signal, rss, n)`` per series, same order
    taus : list or None
        ``((experiment, signal), tau)`` per series in the same order
        (:func:`residual_times`); None counts every sample (white noise)

    Returns
    -------
    lr : float
        Effective LR statistic (may be negative if the alternative fits worse)
    n_eff : float
        Total effective number of samples
    """
    if len(rss_null) != len(rss_alt) or (taus is not None and len(taus) != len(rss_null)):
        raise ValueError("rss lists and autocorrelation times are not aligned")
    lr = 0.0
    n_eff = 0.0
    for i, ((e0, s0, r0, n), (e1, s1, r1, _)) in enumerate(zip(rss_null, rss_alt)):
        if (e0, s0) != (e1, s1) or (taus is not None and taus[i][0] != (e0, s0)):
            raise ValueError("rss lists and autocorrelation times are not aligned")
        if n == 0:
            continue
        w = n / (taus[i][1] if taus is not None else 1.0)
        lr += w * math.log(max(r0, 1e-300) / max(r1, 1e-300))
        n_eff += w
    return lr, n_eff
