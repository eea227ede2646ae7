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
import os
import sqlite3
import threading
import time
import uuid

import numpy as np
import orjson

from pneucore.analysis.history import ModelVersion, RefinementHistory
from pneucore.data.measurement import SIGNALS, Measurement, MeasurementError
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
    note TEXT NOT NULL DEFAULT '', experiments TEXT, PRIMARY KEY (session, version));
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE IF NOT EXISTS jobs (
    id TEXT PRIMARY KEY, kind TEXT NOT NULL, status TEXT NOT NULL, progress REAL NOT NULL,
    step TEXT NOT NULL, error TEXT, created REAL NOT NULL, started REAL, finished REAL,
    result BLOB);
"""


#: Columns added to a table after its first release: (table, column, SQL type). A database
#: written by an older version gets them (NULL in its old rows) when it is opened.
_ADDED_COLUMNS = (("versions", "experiments", "TEXT"),)


def _add_missing_columns(db):
    """Bring an older database's tables up to :data:`_SCHEMA` (``ALTER TABLE ... ADD COLUMN``)."""
    for table, column, kind in _ADDED_COLUMNS:
        have = {r[1] for r in db.execute(f"PRAGMA table_info({table})")}
        if column not in have:
            db.execute(f"ALTER TABLE {table} ADD COLUMN {column} {kind}")


class ReadOnly(Exception):
    """A write to a record that may not be changed (a shipped sample dataset)."""


class StoreUnavailable(Exception):
    """The database file cannot be opened or its tables created (a full disk, no permission)."""


class DamagedRecord(Exception):
    """A stored record that no longer decodes (written by hand, by a faulty disk, or by a
    version that stored it differently): the service answers 409 naming it, never an empty
    record, nor an error blamed on the request that only referred to it.

    Parameters
    ----------
    kind : str
        What the record is (``"dataset"``)
    key : str
        Its id
    cause : str
        What cannot be read
    sample : str or None
        The shipped sample it is, restored at the next start; None for a user's record
    """

    def __init__(self, kind, key, cause, sample=None):
        self.kind, self.key, self.cause, self.sample = kind, key, cause, sample
        remedy = ("it is a shipped sample: the next start of the server restores it" if sample
                  else f"delete it (DELETE /api/{kind}s/{key}) and store it again")
        super().__init__(f"the stored {kind} {key!r} is damaged ({cause}); nothing in the request "
                         f"is wrong; {remedy}")


class DatabaseInUse(StoreUnavailable):
    """Another live server holds the database (:class:`ServerLock`)."""


try:   # POSIX; elsewhere no lock is taken (README: one server per database)
    import fcntl
except ImportError:   # pragma: no cover - Windows
    fcntl = None


class ServerLock:
    """One server per database: an exclusive ``flock`` on ``<database>.lock``, held while the
    server lives.

    Two servers on one file would both resume the studies left running and compute them
    twice, and each would mark the other's jobs interrupted at its start. The kernel
    releases the lock when the holding process ends, however it ends (``kill -9`` too), so
    a stale lock file never blocks a restart; the file holds the holder's pid for the message.
    Re-entrant within a process (``python -m app`` takes it before uvicorn starts the app,
    whose lifespan takes it again); an in-memory database needs none.

    Parameters
    ----------
    db_path : str or os.PathLike
        The SQLite file the server serves
    """

    _held = {}                     # lock file -> [fd, holders] of this process
    _guard = threading.Lock()

    def __init__(self, db_path):
        self.db_path = str(db_path)
        self.path = None if self.db_path in ("", ":memory:") or fcntl is None \
            else os.path.abspath(self.db_path) + ".lock"
        self._acquired = False

    def acquire(self):
        """Take the lock; raises :class:`DatabaseInUse` naming the other server, or
        :class:`StoreUnavailable` when the lock file cannot be written."""
        if self.path is None or self._acquired:
            return self
        with self._guard:
            held = self._held.get(self.path)
            if held is not None:
                held[1] += 1
                self._acquired = True
                return self
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as exc:
                hint = "; free space on its disk, then start again" if disk_full(exc) else ""
                raise StoreUnavailable(f"the lock file {self.path!r} of the database cannot be "
                                       f"created ({type(exc).__name__}: {exc}){hint}") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                holder = os.pread(fd, 200, 0).decode("ascii", "replace").strip()
                os.close(fd)
                raise DatabaseInUse(
                    f"the database {self.db_path!r} is served by another running server "
                    f"({holder or 'pid unknown'}; lock {self.path!r}): one server per database, "
                    f"else both would run the same studies; stop that server, or give this one "
                    f"another file (PNEUCORE_DB)") from None
            try:
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"pid {os.getpid()}".encode(), 0)
            except OSError:
                pass   # the pid is for the message only (a full disk: the lock still holds)
            self._held[self.path] = [fd, 1]
            self._acquired = True
        return self

    def release(self):
        """Give the lock back (the file stays: removing it would race a starting server)."""
        if self.path is None or not self._acquired:
            return
        with self._guard:
            self._acquired = False
            held = self._held[self.path]
            held[1] -= 1
            if held[1] == 0:
                del self._held[self.path]
                os.close(held[0])   # closing the descriptor releases the flock

    def __enter__(self):
        return self.acquire()

    def __exit__(self, *exc):
        self.release()


