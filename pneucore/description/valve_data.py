"""Valve data as catalogues give them, converted to the model's sonic conductance C and
critical ratio b (issue 23, item 7): the model keeps C and b as the one source, and these
conversions are the way in from a catalogue's other figures.

Each conversion is registered in :data:`CONVERSIONS` by the catalogue figure that names it
(``qn``, ``effective_area``, ``cv``, ``kv``, ``flow_rate``), with the fields it reads
(:data:`FIELDS`, each with its unit) and the physics it calls (:mod:`pneucore.physics.flow`, where each law is
cited). The critical ratio b is the catalogue's own in every case: none of these figures
gives it (a nominal flow, an area, a Cv or Kv or one flow point fix the conductance only).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from pneucore.physics.flow import (QN_DP, QN_P1_GAUGE, conductance_from_area,
                                   conductance_from_cv, conductance_from_flow, conductance_from_kv,
                                   conductance_from_qn)
from pneucore.physics.gas import T_REF
from pneucore.description.effects import EFFECTS
from pneucore.description.model import VALVE_C_MAX
from pneucore.description.validation import FieldError, known_keys, mapping, number

#: Unit of a sonic conductance, as the model's effects state it
C_UNIT = EFFECTS["meter_out_throttle"].param("C_a").unit
#: Every field a conversion may read: unit, description, the checks of
#: :func:`pneucore.description.validation.number`, and the default (None = required)
FIELDS = {
    "qn": ("NL/min", f"nominal flow (ISO 6358-1 / VDI 3290: {QN_P1_GAUGE / 1e5:g} bar gauge "
                     f"upstream, {QN_DP / 1e5:g} bar drop), at ANR", {"positive": True}, None),
    "effective_area": ("m^2", "effective area S (JIS B 8390)", {"positive": True}, None),
    "cv": ("US gal/min", "flow coefficient Cv (water at 1 psi drop; ISA-75.01.01 / IEC 60534)",
           {"positive": True}, None),
    "kv": ("m^3/h", "flow coefficient Kv (water at 1 bar drop; IEC 60534-1: Kv = 0.865 Cv)",
           {"positive": True}, None),
    "flow_rate": ("m^3/s", "one measured flow point, volume flow at ANR (ISO 8778)",
                  {"positive": True}, None),
    "p1": ("Pa", "upstream absolute pressure of the flow point", {"positive": True}, None),
    "p2": ("Pa", "downstream absolute pressure of the flow point", {"positive": True}, None),
    "T1": ("K", "upstream temperature of the flow point", {"positive": True}, T_REF),
    "b": ("-", "critical pressure ratio, the catalogue's (none of the figures gives it)",
          {"low": 0.0, "high": 1.0, "high_open": True}, None),
}


@dataclass(frozen=True)
class Conversion:
    """One catalogue figure to C.

    Parameters
    ----------
    fields : tuple
        Names of :data:`FIELDS` it reads [-]
    convert : callable
        ``convert(values) -> C`` [m^3/(s Pa)]
    source : str
        The law and its source, in words [-]
    """
    fields: tuple
    convert: Callable
    source: str


#: Conversions by the catalogue figure that names them
CONVERSIONS = {
    "qn": Conversion(("qn", "b"), lambda v: conductance_from_qn(v["qn"], v["b"]),
                     "ISO 6358 flow law (paper Eq. 4) inverted at the nominal-flow conditions "
                     "(pneucore.physics.flow.conductance_from_qn)"),
    "effective_area": Conversion(("effective_area", "b"),
                                 lambda v: conductance_from_area(v["effective_area"]),
                                 "the ideal nozzle's choked flow (paper Eq. 2) equated to Eq. 5 "
                                 "(pneucore.physics.flow.conductance_from_area; catalogues: "
                                 "S [mm^2] = 5.0 C [dm^3/(s bar)])"),
    "cv": Conversion(("cv", "b"), lambda v: conductance_from_cv(v["cv"], v["b"]),
                     "ISA-75.01.01 / IEC 60534-2-1 gas sizing equation (N7 = 1360 scfh, psia, "
                     "degR) at choked flow, Y = 2/3, with x_T = 1 - b: C = (2/3) N7 Cv "
                     "sqrt(x_T / T0); below choke it runs up to 6.1 % above the ISO 6358 law "
                     "(pneucore.physics.flow.conductance_from_cv)"),
    "kv": Conversion(("kv", "b"), lambda v: conductance_from_kv(v["kv"], v["b"]),
                     "Kv = 0.865 Cv (IEC 60534-1), then the Cv conversion "
                     "(pneucore.physics.flow.conductance_from_kv)"),
    "flow_rate": Conversion(("flow_rate", "p1", "p2", "T1", "b"),
                            lambda v: conductance_from_flow(v["flow_rate"], v["p1"], v["p2"],
                                                            v["b"], v["T1"]),
                            "ISO 6358 flow law (paper Eq. 4-5) inverted at one flow point "
                            "(pneucore.physics.flow.conductance_from_flow)"),
}


def unit(name):
    """The unit of field ``name`` of :data:`FIELDS` [-]."""
    return FIELDS[name][0]


def convert_valve_data(d, path="valve"):
    """Sonic conductance and critical ratio from one catalogue figure.

    Parameters
    ----------
    d : dict
        Exactly one of the figures that name a conversion (``qn`` [NL/min],
        ``effective_area`` [m^2], ``cv`` [US gal/min], ``kv`` [m^3/h], ``flow_rate``
        [m^3/s]), the fields that conversion reads, and ``b`` [-]
    path : str
        Field path named in errors

    Returns
    -------
    answer : dict
        ``C`` [m^3/(s Pa)], ``b`` [-], ``conversion`` (its name), ``source`` and ``units``

    Examples
    --------
    A valve of C = 1 dm^3/(s bar), b = 0.3 has a nominal flow of 254 NL/min:

    >>> ans = convert_valve_data({"qn": 254.27, "b": 0.3})
    >>> round(ans["C"] / 1e-8, 3), ans["b"]
    (1.0, 0.3)
    """
    mapping(d, path)
    known_keys(d, FIELDS, path)
    given = [k for k in CONVERSIONS if d.get(k) is not None]
    if len(given) != 1:
        raise FieldError(path, f"give exactly one of {sorted(CONVERSIONS)} (got "
                               f"{sorted(given) or 'none'})")
    name = given[0]
    conv = CONVERSIONS[name]
    extra = sorted(k for k in d if k not in conv.fields and d[k] is not None)
    if extra:
        raise FieldError(f"{path}.{extra[0]}", f"is not read by the {name} conversion (it reads "
                                               f"{list(conv.fields)})")
    values = {}
    for key in conv.fields:
        u, _, checks, default = FIELDS[key]
        v = d.get(key, default)
        if v is None:
            raise FieldError(f"{path}.{key}", f"is required [{u}]")
        try:
            values[key] = number(v, f"{path}.{key}", **checks)
        except FieldError as exc:
            raise FieldError(exc.path, f"{exc.detail} [{u}]") from None
    if name == "flow_rate" and values["p2"] >= values["p1"]:
        raise FieldError(f"{path}.p2", f"must be below p1 = {values['p1']:g} Pa, got "
                                       f"{values['p2']:g} [Pa]")
    C = conv.convert(values)
    if not C <= VALVE_C_MAX:   # the valve table's own bound (one source)
        raise FieldError(f"{path}.{name}", f"gives a sonic conductance of {C:.3g} m^3/(s Pa), "
                                           f"above the largest a valve may have ({VALVE_C_MAX:g})")
    return {"C": C, "b": values["b"], "conversion": name, "source": conv.source,
            "units": {"C": C_UNIT, "b": unit("b")}}


#: On/off valves as catalogues sell them (:func:`catalogue_valve`): the model's valve kind, the
#: rest (de-energised, spring) position, and each edge's conductance over the openings -1, 0, 1
#: as fractions of the catalogue's supply (``s``) or exhaust (``x``) figure. u = +1 drives
#: chamber A (extends), -1 chamber B; a 5/3 valve's centre is u = 0.
CATALOGUE_VALVES = {
    "3/2": {"kind": "3/2", "rest": 0.0, "monostable": True,
            "description": "3/2 on/off, normally closed: energised P-A, at rest A-R",
            "edges": {"P-A": ((0.0, 1.0), "s", (0.0, 1.0)), "A-R": ((0.0, 1.0), "x", (1.0, 0.0))}},
    "5/2": {"kind": "4/2", "rest": -1.0, "monostable": True,
            "description": "5/2 on/off: energised P-A and B-R (extends), at rest (spring) P-B "
                           "and A-R (retracts); bistable (double solenoid): no rest",
            "edges": {"P-A": ((-1.0, 1.0), "s", (0.0, 1.0)), "B-R": ((-1.0, 1.0), "x", (0.0, 1.0)),
                      "P-B": ((-1.0, 1.0), "s", (1.0, 0.0)), "A-R": ((-1.0, 1.0), "x", (1.0, 0.0))}},
    "5/3-closed": {"kind": "4/2", "rest": 0.0, "monostable": True,
                   "description": "5/3 closed centre: at rest every port closed (the piston held "
                                  "by the trapped air)",
                   "edges": {"P-A": ((-1.0, 0.0, 1.0), "s", (0.0, 0.0, 1.0)),
                             "B-R": ((-1.0, 0.0, 1.0), "x", (0.0, 0.0, 1.0)),
                             "P-B": ((-1.0, 0.0, 1.0), "s", (1.0, 0.0, 0.0)),
                             "A-R": ((-1.0, 0.0, 1.0), "x", (1.0, 0.0, 0.0))}},
    "5/3-exhausted": {"kind": "4/2", "rest": 0.0, "monostable": True,
                      "description": "5/3 exhausted (open) centre: at rest A and B to exhaust, "
                                     "P closed (the piston free)",
                      "edges": {"P-A": ((-1.0, 0.0, 1.0), "s", (0.0, 0.0, 1.0)),
                                "B-R": ((-1.0, 0.0, 1.0), "x", (0.0, 1.0, 1.0)),
                                "P-B": ((-1.0, 0.0, 1.0), "s", (1.0, 0.0, 0.0)),
                                "A-R": ((-1.0, 0.0, 1.0), "x", (1.0, 1.0, 0.0))}},
    "5/3-pressurised": {"kind": "4/2", "rest": 0.0, "monostable": True,
                        "description": "5/3 pressurised centre: at rest P to A and B, exhausts "
                                       "closed (a single-rod piston pushed out by the area "
                                       "difference)",
                        "edges": {"P-A": ((-1.0, 0.0, 1.0), "s", (0.0, 1.0, 1.0)),
                                  "B-R": ((-1.0, 0.0, 1.0), "x", (0.0, 0.0, 1.0)),
                                  "P-B": ((-1.0, 0.0, 1.0), "s", (1.0, 1.0, 0.0)),
                                  "A-R": ((-1.0, 0.0, 1.0), "x", (1.0, 0.0, 0.0))}},
}
#: Fields of a catalogue valve besides the flow figures (unit, description)
CATALOGUE_FIELDS = {
    "function": ("-", "valve function: " + ", ".join(CATALOGUE_VALVES)),
    "on_time": ("s", "switching time energising (catalogue 'response time ON', ISO 12238 "
                     "shifting time)"),
    "off_time": ("s", "switching time de-energising (catalogue 'response time OFF': the "
                      "spring's return)"),
    "bistable": ("-", "5/2 only: double solenoid (no spring, every change takes on_time)"),
    "supply": ("-", "flow figure of the P to A/B paths: {C [m^3/(s Pa)], b [-]} or a "
                    "conversion's fields (qn [NL/min], cv, kv, effective_area, flow_rate; b)"),
    "exhaust": ("-", "flow figure of the A/B to R paths, same form; null = the supply's"),
}


def _flow_figure(d, path):
    """C [m^3/(s Pa)] and b [-] from ``{C, b}`` or one catalogue conversion's fields."""
    mapping(d, path)
    if "C" in d:
        known_keys(d, ("C", "b"), path)
        C = number(d.get("C"), f"{path}.C", positive=True, high=VALVE_C_MAX)
        b = number(d.get("b"), f"{path}.b", low=0.0, high=1.0, high_open=True)
        return C, b
    ans = convert_valve_data(d, path)
    return ans["C"], ans["b"]


