"""Test-rig measurements of a pneumatic jack.

A :class:`Measurement` is a time series sampled on a test rig: the time
``t`` [s], the valve command ``u`` [-] and any of the chamber pressures
``p_a``, ``p_b`` [Pa], the rod position ``x`` [m], and optionally the rod
velocity ``v`` [m/s], chamber temperatures ``T_a``, ``T_b`` [K], the rod force
``F`` [N] (the force the rod exerts on its load, positive outward: a load
cell), the mass flows ``q_a``, ``q_b`` into each chamber and ``q_s`` drawn
from the supply [kg/s] (flow meters; accepted in L/min ANR, NL/min, m³/h ANR,
g/s and kg/s, converted with the one ANR density
:data:`pneucore.physics.gas.RHO_REF`) and the supply pressure ``p_s`` [Pa].

All quantities are stored in SI units; pressures are absolute. Measurements
are read from CSV files (:func:`read_csv`) or from plain JSON-like
dictionaries (:meth:`Measurement.from_dict`). Column names may carry a unit
in brackets, e.g. ``p_a[bar]``, ``p_a[barg]`` (gauge), ``x[mm]``,
``T_a[degC]``, ``t[ms]`` or ``u[%]``; see :func:`parse_header`.

Both constructors share one validation path (:meth:`Measurement.validate`),
and every problem is reported as a :class:`MeasurementError` naming the
offending column and data row whenever they are known.

Examples
--------
>>> text = "t[s],u[%],p_a[barg]\\n" + "".join(
...     f"{0.01 * i:.2f},{0 if i < 5 else 50},{0.5 * (i >= 5)}\\n" for i in range(10))
>>> m = read_csv(text)
>>> m.n, m.measured_signals
(10, ('p_a',))
>>> m.command_breakpoints()
[[0.0, 0.0], [0.05, 0.5]]
"""

from __future__ import annotations

import csv
import difflib
import json
import math
import numbers
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

import numpy as np

from pneucore.physics.gas import P_ATM, PSI, RHO_REF, T_ZERO_CELSIUS

__all__ = [
    "MeasurementError",
    "Measurement",
    "read_csv",
    "read_table",
    "decode_text",
    "parse_header",
    "canonical_unit",
    "propose_mapping",
    "check_mapping",
    "resolve_column",
    "MAX_COLUMNS",
    "ALIASES",
    "EXPORT_MARKER",
    "SIGNALS",
    "SIGNAL_UNITS",
    "sensor_zero",
    "UNITS",
    "MIN_SAMPLES",
    "MAX_SAMPLES",
    "DEFAULT_AMBIENT_PRESSURE",
]

SIGNALS: tuple[str, ...] = ("u", "p_a", "p_b", "x", "v", "T_a", "T_b", "F", "q_a", "q_b", "q_s",
                             "p_s")
"""Known signal names (the time column ``t`` is not a signal)."""

SIGNAL_UNITS: dict[str, str] = {
    "u": "-",
    "p_a": "Pa",
    "p_b": "Pa",
    "x": "m",
    "v": "m/s",
    "T_a": "K",
    "T_b": "K",
    "F": "N",
    "q_a": "kg/s",
    "q_b": "kg/s",
    "q_s": "kg/s",
    "p_s": "Pa",
}
"""SI unit of each signal as stored in a :class:`Measurement`."""


def sensor_zero(signal, ambient):
    """The value a sensor's gain error scales about: ambient pressure for a pressure (a gauge
    sensor's span starts at the atmosphere, so a gain error leaves ambient read right), zero
    for every other signal.

    Parameters
    ----------
    signal : str
        Signal name (:data:`SIGNALS`) [-]
    ambient : float
        Ambient pressure [Pa]

    Returns
    -------
    float
        The zero of the gain, in the signal's SI unit (:data:`SIGNAL_UNITS`)

    >>> sensor_zero("p_s", 101300.0), sensor_zero("x", 101300.0)
    (101300.0, 0.0)
    """
    return float(ambient) if SIGNAL_UNITS.get(signal) == "Pa" else 0.0

MIN_SAMPLES: int = 10
"""Minimum number of samples (data rows) of a measurement."""

MAX_SAMPLES: int = 2_000_000
"""Maximum number of samples (data rows) of a measurement."""

MAX_COLUMNS: int = 1000
"""Maximum number of columns of a file read or previewed: a rig logs tens of channels, a few
hundred at most; a header of a million names is an attack, not a measurement (its preview would
be tens of MB)."""

DEFAULT_AMBIENT_PRESSURE: float = P_ATM
"""Default ambient pressure used to convert gauge pressures: the model's default ambient [Pa]."""


_PRESSURES = ("p_a", "p_b", "p_s")
_TEMPERATURES = ("T_a", "T_b")
_COLUMNS = ("t",) + SIGNALS
#: Cells read as a missing sample (compared without case); each one is listed in the import report
_MISSING_TOKENS = frozenset({"", "nan", "na", "n/a", "#n/a", "null", "none", "-", "--", "---"})


class MeasurementError(ValueError):
    """Invalid measurement data.

    The message always names the column and the data row when they are
    known, e.g. ``"column 'p_a[bar]', row 17: 'abc' is not a number"``.

    Parameters
    ----------
    message : str
        Description of the problem, without column/row prefix [-]
    column : str or None, optional
        Column name as written by the user (CSV header or dictionary key,
        including any unit suffix), or None when not tied to a column [-]
    row : int or None, optional
        1-based data row number as a user sees it: the first data row after
        the header is row 1 (the header is not counted, nor are ``#``
        comment lines and blank lines). For :meth:`Measurement.from_dict`
        it is the 1-based index into the value lists. None when not tied
        to a row [-]
    line : int or None, optional
        1-based physical line number in the CSV text (header and comment
        lines counted), when read from CSV; None otherwise [-]

    Attributes
    ----------
    column : str or None
        See above.
    row : int or None
        See above.
    line : int or None
        See above.
    detail : str
        The message without the column/row prefix.
    """

    def __init__(self, message: str, column: str | None = None,
                 row: int | None = None, line: int | None = None):
        self.detail = message
        self.column = column
        self.row = row
        self.line = line
        parts = []
        if column is not None:
            parts.append(f"column {column!r}")
        if row is not None:
            where = f"row {row}"
            if line is not None:
                where += f" (line {line})"
            parts.append(where)
        text = f"{', '.join(parts)}: {message}" if parts else message
        super().__init__(text)

    def __reduce__(self):
        return (self.__class__, (self.detail, self.column, self.row, self.line))


# --------------------------------------------------------------------------
# Units
# --------------------------------------------------------------------------

def _scale(mul: float = 1.0, div: float = 1.0, add: float = 0.0) -> Callable:
    """Linear converter ``x * mul / div + add``.

    Sub-unit scales use ``div`` rather than multiplying by an inexact
    fraction, so e.g. 25 mm -> 25 / 1000 = 0.025 m is correctly rounded.
    """

    def convert(values):
        out = np.asarray(values, dtype=np.float64)
        if mul != 1.0:
            out = out * mul
        if div != 1.0:
            out = out / div
        if add != 0.0:
            out = out + add
        return np.asarray(out, dtype=np.float64)

    return convert


def _fahrenheit(values):
    out = np.asarray(values, dtype=np.float64)
    return (out - 32.0) * 5.0 / 9.0 + T_ZERO_CELSIUS


# unit -> (factor spec, is_gauge). Gauge units get ambient pressure added.
_PRESSURE_UNITS: dict[str, tuple[dict, bool]] = {
    "Pa": ({}, False),
    "hPa": ({"mul": 1e2}, False),
    "mbar": ({"mul": 1e2}, False),
    "kPa": ({"mul": 1e3}, False),
    "MPa": ({"mul": 1e6}, False),
    "bar": ({"mul": 1e5}, False),
    "psi": ({"mul": PSI}, False),
    "Pag": ({}, True),
    "hPag": ({"mul": 1e2}, True),
    "mbarg": ({"mul": 1e2}, True),
    "kPag": ({"mul": 1e3}, True),
    "MPag": ({"mul": 1e6}, True),
    "barg": ({"mul": 1e5}, True),
    "psig": ({"mul": PSI}, True),
}
_LENGTH_UNITS = {"m": {}, "mm": {"div": 1e3}, "cm": {"div": 1e2},
                 "um": {"div": 1e6}, "\u00b5m": {"div": 1e6}, "\u03bcm": {"div": 1e6},
                 "in": {"mul": 0.0254}}
