"""The memory a request body will take once decoded, estimated before anything is decoded.

Every estimate is checked against ``Limits.max_request_memory`` (GET /api/limits) before the
body is parsed, so that a body under the size limit cannot take the server's memory:

- **CSV**: its cells (lines times the columns of its widest first lines) at
  :data:`CSV_CELL_BYTES` each, what the reader takes for one;
- **JSON** (a dataset, or an analysis with inline measurements): its values (the commas, one
  between two values) at :data:`JSON_VALUE_BYTES` each;
- **TDMS**: the channels' declared lengths (npTDMS reads the metadata alone), each value as
  stored and as float64;
- **MATLAB** v5-v7: every variable's declared class and dimensions, struct fields and cells
  included, read from the headers (a compressed variable is inflated a piece at a time,
  never held, and no further than the budget), each value as its class and as float64;
  v4 files, which cannot be compressed, at the worst case of one byte a stored value.

``.npz`` archives are checked by their reader, from the members' headers
(:func:`pneucore.data.fileformats.read_measurement`'s ``memory_budget``). The per-cell and
per-value figures are measured by ``benchmarks/bench_request_memory.py`` (README: Memory
per request).
"""
from __future__ import annotations

import io
import struct
import zlib

from fastapi import HTTPException

from pneucore.data.fileformats import detect_format
from pneucore.data.measurement import MeasurementError

#: Memory the CSV reader takes per cell of a file [bytes]: 127 measured for 200,000 rows of 5
#: columns (a cell's text, its float and their list slots; benchmarks/bench_request_memory.py)
CSV_CELL_BYTES = 128
#: Memory a JSON body takes per value, parsed and validated [bytes]: 117 measured for a dataset
#: of 1,000,000 values, 79 for a list of zeros (benchmarks/bench_request_memory.py)
JSON_VALUE_BYTES = 120
#: Bytes of a value once read as float64 [bytes]
FLOAT64 = 8


def decoded_bytes(count, itemsize):
    """Memory of ``count`` values read as stored (``itemsize`` bytes each) and converted to
    float64, the rule of the ``.npz`` reader [bytes]."""
    return count * (itemsize + FLOAT64)


def _refuse(what, estimate, budget):
    return MeasurementError(f"the file's {what} would take about {estimate / 1e6:.0f} MB once "
                            f"decoded, more than the memory budget of {budget / 1e6:.0f} MB per "
                            f"request (max_request_memory, GET /api/limits); nothing was decoded: "
                            f"split or decimate the measurement")


# ----------------------------------------------------------------------------- CSV
def csv_cells(data: bytes) -> int:
    """Cells of a CSV text [-]: its lines times the columns of the widest of its first 20
    lines (counted by the most frequent delimiter, or by blanks)."""
    newline = b"\n" if b"\n" in data[:1 << 20] or b"\r" not in data[:1 << 20] else b"\r"
    lines = data.count(newline) + 1
    head = data[:1 << 16].split(newline)[:20]
    cols = max((max(max(line.count(d) for d in (b",", b";", b"\t", b"|")) + 1,
                    len(line.split())) for line in head if line.strip()), default=1)
    return lines * cols


# ----------------------------------------------------------------------------- TDMS
def tdms_bytes(data: bytes) -> int:
    """Decoded size of a TDMS file's channels from its metadata alone [bytes]; 0 when the
    metadata cannot be read (the reader then says why)."""
    try:
        from nptdms import TdmsFile
        f = TdmsFile.read_metadata(io.BytesIO(data))
        total = 0
        for g in f.groups():
            for ch in g.channels():
                size = getattr(ch.data_type, "size", None) or 64   # text: about a short string
                total += decoded_bytes(len(ch), size)
        return total
    except Exception:  # noqa: BLE001 - a damaged file: the reader names what is wrong
        return 0


# ----------------------------------------------------------------------------- MATLAB
#: MATLAB class number -> bytes of one value as loaded (mxDOUBLE_CLASS = 6 ... mxUINT64 = 15;
#: char as one UCS-4 character)
_MX_ITEMSIZE = {4: 4, 6: 8, 7: 4, 8: 1, 9: 1, 10: 2, 11: 2, 12: 4, 13: 4, 14: 8, 15: 8}
_MI_MATRIX, _MI_COMPRESSED = 14, 15
_MX_CELL, _MX_STRUCT = 1, 2
#: Deepest nesting of structs and cells followed [-]; deeper: the worst case
_MAX_DEPTH = 8


