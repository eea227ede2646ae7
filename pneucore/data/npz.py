"""NumPy ``.npz`` archives written in one pass: the binary form of a simulation's answer.

An ``.npz`` file is a ZIP archive holding one ``.npy`` file per array (the format of
``numpy.savez``; NEP 1, "A simple file format for NumPy arrays"). ``numpy.load`` reads
it back without unpickling anything (``allow_pickle=False``, its default), and any ZIP
tool lists it. This module writes such archives stored (not compressed) straight from
the arrays' memory: about 30 us for the 19 series of a 1,001-sample run, where
``numpy.savez`` takes about ten times as long and orjson writes the same numbers as
JSON text in 0.2 ms (``benchmarks/bench_api.py``).

Members other than arrays (``meta.json``: units, events, statistics) are stored as they
are given; ``numpy.load(f)["meta.json"]`` returns their bytes.

Only numeric, boolean and fixed-width text arrays are written (dtype kinds ``b i u f c
U S``): an object array would need pickling to be read back, and is refused.
"""
from __future__ import annotations

import json
import re
import struct
import zlib
from functools import lru_cache
from typing import Mapping

import numpy as np

__all__ = ["npz_bytes", "simulation_npz", "NPZ_MEDIA_TYPE"]

#: Media type of the archives (no registered type exists; this one is the common use)
NPZ_MEDIA_TYPE = "application/x-npz"

#: Array dtypes written: numbers, booleans and fixed-width text (never object arrays)
_KINDS = frozenset("biufcUS")
#: A member name: letters, digits, ``_ - .``; no directories, nothing a ZIP tool could
#: resolve outside the folder it extracts to
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]{0,99}\Z")
#: DOS time and date of every member: 1980-01-01 00:00 (the archive is reproducible:
#: the same arrays give the same bytes)
_DOS_TIME, _DOS_DATE = 0, (0 << 9) | (1 << 5) | 1
_LOCAL = struct.Struct("<IHHHHHIIIHH")      # local file header, then the name
_CENTRAL = struct.Struct("<IHHHHHHIIIHHHHHII")   # central directory entry, then the name
_END = struct.Struct("<IHHHHIIH")           # end of central directory record
_ZIP_LIMIT = 0xFFFFFFFF                     # sizes and offsets without the ZIP64 extension


@lru_cache(maxsize=256)
def _npy_header(descr: str, shape: tuple) -> tuple[bytes, int]:
    """The ``.npy`` header (format 1.0, padded to 64 bytes) of a C-ordered array, and its
    CRC-32 (the member's CRC continues from it over the data)."""
    head = "{'descr': %r, 'fortran_order': False, 'shape': %r, }" % (descr, shape)
    pad = -(10 + len(head) + 1) % 64   # magic (6) + version (2) + length (2) + head + "\n"
    head = head + " " * pad + "\n"
    head = b"\x93NUMPY\x01\x00" + struct.pack("<H", len(head)) + head.encode("latin-1")
    return head, zlib.crc32(head)


@lru_cache(maxsize=1024)
def _member_name(name) -> bytes:
    """A member's name as the archive stores it, checked to be a plain file name."""
    if not isinstance(name, str) or not _NAME.match(name) or ".." in name:
        raise ValueError(f"npz: member name {name!r} is not a plain file name")
    return name.encode("ascii")


def _npy(arr) -> tuple[bytes, int, memoryview]:
    """The ``.npy`` header, its CRC-32 and the data (C order) of one array."""
    arr = np.asarray(arr)
    if arr.dtype.kind not in _KINDS or arr.dtype.fields is not None:
        raise TypeError(f"npz: dtype {arr.dtype} is not written (numbers, booleans, text only)")
    if not arr.flags.c_contiguous:
        arr = arr.copy(order="C")
    head, crc = _npy_header(arr.dtype.str, arr.shape)
    return head, crc, memoryview(arr.reshape(-1).view(np.uint8))