_VELOCITY_UNITS = {"m/s": {}, "mm/s": {"div": 1e3}, "in/s": {"mul": 0.0254}}
_TIME_UNITS = {"s": {}, "ms": {"div": 1e3}, "us": {"div": 1e6}, "\u00b5s": {"div": 1e6}}
_COMMAND_UNITS = {"-": {}, "%": {"div": 1e2}}
#: One pound-force [N] (0.45359237 kg * 9.80665 m/s^2)
LBF: float = 4.4482216152605
_FORCE_UNITS = {"N": {}, "kN": {"mul": 1e3}, "daN": {"mul": 10.0}, "lbf": {"mul": LBF}}
#: Mass flows: a volume flow at the ISO 8778 reference atmosphere (ANR, "normal" litres) times
#: the one reference density RHO_REF [kg/m^3]: 1 L/min ANR = RHO_REF / 60000 kg/s
_FLOW_UNITS = {"kg/s": {}, "g/s": {"div": 1e3}, "kg/h": {"div": 3600.0},
               "L/min ANR": {"mul": RHO_REF, "div": 6e4}, "NL/min": {"mul": RHO_REF, "div": 6e4},
               "m^3/h ANR": {"mul": RHO_REF, "div": 3600.0}, "Nm^3/h": {"mul": RHO_REF, "div": 3600.0},
               "L/s ANR": {"mul": RHO_REF, "div": 1e3}}
_TEMPERATURE_UNITS = {"K": "K", "degC": "C", "C": "C", "\u00b0C": "C",
                      "degF": "F", "\u00b0F": "F"}

UNITS: dict[str, tuple[str, ...]] = {
    "t": tuple(_TIME_UNITS),
    "u": tuple(_COMMAND_UNITS),
    "p_a": tuple(_PRESSURE_UNITS),
    "p_b": tuple(_PRESSURE_UNITS),
    "x": tuple(_LENGTH_UNITS),
    "v": tuple(_VELOCITY_UNITS),
    "T_a": tuple(_TEMPERATURE_UNITS),
    "T_b": tuple(_TEMPERATURE_UNITS),
    "F": tuple(_FORCE_UNITS),
    "q_a": tuple(_FLOW_UNITS),
    "q_b": tuple(_FLOW_UNITS),
    "q_s": tuple(_FLOW_UNITS),
    "p_s": tuple(_PRESSURE_UNITS),
}
"""Accepted unit suffixes for each column name (``t`` included), in canonical
spelling; see :func:`canonical_unit` for the other spellings accepted."""

#: Other spellings of units, mapped to the canonical ones of :data:`UNITS`
_UNIT_SPELLINGS = {"sec": "s", "msec": "ms", "1": "-", "": "-", "percent": "%",
                   "inch": "in", "mu": "um", "deg C": "degC", "deg F": "degF",
                   "kelvin": "K", "millibar": "mbar",
                   # flows: ANR is the ISO 8778 reference atmosphere, also written (ANR) or "Nl"
                   "l/min ANR": "L/min ANR", "L/min (ANR)": "L/min ANR", "l/min (ANR)": "L/min ANR",
                   "Nl/min": "NL/min", "nl/min": "NL/min", "NLPM": "NL/min", "SLPM": "NL/min",
                   "m\u00b3/h ANR": "m^3/h ANR", "m3/h ANR": "m^3/h ANR", "m\u00b3/h (ANR)": "m^3/h ANR",
                   "m3/h (ANR)": "m^3/h ANR", "Nm\u00b3/h": "Nm^3/h", "Nm3/h": "Nm^3/h",
                   "l/s ANR": "L/s ANR", "dm3/s ANR": "L/s ANR", "dm\u00b3/s ANR": "L/s ANR"}
_GAUGE_RE = re.compile(r"^(.*?)\s*(?:\(\s*g(?:auge)?\s*\)|\s+g(?:auge)?|g)$", re.IGNORECASE)
_ABS_RE = re.compile(r"^(.*?)\s*(?:\(\s*a(?:bs)?\s*\)|\s+a(?:bs)?|a)$", re.IGNORECASE)


def canonical_unit(unit: str, signal: str) -> str | None:
    """Canonical spelling of a unit written on a rig export, or None if unknown.

    Pressures accept gauge markers ``bar(g)``, ``barg``, ``bar g``,
    ``bar gauge``, ``psi(g)``, ``kPa (g)`` (all meaning gauge, i.e. relative to
    the ambient pressure) and absolute markers ``bar(a)``, ``bara``,
    ``bar abs``. Units are matched case-sensitively first, then without case
    when that is unambiguous (``KPA`` is kPa, but ``mpa`` is refused since
    it could be mPa or MPa).

    Parameters
    ----------
    unit : str
        Unit as written (without the brackets) [-]
    signal : str
        Signal (or ``"t"``) the unit is for [-]

    Returns
    -------
    unit : str or None
        A key of ``UNITS[signal]``, or None [-]

    Examples
    --------
    >>> canonical_unit("bar(g)", "p_a"), canonical_unit("psi g", "p_b"), canonical_unit("in", "x")
    ('barg', 'psig', 'in')
    """
    accepted = UNITS[signal]
    u = unit.strip()
    u = _UNIT_SPELLINGS.get(u, u)
    if u in accepted:
        return u
    if signal in _PRESSURES:
        for rx, suffix in ((_GAUGE_RE, "g"), (_ABS_RE, "")):
            m = rx.match(u)
            if m and m.group(1):
                base = _lookup_nocase(m.group(1), tuple(k for k in accepted if not
                                                        _PRESSURE_UNITS[k][1]))
                if base is not None:
                    return base + suffix
    return _lookup_nocase(u, accepted)


def _lookup_nocase(u: str, accepted: tuple[str, ...]) -> str | None:
    if u in accepted:
        return u
    hits = [k for k in accepted if k.lower() == u.lower()]
    return hits[0] if len(hits) == 1 else None


def _si_unit(signal: str) -> str:
    return "s" if signal == "t" else SIGNAL_UNITS[signal]


_HEADER_RE = re.compile(r"^\s*([^\[\]\s]+)\s*(?:\[\s*([^\[\]]*?)\s*\])?\s*$")
# a rig's header: a name with spaces allowed, then a unit in [], () or after a comma / slash
_LOOSE_HEADER_RE = re.compile(r"^\s*(.*?)\s*(?:\[\s*([^\[\]]*?)\s*\]|\(\s*([^()]*?)\s*\))?\s*$")


def _check_ambient(ambient_pressure: float) -> float:
    try:
        p = float(ambient_pressure)
    except (TypeError, ValueError):
        raise MeasurementError(
            f"ambient_pressure must be a number in Pa, got {ambient_pressure!r}") from None
    if not math.isfinite(p) or p <= 0.0:
        raise MeasurementError(
            f"ambient_pressure must be a finite positive absolute pressure in Pa, got {p:g}")
    return p


@dataclass(frozen=True)
class Conversion:
    """How one source column becomes a signal in SI units.

    Attributes
    ----------
    source : str
        Column as written in the file [-]
    signal : str
        Signal name, ``"t"`` for time [-]
    unit : str
        Canonical unit of the source (a key of ``UNITS[signal]``) [-]
    si_unit : str
        Unit after conversion [-]
    ambient_pressure : float or None
        Ambient pressure added for a gauge unit, else None [Pa]
    how : str
        ``"name"`` (the column is named for the signal), ``"alias"`` (a known
        alias such as ``Zeit``) or ``"mapping"`` (the caller's mapping) [-]
    gain : float
        Sensor gain: :attr:`unit` per unit of the raw column (1 bar/V) [unit/raw unit]
    offset : float
        Sensor offset added after the gain, in :attr:`unit` [unit]
    raw_unit : str or None
        What the raw column holds (``"V"``, ``"mA"``), for the record [-]
    """
    source: str
    signal: str
    unit: str
    si_unit: str
    ambient_pressure: float | None = None
    how: str = "name"
    gain: float = 1.0
    offset: float = 0.0
    raw_unit: str | None = None

    def to_dict(self) -> dict:
        d = {"column": self.source, "signal": self.signal, "from": self.unit,
             "to": self.si_unit, "ambient_pressure": self.ambient_pressure, "how": self.how}
        if self.gain != 1.0 or self.offset != 0.0 or self.raw_unit:
            d.update(gain=self.gain, offset=self.offset, raw_unit=self.raw_unit)
        return d

    def converter(self) -> Callable[[Any], np.ndarray]:
        """Function from raw values (``gain * raw + offset`` in :attr:`unit`) to float64 in
        :attr:`si_unit`."""
        unit_conv = self._unit_converter()
        if self.gain == 1.0 and self.offset == 0.0:
            return unit_conv
        gain, offset = self.gain, self.offset
        return lambda values: unit_conv(np.asarray(values, dtype=np.float64) * gain + offset)

    def _unit_converter(self) -> Callable[[Any], np.ndarray]:
        signal, unit = self.signal, self.unit
        if signal in _PRESSURES:
            spec, gauge = _PRESSURE_UNITS[unit]
            if gauge:
                spec = dict(spec, add=self.ambient_pressure)
            return _scale(**spec)
        if signal in _TEMPERATURES:
            kind = _TEMPERATURE_UNITS[unit]
            if kind == "K":
                return _scale()
            if kind == "C":
                return _scale(add=T_ZERO_CELSIUS)
            return _fahrenheit
        table = {"t": _TIME_UNITS, "u": _COMMAND_UNITS, "x": _LENGTH_UNITS,
                 "v": _VELOCITY_UNITS, "F": _FORCE_UNITS, "q_a": _FLOW_UNITS, "q_b": _FLOW_UNITS,
                 "q_s": _FLOW_UNITS}[signal]
        return _scale(**table[unit])


