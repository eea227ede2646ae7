"""Stroke metrics of a simulation, as cylinder catalogues define them.

SMC's glossary of cylinder motion characteristics (SMC, *Best Pneumatics*, "Air
Cylinders Drive System: Full Stroke Time & Stroke End Velocity", Glossary of
Terms: Cylinders Motion Characteristics) times every stroke from the moment the
valve is switched:

1. **piston start-up time**: from the valve switching until the piston starts
   to travel (here: the first ``slip`` event after the command event, the
   moment the net force overcomes static friction, Eq. 18);
2. **full stroke time**: from the valve switching until the piston reaches the
   stroke end (here: the ``stop`` event at the far end);
3. **90 % force time**: from the valve switching until the cylinder's output
   reaches 90 % of its theoretical output, ``(p_s - p_atm) A`` of the driving
   chamber (here: the output ``(p_drive - p_atm) A_drive - (p_other - p_atm)
   A_other`` from the sampled pressures, linear interpolation between samples);
4. **stroke end velocity**: the piston's speed on arriving at the stroke end
   (here: ``|v|`` of the state at the located ``stop`` event, logged by the integrator
   at the impact, before the end stop takes the piston's momentum);

Each impact's **kinetic energy** ``m v^2 / 2`` [J] is reported against the end
cushion's **capacity** where the model gives one (effect ``end_cushion``,
``capacity``; SMC, *Best Pneumatics*, "Allowable kinetic energy": a cushion
absorbs at most its catalogue energy; :mod:`pneucore.physics.cushion`), for every
``stop`` event (``impacts``) and for the stop that ends each stroke.

and its charts give the **average speed** as the stroke over the full stroke
time. Besides those: the **maximum speed** over the stroke (sampled), and the
**air used** per stroke, the supply draw from the command to the next one in
normal litres (ANR, ISO 8778: the mass over 1.185 kg/m^3; every volume the
supply fills counts, tubes and dead volumes included), and per cycle (one
extension and one retraction: the sum of the mean air of the strokes each way).

A stroke is a command event followed by a stop at the far end before the next
command event; the direction is the end it reaches (``extend``: x = stroke,
``retract``: x = 0). Commands followed by no stop (a pulse, a locked test) give
the 90 % force time and the air used only, as a ``partial`` stroke.
"""
from __future__ import annotations

import math

import numpy as np

from pneucore.physics.cushion import kinetic_energy
from pneucore.physics.gas import RHO_REF

#: Fraction of the theoretical output of the 90 % force time [-]
FORCE_FRACTION = 0.9

#: Per-stroke metrics: name -> (unit, definition); :func:`stroke_metrics` fills these
STROKE_FIELDS = {
    "direction": ("-", "extend (reaches x = stroke), retract (reaches x = 0) or partial"),
    "t_command": ("s", "time of the valve switching"),
    "start_up_time": ("s", "valve switching to the piston starting to travel (SMC 1)"),
    "full_stroke_time": ("s", "valve switching to the stroke end (SMC 2)"),
    "force_90_time": ("s", "valve switching to 90 % of the theoretical output (SMC 3)"),
    "mean_speed": ("m/s", "stroke / full stroke time (SMC's average speed)"),
    "max_speed": ("m/s", "largest |v| between the switching and the stroke end (sampled, and "
                         "at the impact)"),
    "end_speed": ("m/s", "|v| on arriving at the stroke end (the state at the located impact; "
                         "the fastest of the stroke's impacts where the piston bounces)"),
    "end_energy": ("J", "kinetic energy of the moving mass at the impact, m v^2 / 2"),
    "cushion_capacity": ("J", "the end cushion's capacity (effect end_cushion; null when "
                              "not given)"),
    "energy_ratio": ("-", "end_energy / cushion_capacity (above 1: the cushion is too weak; "
                          "null without a capacity)"),
    "air_NL": ("NL", "air drawn from the supply from this command to the next, ANR"),
}


def _first_crossing(t, y, level, i0, i1):
    """First time in samples ``i0 .. i1 - 1`` where ``y`` reaches ``level`` (interpolated)."""
    seg = y[i0:i1]
    hit = np.flatnonzero(seg >= level)
    if hit.size == 0:
        return None
    k = i0 + int(hit[0])
    if k == i0 or y[k] == y[k - 1]:
        return float(t[k])
    return float(t[k - 1] + (level - y[k - 1]) / (y[k] - y[k - 1]) * (t[k] - t[k - 1]))


