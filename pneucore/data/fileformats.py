"""The files test rigs write: CSV (any dialect), NI TDMS, MATLAB ``.mat`` and NumPy ``.npz``.

:func:`read_measurement` takes a file's bytes, recognises its format from its
first bytes (TDMS: ``TDSm``; MATLAB 5/7: the ``MATLAB 5.0 MAT-file`` text
header; ``.npz``: a ZIP archive, ``PK``; else CSV) and reads it into a :class:`~pneucore.data.measurement.Measurement`
through the same column resolution as CSV: signal names or their aliases
(``Zeit``, ``p_A``), units (``bar(g)``, ``mm``, ``ms``...), the caller's
column mapping and the rig's ambient pressure for gauge units. Every reader
fills the same import report (``measurement.meta["import"]``).

- **TDMS** (National Instruments, npTDMS): every channel of every group is a
  column, named by the channel (``group/channel`` when two groups share a
  channel name), with its unit from the standard ``unit_string`` property.
  Without a time channel, the time comes from the waveform properties
  (``wf_start_offset``, ``wf_increment``) of the first channel.
- **MATLAB** ``.mat`` v4-v7 (scipy.io.loadmat, :mod:`pneucore.data.matfile`): every
  top-level numeric vector is a column, and so is every numeric vector field of a
  top-level struct; a struct or cell variable named ``units`` may give units by column
  name (``units.p_A = 'bar(g)'``). v7.3 files are HDF5: save with ``-v7``. Read in a
  child process by default: a malformed file can crash scipy's compiled reader.
- **NumPy** ``.npz`` (``numpy.savez``, and the ``.npz`` answers of pneucore itself): every
  numeric vector member is a column named by the member (``numpy.savez(f, **{"p_A[bar(g)]":
  pa, "Zeit[ms]": t})``); a ``meta.json`` member whose ``units`` maps names to units gives
  them (the simulation archives of :mod:`pneucore.data.npz` read back like the CSV export:
  the simulated-only series are listed as ignored). Nothing is unpickled: an object array
  is skipped. The archive's directory is checked before anything is read: at most
  :data:`NPZ_MAX_MEMBERS` members, none larger than a vector of ``MAX_SAMPLES`` doubles
  allows, and so no compressed member can inflate past it.

:func:`inspect_file` previews a file for the page's mapping step: columns,
units, dialect and a proposed mapping (:func:`pneucore.data.measurement.propose_mapping`).
"""
from __future__ import annotations

import io
from typing import Any, Mapping

import numpy as np

from pneucore.data.matfile import mat_columns, mat_columns_isolated
from pneucore.data.measurement import (DEFAULT_AMBIENT_PRESSURE, MAX_COLUMNS, MAX_SAMPLES, SIGNALS,
                                      MeasurementError, Measurement, check_mapping, decode_text,
                                      measurement_from_columns, propose_mapping, read_table,
                                      resolve_column, split_label)

__all__ = ["read_measurement", "inspect_file", "detect_format", "FORMATS", "DECODE_BUDGET"]

#: Formats recognised by :func:`detect_format`, with their usual file extensions
FORMATS: dict[str, tuple[str, ...]] = {"csv": (".csv", ".txt", ".tsv", ".dat"),
                                       "tdms": (".tdms",), "mat": (".mat",), "npz": (".npz",)}
#: Most members of an ``.npz`` read [-]: one a column, and ``meta.json``
NPZ_MAX_MEMBERS = MAX_COLUMNS + 1
#: Largest ``meta.json`` member read [bytes]: units and statistics of a simulation take a few kB
NPZ_MAX_META_BYTES = 1 << 20
#: Largest ``.npy`` header read [bytes]: numpy's own default (a header holds a dtype and a shape)
NPY_MAX_HEADER = 10_000
#: Memory the decoded columns of one file may take by default [bytes]: the time and every signal
#: at MAX_SAMPLES samples, as stored (at most 8 bytes a value) and as float64 (8 more), what the
#: largest measurement needs (416 MB with the twelve signals of SIGNALS); the service passes its
#: own ``max_request_memory``
DECODE_BUDGET = (1 + len(SIGNALS)) * MAX_SAMPLES * 16
#: Largest ``.npz`` member read [bytes]: a vector of MAX_SAMPLES doubles and its header; a
#: larger one (text, a matrix) is skipped unread
NPZ_MAX_MEMBER_BYTES = 8 * MAX_SAMPLES + 4096