#: SQLite's result code for a full disk or database (``SQLITE_FULL``, "database or disk is full")
SQLITE_FULL = 13


#: Storage faults a request can meet, by SQLite primary result code: (the fault's name, the
#: text SQLite gives it, the HTTP status, what to do). 507 for a full disk (the request may
#: succeed once space is freed); 503 for a storage that fails (the service is unavailable: the
#: request is not wrong, nor is it a bug of the server's code, so never 500)
STORAGE_FAULTS = {
    SQLITE_FULL: ("SQLITE_FULL", "database or disk is full", 507,
                  "the server's disk is full: nothing can be stored; deleting datasets, "
                  "sessions or studies still works, or free space on the server"),
    5: ("SQLITE_BUSY", "database is locked", 503, "the database is busy, try again"),
    6: ("SQLITE_LOCKED", "database table is locked", 503, "the database is busy, try again"),
    10: ("SQLITE_IOERR", "disk I/O error", 503,
         "the server's disk could not be read or written: its operator should check the disk "
         "(dmesg, SMART, a network file system that went away)"),
    11: ("SQLITE_CORRUPT", "database disk image is malformed", 503,
         "the database file is damaged: its operator should restore it from a backup "
         "(sqlite3 .recover)"),
    26: ("SQLITE_NOTADB", "file is not a database", 503,
         "the database file is damaged: its operator should restore it from a backup"),
    8: ("SQLITE_READONLY", "attempt to write a readonly database", 503,
        "the database cannot be written: its operator should check the permissions of the "
        "file and its directory"),
    14: ("SQLITE_CANTOPEN", "unable to open database file", 503,
         "the database file cannot be opened: its operator should check that its directory "
         "exists and can be written"),
}

#: The same faults met as an ``OSError`` (a file written beside the database), by errno
OS_FAULTS = {errno.ENOSPC: SQLITE_FULL, errno.EDQUOT: SQLITE_FULL, errno.EIO: 10, errno.EROFS: 8}


def storage_fault(exc):
    """Which storage fault ``exc`` is, as an entry of :data:`STORAGE_FAULTS`; None for any
    other error.

    Parameters
    ----------
    exc : BaseException
        A ``sqlite3.Error`` (its result code, else its text on Pythons that lack the code) or
        an ``OSError`` (its errno)

    Returns
    -------
    tuple or None
        ``(name, text, status, remedy)``
    """
    if isinstance(exc, sqlite3.Error):
        code = getattr(exc, "sqlite_errorcode", None)   # Python >= 3.11, raised by SQLite
        if code is not None:
            return STORAGE_FAULTS.get(code & 0xFF)
        text = str(exc)
        return next((f for f in STORAGE_FAULTS.values() if f[1] in text), None)
    if isinstance(exc, OSError):
        code = OS_FAULTS.get(exc.errno)
        return None if code is None else STORAGE_FAULTS[code]
    return None


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
    fault = storage_fault(exc)
    return fault is not None and fault[0] == "SQLITE_FULL"


