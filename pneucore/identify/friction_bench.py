"""A friction bench: the model's friction law from prescribed-motion records (paper section 2.3).

An external drive moves the piston while the chambers are held at (nearly) constant
pressures and a load cell measures the rod force ``F`` (the force the rod exerts on its
load, positive outward, towards +x). The piston's force balance (Eq. 17) then gives the
friction at every sample,

.. math::
    F_f = p_a A_a - p_b A_b + p_{atm} (A_{rod,a} - A_{rod,b}) - F - m \\ddot x ,

with the velocity and acceleration from the measured position by acausal filtered
differentiation (a Savitzky-Golay polynomial fitted over a centred window, as the paper's
"non-causal filtering"). The law fitted is the model's (Eq. 18-20), one set per direction
(the quadrant effect):

.. math::
    F_f = K_v(p)\\, \\dot x + \\mathrm{sign}(\\dot x)\\, F_c(p)\\, S(\\dot x), \\quad
    F_c = f_{c0} + f_{ca} (p_a - p_{atm}) + f_{cb} (p_b - p_{atm}), \\quad
    K_v = k_{v0} + k_{va} (p_a - p_{atm}) + k_{vb} (p_b - p_{atm}),

with the breakaway factor ``S = 1 + (r - 1) exp(-(v / v_s)^2)`` of the
``stribeck_friction`` effect only where the data show it. A load-cell offset, effective
piston areas and the moving mass are identified on request. Every parameter comes with a
standard error (inflated by the residuals' integrated autocorrelation time:
:func:`pneucore.analysis.autocorrelation.integrated_time`) and their correlations; a
parameter the records cannot separate from the others (a pressure coefficient of a chamber
held at one pressure, an offset beside per-direction Coulomb levels) is not identified: it
keeps the model's value and the report says why. When the friction is not linear in
pressure (Eq. 19-20 do not hold) the result says so rather than forcing the fit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from scipy.optimize import least_squares, lsq_linear
from scipy.signal import savgol_filter

from pneucore.analysis.autocorrelation import integrated_time
from pneucore.physics.friction import FRICTION_LAWS, coulomb_level, stribeck_factor, viscous_coefficient
from pneucore.physics.gas import P_ATM
from pneucore.description.effects import EFFECTS
from pneucore.description.model import Model
from pneucore.description.provenance import TEXT_MAX, record
from pneucore.description.validation import FieldError

#: Fewest samples of a record [-]: the velocity filter's default window spans 15 samples at
#: 100 Hz, and a record must hold more than one window
MIN_RECORD_SAMPLES = 30

#: Magnitude bounds of a record's values, by signal: beyond them a value is a unit mistake
#: (a time in ms read as s, a force in mN) and the fit's arithmetic would overflow. Times
#: up to a day [s], positions 100 m [m], absolute pressures 1 GPa [Pa], forces 10 MN [N]
LIMITS = {"t": 86400.0, "x": 100.0, "p_a": 1e9, "p_b": 1e9, "F": 1e7}

#: Fewest sliding samples per direction to identify that direction's friction set [-]: two
#: filter windows of sliding (fewer is a reversal, not a stroke)
MIN_SLIDING_SAMPLES = 30

#: A parameter is not identified when its regressor is less than this fraction independent
#: of those identified before it (the sine of its angle to their span): 5 % leaves out a
#: pressure coefficient fitted on one held pressure whose reading wanders by 3 % [-]
IDENTIFIABLE = 0.05

#: One pressure level [Pa]: records whose held gauge pressures are within 0.2 bar of one another
#: are one level (a regulator wanders by about 0.05 bar as the piston moves), and a chamber whose
#: pressure spans less than this over the fitted samples is held at one level: its pressure
#: coefficients (fc_a, kv_a or fc_b, kv_b, an effective area) are not determined
LEVEL_STEP = 2e4

#: Fraction of the fitted samples left out at each end of a chamber's pressure span, so that a
#: glitch does not make a held pressure look varied [-] (1 %: a level held by 1 % of the
#: samples, a few hundred at 100 Hz, still counts)
SPAN_QUANTILE = 0.01

#: Friction is flagged not linear in pressure when, at some pressure level and direction, the
#: mean residual of the fitted law exceeds this fraction of the friction scale there (the
#: mean of the two directions' magnitudes) and three times its standard error [-]. 20 %: on
#: the real rig (shared/data/friction-bench, fitted at 1, 3 and 7 bar) the law leaves at most
#: 14 % on the three seals whose friction grows smoothly, 29 % on the X-ring, whose friction
#: jumps between 5 and 7 bar
LINEARITY_TOLERANCE = 0.2

#: Stribeck is kept (``stribeck="auto"``) when its ratio exceeds 1 by this much and by three
#: standard errors, and it lowers the rms residual by at least ``STRIBECK_GAIN`` [-]
STRIBECK_MIN_EXCESS = 0.05
STRIBECK_GAIN = 0.02

#: Default velocity threshold as a fraction of the records' 95th-percentile speed: samples
#: slower than this are reversals (stick, seal deflection) and are not fitted [-]
V_MIN_FRACTION = 0.1

#: Default window of the acausal differentiating filter [s]
WINDOW = 0.15

#: Extra parameters that can be identified beside the friction law, with their unit
EXTRAS = {"offset": "N", "area_a": "m^2", "area_b": "m^2", "mass": "kg"}

_KEYS = ("fc0", "fc_a", "fc_b", "kv0", "kv_a", "kv_b")
_UNITS = {"fc0": "N", "fc_a": "N/Pa", "fc_b": "N/Pa", "kv0": "N s/m", "kv_a": "N s/(m Pa)",
          "kv_b": "N s/(m Pa)"}
#: The order in which regressors are admitted (identifiability is judged in this order)
_PRIORITY = [("extend", "fc0"), ("retract", "fc0"), ("extend", "kv0"), ("retract", "kv0"),
             ("extend", "fc_a"), ("retract", "fc_a"), ("extend", "fc_b"), ("retract", "fc_b"),
             ("extend", "kv_a"), ("retract", "kv_a"), ("extend", "kv_b"), ("retract", "kv_b")]
#: Friction effects whose transforms would add to the identified sets: left out of the model
_FRICTION_EFFECTS = ("pressure_dependent_friction", "quadrant_friction")


@dataclass
class FrictionRecord:
    """One prescribed-motion record of a friction bench.

    Parameters
    ----------
    t : ndarray
        Sample times, increasing [s]
    x : ndarray
        Piston position, extension positive [m]
    p_a : ndarray
        Chamber A absolute pressure [Pa]
    p_b : ndarray
        Chamber B absolute pressure [Pa]
    F : ndarray
        Rod force on its load, positive outward (towards +x) [N]
    name : str
        Label [-]
    """
    t: np.ndarray
    x: np.ndarray
    p_a: np.ndarray
    p_b: np.ndarray
    F: np.ndarray
    name: str = ""

    @classmethod
    def from_dict(cls, d, path="experiments[0]"):
        """A validated record from ``{t, x, p_a, p_b, F, name}`` (or ``{name, measurement:
        {...}}``); samples with a missing value (None) are dropped. A
        :class:`~pneucore.description.validation.FieldError` names the field."""
        if not isinstance(d, dict):
            raise FieldError(path, f"must be an object with t, x, p_a, p_b, F, got {type(d).__name__}")
        name = d.get("name") or ""
        if isinstance(d.get("measurement"), dict):
            d = d["measurement"]
            path = f"{path}.measurement"
            name = name or d.get("name") or ""
        cols = {}
        n = None
        for key, unit in (("t", "s"), ("x", "m"), ("p_a", "Pa abs"), ("p_b", "Pa abs"), ("F", "N")):
            if d.get(key) is None:
                what = " (the rod force on its load, positive outward)" if key == "F" else ""
                raise FieldError(f"{path}.{key}", f"is required{what} [{unit}]")
            vals = d[key]
            if not isinstance(vals, (list, tuple, np.ndarray)):
                raise FieldError(f"{path}.{key}", f"must be a list of numbers [{unit}]")
            if n is None:
                n = len(vals)
            elif len(vals) != n:
                raise FieldError(f"{path}.{key}", f"has {len(vals)} samples, t has {n}")
            try:
                arr = np.array([np.nan if v is None else v for v in vals], dtype=float)
            except (TypeError, ValueError):
                raise FieldError(f"{path}.{key}", f"must be a list of numbers [{unit}]") from None
            big = np.isinf(arr) | (np.abs(np.nan_to_num(arr)) > LIMITS[key])
            if big.any():
                i = int(np.flatnonzero(big)[0])
                raise FieldError(f"{path}.{key}[{i}]", f"must be finite and within +-{LIMITS[key]:g} "
                                                       f"[{unit}], got {arr[i]:g}")
            cols[key] = arr
        keep = np.all([np.isfinite(a) for a in cols.values()], axis=0)
        cols = {k: a[keep] for k, a in cols.items()}
        if keep.sum() < MIN_RECORD_SAMPLES:
            raise FieldError(f"{path}.t", f"{int(keep.sum())} complete samples, at least "
                                          f"{MIN_RECORD_SAMPLES} are needed")
        dt = np.diff(cols["t"])
        if (dt <= 0).any():
            i = int(np.flatnonzero(dt <= 0)[0]) + 1
            raise FieldError(f"{path}.t[{i}]", "sample times must increase [s]")
        for key in ("p_a", "p_b"):
            if (cols[key] <= 0).any():
                i = int(np.flatnonzero(cols[key] <= 0)[0])
                raise FieldError(f"{path}.{key}[{i}]", "absolute pressures must be > 0 [Pa]")
        return cls(cols["t"], cols["x"], cols["p_a"], cols["p_b"], cols["F"], str(name))

    def to_dict(self):
        return {"name": self.name, "t": self.t.tolist(), "x": self.x.tolist(),
                "p_a": self.p_a.tolist(), "p_b": self.p_b.tolist(), "F": self.F.tolist()}


#: The TU Delft friction bench's file layout (``shared/data/friction-bench``, its README): time
#: [ms], three raw voltages (not read), piston position [mm] increasing as the piston moves into
#: the pressurised chamber (a retraction, hence ``-x``), chamber pressure [bar gauge], rod force
#: [N]. The importer's column labels and units (:func:`pneucore.data.measurement.parse_header`)
RIG_COLUMNS = ("t[ms]", None, None, None, "-x[mm]", "p_a[bar(g)]", "F[N]")

#: The signals a friction-bench file may hold; ``p_b`` may be left out (chamber B at ambient)
BENCH_SIGNALS = ("t", "x", "p_a", "p_b", "F")
#: Signals whose column may be read negated (a leading ``-``: the rig's sign is the opposite)
_NEGATABLE = ("x", "F")
#: Most columns of a bench file [-]
MAX_BENCH_COLUMNS = 64


def bench_columns(columns, p_atm=P_ATM, field="columns"):
    """The column layout of a headerless bench file, checked.

    Parameters
    ----------
    columns : sequence of str or None, or str
        One label per column in file order: a signal of :data:`BENCH_SIGNALS` with its unit in
        brackets as the importer reads it (``t[ms]``, ``x[mm]``, ``p_a[bar(g)]``, ``F[kN]``),
        a leading ``-`` to negate ``x`` or ``F``, and None, ``""``, ``"-"`` or ``"_"`` for a
        column not read; a string is split at commas [-]
    p_atm : float
        Ambient pressure added to gauge pressures [Pa]
    field : str
        The request's field, for the messages [-]

    Returns
    -------
    list of tuple
        ``(column index, signal, sign, converter)`` of the columns read [-]

    Raises
    ------
    pneucore.description.validation.FieldError
        An unknown signal or unit, a signal twice, or t, x, p_a or F missing (naming the column)

    Examples
    --------
    >>> [(i, sig, sign) for i, sig, sign, _ in bench_columns(RIG_COLUMNS)]
    [(0, 't', 1.0), (4, 'x', -1.0), (5, 'p_a', 1.0), (6, 'F', 1.0)]
    """
    from pneucore.data.measurement import MeasurementError, parse_header

    if isinstance(columns, str):
        columns = [c.strip() for c in columns.split(",")]
    if not isinstance(columns, (list, tuple)) or not 0 < len(columns) <= MAX_BENCH_COLUMNS:
        raise FieldError(field, f"must list 1 to {MAX_BENCH_COLUMNS} column labels in file order")
    out, seen = [], {}
    for i, label in enumerate(columns):
        if label is None or (isinstance(label, str) and label.strip() in ("", "-", "_")):
            continue
        if not isinstance(label, str):
            raise FieldError(f"{field}[{i}]", f"must be a label such as x[mm], got {label!r}")
        text = label.strip()
        sign = -1.0 if text.startswith("-") else 1.0
        text = text.lstrip("-").strip()
        try:
            signal, conv = parse_header(text, p_atm)
        except MeasurementError as exc:
            raise FieldError(f"{field}[{i}]", f"{label!r}: {exc}") from None
        if signal not in BENCH_SIGNALS:
            raise FieldError(f"{field}[{i}]", f"{label!r}: a friction-bench file holds "
                                              f"{', '.join(BENCH_SIGNALS)}, not {signal}")
        if sign < 0 and signal not in _NEGATABLE:
            raise FieldError(f"{field}[{i}]", f"{label!r}: only {' and '.join(_NEGATABLE)} can be "
                                              f"negated")
        if signal in seen:
            raise FieldError(f"{field}[{i}]", f"{signal} is already column {seen[signal] + 1}")
        seen[signal] = i
        out.append((i, signal, sign, conv))
    for need in ("t", "x", "p_a", "F"):
        if need not in seen:
            raise FieldError(field, f"no column holds {need} (a friction record needs t, x, p_a "
                                    f"and F; p_b may be left out: chamber B at ambient)")
    return out


def _bench_rows(source, field, max_rows):
    """The text lines of a bench file (a path or its bytes) with their line numbers, blank
    lines and ``#`` comments left out."""
    if isinstance(source, (bytes, bytearray, memoryview)):
        raw = bytes(source)
    else:
        with open(source, "rb") as fh:
            raw = fh.read()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    if "\x00" in text:
        raise FieldError(field, "is not a text file (it holds NUL bytes): a bench file is text")
    if max_rows is not None and text.count("\n") > 2 * max_rows + 1000:
        raise FieldError(field, f"has more than {max_rows} rows (at most {max_rows} samples a record)")
    rows, numbers = [], []
    for k, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if s and not s.startswith("#"):
            rows.append(s.replace(",", " ").replace(";", " "))
            numbers.append(k)
    if max_rows is not None and len(rows) > max_rows:
        raise FieldError(field, f"has {len(rows)} rows, at most {max_rows} samples a record")
    return rows, numbers


