"""Error measures: the paper's Eq. 25, phases, worst windows, noise level, residual tests."""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

from pneucore.analysis.autocorrelation import autocorrelation, integrated_time

#: Human names of the chambers for window descriptions
_CHAMBER = {"p_a": "A", "p_b": "B", "T_a": "A", "T_b": "B"}


def eq25_error(measured, simulated):
    """Mean relative error of the paper, Eq. 25 [-].

    .. math:: \\varepsilon = \\sqrt{\\frac{\\sum (P_g - P_s)^2}{\\sum P_s^2}}

    where ``P_s`` is the measured and ``P_g`` the simulated value; samples
    where either is missing (NaN) are skipped.

    Parameters
    ----------
    measured : array_like
        Measured samples (the paper's P_s)
    simulated : array_like
        Simulated samples (P_g)

    Returns
    -------
    eps : float
        Relative error (0.0201 = 2.01 %); NaN if no sample is usable
    """
    m = np.asarray(measured, float)
    s = np.asarray(simulated, float)
    ok = np.isfinite(m) & np.isfinite(s)
    if not ok.any():
        return float("nan")
    den = np.sum(m[ok] ** 2)
    if den == 0.0:
        return float("nan")
    return float(math.sqrt(np.sum((s[ok] - m[ok]) ** 2) / den))


#: A run of this many equal successive samples is a sensor that does not move (clipped at its
#: zero, saturated, a quantised hold): left out of the noise estimate. A sensor whose noise is
#: one converter step or more repeats a value with odds below 1/2 per sample, 20 times in a row
#: below 1 in a million
STILL_RUN = 20


def _moving(y):
    """Mask of the samples outside runs of :data:`STILL_RUN` or more equal values."""
    n = y.size
    keep = np.ones(n, bool)
    if n < STILL_RUN:
        return keep
    change = np.flatnonzero(y[1:] != y[:-1]) + 1
    starts = np.concatenate(([0], change))
    ends = np.concatenate((change, [n]))
    for a, b in zip(starts, ends):
        if b - a >= STILL_RUN:
            keep[a:b] = False
    return keep


def noise_sigma(y, lsb=0.0):
    """Robust estimate of white measurement noise from second differences.

    For a smooth signal sampled finely, ``d = y[i+1] - 2 y[i] + y[i-1]`` is
    dominated by noise of variance ``6 sigma^2``. Samples around fast
    transients are screened out with a median-absolute-deviation cut (4
    robust sigmas, which keeps 99.99 % of Gaussian noise), then sigma comes
    from the RMS of what remains. The RMS step matters for quantised data:
    there the MAD itself only takes a few discrete values, while the RMS
    adds quantisation and noise variances correctly.

    A quantised or clipped signal (a pressure reading exactly 0 between pulses, a
    sensor at a stop) holds one value for long runs: there the second differences
    are 0 and say nothing of the noise. The estimate comes from where the signal
    moves (runs of :data:`STILL_RUN` equal samples left out), and is never below
    the quantisation floor ``q / sqrt(12)`` of a quantised signal's smallest step
    ``q`` (repeated values, every step a multiple of ``q``: the converter's
    resolution), so it is never 0 for a quantised signal that changes at all.

    Parameters
    ----------
    y : array_like
        Samples (NaN allowed)
    lsb : float
        Quantisation step, if known (same unit as y)

    Returns
    -------
    sigma : float
        Noise standard deviation (unit of y), at least ``lsb / sqrt(12)``

    Examples
    --------
    A 12-bit pressure of 0 to 10 bar, clipped at 0 bar gauge for half the record: the
    noise comes from the half that moves (300 Pa), not from the zeros

    >>> rng = np.random.default_rng(0)
    >>> lsb = 10e5 / 4095
    >>> y = np.round(np.maximum(np.r_[np.full(2000, -1e4), np.full(2000, 3e5)]
    ...                         + rng.normal(0, 300, 4000), 0) / lsb) * lsb
    >>> 250 < noise_sigma(y) < 350
    True
    """
    y = np.asarray(y, float)
    y = y[np.isfinite(y)]
    floor = lsb / math.sqrt(12.0)
    if y.size < 5:
        return max(floor, 0.0)
    diffs = np.abs(np.diff(y))
    steps = diffs[diffs > 0]
    if steps.size and diffs.size - steps.size >= 0.01 * diffs.size:
        # a quantised signal (repeated values, every step a multiple of the smallest): the
        # converter's resolution bounds its noise from below
        q = float(np.min(steps))
        k = steps / q
        if np.all(np.abs(k - np.round(k)) <= 1e-3 * np.maximum(k, 1.0)):
            floor = max(floor, q / math.sqrt(12.0))
    moving = _moving(y)
    d2 = y[2:] - 2.0 * y[1:-1] + y[:-2]
    ok = moving[1:-1] & moving[2:] & moving[:-2]
    if ok.sum() >= 5:
        d2 = d2[ok]
    med = np.median(d2)
    dev = np.abs(d2 - med)
    s0 = 1.4826 * np.median(dev)
    if s0 == 0.0:
        nz = dev[dev > 0]
        s0 = float(np.min(nz)) if nz.size else 0.0
    keep = d2[dev <= 4.0 * s0] if s0 > 0 else d2
    sigma = math.sqrt(np.mean(keep * keep) / 6.0) if keep.size else 0.0
    return float(max(sigma, floor))


