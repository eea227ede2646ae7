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
since): the vent, not the dip of a piston starting to move.

Each edge's time is then where the signal turns (issue 39): the smoothed rate ramps across
the smoothing window from the rate before the edge to the edge's extreme (the fill's fastest
rise, the vent's fastest fall) and crosses half-way at the turn itself (:data:`TURN_LEVEL`).
A closing's extreme is looked for from the pressure's peak since the opening (at most
:data:`TURN_SEARCH` earlier) to a window after the half-rise crossing: the turn is where the
vent's fast fall starts, not the slow fall of a chamber expanding behind a moving piston
(walking back along a falling rate, as before, went into that slow fall: 7-38 ms early). How
sure each edge is: two standard errors of the crossing's time (the rate's noise over the
ramp's slope) and half a sample, as a half-width [s]. A valve that switches
``switching_time`` after its command makes the signal turn that much later: the proposed
command leads the turns by it (0 for a model without switching time: the edge is where the
valve switched).
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
#: A closing's turn is looked for at most this long before the fall crosses half the rise
#: [s]: 40 ms, several times a vent's first fall to half (a few ms to 10 ms)
TURN_SEARCH = 0.040
#: Share of the way from the rate before an edge to the edge's extreme rate at which the
#: smoothed rate crosses at the turn [-]: a half. A centred moving average of a signal whose
#: slope jumps at t0 has a rate ramping linearly across the window, through half the jump at
#: t0 itself: the crossing is the turn, unbiased, the noise averaged over the window
TURN_LEVEL = 0.5
#: Standard errors in an edge's half-width [-]: 2 (about 95 % for a Gaussian error)
TURN_SIGMAS = 2.0
#: An edge whose half-width exceeds this many sample periods is "uncertain" (the acceptance
#: of issue 39: an edge within two samples of where the signal turns) [-]
SURE_SAMPLES = 2.0


def _refine(t, p, k, w):
    """The turn ``k`` refined on the raw samples: the break of slope among ``k - 2 .. k + 2``
    that fits best a quadratic before and one after it, joined there, all on the same samples
    (a window and two samples either side). The smoothed rate's half-way crossing is unbiased
    for a constant slope after the turn; a vent's slope decays from its start, and the crossing
    comes up to about half a sample early (a sample on this record's shape: 0.32 -> 3.2 %)."""
    n = len(t)
    a0, a1 = k - 2 - w - 1, k + 2 + w + 1
    if p is None or a0 < 0 or a1 > n - 1:
        return k
    tt0, y = t[a0:a1 + 1], p[a0:a1 + 1]
    if not np.all(np.isfinite(y)):
        return k
    best, arg = np.inf, k
    for b in range(k - 2, k + 3):
        tt = tt0 - t[b]
        lo, hi = np.minimum(tt, 0.0), np.maximum(tt, 0.0)
        X = np.column_stack([np.ones_like(tt), lo, lo * lo, hi, hi * hi])
        r = y - X @ np.linalg.lstsq(X, y, rcond=None)[0]
        e = float(r @ r)
        if e < best:
            best, arg = e, b
    return arg


def _turn(t, rate, sigma, w, lo, hi, sign, p=None):
    """Where the smoothed rate turns into an edge among ``lo..hi`` (see the module's text).

    ``sign`` +1 for a rise (an opening), -1 for a fall (a closing). The edge's extreme rate is
    the largest ``sign * rate`` in ``lo..hi``; the rate before it the median over the window
    before its ramp (within the search); the turn where the rate crosses :data:`TURN_LEVEL` of the way between
    them, interpolated between samples and put on the nearer sample. Returns ``(index,
    half_width [s])``: the half-width :data:`TURN_SIGMAS` standard errors of the crossing's
    time (the rate's noise ``sigma`` [Pa/s] over the ramp's slope) and half a sample, or
    ``(None, None)`` where the search is empty.
    """
    n = len(t)
    lo, hi = max(lo, 1), min(hi, n - 1)
    if hi <= lo:
        return None, None
    m = lo + int(np.argmax(sign * rate[lo:hi + 1]))
    # the rate before the ramp: the window before it (the ramp spans a window up to the
    # extreme), not before the search's start (a closing's peak: the rise ends there)
    b1 = max(m - w, lo)
    b0 = max(m - 2 * w, lo, b1 - w)
    if b1 <= b0:
        b0, b1 = max(b1 - 1, 0), b1 + 1 if b1 == b0 else b1
    pre = float(np.median(rate[b0:b1])) if b1 > b0 else float(rate[b0])
    jump = float(rate[m]) - pre
    if not sign * jump > 0:
        return None, None
    level = pre + TURN_LEVEL * jump
    c = m
    while c > b0 and sign * (rate[c - 1] - level) > 0:
        c -= 1
    # the crossing between samples c - 1 and c, interpolated
    r0, r1 = float(rate[c - 1]), float(rate[c])
    f = 0.5 if r1 == r0 else min(max((level - r0) / (r1 - r0), 0.0), 1.0)
    tc = float(t[c - 1] + f * (t[c] - t[c - 1]))
    k = c if tc - t[c - 1] >= 0.5 * (t[c] - t[c - 1]) else c - 1
    k = _refine(t, p, k, w)
    dt = float(t[min(k + 1, n - 1)] - t[max(k - 1, 0)]) / 2 or float(t[1] - t[0])
    # the ramp's slope: the jump across the smoothing window [Pa/s^2]
    ramp = abs(jump) / (w * dt)
    half = TURN_SIGMAS * sigma / ramp + 0.5 * dt
    return k, half


