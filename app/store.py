"""SQLite store: datasets (measurements with their context) and refinement sessions.

Each write is one transaction, so a failed request never leaves a
half-written dataset; the file survives restarts. On first start the sample
datasets shipped with pneucore are loaded.
"""
from __future__ import annotations

import json
import sqlite3
import threading
import time
import uuid

import orjson

from pneucore.measurement import Measurement
from pneucore.samples import DATA_DIR, list_samples
from pneucore.measurement import read_csv

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
"""


class Store:
    """Thread-safe SQLite store (one connection, serialised by a lock)."""

    def __init__(self, path):
        self.path = path
        self._lock = threading.RLock()   # reads too: one connection shared by threads
        self._db = sqlite3.connect(path, check_same_thread=False, isolation_level=None)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.executescript(_SCHEMA)

    def close(self):
        with self._lock:
            self._db.close()

    def _tx(self, fn):
        with self._lock:
            self._db.execute("BEGIN")
            try:
                out = fn(self._db)
                self._db.execute("COMMIT")
                return out
            except BaseException:
                self._db.execute("ROLLBACK")
                raise

    # -- samples ------------------------------------------------------------------
    def seed_samples(self):
        """Load the shipped sample datasets once (remembered in the meta table)."""
        row = self._db.execute("SELECT value FROM meta WHERE key='samples_seeded'").fetchone()
        if row:
            return 0
        n = 0
        for s in list_samples():
            for e in s["experiments"]:
                meas = read_csv(DATA_DIR / e["file"], name=f"{s['id']} / {e['name']}")
                self.add_dataset(meas, e["scenario"], name=f"{s['id']} / {e['name']}",
                                 description=s["description"], sample=s["id"],
                                 dataset_id=f"sample-{s['id']}-{e['name']}")
                n += 1
        self._tx(lambda db: db.execute("INSERT OR REPLACE INTO meta VALUES ('samples_seeded', '1')"))
        return n

    # -- datasets -------------------------------------------------------------------
    def add_dataset(self, meas: Measurement, scenario=None, name=None, description="", sample=None,
                    dataset_id=None):
        did = dataset_id or uuid.uuid4().hex[:12]
        data = orjson.dumps(meas.to_dict(), option=orjson.OPT_SERIALIZE_NUMPY)
        rec = (did, name or meas.name or did, time.time(), int(meas.n),
               json.dumps(list(meas.measured_signals)), json.dumps(scenario or {}), description,
               sample, data)
        self._tx(lambda db: db.execute("INSERT OR REPLACE INTO datasets VALUES (?,?,?,?,?,?,?,?,?)", rec))
        return self.dataset_info(did)

    def dataset_info(self, did):
        with self._lock:
            row = self._db.execute("SELECT id, name, created, n_samples, signals, scenario, description, "
                                   "sample FROM datasets WHERE id=?", (did,)).fetchone()
            if row is None:
                return None
            return {"id": row[0], "name": row[1], "created": row[2], "n_samples": row[3],
                    "signals": json.loads(row[4]), "scenario": json.loads(row[5]),
                    "description": row[6], "sample": row[7]}

    def list_datasets(self):
        with self._lock:
            rows = self._db.execute("SELECT id FROM datasets ORDER BY sample IS NULL, created, id").fetchall()
            return [self.dataset_info(r[0]) for r in rows]

    def dataset_data(self, did):
        with self._lock:
            row = self._db.execute("SELECT data FROM datasets WHERE id=?", (did,)).fetchone()
            return None if row is None else orjson.loads(row[0])

    def measurement(self, did):
        d = self.dataset_data(did)
        if d is None:
            return None
        return Measurement.from_dict(d)

    def delete_dataset(self, did):
        return self._tx(lambda db: db.execute("DELETE FROM datasets WHERE id=?", (did,)).rowcount) > 0

    # -- refinement sessions ---------------------------------------------------------------
    def create_session(self, name, experiments):
        sid = uuid.uuid4().hex[:12]
        self._tx(lambda db: db.execute("INSERT INTO sessions VALUES (?,?,?,?)",
                                       (sid, name, time.time(), json.dumps(experiments))))
        return sid

    def add_version(self, sid, label, model, errors, overall, added=None, params=None, note=""):
        def tx(db):
            n = db.execute("SELECT COUNT(*) FROM versions WHERE session=?", (sid,)).fetchone()[0]
            db.execute("INSERT INTO versions VALUES (?,?,?,?,?,?,?,?,?,?)",
                       (sid, n, label, time.time(), json.dumps(model), json.dumps(errors), overall,
                        added, json.dumps(params or {}), note))
            return n
        return self._tx(tx)

    def session(self, sid):
        with self._lock:
            row = self._db.execute("SELECT id, name, created, experiments FROM sessions WHERE id=?",
                                   (sid,)).fetchone()
            if row is None:
                return None
            vers = self._db.execute("SELECT version, label, created, model, errors, overall, added, params, "
                                    "note FROM versions WHERE session=? ORDER BY version", (sid,)).fetchall()
            return {"id": row[0], "name": row[1], "created": row[2], "experiments": json.loads(row[3]),
                    "versions": [{"version": v[0], "label": v[1], "created": v[2], "model": json.loads(v[3]),
                                  "errors": json.loads(v[4]), "overall": v[5], "added": v[6],
                                  "params": json.loads(v[7]), "note": v[8]} for v in vers]}

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