class _Over(Exception):
    """The budget is exceeded: no need to read further."""


class _Stream:
    """Sequential reads over an element's bytes, inflated a piece at a time when compressed
    (nothing held but the piece); more than ``limit`` bytes read raises :class:`_Over`."""

    def __init__(self, raw, compressed, limit):
        self._raw, self._z = raw, (zlib.decompressobj() if compressed else None)
        self._pos, self._buf, self._limit, self.read_bytes = 0, b"", limit, 0

    def _more(self):
        """The next piece of inflated bytes; b"" at the end."""
        if self._z.unconsumed_tail:
            return self._z.decompress(self._z.unconsumed_tail, 1 << 20)
        if self._pos < len(self._raw):
            piece = self._raw[self._pos:self._pos + (1 << 16)]
            self._pos += len(piece)
            return self._z.decompress(piece, 1 << 20) or self._more()
        return b""

    def read(self, n):
        if self.read_bytes + n > self._limit:
            raise _Over
        if self._z is None:
            out = bytes(self._raw[self._pos:self._pos + n])
            self._pos += len(out)
        else:
            while len(self._buf) < n:
                piece = self._more()
                if not piece:
                    break
                self._buf += piece
            out, self._buf = self._buf[:n], self._buf[n:]
        self.read_bytes += len(out)
        if len(out) < n:
            raise ValueError("short element")
        return out

    def skip(self, n):
        if self.read_bytes + n > self._limit:
            raise _Over
        if self._z is None:
            if self._pos + n > len(self._raw):
                raise ValueError("short element")
            self._pos += n
            self.read_bytes += n
            return
        while n > 0:   # inflated and dropped a piece at a time
            if not self._buf:
                self._buf = self._more()
                if not self._buf:
                    raise ValueError("short element")
            k = min(n, len(self._buf))
            self._buf = self._buf[k:]
            self.read_bytes += k
            n -= k


def _tag(s, e):
    """``(type, nbytes, data)`` of the next data element's tag; ``data``: a small element's
    data (in the tag's last 4 bytes), else None."""
    raw = s.read(8)
    t, n = struct.unpack(e + "II", raw)
    if t >> 16:   # small element: the size in the upper half of the type
        return t & 0xFFFF, t >> 16, raw[4:4 + (t >> 16)]
    return t, n, None


def _element(s, e):
    """``(type, data)`` of the next (small or ordinary) element, its padding skipped."""
    t, n, small = _tag(s, e)
    if small is not None:
        return t, small
    data = s.read(n)
    s.skip(-n % 8)
    return t, data