def npz_bytes(arrays: Mapping[str, np.ndarray], files: Mapping[str, bytes] | None = None) -> bytes:
    """An ``.npz`` archive (stored ZIP of ``.npy`` files) of named arrays, as bytes.

    Parameters
    ----------
    arrays : mapping of str to array_like
        Arrays by name, in their own units; each becomes the member ``NAME.npy``
        (``numpy.load(f)[NAME]``) [-]
    files : mapping of str to bytes, optional
        Other members by their full name (``meta.json``), stored as given [-]

    Returns
    -------
    data : bytes
        The archive; ``numpy.load(io.BytesIO(data))`` reads it [-]

    Raises
    ------
    ValueError
        A name that is not a plain file name, a name given twice, or an archive past
        4 GiB (no ZIP64)
    TypeError
        An array of objects or of a structured dtype

    Examples
    --------
    >>> import io
    >>> data = npz_bytes({"t": np.array([0.0, 0.5, 1.0])}, {"meta.json": b'{"units": {"t": "s"}}'})
    >>> z = np.load(io.BytesIO(data))
    >>> z["t"].tolist(), z["meta.json"]
    ([0.0, 0.5, 1.0], b'{"units": {"t": "s"}}')
    """
    members = [(name + ".npy", *_npy(arr)) for name, arr in arrays.items()]
    members += [(name, b"", 0, memoryview(bytes(data))) for name, data in (files or {}).items()]
    chunks, central, offset = [], [], 0
    for name, head, crc, data in members:
        bname = _member_name(name)
        size = len(head) + data.nbytes
        crc = zlib.crc32(data, crc)
        local = _LOCAL.pack(0x04034B50, 20, 0, 0, _DOS_TIME, _DOS_DATE, crc, size, size,
                            len(bname), 0)
        central.append(_CENTRAL.pack(0x02014B50, 20, 20, 0, 0, _DOS_TIME, _DOS_DATE, crc, size,
                                     size, len(bname), 0, 0, 0, 0, 0, offset))
        central.append(bname)
        chunks += (local, bname, head, data)
        offset += len(local) + len(bname) + size
    if len({name for name, *_ in members}) != len(members):
        raise ValueError(f"npz: a member given twice in {sorted(name for name, *_ in members)}")
    directory = b"".join(central)
    if offset + len(directory) > _ZIP_LIMIT or len(members) > 0xFFFF:
        raise ValueError("npz: the archive would pass 4 GiB or 65,535 members (no ZIP64)")
    chunks += (directory, _END.pack(0x06054B50, 0, 0, len(members), len(members), len(directory),
                                    offset, 0))
    return b"".join(chunks)


def simulation_npz(result, series=None, dumps=None) -> bytes:
    """A :class:`~pneucore.result.SimulationResult` as an ``.npz`` archive.

    Every series is a member (``t`` [s], ``p_a`` [Pa] ...: absolute pressures, SI units;
    ``mode`` as text); ``meta.json`` holds what the JSON form holds besides the series
    (:meth:`~pneucore.result.SimulationResult.summary`: ``units``, ``events``, ``stats``,
    ``status``, ``message``).

    Parameters
    ----------
    result : SimulationResult
        A completed simulation [-]
    series : list of str, optional
        Series to write (default: all) [-]
    dumps : callable, optional
        JSON encoder of ``meta.json``, object -> str or bytes (default :func:`json.dumps`) [-]

    Returns
    -------
    data : bytes
        The archive (series in SI units, absolute pressures) [-]

    Examples
    --------
    >>> import io
    >>> from pneucore import Model, Scenario, model_preset, scenario_preset, simulate
    >>> res = simulate(Model.from_dict(model_preset("paper-4way")),
    ...                Scenario.from_dict(scenario_preset("paper-fig10-pulses")))
    >>> z = np.load(io.BytesIO(simulation_npz(res, ["t", "p_a", "mode"])))
    >>> sorted(z.files), z["p_a"].shape, str(z["mode"][0])
    (['meta.json', 'mode', 'p_a', 't'], (1001,), 'stick')
    """
    names = series or list(result.series)
    meta = (dumps or json.dumps)(result.summary(names))
    return npz_bytes({k: result.series[k] for k in names},
                     {"meta.json": meta.encode() if isinstance(meta, str) else meta})
