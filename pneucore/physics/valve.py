"""Valve metering edges: C(u), b(u), m(u) tables over the spool opening (paper Fig. 2).

A 4/2 spool valve has four edges ``P-A``, ``A-R``, ``P-B``, ``B-R``; a 3/2
valve has ``P-A`` and ``A-R`` and chamber B is held at a constant pressure.
Tables are interpolated linearly; outside a table's openings the end values
hold. The compiled core receives all tables concatenated with offsets.
"""
import numpy as np
from numba import njit


#: The valve's metering edges, in the order of the compiled core's tables and slots
PORT_NAMES = ("P-A", "A-R", "P-B", "B-R")


@njit(cache=True, error_model="numpy", _nrt=False)
def table_segment(u, xs, start, end):
    """Interval of ``u`` in the increasing openings ``xs[start:end]``, ends held.

    Returns ``(lo, hi, w)`` such that a value table ``ys`` on the same
    openings interpolates to ``ys[lo] + w (ys[hi] - ys[lo])``; outside the
    table ``lo = hi`` is the end point. One search serves the C, b and m
    tables of an edge, which share their openings.

    Parameters
    ----------
    u : float
        Spool opening [-]
    xs : ndarray
        Concatenated openings of all tables [-]
    start, end : int
        Slice of this table in the concatenated arrays
    """
    if u <= xs[start]:
        return start, start, 0.0
    if u >= xs[end - 1]:
        return end - 1, end - 1, 0.0
    lo = start
    hi = end - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xs[mid] <= u:
            lo = mid
        else:
            hi = mid
    return lo, hi, (u - xs[lo]) / (xs[hi] - xs[lo])


@njit(cache=True, error_model="numpy", _nrt=False)
def table_interp(u, xs, ys, start, end):
    """Linear interpolation of ``ys`` over increasing ``xs[start:end]``, ends held.

    Parameters
    ----------
    u : float
        Spool opening [-]
    xs : ndarray
        Concatenated openings of all tables [-]
    ys : ndarray
        Concatenated values (C [m^3/(s Pa)], b [-] or m [-])
    start, end : int
        Slice of this table in the concatenated arrays
    """
    lo, hi, w = table_segment(u, xs, start, end)
    return ys[lo] + w * (ys[hi] - ys[lo])


def pack_tables(ports):
    """Concatenate the four edge tables for the compiled core.

    Parameters
    ----------
    ports : dict
        Edge name -> :class:`pneucore.description.model.PortTable`; missing edges get C = 0

    Returns
    -------
    xs, C, b, m : ndarray
        Concatenated openings, conductances, critical ratios, indices
    offsets : ndarray of int
        ``offsets[k]:offsets[k+1]`` is the slice of edge k
    """
    xs, cs, bs, ms, offsets = [], [], [], [], [0]
    for name in PORT_NAMES:
        port = ports.get(name)
        if port is None:
            o, c, bb, mm = [0.0], [0.0], [0.5], [0.5]
        else:
            o, c, bb = list(port.opening), list(port.C), list(port.b)
            mm = list(port.m) if port.m is not None else [0.5] * len(o)
        xs += o
        cs += c
        bs += bb
        ms += mm
        offsets.append(len(xs))
    return (np.array(xs, float), np.array(cs, float), np.array(bs, float),
            np.array(ms, float), np.array(offsets, np.int64))


def edge_characteristic(port, u):
    """Sonic conductance and critical ratio of one edge at openings ``u``.

    Parameters
    ----------
    port : PortTable
        The edge's tables
    u : array_like
        Spool openings [-]

    Returns
    -------
    C : ndarray
        Sonic conductance [m^3/(s Pa)]
    b : ndarray
        Critical pressure ratio [-]
    """
    u = np.asarray(u, float)
    return np.interp(u, port.opening, port.C), np.interp(u, port.opening, port.b)


def switched_command(command, on_time, off_time, rest=None):
    """The spool's positions over time from a held (on/off) command and the valve's switching
    times: each change of the command takes effect ``on_time`` later (``off_time`` for a
    return to the rest position ``rest``), as a solenoid valve's catalogue switching times say
    (ISO 12238: from the electrical signal to the spool's shift).

    A change overtaken by the next one (a pulse shorter than the difference of the two times)
    never reaches the spool: it is dropped. Changes at t <= 0 are the start position (no
    delay).

    Parameters
    ----------
    command : array_like, shape (n, 2)
        Breakpoints ``[t [s], u [-]]``, held between breakpoints, times not decreasing
    on_time : float
        Delay of a change to a position other than ``rest`` [s]
    off_time : float
        Delay of a change to ``rest`` [s]
    rest : float or None
        De-energised position; None = every change takes ``on_time`` (bistable) [-]

    Returns
    -------
    spool : ndarray, shape (m, 2)
        Breakpoints ``[t [s], u [-]]`` of the spool, held
    signal_times : ndarray, shape (m,)
        For each breakpoint of ``spool``, the command's time that caused it [s]

    Examples
    --------
    A 5/2 monostable valve (rest -1), on 15 ms, off 25 ms: extend at 0.1 s, return at 0.5 s

    >>> spool, sig = switched_command([[0, -1], [0.1, 1], [0.5, -1]], 0.015, 0.025, rest=-1)
    >>> spool.round(4).tolist(), sig.tolist()
    ([[0.0, -1.0], [0.115, 1.0], [0.525, -1.0]], [0.0, 0.1, 0.5])
    """
    cmd = np.asarray(command, float).reshape(-1, 2)
    out_t, out_u, sig = [], [], []
    u_prev = None
    for t, u in cmd:
        if t <= 0.0 or u_prev is None:
            if out_t and out_t[-1] <= 0.0:
                out_u[-1] = u
            else:
                out_t.append(max(t, 0.0) if t <= 0.0 else t)
                out_u.append(u)
                sig.append(t)
            u_prev = u
            continue
        if u == u_prev:
            continue
        td = t + (off_time if rest is not None and u == rest else on_time)
        # a later change that overtakes an earlier one cancels it (the spool never got there)
        while len(out_t) > 1 and out_t[-1] >= td:
            out_t.pop()
            out_u.pop()
            sig.pop()
        if out_u[-1] == u:      # back where the spool already is: no change at all
            u_prev = u
            continue
        out_t.append(td)
        out_u.append(u)
        sig.append(t)
        u_prev = u
    return np.column_stack([out_t, out_u]), np.asarray(sig, float)