def propose_command(measurement: Measurement, signal: str | None = None, open_level: float = 1.0,
                    closed_level: float = 0.0, min_rate: float | None = None,
                    switching_time: float = 0.0) -> dict:
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
    switching_time : float
        The valve's switching time after its command [s]: the command's edges lead the
        signal's turns by it (0: the edges are where the valve switched, for a model without
        switching time)

    Returns
    -------
    proposal : dict
        ``command`` (``[[t [s], u [-]], ...]`` on the record's time axis, held between
        breakpoints), ``pulses`` (``[[t_open, t_close], ...]`` [s], ``t_close`` None for a
        valve still open at the end), ``edges`` (per edge: ``t`` [s] of the command,
        ``turn`` [s] where the signal turns, ``kind`` "open"/"close", ``uncertainty`` [s]
        half-width of the times the data allow, ``sure`` within :data:`SURE_SAMPLES`
        samples), ``signal``, ``threshold`` [Pa/s], ``source`` (``"proposed"``) and a
        ``note`` stating the rule applied

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
    opens, peaks, crossings = [], [], []   # sample indices: coarse opening, peak, half-rise
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
        opens.append(min(j + h, n - 1))
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
        peaks.append(j + int(np.argmax(ps[j:k + 1])))
        crossings.append(k)
        pulses[-1][1] = float(t[k])
        i = k
        while i < n and rate[i] > ONSET_SHARE * thr:
            i += 1
    # each edge where the smoothed rate turns (TURN_LEVEL of the way to the edge's extreme)
    search = max(int(round(TURN_SEARCH / dt)), 2 * w)
    edges = []
    for q, (a, b) in enumerate(pulses):
        # an opening: the fill's fastest rise within two windows of the coarse onset
        ko, half = _turn(t, rate, sigma, w, opens[q] - w, opens[q] + 2 * w, 1, p)
        if ko is not None:
            a = pulses[q][0] = float(t[ko])
        edges.append({"kind": "open", "turn": a, "uncertainty": half})
        if b is None:
            continue
        # a closing: the vent's fastest fall between the pressure's peak since the opening (at
        # most TURN_SEARCH before the half-rise crossing) and a window after the crossing
        top = max(peaks[q], ko if ko is not None else 0, crossings[q] - search)
        kc, half = _turn(t, rate, sigma, w, top, crossings[q] + w, -1, p)
        if kc is not None:
            b = pulses[q][1] = float(max(t[kc], a))
        edges.append({"kind": "close", "turn": b, "uncertainty": half})
    shift = float(switching_time)
    pulses = [[a - shift, None if b is None else b - shift] for a, b in pulses]
    for e in edges:
        e["t"] = round(e["turn"] - shift, 9)
        e["turn"] = round(e["turn"], 9)
        u = e["uncertainty"]
        e["uncertainty"] = None if u is None else round(float(u), 9)
        e["sure"] = u is not None and u <= SURE_SAMPLES * dt * (1 + 1e-9)
    cmd = [[float(t[0]), float(closed_level)]]
    for a, b in pulses:
        if a > cmd[-1][0] or not cmd:
            cmd.append([a, float(open_level)])
        else:
            cmd[-1][1] = float(open_level)
        if b is not None:
            cmd.append([b, float(closed_level)])
    cmd = [c for k, c in enumerate(cmd) if k == 0 or c[0] > cmd[k - 1][0]]
    unsure = [e for e in edges if not e["sure"]]
    note = (f"{len(pulses)} opening(s) read from {signal}: a rise faster than {thr:.3g} Pa/s "
            f"opens the valve ({open_level:g}) where the pressure starts to rise; a fall below "
            f"half the rise closes it ({closed_level:g}) where that fall starts (each edge where "
            f"the smoothed rate is half-way to the edge's fastest)")
    if shift:
        note += f", {1e3 * shift:g} ms before the turn for the valve's switching time"
    listed = "; ".join(_edge_text(e) for e in unsure[:6])
    note += (f". {len(edges) - len(unsure)} of {len(edges)} edge(s) within "
             f"{SURE_SAMPLES:g} samples" + (f"; uncertain: {listed}" if unsure else "")
             + ". Confirm or edit, then give it as scenario.command")
    return _result([[round(a, 9), None if b is None else round(b, 9)] for a, b in pulses],
                   [[round(a, 9), u] for a, u in cmd], signal, thr, note, edges)