def command_phases(t, u):
    """Label each sample with the valve phase it belongs to (paper Table 2).

    After a command change the phase is ``valve opens`` when the opening
    magnitude grows, ``valve closes`` when it shrinks and ``valve reverses``
    when it flips sign at equal magnitude; before the first change it is
    ``initial``.

    Parameters
    ----------
    t : ndarray
        Sample times [s]
    u : ndarray
        Command [-]

    Returns
    -------
    labels : ndarray of str
    """
    u = np.asarray(u, float)
    n = u.shape[0]
    if n == 0:
        return np.array([], dtype=str)
    # vectorised: classify each change, then carry the last class forward (zero-order hold)
    idx = np.flatnonzero(u[1:] != u[:-1]) + 1
    a, b = np.abs(u[idx - 1]), np.abs(u[idx])
    kind = np.where(b > a + 1e-12, 1, np.where(b < a - 1e-12, 2, 3))
    code = np.zeros(n, dtype=np.int64)
    code[idx] = kind
    pos = np.zeros(n, dtype=np.int64)
    pos[idx] = idx
    np.maximum.accumulate(pos, out=pos)
    return _COMMAND_LABELS[code[pos]]


#: Labels of :func:`command_phases`, indexed by change class (0 = before the first change)
_COMMAND_LABELS = np.array(["initial", "valve opens", "valve closes", "valve reverses"])


_PISTON = {"slide": "piston moving", "stick": "piston stuck", "stop": "piston at a stop",
           "locked": "piston locked", "": "unknown"}


def piston_phases(mode):
    """Piston state labels (``piston moving``, ``piston stuck``, ...) from simulated modes."""
    mode = np.asarray(mode)
    if mode.size == 0:
        return np.array([], dtype=str)
    keys, inv = np.unique(mode.astype(str), return_inverse=True)
    return np.array([_PISTON.get(k, k) for k in keys.tolist()])[inv.reshape(-1)]


def ordered_labels(labels):
    """Distinct labels of a per-sample label array, in order of first appearance.

    What ``dict.fromkeys(labels)`` gives, without its Python loop over every sample
    (21,000 a signal on a 20 s record at 1 kHz).

    Parameters
    ----------
    labels : ndarray
        One label per sample [-]

    Returns
    -------
    labels : list
        The distinct labels, first seen first [-]
    """
    labels = np.asarray(labels)
    if labels.size == 0:
        return []
    _, first = np.unique(labels, return_index=True)
    return list(labels[np.sort(first)])


def phase_errors(measured, simulated, labels):
    """Eq. 25 error of one signal within each phase label.

    Returns
    -------
    errors : dict
        label -> {"error": float, "n": samples}
    """
    out = {}
    for lab in ordered_labels(labels):
        sel = labels == lab
        n = int(np.sum(sel & np.isfinite(measured) & np.isfinite(simulated)))
        if n:
            out[str(lab)] = {"error": eq25_error(measured[sel], simulated[sel]), "n": n}
    return out


