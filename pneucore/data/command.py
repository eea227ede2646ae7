"""A valve command proposed from what a record holds: a chamber pressure's edges.

Rigs often log no command (or log it elsewhere). A valve that opens the supply to
a chamber makes its pressure rise within milliseconds; one that vents it makes it
fall. :func:`propose_command` finds those edges and returns a held command
(``[[t, u], ...]``, the scenario's form) for the user to confirm or edit; it is
never used without being given back as ``scenario.command``.

The edges: the pressure is smoothed over a short window (:data:`SMOOTH_WINDOW`) and
differentiated. A rise faster than a threshold opens the valve: the larger of six times
the derivative's noise (its median absolute deviation, a robust standard deviation for
Gaussian noise, Hampel 1974) and :data:`OPEN_SHARE` of the record's fastest rise (the
supply filling a chamber; a piston compressing the closed chamber rises slower), so that
a slow leak, a bounce or a quantised flat signal opens nothing. The opening's time goes
back to where the rate first exceeded a quarter of the threshold. The valve closes when
the pressure falls below half its rise (from the level before the opening to the peak
since): the vent, not the dip of a piston starting to move; the closing's time goes back
to the start of that fall.
"""
from __future__ import annotations

import numpy as np

from pneucore.data.measurement import Measurement

#: Pressure signals an edge can be read from, in order of preference
EDGE_SIGNALS = ("p_a", "p_b")
#: Smoothing window of the pressure before differentiating [s]: 5 ms, shorter than a valve
#: pulse and than a chamber's filling (tens of ms), longer than a few samples at 1 kHz
SMOOTH_WINDOW = 0.005
#: Derivative threshold in robust standard deviations of the derivative's noise [-]
NOISE_SIGMAS = 6.0
#: An edge's time goes back to where the rate first exceeded this share of the threshold [-]
ONSET_SHARE = 0.25
#: An opening is a rise at least this share of the record's fastest: the supply filling a
#: chamber through an open valve is the fastest rise a record holds; a piston compressing the
#: closed chamber (a load pushing it back, a bounce) rises several times slower [-]
OPEN_SHARE = 0.3
#: A closing's time goes back along the fall to where the rate was last above this share of
#: the opening threshold (the fall's start: the vent's first milliseconds are slow) [-]
CLOSE_SHARE = 0.025