def _loads(text, default):
    """Decode a stored JSON column; ``default`` when the row cannot be decoded."""
    try:
        return json.loads(text)
    except (TypeError, ValueError, RecursionError):
        return default


def _metadata_damage(signals_text, scenario_text):
    """What is wrong with a dataset row's JSON columns; None when both decode as they should."""
    signals, scenario = _loads(signals_text, None), _loads(scenario_text, None)
    if not isinstance(signals, list) or not all(isinstance(k, str) for k in signals):
        return "its list of signals is not a JSON list of names"
    if not isinstance(scenario, dict):
        return "its scenario is not a JSON object"
    return None


def _data_damage(blob, n_samples):
    """What is wrong with a dataset's stored measurement; ``(decoded, None)`` when it is a
    JSON object whose time and signals are lists of ``n_samples`` values."""
    try:
        d = orjson.loads(blob)
    except (orjson.JSONDecodeError, TypeError):
        return None, "its measurement is not valid JSON"
    if not isinstance(d, dict):
        return None, "its measurement is not a JSON object of columns"
    for k in ("t",) + tuple(k for k in SIGNALS if k in d):
        v = d.get(k)
        if not isinstance(v, list) or len(v) != n_samples:
            return None, (f"its column {k!r} is not a list of the {n_samples} samples the "
                          f"record declares")
        try:   # numbers or null (NaN), as the store writes them: a few ms for 200,000 samples
            np.asarray(v, dtype=np.float64)
        except (TypeError, ValueError):
            return None, f"its column {k!r} holds values that are not numbers"
    return d, None


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
            _add_missing_columns(db)
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
        """Store any shipped sample dataset that is missing or damaged; returns how many were
        restored.

        Samples are read-only (:meth:`delete_dataset` refuses them), so a missing one was
        removed by an older version or by hand, and a damaged one (a row that no longer
        decodes: :class:`DamagedRecord`) changed by hand or by a faulty disk: either comes
        back at the next start.
        """
        with self._lock:
            rows = self._db.execute("SELECT id, n_samples, signals, scenario, data FROM datasets "
                                    "WHERE sample IS NOT NULL").fetchall()
        # a damaged one (a row changed by hand or by a faulty disk) is written again
        have = {r[0] for r in rows if _metadata_damage(r[2], r[3]) is None
                and _data_damage(r[4], r[1])[1] is None}
        del rows
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
        """The info of a dataset row; a damaged one lists as such (``damaged``: what is wrong)
        with empty signals and scenario, and never makes a whole listing fail."""
        damage = _metadata_damage(row[4], row[5])
        info = {"id": row[0], "name": row[1], "created": row[2], "n_samples": row[3],
                "signals": [], "scenario": {}, "description": row[6], "sample": row[7],
                "damaged": damage}
        if damage is None:
            info["signals"], info["scenario"] = _loads(row[4], []), _loads(row[5], {})
        return info

    def checked_dataset_info(self, did):
        """:meth:`dataset_info`, raising :class:`DamagedRecord` for a damaged row; None when
        there is none."""
        info = self.dataset_info(did)
        if info is not None and info["damaged"]:
            raise DamagedRecord("dataset", did, info["damaged"], info["sample"])
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
        """The stored measurement of dataset ``did`` as decoded JSON (``{"t": [...], ...}``);
        None when there is none. Raises :class:`DamagedRecord` when its row no longer decodes."""
        with self._lock:
            row = self._db.execute("SELECT data, n_samples, signals, scenario, sample FROM datasets "
                                   "WHERE id=?", (did,)).fetchone()
        if row is None:
            return None
        d, damage = _data_damage(row[0], row[1])
        damage = damage or _metadata_damage(row[2], row[3])
        if damage:
            raise DamagedRecord("dataset", did, damage, row[4])
        return d

    def measurement(self, did):
        """Dataset ``did`` as a :class:`Measurement`; None when there is none. Raises
        :class:`DamagedRecord` when its row no longer decodes or is no valid measurement."""
        d = self.dataset_data(did)
        if d is None:
            return None
        try:
            return Measurement.from_dict(d)
        except MeasurementError as exc:   # stored values no measurement has (changed by hand)
            raise DamagedRecord("dataset", did, f"its measurement is invalid: {exc}",
                                (self.dataset_info(did) or {}).get("sample")) from None

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
        model : pneucore.description.model.Model
            The starting model (validated)
        comparison : tuple or None
            Its errors ``(errors, overall)`` on the experiments (:func:`pneucore.analysis.compare.errors`),
            None without experiments
        """
        sid = uuid.uuid4().hex[:12]

        def tx(db):
            db.execute("INSERT INTO sessions VALUES (?,?,?,?)",
                       (sid, name, time.time(), _dumps(experiments)))
            self._insert_version(db, sid, RefinementHistory().add(model, comparison), experiments)
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
    def _insert_version(db, sid, v, experiments):
        """Write a :class:`ModelVersion` (its ISO time stored as Unix epoch seconds) with the
        experiments its errors were computed on."""
        overall = v.overall if v.overall is None or math.isfinite(v.overall) else None
        db.execute("INSERT INTO versions (session, version, label, created, model, errors, overall, added, "
                   "params, note, experiments) VALUES (?,?,?,?,?,?,?,?,?,?,?)",
                   (sid, v.version, v.label, _dt.datetime.fromisoformat(v.created).timestamp(),
                    _dumps(v.model), _dumps(v.errors), overall, v.added, _dumps(v.params or {}), v.note,
                    _dumps(experiments)))
        return v.version

    def add_version(self, sid, model, comparison=None, added=None, params=None, note="", experiments=None):
        """Record the next version of session ``sid``; returns its number.

        The session's history is read and extended by :meth:`RefinementHistory.add` inside
        the write transaction, so two concurrent writers never get the same number.

        Parameters
        ----------
        sid : str
            Session id
        model : pneucore.description.model.Model
            The new version's model (validated)
        comparison : tuple or None
            Its errors ``(errors, overall)``, None without experiments
        added : str or None
            Catalog effect added at this step
        params : dict or None
            Its fitted parameters (validated JSON)
        note : str
            Free text
        experiments : list of dict or None
            The session's new set of experiments (validated JSON), from this version on; None =
            the set stays. The session stays one across a change of its data: each version
            records the set its errors were computed on.
        """
        def tx(db):
            if experiments is not None:
                db.execute("UPDATE sessions SET experiments=? WHERE id=?", (_dumps(experiments), sid))
            exps = experiments
            if exps is None:
                row = db.execute("SELECT experiments FROM sessions WHERE id=?", (sid,)).fetchone()
                exps = _loads(row[0], None) if row else None
            v = self._history(db, sid).add(model, comparison, added, params, note)
            return self._insert_version(db, sid, v, exps)
        return self._tx(tx)

    def session(self, sid):
        with self._lock:
            row = self._db.execute("SELECT id, name, created, experiments FROM sessions WHERE id=?",
                                   (sid,)).fetchone()
            if row is None:
                return None
            vers = self._db.execute("SELECT version, label, created, model, errors, overall, added, params, "
                                    "note, experiments FROM versions WHERE session=? ORDER BY version",
                                    (sid,)).fetchall()
        experiments = _loads(row[3], None)
        if not isinstance(experiments, list):
            # the session's own row no longer decodes (changed by hand, a faulty disk): answered
            # as damaged; a damaged version reads as it can (model null), the others stay usable
            raise DamagedRecord("session", sid, "its experiments are not a JSON list")
        return {"id": row[0], "name": row[1], "created": row[2], "experiments": experiments,
                "versions": [{"version": v[0], "label": v[1], "created": v[2], "model": _loads(v[3], None),
                              "errors": _loads(v[4], {}), "overall": v[5], "added": v[6],
                              "params": _loads(v[7], {}), "note": v[8], "experiments": _loads(v[9], None)}
                             for v in vers]}

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