def _unit_of(signal: str, unit: str | None, column: str, ambient_pressure: float,
             how: str = "name") -> Conversion:
    """Resolve the unit of a column for `signal`; raise naming the column if unknown."""
    if unit is None or unit.strip() == "":
        canon = UNITS[signal][0]
    else:
        canon = canonical_unit(unit, signal)
        if canon is None:
            raise MeasurementError(
                f"unknown unit {unit!r} for {signal!r}; accepted units: "
                f"{', '.join(UNITS[signal])} (no unit means SI, {_si_unit(signal)})",
                column=column)
    gauge = signal in _PRESSURES and _PRESSURE_UNITS[canon][1]
    return Conversion(column, signal, canon, _si_unit(signal),
                      _check_ambient(ambient_pressure) if gauge else None, how)


def parse_header(name: str, ambient_pressure: float = DEFAULT_AMBIENT_PRESSURE
                 ) -> tuple[str, Callable[[Any], np.ndarray]]:
    """Parse a column name such as ``p_a[bar]`` into a signal and a converter.

    Parameters
    ----------
    name : str
        Column name: one of ``t``, ``u``, ``p_a``, ``p_b``, ``x``, ``v``,
        ``T_a``, ``T_b``, optionally followed by a unit in brackets
        (``p_a[kPa]``, ``p_a[bar(g)]``, ``x[mm]``, ``T_a[degC]``...; see
        :func:`canonical_unit`). Surrounding whitespace is ignored; names are
        case-sensitive (aliases such as ``Zeit`` are resolved by
        :func:`read_csv`, not here). No unit (or ``[]``) means SI [-]
    ambient_pressure : float, optional
        Ambient pressure added to gauge pressure columns (``barg``, ``bar(g)``,
        ``kPag``, ``psi(g)``...) [Pa]

    Returns
    -------
    signal : str
        Signal name without unit, ``"t"`` for the time column [-]
    converter : callable
        Function mapping an array of values in the column unit to a float64
        array in SI units (absolute pressures, kelvin, metres, seconds) [-]

    Raises
    ------
    MeasurementError
        For an unknown column name (the message lists the known names) or a
        unit not accepted for that signal (the message lists accepted units);
        ``column`` is set to `name`.

    Examples
    --------
    >>> sig, conv = parse_header("p_a[barg]")
    >>> sig, float(conv(2.0)[()])
    ('p_a', 301300.0)
    """
    conv = _header_conversion(name, ambient_pressure)
    return conv.signal, conv.converter()


def _header_conversion(name: str, ambient_pressure: float) -> Conversion:
    if not isinstance(name, str):
        raise MeasurementError(f"column name must be a string, got {name!r}",
                               column=repr(name))
    match = _HEADER_RE.match(name)
    if match is None:
        raise MeasurementError(
            "cannot parse column name; expected a signal name optionally followed "
            f"by a unit in brackets, e.g. 'p_a[bar]'. Known names: {', '.join(_COLUMNS)}",
            column=name)
    signal, unit = match.group(1), match.group(2)
    if signal not in _COLUMNS:
        msg = f"unknown column name {signal!r}; known names: {', '.join(_COLUMNS)}"
        # the same name in another case first ('P_a' is p_a, not q_a), then the closest spelling
        close = [c for c in _COLUMNS if c.lower() == signal.lower()][:1] or \
            difflib.get_close_matches(signal, _COLUMNS, n=1, cutoff=0.5)
        if close:
            msg += f" (did you mean {close[0]!r}?)"
        raise MeasurementError(msg, column=name)
    return _unit_of(signal, unit, name, ambient_pressure)


# --------------------------------------------------------------------------
# Column names of rig exports: aliases and the caller's mapping
# --------------------------------------------------------------------------

ALIASES: dict[str, tuple[str, ...]] = {
    "t": ("t", "time", "zeit", "temps", "tiempo", "timestamp", "time_s", "zeit_s"),
    "u": ("u", "command", "cmd", "valve", "valve_command", "spool", "setpoint", "sollwert",
          "stellsignal", "ventil", "commande", "y"),
    "p_a": ("p_a", "pa", "p1", "pressure_a", "p_chamber_a", "druck_a", "pression_a",
            "pressure a", "druck a", "p a"),
    "p_b": ("p_b", "pb", "p2", "pressure_b", "p_chamber_b", "druck_b", "pression_b",
            "pressure b", "druck b", "p b"),
    "x": ("x", "position", "pos", "weg", "stroke", "displacement", "s"),
    "v": ("v", "velocity", "speed", "geschwindigkeit", "vitesse"),
    "T_a": ("t_a", "temperature_a", "temp_a", "ta"),
    "T_b": ("t_b", "temperature_b", "temp_b", "tb"),
    "F": ("force", "rod_force", "rod force", "load_cell", "loadcell", "load cell"),
    "q_a": ("q_a", "qa", "flow_a", "flow a", "mass_flow_a"),
    "q_b": ("q_b", "qb", "flow_b", "flow b", "mass_flow_b"),
    "q_s": ("q_s", "qs", "supply_flow", "supply flow", "flow_supply", "q_supply",
            "air_consumption"),
    "p_s": ("p_s", "ps", "p_supply", "supply_pressure", "supply pressure"),
}
"""Column names of rig exports recognised for each signal (compared without case,
surrounding whitespace and units). ``"t"`` is time; ``T_a`` / ``T_b`` are
temperatures, which is why a plain lower-case alias ``t`` means time."""

_ALIAS_LOOKUP: dict[str, str] = {a: sig for sig, names in ALIASES.items() for a in names}

#: First comment line of the files :mod:`pneucore.data.export` writes (and the CLI's ``--csv``). In a
#: file that carries it, columns that are no signal (simulated masses and flows, a comparison's
#: ``*_model`` and ``*_residual`` columns) are skipped and listed as ignored, so an export reads
#: back unchanged; in any other file an unknown column is an error naming it.
EXPORT_MARKER = "# pneucore"


def split_label(label: str) -> tuple[str, str | None]:
    """``"Zeit [ms]"`` -> ("Zeit", "ms"); ``"p A (bar g)"`` -> ("p A", "bar g")."""
    m = _LOOSE_HEADER_RE.match(label)
    if m is None:
        return label.strip(), None
    unit = m.group(2) if m.group(2) is not None else m.group(3)
    return m.group(1), unit


def _match_target(label: str, mapping: Mapping[str, Any]) -> tuple[bool, Any]:
    """The caller's mapping entry for a header (its full text or its name part)."""
    if label in mapping:
        return True, mapping[label]
    name, _ = split_label(label)
    if name in mapping:
        return True, mapping[name]
    return False, None


def propose_mapping(labels: Iterable[str]) -> dict[str, str | None]:
    """Propose a column mapping for a rig's header from :data:`ALIASES`.

    Parameters
    ----------
    labels : iterable of str
        Column names as written in the file [-]

    Returns
    -------
    mapping : dict[str, str or None]
        Column name (without unit) -> signal name, or None for columns that
        match no signal (they would be ignored) [-]

    Examples
    --------
    >>> propose_mapping(["Zeit [ms]", "Ventil", "p_A", "Kraft"])
    {'Zeit': 't', 'Ventil': 'u', 'p_A': 'p_a', 'Kraft': None}
    """
    out: dict[str, str | None] = {}
    taken: set[str] = set()
    for label in labels:
        name, _ = split_label(str(label))
        sig = name if name in _COLUMNS else _ALIAS_LOOKUP.get(name.strip().lower())
        if sig in taken:
            sig = None
        if sig is not None:
            taken.add(sig)
        out[name] = sig
    return out


#: The fields of a sensor object in a column mapping, with what each means (and its unit)
SENSOR_FIELDS: dict[str, str] = {
    "signal": f"the signal the column gives ({', '.join(_COLUMNS)}) [-]",
    "unit": "unit of gain * raw + offset (bar, mm, degC...; default: the file's, else SI) [-]",
    "gain": "sensor gain: unit per raw unit (1 bar/V, 25 mm/V); default 1, non-zero [unit/raw]",
    "offset": "added after the gain (the sensor's zero), in unit; default 0 [unit]",
    "reference": "pressures only: 'gauge' (ambient added) or 'absolute' [-]",
    "raw_unit": "what the column holds (V, mA), recorded with the dataset [-]",
}

