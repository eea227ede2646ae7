"""Stroke metrics of one full stroke, from a :class:`~pneucore.result.SimulationResult`.

The definitions are those of the manufacturers' stroke-time tables and sizing tools (SMC's
"Air Cylinders Model Selection" and its stroke-time data, read for meter-out speed
controllers and 1-3 m of tube):

* **start-up time**: from the valve's command (t = 0 of the run) until the piston starts
  to move (the run's first ``slip`` event) [s];
* **full-stroke time**: from the valve's command until the piston reaches the end stop,
  start-up included (the run's first ``stop`` event at the far end) [s];
* **mean speed**: the stroke over the full-stroke time (the sizing charts' "average
  speed") [m/s];
* **maximum speed**: the largest |v| on the way [m/s];
* **stroke-end speed**: |v| at the instant of the end stop (the impact speed a cushion or a
  stopper must absorb; SMC's selection step 2 checks the kinetic energy ``m v^2 / 2`` it
  gives against the cushion's capacity) [m/s];
* **air**: the air drawn from the supply over the run, in normal litres (ANR, ISO 8778:
  20 degC, 100 kPa, 65 % RH; density :data:`pneucore.physics.gas.RHO_REF`, as the rest of
  pneucore) [NL]: the mass the pressurised chamber gains over the run (chamber A while
  extending, B while retracting); its exhaust edge is closed, so every gram came through
  the supply edge. (Integrating the sampled supply flow instead misses the first
  milliseconds' steep filling: 9 % on a retraction sampled every 6 ms.)

Note: the reference corpus this was written from held SMC's "Air Cylinders Model
Selection" (load factor, stroke-end impact) but not the page that words these definitions;
they follow the sizing tools' common usage and the issue's list (issue 23, item 8).
"""
from __future__ import annotations

import math

import numpy as np

from pneucore.physics.gas import RHO_REF

#: Each metric's unit (the answer's ``metrics.units``)
STROKE_METRIC_UNITS = {
    "start_up_time": "s", "full_stroke_time": "s", "mean_speed": "m/s", "max_speed": "m/s",
    "end_speed": "m/s", "end_energy": "J", "air": "NL",
}
#: The end stop of each direction, as the result's events name it
_END_MODE = {"extend": "stop@stroke", "retract": "stop@0"}


def air_normal_litres(mass):
    """A mass of air as a volume at the ISO 8778 reference atmosphere [NL].

    Parameters
    ----------
    mass : float
        Mass of air [kg]

    Returns
    -------
    volume : float
        Normal litres (ANR: 20 degC, 100 kPa, 65 % RH) [NL]

    Examples
    --------
    >>> round(air_normal_litres(1.185e-3), 6)   # the reference density: 1 NL
    1.0
    """
    return mass / RHO_REF * 1e3


def stroke_metrics(res, direction):
    """Stroke metrics of a run that starts at one end stop and is commanded to the other.

    Parameters
    ----------
    res : SimulationResult
        A run commanded at t = 0, starting at rest at one end stop
    direction : str
        ``extend`` (towards x = stroke) or ``retract`` (towards x = 0) [-]

    Returns
    -------
    metrics : dict
        ``start_up_time`` [s], ``full_stroke_time`` [s], ``mean_speed`` [m/s],
        ``max_speed`` [m/s], ``end_speed`` [m/s], ``end_energy`` [J], ``air`` [NL]
        (units: :data:`STROKE_METRIC_UNITS`); the times and speeds are None when the piston
        never started, or never reached the end stop within the run
    """
    t, v = np.asarray(res.t, float), np.asarray(res.v, float)
    stroke = res.model.jack.stroke
    start = next((e["t"] for e in res.events if e["kind"] == "slip"), None)
    end = next((e["t"] for e in res.events if e["kind"] == "stop" and e["mode"] == _END_MODE[direction]
                and (start is None or e["t"] > start)), None)
    m = np.asarray(res.m_a if direction == "extend" else res.m_b, float)
    m = m[np.isfinite(m)]
    air = air_normal_litres(float(m[-1] - m[0])) if len(m) > 1 else 0.0
    out = dict.fromkeys(STROKE_METRIC_UNITS)
    out["air"] = air
    out["start_up_time"] = start
    if start is None or end is None:
        return out
    moving = (t >= start) & (t < end)
    out["full_stroke_time"] = end
    out["mean_speed"] = stroke / end
    out["max_speed"] = float(np.max(np.abs(v[moving]))) if moving.any() else 0.0
    out["end_speed"] = _speed_at(t, v, end)
    out["end_energy"] = 0.5 * res.model.jack.moving_mass * out["end_speed"] ** 2
    return out


def _speed_at(t, v, t_end):
    """|v| just before ``t_end``: the last two samples before it, extrapolated linearly."""
    k = int(np.searchsorted(t, t_end, side="left")) - 1
    if k < 0:
        return 0.0
    if k == 0 or t[k] >= t_end:
        return abs(float(v[k]))
    slope = (v[k] - v[k - 1]) / (t[k] - t[k - 1])
    val = v[k] + slope * (t_end - t[k])
    # the extrapolation never reverses the motion, and a sample at the stop itself is exact
    return abs(float(val)) if math.copysign(1.0, val) == math.copysign(1.0, v[k]) else 0.0