def _matrix_cost(s, e, depth, budget, spent):
    """Decoded size of the miMATRIX element next in ``s`` (its tag included) [bytes]; a
    top-level one (``depth`` 0) is not read past its headers (the next one is found from
    the file's tags)."""
    t, n, small = _tag(s, e)
    if t != _MI_MATRIX or n == 0 or small is not None:
        if small is None:
            s.skip(n)
        return 0
    start = s.read_bytes
    _, flags = _element(s, e)
    word = struct.unpack(e + "I", flags[:4])[0]
    mx, complex_ = word & 0xFF, bool(word & 0x800)
    _, dims = _element(s, e)
    count = 1
    for d in struct.unpack(e + f"{len(dims) // 4}i", dims[:len(dims) // 4 * 4]):
        count *= max(d, 0)
    if mx in (_MX_STRUCT, _MX_CELL) and depth < _MAX_DEPTH:
        _element(s, e)                          # the array's name
        if mx == _MX_STRUCT:
            _, fl = _element(s, e)                  # field name length
            _, names = _element(s, e)               # field names
            length = struct.unpack(e + "i", fl[:4])[0] or 1
            children = count * (len(names) // length)
        else:
            children = count
        cost = 0
        for _ in range(children):
            cost += _matrix_cost(s, e, depth + 1, budget, spent + cost)
            if spent + cost > budget:
                raise _Over
        return cost
    if mx in _MX_ITEMSIZE:
        if depth:   # the values, to reach the next field: their size is in the header
            s.skip(n - (s.read_bytes - start))
        return decoded_bytes(count, _MX_ITEMSIZE[mx]) * (2 if complex_ else 1)
    # sparse, objects, deeper nesting: the worst case, one byte a stored value
    if depth:
        s.skip(n - (s.read_bytes - start))
    return decoded_bytes(n, 1)


def mat_bytes(data: bytes, budget: int) -> int:
    """Decoded size of a MATLAB file's variables from their headers [bytes]; stops (and
    answers more than ``budget``) as soon as the budget is exceeded; 0 when the file is no
    MATLAB 5 file it can walk (the reader then says why)."""
    if data[:10] != b"MATLAB 5.0":
        return decoded_bytes(len(data), 1) if data[:10] != b"MATLAB 7.3" else 0   # v4: raw
    e = "<" if data[126:128] == b"IM" else ">"
    pos, total = 128, 0
    view = memoryview(data)
    try:
        while pos + 8 <= len(data) and total <= budget:
            t, n = struct.unpack_from(e + "II", data, pos)
            body = view[pos + 8:pos + 8 + n]
            if t == _MI_COMPRESSED:   # inflated no further than the budget left
                s = _Stream(body, True, budget - total)
                total += _matrix_cost(s, e, 0, budget, total)
                pos += 8 + n
            elif t == _MI_MATRIX:
                s = _Stream(view[pos:pos + 8 + n], False, len(data))
                total += _matrix_cost(s, e, 0, budget, total)
                pos += 8 + n + (-n % 8)
            else:
                pos += 8 + n + (-n % 8)
    except _Over:
        return budget + 1
    except (ValueError, struct.error, zlib.error):
        return total   # a damaged file: the reader names what is wrong
    return total


# ----------------------------------------------------------------------------- checks
def check_file(data: bytes, filename, budget: int, preview=False):
    """Refuse a rig file whose decoded columns would exceed ``budget`` [bytes], before any is
    decoded (a :class:`MeasurementError`, answered 422 naming ``max_request_memory``).

    Parameters
    ----------
    data : bytes
        The file's content [-]
    filename : str or None
        Its name (a MATLAB v4 file is told by its extension) [-]
    budget : int
        ``Limits.max_request_memory`` [bytes]
    preview : bool
        For a preview (POST /api/datasets/inspect), which reads a CSV's first rows only and
        every column of the other formats: CSV not checked [-]

    Returns
    -------
    estimate : int
        The decoded size [bytes] (0 for what is not estimated here: ``.npz``, a CSV preview),
        held on the analyses' memory budget while the file is decoded
        (:func:`app.analysis_memory.admitted`)
    """
    fmt = detect_format(data, filename)
    if fmt == "csv" and preview:
        return 0
    if fmt == "csv":
        estimate, what = csv_cells(data) * CSV_CELL_BYTES, "cells"
    elif fmt == "tdms":
        estimate, what = tdms_bytes(data), "channels"
    elif fmt == "mat":
        estimate, what = mat_bytes(data, budget), "variables"
    else:
        return 0   # .npz: checked by its reader from the members' headers
    if estimate > budget:
        raise _refuse(what, estimate, budget)
    return estimate


def json_values(body: bytes) -> int:
    """Values of a JSON text, at most: its commas, one between two values, plus one [-]."""
    return body.count(b",") + 1


def check_json(body: bytes, budget: int):
    """Refuse a JSON body whose parsed values would exceed ``budget`` [bytes] with 413, before
    it is parsed.

    Parameters
    ----------
    body : bytes
        The JSON text [-]
    budget : int
        ``Limits.max_request_memory`` [bytes]
    """
    # at most one value per 2 bytes ("0,"): a body that small cannot exceed it, not counted
    if len(body) // 2 * JSON_VALUE_BYTES <= budget:
        return
    values = json_values(body)
    if values * JSON_VALUE_BYTES > budget:
        raise HTTPException(413, f"the JSON body's {values} values would take about "
                                 f"{values * JSON_VALUE_BYTES / 1e6:.0f} MB once parsed, more than "
                                 f"the memory budget of {budget / 1e6:.0f} MB per request "
                                 f"(max_request_memory, GET /api/limits); nothing was parsed: "
                                 f"upload the measurement as a file (CSV, .npz) or decimate it")
