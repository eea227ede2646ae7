"""Per-run metrics of a robustness study, from one :class:`~pneucore.result.SimulationResult`.

All in SI units; times are counted from the start of the scenario (t = 0).
``travel = x_final - x0`` with ``x0 = x(0)``; a run whose ``|travel|`` is
below :data:`NO_TRAVEL` has no travel and its ``t95`` and ``overshoot`` are
undefined (None in JSON, NaN in arrays).
"""
from __future__ import annotations

import math

import numpy as np

from .gas import RHO_REF

#: Travel below which a run is considered not to have moved [m]
NO_TRAVEL = 1e-6
#: Settling band: the larger of this fraction of |travel| and :data:`SETTLING_FLOOR`
SETTLING_FRACTION = 0.02
#: Smallest settling band [m]
SETTLING_FLOOR = 1e-3

#: name -> (unit, definition)
METRICS = {
    "x_final": ("m", "final position x(t_end)"),
    "x_max": ("m", "peak (largest) position over the run"),
    "x_min": ("m", "smallest position over the run"),
    "t95": ("s", "first time x reaches x0 + 0.95 travel (linear interpolation between samples); "
                 "null without travel"),
    "overshoot": ("m", "extension (travel > 0): x_max - x_final; retraction: x_final - x_min; "
                       "null without travel"),
    "settling_time": ("s", "time x enters the band |x - x_final| <= max(2 % |travel|, 1 mm) for "
                           "the last time (linear interpolation); 0 if it never leaves it"),
    "p_a_max": ("Pa", "peak absolute pressure in chamber A"),
    "p_b_max": ("Pa", "peak absolute pressure in chamber B"),
    "T_max": ("K", "peak gas temperature over both chambers"),
    "T_min": ("K", "lowest gas temperature over both chambers"),
    "stick_events": ("-", "number of stick events (piston stopping by friction)"),
    "air_consumption": ("NL", "air drawn from the supply in normal litres (ANR): the time integral "
                              "(trapezoidal) of q_supply [kg/s] / 1.185 kg/m^3 x 1000"),
}


def run_metrics(res, names=None):
    """Metrics of one simulation result.

    Parameters
    ----------
    res : SimulationResult  A completed simulation
    names : list of str or None  Metrics to compute (None = all of :data:`METRICS`)

    Returns
    -------
    metrics : dict  name -> float, or None where undefined (see :data:`METRICS`)
    """
    names = list(METRICS) if names is None else names
    t, x = np.asarray(res.t, float), np.asarray(res.x, float)
    x0, x_final = float(x[0]), float(x[-1])
    travel = x_final - x0
    moved = abs(travel) >= NO_TRAVEL
    out = {}
    for name in names:
        if name == "x_final":
            v = x_final
        elif name == "x_max":
            v = float(np.max(x))
        elif name == "x_min":
            v = float(np.min(x))
        elif name == "t95":
            v = _t95(t, x, x0, travel) if moved else None
        elif name == "overshoot":
            if not moved:
                v = None
            elif travel > 0:
                v = float(np.max(x)) - x_final
            else:
                v = x_final - float(np.min(x))
        elif name == "settling_time":
            v = _settling(t, x, x_final, max(SETTLING_FRACTION * abs(travel), SETTLING_FLOOR))
        elif name == "p_a_max":
            v = float(np.max(res.p_a))
        elif name == "p_b_max":
            v = float(np.max(res.p_b))
        elif name == "T_max":
            v = float(max(np.max(res.T_a), np.max(res.T_b)))
        elif name == "T_min":
            v = float(min(np.min(res.T_a), np.min(res.T_b)))
        elif name == "stick_events":
            v = float(sum(1 for e in res.events if e["kind"] == "stick"))
        elif name == "air_consumption":
            v = air_consumption(t, res.q_supply)
        else:
            raise KeyError(f"unknown metric {name!r}")
        out[name] = None if v is None or not math.isfinite(v) else float(v)
    return out


def air_consumption(t, q_supply):
    """Normal litres (ANR, 1.185 kg/m^3) drawn from the supply [NL]: trapezoidal integral of q_supply."""
    return float(np.trapezoid(np.asarray(q_supply, float), np.asarray(t, float)) / RHO_REF * 1000.0)


def _t95(t, x, x0, travel):
    s = (x - x0) / travel
    hit = np.flatnonzero(s >= 0.95)
    if hit.size == 0:  # pragma: no cover - x_final itself is at s = 1
        return None
    i = int(hit[0])
    if i == 0:
        return float(t[0])
    return float(t[i - 1] + (0.95 - s[i - 1]) / (s[i] - s[i - 1]) * (t[i] - t[i - 1]))


def _settling(t, x, x_final, band):
    d = np.abs(x - x_final)
    out = np.flatnonzero(d > band)
    if out.size == 0:
        return 0.0
    k = int(out[-1])
    if k == len(t) - 1:  # pragma: no cover - d[-1] = 0
        return float(t[-1])
    return float(t[k] + (d[k] - band) / (d[k] - d[k + 1]) * (t[k + 1] - t[k]))
