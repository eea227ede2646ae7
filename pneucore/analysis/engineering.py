"""A finding in the words and units an engineer checks it by: where the effect acts (chamber A,
both chambers, the retract stroke) and how big it is in engineering units (a leak as a flow in
L/min ANR at the working pressure, a dead volume in cm³, a lag in ms).

One small function per catalog effect, in a registry by effect name (:data:`IN_WORDS`); an
effect without one is described by its parameters alone. The flows use the ISO 6358 / ISO 8778
reference density of :mod:`pneucore.physics.gas` (normal litres).
"""
from __future__ import annotations

from pneucore.physics.gas import RHO_REF

#: A side of an effect counts as absent when it is below this fraction of the larger side [-]:
#: a fit rarely returns an exact zero, and a tenth is well outside a side's typical error
ONE_SIDED = 0.1


def _nl_min(mass_flow):
    """A mass flow [kg/s] in normal litres per minute (ANR)."""
    return mass_flow / RHO_REF * 60e3


def _working_gauge(model):
    """The working pressure difference to ambient: supply minus ambient [Pa]."""
    return model.supply.pressure - model.ambient.pressure


def _bar(p):
    return f"{p / 1e5:.3g} bar"


def _piston_leak(p, model):
    dp = _working_gauge(model)
    q = _nl_min(p["conductance"] * dp)
    return (f"a leak across the piston seal (chamber A ↔ chamber B) of {q:.3g} L/min ANR with "
            f"{_bar(dp)} between the chambers")


def _external_leak(p, model):
    dp = _working_gauge(model)
    qa, qb = _nl_min(p.get("conductance_a", 0.0) * dp), _nl_min(p.get("conductance_b", 0.0) * dp)
    big = max(qa, qb)
    if big <= 0.0:
        return "no leak to ambient"
    if qb < ONE_SIDED * big:
        return f"a leak from chamber A to ambient (rod seal, fittings) of {qa:.3g} L/min ANR at {_bar(dp)} gauge; chamber B tight"
    if qa < ONE_SIDED * big:
        return f"a leak from chamber B to ambient (rod seal, fittings) of {qb:.3g} L/min ANR at {_bar(dp)} gauge; chamber A tight"
    return (f"leaks to ambient from both chambers: A {qa:.3g}, B {qb:.3g} L/min ANR at "
            f"{_bar(dp)} gauge")


def _dead_volume(p, model):
    va, vb = 1e6 * p.get("volume_a", 0.0), 1e6 * p.get("volume_b", 0.0)
    big = max(va, vb)
    if vb < ONE_SIDED * big:
        return f"{va:.3g} cm³ more volume on the chamber A side (tubing, fittings); none on B"
    if va < ONE_SIDED * big:
        return f"{vb:.3g} cm³ more volume on the chamber B side (tubing, fittings); none on A"
    return f"more volume between valve and chamber: A {va:.3g} cm³, B {vb:.3g} cm³"


def _spool(p, model):
    text = f"the valve opens {1e3 * p['time_constant']:.3g} ms late (first-order lag)"
    if p.get("natural_frequency", 0.0) > 0.0:
        text += (f", second order at {p['natural_frequency'] / 6.283185307179586:.3g} Hz, damping "
                 f"{p.get('damping', 0.7):.2g}")
    return text


def _sensor(p, model):
    return f"the pressure transducers read {1e3 * p['time_constant']:.3g} ms late (first-order lag)"


def _null_leak(p, model):
    return (f"a centred spool still passes {100 * p['fraction']:.3g} % of each edge's full "
            "conductance (all four edges)")


def _supply(p, model):
    return (f"the supply sags under flow: regulator conductance {p['C'] * 1e8:.3g} dm³/(s bar), "
            f"supply line {1e6 * p.get('volume', 0.0):.3g} cm³")


def _heat(p, model):
    return f"heat exchange with the walls at h = {p['h']:.3g} W/(m² K)"


def _quadrant(p, model):
    d = p.get("fc0", 0.0)
    stroke = "retract" if d > 0 else "extend"
    return (f"friction differs with the direction: the {stroke} stroke's Coulomb level is "
            f"{abs(d):.3g} N higher")


def _stribeck(p, model):
    return (f"breakaway friction {p['static_ratio']:.3g} times the Coulomb level, fading over "
            f"{1e3 * p.get('stribeck_velocity', 0.0):.3g} mm/s")


def _switching(p, model):
    text = f"the valve switches {1e3 * p['on_time']:.3g} ms after its command"
    if model.valve.rest_opening is not None:
        text += (f" when energised, {1e3 * p.get('off_time', 0.0):.3g} ms when de-energised "
                 "(its spring return)")
    return text + " (a pure delay, beside the catalogue's switching times)"


