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
        Edge name -> :class:`pneucore.spec.model.PortTable`; missing edges get C = 0

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