def propose_command(measurement: Measurement, signal: str | None = None, open_level: float = 1.0,
                    closed_level: float = 0.0, min_rate: float | None = None) -> dict:
    """A held valve command read from a measured pressure's rises (open) and falls (closed).

    Parameters
    ----------
    measurement : Measurement
        The record (SI units)
    signal : str or None
        Pressure the edges are read from (``p_a`` or ``p_b``); None: the first measured
        of :data:`EDGE_SIGNALS` [-]
    open_level : float
        Command while the pressure is held up (a rise until the next fall) [-]
    closed_level : float
        Command before the first rise and after each fall [-]
    min_rate : float or None
        Smallest pressure rate that opens the valve [Pa/s]; None: :data:`OPEN_SHARE` of the
        record's fastest rise

    Returns
    -------
    proposal : dict
        ``command`` (``[[t [s], u [-]], ...]`` on the record's time axis, held between
        breakpoints), ``pulses`` (``[[t_open, t_close], ...]`` [s], ``t_close`` None for a
        valve still open at the end), ``signal``, ``threshold`` [Pa/s], ``source``
        (``"proposed"``) and a ``note`` saying how it was found

    Raises
    ------
    ValueError
        The record holds no chamber pressure, or ``signal`` is not one of them

    Examples
    --------
    A chamber filled at 0.1 s and vented at 0.3 s (a 3/2 valve's pulse), found within the
    smoothing window (5 ms):

    >>> import numpy as np
    >>> t = np.arange(0, 0.5, 0.001)
    >>> p = 1e5 + 5e5 * ((t >= 0.1) & (t < 0.3)) * (1 - np.exp(-(t - 0.1) / 0.01))
    >>> m = Measurement(t, {"p_a": p}).validate()
    >>> [[round(a, 2), round(b, 2)] for a, b in propose_command(m)["pulses"]]
    [[0.1, 0.3]]
    """
    present = [s for s in EDGE_SIGNALS if s in measurement.measured_signals]
    if signal is None:
        if not present:
            raise ValueError("the record holds no chamber pressure (p_a or p_b) to read the "
                             "valve's edges from")
        signal = present[0]
    elif signal not in present:
        raise ValueError(f"signal {signal!r} is not a measured chamber pressure of this record "
                         f"(measured: {', '.join(present) or 'none'})")
    t = measurement.t
    p = np.asarray(measurement.signals[signal], float)
    ok = np.isfinite(p)
    p = np.interp(t, t[ok], p[ok])   # missing samples bridged (edges are read, not values)
    dt = float(np.median(np.diff(t)))
    w = max(int(round(SMOOTH_WINDOW / dt)), 1)
    ps = np.convolve(p, np.ones(w) / w, mode="same") if w > 1 else p
    # the window's half-width at each end has fewer samples: hold the end values there
    h = w // 2
    if h:
        ps[:h], ps[-h:] = ps[h], ps[-h - 1]
    rate = np.gradient(ps, t)
    dev = np.abs(rate - np.median(rate))
    sigma = 1.4826 * float(np.median(dev))
    fastest = float(np.max(rate)) if rate.size else 0.0
    floor = OPEN_SHARE * fastest if min_rate is None else float(min_rate)
    thr = max(NOISE_SIGMAS * sigma, floor)
    if not thr > 0:
        return _result([], [[float(t[0]), closed_level]], signal, 0.0,
                       "the pressure never rises: no edge, the valve held closed")
    pulses = []
    i, n = 0, len(t)
    while i < n:
        if rate[i] <= thr:
            i += 1
            continue
        j = i
        while j > 0 and rate[j - 1] > ONSET_SHARE * thr:
            j -= 1
        low = float(ps[max(j - 1, 0)])
        # the centred window spreads a step over h samples before it: the edge is h later
        pulses.append([float(t[min(j + h, n - 1)]), None])
        # open while the pressure stays above half its rise: a fall below it is the vent
        peak = low
        k = i
        while k < n:
            peak = max(peak, float(ps[k]))
            if ps[k] < 0.5 * (low + peak) and peak - low > 0:
                break
            k += 1
        if k >= n:
            break
        c = k
        while c > j and rate[c - 1] < -CLOSE_SHARE * thr:
            c -= 1
        pulses[-1][1] = float(max(t[min(c + h, n - 1)], pulses[-1][0]))
        i = k
        while i < n and rate[i] > ONSET_SHARE * thr:
            i += 1
    cmd = [[float(t[0]), float(closed_level)]]
    for a, b in pulses:
        if a > cmd[-1][0] or not cmd:
            cmd.append([a, float(open_level)])
        else:
            cmd[-1][1] = float(open_level)
        if b is not None:
            cmd.append([b, float(closed_level)])
    cmd = [c for k, c in enumerate(cmd) if k == 0 or c[0] > cmd[k - 1][0]]
    note = (f"{len(pulses)} opening(s) read from {signal}: a rise faster than {thr:.3g} Pa/s "
            f"opens the valve ({open_level:g}), a fall below half the rise closes it ({closed_level:g}); "
            "confirm or edit, then give it as scenario.command")
    return _result([[round(a, 9), None if b is None else round(b, 9)] for a, b in pulses],
                   [[round(a, 9), u] for a, u in cmd], signal, thr, note)


def _result(pulses, command, signal, thr, note):
    return {"command": command, "pulses": pulses, "signal": signal, "threshold": float(thr),
            "source": "proposed", "note": note}