#: Longest ``raw_unit`` label of a sensor object [characters]
_RAW_UNIT_MAX = 16


def _check_sensor(target: Mapping, where: str) -> dict:
    """A sensor object of a column mapping, checked; each error names its field."""
    unknown = [k for k in target if k not in SENSOR_FIELDS]
    if unknown:
        raise MeasurementError(f"unknown field {unknown[0]!r}; a sensor has "
                               f"{', '.join(SENSOR_FIELDS)}", column=where)
    sig = target.get("signal")
    if not isinstance(sig, str) or sig not in _COLUMNS:
        raise MeasurementError(f"signal must be one of {', '.join(_COLUMNS)}, got {sig!r}",
                               column=f"{where}.signal")
    out: dict[str, Any] = {"signal": sig}
    unit = target.get("unit")
    if unit not in (None, ""):
        if not isinstance(unit, str):
            raise MeasurementError(f"unit must be a string, got {unit!r}", column=f"{where}.unit")
        _unit_of(sig, unit, f"{where}.unit", DEFAULT_AMBIENT_PRESSURE)
        out["unit"] = unit
    for k, default in (("gain", 1.0), ("offset", 0.0)):
        v = target.get(k, default)
        v = default if v is None else v
        if isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(float(v)):
            raise MeasurementError(f"{k} must be a finite number, got {v!r}", column=f"{where}.{k}")
        out[k] = float(v)
    if out["gain"] == 0.0:
        raise MeasurementError("gain must not be 0 (it would make every sample the offset)",
                               column=f"{where}.gain")
    ref = target.get("reference")
    if ref not in (None, ""):
        if ref not in ("gauge", "absolute"):
            raise MeasurementError(f"reference must be 'gauge' or 'absolute', got {ref!r}",
                                   column=f"{where}.reference")
        if sig not in _PRESSURES:
            raise MeasurementError(f"reference applies to pressures only, not {sig!r}",
                                   column=f"{where}.reference")
        out["reference"] = ref
    raw = target.get("raw_unit")
    if raw not in (None, ""):
        if not isinstance(raw, str) or len(raw) > _RAW_UNIT_MAX:
            raise MeasurementError(f"raw_unit must be a label of at most {_RAW_UNIT_MAX} "
                                   "characters", column=f"{where}.raw_unit")
        out["raw_unit"] = raw
    return out


def _with_reference(canon: str, reference: str | None) -> str:
    """A pressure unit made gauge (``bar`` -> ``barg``) or absolute (``barg`` -> ``bar``)."""
    gauge = _PRESSURE_UNITS[canon][1]
    if reference == "gauge" and not gauge:
        return canon + "g"
    if reference == "absolute" and gauge:
        return canon[:-1]
    return canon


def check_mapping(mapping: Any) -> dict[str, str | None]:
    """Validate a column mapping ``{"Zeit": "t", "pA": "p_a[bar(g)]", "Kraft": null}``.

    Values are a signal name, optionally with a unit in brackets that
    overrides the file's, None to ignore the column, or a sensor object
    (:data:`SENSOR_FIELDS`): ``{"signal": "p_a", "unit": "bar", "gain": 1.0,
    "offset": 0.0, "reference": "absolute", "raw_unit": "V"}`` for a
    column of raw sensor volts at 1 bar/V.

    Raises
    ------
    MeasurementError
        Naming the entry (``column`` = ``columns.<key>``) that is not a
        string key with a known signal or None.
    """
    if mapping is None:
        return {}
    if not isinstance(mapping, Mapping):
        raise MeasurementError(
            f"the column mapping must be a JSON object such as {{\"Zeit\": \"t\"}}, "
            f"got {type(mapping).__name__}", column="columns")
    out: dict[str, str | None] = {}
    for key, target in mapping.items():
        if not isinstance(key, str):
            raise MeasurementError(f"key {key!r} is not a column name", column="columns")
        if target is None or target == "":
            out[key] = None
            continue
        if isinstance(target, Mapping):
            out[key] = _check_sensor(target, f"columns.{key}")
            continue
        if not isinstance(target, str):
            raise MeasurementError(f"target must be a signal name, a sensor object or null, got "
                                   f"{target!r}", column=f"columns.{key}")
        m = _HEADER_RE.match(target)
        if m is None or m.group(1) not in _COLUMNS:
            raise MeasurementError(
                f"unknown signal {target!r}; known names: {', '.join(_COLUMNS)} "
                "(a unit may follow in brackets, e.g. 'p_a[bar(g)]'; null ignores the column)",
                column=f"columns.{key}")
        if m.group(2):
            _unit_of(m.group(1), m.group(2), f"columns.{key}", DEFAULT_AMBIENT_PRESSURE)
        out[key] = target
    return out


def _resolve(label: str, unit_row: str | None, mapping: Mapping[str, Any],
             ambient_pressure: float, export: bool = False) -> Conversion | None:
    """Conversion for one source column; None when the column is to be ignored.

    The unit is, by priority: the one in the mapping's target (``p_a[bar]``),
    the one in the header's brackets, the units row under the header, SI.
    """
    if not isinstance(label, str):
        raise MeasurementError(f"column name must be a string, got {label!r}",
                               column=repr(label))
    strict = _HEADER_RE.match(label)
    if strict is not None and strict.group(1) in _COLUMNS:
        name, unit = strict.group(1), strict.group(2)
    else:
        name, unit = split_label(label)
    if not unit and unit_row is not None and unit_row.strip():
        unit = unit_row.strip()
        if unit[:1] + unit[-1:] in ("[]", "()"):   # a units row written '[bar]' or '(bar)'
            unit = unit[1:-1]
    found, target = _match_target(label, mapping)
    if found:
        if target is None:
            return None
        if isinstance(target, Mapping):   # a sensor object (checked by check_mapping)
            sig = target["signal"]
            conv = _unit_of(sig, target.get("unit") or unit, label, DEFAULT_AMBIENT_PRESSURE,
                            "mapping")
            canon = conv.unit
            if sig in _PRESSURES:
                canon = _with_reference(canon, target.get("reference"))
            gauge = sig in _PRESSURES and _PRESSURE_UNITS[canon][1]
            return Conversion(label, sig, canon, _si_unit(sig),
                              _check_ambient(ambient_pressure) if gauge else None, "mapping",
                              target.get("gain", 1.0), target.get("offset", 0.0),
                              target.get("raw_unit"))
        m = _HEADER_RE.match(target)
        return _unit_of(m.group(1), m.group(2) or unit, label, ambient_pressure, "mapping")
    if name in _COLUMNS:
        return _unit_of(name, unit, label, ambient_pressure, "name")
    sig = _ALIAS_LOOKUP.get(name.lower())
    if sig is not None:
        return _unit_of(sig, unit, label, ambient_pressure, "alias")
    if export:   # a pneucore export: a simulated or comparison-only column
        return None
    _header_conversion(label, ambient_pressure)   # raises: unknown name, did you mean ...
    raise MeasurementError("cannot read this column name", column=label)  # pragma: no cover


# --------------------------------------------------------------------------
# Cell parsing
# --------------------------------------------------------------------------

def _parse_values(values: list, column: str, lines: list[int] | None,
                  decimal_comma_hint: bool = False) -> np.ndarray:
    """Convert a list of cells (str, number or None) to float64, NaN = missing."""
    if isinstance(values, np.ndarray) and values.dtype.kind in "iuf":
        return values.astype(np.float64)   # a binary format's channel
    if all(isinstance(v, str) for v in values):
        try:  # fast path: every cell is a plain number (or 'nan')
            return np.array(values, dtype=np.float64)
        except ValueError:
            pass
    out = np.empty(len(values), dtype=np.float64)
    for i, v in enumerate(values):
        if v is None:
            out[i] = np.nan
            continue
        if isinstance(v, bool) or not isinstance(v, (str, numbers.Real)):
            raise MeasurementError(f"{v!r} is not a number", column=column, row=i + 1,
                                   line=lines[i] if lines else None)
        if isinstance(v, numbers.Real):
            out[i] = float(v)
            continue
        s = v.strip()
        if s.lower() in _MISSING_TOKENS:
            out[i] = np.nan
            continue
        try:
            out[i] = float(s)
        except ValueError:
            msg = f"{s!r} is not a number"
            if decimal_comma_hint and re.fullmatch(r"[+-]?\d*,\d+", s):
                msg += " (decimal commas are not supported; use '.' as decimal point)"
            raise MeasurementError(msg, column=column, row=i + 1,
                                   line=lines[i] if lines else None) from None
    return out


