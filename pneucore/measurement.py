"""Test-rig measurements of a pneumatic jack.

A :class:`Measurement` is a time series sampled on a test rig: the time
``t`` [s], the valve command ``u`` [-] and any of the chamber pressures
``p_a``, ``p_b`` [Pa], the rod position ``x`` [m], and optionally the rod
velocity ``v`` [m/s] and chamber temperatures ``T_a``, ``T_b`` [K].

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
import io
import math
import numbers
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Mapping

import numpy as np

__all__ = [
    "MeasurementError",
    "Measurement",
    "read_csv",
    "parse_header",
    "SIGNALS",
    "SIGNAL_UNITS",
    "UNITS",
    "MIN_SAMPLES",
    "MAX_SAMPLES",
    "DEFAULT_AMBIENT_PRESSURE",
]

SIGNALS: tuple[str, ...] = ("u", "p_a", "p_b", "x", "v", "T_a", "T_b")
"""Known signal names (the time column ``t`` is not a signal)."""

SIGNAL_UNITS: dict[str, str] = {
    "u": "-",
    "p_a": "Pa",
    "p_b": "Pa",
    "x": "m",
    "v": "m/s",
    "T_a": "K",
    "T_b": "K",
}
"""SI unit of each signal as stored in a :class:`Measurement`."""

MIN_SAMPLES: int = 10
"""Minimum number of samples (data rows) of a measurement."""

MAX_SAMPLES: int = 2_000_000
"""Maximum number of samples (data rows) of a measurement."""

DEFAULT_AMBIENT_PRESSURE: float = 101300.0
"""Default ambient pressure used to convert gauge pressures [Pa]."""

PSI: float = 6894.757293168361
"""One pound-force per square inch [Pa] (0.45359237 kg * 9.80665 m/s^2 / 0.0254^2 m^2)."""

_PRESSURES = ("p_a", "p_b")
_TEMPERATURES = ("T_a", "T_b")
_COLUMNS = ("t",) + SIGNALS
_MISSING_TOKENS = frozenset({"", "nan", "na"})


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
    return (out - 32.0) * 5.0 / 9.0 + 273.15


# unit -> (factor spec, is_gauge). Gauge units get ambient pressure added.
_PRESSURE_UNITS: dict[str, tuple[dict, bool]] = {
    "Pa": ({}, False),
    "kPa": ({"mul": 1e3}, False),
    "MPa": ({"mul": 1e6}, False),
    "bar": ({"mul": 1e5}, False),
    "psi": ({"mul": PSI}, False),
    "Pag": ({}, True),
    "kPag": ({"mul": 1e3}, True),
    "MPag": ({"mul": 1e6}, True),
    "barg": ({"mul": 1e5}, True),
    "psig": ({"mul": PSI}, True),
}
_LENGTH_UNITS = {"m": {}, "mm": {"div": 1e3}, "cm": {"div": 1e2},
                 "um": {"div": 1e6}, "\u00b5m": {"div": 1e6}, "\u03bcm": {"div": 1e6}}
_VELOCITY_UNITS = {"m/s": {}, "mm/s": {"div": 1e3}}
_TIME_UNITS = {"s": {}, "ms": {"div": 1e3}}
_COMMAND_UNITS = {"-": {}, "%": {"div": 1e2}}
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
}
"""Accepted unit suffixes for each column name (``t`` included)."""

_HEADER_RE = re.compile(r"^\s*([^\[\]\s]+)\s*(?:\[\s*([^\[\]]*?)\s*\])?\s*$")


def _check_ambient(ambient_pressure: float) -> float:
    try:
        p = float(ambient_pressure)
    except (TypeError, ValueError):
        raise MeasurementError(
            f"ambient_pressure must be a number in Pa, got {ambient_pressure!r}") from None
    if not math.isfinite(p) or p <= 0.0:
        raise MeasurementError(
            f"ambient_pressure must be a finite positive absolute pressure in Pa, got {p!r}")
    return p


def parse_header(name: str, ambient_pressure: float = DEFAULT_AMBIENT_PRESSURE
                 ) -> tuple[str, Callable[[Any], np.ndarray]]:
    """Parse a column name such as ``p_a[bar]`` into a signal and a converter.

    Parameters
    ----------
    name : str
        Column name: one of ``t``, ``u``, ``p_a``, ``p_b``, ``x``, ``v``,
        ``T_a``, ``T_b``, optionally followed by a unit in brackets
        (``p_a[kPa]``, ``x[mm]``, ``T_a[degC]``...). Surrounding whitespace
        is ignored; names are case-sensitive. No unit (or ``[]``) means SI [-]
    ambient_pressure : float, optional
        Ambient pressure added to gauge pressure columns (units ending in
        ``g``: ``barg``, ``kPag``, ``MPag``, ``psig``, ``Pag``) [Pa]

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
        close = difflib.get_close_matches(signal, _COLUMNS, n=1, cutoff=0.5)
        if close:
            msg += f" (did you mean {close[0]!r}?)"
        raise MeasurementError(msg, column=name)
    accepted = UNITS[signal]
    if unit is None or unit == "":
        return signal, _scale()
    if unit not in accepted:
        si = "s" if signal == "t" else SIGNAL_UNITS[signal]
        raise MeasurementError(
            f"unknown unit {unit!r} for {signal!r}; accepted units: "
            f"{', '.join(accepted)} (no unit means SI, {si})", column=name)

    if signal in _PRESSURES:
        spec, gauge = _PRESSURE_UNITS[unit]
        if gauge:
            spec = dict(spec, add=_check_ambient(ambient_pressure))
        return signal, _scale(**spec)
    if signal in _TEMPERATURES:
        kind = _TEMPERATURE_UNITS[unit]
        if kind == "K":
            return signal, _scale()
        if kind == "C":
            return signal, _scale(add=273.15)
        return signal, _fahrenheit
    table = {"t": _TIME_UNITS, "u": _COMMAND_UNITS, "x": _LENGTH_UNITS,
             "v": _VELOCITY_UNITS}[signal]
    return signal, _scale(**table[unit])


