"""SQLite store of robustness studies (the same file as the web service's store may be used).

Tables (created if absent)::

    studies(id TEXT PRIMARY KEY, definition TEXT, created REAL, status TEXT)
    study_runs(study_id TEXT, run_index INTEGER, params TEXT, metrics TEXT, error TEXT,
               PRIMARY KEY (study_id, run_index))

``definition`` is the canonical study JSON, ``created`` a Unix time [s],
``status`` one of :data:`STATUSES`. ``params`` and ``metrics`` are JSON
objects (``{path: value}``, ``{metric: value or null}``; metrics is null and
``error`` holds the message for a failed run). Rows are written with
``INSERT OR REPLACE`` keyed by run index, one transaction per batch, so a
batch written twice (a rescheduled task) changes nothing.
"""
from __future__ import annotations

import json
import math
import sqlite3
import time

#: Study states: queued (accepted, not started), running (or killed while running),
#: interrupted (stopped by an error or a callback), done (every run stored, failed runs included)
STATUSES = ("queued", "running", "interrupted", "done")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS studies (
    id TEXT PRIMARY KEY, definition TEXT NOT NULL, created REAL NOT NULL, status TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS study_runs (
    study_id TEXT NOT NULL, run_index INTEGER NOT NULL, params TEXT NOT NULL, metrics TEXT,
    error TEXT, PRIMARY KEY (study_id, run_index));
"""


def connect(path):
    """Open (and create the tables of) the store at ``path`` (``:memory:`` allowed)."""
    db = sqlite3.connect(path, isolation_level=None, timeout=30.0, check_same_thread=False)
    if path != ":memory:":
        db.execute("PRAGMA journal_mode=WAL")
    db.execute("PRAGMA busy_timeout=30000")
    db.executescript(_SCHEMA)
    return db


def _json(obj):
    return json.dumps(obj, allow_nan=False, separators=(",", ":"))


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


def write_runs(db, study_id, rows):
    """Store finished runs in one transaction.

    Parameters
    ----------
    rows : list of (run_index, params dict, metrics dict or None, error str or None)
    """
    recs = [(study_id, int(i), _json({k: clean(v) for k, v in p.items()}),
             None if m is None else _json({k: clean(v) for k, v in m.items()}), err)
            for i, p, m, err in rows]
    db.execute("BEGIN IMMEDIATE")
    try:
        db.executemany("INSERT OR REPLACE INTO study_runs (study_id, run_index, params, metrics, error) "
                       "VALUES (?,?,?,?,?)", recs)
        db.execute("COMMIT")
    except BaseException:
        db.execute("ROLLBACK")
        raise


def load_runs(db, study_id):
    """All stored runs ordered by index: list of ``(index, params, metrics or None, error)``."""
    out = []
    for i, p, m, err in db.execute("SELECT run_index, params, metrics, error FROM study_runs "
                                   "WHERE study_id=? ORDER BY run_index", (study_id,)):
        out.append((i, json.loads(p), None if m is None else json.loads(m), err))
    return out


def list_studies(path):
    """Every study in the store: ``[{"id", "name", "created", "status", "n_runs", "stored", "failed"}]``."""
    from .study_def import Study
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