def read_bench_file(source, p_atm=P_ATM, name=None, columns=RIG_COLUMNS, *, field="file",
                    max_rows=None):
    """Read a friction-bench record as the rig writes it: no header, one sample a line.

    By default the TU Delft friction bench's files (``shared/data/friction-bench``,
    :data:`RIG_COLUMNS`): whitespace-separated, seven columns, time [ms], three raw voltages,
    piston position [mm], chamber pressure [bar gauge], rod force [N]. The pressurised chamber
    pushes the rod outward, so it is chamber A and its position increasing (the piston moving
    into the chamber) is a retraction: ``x = -position``. Another rig declares its own
    ``columns`` (:func:`bench_columns`). Values may be separated by blanks, tabs, commas or
    semicolons. Without a ``p_b`` column chamber B is at ambient: ``p_b = p_atm``. The
    logger's start (about 270 ms between the first two rows) and any later gap are left to
    :func:`kinematics`, which differentiates each gap-free stretch on its own.

    Parameters
    ----------
    source : str, path-like or bytes
        File path, or the file's content
    p_atm : float
        Ambient pressure, to make gauge readings absolute and chamber B's when not measured [Pa]
    name : str or None
        Label; None = the file name [-]
    columns : sequence of str or None
        The column layout (:func:`bench_columns`) [-]
    field : str
        The request's field, for the messages [-]
    max_rows : int or None
        Most samples; None = no limit [-]

    Returns
    -------
    FrictionRecord

    Raises
    ------
    pneucore.description.validation.FieldError
        A malformed file, naming the line (and column): a row with another number of values, a
        cell that is no number, a value beyond :data:`LIMITS`, times not increasing, a
        pressure not positive, fewer than :data:`MIN_RECORD_SAMPLES` rows
    """
    import io
    import os
    if not (isinstance(p_atm, (int, float)) and 0.0 < p_atm <= LIMITS["p_b"]):
        raise FieldError("ambient_pressure", f"must be an absolute pressure in (0, {LIMITS['p_b']:g}] "
                                             f"[Pa], got {p_atm!r}")
    layout = bench_columns(columns, p_atm)
    rows, numbers = _bench_rows(source, field, max_rows)
    ncol = len(columns)
    if len(rows) < MIN_RECORD_SAMPLES:
        raise FieldError(field, f"{len(rows)} data rows, at least {MIN_RECORD_SAMPLES} are needed")
    try:
        data = np.loadtxt(io.StringIO("\n".join(rows)), ndmin=2, comments=None)
    except ValueError:
        data = None
    if data is None or data.shape[1] != ncol:
        for line, row in zip(numbers, rows):   # name the first bad line
            cells = row.split()
            if len(cells) != ncol:
                raise FieldError(f"{field}.line[{line}]", f"{len(cells)} values, the layout has {ncol} "
                                                         f"columns ({', '.join(str(c) for c in columns)})")
            for j, c in enumerate(cells):
                try:
                    float(c)
                except ValueError:
                    raise FieldError(f"{field}.line[{line}]", f"column {j + 1}: {c[:40]!r} is not a "
                                                             f"number") from None
        raise FieldError(field, "could not be read as a table of numbers")
    cols = {}
    for j, signal, sign, conv in layout:
        raw = data[:, j]
        bad = ~np.isfinite(raw)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise FieldError(f"{field}.line[{numbers[k]}]", f"column {j + 1} ({signal}): {raw[k]} is "
                                                           f"not a finite number")
        vals = conv(-raw if sign < 0 else raw)
        big = np.abs(vals) > LIMITS[signal]
        if big.any():
            k = int(np.flatnonzero(big)[0])
            raise FieldError(f"{field}.line[{numbers[k]}]", f"column {j + 1} ({signal}): {vals[k]:g} "
                                                           f"beyond +-{LIMITS[signal]:g} in SI units "
                                                           f"(check the column's unit)")
        cols[signal] = vals
    dt = np.diff(cols["t"])
    if (dt <= 0).any():
        k = int(np.flatnonzero(dt <= 0)[0]) + 1
        raise FieldError(f"{field}.line[{numbers[k]}]", "sample times must increase [s]")
    if "p_b" not in cols:
        cols["p_b"] = np.full_like(cols["t"], p_atm)
    for key in ("p_a", "p_b"):
        if (cols[key] <= 0).any():
            k = int(np.flatnonzero(cols[key] <= 0)[0])
            raise FieldError(f"{field}.line[{numbers[k]}]", f"{key}: absolute pressures must be > 0 "
                                                           f"[Pa] (a gauge reading below -1 atm)")
    if name is None:
        name = "" if isinstance(source, (bytes, bytearray, memoryview)) else os.path.basename(str(source))
    return FrictionRecord(cols["t"], cols["x"], cols["p_a"], cols["p_b"], cols["F"], name)


