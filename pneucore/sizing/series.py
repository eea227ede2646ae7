"""Component series as data: cylinders, tubes and valves, each series with its one source.

The numbers live in ``series.json`` beside this module, in the units their source prints
them (mm, dm^3/(s bar)) with the source named for each series; :func:`load_series` converts
them to SI once. :func:`resolve_cylinders`, :func:`resolve_valves` and :func:`resolve_tubes`
turn a request's choices (series names, ``series:member`` names, or the user's own values)
into plain SI records.

>>> s = load_series()
>>> [c["rod"] for c in s["cylinders"]["iso15552"]["members"]][:3]   # 32, 40, 50 mm bores
[0.012, 0.016, 0.02]
"""
from __future__ import annotations

import copy
import functools
import json
import os

from pneucore.physics.flow import (P_ANR, QN_DP, QN_P1_GAUGE, R_LAMINAR, anr_volume_flow,
                                   iso6358_mass_flow)
from pneucore.physics.gas import GAMMA_AIR, R_AIR, T_REF
from pneucore.description.effects import EFFECTS
from pneucore.description.model import VALVE_C_MAX, Jack
from pneucore.description.valve_data import CONVERSIONS as VALVE_CONVERSIONS
from pneucore.description.valve_data import FIELDS as VALVE_FIELDS
from pneucore.description.valve_data import convert_valve_data
from pneucore.description.valve_data import unit as valve_unit
from pneucore.description.validation import FieldError, known_keys, number

#: File holding the series (beside this module)
SERIES_FILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "series.json")
#: SI factor of each unit the series file uses
_UNIT_FACTORS = {"mm": 1e-3, "m": 1.0, "dm^3/(s bar)": 1e-8, "J": 1.0}
#: A cylinder member's catalogue energies (in its series' ``energy_unit``) and the record key
#: each becomes: the kinetic energy its air cushion absorbs at most, and its rubber bumper
#: (the series without an air cushion)
CYLINDER_ENERGIES = {"cushion_energy": "cushion_capacity", "bumper_energy": "bumper_capacity"}


@functools.lru_cache(maxsize=None)
def _load():
    with open(SERIES_FILE, encoding="utf-8") as fh:
        raw = json.load(fh)
    out = {"cylinders": {}, "tubes": {}, "valves": {}, "dead_length": raw["dead_length"]}
    for kind, keys in (("cylinders", ("bore", "rod")), ("tubes", ("outer", "inner")),
                       ("valves", ("C", "C_exhaust"))):
        for name, series in raw[kind].items():
            f = _UNIT_FACTORS[series["unit"]]
            fe = _UNIT_FACTORS[series.get("energy_unit", "J")]
            members = []
            for m in series["members"]:
                m = dict(m)
                for k in keys:
                    m[k] = round(m[k] * f, 15)
                for k in CYLINDER_ENERGIES:
                    if k in m:
                        m[k] = round(m[k] * fe, 15)
                members.append(m)
            out[kind][name] = {**series, "members": members, "unit": "SI"}
    out["dead_length"] = {**raw["dead_length"],
                          "value": raw["dead_length"]["value"] * _UNIT_FACTORS[raw["dead_length"]["unit"]]}
    return out


def load_series():
    """The shipped series in SI units (a copy), with each series' ``source``.

    Returns
    -------
    series : dict
        ``cylinders``, ``tubes``, ``valves``: series name -> ``{"label", "source",
        "members"}``; ``dead_length``: the equivalent dead length of a cylinder chamber [m]
        with its source
    """
    return copy.deepcopy(_load())


def energy_series(key):
    """Names of the shipped cylinder series whose catalogue gives ``key``
    (``cushion_capacity`` or ``bumper_capacity``, :data:`CYLINDER_ENERGIES`) for every member."""
    src = {rec: k for k, rec in CYLINDER_ENERGIES.items()}[key]
    return [name for name, s in _load()["cylinders"].items()
            if s["members"] and all(src in m for m in s["members"])]


def dead_length():
    """Equivalent length of bore that each chamber's dead volume fills (see series.json) [m]."""
    return _load()["dead_length"]["value"]


