"""CSV exports of simulations and comparisons, in the format uploads read back.

One format for the API (``Accept: text/csv``), the page and the CLI's
``--csv``: a first comment line ``# pneucore <kind> export ...`` (the
marker), then a header whose names carry their unit in brackets
(``t[s]``, ``p_a[Pa]``, ``x[m]``), then one row per sample, numbers with 10
significant digits, a missing value as an empty cell. Pressures are absolute.

:func:`pneucore.data.measurement.read_csv` reads such a file back unchanged: the
measured signals (``t``, ``u``, ``p_a``, ``p_b``, ``x``, ``v``, ``T_a``,
``T_b``) are read, and because of the marker the other columns (masses,
flows, modes, a comparison's ``*_model`` and ``*_residual`` columns, the
``experiment`` label) are skipped and listed as ignored instead of refused.
"""
from __future__ import annotations

import numpy as np

from pneucore.data.measurement import EXPORT_MARKER, SIGNALS, SIGNAL_UNITS

__all__ = ["simulation_csv", "comparison_csv", "spreadsheet_safe", "EXPORT_MARKER"]

#: Significant digits written: below the solver's own accuracy (rtol 1e-5) by far and
#: above a 24-bit converter's resolution, without printing float noise (18 digits)
DIGITS = 10


#: First characters that make a spreadsheet (Excel, LibreOffice, Google Sheets) read a cell as a
#: formula, or that some of them strip before doing so (tab, carriage return): OWASP's
#: "CSV Injection" list
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def spreadsheet_safe(cell: str) -> str:
    """A text cell a spreadsheet shows as text: one that begins with a formula character
    (:data:`FORMULA_STARTS`) gets a leading single quote, as OWASP recommends against CSV
    injection (``=1+2`` -> ``'=1+2``). Only text cells go through it: numbers (``-1.5``)
    are written as they are.

    Parameters
    ----------
    cell : str
        The cell's text, before CSV quoting [-]

    Returns
    -------
    cell : str
        The text, neutralised when it could start a formula [-]

    Examples
    --------
    >>> spreadsheet_safe("=1+2"), spreadsheet_safe("@SUM(1+1)"), spreadsheet_safe("run 1")
    ("'=1+2", "'@SUM(1+1)", 'run 1')
    """
    return "'" + cell if cell.startswith(FORMULA_STARTS) else cell


def _cells(values) -> list[str]:
    """Text cells of one column: numbers with DIGITS significant digits, NaN as empty; text
    neutralised for spreadsheets (:func:`spreadsheet_safe`)."""
    arr = np.asarray(values)
    if arr.dtype.kind in "fiu":
        arr = arr.astype(np.float64)
        out = np.char.mod(f"%.{DIGITS}g", arr).astype(object)
        out[~np.isfinite(arr)] = ""
        return out.tolist()
    return [spreadsheet_safe(str(v)) for v in arr.tolist()]


def _quote(cell: str) -> str:
    if any(c in cell for c in ',"\n\r'):
        return '"' + cell.replace('"', '""') + '"'
    return cell


def _table(header: list[str], columns: list[list[str]], comment: str) -> str:
    lines = [f"{EXPORT_MARKER} {comment}", ",".join(_quote(spreadsheet_safe(h)) for h in header)]
    lines += [",".join(row) for row in zip(*columns)]
    return "\n".join(lines) + "\n"


def simulation_csv(result, series=None, units=None) -> str:
    """A simulation as CSV, units in brackets: ``t[s],u[-],p_a[Pa],...``.

    Parameters
    ----------
    result : SimulationResult or dict
        A result, or its ``to_dict()`` (``series`` and ``units``) [-]
    series : list of str or None, optional
        Series to write, in order; None = every series of the result [-]
    units : dict or None, optional
        Unit of each series when `result` is a plain dict without ``units`` [-]

    Returns
    -------
    text : str
        The CSV text; :func:`pneucore.data.measurement.read_csv` reads it back [-]
    """
    if isinstance(result, dict):
        data, units = result["series"], result.get("units", units or {})
        stroke = (result.get("stats") or {}).get("stroke")
    else:
        d = result.to_dict(series=series, arrays=True)
        data, units = d["series"], d["units"]
        stroke = d["stats"].get("stroke")
    names = [s for s in (series or list(data)) if s in data]
    if "t" in names:
        names.remove("t")
    names.insert(0, "t")
    header = [f"{n}[{units.get(n, '-')}]" for n in names]
    return _table(header, [_cells(data[n]) for n in names],
                  "simulation; SI units, absolute pressures; the measured signals read back on upload"
                  + _stroke_note(stroke))


#: Stroke metrics written on a simulation CSV's comment line: key, label, unit
_STROKE_NOTE = (("full_stroke_time_extend", "full stroke time extending", "s"),
                ("full_stroke_time_retract", "full stroke time retracting", "s"),
                ("end_speed_max", "stroke end speed", "m/s"),
                ("air_per_cycle_NL", "air per cycle", "NL"))


def _stroke_note(stroke):
    """``; full stroke time extending 0.112 s, ...`` from the stroke metrics (those defined)."""
    if not isinstance(stroke, dict):
        return ""
    parts = [f"{label} {stroke[key]:.4g} {unit}" for key, label, unit in _STROKE_NOTE
             if isinstance(stroke.get(key), (int, float))]
    return "; " + ", ".join(parts) if parts else ""


def comparison_csv(comparison) -> str:
    """Measured, model and residual series of a comparison as CSV.

    One row per sample of each experiment: ``experiment``, ``t[s]`` (the
    measurement's own time), ``u[-]``, then for each compared signal the
    measured value (``p_a[Pa]``), the model's (``p_a_model[Pa]``) and the
    residual model - measured (``p_a_residual[Pa]``).

    Parameters
    ----------
    comparison : pneucore.analysis.compare.Comparison
        The result of :func:`pneucore.analysis.compare.compare` (with its replays) [-]

    Returns
    -------
    text : str
        The CSV text; a one-experiment file reads back as that measurement [-]
    """
    replays = comparison.replays
    signals = [s for s in SIGNALS if s != "u" and any(s in rp.measured for rp in replays)]
    header = ["experiment", "t[s]", "u[-]"]
    for s in signals:
        unit = SIGNAL_UNITS[s]
        header += [f"{s}[{unit}]", f"{s}_model[{unit}]", f"{s}_residual[{unit}]"]
    cols: list[list[str]] = [[] for _ in header]
    for rp in replays:
        n = len(rp.t)
        exp = rp.experiment
        nan = np.full(n, np.nan)
        parts = [[spreadsheet_safe(str(exp.name))] * n, _cells(np.asarray(rp.t) + exp.t0),
                 _cells(exp.command_samples[:n])]
        for s in signals:
            meas = np.asarray(rp.measured.get(s, nan), float)
            sim = np.asarray(rp.simulated.get(s, nan), float)
            parts += [_cells(meas), _cells(sim), _cells(sim - meas)]
        for col, part in zip(cols, parts):
            col.extend(_quote(c) for c in part) if part is parts[0] else col.extend(part)
    return _table(header, cols, "comparison; SI units, absolute pressures; residual = model - "
                                "measured; the measured signals read back on upload")