def kinematics(t, x, window=WINDOW, polyorder=3):
    """Velocity and acceleration by acausal filtered differentiation.

    Each stretch without a gap (a step over 2.5 times the median) is resampled on its median
    step, differentiated by a Savitzky-Golay filter (a cubic fitted over a centred window:
    no phase lag), and read back at the samples. Samples within half a window of a
    stretch's ends are marked invalid.

    Parameters
    ----------
    t : ndarray
        Sample times [s]
    x : ndarray
        Position [m]
    window : float
        Filter window [s]
    polyorder : int
        Polynomial order [-]

    Returns
    -------
    v : ndarray
        Velocity [m/s]
    a : ndarray
        Acceleration [m/s^2]
    valid : ndarray of bool
        Samples far enough from a stretch's ends [-]
    """
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    v = np.zeros_like(x)
    a = np.zeros_like(x)
    valid = np.zeros(len(x), bool)
    dt = np.diff(t)
    h = float(np.median(dt))
    cuts = np.flatnonzero(dt > 2.5 * h) + 1
    for s in np.split(np.arange(len(t)), cuts):
        if len(s) < 3:
            continue
        ts = t[s]
        grid = np.arange(ts[0], ts[-1] + 0.5 * h, h)
        n_win = int(round(window / h)) | 1
        n_win = max(n_win, polyorder + 2 | 1)
        if len(grid) < n_win + 2:
            continue
        xg = np.interp(grid, ts, x[s])
        vg = savgol_filter(xg, n_win, polyorder, deriv=1, delta=h)
        ag = savgol_filter(xg, n_win, polyorder, deriv=2, delta=h)
        v[s] = np.interp(ts, grid, vg)
        a[s] = np.interp(ts, grid, ag)
        half = 0.5 * n_win * h
        valid[s] = (ts >= ts[0] + half) & (ts <= ts[-1] - half)
    return v, a, valid


