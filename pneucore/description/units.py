"""Display unit systems of the page: SI, or engineering units (bar absolute or gauge, mm, L/min ANR, °C).

The service computes in SI with absolute pressures; a unit system only says
how a quantity is *shown*: ``display = (si - offset) / scale``. The page
reads these tables from ``GET /api/units`` (one source, no copy in the
JavaScript). ``"gauge"`` as an offset means the model's ambient pressure.

Normal litres per minute (ANR, ISO 8778: 20 °C, 1 bar... here the reference
density ``RHO_REF`` of :mod:`pneucore.physics.gas`) turn a mass flow into the volume
flow a flow meter of the air-preparation unit shows: 1 L/min ANR =
``RHO_REF * 1e-3 / 60`` kg/s.
"""
from __future__ import annotations

from pneucore.physics.gas import RHO_REF, T_ZERO_CELSIUS

__all__ = ["UNIT_SYSTEMS", "unit_systems", "difference_shown"]

#: Engineering units shown for each SI unit: (shown unit, scale to SI, offset to SI)
_ENGINEERING = {
    "Pa": ("bar abs", 1e5, 0.0),
    "m": ("mm", 1e-3, 0.0),
    "m/s": ("mm/s", 1e-3, 0.0),
    "m^3": ("cm³", 1e-6, 0.0),
    "m^2": ("cm²", 1e-4, 0.0),
    "kg/s": ("L/min ANR", RHO_REF * 1e-3 / 60.0, 0.0),
    "m^3/(s Pa)": ("dm³/(s bar)", 1e-3 / 1e5, 0.0),
    "K": ("°C", 1.0, T_ZERO_CELSIUS),
}

#: SI unit -> (shown unit, scale to SI, offset to SI) for each system; units absent are shown in SI
UNIT_SYSTEMS: dict[str, dict] = {
    "si": {"label": "SI (Pa, m, m³, kg/s)", "units": {}},
    "engineering": {"label": "engineering (bar abs, mm, cm³, L/min ANR, °C)",
                    "units": dict(_ENGINEERING)},
    "engineering-gauge": {"label": "engineering, gauge pressures (bar g, mm, cm³, L/min ANR, °C)",
                          "units": {**_ENGINEERING, "Pa": ("bar g", 1e5, "gauge")}},
}


def unit_systems() -> dict:
    """The systems as plain JSON: ``{name: {label, units: {si: {unit, scale, offset}}}}``."""
    return {name: {"label": s["label"],
                   "units": {si: {"unit": u, "scale": sc, "offset": off}
                             for si, (u, sc, off) in s["units"].items()}}
            for name, s in UNIT_SYSTEMS.items()}


def difference_shown(si_unit: str, system: str = "engineering") -> tuple[str, float]:
    """How a message words a *difference* of a quantity: (unit shown, factor from SI).

    Derived from :data:`UNIT_SYSTEMS` (the one source of shown units): the scale
    without the offset, since a difference has no zero (0.01 bar(g) and 0.01 bar abs
    are the same 1,000 Pa; a difference of 1 °C is 1 K, so temperatures stay in K);
    "abs" and "g" are dropped from the label for the same reason. Units the system
    does not list are shown in SI.

    Parameters
    ----------
    si_unit : str
        The quantity's SI unit, as :data:`UNIT_SYSTEMS` spells it [-]
    system : str
        A name of :data:`UNIT_SYSTEMS` [-]

    Returns
    -------
    shown : tuple
        (unit shown, factor: shown = factor * SI difference) [-]

    >>> difference_shown("Pa"), difference_shown("m"), difference_shown("K")
    (('bar', 1e-05), ('mm', 1000.0), ('K', 1.0))
    """
    entry = UNIT_SYSTEMS[system]["units"].get(si_unit)
    if entry is None or si_unit == "K":
        return si_unit, 1.0
    unit, scale, _ = entry
    unit = unit.removesuffix(" abs").removesuffix(" g")
    return unit, 1.0 / scale