#: Effect name -> ``f(params, model) -> str`` (params as plain values in SI units)
IN_WORDS = {
    "valve_switching_delay": _switching,
    "piston_leakage": _piston_leak, "external_leakage": _external_leak,
    "dead_volume": _dead_volume, "valve_spool_dynamics": _spool, "sensor_lag": _sensor,
    "valve_null_leakage": _null_leak, "supply_pressure_drop": _supply,
    "heat_exchange": _heat, "quadrant_friction": _quadrant, "stribeck_friction": _stribeck,
}


def in_words(effect, params, model):
    """An effect's fitted parameters in engineering terms, or None without a registered wording.

    Parameters
    ----------
    effect : str
        Catalog effect name [-]
    params : dict
        Its parameters: plain values, or the diagnosis' ``{"value", ...}`` entries (SI) [-]
    model : Model
        The model it was fitted on (supply and ambient pressures) [-]

    Returns
    -------
    text : str or None
        E.g. "a leak across the piston seal (chamber A ↔ chamber B) of 3.1 L/min ANR with
        5.99 bar between the chambers" [-]

    Examples
    --------
    >>> from pneucore import Model, model_preset
    >>> in_words("dead_volume", {"volume_a": 1.2e-5, "volume_b": 0.0},
    ...          Model.from_dict(model_preset("paper-4way")))
    '12 cm³ more volume on the chamber A side (tubing, fittings); none on B'
    """
    fn = IN_WORDS.get(effect)
    if fn is None:
        return None
    values = {k: (v["value"] if isinstance(v, dict) else v) for k, v in (params or {}).items()}
    try:
        return fn(values, model)
    except (KeyError, TypeError, ZeroDivisionError):
        return None   # a parameter set the wording does not cover: the parameters speak alone


def _chamber_volumes(model):
    """Swept volumes of chambers A and B over the stroke [m^3]."""
    import math
    j = model.jack
    a_a = math.pi / 4.0 * (j.bore ** 2 - j.rod_a ** 2)
    a_b = math.pi / 4.0 * (j.bore ** 2 - j.rod_b ** 2)
    return a_a * j.stroke, a_b * j.stroke


def _valve_choked_flow(model):
    """The valve's largest edge flow, choked, from the supply [kg/s] (ISO 6358 Eq. 4:
    q = C p_s rho_ref at the reference temperature)."""
    ports = model.to_dict()["valve"]["ports"]
    c_max = max((max(e["C"]) for e in ports.values() if e.get("C")), default=0.0)
    return c_max * model.supply.pressure * RHO_REF


def _leak_impossible(flow, model, where):
    q_valve = _valve_choked_flow(model)
    if q_valve > 0.0 and flow > q_valve:
        return (f"{where} of {_nl_min(flow):.3g} L/min ANR would exceed what the valve itself "
                f"passes fully open ({_nl_min(q_valve):.3g} L/min ANR)")
    return ""


#: Effect name -> ``f(params, model) -> str``: why the fitted values are physically impossible
#: for this jack and valve ("" when they are not)
IMPOSSIBLE = {
    "dead_volume": lambda p, m: "; ".join(
        f"an extra volume on {side} of {1e6 * v:.3g} cm³ exceeds the chamber's own swept volume "
        f"({1e6 * swept:.3g} cm³)"
        for side, v, swept in zip(("A", "B"), (p.get("volume_a", 0.0), p.get("volume_b", 0.0)),
                                  _chamber_volumes(m)) if v > swept),
    "piston_leakage": lambda p, m: _leak_impossible(
        p["conductance"] * (m.supply.pressure - m.ambient.pressure), m, "a piston-seal leak"),
    "external_leakage": lambda p, m: "; ".join(filter(None, (
        _leak_impossible(p.get(k, 0.0) * (m.supply.pressure - m.ambient.pressure), m,
                         f"a leak of chamber {side}")
        for k, side in (("conductance_a", "A"), ("conductance_b", "B"))))),
}


def impossible(effect, params, model):
    """Why an effect's fitted values are physically impossible for this jack and valve, or "".

    A dead volume larger than the chamber it is added to, a leak that passes more than the
    valve does fully open: such a fit stands in for something else, whatever its evidence
    (issue 28, physical plausibility as a rule of the verdict).

    Parameters
    ----------
    effect : str
        Catalog effect name [-]
    params : dict
        Its parameters: plain values or ``{"value", ...}`` entries (SI) [-]
    model : Model
        The model it was fitted on [-]

    Returns
    -------
    reason : str
        Empty when the values are possible [-]

    Examples
    --------
    >>> from pneucore import Model, model_preset
    >>> m = Model.from_dict(model_preset("paper-4way"))   # chambers of about 173 cm³
    >>> impossible("dead_volume", {"volume_a": 4.84e-4, "volume_b": 0.0}, m)
    "an extra volume on A of 484 cm³ exceeds the chamber's own swept volume (173 cm³)"
    """
    fn = IMPOSSIBLE.get(effect)
    if fn is None:
        return ""
    values = {k: (v["value"] if isinstance(v, dict) else v) for k, v in (params or {}).items()}
    try:
        return fn(values, model)
    except (KeyError, TypeError, ValueError):
        return ""