@njit(cache=True)
def _stribeck_array(v, ratio, v_s):
    out = np.empty_like(v)
    for i in range(v.shape[0]):
        out[i] = stribeck_factor(v[i], ratio, v_s)
    return out


@dataclass
class _Samples:
    """The fitted samples of all records, stacked."""
    v: np.ndarray
    a: np.ndarray
    g_a: np.ndarray     # gauge pressures [Pa]
    g_b: np.ndarray
    y: np.ndarray       # F_p - F - m a: the friction when the extras are zero [N]
    F: np.ndarray
    F_p: np.ndarray
    record: np.ndarray  # index of the record of each sample
    ext: np.ndarray     # extending (v > 0)


def _pressure_force(model, p_a, p_b):
    """``p_a A_a - p_b A_b + p_atm (A_rod_a - A_rod_b)`` (Eq. 17, no load) [N]."""
    j = model.jack
    p_atm = model.ambient.pressure
    return p_a * j.area_a - p_b * j.area_b + p_atm * (j.rod_area_a - j.rod_area_b)


def _stack(model, records, window, v_min, mass_known):
    parts = []
    for k, rec in enumerate(records):
        v, a, valid = kinematics(rec.t, rec.x, window)
        parts.append((k, rec, v, a, valid))
    speeds = np.concatenate([np.abs(v[valid]) for _, _, v, _, valid in parts])
    if v_min is None:
        v_min = V_MIN_FRACTION * float(np.percentile(speeds, 95)) if speeds.size else 0.0
    cols = {key: [] for key in ("v", "a", "g_a", "g_b", "y", "F", "F_p", "record")}
    p_atm = model.ambient.pressure
    m = model.jack.moving_mass if mass_known else 0.0
    for k, rec, v, a, valid in parts:
        sel = valid & (np.abs(v) > v_min)
        F_p = _pressure_force(model, rec.p_a[sel], rec.p_b[sel])
        cols["v"].append(v[sel])
        cols["a"].append(a[sel])
        cols["g_a"].append(rec.p_a[sel] - p_atm)
        cols["g_b"].append(rec.p_b[sel] - p_atm)
        cols["F"].append(rec.F[sel])
        cols["F_p"].append(F_p)
        cols["y"].append(F_p - rec.F[sel] - m * a[sel])
        cols["record"].append(np.full(int(sel.sum()), k))
    s = _Samples(**{k: np.concatenate(c) for k, c in cols.items()}, ext=None)
    s.ext = s.v > 0
    return s, v_min


def _regressors(s, stribeck=None):
    """The columns of the linear problem by parameter name (friction at Stribeck ``(r, v_s)``)."""
    S = np.ones_like(s.v) if stribeck is None else _stribeck_array(s.v, *stribeck)
    cols = {}
    for side, mask, sign in (("extend", s.ext, 1.0), ("retract", ~s.ext, -1.0)):
        I = mask.astype(float)
        cols[f"friction.{side}.fc0"] = I * sign * S
        cols[f"friction.{side}.fc_a"] = I * sign * S * s.g_a
        cols[f"friction.{side}.fc_b"] = I * sign * S * s.g_b
        cols[f"friction.{side}.kv0"] = I * s.v
        cols[f"friction.{side}.kv_a"] = I * s.v * s.g_a
        cols[f"friction.{side}.kv_b"] = I * s.v * s.g_b
    cols["offset"] = -np.ones_like(s.v)
    cols["area_a"] = -s.g_a
    cols["area_b"] = s.g_b
    cols["mass"] = s.a
    return cols


def _not_varied(s, order, quadrant):
    """``{name: reason}`` of the pressure coefficients (and effective areas) of a chamber whose
    gauge pressure spans less than :data:`LEVEL_STEP` over the samples its regressor covers
    (those of its direction, or all): a coefficient of a pressure the records do not vary is
    not identifiable, however independent the pressure's noise makes its regressor look."""
    out = {}
    for name in order:
        chamber = "a" if name.endswith(("_a", ".fc_a", ".kv_a")) else \
            "b" if name.endswith(("_b", ".fc_b", ".kv_b")) else None
        if chamber is None:
            continue
        g = s.g_a if chamber == "a" else s.g_b
        if quadrant and name.startswith("friction."):
            g = g[s.ext] if ".extend." in name else g[~s.ext]
        if g.size == 0:
            continue
        lo, hi = np.quantile(g, [SPAN_QUANTILE, 1.0 - SPAN_QUANTILE])
        if hi - lo < LEVEL_STEP:
            out[name] = (f"not determined: chamber {chamber.upper()}'s gauge pressure spans "
                         f"{(hi - lo) / 1e5:.3g} bar on these records ({lo / 1e5:+.3g} to "
                         f"{hi / 1e5:+.3g} bar, {1 - 2 * SPAN_QUANTILE:.0%} of the samples), less "
                         f"than one level ({LEVEL_STEP / 1e5:g} bar): a coefficient of a pressure "
                         f"the records do not vary is not identifiable")
    return out


def _identifiable(cols, order):
    """Split ``order`` into the identified names and ``{name: reason}`` of the others."""
    kept, basis, dropped = [], [], {}
    for name in order:
        c = cols[name]
        norm = float(np.linalg.norm(c))
        if norm == 0.0:
            dropped[name] = "not determined: its regressor is zero on the records (that pressure is ambient, " \
                            "or that direction or acceleration absent)"
            continue
        r = c / norm
        for q in basis:
            r = r - (q @ r) * q
        sine = float(np.linalg.norm(r))
        if sine < IDENTIFIABLE:
            # name what it is confounded with: the kept regressors it projects on most
            c0 = c / norm
            weights = sorted(((abs(float(cols[k] @ c0) / (np.linalg.norm(cols[k]) or 1.0)), k)
                              for k in kept), reverse=True)[:2]
            dropped[name] = (f"not determined: not separable from {' and '.join(k for _, k in weights)} on these "
                             f"records ({sine:.1%} independent; a different pressure or speed "
                             f"would separate it)")
            continue
        kept.append(name)
        basis.append(r / sine)
    return kept, dropped


def _held_value(model, name):
    if name.startswith("friction."):
        _, side, key = name.split(".")
        return float(getattr(getattr(model.friction, side), key))
    if name == "mass":
        return float(model.jack.moving_mass)
    return 0.0