def _trend(series, t, i0, i1):
    seg = series[i0:i1]
    ok = np.isfinite(seg)
    if ok.sum() < 2:
        return 0.0
    tt = t[i0:i1][ok]
    slope = np.polyfit(tt - tt[0], seg[ok], 1)[0]
    return slope


def describe_window(signal, t0, t1, cmd_phase, piston, p_trend=None, x_trend=None):
    """One sentence for a failure window, e.g. ``p_b, 0.38-0.45 s, valve closes, chamber B expanding, piston stuck``."""
    parts = [signal, f"{t0:.3f}-{t1:.3f} s", cmd_phase]
    if signal in _CHAMBER and p_trend is not None:
        ch = _CHAMBER[signal]
        if p_trend > 0:
            parts.append(f"chamber {ch} compressing")
        elif p_trend < 0:
            parts.append(f"chamber {ch} expanding")
        else:
            parts.append(f"chamber {ch} steady")
    if x_trend is not None and piston == "piston moving":
        piston = "piston extending" if x_trend > 0 else "piston retracting"
    parts.append(piston)
    return ", ".join(parts)


def worst_windows(t, measured, simulated, cmd_labels, piston_labels, n_windows=5, width=None,
                  experiment=""):
    """Time windows with the largest normalised residual energy, described in words.

    The residual of each signal is normalised as in Eq. 25 (divided by the
    mean square of the measurement) so that signals of different units
    compete on equal terms. Windows are ``width`` long (default 5 % of the
    record, at least 10 samples); the strongest are taken greedily without
    overlap within a signal.

    Parameters
    ----------
    t : ndarray
        Sample times [s]
    measured, simulated : dict
        Signal -> samples
    cmd_labels, piston_labels : ndarray
        Phase labels per sample
    n_windows : int
        How many windows to return
    width : float or None
        Window length [s]

    Returns
    -------
    windows : list of dict
        ``signal, t_start, t_end, share`` (fraction of that signal's
        squared error), ``energy`` (contribution to Eq. 25^2), ``phase``, ``piston``, ``description``
    """
    n = t.shape[0]
    if n < 3:
        return []
    dt = float(np.median(np.diff(t)))
    if width is None:
        width = 0.05 * (t[-1] - t[0])
    w = int(max(10, round(width / dt)))
    w = min(w, n)
    cands = []
    for sig, m in measured.items():
        s = simulated[sig]
        ok = np.isfinite(m) & np.isfinite(s)
        if ok.sum() < 3:
            continue
        ms = np.mean(m[ok] ** 2)
        if ms == 0:
            continue
        z = np.where(ok, (s - m) ** 2, 0.0) / (ms * ok.sum())
        total = z.sum()
        if total <= 0:
            continue
        csum = np.concatenate([[0.0], np.cumsum(z)])
        energy = csum[w:] - csum[:-w]
        taken = np.zeros(energy.shape[0], bool)
        for _ in range(n_windows):
            e = np.where(taken, -1.0, energy)
            k = int(np.argmax(e))
            if e[k] <= 0:
                break
            lo, hi = max(0, k - w + 1), min(energy.shape[0], k + w)
            taken[lo:hi] = True
            cands.append((float(energy[k]), sig, k, k + w - 1, float(energy[k] / total)))
    cands.sort(key=lambda c: -c[0])
    out = []
    for energy, sig, i0, i1, share in cands[:n_windows]:
        mid = (i0 + i1) // 2
        cmd = _majority(cmd_labels[i0:i1 + 1])
        pis = _majority(piston_labels[i0:i1 + 1])
        p_tr = None
        if sig in _CHAMBER:
            slope = _trend(measured[sig], t, i0, i1 + 1)
            scale = np.nanmax(np.abs(measured[sig])) / max(t[-1] - t[0], 1e-9)
            p_tr = 0.0 if abs(slope) < 0.02 * scale else slope
        x_tr = None
        if "x" in simulated:
            x_tr = _trend(simulated["x"], t, i0, i1 + 1)
        desc = describe_window(sig, t[i0], t[i1], cmd, pis, p_tr, x_tr)
        if experiment:
            desc = f"{experiment}: {desc}"
        out.append({"signal": sig, "t_start": float(t[i0]), "t_end": float(t[i1]),
                    "t_mid": float(t[mid]), "energy": energy, "share": share,
                    "phase": cmd, "piston": pis, "description": desc, "experiment": experiment})
    return out


