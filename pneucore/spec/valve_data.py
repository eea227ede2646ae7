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
from pneucore.spec.effects import EFFECTS
from pneucore.spec.model import VALVE_C_MAX
from pneucore.spec.validation import FieldError, known_keys, mapping, number

#: Unit of a sonic conductance, as the model's effects state it
C_UNIT = EFFECTS["meter_out_throttle"].param("C_a").unit
#: Every field a conversion may read: unit, description, the checks of
#: :func:`pneucore.spec.validation.number`, and the default (None = required)
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
