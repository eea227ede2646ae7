"""SQLite store: datasets (measurements with their context), refinement sessions, job records.

The routers validate every field before calling a write here, and each write
is one transaction, so a failed request never leaves a half-written record;
the file survives restarts. Reads decode row by row: a row that cannot be
decoded (written by an older version, or damaged) is reported as such and
never makes a whole listing fail. The sample datasets shipped with pneucore
are read-only and any missing one is restored at every start.
"""
from __future__ import annotations

import datetime as _dt
import errno
import json
import math
import sqlite3
import threading
import time
import uuid

import numpy as np
import orjson

from pneucore.analysis.history import ModelVersion, RefinementHistory
from pneucore.data.measurement import SIGNALS, Measurement
from pneucore.data.samples import DATA_DIR, list_samples
from pneucore.data.measurement import read_csv


def _dumps(value):
    """JSON text of a validated value; a stray NaN is written as null, never as a bare token."""
    return orjson.dumps(value, option=orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS).decode()

_SCHEMA = """
CREATE TABLE IF NOT EXISTS datasets (
    id TEXT PRIMARY KEY, name TEXT NOT NULL, created REAL NOT NULL,
    n_samples INTEGER NOT NULL, signals TEXT NOT NULL, scenario TEXT NOT NULL,
    description TEXT NOT NULL DEFAULT '', sample TEXT, data BLOB NOT NULL);
CREATE TABLE IF NOT EXISTS sessions (
    id TEXT PRIMARY KEY, name TEXT NOT NULL, created REAL NOT NULL, experiments TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS versions (
    session TEXT NOT NULL, version INTEGER NOT NULL, label TEXT NOT NULL, created REAL NOT NULL,
    model TEXT NOT NULL, errors TEXT NOT NULL, overall REAL, added TEXT, params TEXT NOT NULL,
    note TEXT NOT NULL DEFAULT '', PRIMARY KEY (session, version));
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE IF NOT EXISTS jobs (
    id TEXT PRIMARY KEY, kind TEXT NOT NULL, status TEXT NOT NULL, progress REAL NOT NULL,
    step TEXT NOT NULL, error TEXT, created REAL NOT NULL, started REAL, finished REAL,
    result BLOB);
"""


class ReadOnly(Exception):
    """A write to a record that may not be changed (a shipped sample dataset)."""


class StoreUnavailable(Exception):
    """The database file cannot be opened or its tables created (a full disk, no permission)."""


#: SQLite's result code for a full disk or database (``SQLITE_FULL``, "database or disk is full")
SQLITE_FULL = 13


def disk_full(exc) -> bool:
    """Whether ``exc`` says the disk (or the database's page limit) is full.

    Parameters
    ----------
    exc : BaseException
        A ``sqlite3.Error`` (``SQLITE_FULL``) or an ``OSError`` (``ENOSPC``, ``EDQUOT``)

    Returns
    -------
    bool
        True for a full disk, a full quota or a database at its page limit
    """
    if isinstance(exc, sqlite3.Error):
        code = getattr(exc, "sqlite_errorcode", None)   # Python >= 3.11
        if code is not None:
            return code & 0xFF == SQLITE_FULL
        return "database or disk is full" in str(exc)
    return isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT)


def _loads(text, default):
    """Decode a stored JSON column; ``default`` when the row cannot be decoded."""
    try:
        return json.loads(text)
    except (TypeError, ValueError, RecursionError):
        return default


def _iso(epoch):
    """ISO 8601 text of a stored Unix time; ``""`` when the stored value is not a time."""
    try:
        return _dt.datetime.fromtimestamp(epoch, _dt.timezone.utc).isoformat()
    except (TypeError, ValueError, OverflowError, OSError):
        return ""


#: How long a write waits for another writer of the same file (a study storing its runs, a
#: second server) before failing [s]; the study store waits as long (pneucore.study.store)
BUSY_TIMEOUT_S = 30.0