def detect_format(data: bytes, filename: str | None = None) -> str:
    """The format of a rig file from its first bytes (the extension breaks no tie).

    Parameters
    ----------
    data : bytes
        The file's content [-]
    filename : str or None, optional
        Its name; ``.mat`` marks a MATLAB v4 file, which has no signature [-]

    Returns
    -------
    format : str
        ``"tdms"``, ``"mat"``, ``"npz"`` or ``"csv"`` [-]
    """
    if data[:4] == b"TDSm":
        return "tdms"
    if data[:4] in (b"PK\x03\x04", b"PK\x05\x06"):   # a ZIP archive (an empty one: its end record)
        return "npz"
    if data[:10] == b"MATLAB 5.0" or data[:10] == b"MATLAB 7.3":
        return "mat"
    if filename and filename.lower().endswith(".mat"):
        return "mat"
    return "csv"


def _is_time(label) -> bool:
    """Whether a column's label (a unit in brackets or not: ``t [ms]``) names the time."""
    name = split_label(str(label))[0]
    return propose_mapping([str(label)]).get(name) == "t"


# ----------------------------------------------------------------------------- TDMS
def _tdms_columns(data: bytes):
    try:
        from nptdms import TdmsFile
    except ImportError:  # pragma: no cover - a declared dependency
        raise MeasurementError("reading TDMS files needs the npTDMS package") from None
    try:
        f = TdmsFile.read(io.BytesIO(data))
        channels = [ch for g in f.groups() for ch in g.channels()]
        arrays = [(ch, np.asarray(ch[:])) for ch in channels]
    except MeasurementError:
        raise
    except Exception as exc:  # a corrupt file: npTDMS raises many kinds
        raise MeasurementError(f"not a readable TDMS file ({type(exc).__name__}: {exc})") from None
    arrays = [(ch, a) for ch, a in arrays if a.ndim == 1 and a.size
              and np.issubdtype(a.dtype, np.number)]
    if not arrays:
        raise MeasurementError("the TDMS file holds no numeric channel")
    names = [ch.name for ch, _ in arrays]
    labels = [ch.name if names.count(ch.name) == 1 else f"{ch.group_name}/{ch.name}"
              for ch, _ in arrays]
    units = [str(ch.properties.get("unit_string", "") or "") for ch, _ in arrays]
    cols = [(lab, a) for lab, (_, a) in zip(labels, arrays)]
    extra = {}
    if not any(_is_time(lab) for lab in labels):
        for lab, (ch, a) in zip(labels, arrays):
            if "wf_increment" not in ch.properties:
                continue
            try:
                t = np.asarray(ch.time_track(), dtype=np.float64)
            except Exception:   # e.g. an absolute-time waveform: no relative time base
                continue
            cols.insert(0, ("t", t))
            units.insert(0, "s")
            extra["time"] = (f"from the waveform properties of channel {lab!r} "
                             f"(wf_increment = {float(ch.properties['wf_increment']):g} s)")
            break
    return cols, units, extra


# ----------------------------------------------------------------------------- NumPy .npz
def _npy_head(zf, info):
    """``(dtype, shape, fortran_order, header_bytes)`` of an ``.npy`` member, from its header
    alone (a few hundred bytes decompressed); None when it is no plain numeric array (an
    object array would need unpickling, a structured one is no column)."""
    fmt = np.lib.format
    with zf.open(info) as fh:
        version = fmt.read_magic(fh)
        if version == (1, 0):
            shape, fortran, dtype = fmt.read_array_header_1_0(fh, max_header_size=NPY_MAX_HEADER)
        elif version == (2, 0):
            shape, fortran, dtype = fmt.read_array_header_2_0(fh, max_header_size=NPY_MAX_HEADER)
        else:
            return None
        offset = fh.tell()
    if dtype.kind not in "iuf" or dtype.fields is not None or dtype.hasobject:
        return None
    return dtype, shape, fortran, offset