def _lower_bound(name):
    # the model holds fc0 and kv0 >= 0 (FrictionSet)
    return 0.0 if name.endswith((".fc0", ".kv0")) or name == "mass" else -np.inf


def _bounded_lstsq(X, y, lo, hi):
    """``argmin |X theta - y|`` within bounds, solved on the Cholesky factor of ``X^T X``
    (the same minimiser: ``|X theta - y|^2 = |L^T theta - L^-1 X^T y|^2 + const``)."""
    G = X.T @ X
    g = X.T @ y
    try:
        L = np.linalg.cholesky(G + 1e-13 * np.trace(G) * np.eye(len(g)) / max(len(g), 1))
    except np.linalg.LinAlgError:
        return lsq_linear(X, y, bounds=(lo, hi), method="bvls").x
    z = np.linalg.solve(L, g)
    return lsq_linear(L.T, z, bounds=(lo, hi), method="bvls").x


def _solve_linear(cols, names, y):
    """Bounded linear least squares on unit-norm columns; returns values and the design."""
    X = np.column_stack([cols[n] for n in names])
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    lb = np.array([_lower_bound(n) for n in names])
    return _bounded_lstsq(X / scale, y, lb, np.full(len(names), np.inf)) / scale, X


@dataclass
class FrictionBenchResult:
    """The friction law identified on a bench.

    Parameters
    ----------
    model : pneucore.description.model.Model
        The input model with the identified friction (and moving mass when identified)
    parameters : dict
        By name (``friction.extend.fc0``, ..., ``offset``, ``area_a``, ``mass``,
        ``effects.stribeck_friction.static_ratio``): ``value``, ``se``, ``unit``,
        ``identified`` (False: held at the model's value, ``reason`` says why), ``at_bound``
    correlations : dict
        ``names`` and ``matrix`` of the identified parameters [-]
    rms : float
        Rms force residual over the fitted samples [N]
    levels : list of dict
        Per pressure level and direction: ``p_a``, ``p_b`` [Pa abs], ``direction``,
        ``n``, measured and model mean friction [N], ``mean_residual`` [N] and its ``se``
    linear_in_pressure : bool or None
        False when some level departs from the law by more than ``LINEARITY_TOLERANCE``;
        None with fewer than three pressure levels (a line always fits two)
    warnings : list of str
        Plain statements of what did not hold [-]
    friction_map : list of dict
        Per record and direction, the measured friction binned in velocity against the
        model's (the paper's Fig. 4): ``velocity`` [m/s], ``measured``, ``model`` [N]
    v_min : float
        Speed below which samples were not fitted [m/s]
    tau : float
        Integrated autocorrelation time of the residuals, the standard errors' inflation is
        its square root [samples]
    window : float
        Window of the differentiating filter [s]
    extras : dict
        The extra parameters asked for (``offset``, ``area_a``, ``area_b``, ``mass``), as in
        ``parameters``
    stribeck : dict or None
        The breakaway term's trial: ``static_ratio`` [-], ``stribeck_velocity`` [m/s],
        ``se_ratio`` [-], ``rms_without``, ``rms_with`` [N], ``kept`` and ``shown_by_data``;
        None when not tried
    quadrant : bool
        One friction set per direction (False: one set for both) [-]
    """
    model: Model
    parameters: dict
    correlations: dict
    rms: float
    levels: list
    linear_in_pressure: object
    warnings: list
    friction_map: list
    v_min: float
    tau: float
    window: float = WINDOW
    extras: dict = field(default_factory=dict)
    stribeck: dict = None
    quadrant: bool = True

    def report(self):
        """Plain text: the parameters with standard errors, the levels, the warnings."""
        lines = [f"friction bench (Eq. 17-20): rms residual {self.rms:.3g} N over samples "
                 f"faster than {self.v_min * 1e3:.3g} mm/s"]
        for name, p in self.parameters.items():
            if p["identified"]:
                se = "" if p["se"] is None else f" +- {p['se']:.3g}"
                lines.append(f"  {name} = {p['value']:.5g}{se} {p['unit']}"
                             + (" (at its bound)" if p.get("at_bound") else ""))
            else:
                lines.append(f"  {name} = {p['value']:.5g} {p['unit']} {p['reason']}")
        for w in self.warnings:
            lines.append(f"  WARNING: {w}")
        return "\n".join(lines)

    def to_dict(self):
        return {"model": self.model.to_dict(), "parameters": self.parameters,
                "correlations": self.correlations, "rms": self.rms, "levels": self.levels,
                "linear_in_pressure": self.linear_in_pressure, "warnings": self.warnings,
                "friction_map": self.friction_map, "v_min": self.v_min, "tau": self.tau,
                "stribeck": self.stribeck, "quadrant": self.quadrant, "report": self.report()}


