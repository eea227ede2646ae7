"""The service's store shares its SQLite file with the studies' writer: a write transaction
must not fail with "database is locked" because another writer committed while it was reading
(a 500 the fuzz test found while a study stored its runs)."""
import sqlite3

from app.store import Store


def test_a_transaction_that_reads_then_writes_survives_another_writer(tmp_path):
    path = str(tmp_path / "s.sqlite3")
    store = Store(path)
    other = sqlite3.connect(path, isolation_level=None, timeout=0)   # a study's writer, not waiting
    other.execute("CREATE TABLE runs (x)")
    seen = {}

    def read_then_write(db):
        seen["before"] = db.execute("SELECT count(*) FROM sessions").fetchone()[0]
        try:   # the other writer commits between our read and our write...
            other.execute("INSERT INTO runs VALUES (1)")
            seen["other"] = "wrote"
        except sqlite3.OperationalError:
            seen["other"] = "waits"   # ...or finds the write lock already ours, and waits its turn
        db.execute("INSERT INTO sessions VALUES ('s1', 'x', 0, '[]')")
    # a deferred BEGIN reads a snapshot, then cannot upgrade once the other writer has
    # committed: sqlite3.OperationalError "database is locked" at once, whatever the timeout
    store._tx(read_then_write)
    assert seen == {"before": 0, "other": "waits"}
    assert store.session("s1")["name"] == "x"
    other.close()
    store.close()