def _npy_values(zf, info, dtype, count, offset):
    """The first ``count`` values of an ``.npy`` member whose header ends at ``offset``, as
    float64; the member's declared size bounds what is decompressed."""
    with zf.open(info) as fh:
        fh.read(offset)
        raw = fh.read(count * dtype.itemsize)
    if len(raw) != count * dtype.itemsize:
        raise ValueError(f"{len(raw)} bytes of data where the header declares "
                         f"{count * dtype.itemsize}")
    return np.frombuffer(raw, dtype=dtype).astype(np.float64)


def _npz_columns(data: bytes, mapping=None, ambient_pressure=DEFAULT_AMBIENT_PRESSURE,
                 memory_budget=None, preview_rows=None):
    """Columns of an ``.npz`` archive, the directory and every member's header checked before
    any array is read: the declared sizes (each at most :data:`NPZ_MAX_MEMBER_BYTES`), the dtype
    and shape, and, unless ``preview_rows`` is given, the column's name (an unknown name is
    refused, a column mapped to null or a simulated-only series is not read), and the decoded
    size of the columns to read summed against ``memory_budget`` [bytes]. A preview reads the
    first ``preview_rows`` values of each member only."""
    import json
    import zipfile
    try:
        zf = zipfile.ZipFile(io.BytesIO(data))
        infos = zf.infolist()
    except Exception as exc:  # noqa: BLE001 - zipfile raises many kinds on a damaged directory
        raise MeasurementError(f"not a readable .npz (ZIP) archive ({type(exc).__name__}: {exc})") from None
    if len(infos) > NPZ_MAX_MEMBERS:
        raise MeasurementError(f"the archive has {len(infos)} members; at most {NPZ_MAX_MEMBERS} "
                               f"are read")
    npy = [i for i in infos if i.filename.endswith(".npy") and not i.is_dir()]
    if not npy:
        raise MeasurementError("a ZIP archive without .npy members is not a NumPy .npz file (an "
                               "Excel workbook? save it as CSV)")
    meta, extra = {}, {}
    info = next((i for i in infos if i.filename == "meta.json"), None)
    if info is not None and info.file_size <= NPZ_MAX_META_BYTES:
        try:
            meta = json.loads(zf.read(info))
        except Exception:  # noqa: BLE001 - a damaged or foreign meta.json gives no units
            meta = {}
    units_of = meta.get("units") if isinstance(meta, dict) else None
    units_of = units_of if isinstance(units_of, dict) else {}
    if isinstance(meta, dict) and {"units", "stats"} <= set(meta):
        extra["pneucore_export"] = True   # a simulated archive: simulated-only series ignored
    mapping = check_mapping(mapping)
    budget = DECODE_BUDGET if memory_budget is None else int(memory_budget)
    planned, skipped, signals, decoded = [], [], {}, 0
    for i in npy:
        label = i.filename[:-4]
        if i.file_size > NPZ_MAX_MEMBER_BYTES:
            skipped.append(label)
            continue
        try:
            head = _npy_head(zf, i)
        except ValueError:   # a malformed header
            head = None
        except Exception as exc:  # noqa: BLE001 - a bad CRC, an unknown compression, a short member
            raise MeasurementError(f"member {i.filename!r} of the archive is damaged "
                                   f"({type(exc).__name__}: {exc})", column=label) from None
        if head is None:
            skipped.append(label)
            continue
        dtype, shape, _, offset = head
        count = int(np.prod(shape, dtype=np.int64)) if shape else 1
        if not (len(shape) == 1 or (len(shape) == 2 and min(shape) == 1)) or count < 1:
            skipped.append(label)
            continue
        if offset + count * dtype.itemsize > i.file_size:
            raise MeasurementError(f"member {i.filename!r} of the archive is damaged (its header "
                                   f"declares {count} values, more than its {i.file_size} bytes "
                                   f"hold)", column=label)
        unit = units_of.get(label, "")
        unit = unit if isinstance(unit, str) else ""
        if preview_rows is None:
            # the name first: an unknown one is refused, an ignored one never read
            conv = resolve_column(label, unit or None, mapping, ambient_pressure,
                                  export=bool(extra.get("pneucore_export")))
            if conv is None:
                planned.append((label, unit, None, None))
                continue
            if conv.signal in signals:
                raise MeasurementError(f"duplicate column: {signals[conv.signal]!r} and {label!r} "
                                       f"both give signal {conv.signal!r}", column=label)
            signals[conv.signal] = label
            # as stored, then as float64
            decoded += count * (dtype.itemsize + 8)
        else:
            count = min(count, preview_rows)
        planned.append((label, unit, (dtype, count, offset), i))
    if decoded > budget:
        raise MeasurementError(f"the archive's columns would take {decoded} bytes once decoded, "
                               f"more than the memory budget of {budget} bytes per request "
                               f"(max_request_memory); nothing was read")
    cols: list[tuple[str, Any]] = []
    units = []
    for label, unit, how, i in planned:
        if how is None:
            cols.append((label, None))   # ignored by name: listed, never read
        else:
            try:
                cols.append((label, _npy_values(zf, i, *how)))
            except Exception as exc:  # noqa: BLE001 - a bad CRC, an unknown compression, a short member
                raise MeasurementError(f"member {i.filename!r} of the archive is damaged "
                                       f"({type(exc).__name__}: {exc})", column=label) from None
        units.append(unit)
    if not any(v is not None for _, v in cols):
        raise MeasurementError("the .npz archive holds no numeric vector")
    if skipped:
        extra["skipped_members"] = skipped
    return cols, units, extra