def nominal_flow(C, b):
    """ISO 6358 nominal flow Qn of a valve edge: 6 bar gauge in, 5 bar gauge out, 20 degC.

    Derived from the edge's C and b (the model's one source) with the paper's Eq. 4-5, at
    the nominal-flow conditions of :mod:`pneucore.physics.flow` (``QN_P1_GAUGE``, ``QN_DP``
    over the ANR atmosphere ``P_ANR``): the inverse of
    :func:`pneucore.physics.flow.conductance_from_qn`, the way in from a catalogue's Qn.

    Parameters
    ----------
    C : float
        Sonic conductance [m^3/(s Pa)]
    b : float
        Critical pressure ratio [-]

    Returns
    -------
    qn : float
        Nominal flow [NL/min] (ANR, ISO 8778)

    Examples
    --------
    A 1 dm^3/(s bar) edge with b = 0.3. Choked at 7 bar abs it would pass SMC's worked
    figure 600 x C x (P1 + 0.1) = 600 x 1 x 0.7 = 420 NL/min (P1 in MPa gauge; SMC's
    "Solenoid valves flow characteristics"); at the nominal ratio 6 / 7 = 0.857 the
    subsonic law leaves sqrt(1 - ((0.857 - 0.3) / 0.7)^2) = 0.605 of it:

    >>> round(nominal_flow(1e-8, 0.3), 1)
    254.3
    """
    p1 = P_ANR + QN_P1_GAUGE
    q = iso6358_mass_flow(p1, T_REF, p1 - QN_DP, T_REF, C, b, 0.5, R_LAMINAR, R_AIR, GAMMA_AIR)
    return anr_volume_flow(q) * 60e3


def _resolve(kind, items, path, what, member_record, given_record):
    """The one walk over a request's choices of one kind: series names, ``series:member``
    names, or the user's own values.

    Parameters
    ----------
    kind : str
        Registry in the series file: ``cylinders``, ``valves`` or ``tubes``
    items : list
        The request's choices; empty = every shipped series of that kind
    path : str
        Field path named in errors
    what : str
        The component's name in messages (``cylinder``, ``valve``, ``tube``)
    member_record : callable
        ``member_record(member)``: the SI record of a shipped series member (its ``series``
        and ``name`` are added here)
    given_record : callable
        ``given_record(item, path)``: the SI record of a value the user gives, or a
        :class:`FieldError` naming ``path``

    Returns
    -------
    records : list of dict
        One per component, each with ``series`` (None for the user's own) and ``name``
    """
    registry = _load()[kind]
    out = []
    for i, item in enumerate(items or list(registry)):
        p = f"{path}[{i}]"
        if not isinstance(item, str):
            out.append({"series": None, **given_record(item, p)})
            continue
        series_name, _, member = item.partition(":")
        if series_name not in registry:
            raise FieldError(p, f"unknown {what} series {series_name!r}; expected one of "
                                f"{sorted(registry)} (or {what} values)")
        members = registry[series_name]["members"]
        if member:
            members = [m for m in members if m["name"] == member]
            if not members:
                raise FieldError(p, f"no {what} {member!r} in series {series_name!r}; expected "
                                    f"one of {[m['name'] for m in registry[series_name]['members']]}")
        out += [{"series": series_name, "name": f"{series_name}:{m['name']}", **member_record(m)}
                for m in members]
    return out


def _given_cylinder(item, p):
    if isinstance(item, (int, float)) and not isinstance(item, bool):
        raise FieldError(p, "a cylinder needs its rod too: give {\"bore\": [m], \"rod\": [m]} "
                            "or a series name")
    if not isinstance(item, dict):
        raise FieldError(p, f"must be a series name or {{\"bore\": [m], \"rod\": [m]}}, got "
                            f"{type(item).__name__}")
    known_keys(item, ("bore", "rod", "name"), p)
    bore = number(item.get("bore"), f"{p}.bore", positive=True)
    # the jack's own rule (one source): non-negative and smaller than the bore
    rod = Jack.checked_rod(item.get("rod", 0.0), bore, f"{p}.rod")
    return {"name": str(item.get("name") or f"bore {bore * 1e3:g} mm"), "bore": bore, "rod": rod}


