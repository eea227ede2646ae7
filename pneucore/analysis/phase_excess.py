"""Why a phase's error stands above the noise: an offset, a drift, a lag, or none of them.

The comparison's per-phase errors (:func:`pneucore.analysis.metrics.phase_errors`) say how
much the model misses in each phase, not how. Here the residual of one signal within one phase
(model minus measurement) is split into the three shapes an engineer acts on differently:

- a constant **offset** (a wrong initial state, a sensor's zero): the residual's mean;
- a **drift** (a leak, heat exchange): a straight line in time on top of the offset;
- a **lag** (valve timing, a dead time): the model's signal shifted in time by ``tau``. For a
  model that runs ``tau`` late, ``sim(t) = meas(t - tau)``, so to first order in ``tau`` the
  residual is ``-tau d(sim)/dt`` (the model's derivative, smooth where the measurement's is noisy).

Each shape is fitted by least squares alone (with an offset beside the drift and the lag) and
judged by the share of the *excess* energy it explains: the residual's energy less what white
noise of the measured level (:func:`pneucore.analysis.metrics.noise_sigma`) would put there.
"""
from __future__ import annotations

import math

import numpy as np

from pneucore.data.measurement import SIGNAL_UNITS
from pneucore.description.units import difference_shown

#: A residual whose RMS is below this many noise sigmas is within the noise. White noise alone
#: gives an RMS of about 1 sigma; over 20 samples (the fewest a phase is judged on) its RMS
#: exceeds 1.5 sigma with odds below 1 in 1,000 (chi-square, 20 degrees of freedom), and 2
#: leaves room for a noise level estimated 30 % low
WITHIN_NOISE = 2.0
#: A shape explains the excess when its fit leaves less than this share of it: 90 %, so that a
#: straight ramp (of which a constant offset explains exactly 3/4) is called a drift, not an offset
EXPLAINS = 0.9
#: The fewest samples a phase is judged on: fewer say nothing reliable of a shape [-]
MIN_SAMPLES = 20
#: The samples at the phase's start whose mean residual is reported (the initial state) [-]
START_SAMPLES = 20

#: The longest shift taken for a timing error [s]: valves switch in a few ms to some tens of ms
#: (catalogue response times of 5 to 30 ms); a fitted shift beyond this is no lag but another
#: shape, or a signal too flat for a shift to show (a phase where nothing moves)
LAG_AT_MOST = 0.05



def _fit(r, cols):
    """Least-squares fit of ``r`` on the columns; returns (coefficients, fitted)."""
    a = np.column_stack(cols)
    scale = np.linalg.norm(a, axis=0)
    scale[scale == 0] = 1.0
    coef, *_ = np.linalg.lstsq(a / scale, r, rcond=1e-10)
    coef = coef / scale
    return coef, a @ coef