def catalogue_valve(d, path="valve"):
    """A model valve from a catalogue's figures: function, flow, switching times.

    The switching times are ISO 12238's shifting times as solenoid-valve catalogues give them
    ("response time ON / OFF", SMC, Festo, CKD: 5 to 50 ms), taken as a pure delay from the
    command to the spool's full shift (:func:`pneucore.physics.valve.switched_command`). ISO
    12238 measures to a pressure change at the outlet port (the national standards before it
    to its first change, 50 % or 90 %: Dyksterhouse, Fluid Power Journal), so a catalogue
    time already holds a few ms of a test volume's filling: read it as an upper bound of the
    spool's delay.

    Parameters
    ----------
    d : dict
        ``function`` (a key of :data:`CATALOGUE_VALVES`), ``supply`` and optional ``exhaust``
        flow figures (``{C [m^3/(s Pa)], b [-]}``, or ``qn`` [NL/min], ``cv`` [US gal/min],
        ``kv`` [m^3/h], ``effective_area`` [m^2] or a flow point, each with ``b`` [-]: the
        ISO 6358 conversions of :data:`CONVERSIONS`), ``on_time`` and ``off_time`` [s],
        ``bistable`` (5/2 only) [-]
    path : str
        Field path named in errors

    Returns
    -------
    valve : dict
        The model's ``valve`` (``Model.from_dict`` accepts it): edge tables, ``on_time``,
        ``off_time``, ``rest_opening``

    Examples
    --------
    A 5/2 valve of C = 1 dm^3/(s bar), b = 0.3, ON 12 ms, OFF 20 ms:

    >>> v = catalogue_valve({"function": "5/2", "supply": {"C": 1e-8, "b": 0.3},
    ...                      "on_time": 0.012, "off_time": 0.02})
    >>> v["kind"], v["ports"]["P-A"]["C"], v["rest_opening"]
    ('4/2', [0.0, 1e-08], -1.0)
    """
    from pneucore.description.model import MAX_SWITCHING_TIME
    mapping(d, path)
    known_keys(d, CATALOGUE_FIELDS, path)
    fn = d.get("function")
    if fn not in CATALOGUE_VALVES:
        raise FieldError(f"{path}.function", f"must be one of {list(CATALOGUE_VALVES)}, got {fn!r}")
    spec = CATALOGUE_VALVES[fn]
    Cs, bs = _flow_figure(d.get("supply"), f"{path}.supply")
    Cx, bx = (Cs, bs) if d.get("exhaust") is None else _flow_figure(d["exhaust"], f"{path}.exhaust")
    times = {k: number(d.get(k, 0.0), f"{path}.{k}", nonnegative=True, high=MAX_SWITCHING_TIME)
             for k in ("on_time", "off_time")}
    bistable = d.get("bistable", False)
    if not isinstance(bistable, bool):
        raise FieldError(f"{path}.bistable", f"must be true or false, got {bistable!r}")
    if bistable and fn != "5/2":
        raise FieldError(f"{path}.bistable", "only a 5/2 valve comes bistable (double "
                                             "solenoid); a 3/2 or 5/3 valve has a spring")
    ports = {}
    for edge, (opening, which, frac) in spec["edges"].items():
        C, b = (Cs, bs) if which == "s" else (Cx, bx)
        ports[edge] = {"opening": list(opening), "C": [f * C for f in frac],
                       "b": [b] * len(opening)}
    out = {"kind": spec["kind"], "ports": ports, **times,
           "rest_opening": None if bistable else spec["rest"]}
    if spec["kind"] == "3/2":
        out["b_chamber"] = "vented"    # a single-acting cylinder: chamber B open to the air
        out["b_chamber_pressure"] = None
    return out