def _ranges(rows: np.ndarray) -> list[list[int]]:
    """Sorted 1-based row numbers as ``[[first, last], ...]`` runs."""
    if rows.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(rows) != 1)
    starts = np.concatenate(([rows[0]], rows[breaks + 1]))
    ends = np.concatenate((rows[breaks], [rows[-1]]))
    return [[int(a), int(b)] for a, b in zip(starts, ends)]


#: Share of the ambient pressure below which an absolute pressure at rest is implausible for
#: a pneumatic jack (vacuum is not this tool's domain): a sign of gauge values labelled absolute
_REST_PRESSURE_FRACTION = 0.5


def resolve_column(label: str, unit_row: str | None, mapping: Mapping[str, Any],
                   ambient_pressure: float, export: bool = False):
    """The signal and unit conversion a column's name gives, or None when it is ignored; read
    from its name alone, so that a reader can refuse or skip a column before reading its values.

    Parameters
    ----------
    label : str
        The column's name as written (``p_A [bar(g)]``) [-]
    unit_row : str or None
        Its unit from a units row or the file's metadata [-]
    mapping : mapping
        The caller's checked column mapping (:func:`check_mapping`) [-]
    ambient_pressure : float
        The rig's ambient pressure, for gauge units [Pa]
    export : bool, optional
        The file is a pneucore export: columns that are no signal are ignored [-]

    Returns
    -------
    conversion : Conversion or None
        ``conversion.signal`` is the signal the column gives; None: ignored [-]

    Raises
    ------
    MeasurementError
        An unknown column name or unit, naming the column and how to map or ignore it
    """
    try:
        return _resolve(label, unit_row, mapping, ambient_pressure, export=export)
    except MeasurementError as exc:
        if exc.detail.startswith("unknown column name"):
            exc = MeasurementError(
                exc.detail + f"; map it to a signal with columns={{{json.dumps(str(label))}: "
                f"\"p_a\"}} or ignore it with columns={{{json.dumps(str(label))}: null}}",
                column=exc.column)
        raise exc from None


#: Key of a measurement's metadata that states each signal's sensor accuracy (issue 22, item 6)
ACCURACY = "accuracy"


def sensor_accuracy(given: Any, ambient_pressure: float = DEFAULT_AMBIENT_PRESSURE
                    ) -> dict[str, float]:
    """The per-signal sensor accuracy of a measurement's metadata, in SI units.

    A fit weighs each signal's residual by the standard deviation of its error
    (:class:`pneucore.analysis.calibrate.Objective`); without a stated accuracy that is
    estimated from the record's own noise. A stated one replaces the estimate: a sensor's
    datasheet error is what the user knows, and a quantised or smooth record hides its
    noise. Keys are signal names with an optional unit in brackets, as column names
    (``"p_a[bar]": 0.003``); the value is a difference, so a gauge unit's ambient or a
    Celsius zero does not apply (``0.003 bar(g)`` is 300 Pa, ``1 degC`` is 1 K).

    Parameters
    ----------
    given : dict
        ``{signal or "signal[unit]": accuracy}``, accuracy a positive number in that unit [-]
    ambient_pressure : float, optional
        Ambient pressure of gauge units [Pa]

    Returns
    -------
    accuracy : dict
        ``{signal: accuracy [SI unit of the signal]}`` [-]

    Raises
    ------
    MeasurementError
        Naming ``meta.accuracy.<key>`` and the unit, for an unknown signal or unit, or a
        value that is not a finite positive number.

    Examples
    --------
    >>> sensor_accuracy({"p_a[bar]": 0.003, "T_a[degC]": 1.0, "x[mm]": 0.05})
    {'p_a': 300.0, 'T_a': 1.0, 'x': 5e-05}
    """
    if not isinstance(given, Mapping):
        raise MeasurementError(f"must be a dict of signal -> accuracy, got {type(given).__name__}",
                               column=f"meta.{ACCURACY}")
    out: dict[str, float] = {}
    for key, value in given.items():
        where = f"meta.{ACCURACY}.{key}"
        try:
            conv = _header_conversion(key, ambient_pressure)
        except MeasurementError as exc:
            raise MeasurementError(exc.detail, column=where) from None
        if conv.signal in ("t", "u"):
            raise MeasurementError("an accuracy is stated for a measured signal, not for time "
                                   "or the command", column=where)
        unit = conv.unit or conv.si_unit
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value) or value <= 0:
            raise MeasurementError(f"must be a finite positive number [{unit}], got {value!r}",
                                   column=where)
        f = conv.converter()
        si = float(f(np.array([float(value)]))[0] - f(np.array([0.0]))[0])
        if conv.signal in out:
            raise MeasurementError(f"accuracy of {conv.signal!r} given twice", column=where)
        out[conv.signal] = abs(si)
    return out


def measurement_from_columns(columns: list[tuple[str, list]], ambient_pressure: float,
                             name: str, meta: dict, lines: list[int] | None,
                             decimal_comma_hint: bool = False, units: list | None = None,
                             mapping: Mapping[str, Any] | None = None,
                             report: dict | None = None) -> "Measurement":
    """Shared back end of every reader: resolve names and units, convert, validate.

    ``units`` is the units row (one entry per column, or None), ``mapping``
    the caller's column mapping (see :func:`check_mapping`), ``report`` the
    reader's own facts (format, encoding...) completed here and stored as
    ``meta["import"]``.
    """
    ambient_pressure = _check_ambient(ambient_pressure)
    mapping = check_mapping(mapping)
    labels = [label for label, _ in columns]
    for key in mapping:
        if not any(_match_target(str(lab), {key: None})[0] for lab in labels):
            raise MeasurementError(
                f"the mapping names column {key!r}, which is not in the file (columns: "
                f"{', '.join(repr(lab) for lab in labels)})", column=f"columns.{key}")
    parsed: dict[str, tuple[Conversion, list]] = {}
    ignored: list[str] = []
    for j, (label, values) in enumerate(columns):
        unit_row = units[j] if units is not None and j < len(units) else None
        conv = resolve_column(label, unit_row, mapping, ambient_pressure,
                              export=bool((report or {}).get("pneucore_export")))
        if conv is None:
            ignored.append(str(label))
            continue
        if conv.signal in parsed:
            first = parsed[conv.signal][0].source
            raise MeasurementError(
                f"duplicate column: {first!r} and {label!r} both give signal {conv.signal!r}",
                column=label)
        parsed[conv.signal] = (conv, values)
    found = ", ".join(repr(label) for label, _ in columns) or "none"
    # no command column: the experiment's scenario gives the command (or one is proposed from a
    # measured pressure's edges, :func:`pneucore.data.command.propose_command`)
    for required in ("t",):
        if required not in parsed:
            raise MeasurementError(
                f"required column {required!r} is missing (columns found: {found})",
                column=required)

    source_columns = {sig: conv.source for sig, (conv, _) in parsed.items()}
    arrays: dict[str, np.ndarray] = {}
    missing_cells = []
    for sig, (conv, values) in parsed.items():
        raw = _parse_values(values, conv.source, lines, decimal_comma_hint)
        gaps = np.flatnonzero(np.isnan(raw)) + 1
        if gaps.size:
            missing_cells.append({"column": conv.source, "count": int(gaps.size),
                                  "rows": _ranges(gaps)})
        with np.errstate(over="ignore", invalid="ignore"):
            arrays[sig] = conv.converter()(raw)
    t = arrays.pop("t")
    signals = {sig: arrays[sig] for sig in SIGNALS if sig in arrays}
    meta = dict(meta)
    meta.setdefault("columns", dict(source_columns))
    if ACCURACY in meta:
        meta[ACCURACY] = sensor_accuracy(meta[ACCURACY], ambient_pressure)
        absent = sorted(set(meta[ACCURACY]) - set(signals))
        if absent:
            raise MeasurementError(f"accuracy stated for {', '.join(absent)}, which the record "
                                   f"does not hold", column=f"meta.{ACCURACY}.{absent[0]}")
    m = Measurement(t=t, signals=signals, name=name, meta=meta)
    m._columns = source_columns
    m._lines = list(lines) if lines is not None else None
    m.validate()

    warnings = []
    for sig in _PRESSURES:
        if sig not in parsed or parsed[sig][0].ambient_pressure is not None:
            continue
        arr = m.signals[sig]
        ok = np.flatnonzero(np.isfinite(arr))
        rest = float(arr[ok[0]])
        if rest < _REST_PRESSURE_FRACTION * ambient_pressure:
            conv = parsed[sig][0]
            warnings.append(
                f"column {conv.source!r}: the absolute pressure at rest (first sample) is "
                f"{rest:g} Pa, {rest / ambient_pressure:.2g} times the ambient "
                f"{ambient_pressure:g} Pa; if these are gauge pressures, give the unit as "
                f"'{conv.unit}g' (e.g. '{sig}[{conv.unit}(g)]' or a mapping "
                f"{{\"{conv.source}\": \"{sig}[{conv.unit}(g)]\"}})")
    info = dict(report or {})
    info.update({"ambient_pressure": ambient_pressure,
                 "conversions": [conv.to_dict() for conv, _ in parsed.values()],
                 "ignored_columns": ignored, "missing_cells": missing_cells,
                 "warnings": warnings})
    m.meta["import"] = info
    return m