def identify_friction(model, records, *, extras=(), stribeck="auto", quadrant=True, v_min=None,
                      window=WINDOW, progress=None):
    """Fit the model's friction law (Eq. 18-20) to friction-bench records by Eq. 17.

    Parameters
    ----------
    model : pneucore.description.model.Model
        The jack (areas, rods, moving mass) and ambient pressure; its friction gives the
        values of the parameters the records cannot identify
    records : list of FrictionRecord or dict
        Prescribed-motion records: ``t`` [s], ``x`` [m, extension positive], ``p_a``,
        ``p_b`` [Pa abs], ``F`` [N, rod force on its load, positive outward]
    extras : iterable of str
        Also identify: ``offset`` (load cell) [N], ``area_a``, ``area_b`` (effective area
        minus the model's) [m^2], ``mass`` (moving mass) [kg]
    stribeck : str or bool
        ``"auto"``: fit the breakaway term and keep it only where the data show it; True:
        keep it; False: Coulomb and viscous only (the paper's Fig. 4 found none)
    quadrant : bool
        One friction set per direction (the quadrant effect, the model's form); False: one
        set for both, which lets a load-cell offset be told apart from the Coulomb levels
    v_min : float or None
        Samples slower than this are reversals and are not fitted; None =
        ``V_MIN_FRACTION`` of the records' 95th-percentile speed [m/s]
    window : float
        Window of the differentiating filter [s]
    progress : callable or None
        ``progress(fraction, step)``

    Returns
    -------
    FrictionBenchResult

    Raises
    ------
    pneucore.description.validation.FieldError
        A record without ``F`` or with bad samples (naming it), an unknown extra, or too few
        sliding samples in a direction to identify its friction set (naming it)
    """
    progress = progress or (lambda f, s: None)
    recs = [r if isinstance(r, FrictionRecord) else FrictionRecord.from_dict(r, f"experiments[{i}]")
            for i, r in enumerate(records)]
    if not recs:
        raise FieldError("experiments", "at least one record is required")
    extras = list(extras)
    for e in extras:
        if e not in EXTRAS:
            raise FieldError("extras", f"unknown extra {e!r} (known: {', '.join(EXTRAS)})")
    mass_known = "mass" not in extras
    progress(0.05, "velocity and acceleration")
    s, v_min = _stack(model, recs, window, v_min, mass_known)
    for side, mask in (("extend", s.ext), ("retract", ~s.ext)):
        n = int(mask.sum())
        if n < MIN_SLIDING_SAMPLES:
            word = "extending (v > 0)" if side == "extend" else "retracting (v < 0)"
            raise FieldError("experiments", f"too few points to identify friction.{side} (fc0, kv0, "
                                            f"...): {n} samples {word} faster than "
                                            f"{v_min * 1e3:.3g} mm/s, at least "
                                            f"{MIN_SLIDING_SAMPLES} are needed")

    order = [f"friction.{side}.{key}" for side, key in _PRIORITY
             if quadrant or side == "extend"] + extras
    cols = _regressors(s)
    if not quadrant:   # one set for both directions: the extend columns carry both
        for key in _KEYS:
            cols[f"friction.extend.{key}"] = cols[f"friction.extend.{key}"] + cols.pop(f"friction.retract.{key}")
    flat = _not_varied(s, order, quadrant)
    names, dropped = _identifiable(cols, [n for n in order if n not in flat])
    dropped.update(flat)
    held = {n: _held_value(model, n) for n in order if n not in names}
    prior = model.to_dict().get("provenance") or {}
    y = s.y - sum((held[n] * cols[n] for n in held), np.zeros_like(s.y))
    progress(0.3, "linear fit (Coulomb + viscous)")
    theta, X = _solve_linear(cols, names, y)
    res = y - X @ theta
    rms0 = float(np.sqrt(np.mean(res ** 2)))
    strib = None
    stribeck_test = None

    if stribeck:
        progress(0.5, "Stribeck term")
        fit = _fit_stribeck(s, cols, names, held, theta, v_min)
        if fit is not None:
            th_s, (ratio, v_s), res_s, cov_s, at_bound = fit
            rms_s = float(np.sqrt(np.mean(res_s ** 2)))
            tau_s = integrated_time(res_s)
            se_r = math.sqrt(max(cov_s[-2, -2], 0.0) * tau_s)
            # shown by the data: a ratio clear of 1 by three standard errors, a better fit, and
            # (ratio, v_s) inside their bounds (a value on a bound is the fit running away)
            shows = ratio - 1.0 > max(STRIBECK_MIN_EXCESS, 3.0 * se_r) and \
                rms_s < (1 - STRIBECK_GAIN) * rms0 and not at_bound and v_s > v_min
            stribeck_test = {"static_ratio": ratio, "stribeck_velocity": v_s, "se_ratio": se_r,
                             "rms_without": rms0, "rms_with": rms_s, "kept": bool(stribeck is True or shows),
                             "shown_by_data": bool(shows)}
            if stribeck is True or shows:
                theta, res, strib = th_s, res_s, (ratio, v_s, cov_s)
    progress(0.8, "standard errors and pressure levels")
    rms = float(np.sqrt(np.mean(res ** 2)))
    tau = integrated_time(res)
    if strib is None:
        dof = max(len(y) - len(names), 1)
        s2 = float(res @ res) / dof
        scale = np.linalg.norm(X, axis=0)
        scale[scale == 0] = 1.0
        Xs = X / scale
        cov = s2 * np.linalg.pinv(Xs.T @ Xs) / np.outer(scale, scale) * tau
        all_names = list(names)
    else:
        cov = strib[2] * tau
        all_names = list(names) + ["effects.stribeck_friction.static_ratio",
                                   "effects.stribeck_friction.stribeck_velocity"]
        theta = np.concatenate([theta, [strib[0], strib[1]]])
    if not (np.all(np.isfinite(theta)) and np.all(np.isfinite(cov)) and math.isfinite(rms)):
        raise FieldError("experiments", "the fit gave no finite result on these records (check "
                                        "their units: t [s], x [m], p_a, p_b [Pa abs], F [N])")
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    d = np.where(se > 0, se, 1.0)
    corr = cov / np.outer(d, d)

    params = {}
    values = {}
    for i, n in enumerate(all_names):
        values[n] = float(theta[i])
        params[n] = {"value": float(theta[i]), "se": float(se[i]), "unit": _unit(n), "identified": True,
                     "status": "identified",
                     "at_bound": bool(_lower_bound(n) == 0.0 and theta[i] <= 1e-12)}
    for n, v in held.items():
        values[n] = v
        # held at the model's value: where that came from (its provenance, else the model as
        # given: a catalogue value or the default prior)
        src = (prior.get("jack.moving_mass" if n == "mass" else n) or {}).get("source") or "prior"
        params[n] = {"value": v, "se": None, "unit": _unit(n), "identified": False,
                     "status": "not determined", "held_from": src,
                     "reason": f"{dropped[n]}; held at the model's value ({src})"}
    if not quadrant:
        for key in _KEYS:
            values[f"friction.retract.{key}"] = values[f"friction.extend.{key}"]
    names_used = ', '.join(r.name or str(i) for i, r in enumerate(recs))
    out = _write_model(model, values, strib, "friction identified on a friction bench (Eq. 17-20) "
                       f"from {names_used}", _bench_provenance(params, quadrant), names_used)
    levels, linear, warns = _levels(s, res, s.y - res, tau)
    warns += _sign_warnings(s, values)
    for n, why in dropped.items():
        if n in ("offset", "area_a", "area_b", "mass"):
            warns.append(f"{n} was asked for but is not identified: {why}")
    fmap = _friction_map(s, s.y, res)
    ext = {n: params[n] for n in EXTRAS if n in params}
    progress(1.0, "done")
    return FrictionBenchResult(out, params, {"names": all_names, "matrix": corr.tolist()}, rms, levels,
                               linear, warns, fmap, float(v_min), float(tau), window, ext,
                               stribeck_test, bool(quadrant))


def _sign_warnings(s, values):
    """Statements where the fitted Coulomb level or viscous coefficient is negative at the
    records' pressures: the model clips them at zero (Eq. 19-20 as the core computes them),
    so the fitted law and the simulated one part. A wrong area or force sign does this."""
    out = []
    for side in ("extend", "retract"):
        v = {k: values[f"friction.{side}.{k}"] for k in _KEYS}
        fc = v["fc0"] + v["fc_a"] * s.g_a + v["fc_b"] * s.g_b
        kv = v["kv0"] + v["kv_a"] * s.g_a + v["kv_b"] * s.g_b
        for what, arr, unit in (("Coulomb level", fc, "N"), ("viscous coefficient", kv, "N s/m")):
            # 5 % of its largest value: a coefficient at its bound of zero with a little noise
            # in its pressure slope is no contradiction
            if arr.size and arr.min() < -0.05 * max(abs(arr).max(), 1e-12):
                out.append(f"the fitted {side} {what} is negative at some of the records' pressures "
                           f"(down to {arr.min():.3g} {unit}); the model clips it at zero, so its "
                           f"friction differs from the fit there: check the jack's areas (bore, rods) "
                           f"and the sign of F (positive outward)")
    return out


