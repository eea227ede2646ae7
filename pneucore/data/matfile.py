"""MATLAB ``.mat`` files (v4-v7) read into columns, in a child process by default.

scipy's MATLAB reader is compiled code, and a malformed file can crash it: a file of 1,960
bytes made by flipping bytes of a valid one ends the interpreter with a segmentation fault
inside ``scipy.io.matlab._mio5`` (scipy 1.17.1). A service that reads uploads must not die
of one, so :func:`mat_columns_isolated` runs :func:`mat_columns` in a child process
(``python -m pneucore.data.matfile``: the file on its standard input, the columns back on
its standard output as an ``.npz`` archive, :mod:`pneucore.data.npz`) and turns a crash or
a hang into a :class:`~pneucore.data.measurement.MeasurementError`. It costs the child's
start (about 0.3-0.5 s); :func:`mat_columns` reads in this process, for files one trusts.

Every top-level numeric vector is a column, and so is every numeric vector field of a
top-level struct; a struct or cell variable named ``units`` may give units by column
name (``units.p_A = 'bar(g)'``). v7.3 files are HDF5: save with ``-v7``.
"""
from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import threading
from typing import Any

import numpy as np

from pneucore.data.measurement import MeasurementError

__all__ = ["mat_columns", "mat_columns_isolated", "MAT_CHILD_TIMEOUT", "MAT_MAX_CHILDREN"]

#: Longest a child process may read a file [s] (a bound on a hang: a file within the
#: upload limit reads in well under a second)
MAT_CHILD_TIMEOUT = 60.0
#: Most child readers at once in this process [-] (each is an interpreter with scipy, about
#: 60 MB: many uploads at once wait for a turn rather than fill the memory)
MAT_MAX_CHILDREN = 4
_CHILDREN = threading.BoundedSemaphore(MAT_MAX_CHILDREN)


def mat_columns(data: bytes):
    """The columns of a MATLAB file, read in this process.

    Parameters
    ----------
    data : bytes
        The file's content [-]

    Returns
    -------
    columns : list of (str, ndarray)
        Label and values (float64) of each numeric vector [-]
    units : list of str
        The unit of each column from a ``units`` variable, else ``""`` [-]
    extra : dict
        Facts for the import report (none for MATLAB files) [-]

    Raises
    ------
    MeasurementError
        A v7.3 (HDF5) file, an unreadable file, or one without a numeric vector
    """
    from scipy.io import loadmat
    if data[:10] == b"MATLAB 7.3":
        raise MeasurementError("MATLAB v7.3 files (HDF5) are not supported; save with "
                               "save(..., '-v7')")
    try:
        d = loadmat(io.BytesIO(data), simplify_cells=True)
    except NotImplementedError:
        raise MeasurementError("MATLAB v7.3 files (HDF5) are not supported; save with "
                               "save(..., '-v7')") from None
    except Exception as exc:
        raise MeasurementError(f"not a readable MATLAB file ({type(exc).__name__}: {exc})") from None
    units_var = d.get("units")
    cols: list[tuple[str, Any]] = []

    def vector(v):
        a = np.asarray(v)
        if a.dtype.kind in "iuf" and a.size >= 1 and (a.ndim == 1 or (a.ndim == 2 and min(a.shape) == 1)):
            return a.reshape(-1).astype(np.float64)
        return None

    for key, v in d.items():
        if key.startswith("__") or key == "units":
            continue
        if isinstance(v, dict):
            for fk, fv in v.items():
                a = vector(fv)
                if a is not None:
                    cols.append((fk, a))
        else:
            a = vector(v)
            if a is not None:
                cols.append((key, a))
    if not cols:
        raise MeasurementError("the MATLAB file holds no numeric vector")
    units = []
    for label, _ in cols:
        u = ""
        if isinstance(units_var, dict):
            u = units_var.get(label, "")
        units.append(u if isinstance(u, str) else "")
    return cols, units, {}


def mat_columns_isolated(data: bytes, timeout: float = MAT_CHILD_TIMEOUT):
    """:func:`mat_columns` in a child process: a file that crashes or hangs the reader is a
    :class:`~pneucore.data.measurement.MeasurementError`, never the caller's end.

    Parameters
    ----------
    data : bytes
        The file's content [-]
    timeout : float
        Longest the child may take [s]

    Returns
    -------
    columns, units, extra
        As :func:`mat_columns`
    """
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [root] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    if not _CHILDREN.acquire(timeout=timeout):
        raise MeasurementError(f"{MAT_MAX_CHILDREN} MATLAB files are being read; try again")
    try:
        # a fixed command line, the file on stdin: nothing of the file reaches a shell
        proc = subprocess.run([sys.executable, "-m", "pneucore.data.matfile"], input=bytes(data),
                              capture_output=True, timeout=timeout, env=env, check=False)
    except subprocess.TimeoutExpired:
        raise MeasurementError(f"the MATLAB reader took more than {timeout:g} s on this file; "
                               f"it is malformed, or save it again with save(..., '-v7')") from None
    finally:
        _CHILDREN.release()
    if proc.returncode != 0:
        how = f"signal {-proc.returncode}" if proc.returncode < 0 else f"exit code {proc.returncode}"
        raise MeasurementError(f"the MATLAB reader crashed on this file ({how}): it is malformed; "
                               f"save it again with save(..., '-v7')")
    try:
        z = np.load(io.BytesIO(proc.stdout))   # our own archive; allow_pickle=False
        meta = json.loads(z["meta.json"])
        if meta.get("error") is not None:
            raise MeasurementError(meta["error"])
        cols = [(label, z[f"c{i}"]) for i, label in enumerate(meta["labels"])]
    except MeasurementError:
        raise
    except Exception as exc:  # noqa: BLE001 - whatever the child left is not a reading
        raise MeasurementError(f"the MATLAB reader gave no reading of this file ({type(exc).__name__})") from None
    return cols, meta["units"], meta["extra"]


def _child():
    """``python -m pneucore.data.matfile``: :func:`mat_columns` of the file on stdin, as an
    ``.npz`` archive on stdout (members ``c0``, ``c1`` ... and ``meta.json`` with the labels,
    units and report facts, or the error)."""
    from pneucore.data.npz import npz_bytes
    data = sys.stdin.buffer.read()
    try:
        cols, units, extra = mat_columns(data)
        meta = {"labels": [str(lab) for lab, _ in cols], "units": units, "extra": extra, "error": None}
        arrays = {f"c{i}": a for i, (_, a) in enumerate(cols)}
    except MeasurementError as exc:
        meta, arrays = {"error": exc.detail}, {}
    sys.stdout.buffer.write(npz_bytes(arrays, {"meta.json": json.dumps(meta).encode()}))
    sys.stdout.buffer.flush()


if __name__ == "__main__":   # guarded: never run on import
    _child()
