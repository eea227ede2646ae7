"""SQLite store of robustness studies (the same file as the web service's store may be used).

Tables (created if absent)::

    studies(id TEXT PRIMARY KEY, definition TEXT, created REAL, status TEXT)
    study_runs(study_id TEXT, run_index INTEGER, params, metrics, error TEXT,
               PRIMARY KEY (study_id, run_index))

``definition`` is the canonical study JSON, ``created`` a Unix time [s],
``status`` one of :data:`STATUSES`. ``params`` and ``metrics`` hold one run's
values as a packed little-endian float64 vector (a BLOB): the parameter values
in the order of ``Study.paths`` and the metrics in the order of
``Study.metric_names``, in SI units, NaN where a metric is undefined;
``metrics`` is NULL and ``error`` holds the message for a failed run. Rows
written by earlier versions hold JSON objects (``{path: value}``,
``{metric: value or null}``) instead, and are still read.

A finished batch is written as one transaction of ``INSERT OR REPLACE``
keyed by run index (``executemany``), so a batch written twice (a
rescheduled task) changes nothing. The file is in WAL mode with
``synchronous=NORMAL``: a crash of the process loses nothing committed; a
power cut may lose the last batches, which a resume recomputes.
Packing the values instead of writing JSON is what lets the store take
finished runs several times faster than the workers of a large machine
produce them, and lets a 100,000-run summary read its arrays in a fraction
of a second (``benchmarks/bench_study_store.py``).
"""
from __future__ import annotations

import json
import math
import sqlite3
import time
from typing import NamedTuple

import numpy as np