def _edge_text(e):
    if e["uncertainty"] is None:
        return f"{e['kind']} at {e['t']:.3f} s"
    return f"{e['kind']} at {e['t']:.3f} s (+-{1e3 * e['uncertainty']:.0f} ms)"


def _result(pulses, command, signal, thr, note, edges=()):
    return {"command": command, "pulses": pulses, "edges": list(edges), "signal": signal,
            "threshold": float(thr), "source": "proposed", "note": note}


#: Ambient pressure assumed where the record does not give one [Pa]
AMBIENT = 101325.0
#: A chamber within this of the ambient pressure is at ambient [Pa]: 0.15 bar, above a gauge
#: sensor's zero error and noise (a few kPa), far below a pulse's rise (bars)
AMBIENT_BAND = 15000.0
#: A measured p_b whose spread (standard deviation) is below this is held constant [Pa]
HELD_SPREAD = 10000.0


def propose_b_chamber(measurement: Measurement, pulses=(), ambient: float = AMBIENT) -> dict:
    """Chamber B's state for a 3/2 valve's record, proposed from what the record shows.

    Measured p_b: at the ambient throughout (within :data:`AMBIENT_BAND`) -> ``vented``;
    constant above it (spread below :data:`HELD_SPREAD`) -> ``held`` at its mean; moving with
    the piston -> ``closed`` (an air spring; a restriction if it also leaks back to ambient).
    Without p_b: chamber A back at the ambient between pulses while the piston falls back (a
    load returning it, nothing in B needed) -> ``vented``, less sure. Otherwise no proposal.

    Parameters
    ----------
    measurement : Measurement
        The record (SI) [-]
    pulses : list
        ``[[t_open, t_close], ...]`` of the proposed command [s]
    ambient : float
        The ambient pressure [Pa]

    Returns
    -------
    proposal : dict
        ``b_chamber`` (a mode of :data:`pneucore.description.model.B_CHAMBER_MODES` or None),
        ``b_chamber_pressure`` [Pa] for ``held``, ``sure`` [-] and ``why`` (in words)
    """
    sig = measurement.signals
    out = {"b_chamber": None, "b_chamber_pressure": None, "sure": False, "why": ""}
    if "p_b" in sig:
        pb = np.asarray(sig["p_b"], float)
        pb = pb[np.isfinite(pb)]
        if pb.size:
            mean, spread = float(np.mean(pb)), float(np.std(pb))
            if abs(mean - ambient) < AMBIENT_BAND and spread < HELD_SPREAD:
                out.update(b_chamber="vented", sure=True,
                           why=f"p_b stays at the ambient ({mean / 1e5:.3g} bar abs)")
            elif spread < HELD_SPREAD:
                out.update(b_chamber="held", b_chamber_pressure=mean, sure=True,
                           why=f"p_b is held at {mean / 1e5:.3g} bar abs (spread "
                               f"{spread / 1e3:.2g} kPa)")
            else:
                out.update(b_chamber="closed", sure=False,
                           why=f"p_b moves with the piston ({spread / 1e3:.3g} kPa spread): an air "
                               "spring, or a restriction if it leaks back to the ambient")
        return out
    if "p_a" not in sig or "x" not in sig or not len(pulses):
        return out
    t, pa, x = measurement.t, np.asarray(sig["p_a"], float), np.asarray(sig["x"], float)
    between = np.ones(t.shape, bool)
    for a, b in pulses:
        between &= ~((t >= a) & (t <= (b if b is not None else t[-1])))
    at_amb = between & (np.abs(pa - ambient) < AMBIENT_BAND)
    if at_amb.sum() < 0.5 * between.sum():
        return out
    falls = 0
    for a, b in pulses:
        if b is None:
            continue
        after = (t > b) & at_amb
        idx = np.flatnonzero(after)
        if idx.size > 10 and np.nanmax(x[idx[:idx.size // 2]]) - np.nanmin(x[idx]) > 1e-3:
            falls += 1
    if falls:
        out.update(b_chamber="vented", sure=False,
                   why=f"chamber A is back at the ambient between pulses and the piston falls "
                       f"back after {falls} of {len(pulses)} pulse(s): a load returns it, "
                       "nothing needs to be held in B (no p_b recorded to confirm)")
    return out

