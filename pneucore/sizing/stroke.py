"""The sizing's view of one stroke: :func:`pneucore.analysis.strokes.stroke_metrics` plus the energy at
the end stop.

Every definition (start-up time, full-stroke time, mean, maximum and stroke-end speed, air
per stroke in normal litres) is SMC's, as :mod:`pneucore.analysis.strokes` implements it for every
simulation's ``stats.stroke``; this module only picks the stroke of one direction and adds
what the sizing checks and :mod:`pneucore.analysis.strokes` does not give: the kinetic energy of the
moving mass at the end stop, ``m v^2 / 2`` (SMC's selection step 2 checks it against the
cushion's capacity) [J].
"""
from __future__ import annotations

from pneucore.analysis.strokes import STROKE_FIELDS

#: The sizing's metric -> the field of :data:`pneucore.analysis.strokes.STROKE_FIELDS` it is
_FROM_STROKES = {"start_up_time": "start_up_time", "full_stroke_time": "full_stroke_time",
                 "mean_speed": "mean_speed", "max_speed": "max_speed", "end_speed": "end_speed",
                 "air": "air_NL"}
#: Each metric's unit (the answer's ``metrics.units``): those of :mod:`pneucore.analysis.strokes`,
#: and the kinetic energy's
STROKE_METRIC_UNITS = {**{k: STROKE_FIELDS[f][0] for k, f in _FROM_STROKES.items()},
                       "end_energy": "J"}


def direction_metrics(res, direction):
    """Stroke metrics of a run with one command, from rest at one end stop to the other.

    Parameters
    ----------
    res : SimulationResult
        A run whose valve is switched once (its ``command`` event), the piston at rest at
        one end stop
    direction : str
        ``extend`` (towards x = stroke) or ``retract`` (towards x = 0) [-]

    Returns
    -------
    metrics : dict
        ``start_up_time`` [s], ``full_stroke_time`` [s], ``mean_speed`` [m/s],
        ``max_speed`` [m/s], ``end_speed`` [m/s], ``end_energy`` [J], ``air`` [NL]
        (:data:`STROKE_METRIC_UNITS`); the times and speeds are None when the piston never
        reached that end stop within the run
    """
    strokes = res.stroke_metrics()["strokes"]
    out = dict.fromkeys(STROKE_METRIC_UNITS)
    if not strokes:
        return out
    s = strokes[0]
    out["air"] = s["air_NL"]
    out["start_up_time"] = s["start_up_time"]
    if s["direction"] != direction:
        return out
    for k, f in _FROM_STROKES.items():
        out[k] = s[f]
    if out["end_speed"] is not None:
        out["end_energy"] = 0.5 * res.model.jack.moving_mass * out["end_speed"] ** 2
    return out
