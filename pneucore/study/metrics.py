"""Per-run metrics of a robustness study, from one :class:`~pneucore.result.SimulationResult`.

All in SI units; times are counted from the start of the scenario (t = 0).
``travel = x_final - x0`` with ``x0 = x(0)``; a run whose ``|travel|`` is
below :data:`NO_TRAVEL` has no travel and its ``t95`` and ``overshoot`` are
undefined (None in JSON, NaN in arrays).
"""
from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numpy as np

from pneucore.physics.gas import RHO_REF

#: Travel below which a run is considered not to have moved [m]
NO_TRAVEL = 1e-6
#: Settling band: the larger of this fraction of |travel| and :data:`SETTLING_FLOOR`
SETTLING_FRACTION = 0.02
#: Smallest settling band [m]
SETTLING_FLOOR = 1e-3

class Metric(NamedTuple):
    """One per-run metric of :data:`METRICS`.

    Indexing keeps the earlier ``(unit, definition)`` pair: ``METRICS[name][0]`` is the unit.

    Parameters
    ----------
    unit : str
        Unit of the value [-]
    definition : str
        What it measures, in words
    compute : callable
        ``compute(run) -> float or None`` with ``run`` a :class:`RunSeries`; None = undefined
    """
    unit: str
    definition: str
    compute: Callable


class RunSeries(NamedTuple):
    """What every metric reads from one simulation, computed once per run.

    Parameters
    ----------
    res : SimulationResult
        The completed simulation
    t : ndarray
        Sample times [s]
    x : ndarray
        Position [m]
    x0 : float
        Initial position x(0) [m]
    x_final : float
        Final position x(t_end) [m]
    travel : float
        ``x_final - x0`` [m]
    moved : bool
        ``|travel| >= NO_TRAVEL`` [-]
    """
    res: object
    t: np.ndarray
    x: np.ndarray
    x0: float
    x_final: float
    travel: float
    moved: bool

    @classmethod
    def of(cls, res):
        """The series of the result ``res``."""
        t, x = np.asarray(res.t, float), np.asarray(res.x, float)
        x0, x_final = float(x[0]), float(x[-1])
        travel = x_final - x0
        return cls(res, t, x, x0, x_final, travel, abs(travel) >= NO_TRAVEL)


#: name -> :class:`Metric` (unit, definition, compute); :func:`run_metrics` computes these
#: and nothing else, so a metric registered here (:func:`register_metric`) is what a study
#: computes, stores and summarises
METRICS: dict[str, Metric] = {}


def register_metric(name, unit, definition, compute):
    """Add (or replace) a per-run metric of every study that names it.

    Parameters
    ----------
    name : str
        Metric name, as a study's ``metrics`` lists it
    unit : str
        Unit of the value [-]
    definition : str
        What it measures, in words
    compute : callable
        ``compute(run) -> float or None``, ``run`` a :class:`RunSeries`

    Notes
    -----
    The runs compute metrics where they run: a metric registered here is
    known to ``run_study(..., workers=0)`` (this process) and to Dask workers
    that preload the registering module (``dask worker --preload mymodule``);
    the local pool's forkserver workers import pneucore only and do not know it.
    """
    METRICS[name] = Metric(unit, definition, compute)
    return METRICS[name]


def _overshoot(r):
    if not r.moved:
        return None
    if r.travel > 0:
        return float(np.max(r.x)) - r.x_final
    return r.x_final - float(np.min(r.x))