# --------------------------------------------------------------------------
# Measurement
# --------------------------------------------------------------------------

@dataclass(eq=False)
class Measurement:
    """Time series measured on a pneumatic-jack test rig, in SI units.

    Build instances with :func:`read_csv` or :meth:`from_dict`, which convert
    units and call :meth:`validate`. When constructing directly, arrays are
    converted to float64 copies but not validated: call :meth:`validate`.

    Parameters
    ----------
    t : numpy.ndarray
        Sample times, finite and strictly increasing; sampling may be
        irregular [s]
    signals : dict[str, numpy.ndarray]
        Signals by name (see :data:`SIGNALS`), each the same length as `t`;
        NaN marks a missing sample. ``u`` is the valve command in [-1, 1]
        [-], ``p_a``/``p_b`` absolute chamber pressures [Pa], ``x`` rod
        position [m], ``v`` rod velocity [m/s], ``T_a``/``T_b`` chamber
        temperatures [K], ``F`` rod force on the load, positive outward [N],
        ``q_a``/``q_b``/``q_s`` mass flows into A, into B and from the supply
        [kg/s], ``p_s`` absolute supply pressure [Pa]
    name : str, optional
        Label of the measurement, e.g. the CSV file stem [-]
    meta : dict, optional
        Free-form metadata. The constructors store ``"columns"`` (signal ->
        column name as written in the source) and, for files, ``"source"``
        (the path) [-]

    Notes
    -----
    Equality is identity (``eq=False``); compare arrays explicitly.
    """

    t: np.ndarray
    signals: dict[str, np.ndarray]
    name: str = ""
    meta: dict = field(default_factory=dict)
    # Column labels as written by the user and physical CSV line of each row,
    # used only to make error messages point at the source.
    _columns: dict = field(default_factory=dict, init=False, repr=False)
    _lines: list | None = field(default=None, init=False, repr=False)

    def __post_init__(self):
        self.t = np.array(self.t, dtype=np.float64)
        self.signals = {str(k): np.array(v, dtype=np.float64)
                        for k, v in dict(self.signals).items()}
        self.name = "" if self.name is None else str(self.name)
        self.meta = {} if self.meta is None else dict(self.meta)

    # ---------------------------------------------------------------- access
    @property
    def n(self) -> int:
        """Number of samples [-]."""
        return int(self.t.shape[0])

    @property
    def duration(self) -> float:
        """Time span from the first to the last sample [s]."""
        return float(self.t[-1] - self.t[0]) if self.n else 0.0

    @property
    def measured_signals(self) -> tuple[str, ...]:
        """Names of signals other than ``u`` with at least one finite sample.

        Returns
        -------
        names : tuple[str, ...]
            In :data:`SIGNALS` order [-]
        """
        return tuple(s for s in SIGNALS
                     if s != "u" and s in self.signals
                     and bool(np.isfinite(self.signals[s]).any()))

    def __getitem__(self, name: str) -> np.ndarray:
        """Return signal `name` (or ``"t"``) as a float64 array in SI units."""
        if name == "t":
            return self.t
        try:
            return self.signals[name]
        except KeyError:
            present = ", ".join(("t",) + tuple(s for s in SIGNALS if s in self.signals))
            raise KeyError(f"signal {name!r} is not in this measurement "
                           f"(available: {present})") from None

    def __contains__(self, name: object) -> bool:
        return name == "t" or name in self.signals

    def _col(self, sig: str) -> str:
        return self._columns.get(sig, sig)

    def _err(self, message: str, sig: str | None = None, index: int | None = None
             ) -> MeasurementError:
        line = None
        if index is not None and self._lines is not None and index < len(self._lines):
            line = self._lines[index]
        return MeasurementError(message, column=None if sig is None else self._col(sig),
                                row=None if index is None else index + 1, line=line)

    # ------------------------------------------------------------ validation
    def validate(self) -> "Measurement":
        """Check the data and fill missing commands; raise on any problem.

        Checks, in order: array shapes and signal names;
        ``MIN_SAMPLES <= n <= MAX_SAMPLES``; ``t`` finite and strictly
        increasing; no infinite values; no signal entirely missing; a first
        command sample present; ``u`` within [-1, 1]; pressures > 0 Pa
        absolute; temperatures > 0 K; at least one measured signal besides
        ``u``. Missing ``u`` samples are then filled in place by holding the
        previous value (zero-order hold). A record without ``u`` (a rig that logs no
        command) is valid: its experiment's scenario gives the command.

        Returns
        -------
        self : Measurement
            The same object, for chaining [-]

        Raises
        ------
        MeasurementError
            Naming the column (as written in the source) and the 1-based
            data row when applicable.
        """
        if self.t.ndim != 1:
            raise self._err(f"time must be one-dimensional, got shape {self.t.shape}", "t")
        n = self.n
        for sig, arr in self.signals.items():
            if sig not in SIGNALS:
                raise MeasurementError(
                    f"unknown signal {sig!r}; known names: {', '.join(SIGNALS)}", column=sig)
            if arr.shape != (n,):
                raise self._err(f"has shape {arr.shape} but 't' has {n} samples", sig)
        if n > MAX_SAMPLES:
            raise MeasurementError(
                f"too many samples: {n} rows found, at most MAX_SAMPLES = {MAX_SAMPLES} "
                "are supported; decimate or split the measurement")
        if n < MIN_SAMPLES:
            raise MeasurementError(
                f"too few samples: {n} data row{'s' if n != 1 else ''} found, at least "
                f"MIN_SAMPLES = {MIN_SAMPLES} are required")

        t = self.t
        bad = np.flatnonzero(~np.isfinite(t))
        if bad.size:
            i = int(bad[0])
            what = "missing" if np.isnan(t[i]) else f"infinite ({float(t[i]):g})"
            raise self._err(f"time is {what}; 't' must be finite in every row", "t", i)
        dt = np.diff(t)
        bad = np.flatnonzero(~(dt > 0.0))
        if bad.size:
            i = int(bad[0]) + 1
            raise self._err(
                f"time is not strictly increasing: t = {float(t[i]):g} s at row {i + 1} is not "
                f"greater than t = {float(t[i - 1]):g} s at row {i}", "t", i)

        for sig in SIGNALS:
            if sig not in self.signals:
                continue
            arr = self.signals[sig]
            bad = np.flatnonzero(np.isinf(arr))
            if bad.size:
                i = int(bad[0])
                raise self._err(f"infinite value ({float(arr[i]):g}) after conversion to "
                                f"{SIGNAL_UNITS[sig]}", sig, i)
            finite = np.isfinite(arr)
            if sig == "u" and not finite[0]:
                raise self._err(
                    "the first command sample is missing; missing 'u' samples are "
                    "filled by holding the previous value, so the first must be given",
                    sig, 0)
            if not finite.any():
                raise self._err("signal is entirely missing (no numeric sample); "
                                "remove the column or provide data", sig)
            if sig == "u":
                bad = np.flatnonzero(finite & ((arr < -1.0) | (arr > 1.0)))
                if bad.size:
                    i = int(bad[0])
                    raise self._err(
                        f"valve command {float(arr[i]):g} is outside [-1, 1] (for a command in "
                        "percent, label the column 'u[%]')", sig, i)
            elif sig in _PRESSURES or sig in _TEMPERATURES:
                bad = np.flatnonzero(finite & (arr <= 0.0))
                if bad.size:
                    i = int(bad[0])
                    if sig in _PRESSURES:
                        msg = (f"absolute pressure {float(arr[i]):g} Pa is not positive (gauge "
                               "columns such as 'p_a[barg]' are converted by adding "
                               "the ambient pressure)")
                    else:
                        msg = f"temperature {float(arr[i]):g} K is not positive"
                    raise self._err(msg, sig, i)

        if not self.measured_signals:
            raise MeasurementError(
                "no measured signal besides 'u'; provide at least one of "
                + ", ".join(s for s in SIGNALS if s != "u"))

        u = self.signals.get("u")
        missing = np.isnan(u) if u is not None else np.zeros(0, bool)
        if missing.any():
            idx = np.where(missing, 0, np.arange(n))
            np.maximum.accumulate(idx, out=idx)
            self.signals["u"] = u[idx]
        return self

    # ------------------------------------------------------- conversions
    def to_dict(self) -> dict:
        """Plain JSON-compatible representation in SI units.

        Returns
        -------
        d : dict
            ``{"t": [...], "u": [...], "p_a": [...], ...}`` with lists of
            floats, NaN (missing sample) as None, plus ``"name"`` when the
            name is not empty. `meta` is not included. Accepted by
            :meth:`from_dict` [-]
        """
        def plain(arr: np.ndarray) -> list:
            return [None if x != x else x for x in arr.tolist()]

        d: dict[str, Any] = {"t": plain(self.t)}
        for sig in SIGNALS:
            if sig in self.signals:
                d[sig] = plain(self.signals[sig])
        if self.name:
            d["name"] = self.name
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any],
                  ambient_pressure: float = DEFAULT_AMBIENT_PRESSURE) -> "Measurement":
        """Build a validated measurement from a JSON-like dictionary.

        Parameters
        ----------
        d : Mapping[str, Any]
            ``{"t": [...], "u": [...], "p_a": [...], ...}``. Keys are column
            names exactly as CSV headers (units allowed: ``"p_a[bar]"``,
            ``"t[ms]"``...). Values are equal-length lists of numbers; None,
            NaN, ``""``, ``"NaN"``/``"NA"`` mark a missing sample. Optional
            keys ``"name"`` (str) and ``"meta"`` (dict) [-]
        ambient_pressure : float, optional
            Ambient pressure used for gauge columns [Pa]

        Returns
        -------
        measurement : Measurement
            Validated, in SI units [-]

        Raises
        ------
        MeasurementError
            For any invalid key or value; ``row`` is the 1-based list index.
        """
        if not isinstance(d, Mapping):
            raise MeasurementError(f"expected a dict of columns, got {type(d).__name__}")
        name = d.get("name", "")
        if not isinstance(name, str):
            raise MeasurementError(f"'name' must be a string, got {name!r}", column="name")
        meta = d.get("meta", {})
        if not isinstance(meta, Mapping):
            raise MeasurementError(f"'meta' must be a dict, got {type(meta).__name__}",
                                   column="meta")
        columns: list[tuple[str, list]] = []
        for key, values in d.items():
            if key in ("name", "meta"):
                continue
            if isinstance(values, np.ndarray):
                if values.ndim != 1:
                    raise MeasurementError(
                        f"expected a 1-D list of values, got array of shape {values.shape}",
                        column=str(key))
                values = values.tolist()
            elif isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
                raise MeasurementError(
                    f"expected a list of values, got {type(values).__name__}",
                    column=str(key))
            columns.append((key, list(values)))
        labels = [label for label, _ in columns]
        t_label = next((lab for lab in labels
                        if isinstance(lab, str) and _HEADER_RE.match(lab)
                        and _HEADER_RE.match(lab).group(1) == "t"), None)
        if t_label is not None:
            n = len(dict(columns)[t_label])
            for label, values in columns:
                if len(values) != n:
                    raise MeasurementError(
                        f"has {len(values)} values but {t_label!r} has {n}", column=label)
        return measurement_from_columns(columns, ambient_pressure, name, dict(meta), None,
                                        report={"format": "json"})

    # ----------------------------------------------------------- derived
    def command_breakpoints(self) -> list[list[float]]:
        """Valve command as zero-order-hold breakpoints for the simulator.

        Returns
        -------
        breakpoints : list[list[float]]
            ``[[t, u], ...]`` with time [s] and command [-]; the first sample
            is always kept, then only samples where ``u`` differs from the
            previous sample. ``u`` holds its value until the next breakpoint.
        """
        u = self.signals.get("u")
        if self.n == 0 or u is None:
            return []
        keep = np.ones(self.n, dtype=bool)
        keep[1:] = u[1:] != u[:-1]
        return [[float(ti), float(ui)] for ti, ui in zip(self.t[keep], u[keep])]

    def slice(self, t0: float | None = None, t1: float | None = None) -> "Measurement":
        """Sub-measurement with the samples ``t0 <= t <= t1``.

        Times are kept as they are (not shifted to start at zero). Signals
        that have no finite sample inside the window are kept (all NaN) and
        simply drop out of :attr:`measured_signals`.

        Parameters
        ----------
        t0 : float or None, optional
            Start of the window, inclusive; None for the first sample [s]
        t1 : float or None, optional
            End of the window, inclusive; None for the last sample [s]

        Returns
        -------
        measurement : Measurement
            New object with copied arrays and a shallow copy of `meta` [-]

        Raises
        ------
        MeasurementError
            If ``t1 < t0`` or the window holds fewer than MIN_SAMPLES samples.
        """
        lo = -np.inf if t0 is None else float(t0)
        hi = np.inf if t1 is None else float(t1)
        if hi < lo:
            raise MeasurementError(f"slice end t1 = {hi} s is before start t0 = {lo} s")
        mask = (self.t >= lo) & (self.t <= hi)
        count = int(mask.sum())
        if count < MIN_SAMPLES:
            raise MeasurementError(
                f"slice [{lo}, {hi}] s holds {count} samples, at least "
                f"MIN_SAMPLES = {MIN_SAMPLES} are required")
        out = Measurement(t=self.t[mask],
                          signals={k: v[mask] for k, v in self.signals.items()},
                          name=self.name, meta=dict(self.meta))
        out._columns = dict(self._columns)
        if self._lines is not None:
            out._lines = [ln for ln, k in zip(self._lines, mask) if k]
        return out