def _unit(name):
    if name in EXTRAS:
        return EXTRAS[name]
    if name.endswith("static_ratio"):
        return "-"
    if name.endswith("stribeck_velocity"):
        return "m/s"
    return _UNITS[name.split(".")[-1]]


def _fit_stribeck(s, base, names, held, theta0, v_min):
    """Nonlinear least squares on (theta, ratio, v_s) from the linear solution.

    The force is linear in theta given the breakaway factor ``S(v; ratio, v_s)``
    (:func:`pneucore.physics.friction.stribeck_factor`, the Coulomb columns times S): the
    Jacobian is exact in theta and a forward difference of S in (ratio, v_s). Returns None
    when no start converges.
    """
    spec = {p.name: p for p in EFFECTS["stribeck_friction"].parameters}
    r_lo, r_hi = spec["static_ratio"].min, spec["static_ratio"].max
    vs_lo, vs_hi = spec["stribeck_velocity"].min, spec["stribeck_velocity"].max
    coulomb = [n for n in names if ".fc" in n]
    other = [n for n in names if ".fc" not in n]
    order = coulomb + other
    B = np.column_stack([base[n] for n in order])
    scale = np.linalg.norm(B, axis=0)
    scale[scale == 0] = 1.0
    Bs = B / scale
    nc = len(coulomb)
    held_c = sum((held[n] * base[n] for n in held if ".fc" in n), np.zeros_like(s.y))
    held_o = sum((held[n] * base[n] for n in held if ".fc" not in n), np.zeros_like(s.y))
    y = s.y - held_o
    lo = np.array([_lower_bound(n) for n in order] + [r_lo, vs_lo])
    hi = np.array([np.inf] * len(order) + [r_hi, vs_hi])
    lo[:-2] *= scale
    th0 = np.array([theta0[names.index(n)] for n in order]) * scale

    def parts(p):
        S = _stribeck_array(s.v, p[-2], p[-1])
        coul = Bs[:, :nc] @ p[:nc] + held_c
        return S, coul

    def resid(p):
        S, coul = parts(p)
        return S * coul + Bs[:, nc:] @ p[nc:-2] - y

    def jac(p):
        S, coul = parts(p)
        J = np.empty((len(y), len(p)))
        J[:, :nc] = Bs[:, :nc] * S[:, None]
        J[:, nc:-2] = Bs[:, nc:]
        for k, step in ((-2, 1e-6 * max(p[-2], 1.0)), (-1, 1e-6 * p[-1])):
            q = p.copy()
            q[k] += step
            J[:, k] = (_stribeck_array(s.v, q[-2], q[-1]) - S) * coul / step
        return J

    lo_t, hi_t = lo[:-2], hi[:-2]

    def inner(q):
        # the linear parameters for given (ratio, v_s): variable projection (Golub & Pereyra 1973)
        S = _stribeck_array(s.v, q[0], q[1])
        X = np.column_stack([Bs[:, :nc] * S[:, None], Bs[:, nc:]])
        yy = y - S * held_c
        th = _bounded_lstsq(X, yy, lo_t, hi_t)
        return th, yy - X @ th

    best = None
    for vs0 in (v_min, 0.3 * float(np.percentile(np.abs(s.v), 95))):
        vs0 = min(max(vs0, vs_lo * 1.01), vs_hi * 0.99)
        sol = least_squares(lambda q: inner(q)[1], [1.5, vs0], bounds=([r_lo, vs_lo], [r_hi, vs_hi]),
                            x_scale=[0.3, vs0], diff_step=1e-4, max_nfev=60)
        if best is None or sol.cost < best.cost:
            best = sol
    if best is None:
        return None
    th, _ = inner(best.x)
    p = np.concatenate([th, best.x])
    res = -resid(p)
    J = jac(p)
    J[:, :-2] /= scale[None, :]          # per unit parameter
    dof = max(len(y) - len(p), 1)
    cov = float(res @ res) / dof * np.linalg.pinv(J.T @ J)
    theta = np.empty(len(names))
    for i, n in enumerate(order):
        theta[names.index(n)] = p[i] / scale[i]
    perm = [order.index(n) for n in names] + [len(order), len(order) + 1]
    cov = cov[np.ix_(perm, perm)]
    at_bound = not (r_lo < p[-2] < 0.99 * r_hi) or not (1.01 * vs_lo < p[-1] < 0.99 * vs_hi)
    return theta, (float(p[-2]), float(p[-1])), res, cov, at_bound


def _bench_provenance(params, quadrant):
    """``{model path: (stderr, unit)}`` of the identified parameters that are model values (the
    load-cell offset and the effective areas are the bench's, not the model's); without the
    quadrant effect the retraction set is the extension's, with its standard errors."""
    out = {}
    for n, p in params.items():
        if not p.get("identified") or (n == "mass" and not p["value"] > 0.0):
            continue   # a moving mass at or below 0 is not written into the model
        path = "jack.moving_mass" if n == "mass" else n
        if path.startswith(("friction.", "effects.", "jack.")):
            out[path] = (p.get("se"), p.get("unit"))
        if not quadrant and n.startswith("friction.extend."):
            out[n.replace(".extend.", ".retract.")] = (p.get("se"), p.get("unit"))
    return out


def _write_model(model, values, strib, note="", provenance=None, records=""):
    """The input model with the identified friction sets (and mass, Stribeck) written in, and
    where they came from appended to its notes and recorded in its ``provenance`` (source
    ``bench``, :mod:`pneucore.description.provenance`)."""
    d = model.to_dict()
    if note:
        d["notes"] = (d.get("notes") or "") + ("\n" if d.get("notes") else "") + note
    if provenance:
        d["provenance"] = record(d.get("provenance"), provenance, "bench",
                                 "friction bench (Eq. 17-20)", f"records: {records}"[:TEXT_MAX])
    for side in ("extend", "retract"):
        for key in _KEYS:
            d["friction"][side][key] = float(values[f"friction.{side}.{key}"])
    effects = {k: v for k, v in d.get("effects", {}).items()
               if k not in _FRICTION_EFFECTS and k != "stribeck_friction"}
    if strib is not None:
        effects["stribeck_friction"] = {"static_ratio": float(strib[0]),
                                        "stribeck_velocity": float(strib[1])}
    d["effects"] = effects
    if "mass" in values and values.get("mass", 0.0) > 0.0:
        d["jack"]["moving_mass"] = float(values["mass"])
    return Model.from_dict(d)