def stroke_metrics(res, model):
    """Stroke metrics of a simulation result (see the module docstring for the definitions).

    Parameters
    ----------
    res : SimulationResult
        The simulation
    model : Model
        Its (effective) model: stroke, areas, supply and ambient pressures

    Returns
    -------
    metrics : dict
        ``strokes``: one dict per command event (:data:`STROKE_FIELDS`, SI units, None where
        undefined); ``air_per_cycle_NL``: air per extension + retraction [NL] (None without a
        full stroke each way); ``full_stroke_time_extend`` and ``full_stroke_time_retract``:
        of the first full stroke each way [s]; ``end_speed_max``: the largest stroke end
        velocity [m/s], ``end_energy_max`` its kinetic energy [J]; ``impacts``: every ``stop`` event's ``t`` [s], ``end``, ``speed``
        [m/s], kinetic ``energy`` [J], the cushion's ``capacity`` [J] and ``energy_ratio``
    """
    # a run stopped early (status != 0) has NaN samples after the last time reached
    ok = np.isfinite(np.asarray(res.x, float))
    n = int(np.argmin(ok)) if not ok.all() else len(ok)
    t = np.asarray(res.t, float)[:n]
    v = np.asarray(res.v, float)[:n]
    acc = np.asarray(res.a, float)[:n]
    j = model.jack
    p_atm = model.ambient.pressure
    dp_s = model.supply.pressure - p_atm
    out_ext = (res.p_a[:n] - p_atm) * j.area_a - (res.p_b[:n] - p_atm) * j.area_b
    # cumulative supply draw (trapezoid) [kg], to difference between commands
    q = np.asarray(res.q_supply, float)[:n]
    cum = np.concatenate(([0.0], np.cumsum(0.5 * (q[1:] + q[:-1]) * np.diff(t))))

    mass = j.moving_mass
    cushion = getattr(model, "effects", {}).get("end_cushion")
    capacity = cushion.get("capacity") if cushion else None
    capacity = capacity if capacity else None
    impacts = [_impact(e, mass, capacity) for e in res.events
               if e["kind"] == "stop" and e["t"] <= (t[-1] if n else -math.inf)]
    if n < 2:
        return {"strokes": [], "full_stroke_time_extend": None, "full_stroke_time_retract": None,
                "end_speed_max": None, "end_energy_max": None, "air_per_cycle_NL": None,
                "impacts": impacts}
    cmd = [e["t"] for e in res.events if e["kind"] == "command" and e["t"] <= t[-1]]
    strokes = []
    for k, tc in enumerate(cmd):
        t_next = cmd[k + 1] if k + 1 < len(cmd) else math.inf
        window = [e for e in res.events if tc < e["t"] < t_next or
                  (e["t"] == tc and e["kind"] != "command")]
        stops = [e for e in window if e["kind"] == "stop"]
        slips = [e for e in window if e["kind"] == "slip"]
        i0 = int(np.searchsorted(t, tc, side="left"))
        i1 = int(np.searchsorted(t, min(t_next, t[-1]), side="right"))
        s = dict.fromkeys(STROKE_FIELDS)
        s["t_command"] = float(tc)
        s["direction"] = "partial"
        t_stop = None
        if stops:
            stop = stops[-1]
            t_stop = stop["t"]
            s["direction"] = "extend" if stop["mode"] == "stop@stroke" else "retract"
            s["full_stroke_time"] = float(t_stop - tc)
            s["mean_speed"] = j.stroke / s["full_stroke_time"] if t_stop > tc else None
            i_stop = int(np.searchsorted(t, t_stop, side="left"))
            # the hardest impact of the stroke (a cushioned piston may bounce off the
            # trapped air and meet the end again, slower)
            impact = max((_impact(e, mass, capacity) for e in stops),
                         key=lambda i: -1.0 if i["speed"] is None else i["speed"])
            s["end_speed"] = impact["speed"]
            s["end_energy"] = impact["energy"]
            s["cushion_capacity"] = impact["capacity"]
            s["energy_ratio"] = impact["energy_ratio"]
            if i_stop > i0:
                if impact["speed"] is None:
                    # a log without the impact velocity (a result stored before it was
                    # logged): the last sample's speed carried to the stop with its acceleration
                    k = i_stop - 1
                    s["end_speed"] = float(abs(v[k] + acc[k] * (t_stop - t[k])))
                s["max_speed"] = float(max(np.max(np.abs(v[i0:i_stop])), s["end_speed"]))
        if slips:
            s["start_up_time"] = float(slips[0]["t"] - tc)
        if dp_s > 0.0 and i1 > i0:
            if s["direction"] == "retract":
                F, F_th = -out_ext, dp_s * j.area_b
            elif s["direction"] == "extend":
                F, F_th = out_ext, dp_s * j.area_a
            else:     # partial: the side the output grows towards after the switching
                d = out_ext[i1 - 1] - out_ext[i0]
                F, F_th = (out_ext, dp_s * j.area_a) if d >= 0.0 else (-out_ext, dp_s * j.area_b)
            t90 = _first_crossing(t, F, FORCE_FRACTION * F_th, i0, i1)
            s["force_90_time"] = None if t90 is None else max(t90 - tc, 0.0)
        if i1 > i0:
            s["air_NL"] = float((cum[min(i1, n) - 1] - cum[i0]) / RHO_REF * 1000.0)
        strokes.append({k: (None if isinstance(val, float) and not math.isfinite(val) else val)
                        for k, val in s.items()})

    def first(direction, key):
        vals = [s[key] for s in strokes if s["direction"] == direction and s[key] is not None]
        return vals[0] if vals else None

    def mean_air(direction):
        vals = [s["air_NL"] for s in strokes if s["direction"] == direction
                and s["air_NL"] is not None]
        return sum(vals) / len(vals) if vals else None

    ext, ret = mean_air("extend"), mean_air("retract")
    ends = [s["end_speed"] for s in strokes if s["end_speed"] is not None]
    return {"strokes": strokes,
            "full_stroke_time_extend": first("extend", "full_stroke_time"),
            "full_stroke_time_retract": first("retract", "full_stroke_time"),
            "end_speed_max": max(ends) if ends else None,
            "end_energy_max": kinetic_energy(mass, max(ends)) if ends else None,
            "air_per_cycle_NL": ext + ret if ext is not None and ret is not None else None,
            "impacts": impacts}


def _impact(stop, mass, capacity):
    """Speed [m/s], kinetic energy [J] and the energy against the capacity [J] of one ``stop``
    event (its logged impact velocity ``v``)."""
    v = stop.get("v")
    speed = abs(float(v)) if v is not None and math.isfinite(v) else None
    energy = kinetic_energy(mass, speed) if speed is not None else None
    return {"t": float(stop["t"]), "end": "x = stroke" if stop["mode"] == "stop@stroke" else "x = 0",
            "speed": speed, "energy": energy, "capacity": capacity,
            "energy_ratio": energy / capacity if capacity and energy is not None else None}