def _majority(labels):
    if len(labels) == 0:
        return ""
    vals, counts = np.unique(labels, return_counts=True)
    return str(vals[int(np.argmax(counts))])


def ljung_box(residual, lags=20):
    """Ljung-Box portmanteau test of residual whiteness.

    ``Q = N (N + 2) sum_{k=1..h} rho_k^2 / (N - k)``, chi-square with ``h``
    degrees of freedom when the residual is white (Ljung & Box, Biometrika 1978).

    Returns
    -------
    Q : float, p_value : float
    """
    r = np.asarray(residual, float)
    r = r[np.isfinite(r)]
    n = r.shape[0]
    h = min(lags, max(1, n // 5))
    if n < 10:
        return float("nan"), float("nan")
    r = r - r.mean()
    den = np.sum(r * r)
    if den == 0:
        return 0.0, 1.0
    q = 0.0
    for k in range(1, h + 1):
        rho = np.sum(r[k:] * r[:-k]) / den
        q += rho * rho / (n - k)
    q *= n * (n + 2)
    return float(q), float(stats.chi2.sf(q, h))


def cross_correlation_test(residual, inp, lags=20):
    """Test that the residual is independent of an input (e.g. the command).

    With ``r_k`` the sample cross-correlation of residual ``e`` (lagging) and
    input ``u`` at lags ``k = 0..h``, the statistic is

    .. math:: S = N r^T P^{-1} r, \\qquad
              P_{jk} = \\sum_\\tau \\rho_e(\\tau) \\rho_u(\\tau + j - k)

    (Ljung, *System Identification*, 2nd ed., 1999, Sect. 16.6): ``P`` is the
    covariance of ``sqrt(N) r`` when ``e`` and ``u`` are independent, and ``S``
    is chi-square with ``h + 1`` degrees of freedom. With a white residual and
    a white input ``P = I``. A step command is far from white, and so is
    coloured measurement noise: without ``P``, ``N sum r_k^2`` grows with both
    autocorrelations and independence would be rejected on noise alone. The
    sum over ``tau`` is truncated at five autocorrelation times of the
    residual with Bartlett weights (which keeps ``P`` positive semidefinite);
    directions of ``P`` with eigenvalues below 1e-3 of the largest carry no
    information and are dropped, with their degrees of freedom.

    Returns
    -------
    S : float, p_value : float
    """
    r = np.asarray(residual, float)
    u = np.asarray(inp, float)
    ok = np.isfinite(r) & np.isfinite(u)
    r, u = r[ok], u[ok]
    n = r.shape[0]
    if n < 10:
        return float("nan"), float("nan")
    r = r - r.mean()
    u = u - u.mean()
    den = math.sqrt(np.sum(r * r) * np.sum(u * u))
    if den == 0:
        return 0.0, 1.0
    h = min(lags, n // 5)
    rk = np.array([np.sum(r[k:] * u[:n - k]) / den for k in range(h + 1)])
    rho_e = autocorrelation(r)
    rho_u = autocorrelation(u)
    m = int(min(n - h - 1, max(h, math.ceil(5.0 * integrated_time(r)))))
    tau = np.arange(-m, m + 1)
    w = (1.0 - np.abs(tau) / (m + 1.0)) * rho_e[np.abs(tau)]
    p = np.array([np.sum(w * rho_u[np.abs(tau + d)]) for d in range(h + 1)])
    P = p[np.abs(np.subtract.outer(np.arange(h + 1), np.arange(h + 1)))]
    lam, vec = np.linalg.eigh(P)
    keep = lam > 1e-3 * lam.max()
    z = vec[:, keep].T @ rk
    s = float(n * np.sum(z * z / lam[keep]))
    return s, float(stats.chi2.sf(s, int(keep.sum())))