def _given_valve(item, p):
    if not isinstance(item, dict):
        raise FieldError(p, f"must be a series name or {{\"C\": [m^3/(s Pa)], \"b\": [-]}}, "
                            f"got {type(item).__name__}")
    known_keys(item, ("C", "b", "C_exhaust", "b_exhaust", "name", *VALVE_FIELDS), p)
    figures = [k for k in VALVE_CONVERSIONS if item.get(k) is not None]
    if figures:
        # a catalogue's figure (Qn, effective area, one flow point): the valve converter's
        # registry turns it into C, the one way in (POST /api/valve/convert answers the same)
        if item.get("C") is not None:
            raise FieldError(f"{p}.C", f"give C or a catalogue figure ({figures[0]}), not both")
        conv = convert_valve_data({k: v for k, v in item.items() if k in VALVE_FIELDS}, p)
        C, b = conv["C"], conv["b"]
        fig = figures[0]
        label = f"{fig} {item[fig]:g} {valve_unit(fig)}"
    else:
        C = number(item.get("C"), f"{p}.C", positive=True, high=VALVE_C_MAX)
        b = number(item.get("b"), f"{p}.b", low=0.0, high=1.0, high_open=True)
        label = f"C {C:.3g} m^3/(s Pa)"
    Ce = number(item.get("C_exhaust", C), f"{p}.C_exhaust", positive=True, high=VALVE_C_MAX)
    be = number(item.get("b_exhaust", b), f"{p}.b_exhaust", low=0.0, high=1.0, high_open=True)
    return {"name": str(item.get("name") or label), "C": C, "b": b, "C_exhaust": Ce,
            "b_exhaust": be}


def _given_tube(item, p):
    # the tubing effect's own bounds (the one source): a design's model carries the tube there
    bound = EFFECTS["tubing"].param("diameter_a")
    d = number(item, p, low=bound.min, high=bound.max)
    return {"name": f"ID {d * 1e3:g} mm", "inner_diameter": d}


def resolve_cylinders(items, path="choices.bore"):
    """Cylinders named or given in ``items``; empty = every shipped cylinder series.

    Parameters
    ----------
    items : list
        Series names, ``series:member`` names or ``{"bore": [m], "rod": [m]}``
    path : str
        Field path named in errors

    Returns
    -------
    cylinders : list of dict
        ``{"series", "name", "bore" [m], "rod" [m]}``, and where the series' catalogue gives
        them ``cushion_capacity`` (the kinetic energy its air cushion absorbs at most) and
        ``bumper_capacity`` (its rubber bumper's) [J]
    """
    return _resolve("cylinders", items, path, "cylinder",
                    lambda m: {"bore": m["bore"], "rod": m["rod"],
                               **{rec: m[k] for k, rec in CYLINDER_ENERGIES.items() if k in m}},
                    _given_cylinder)


def resolve_valves(items, path="choices.valve"):
    """Valves named or given in ``items``; empty = every shipped valve series.

    Parameters
    ----------
    items : list
        Series names, ``series:member`` names or ``{"C": [m^3/(s Pa)], "b": [-]}`` with
        optional ``C_exhaust``, ``b_exhaust`` (default: as the supply edge) and ``name``;
        instead of ``C``, a catalogue's figure that :func:`pneucore.description.valve_data.convert_valve_data`
        converts: ``{"qn": [NL/min], "b": [-]}``, ``{"effective_area": [m^2], "b": [-]}`` or
        one flow point ``{"flow_rate": [m^3/s], "p1": [Pa], "p2": [Pa], "b": [-]}``
    path : str
        Field path named in errors

    Returns
    -------
    valves : list of dict
        ``{"series", "name", "C", "b", "C_exhaust", "b_exhaust", "qn"}`` (C in m^3/(s Pa),
        qn in NL/min)
    """
    out = _resolve("valves", items, path, "valve",
                   lambda m: {k: m[k] for k in ("C", "b", "C_exhaust", "b_exhaust")}, _given_valve)
    for v in out:
        v["qn"] = nominal_flow(v["C"], v["b"])
    return out


def resolve_tubes(items, path="choices.tube_inner_diameter"):
    """Tubes named or given in ``items``; empty = the shipped tube series.

    Parameters
    ----------
    items : list
        Series names, ``series:member`` names or inner diameters [m]
    path : str
        Field path named in errors

    Returns
    -------
    tubes : list of dict
        ``{"series", "name", "inner_diameter" [m]}``
    """
    return _resolve("tubes", items, path, "tube", lambda m: {"inner_diameter": m["inner"]},
                    _given_tube)