# --------------------------------------------------------------------------
# Cell parsing
# --------------------------------------------------------------------------

def _parse_values(values: list, column: str, lines: list[int] | None,
                  decimal_comma_hint: bool = False) -> np.ndarray:
    """Convert a list of cells (str, number or None) to float64, NaN = missing."""
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


def _from_columns(columns: list[tuple[str, list]], ambient_pressure: float,
                  name: str, meta: dict, lines: list[int] | None,
                  decimal_comma_hint: bool = False) -> "Measurement":
    """Shared back end of :func:`read_csv` and :meth:`Measurement.from_dict`."""
    ambient_pressure = _check_ambient(ambient_pressure)
    parsed: dict[str, tuple[str, Callable, list]] = {}
    for label, values in columns:
        signal, convert = parse_header(label, ambient_pressure)
        if signal in parsed:
            first = parsed[signal][0]
            raise MeasurementError(
                f"duplicate column: {first!r} and {label!r} both give signal {signal!r}",
                column=label)
        parsed[signal] = (label, convert, values)
    found = ", ".join(repr(label) for label, _ in columns) or "none"
    for required in ("t", "u"):
        if required not in parsed:
            raise MeasurementError(
                f"required column {required!r} is missing (columns found: {found})",
                column=required)

    source_columns = {sig: label for sig, (label, _, _) in parsed.items()}
    arrays: dict[str, np.ndarray] = {}
    for sig, (label, convert, values) in parsed.items():
        raw = _parse_values(values, label, lines, decimal_comma_hint)
        with np.errstate(over="ignore", invalid="ignore"):
            arrays[sig] = convert(raw)
    t = arrays.pop("t")
    signals = {sig: arrays[sig] for sig in SIGNALS if sig in arrays}
    meta = dict(meta)
    meta.setdefault("columns", dict(source_columns))
    m = Measurement(t=t, signals=signals, name=name, meta=meta)
    m._columns = source_columns
    m._lines = list(lines) if lines is not None else None
    return m.validate()


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
        temperatures [K]
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

        Checks, in order: array shapes and signal names; presence of ``u``;
        ``MIN_SAMPLES <= n <= MAX_SAMPLES``; ``t`` finite and strictly
        increasing; no infinite values; no signal entirely missing; a first
        command sample present; ``u`` within [-1, 1]; pressures > 0 Pa
        absolute; temperatures > 0 K; at least one measured signal besides
        ``u``. Missing ``u`` samples are then filled in place by holding the
        previous value (zero-order hold).

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
        if "u" not in self.signals:
            raise MeasurementError("required column 'u' (valve command) is missing",
                                   column="u")
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
            what = "missing" if np.isnan(t[i]) else f"infinite ({t[i]})"
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
                raise self._err(f"infinite value ({arr[i]}) after conversion to "
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
                        msg = (f"absolute pressure {arr[i]!r} Pa is not positive (gauge "
                               "columns such as 'p_a[barg]' are converted by adding "
                               "the ambient pressure)")
                    else:
                        msg = f"temperature {arr[i]!r} K is not positive"
                    raise self._err(msg, sig, i)

        if not self.measured_signals:
            raise MeasurementError(
                "no measured signal besides 'u'; provide at least one of "
                + ", ".join(s for s in SIGNALS if s != "u"))

        u = self.signals["u"]
        missing = np.isnan(u)
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
        return _from_columns(columns, ambient_pressure, name, dict(meta), None)

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
        u = self.signals["u"]
        if self.n == 0:
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

def _sniff_delimiter(header_line: str) -> str:
    """Pick ',' or ';' (or tab) from the header line: the most frequent wins."""
    counts = {d: header_line.count(d) for d in (",", ";", "\t")}
    best = max(counts, key=lambda d: counts[d])
    return best if counts[best] > 0 else ","


def _open_text(source) -> tuple[io.TextIOBase, bool, str | None]:
    """Return (text stream, must_close, path or None)."""
    if isinstance(source, (bytes, bytearray)):
        return io.StringIO(bytes(source).decode("utf-8-sig")), True, None
    if isinstance(source, str) and ("\n" in source or "\r" in source):
        return io.StringIO(source.lstrip("\ufeff")), True, None
    if isinstance(source, (str, os.PathLike)):
        path = Path(source)
        return open(path, "r", encoding="utf-8-sig", newline=""), True, str(path)
    if hasattr(source, "read"):
        data = source.read()
        if isinstance(data, (bytes, bytearray)):
            data = bytes(data).decode("utf-8-sig")
        return io.StringIO(data.lstrip("\ufeff")), True, None
    raise TypeError("source must be a path, a file-like object or CSV text, "
                    f"got {type(source).__name__}")


def read_csv(source, ambient_pressure: float = DEFAULT_AMBIENT_PRESSURE,
             name: str | None = None) -> Measurement:
    """Read a test-rig measurement from CSV.

    The first non-comment line is the header. Column names are signal names
    (``t``, ``u``, ``p_a``, ``p_b``, ``x``, ``v``, ``T_a``, ``T_b``),
    optionally with a unit in brackets (see :func:`parse_header` and
    :data:`UNITS`); no unit means SI. The delimiter (comma or semicolon, tab
    also accepted) is sniffed from the header. Whitespace around names and
    cells is ignored, lines starting with ``#`` and blank lines are skipped.
    Empty cells, ``NaN``, ``nan`` and ``NA`` are missing samples.

    Parameters
    ----------
    source : str, os.PathLike or file-like
        Path to a CSV file, an object with ``read()`` (text or bytes), or
        the CSV text itself (a str containing a newline) [-]
    ambient_pressure : float, optional
        Ambient pressure used for gauge columns (``p_a[barg]`` etc.) [Pa]
    name : str or None, optional
        Name of the measurement; default the file stem for paths, else "" [-]

    Returns
    -------
    measurement : Measurement
        Validated, in SI units with absolute pressures [-]

    Raises
    ------
    MeasurementError
        For any invalid content; ``row`` counts data rows from 1 after the
        header (comment and blank lines not counted) and ``line`` gives the
        physical line in the file.
    """
    ambient_pressure = _check_ambient(ambient_pressure)
    stream, must_close, path = _open_text(source)
    try:
        kept_lines: list[int] = []

        def data_lines() -> Iterator[str]:
            for lineno, text in enumerate(stream, start=1):
                stripped = text.strip()
                if not stripped or stripped.startswith("#"):
                    continue
                kept_lines.append(lineno)
                yield text

        it = data_lines()
        header_text = next(it, None)
        if header_text is None:
            raise MeasurementError("no header line found (the CSV is empty or all comments)")
        delimiter = _sniff_delimiter(header_text)
        header = [h.strip() for h in next(csv.reader([header_text], delimiter=delimiter))]
        while header and header[-1] == "":  # trailing delimiter
            header.pop()
        for j, h in enumerate(header):
            if h == "":
                raise MeasurementError(
                    f"header cell {j + 1} is empty; every column needs a name "
                    f"(line {kept_lines[0]})")
        ncol = len(header)
        # Parse the header now, so unknown names fail before reading the data.
        for h in header:
            parse_header(h, ambient_pressure)

        cols: list[list[str]] = [[] for _ in range(ncol)]
        row_lines: list[int] = []
        reader = csv.reader(it, delimiter=delimiter)
        max_samples = MAX_SAMPLES
        for cells in reader:
            row = len(row_lines) + 1
            line = kept_lines[-1]
            if row > max_samples:
                raise MeasurementError(
                    f"too many samples: more than MAX_SAMPLES = {max_samples} data rows; "
                    "decimate or split the measurement", row=row, line=line)
            if len(cells) < ncol:
                raise MeasurementError(
                    f"row has {len(cells)} cells but the header has {ncol} columns",
                    column=header[len(cells)], row=row, line=line)
            if len(cells) > ncol:
                extra = [c for c in cells[ncol:] if c.strip()]
                if extra:
                    raise MeasurementError(
                        f"row has {len(cells)} cells but the header has {ncol} columns "
                        f"(extra value {extra[0].strip()!r})", row=row, line=line)
            for j in range(ncol):
                cols[j].append(cells[j])
            row_lines.append(line)
    finally:
        if must_close:
            stream.close()

    if name is None:
        name = Path(path).stem if path is not None else ""
    meta: dict[str, Any] = {}
    if path is not None:
        meta["source"] = path
    return _from_columns(list(zip(header, cols)), ambient_pressure, name, meta,
                         row_lines, decimal_comma_hint=(delimiter == ";"))