#: Study states: queued (accepted, not started), running (or killed while running),
#: interrupted (stopped by an error or a callback), done (every run stored, failed runs included)
STATUSES = ("queued", "running", "interrupted", "done")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS studies (
    id TEXT PRIMARY KEY, definition TEXT NOT NULL, created REAL NOT NULL, status TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS study_runs (
    study_id TEXT NOT NULL, run_index INTEGER NOT NULL, params BLOB NOT NULL, metrics BLOB,
    error TEXT, PRIMARY KEY (study_id, run_index));
"""


class RunBlock(NamedTuple):
    """Finished runs of one batch, column-wise (what a worker returns and the store writes).

    Attributes
    ----------
    indices : ndarray of int64, shape (n,)
        Run indices [-]
    params : ndarray of float64, shape (n, k)
        Parameter values in ``Study.paths`` order (SI units of each path)
    metrics : ndarray of float64, shape (n, m)
        Metrics in ``Study.metric_names`` order (units of :data:`~pneucore.study.metrics.METRICS`);
        NaN where undefined or where the run failed
    errors : list of str or None
        Error message of each failed run, None for a run that succeeded
    """
    indices: np.ndarray
    params: np.ndarray
    metrics: np.ndarray
    errors: list

    def __len__(self):
        return len(self.indices)


def connect(path):
    """Open (and create the tables of) the store at ``path`` (``:memory:`` allowed)."""
    db = sqlite3.connect(path, isolation_level=None, timeout=30.0, check_same_thread=False)
    if path != ":memory:":
        db.execute("PRAGMA journal_mode=WAL")
        db.execute("PRAGMA synchronous=NORMAL")
    db.execute("PRAGMA busy_timeout=30000")
    db.executescript(_SCHEMA)
    return db


def clean(v):
    """A float for JSON: None for NaN/inf."""
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def get_study(db, study_id):
    """``{"id", "definition" (JSON text), "created", "status"}`` or None."""
    row = db.execute("SELECT id, definition, created, status FROM studies WHERE id=?",
                     (study_id,)).fetchone()
    if row is None:
        return None
    return {"id": row[0], "definition": row[1], "created": row[2], "status": row[3]}


def create_study(db, study_id, definition_json, status="running"):
    db.execute("INSERT INTO studies (id, definition, created, status) VALUES (?,?,?,?)",
               (study_id, definition_json, time.time(), status))


def set_status(db, study_id, status):
    db.execute("UPDATE studies SET status=? WHERE id=?", (status, study_id))


def set_study_status(path, study_id, status):
    """Set a stored study's status (one of :data:`STATUSES`) in the store at ``path``."""
    if status not in STATUSES:
        raise ValueError(f"status must be one of {STATUSES}, got {status!r}")
    db = connect(path)
    try:
        set_status(db, study_id, status)
    finally:
        db.close()


def stored_indices(db, study_id):
    """Run indices already stored for the study (a set)."""
    return {r[0] for r in db.execute("SELECT run_index FROM study_runs WHERE study_id=?", (study_id,))}


def count_runs(db, study_id):
    """``(stored, failed)`` run counts."""
    row = db.execute("SELECT COUNT(*), COALESCE(SUM(error IS NOT NULL), 0) FROM study_runs "
                     "WHERE study_id=?", (study_id,)).fetchone()
    return int(row[0]), int(row[1])


def write_runs(db, study_id, block):
    """Store a batch of finished runs in one transaction.

    Parameters
    ----------
    db : sqlite3.Connection
        Open store
    study_id : str
        Study id
    block : RunBlock
        The runs (values packed as float64 vectors, see the module docstring)
    """
    P = np.ascontiguousarray(block.params, dtype="<f8")
    M = np.ascontiguousarray(block.metrics, dtype="<f8")
    recs = [(study_id, i, P[j].tobytes(), None if err is not None else M[j].tobytes(), err)
            for j, (i, err) in enumerate(zip(block.indices.tolist(), block.errors))]
    db.execute("BEGIN IMMEDIATE")
    try:
        db.executemany("INSERT OR REPLACE INTO study_runs (study_id, run_index, params, metrics, error) "
                       "VALUES (?,?,?,?,?)", recs)
        db.execute("COMMIT")
    except BaseException:
        db.execute("ROLLBACK")
        raise


def _vector(value, names):
    """A stored value (packed float64, or a JSON object of earlier versions) as a float64 row."""
    if isinstance(value, bytes):
        v = np.frombuffer(value, dtype="<f8")
        if v.size == len(names):
            return v
        raise ValueError(f"stored vector of {v.size} values, expected {len(names)}")
    d = json.loads(value)
    return np.array([np.nan if d.get(k) is None else d[k] for k in names], float)


def _packed(values, n, k):
    """``n`` packed rows of ``k`` float64 as an (n, k) array in one copy, or None if any row is
    not packed (JSON of an earlier version)."""
    try:
        buf = b"".join(values)
    except TypeError:
        return None
    if len(buf) != 8 * n * k:
        return None
    return np.frombuffer(buf, dtype="<f8").reshape(n, k).astype(float)


def load_arrays(db, study_id, paths, names):
    """Every stored run of a study as arrays, ordered by run index.

    Parameters
    ----------
    paths : list of str
        ``Study.paths`` (column order of ``params``)
    names : list of str
        ``Study.metric_names`` (column order of ``metrics``)

    Returns
    -------
    block : RunBlock
        ``metrics`` rows of failed runs are NaN
    """
    rows = db.execute("SELECT run_index, params, metrics, error FROM study_runs WHERE study_id=? "
                      "ORDER BY run_index", (study_id,)).fetchall()
    n, k, m = len(rows), len(paths), len(names)
    idx = np.fromiter((r[0] for r in rows), dtype=np.int64, count=n)
    errors = [r[3] for r in rows]
    pv = [r[1] for r in rows]
    mv = [r[2] for r in rows]
    P = _packed(pv, n, k)
    if P is None:   # rows of an earlier version (JSON)
        P = np.array([_vector(v, paths) for v in pv], float).reshape(n, k)
    nan_row = np.full(m, np.nan).tobytes()
    M = _packed([nan_row if v is None else v for v in mv], n, m)
    if M is None:
        M = np.array([np.full(m, np.nan) if v is None else _vector(v, names) for v in mv],
                     float).reshape(n, m)
    return RunBlock(idx, P, M, errors)


def load_runs(db, study_id, paths, names):
    """All stored runs ordered by index: list of ``(index, params dict, metrics dict or None, error)``
    (metric values None where undefined)."""
    b = load_arrays(db, study_id, paths, names)
    out = []
    for j, i in enumerate(b.indices.tolist()):
        params = {p: clean(v) for p, v in zip(paths, b.params[j])}
        metrics = None if b.errors[j] is not None else {k: clean(v) for k, v in zip(names, b.metrics[j])}
        out.append((i, params, metrics, b.errors[j]))
    return out


def list_studies(path):
    """Every study in the store: ``[{"id", "name", "created", "status", "n_runs", "stored", "failed"}]``."""
    from pneucore.study.definition import Study
    db = connect(path)
    try:
        out = []
        for sid, definition, created, status in db.execute(
                "SELECT id, definition, created, status FROM studies ORDER BY created"):
            d = json.loads(definition)
            stored, failed = count_runs(db, sid)
            out.append({"id": sid, "name": d.get("name", ""), "created": created, "status": status,
                        "n_runs": Study.from_dict(d).n_runs, "stored": stored, "failed": failed})
        return out
    finally:
        db.close()


def delete_study(path, study_id):
    """Remove a study and its runs; returns True if it existed."""
    db = connect(path)
    try:
        db.execute("BEGIN IMMEDIATE")
        db.execute("DELETE FROM study_runs WHERE study_id=?", (study_id,))
        n = db.execute("DELETE FROM studies WHERE id=?", (study_id,)).rowcount
        db.execute("COMMIT")
        return n > 0
    finally:
        db.close()