# --------------------------------------------------------------------------
# CSV
# --------------------------------------------------------------------------

_BOMS = ((b"\xef\xbb\xbf", "utf-8-sig"), (b"\xff\xfe\x00\x00", "utf-32"),
         (b"\x00\x00\xfe\xff", "utf-32"), (b"\xff\xfe", "utf-16"), (b"\xfe\xff", "utf-16"))


def decode_text(data: bytes) -> tuple[str, str]:
    """Decode a rig's text export, detecting its encoding.

    A byte-order mark decides (UTF-8, UTF-16, UTF-32); without one, NUL bytes
    at every other position mean UTF-16 (little or big endian); then strict
    UTF-8 is tried, and Windows-1252 (the superset of latin-1 that European
    Windows lab software writes, ``°C``, ``µm``, ``ä``) is the fallback,
    latin-1 for its five undefined bytes.

    Parameters
    ----------
    data : bytes
        The file's content [-]

    Returns
    -------
    text : str
        Decoded text, without a byte-order mark [-]
    encoding : str
        The encoding used [-]

    Raises
    ------
    MeasurementError
        If a UTF-16/32 file does not decode.
    """
    data = bytes(data)
    for bom, enc in _BOMS:
        if data.startswith(bom):
            try:
                return data.decode(enc).lstrip("\ufeff"), enc.replace("-sig", "")
            except UnicodeDecodeError as exc:
                raise MeasurementError(f"the file starts with a {enc} byte-order mark but does "
                                       f"not decode as {enc} ({exc.reason} at byte {exc.start})") from None
    head = data[:4096]
    if head.count(b"\x00") * 4 >= len(head) > 0:   # >= 1 NUL in 4 bytes: UTF-16 without BOM
        enc = "utf-16-le" if head[1::2].count(b"\x00") > head[0::2].count(b"\x00") else "utf-16-be"
        try:
            return data.decode(enc), enc
        except UnicodeDecodeError as exc:
            raise MeasurementError(f"the file looks like {enc} (NUL bytes) but does not decode "
                                   f"({exc.reason} at byte {exc.start})") from None
    try:
        return data.decode("utf-8"), "utf-8"
    except UnicodeDecodeError:
        pass
    try:
        return data.decode("cp1252"), "cp1252"
    except UnicodeDecodeError:
        return data.decode("latin-1"), "latin-1"


_LINE_BREAK = re.compile(r"\r\n|\r|\n")
_DELIMITERS = (",", ";", "\t", "|")
_COMMA_DECIMAL = re.compile(r"^\s*[+-]?\d*,\d+(?:[eE][+-]?\d+)?\s*$")
_DOT_DECIMAL = re.compile(r"^\s*[+-]?\d*\.\d+(?:[eE][+-]?\d+)?\s*$")


def _sniff_delimiter(header_line: str) -> str:
    """Pick ',', ';', tab or '|' from the header line: the most frequent wins."""
    counts = {d: header_line.count(d) for d in _DELIMITERS}
    best = max(counts, key=lambda d: counts[d])
    return best if counts[best] > 0 else ","


def _looks_numeric(cell: str, decimal_comma: bool) -> bool:
    c = cell.strip()
    if decimal_comma:
        c = c.replace(",", ".")
    try:
        float(c)
        return True
    except ValueError:
        return False