def explain_residual(t, residual, sigma, simulated=None, derivative=None):
    """Split one phase's residual into offset, drift and lag, and say which explains its excess.

    Parameters
    ----------
    t : array_like
        Sample times of the phase [s]
    residual : array_like
        Model minus measurement at those times (unit of the signal, SI); NaN samples skipped
    sigma : float
        White measurement noise of the signal (same unit as the residual)
    simulated : array_like or None
        The model's signal at those times (same unit), for the lag; None: no lag fitted
    derivative : array_like or None
        The model's time derivative at those times [unit of the signal / s]; None: from
        ``simulated`` by finite differences (only right on one contiguous stretch)

    Returns
    -------
    explanation : dict
        ``n`` samples [-]; ``rms`` of the residual (unit of the signal); ``sigma`` (same);
        ``ratio`` rms / sigma [-]; ``offset`` the mean residual (unit); ``start_offset`` the mean
        residual over the first :data:`START_SAMPLES` samples (unit) and ``start_sigmas`` its
        size in its own standard errors [-]; ``drift`` the slope of the offset-and-drift fit
        [unit/s]; ``lag`` the model's delay of the offset-and-lag fit [s] (positive: the model
        late; None when none fits between half a sample step and :data:`LAG_AT_MOST`); ``explained`` the share of the
        excess energy each of ``offset``, ``drift`` and ``lag`` explains [-]; ``cause`` one of
        ``noise``, ``offset``, ``drift``, ``lag``, ``shape`` (none of the three), ``too_few`` [-]

    Examples
    --------
    A pressure 0.1 bar high from the start, with 300 Pa of noise: an offset

    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(200) * 1e-3
    >>> e = explain_residual(t, 1e4 + rng.normal(0, 300, 200), 300.0)
    >>> e["cause"], round(e["offset"] / 1e4, 2)
    ('offset', 1.0)
    """
    t = np.asarray(t, float)
    r = np.asarray(residual, float)
    ok = np.isfinite(t) & np.isfinite(r)
    sim = None
    if derivative is not None:
        dsim = np.asarray(derivative, float)
        ok &= np.isfinite(dsim)
    elif simulated is not None:
        sim = np.asarray(simulated, float)
        ok &= np.isfinite(sim)
    t, r = t[ok], r[ok]
    n = int(r.size)
    sigma = float(sigma)
    out = {"n": n, "sigma": sigma, "rms": None, "ratio": None, "offset": None,
           "start_offset": None, "start_sigmas": None, "drift": None, "lag": None,
           "explained": {}, "cause": "too_few"}
    if n < MIN_SAMPLES:
        return out
    if derivative is not None:
        dsim = dsim[ok]
    elif sim is not None:
        dsim = np.gradient(sim[ok], t)
    else:
        dsim = None
    energy = float(np.sum(r * r))
    rms = math.sqrt(energy / n)
    ratio = rms / sigma if sigma > 0 else math.inf
    k = min(START_SAMPLES, n)
    start = float(np.mean(r[:k]))
    out.update(rms=rms, ratio=ratio, offset=float(np.mean(r)), start_offset=start,
               start_sigmas=abs(start) / (sigma / math.sqrt(k)) if sigma > 0 else math.inf)
    ones = np.ones(n)
    tc = t - t.mean()
    (_, slope), fit_drift = _fit(r, [ones, tc])
    excess = max(energy - n * sigma * sigma, 1e-300)
    left = {"offset": energy - n * out["offset"] ** 2,
            "drift": float(np.sum((r - fit_drift) ** 2))}
    out["drift"] = float(slope)
    if dsim is not None and np.any(dsim != 0):
        (_, minus_tau), fit_lag = _fit(r, [ones, -dsim])
        # a shift under half a sample step is below what the record's time base resolves
        step = float(np.median(np.diff(t))) if n > 1 else 0.0
        if 0.5 * step <= abs(minus_tau) <= LAG_AT_MOST:
            out["lag"] = float(minus_tau)
            left["lag"] = float(np.sum((r - fit_lag) ** 2))
    out["explained"] = {c: float(min(max((energy - u) / excess, 0.0), 1.0)) for c, u in left.items()}
    if ratio < WITHIN_NOISE:
        out["cause"] = "noise"
    elif out["explained"]["offset"] >= EXPLAINS:
        out["cause"] = "offset"
    else:
        best = max(("drift", "lag"), key=lambda c: out["explained"].get(c, -1.0))
        out["cause"] = best if out["explained"].get(best, 0.0) >= EXPLAINS else "shape"
    return out


def _shown(value, si):
    unit, f = difference_shown(si)
    return f"{value * f:+.3g} {unit}"


def describe(signal, e):
    """One sentence for :func:`explain_residual`'s answer on ``signal``, numbers with units.

    Parameters
    ----------
    signal : str
        Signal name (p_a, x, ...) [-]
    e : dict
        What :func:`explain_residual` returned [-]

    Returns
    -------
    sentence : str
        The cause in words [-]
    """
    si = SIGNAL_UNITS.get(signal, "-")
    if e["cause"] == "too_few":
        return f"{signal}: {e['n']} samples, too few to judge"
    head = f"{signal}: {e['ratio']:.2g}x the noise (noise {_shown(e['sigma'], si).lstrip('+')})"
    share = e["explained"]
    if e["cause"] == "noise":
        return f"{head}: within the noise"
    if e["cause"] == "offset":
        return (f"{head}: a constant offset of {_shown(e['offset'], si)} ({100 * share['offset']:.0f} % "
                f"of the excess), already {_shown(e['start_offset'], si)} over the first "
                f"{min(START_SAMPLES, e['n'])} samples ({e['start_sigmas']:.0f} standard errors): "
                "the initial state or a sensor's zero")
    # a drift or a lag is fitted with an offset beside it: say so where the offset alone
    # explains half the excess or more, the two together being the explanation
    beside = (f", on an offset of {_shown(e['offset'], si)} (the offset alone "
              f"{100 * share['offset']:.0f} %)" if share.get("offset", 0.0) >= 0.5 else "")
    if e["cause"] == "drift":
        return (f"{head}: a drift of {_shown(e['drift'], si)}/s ({100 * share['drift']:.0f} % of "
                f"the excess){beside}: a leak or heat exchange the model lacks or overstates")
    if e["cause"] == "lag":
        late = "late" if e["lag"] > 0 else "early"
        return (f"{head}: a lag, the model {1e3 * abs(e['lag']):.3g} ms {late} "
                f"({100 * share['lag']:.0f} % of the excess){beside}: valve timing or a dead time")
    parts = ", ".join(f"{c} {100 * v:.0f} %" for c, v in share.items())
    return (f"{head}: not an offset, a drift or a lag alone (share of the excess each explains: "
            f"{parts}): look at the residual plot")