def _table(data: bytes, fmt: str, isolated: bool = True, **npz):
    """(columns [(label, values)], units or None, report, row_lines) of a file; ``isolated``:
    MATLAB files are read in a child process (:func:`pneucore.data.matfile.mat_columns_isolated`);
    ``npz``: :func:`_npz_columns`'s mapping, ambient pressure, memory budget and preview rows."""
    if fmt in ("tdms", "mat", "npz"):
        if fmt == "tdms":
            cols, units, extra = _tdms_columns(data)
        elif fmt == "mat":
            cols, units, extra = mat_columns_isolated(data) if isolated else mat_columns(data)
        else:
            cols, units, extra = _npz_columns(data, **npz)
        if len(cols) > MAX_COLUMNS:
            raise MeasurementError(f"the file has {len(cols)} columns; at most MAX_COLUMNS = "
                                   f"{MAX_COLUMNS} are read")
        return cols, units, {"format": fmt, **extra}, None
    text, encoding = decode_text(data)
    table = read_table(text)
    return (list(zip(table.header, table.columns)), table.units,
            {"format": "csv", "encoding": encoding, **table.dialect}, table.row_lines)


def read_measurement(data: bytes, filename: str | None = None,
                     ambient_pressure: float = DEFAULT_AMBIENT_PRESSURE,
                     name: str | None = None, columns: Mapping[str, Any] | None = None,
                     isolated: bool = True, memory_budget: int | None = None) -> Measurement:
    """Read a rig file (CSV, TDMS, MATLAB or NumPy .npz) into a validated measurement.

    Parameters
    ----------
    data : bytes
        The file's content [-]
    filename : str or None, optional
        Its name: the default measurement name (without extension) and the
        format of a MATLAB v4 file [-]
    ambient_pressure : float, optional
        The rig's ambient pressure, added to gauge pressures [Pa]
    name : str or None, optional
        Name of the measurement [-]
    columns : mapping or None, optional
        Column mapping ``{"Zeit": "t", "pA": "p_a[bar(g)]", "Kraft": None}`` [-]
    isolated : bool, optional
        Read a MATLAB file in a child process, so that a file crashing scipy's reader
        is an error and not the end of this process (about 0.4 s more); False reads it
        here (files one trusts) [-]
    memory_budget : int or None, optional
        Most memory the decoded columns of an ``.npz`` archive may take, checked from the
        members' headers before any is read; None = :data:`DECODE_BUDGET` [bytes]

    Returns
    -------
    measurement : Measurement
        In SI units, absolute pressures; ``meta["import"]`` is the import
        report (format, encoding and dialect for CSV, every conversion,
        ignored columns, missing cells, warnings) [-]

    Raises
    ------
    MeasurementError
        Naming the column and row of what is wrong.
    """
    data = bytes(data)
    fmt = detect_format(data, filename)
    npz = {"mapping": columns, "ambient_pressure": ambient_pressure,
           "memory_budget": memory_budget} if fmt == "npz" else {}
    cols, units, report, lines = _table(data, fmt, isolated, **npz)
    n = max((len(v) for _, v in cols if v is not None), default=0)
    if n > MAX_SAMPLES:
        raise MeasurementError(f"too many samples: {n} rows found, at most MAX_SAMPLES = "
                               f"{MAX_SAMPLES} are supported; decimate or split the measurement")
    if fmt != "csv":
        # binary formats: channels of different lengths cannot share one time base
        lengths = {lab: len(v) for lab, v in cols if v is not None}   # None: ignored, unread
        t_len = next((len(v) for lab, v in cols if v is not None and _is_time(lab)), None)
        for lab, k in lengths.items():
            mapped = columns.get(lab, "") if isinstance(columns, Mapping) else ""
            if t_len is not None and k != t_len and mapped is not None:
                raise MeasurementError(f"has {k} samples but the time has {t_len}; ignore it "
                                       f"with columns={{\"{lab}\": null}}", column=lab)
    if name is None:
        name = filename.rsplit(".", 1)[0] if filename else ""
    meta = {"source": filename} if filename else {}
    return measurement_from_columns(cols, ambient_pressure, name, meta, lines,
                                    decimal_comma_hint=report.get("delimiter", ",") != ",",
                                    units=units, mapping=columns, report=report)