class Store:
    """Thread-safe SQLite store (one connection, serialised by a lock)."""

    def __init__(self, path):
        self.path = path
        self._lock = threading.RLock()   # reads too: one connection shared by threads
        try:
            self._db = self._connect(path)
        except (sqlite3.Error, OSError) as exc:
            cause = f"{type(exc).__module__}.{type(exc).__name__}: {exc}"
            hint = "; free space on its disk, then start again" if disk_full(exc) else ""
            raise StoreUnavailable(f"the database {str(path)!r} cannot be opened ({cause}){hint}") \
                from None

    @staticmethod
    def _connect(path):
        """Open ``path`` (WAL journal) and create the tables it lacks; returns the connection."""
        db = sqlite3.connect(path, check_same_thread=False, isolation_level=None,
                             timeout=BUSY_TIMEOUT_S)
        try:
            db.execute("PRAGMA journal_mode=WAL")
            db.executescript(_SCHEMA)
        except BaseException:
            db.close()
            raise
        return db

    def close(self):
        with self._lock:
            self._db.close()

    def _tx(self, fn):
        with self._lock:
            # IMMEDIATE: the write lock is taken (waiting up to BUSY_TIMEOUT_S) before the first
            # read; a deferred BEGIN fails at once when it upgrades while a study is writing
            self._db.execute("BEGIN IMMEDIATE")
            try:
                out = fn(self._db)
                self._db.execute("COMMIT")
                return out
            except BaseException:
                # SQLite has already rolled back after some errors (SQLITE_FULL among them):
                # a second ROLLBACK would fail with "cannot rollback - no transaction is
                # active" and hide the cause, which is what propagates
                if self._db.in_transaction:
                    try:
                        self._db.execute("ROLLBACK")
                    except sqlite3.Error:
                        pass
                raise

    # -- samples ------------------------------------------------------------------
    def seed_samples(self):
        """Store any shipped sample dataset that is missing; returns how many were restored.

        Samples are read-only (:meth:`delete_dataset` refuses them), so a missing one was
        removed by an older version or by hand: it comes back at the next start.
        """
        with self._lock:
            have = {r[0] for r in self._db.execute("SELECT id FROM datasets WHERE sample IS NOT NULL")}
        n = 0
        for s in list_samples():
            for e in s["experiments"]:
                did = f"sample-{s['id']}-{e['name']}"
                if did in have:
                    continue
                meas = read_csv(DATA_DIR / e["file"], name=f"{s['id']} / {e['name']}")
                self.add_dataset(meas, e["scenario"], name=f"{s['id']} / {e['name']}",
                                 description=s["description"], sample=s["id"], dataset_id=did)
                n += 1
        return n

    # -- datasets -------------------------------------------------------------------
    def add_dataset(self, meas: Measurement, scenario=None, name=None, description="", sample=None,
                    dataset_id=None):
        did = dataset_id or uuid.uuid4().hex[:12]
        # the arrays written as they are (orjson writes NaN as null, as Measurement.to_dict does):
        # no list of Python floats, several times the size of the text, on the way
        d = {"t": np.ascontiguousarray(meas.t, dtype=np.float64)}
        d.update((k, np.ascontiguousarray(meas.signals[k], dtype=np.float64))
                 for k in SIGNALS if k in meas.signals)
        if meas.name:
            d["name"] = meas.name
        sensors = (meas.meta.get("import") or {}).get("conversions")
        if sensors:   # how each column was read (unit, gain, offset): the record's provenance
            d["meta"] = {"sensors": sensors}
        data = orjson.dumps(d, option=orjson.OPT_SERIALIZE_NUMPY)
        del d
        rec = (did, name or meas.name or did, time.time(), int(meas.n),
               json.dumps(list(meas.measured_signals)), _dumps(scenario or {}), description,
               sample, data)
        self._tx(lambda db: db.execute("INSERT OR REPLACE INTO datasets VALUES (?,?,?,?,?,?,?,?,?)", rec))
        return self.dataset_info(did)

    @staticmethod
    def _dataset_row(row):
        info = {"id": row[0], "name": row[1], "created": row[2], "n_samples": row[3],
                "signals": _loads(row[4], []), "scenario": _loads(row[5], {}),
                "description": row[6], "sample": row[7]}
        if not isinstance(info["signals"], list) or not isinstance(info["scenario"], dict):
            info["signals"], info["scenario"] = [], {}
        return info

    def dataset_info(self, did):
        with self._lock:
            row = self._db.execute("SELECT id, name, created, n_samples, signals, scenario, description, "
                                   "sample FROM datasets WHERE id=?", (did,)).fetchone()
            return None if row is None else self._dataset_row(row)

    def list_datasets(self):
        with self._lock:
            rows = self._db.execute("SELECT id, name, created, n_samples, signals, scenario, description, "
                                    "sample FROM datasets ORDER BY sample IS NULL, created, id").fetchall()
        return [self._dataset_row(r) for r in rows]

    def dataset_data(self, did):
        with self._lock:
            row = self._db.execute("SELECT data FROM datasets WHERE id=?", (did,)).fetchone()
        if row is None:
            return None
        try:
            return orjson.loads(row[0])
        except orjson.JSONDecodeError:
            return {}   # a damaged row: Measurement.from_dict names what is missing

    def measurement(self, did):
        d = self.dataset_data(did)
        if d is None:
            return None
        return Measurement.from_dict(d)

    def delete_dataset(self, did):
        """Delete a dataset; False when there is none. Raises :class:`ReadOnly` for a sample."""
        def tx(db):
            row = db.execute("SELECT sample FROM datasets WHERE id=?", (did,)).fetchone()
            if row is not None and row[0] is not None:
                raise ReadOnly(f"dataset {did!r} is a shipped sample and is read-only")
            return db.execute("DELETE FROM datasets WHERE id=?", (did,)).rowcount
        return self._tx(tx) > 0

    # -- refinement sessions ---------------------------------------------------------------
    # A session's versions are a pneucore.analysis.history.RefinementHistory: the history numbers and
    # labels each version (base, + <effect>, version <n>); the store only persists it.
    def create_session(self, name, experiments, model, comparison=None):
        """A new session whose version 0 is ``model``, written in the same transaction.

        Parameters
        ----------
        name : str
            Label
        experiments : list of dict
            The experiments every version is compared with (validated JSON)
        model : pneucore.spec.model.Model
            The starting model (validated)
        comparison : tuple or None
            Its errors ``(errors, overall)`` on the experiments (:func:`pneucore.analysis.compare.errors`),
            None without experiments
        """
        sid = uuid.uuid4().hex[:12]

        def tx(db):
            db.execute("INSERT INTO sessions VALUES (?,?,?,?)",
                       (sid, name, time.time(), _dumps(experiments)))
            self._insert_version(db, sid, RefinementHistory().add(model, comparison))
        self._tx(tx)
        return sid

    @staticmethod
    def _history(db, sid):
        """The stored versions of session ``sid`` as a :class:`RefinementHistory`."""
        rows = db.execute("SELECT version, label, created, model, errors, overall, added, params, note "
                          "FROM versions WHERE session=? ORDER BY version", (sid,)).fetchall()
        return RefinementHistory([
            ModelVersion(v[0], v[1], _loads(v[3], None), _loads(v[4], {}), v[5], v[6], _loads(v[7], {}),
                         v[8], _iso(v[2]))
            for v in rows])

    @staticmethod
    def _insert_version(db, sid, v):
        """Write a :class:`ModelVersion` (its ISO time stored as Unix epoch seconds)."""
        overall = v.overall if v.overall is None or math.isfinite(v.overall) else None
        db.execute("INSERT INTO versions VALUES (?,?,?,?,?,?,?,?,?,?)",
                   (sid, v.version, v.label, _dt.datetime.fromisoformat(v.created).timestamp(),
                    _dumps(v.model), _dumps(v.errors), overall, v.added, _dumps(v.params or {}), v.note))
        return v.version

    def add_version(self, sid, model, comparison=None, added=None, params=None, note=""):
        """Record the next version of session ``sid``; returns its number.

        The session's history is read and extended by :meth:`RefinementHistory.add` inside
        the write transaction, so two concurrent writers never get the same number.

        Parameters
        ----------
        sid : str
            Session id
        model : pneucore.spec.model.Model
            The new version's model (validated)
        comparison : tuple or None
            Its errors ``(errors, overall)``, None without experiments
        added : str or None
            Catalog effect added at this step
        params : dict or None
            Its fitted parameters (validated JSON)
        note : str
            Free text
        """
        def tx(db):
            v = self._history(db, sid).add(model, comparison, added, params, note)
            return self._insert_version(db, sid, v)
        return self._tx(tx)

    def session(self, sid):
        with self._lock:
            row = self._db.execute("SELECT id, name, created, experiments FROM sessions WHERE id=?",
                                   (sid,)).fetchone()
            if row is None:
                return None
            vers = self._db.execute("SELECT version, label, created, model, errors, overall, added, params, "
                                    "note FROM versions WHERE session=? ORDER BY version", (sid,)).fetchall()
        return {"id": row[0], "name": row[1], "created": row[2], "experiments": _loads(row[3], []),
                "versions": [{"version": v[0], "label": v[1], "created": v[2], "model": _loads(v[3], None),
                              "errors": _loads(v[4], {}), "overall": v[5], "added": v[6],
                              "params": _loads(v[7], {}), "note": v[8]} for v in vers]}

    def list_sessions(self):
        with self._lock:
            rows = self._db.execute("SELECT s.id, s.name, s.created, COUNT(v.version) FROM sessions s "
                                    "LEFT JOIN versions v ON v.session = s.id GROUP BY s.id "
                                    "ORDER BY s.created").fetchall()
            return [{"id": r[0], "name": r[1], "created": r[2], "n_versions": r[3]} for r in rows]

    def delete_session(self, sid):
        def tx(db):
            db.execute("DELETE FROM versions WHERE session=?", (sid,))
            return db.execute("DELETE FROM sessions WHERE id=?", (sid,)).rowcount
        return self._tx(tx) > 0

    # -- job records -------------------------------------------------------------------
    _JOB_FIELDS = ("id", "kind", "status", "progress", "step", "error", "created", "started",
                   "finished")

    def save_job(self, job):
        """Insert or update a job record (``job``: its ``to_dict``; ``result`` only when finished)."""
        row = tuple(job.get(k) for k in self._JOB_FIELDS)
        if "result" in job:
            blob = orjson.dumps(job["result"], option=orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS)
            self._tx(lambda db: db.execute("INSERT OR REPLACE INTO jobs VALUES (?,?,?,?,?,?,?,?,?,?)",
                                           row + (blob,)))
        else:
            self._tx(lambda db: db.execute(
                "INSERT INTO jobs VALUES (?,?,?,?,?,?,?,?,?,NULL) ON CONFLICT(id) DO UPDATE SET "
                "status=excluded.status, progress=excluded.progress, step=excluded.step, "
                "error=excluded.error, started=excluded.started, finished=excluded.finished", row))

    def job(self, jid):
        """A stored job record as a dict (with its result), or None."""
        with self._lock:
            row = self._db.execute(f"SELECT {', '.join(self._JOB_FIELDS)}, result FROM jobs WHERE id=?",
                                   (jid,)).fetchone()
        if row is None:
            return None
        d = dict(zip(self._JOB_FIELDS, row[:-1]))
        try:
            d["result"] = None if row[-1] is None else orjson.loads(row[-1])
        except orjson.JSONDecodeError:
            d["result"] = None
        return d

    def interrupt_jobs(self):
        """Mark the jobs left queued or running (by a server that stopped) as interrupted."""
        return self._tx(lambda db: db.execute(
            "UPDATE jobs SET status='interrupted', error='the server stopped while the job was ' "
            "|| status || ' (at: ' || step || '); submit it again', finished=COALESCE(finished, ?) "
            "WHERE status IN ('queued', 'running')", (time.time(),)).rowcount)