def _source_text(source) -> tuple[str, str, str | None]:
    """Return (text, encoding, path or None) of a CSV source."""
    if isinstance(source, (bytes, bytearray, memoryview)):
        text, enc = decode_text(bytes(source))
        return text, enc, None
    if isinstance(source, str) and ("\n" in source or "\r" in source):
        return source.lstrip("\ufeff"), "text", None
    if isinstance(source, (str, os.PathLike)):
        path = Path(source)
        text, enc = decode_text(path.read_bytes())
        return text, enc, str(path)
    if hasattr(source, "read"):
        data = source.read()
        if isinstance(data, (bytes, bytearray)):
            text, enc = decode_text(bytes(data))
            return text, enc, None
        return str(data).lstrip("\ufeff"), "text", None
    raise TypeError("source must be a path, a file-like object or CSV text, "
                    f"got {type(source).__name__}")


@dataclass
class CsvTable:
    """A CSV file split into header, optional units row and columns of cells (see :func:`read_table`)."""
    header: list
    units: list | None
    columns: list
    row_lines: list
    dialect: dict


def read_table(text: str, max_rows: int | None = None) -> CsvTable:
    """Split CSV text into its header, units row and columns of cells.

    Line endings CR LF, LF and CR alone are accepted. The delimiter (comma,
    semicolon, tab or '|') is sniffed from the header; with a semicolon, tab
    or '|' delimiter, cells written with a decimal comma (``2,5``) and none
    with a decimal point mean a decimal comma. A first row under the header
    in which no cell is a number is a units row (``ms;%;bar(g);mm``).
    Lines starting with ``#`` and blank lines are skipped.

    Parameters
    ----------
    text : str
        Decoded CSV text [-]
    max_rows : int or None, optional
        Stop after this many data rows (a preview); None reads all, up to
        MAX_SAMPLES [-]

    Returns
    -------
    table : CsvTable
        ``header``, ``units`` (None without a units row), ``columns`` (lists
        of cell strings, decimal commas already turned into points),
        ``row_lines`` (physical line of each data row) and ``dialect``
        (``delimiter``, ``decimal``, ``units_row``) [-]

    Raises
    ------
    MeasurementError
        Naming the row and line of a malformed line (a cell longer than the
        CSV reader's limit, a NUL character, a row with more or fewer cells
        than the header).
    """
    lines = _LINE_BREAK.split(text)
    kept = [(i + 1, ln) for i, ln in enumerate(lines)
            if ln.strip() and not ln.lstrip().startswith("#")]
    export = bool(lines) and lines[0].startswith(EXPORT_MARKER)
    if not kept:
        raise MeasurementError("no header line found (the CSV is empty or all comments)")
    header_line, header_text = kept[0]
    delimiter = _sniff_delimiter(header_text)

    def split(lineno, row, line_text):
        if "\x00" in line_text:
            raise MeasurementError("the line holds a NUL character: is this a binary file "
                                   "(TDMS, .mat) sent as CSV?", row=row, line=lineno)
        try:
            return next(csv.reader([line_text], delimiter=delimiter))
        except csv.Error as exc:
            why = str(exc)
            if "field larger than field limit" in why:
                why = (f"a cell is longer than {csv.field_size_limit()} characters; "
                       "is the delimiter or a quote character wrong?")
            raise MeasurementError(f"unreadable CSV line: {why}", row=row, line=lineno) from None
        except StopIteration:
            return []

    header = [h.strip() for h in split(header_line, None, header_text)]
    while header and header[-1] == "":  # trailing delimiter
        header.pop()
    if len(header) > MAX_COLUMNS:
        raise MeasurementError(f"the header has {len(header)} columns; at most MAX_COLUMNS = "
                               f"{MAX_COLUMNS} are read (line {header_line})")
    for j, h in enumerate(header):
        if h == "":
            raise MeasurementError(
                f"header cell {j + 1} is empty; every column needs a name (line {header_line})")
    ncol = len(header)
    body = kept[1:]
    limit = MAX_SAMPLES if max_rows is None else max_rows
    # decimal comma: sniffed on the first rows of a file not delimited by commas
    decimal_comma = False
    if delimiter != ",":
        n_comma = n_dot = 0
        for _, ln in body[:200]:
            for c in ln.split(delimiter):
                n_comma += bool(_COMMA_DECIMAL.match(c))
                n_dot += bool(_DOT_DECIMAL.match(c))
        decimal_comma = n_comma > 0 and n_dot == 0
    units = None
    if body:
        lineno, first = body[0]
        cells = [c.strip() for c in split(lineno, 1, first)]
        # a units row: no number in it, and something besides missing-value markers
        if not any(_looks_numeric(c, decimal_comma) for c in cells if c) \
                and any(c.lower() not in _MISSING_TOKENS for c in cells):
            units = (cells + [""] * ncol)[:ncol]
            body = body[1:]
    cols: list[list[str]] = [[] for _ in range(ncol)]
    row_lines: list[int] = []
    for row, (lineno, ln) in enumerate(body, start=1):
        if row > limit:
            if max_rows is not None:
                break
            raise MeasurementError(
                f"too many samples: more than MAX_SAMPLES = {limit} data rows; "
                "decimate or split the measurement", row=row, line=lineno)
        cells = split(lineno, row, ln)
        if len(cells) < ncol:
            raise MeasurementError(
                f"row has {len(cells)} cells but the header has {ncol} columns",
                column=header[len(cells)], row=row, line=lineno)
        if len(cells) > ncol:
            extra = [c for c in cells[ncol:] if c.strip()]
            if extra:
                raise MeasurementError(
                    f"row has {len(cells)} cells but the header has {ncol} columns "
                    f"(extra value {extra[0].strip()!r})", row=row, line=lineno)
        for j in range(ncol):
            cols[j].append(cells[j])
        row_lines.append(lineno)
    if decimal_comma:
        cols = [[c.replace(",", ".") for c in col] for col in cols]
    dialect = {"delimiter": delimiter, "decimal": "," if decimal_comma else ".",
               "units_row": units is not None}
    if export:
        dialect["pneucore_export"] = True
    return CsvTable(header, units, cols, row_lines, dialect)


def read_csv(source, ambient_pressure: float = DEFAULT_AMBIENT_PRESSURE,
             name: str | None = None, columns: Mapping[str, Any] | None = None
             ) -> Measurement:
    """Read a test-rig measurement from CSV.

    The first non-comment line is the header. Column names are signal names
    (``t``, ``u``, ``p_a``, ``p_b``, ``x``, ``v``, ``T_a``, ``T_b``) or their
    aliases (:data:`ALIASES`: ``Time``, ``Zeit``, ``p_A``...), optionally
    with a unit in brackets (see :func:`parse_header`, :func:`canonical_unit`
    and :data:`UNITS`); a units row under the header gives the units of
    columns whose names carry none; no unit means SI. Other names are read
    through the `columns` mapping. Dialects: see :func:`read_table` (delimiter,
    decimal comma, line endings) and :func:`decode_text` (encoding).
    Whitespace around names and cells is ignored. Empty cells and the
    markers ``NaN``, ``NA``, ``n/a``, ``-``... are missing samples, each one
    listed in the import report.

    Parameters
    ----------
    source : str, os.PathLike, bytes or file-like
        Path to a CSV file, the file's bytes, an object with ``read()``
        (text or bytes), or the CSV text itself (a str containing a newline) [-]
    ambient_pressure : float, optional
        Ambient pressure of the rig, added to gauge columns (``p_a[bar(g)]``
        etc.) [Pa]
    name : str or None, optional
        Name of the measurement; default the file stem for paths, else "" [-]
    columns : mapping or None, optional
        Column mapping ``{"Zeit": "t", "pA": "p_a[bar(g)]", "Kraft": None}``
        (see :func:`check_mapping`) [-]

    Returns
    -------
    measurement : Measurement
        Validated, in SI units with absolute pressures. ``meta["import"]``
        holds the import report: format, encoding, delimiter, decimal mark,
        units row, every conversion (column, unit from and to, ambient used),
        ignored columns, missing cells by column and row ranges, warnings [-]

    Raises
    ------
    MeasurementError
        For any invalid content; ``row`` counts data rows from 1 after the
        header (comment and blank lines and the units row not counted) and
        ``line`` gives the physical line in the file.
    """
    ambient_pressure = _check_ambient(ambient_pressure)
    text, encoding, path = _source_text(source)
    table = read_table(text)
    if name is None:
        name = Path(path).stem if path is not None else ""
    meta: dict[str, Any] = {}
    if path is not None:
        meta["source"] = path
    report = {"format": "csv", "encoding": encoding, **table.dialect}
    return measurement_from_columns(list(zip(table.header, table.columns)), ambient_pressure, name, meta,
                         table.row_lines, decimal_comma_hint=(table.dialect["delimiter"] != ","),
                         units=table.units, mapping=columns, report=report)