def inspect_file(data: bytes, filename: str | None = None, rows: int = 5, isolated: bool = True) -> dict:
    """Preview a rig file for a mapping step: columns, units, dialect, a proposed mapping.

    Parameters
    ----------
    data : bytes
        The file's content [-]
    filename : str or None, optional
        Its name [-]
    rows : int, optional
        Number of data rows in the preview [-]
    isolated : bool, optional
        As for :func:`read_measurement` [-]

    Returns
    -------
    preview : dict
        ``format``, ``encoding``/``delimiter``/``decimal``/``units_row`` for
        CSV, ``columns`` (name as written, unit, proposed signal), ``mapping``
        (the proposed ``{column: signal or null}``), ``rows`` (the first
        cells as text) and ``signals`` (every signal with its SI unit and the
        units accepted) [-]
    """
    data = bytes(data)
    fmt = detect_format(data, filename)
    if fmt == "csv":
        text, encoding = decode_text(data)
        table = read_table(text, max_rows=rows)
        cols = list(zip(table.header, table.columns))
        units, report = table.units, {"format": "csv", "encoding": encoding, **table.dialect}
    else:
        cols, units, report, _ = _table(data, fmt, isolated,
                                        **({"preview_rows": rows} if fmt == "npz" else {}))
    labels = [str(lab) for lab, _ in cols]
    mapping = propose_mapping(labels)
    out_cols = []
    for j, lab in enumerate(labels):
        name, unit = split_label(lab)
        if units is not None and j < len(units) and units[j] and not unit:
            unit = units[j]
        out_cols.append({"name": lab, "unit": unit or "", "signal": mapping.get(name)})
    preview = [[str(v) if isinstance(v, str) else f"{float(v):.6g}" for v in r]
               for r in zip(*[list(v[:rows]) for _, v in cols])]
    from pneucore.data.measurement import SIGNAL_UNITS, UNITS
    signals = {"t": "s", **SIGNAL_UNITS}
    return {**report, "columns": out_cols,
            "mapping": {c["name"]: c["signal"] for c in out_cols}, "rows": preview,
            "signals": {k: {"unit": u, "accepted_units": list(UNITS[k])} for k, u in signals.items()}}