for _name, _unit, _definition, _compute in (
    ("x_final", "m", "final position x(t_end)", lambda r: r.x_final),
    ("x_max", "m", "peak (largest) position over the run", lambda r: float(np.max(r.x))),
    ("x_min", "m", "smallest position over the run", lambda r: float(np.min(r.x))),
    ("t95", "s", "first time x reaches x0 + 0.95 travel (linear interpolation between samples); "
                 "null without travel",
     lambda r: _t95(r.t, r.x, r.x0, r.travel) if r.moved else None),
    ("overshoot", "m", "extension (travel > 0): x_max - x_final; retraction: x_final - x_min; "
                       "null without travel", _overshoot),
    ("settling_time", "s", "time x enters the band |x - x_final| <= max(2 % |travel|, 1 mm) for "
                           "the last time (linear interpolation); 0 if it never leaves it",
     lambda r: _settling(r.t, r.x, r.x_final,
                         max(SETTLING_FRACTION * abs(r.travel), SETTLING_FLOOR))),
    ("p_a_max", "Pa", "peak absolute pressure in chamber A", lambda r: float(np.max(r.res.p_a))),
    ("p_b_max", "Pa", "peak absolute pressure in chamber B", lambda r: float(np.max(r.res.p_b))),
    ("T_max", "K", "peak gas temperature over both chambers",
     lambda r: float(max(np.max(r.res.T_a), np.max(r.res.T_b)))),
    ("T_min", "K", "lowest gas temperature over both chambers",
     lambda r: float(min(np.min(r.res.T_a), np.min(r.res.T_b)))),
    ("stick_events", "-", "number of stick events (piston stopping by friction)",
     lambda r: float(sum(1 for e in r.res.events if e["kind"] == "stick"))),
    ("air_consumption", "NL", "air drawn from the supply in normal litres (ANR): the time "
                              "integral (trapezoidal) of q_supply [kg/s] / 1.185 kg/m^3 x 1000",
     lambda r: air_consumption(r.t, r.res.q_supply)),
    # stroke metrics (pneucore.analysis.strokes: SMC's definitions, from the valve switching)
    ("start_up_time", "s", "valve switching to the piston starting to travel, first full stroke "
                           "(SMC); null without one",
     lambda r: _first_stroke(r, "start_up_time")),
    ("full_stroke_time_extend", "s", "valve switching to the far stroke end, first extension "
                                     "(SMC); null without one",
     lambda r: r.res.stroke_metrics()["full_stroke_time_extend"]),
    ("full_stroke_time_retract", "s", "valve switching to x = 0, first retraction (SMC); null "
                                      "without one",
     lambda r: r.res.stroke_metrics()["full_stroke_time_retract"]),
    ("mean_speed", "m/s", "stroke / full stroke time of the first full stroke (SMC's average "
                          "speed); null without one",
     lambda r: _first_stroke(r, "mean_speed")),
    ("max_speed", "m/s", "largest |v| over the run (sampled)",
     lambda r: float(np.max(np.abs(r.res.v)))),
    ("end_speed_max", "m/s", "largest stroke end velocity (|v| arriving at an end stop); null "
                             "without a full stroke",
     lambda r: r.res.stroke_metrics()["end_speed_max"]),
    ("air_per_cycle", "NL", "air drawn from the supply per extension + retraction (ANR), mean "
                            "over the full strokes each way; null without one each way",
     lambda r: r.res.stroke_metrics()["air_per_cycle_NL"]),
    ("end_energy_max", "J", "largest kinetic energy of the moving mass at a stroke end, m v^2 / 2 "
                            "(SMC's allowable kinetic energy check); null without a full stroke",
     lambda r: r.res.stroke_metrics()["end_energy_max"]),
    ("energy_ratio_max", "-", "largest stroke-end energy over the end cushion's capacity (effect "
                              "end_cushion; above 1 the cushion is too weak); null without a "
                              "capacity or a full stroke",
     lambda r: _energy_ratio_max(r)),
):
    register_metric(_name, _unit, _definition, _compute)
del _name, _unit, _definition, _compute


def _energy_ratio_max(r):
    ratios = [s["energy_ratio"] for s in r.res.stroke_metrics()["strokes"]
              if s["energy_ratio"] is not None]
    return max(ratios) if ratios else None


def _first_stroke(r, key):
    for s in r.res.stroke_metrics()["strokes"]:
        if s["direction"] != "partial" and s[key] is not None:
            return s[key]
    return None


def run_metrics(res, names=None):
    """Metrics of one simulation result.

    Parameters
    ----------
    res : SimulationResult
        A completed simulation
    names : list of str or None
        Metrics to compute (None = all of :data:`METRICS`)

    Returns
    -------
    metrics : dict
        name -> float in the metric's unit, or None where undefined (see :data:`METRICS`)
    """
    names = list(METRICS) if names is None else names
    run = RunSeries.of(res)
    out = {}
    for name in names:
        metric = METRICS.get(name)
        if metric is None:
            raise KeyError(f"unknown metric {name!r}")
        v = metric.compute(run)
        out[name] = None if v is None or not math.isfinite(v) else float(v)
    return out


def air_consumption(t, q_supply):
    """Normal litres (ANR, 1.185 kg/m^3) drawn from the supply: trapezoidal integral of q_supply.

    Parameters
    ----------
    t : array_like
        Sample times [s]
    q_supply : array_like
        Mass flow drawn from the supply [kg/s]

    Returns
    -------
    volume : float
        Air volume at normal conditions [NL]

    Examples
    --------
    1.185 g/s for one second is one normal litre:

    >>> air_consumption([0.0, 1.0], [1.185e-3, 1.185e-3])
    1.0
    """
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