def _levels(s, res, fitted, tau):
    """Mean residual per pressure level and direction, and the linearity verdict.

    A level is a record's median gauge pressures, records within 0.2 bar of one another
    together. The residual is measured against the friction scale of the level, the mean of
    the two directions' measured magnitudes (the extension friction of a seal can be near
    zero when the offset-like part of the force is in it; the scale is the seal's).
    """
    rec_ids = np.unique(s.record)
    med = {k: (np.median(s.g_a[s.record == k]), np.median(s.g_b[s.record == k])) for k in rec_ids}
    keys = {k: (round(med[k][0] / LEVEL_STEP), round(med[k][1] / LEVEL_STEP)) for k in rec_ids}
    key = np.array([keys[k] for k in s.record.tolist()]) if len(s.record) else np.zeros((0, 2))
    levels, warns, bad = [], [], []
    distinct = sorted(set(keys.values()))
    for kk in distinct:
        at = np.all(key == np.array(kk), axis=1)
        rows = []
        for side, mask in (("extend", s.ext), ("retract", ~s.ext)):
            sel = at & mask
            n = int(sel.sum())
            if n < MIN_SLIDING_SAMPLES:
                continue
            mr = float(np.mean(res[sel]))
            rows.append({"p_a": float(np.median(s.g_a[at])), "p_b": float(np.median(s.g_b[at])),
                         "direction": side, "n": n, "friction_model": float(np.mean(fitted[sel])),
                         "friction_measured": float(np.mean(fitted[sel] + res[sel])),
                         "mean_residual": mr, "se": float(np.std(res[sel]) * math.sqrt(tau / n))})
        scale = float(np.mean([abs(r["friction_measured"]) for r in rows])) if rows else 0.0
        for r in rows:
            r["relative"] = r["mean_residual"] / scale if scale > 0 else None
            if scale > 0 and abs(r["mean_residual"]) > LINEARITY_TOLERANCE * scale \
                    and abs(r["mean_residual"]) > 3 * r["se"]:
                bad.append(r)
        levels += rows
    linear = None if len(distinct) < 3 else not bad
    for r in bad:
        warns.append(f"friction not linear in pressure (Eq. 19-20 do not hold): {r['direction']} "
                     f"at {r['p_a'] / 1e5:.2f} bar gauge in A and {r['p_b'] / 1e5:.2f} in B the "
                     f"measured friction is {r['friction_measured']:.3g} N, the fitted law gives "
                     f"{r['friction_model']:.3g} N ({r['relative']:+.0%} of the friction there)")
    if linear is None:
        warns.append(f"{len(distinct)} pressure level(s): a line in pressure always fits them, "
                     f"its linearity cannot be tested (three levels or more can)")
    return levels, linear, warns


def _friction_map(s, y, res, bins=12):
    """Measured friction binned in velocity against the fitted law, per record and direction."""
    out = []
    fitted = y - res
    for k in np.unique(s.record):
        for side, mask in (("extend", s.ext), ("retract", ~s.ext)):
            sel = (s.record == k) & mask
            if sel.sum() < bins:
                continue
            v = s.v[sel]
            edges = np.quantile(v, np.linspace(0, 1, bins + 1))
            idx = np.clip(np.searchsorted(edges, v, side="right") - 1, 0, bins - 1)
            row = {"record": int(k), "direction": side,
                   "p_a": float(np.median(s.g_a[sel])), "p_b": float(np.median(s.g_b[sel])),
                   "velocity": [], "measured": [], "model": []}
            for b in range(bins):
                m = idx == b
                if m.any():
                    row["velocity"].append(float(v[m].mean()))
                    row["measured"].append(float(y[sel][m].mean()))
                    row["model"].append(float(fitted[sel][m].mean()))
            out.append(row)
    return out


def predict_rod_force(model, record, *, offset=0.0, area_a=0.0, area_b=0.0, window=WINDOW, v_min=0.0):
    """The rod force a model predicts on a bench record (Eq. 17 with its friction law).

    ``F = p_a (A_a + dA_a) - p_b (A_b + dA_b) + ... - F_f(v, p) - m a + offset``, the friction
    from the model's own law (effects applied: :func:`pneucore.simulate.build_core`) at the
    filtered velocity; zero friction where the velocity is zero.

    Parameters
    ----------
    model : pneucore.description.model.Model
        The model
    record : FrictionRecord
        The record (its ``F`` is not used)
    offset : float
        Load-cell offset [N]
    area_a, area_b : float
        Effective minus model area [m^2]
    window : float
        Differentiating filter window [s]
    v_min : float
        Samples slower than this are left out of the errors [m/s]

    Returns
    -------
    dict
        ``force`` [N] at every sample, and the errors (predicted - measured) over the samples
        faster than ``v_min``: ``rms``, ``mean`` [N], ``extend`` and ``retract`` each with
        ``rms``, ``mean`` [N] and ``n`` [-]; the same errors grouped under ``errors``
    """
    from pneucore.core import layout as L
    from pneucore.simulate import build_core
    from pneucore.description.scenario import Scenario

    prm = build_core(model, Scenario())["model"][0]
    law = FRICTION_LAWS[model.friction.law]
    p_atm = float(prm[L.P_ATM])
    ratio, v_s = float(prm[L.P_STRIBECK_RATIO]), float(prm[L.P_STRIBECK_V])
    sets = {1.0: ((prm[L.P_FE_FC0], prm[L.P_FE_FCA], prm[L.P_FE_FCB]),
                  (prm[L.P_FE_KV0], prm[L.P_FE_KVA], prm[L.P_FE_KVB])),
            -1.0: ((prm[L.P_FR_FC0], prm[L.P_FR_FCA], prm[L.P_FR_FCB]),
                   (prm[L.P_FR_KV0], prm[L.P_FR_KVA], prm[L.P_FR_KVB]))}
    v, a, valid = kinematics(record.t, record.x, window)
    Ff = np.zeros_like(v)
    for i in range(len(v)):
        if v[i] == 0.0:
            continue
        direction = 1.0 if v[i] > 0 else -1.0
        fc_set, kv_set = sets[direction]
        pa, pb = float(record.p_a[i]), float(record.p_b[i])
        fc = coulomb_level(*fc_set, pa, pb, p_atm)
        kv = viscous_coefficient(*kv_set, pa, pb, p_atm)
        Ff[i] = law.force(float(v[i]), direction, fc, kv, ratio, v_s)
    j = model.jack
    F_p = _pressure_force(model, record.p_a, record.p_b) + area_a * (record.p_a - p_atm) \
        - area_b * (record.p_b - p_atm)
    force = F_p - Ff - j.moving_mass * a + offset
    err = force - record.F
    sel = valid & (np.abs(v) > v_min)

    def stats(mask):
        n = int(mask.sum())
        if n == 0:
            return {"rms": None, "mean": None, "n": 0}
        e = err[mask]
        return {"rms": float(np.sqrt(np.mean(e ** 2))), "mean": float(np.mean(e)), "n": n}

    total = stats(sel)
    ext, ret = stats(sel & (v > 0)), stats(sel & (v < 0))
    return {"name": record.name, "t": record.t.tolist(), "force": force.tolist(),
            "measured": record.F.tolist(), "rms": total["rms"], "mean": total["mean"], "n": total["n"],
            "extend": ext, "retract": ret, "v_min": float(v_min),
            "errors": {"rms": total["rms"], "mean": total["mean"], "n": total["n"], "extend": ext,
                       "retract": ret}}
