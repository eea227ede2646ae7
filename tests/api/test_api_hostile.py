"""Hostile load and faults (issue 30): exports a spreadsheet cannot execute, a memory budget per
request, bounded form fields and names, server limits, a full disk, a bounded synchronous pool."""
from __future__ import annotations

import csv
import io

import pytest

from api_conftest import (client, db_path, inline_experiment, model, small_csv)  # noqa: F401
from pneucore.data.export import FORMULA_STARTS, simulation_csv, spreadsheet_safe

#: Names a spreadsheet would run as formulas (OWASP's CSV injection examples)
FORMULA_NAMES = ["=1+2", "@SUM(1+1)*cmd|' /C calc'!A0", "+1", "-2+3", "\tx", "\r=1"]


def _text_cells_are_safe(text):
    """Every cell of a CSV text that is not a number starts with no formula character."""
    for row in csv.reader(io.StringIO(text)):
        for cell in row:
            try:
                float(cell)
                continue   # numbers untouched: -1.5 stays a number
            except ValueError:
                pass
            assert not cell.startswith(FORMULA_STARTS), (cell, row)


# ------------------------------------------------------------------ (4) formula injection
@pytest.mark.parametrize("name", FORMULA_NAMES)
def test_spreadsheet_safe_quotes_formula_cells(name):
    assert spreadsheet_safe(name) == "'" + name
    assert spreadsheet_safe("run 1") == "run 1"


def test_simulation_csv_text_cells_are_neutralised_numbers_untouched():
    text = simulation_csv({"series": {"t": [0.0, 1.0], "x": [-1.5, 2.0], "mode": ["=cmd", "stick"],
                                      "=bad": [1.0, -2.0]},
                           "units": {"t": "s", "x": "m", "mode": "-", "=bad": "-"}})
    _text_cells_are_safe(text)
    rows = list(csv.reader(io.StringIO(text)))
    assert rows[2][1] == "-1.5" and rows[2][2] == "'=cmd"


@pytest.mark.parametrize("name", FORMULA_NAMES[:2])
def test_comparison_csv_neutralises_experiment_and_dataset_names(client, name):
    exp = inline_experiment("clean", "free-pulses")
    exp["name"] = name
    r = client.post("/api/compare", json={"model": model(), "experiments": [exp]},
                    headers={"accept": "text/csv"})
    assert r.status_code == 200, r.text[:500]
    _text_cells_are_safe(r.text)
    rows = list(csv.reader(io.StringIO(r.text)))
    assert rows[2][0] == "'" + name and float(rows[2][1]) == pytest.approx(float(rows[2][1]))
    # a stored dataset named so
    up = client.post("/api/datasets", files={"file": ("a.csv", small_csv(40), "text/csv")},
                     data={"name": name})
    assert up.status_code in (200, 201), up.text
    r = client.post("/api/compare", json={"model": model(), "experiments": [
        {"dataset_id": up.json()["id"]}]}, headers={"accept": "text/csv"})
    assert r.status_code == 200, r.text[:500]
    _text_cells_are_safe(r.text)


def test_study_runs_csv_neutralises_error_messages(monkeypatch):
    """A failed run's message (text the solver or a user law wrote) cannot start a formula."""
    from types import SimpleNamespace

    import numpy as np

    from pneucore.study import results
    block = SimpleNamespace(indices=np.array([0, 1]), params=np.array([[-1.5], [2.0]]),
                            metrics=np.array([[np.nan], [3.0]]), errors=["=HYPERLINK(1)", None])
    monkeypatch.setattr(results, "_stored_runs",
                        lambda *a: (["supply.pressure"], ["t95"], ["s"], block))
    text = "".join(results.runs_csv("unused", "s1"))
    _text_cells_are_safe(text)
    rows = list(csv.reader(io.StringIO(text)))
    assert rows[1][1] == "-1.5" and rows[1][-1] == "'=HYPERLINK(1)"


# ------------------------------------------------------------------ (1) a memory budget per request
def _npz(**arrays):
    import numpy as np
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def test_the_memory_budget_is_a_limit_and_refuses_an_archive_before_reading(db_path):
    import numpy as np

    from api_conftest import api
    data = _npz(t=np.arange(50_000) * 1e-4, u=np.ones(50_000), p_a=np.full(50_000, 2e5))
    with api(db_path, max_request_memory=1_000_000) as c:
        assert c.get("/api/limits").json()["max_request_memory"] == 1_000_000
        r = c.post("/api/datasets", files={"file": ("a.npz", data, "application/x-npz")})
        assert r.status_code == 422 and "max_request_memory" in r.text, r.text
    with api(db_path) as c:
        r = c.post("/api/datasets", files={"file": ("a.npz", data, "application/x-npz")})
        assert r.status_code == 201, r.text


# ------------------------------------------------------------------ (6) fields, names, counts
def _up(c, **fields):
    return c.post("/api/datasets", files={"file": ("a.csv", small_csv(), "text/csv")},
                  data={k: str(v) for k, v in fields.items()})


@pytest.mark.parametrize("key", ["columns", "scenario"])
def test_deep_or_long_json_form_fields_are_422_naming_the_field(client, key):
    from api_conftest import assert_field_error
    assert_field_error(_up(client, **{key: "[" * 5000 + "]" * 5000}), key, msg_contains="max_json_depth")
    assert_field_error(_up(client, **{key: '{"a": "' + "x" * 300_000 + '"}'}), key,
                       msg_contains="max_form_field_bytes")


@pytest.mark.parametrize("name", ["x" * 201, "a\nb", "a\x1b[31mb", "a\tb"])
def test_names_are_bounded_and_free_of_control_characters(client, name):
    from api_conftest import assert_field_error, inline_experiment
    assert_field_error(_up(client, name=name), "name")
    r = client.post("/api/datasets", json={"name": name, "measurement": inline_experiment(
        "clean", "free-pulses")["measurement"]})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "name", r.text[:300]
    r = client.post("/api/sessions", json={"name": name, "model": model()})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "name", r.text[:300]
    if len(name) < 10:   # said in words, not as the pattern's regular expression
        assert "control character" in r.json()["detail"][0]["msg"], r.text[:300]
    assert _up(client, name="ok name").status_code == 201


@pytest.mark.parametrize("text", ["line one\r\nline two", "a\x00b", "a\nb"])
def test_descriptions_refuse_cr_lf_and_nul_naming_the_field(client, text):
    """Issue 24: a description reaches the same logs, reports and CSV headers as a name."""
    from api_conftest import assert_field_error
    assert_field_error(_up(client, description=text), "description")
    m = model()
    m["description"] = text
    r = client.post("/api/simulate", json={"model": m, "scenario": {"duration": 0.01}})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "model.description", r.text[:300]
    assert "control character" in r.json()["detail"][0]["msg"], r.text[:300]
    assert _up(client, description="a plain description").status_code == 201


@pytest.mark.parametrize("nfev", [-1, 0, 10_000])
def test_max_nfev_out_of_range_is_422(client, nfev):
    r = client.post("/api/calibrate", json={"model": model(), "experiments": [
        {"dataset_id": "sample-clean-free-pulses"}], "parameters": {"friction.extend.fc0": {}},
        "max_nfev": nfev})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "max_nfev", r.text[:300]


def test_a_token_in_the_query_never_reaches_the_access_log():
    """uvicorn's access line is written from the request's scope: the guard redacts the token in
    it before anything answers (the login's 303, a refusal, any route)."""
    import asyncio

    from app.security import Guard
    seen = {}

    async def inner(scope, receive, send):
        seen["inner"] = scope["query_string"]

    async def send(message):
        pass
    for path, query in (("/", b"token=s3cret"), ("/api/limits", b"token=s3cret&x=1")):
        scope = {"type": "http", "method": "GET", "path": path, "query_string": query,
                 "headers": [(b"host", b"127.0.0.1")], "scheme": "http"}
        asyncio.run(Guard(inner, ["127.0.0.1"], token="s3cret")(scope, None, send))
        assert b"s3cret" not in scope["query_string"]


@pytest.mark.parametrize("query, logged", [
    (b"token=s3cret", b"token=redacted"),
    (b"token=s3cret&x=1", b"token=redacted&x=1"),
    (b"a=%C3%A9&token=s3cret&b=2&b=3", b"a=%C3%A9&token=redacted&b=2&b=3"),
    (b"to%6Ben=s3cret&tokens=kept", b"token=redacted&tokens=kept"),   # an encoded name too
    (b"x=1&token=s3cret&token=again", b"x=1&token=redacted&token=redacted"),
])
def test_the_token_redaction_keeps_the_rest_of_the_query(query, logged):
    """Only the token's value leaves the access log; the other parameters stay to read there."""
    import asyncio

    from app.security import Guard
    seen = {}

    async def inner(scope, receive, send):
        seen["query"] = scope["query_string"]

    async def send(message):
        pass
    scope = {"type": "http", "method": "GET", "path": "/api/limits", "query_string": query,
             "headers": [(b"host", b"127.0.0.1")], "scheme": "http"}
    asyncio.run(Guard(inner, ["127.0.0.1"])(scope, None, send))
    assert seen["query"] == logged and scope["query_string"] == logged


# ------------------------------------------------------------------ (3) server limits
@pytest.fixture
def protocol_server(db_path, monkeypatch):
    """``python -m app``'s protocol on a live uvicorn (in a thread), the head timeout 1 s."""
    import socket
    import threading
    import time

    import uvicorn

    from api_conftest import make_settings
    from app import http_protocol
    from app.main import create_app
    monkeypatch.setattr(http_protocol, "HEADER_TIMEOUT", 1.0)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(create_app(make_settings(db_path)), host="127.0.0.1",
                                           port=port, log_level="warning",
                                           http=http_protocol.CombinedWritesProtocol))
    th = threading.Thread(target=server.run, daemon=True)
    th.start()
    t0 = time.monotonic()
    while not server.started:
        assert time.monotonic() - t0 < 60 and th.is_alive()   # a bound on a hang
        time.sleep(0.02)
    yield port
    server.should_exit = True
    th.join(timeout=30)


def _recv_all(sock, budget):
    import time
    sock.settimeout(budget)
    out, t0 = b"", time.monotonic()
    while time.monotonic() - t0 < budget:
        try:
            chunk = sock.recv(65536)
        except (TimeoutError, OSError):
            break
        if not chunk:
            return out, True   # closed by the server
        out += chunk
    return out, False


def test_a_slow_header_client_is_cut_off(protocol_server):
    import socket
    with socket.create_connection(("127.0.0.1", protocol_server)) as s:
        s.sendall(b"GET /api/limits HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: 1\r\n")
        _, closed = _recv_all(s, 20.0)   # generous: the cut comes after 1 s
        assert closed
    # a client that sends its head is answered, and kept alive past the head timeout
    with socket.create_connection(("127.0.0.1", protocol_server)) as s:
        s.sendall(b"GET /api/limits HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        s.settimeout(20)
        assert s.recv(65536).startswith(b"HTTP/1.1 200")


def test_an_oversized_header_is_431(protocol_server):
    import socket

    from app.config import Limits
    with socket.create_connection(("127.0.0.1", protocol_server)) as s:
        s.sendall(b"GET /api/limits HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: ")
        try:
            s.sendall(b"a" * (Limits.max_header_bytes + 1024))
        except OSError:
            pass   # the server may close while we still write
        out, closed = _recv_all(s, 20.0)
        assert out.startswith(b"HTTP/1.1 431") and b"max_header_bytes" in out, out[:200]


# ------------------------------------------------------------------ (5) a full disk
# SQLite's ``PRAGMA max_page_count`` (a limit of one connection) at the database's size makes
# every write that needs a new page fail as a full disk does: SQLITE_FULL, "database or disk
# is full"; deletes need no new page.
def _full(db, spare=0):
    """Set connection ``db``'s page limit ``spare`` pages above the database's size."""
    n = db.execute("PRAGMA page_count").fetchone()[0]
    db.execute(f"PRAGMA max_page_count = {max(n + spare, 1)}")
    return db


@pytest.fixture
def full_disk(monkeypatch):
    """Every store the app opens from now on is full (the tables exist, no new page fits)."""
    from app.store import Store
    opened = Store._connect
    monkeypatch.setattr(Store, "_connect", staticmethod(lambda path: _full(opened(path))))


def _started_once(db_path):
    """A database a first start has seeded, with one user dataset; returns its id."""
    from api_conftest import api
    with api(db_path) as c:
        up = c.post("/api/datasets", files={"file": ("mine.csv", small_csv(40), "text/csv")})
        assert up.status_code == 201, up.text
        return up.json()["id"]


def _assert_507(r):
    assert r.status_code == 507, (r.status_code, r.text[:300])
    detail = r.json()["detail"]
    assert "disk is full" in detail and "database or disk is full" in detail, detail
    assert "cannot rollback" not in detail


def test_the_store_rolls_back_a_full_write_and_names_the_cause(tmp_path):
    import sqlite3

    from app.store import Store, disk_full
    from pneucore.data.measurement import read_csv
    store = Store(str(tmp_path / "s.sqlite3"))
    meas = read_csv(io.StringIO(small_csv(4000)), name="big")
    _full(store._db)
    with pytest.raises(sqlite3.OperationalError) as err:
        store.add_dataset(meas)
    assert disk_full(err.value) and "cannot rollback" not in str(err.value)
    assert not store._db.in_transaction and store.list_datasets() == []
    _full(store._db, spare=10_000)   # space freed: the same store writes again
    assert store.add_dataset(meas)["n_samples"] == 4000
    store.close()


def test_a_full_disk_answers_507_naming_the_cause_and_deletes_still_work(db_path, full_disk):
    from api_conftest import api
    mine = _started_once(db_path)
    with api(db_path) as c:   # starts on the full disk: its reads work
        assert c.get("/api/datasets").status_code == 200
        _assert_507(c.post("/api/datasets", files={"file": ("a.csv", small_csv(4000), "text/csv")}))
        exp = inline_experiment("clean", "free-pulses")
        _assert_507(c.post("/api/sessions", json={"name": "s", "model": model(), "experiments": [exp]}))
        assert c.get(f"/api/datasets/{mine}").status_code == 200   # the same client goes on
        assert c.delete(f"/api/datasets/{mine}").status_code == 204
        assert c.get(f"/api/datasets/{mine}").status_code == 404


def test_a_full_disk_keeps_the_connection(db_path, full_disk):
    """A 507 is an ordinary answer: the kept-alive connection carries the next request."""
    import http.client
    import json

    from api_conftest import live_server
    _started_once(db_path)
    body = json.dumps({"name": "s", "model": model(),
                       "experiments": [inline_experiment("clean", "free-pulses")]})
    with live_server(db_path) as url:
        conn = http.client.HTTPConnection(url.removeprefix("http://"), timeout=60)
        conn.request("POST", "/api/sessions", body=body, headers={"Content-Type": "application/json"})
        r = conn.getresponse()
        detail = json.loads(r.read())["detail"]
        sock = conn.sock
        assert r.status == 507 and "database or disk is full" in detail, (r.status, detail)
        conn.request("GET", "/api/limits")
        r2 = conn.getresponse()
        assert r2.status == 200 and json.loads(r2.read())["max_connections"] > 0
        assert conn.sock is sock   # the same connection, not a new one
        conn.close()


def test_a_database_that_cannot_be_created_is_a_clear_message(tmp_path, monkeypatch):
    import sqlite3

    import app.main
    from app.store import _SCHEMA, Store, StoreUnavailable

    def fresh_on_a_full_disk(path):
        db = sqlite3.connect(path, isolation_level=None)
        db.execute("PRAGMA max_page_count = 1")
        db.executescript(_SCHEMA)
        return db
    monkeypatch.setattr(Store, "_connect", staticmethod(fresh_on_a_full_disk))
    path = str(tmp_path / "new.sqlite3")
    with pytest.raises(StoreUnavailable, match="cannot be opened .*database or disk is full.*free space"):
        Store(path)
    # python -m app: the message, no traceback, and no server started
    monkeypatch.setenv("PNEUCORE_DB", path)
    monkeypatch.setattr("sys.argv", ["app"])
    monkeypatch.setattr("uvicorn.run", lambda *a, **k: pytest.fail("started on a full disk"))
    with pytest.raises(SystemExit) as stop:
        app.main.main()
    assert str(stop.value).startswith("pneucore: not started: the database") and \
        "database or disk is full" in str(stop.value)


def test_a_study_whose_job_failed_on_a_full_disk_reads_interrupted(db_path, monkeypatch):
    import sqlite3

    from api_conftest import api
    from app import services
    from pneucore.study import list_studies, set_study_status

    def fails(*a, study_id=None, store_path=None, **k):
        set_study_status(store_path, study_id, "running")
        raise sqlite3.OperationalError("database or disk is full")

    def still_full(*a):
        raise sqlite3.OperationalError("database or disk is full")
    monkeypatch.setattr(services, "run_study", fails)
    monkeypatch.setattr(services, "set_study_status", still_full)
    body = {"model": model(), "scenario": {"duration": 0.3, "command": [[0, 0], [0.02, 0.7]]},
            "parameters": {"supply.pressure": {"distribution": "uniform", "min": 5e5, "max": 6e5}},
            "samples": 2, "seed": 1, "workers": 0}
    with api(db_path) as c:
        r = c.post("/api/studies", json=body)
        assert r.status_code == 202, r.text
        sid, jid = r.json()["id"], r.json()["job_id"]
        import time
        t0 = time.monotonic()
        while c.get(f"/api/jobs/{jid}").json()["status"] in ("queued", "running"):
            assert time.monotonic() - t0 < 60   # a bound on a hang
            time.sleep(0.02)
        assert c.get(f"/api/jobs/{jid}").json()["status"] == "error"
        assert [s["status"] for s in list_studies(str(db_path)) if s["id"] == sid] == ["running"]
        # the disk still full: the study reads its job's state
        assert c.get(f"/api/studies/{sid}").json()["status"] == "interrupted"
        assert [s["status"] for s in c.get("/api/studies").json() if s["id"] == sid] == ["interrupted"]
        # space freed: the next read stores it
        monkeypatch.setattr(services, "set_study_status", set_study_status)
        assert c.get(f"/api/studies/{sid}").json()["status"] == "interrupted"
        assert [s["status"] for s in list_studies(str(db_path)) if s["id"] == sid] == ["interrupted"]


# ------------------------------------------------------------------ (2) a bounded synchronous pool
def test_synchronous_analyses_beyond_the_queue_are_429_and_reads_go_on(db_path, monkeypatch):
    """Eight diagnoses at once on 1 worker and a queue of 1: one runs, one waits, six are 429
    with Retry-After naming the limits; a read is answered meanwhile; the two finish."""
    import threading
    import time
    from concurrent.futures import ThreadPoolExecutor

    from api_conftest import api
    from app.routers import analysis
    release, running = threading.Event(), threading.Semaphore(0)

    def held(*a, **k):   # a diagnosis that lasts until the test lets it go
        running.release()
        assert release.wait(120)
        return {"held": True}
    monkeypatch.setattr(analysis, "run_diagnose", held)
    body = {"model": model(), "experiments": [{"dataset_id": "sample-leak-and-lag-free-pulses"}]}
    with api(db_path, sync_workers=1, max_sync_queue=1) as c, ThreadPoolExecutor(8) as ex:
        limits = c.get("/api/limits").json()
        assert (limits["sync_workers"], limits["max_sync_queue"]) == (1, 1)
        calls = [ex.submit(c.post, "/api/diagnose", json=body) for _ in range(8)]
        assert running.acquire(timeout=120)   # one runs (a bound on a hang)
        t0 = time.monotonic()
        refused = []
        while len(refused) < 6:
            refused = [f.result() for f in calls if f.done()]
            assert time.monotonic() - t0 < 60, [r.status_code for r in refused]
            time.sleep(0.01)
        t0 = time.monotonic()
        read = c.get("/api/datasets/sample-leak-and-lag-free-pulses")
        read_s = time.monotonic() - t0
        busy = c.app.state.sync_pool.admitted
        release.set()
        answers = [f.result(timeout=120) for f in calls]
    assert read.status_code == 200 and read_s < 5.0, read_s   # generous: a loaded 2-core machine
    assert busy == 2   # precondition: the read came while the pool was full
    assert all(r.status_code == 429 for r in refused), [r.text for r in refused]
    for r in refused:
        assert r.headers["retry-after"].isdigit() and int(r.headers["retry-after"]) > 0
        assert "max_sync_queue" in r.json()["detail"] and "/api/jobs/diagnose" in r.json()["detail"]
    assert sorted(r.status_code for r in answers) == [200] * 2 + [429] * 6
    assert c.app.state.sync_pool.admitted == 0   # every slot given back


# ------------------------------------------------------------------ (6) one server per database
def _env(db, port):
    """The environment of a server on ``db`` and ``port`` importing this checkout."""
    import os

    from service import ROOT
    env = dict(os.environ, PNEUCORE_DB=str(db), PNEUCORE_PORT=str(port))
    env.pop("PNEUCORE_DASK_SCHEDULER", None)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


def _python_m_app(db, log_path):
    """``python -m app`` on ``db`` and a free port in its own process group, answering; returns
    the process (its URL as ``.url``)."""
    import subprocess
    import sys
    import time
    import urllib.request

    from service import ROOT, free_port
    port = free_port()
    with open(log_path, "w") as log:
        proc = subprocess.Popen([sys.executable, "-m", "app"], cwd=ROOT, env=_env(db, port),
                                stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    proc.url = f"http://127.0.0.1:{port}"
    t0 = time.monotonic()
    while True:
        assert proc.poll() is None, log_path.read_text()
        try:
            with urllib.request.urlopen(proc.url + "/api/limits", timeout=2) as r:
                if r.status == 200:
                    return proc
        except OSError:
            pass
        # a bound on a hang: a cold numba cache compiles the core on a loaded machine
        assert time.monotonic() - t0 < 120, "the service did not start: " + log_path.read_text()
        time.sleep(0.2)


def _kill9(proc):
    import os
    import signal
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(30)


def test_a_second_server_on_the_same_database_is_refused_at_start(tmp_path):
    """Two processes on one database: the second stops at once with a message naming the first
    (else both resume the same studies and compute them twice); ``uvicorn app.main:app`` and an
    app in a third process are refused too (the app's lifespan); once the first is killed (-9:
    no clean-up ran) the lock file it left does not block a new server."""
    import json
    import subprocess
    import sys
    import urllib.request

    from api_conftest import api
    from app.store import DatabaseInUse, ServerLock
    from service import ROOT, free_port
    db = tmp_path / "one.sqlite3"
    first = _python_m_app(db, tmp_path / "first.log")
    try:
        # 120 s: a bound on a hang (the imports on a loaded machine), not a speed claim
        second = subprocess.run([sys.executable, "-m", "app"], cwd=ROOT, capture_output=True,
                                text=True, timeout=120, env=_env(db, free_port()))
        assert second.returncode != 0, second.stdout
        assert "not started" in second.stderr and "another running server" in second.stderr, \
            second.stderr
        assert f"pid {first.pid}" in second.stderr and "Traceback" not in second.stderr, second.stderr
        plain = subprocess.run([sys.executable, "-m", "uvicorn", "app.main:app", "--port",
                                str(free_port())], cwd=ROOT, capture_output=True, text=True,
                               timeout=120, env=_env(db, 0))
        assert plain.returncode != 0 and "another running server" in plain.stderr, plain.stderr[-2000:]
        with pytest.raises(DatabaseInUse, match="another running server"):
            with api(db):
                pass
        with urllib.request.urlopen(first.url + "/api/limits", timeout=30) as r:   # the first goes on
            assert json.loads(r.read())["max_connections"] > 0
    finally:
        _kill9(first)
    assert (tmp_path / "one.sqlite3.lock").exists()   # left behind by the kill...
    with ServerLock(db):                             # ...and no obstacle
        pass
    _kill9(_python_m_app(db, tmp_path / "third.log"))


def test_the_server_lock_is_reentrant_in_one_process_and_released(tmp_path):
    """``python -m app`` takes the lock, then its app's lifespan takes it again; the last
    release frees it for another process."""
    import subprocess
    import sys

    from app.store import ServerLock
    from service import ROOT
    db = tmp_path / "r.sqlite3"
    probe = [sys.executable, "-c", "import sys; from app.store import ServerLock, DatabaseInUse\n"
             "try: ServerLock(sys.argv[1]).acquire()\nexcept DatabaseInUse: sys.exit(3)", str(db)]

    def other_process_gets_it():
        # 120 s: a bound on a hang (imports on a loaded machine)
        rc = subprocess.run(probe, cwd=ROOT, env=_env(db, 0), timeout=120).returncode
        assert rc in (0, 3), rc
        return rc == 0
    outer = ServerLock(db).acquire()
    inner = ServerLock(db).acquire()
    inner.release()
    assert not other_process_gets_it()   # still held by the outer holder
    outer.release()
    assert other_process_gets_it()


# ------------------------------------------------------------------ (6) damaged rows answered as damaged
def _scribble(db_path, did, **columns):
    """Overwrite columns of a stored dataset row behind the service's back (a faulty disk, a
    hand edit)."""
    import contextlib
    import sqlite3
    with contextlib.closing(sqlite3.connect(db_path, isolation_level=None)) as db:
        for col, value in columns.items():
            assert col in ("data", "signals", "scenario")
            db.execute(f"UPDATE datasets SET {col}=? WHERE id=?", (value, did))


#: Damage that leaves a row readable by SQLite but not as a dataset: a truncated blob, JSON of
#: another shape, columns shorter than the declared length, values no measurement has, and
#: undecodable metadata columns
DAMAGE = {
    "truncated blob": {"data": b'{"t": [0.0, 0.001, 0.00'},
    "not an object": {"data": b"[1, 2, 3]"},
    "short column": {"data": b'{"t": [0.0, 0.1], "u": [0, 1]}'},
    "bad values": {"data": None},   # filled in by the test: the right length, text for numbers
    "signals": {"signals": "[not json"},
    "scenario": {"scenario": '["a list"]'},
}


@pytest.mark.parametrize("damage", list(DAMAGE))
def test_a_damaged_stored_dataset_is_409_naming_it_never_an_empty_200(client, db_path, damage):
    import orjson
    up = client.post("/api/datasets", files={"file": ("a.csv", small_csv(40), "text/csv")},
                     data={"name": "mine"})
    assert up.status_code == 201, up.text
    did, n = up.json()["id"], up.json()["n_samples"]
    columns = dict(DAMAGE[damage])
    if damage == "bad values":
        columns["data"] = orjson.dumps({"t": ["soon"] * n, "u": [0.0] * n})
    _scribble(db_path, did, **columns)
    r = client.get(f"/api/datasets/{did}")
    assert r.status_code == 409, (r.status_code, r.text[:300])
    detail = r.json()["detail"]
    assert f"dataset {did!r} is damaged" in detail and f"DELETE /api/datasets/{did}" in detail, detail
    # an analysis that refers to it is not blamed for it (a 422 would say the request is wrong)
    body = {"model": model(), "experiments": [{"dataset_id": did}]}
    if damage != "bad values":   # read by the store alone
        assert client.get(f"/api/datasets/{did}").json()["detail"] == detail
    r = client.post("/api/compare", json=body)
    assert r.status_code == 409 and "is damaged" in r.json()["detail"], (r.status_code, r.text[:300])
    # the listing still answers, and says which one
    listed = {d["id"]: d for d in client.get("/api/datasets").json()}
    assert listed["sample-clean-free-pulses"]["damaged"] is None
    if damage in ("signals", "scenario"):
        assert listed[did]["damaged"] and listed[did]["signals"] == []
    assert client.delete(f"/api/datasets/{did}").status_code == 204   # the remedy works


def test_a_damaged_shipped_sample_is_restored_at_start(db_path):
    from api_conftest import api
    did = "sample-clean-free-pulses"
    with api(db_path) as c:
        sound = c.get(f"/api/datasets/{did}").json()
        _scribble(db_path, did, data=b'{"t": [0.0, 0.0')
        r = c.get(f"/api/datasets/{did}")
        assert r.status_code == 409 and "next start of the server restores it" in r.json()["detail"]
        other = c.get("/api/datasets/sample-clean-locked-hold").json()
        _scribble(db_path, "sample-clean-locked-hold", scenario="{")
    with api(db_path) as c:   # the next start
        again = c.get(f"/api/datasets/{did}")
        assert again.status_code == 200, again.text[:300]
        assert again.json()["measurement"] == sound["measurement"]
        assert again.json()["n_samples"] == sound["n_samples"] > 100
        assert c.get("/api/datasets/sample-clean-locked-hold").json()["scenario"] == other["scenario"]


# ------------------------------------------------------------------ (5) a failing disk, an unexpected error
@pytest.mark.parametrize("error, status, named", [
    # SQLite's texts for its result codes (sqlite3.OperationalError made here has no code: the
    # store falls back on the text, as on a Python without sqlite_errorcode)
    ("disk I/O error", 503, "SQLITE_IOERR"),
    ("database disk image is malformed", 503, "SQLITE_CORRUPT"),
    ("attempt to write a readonly database", 503, "SQLITE_READONLY"),
    ("database or disk is full", 507, "SQLITE_FULL"),
])
def test_a_failing_disk_is_named_and_the_connection_kept(protocol_server, monkeypatch, error, status,
                                                        named):
    """Over ``python -m app``'s protocol: a storage fault is its status naming the cause (never
    500), an ordinary answer after which the kept-alive connection carries the next request."""
    import http.client
    import json
    import sqlite3

    from app.store import Store

    def fails(self):
        raise sqlite3.OperationalError(error)
    monkeypatch.setattr(Store, "list_datasets", fails)
    conn = http.client.HTTPConnection("127.0.0.1", protocol_server, timeout=60)
    conn.request("GET", "/api/datasets")
    r = conn.getresponse()
    detail = json.loads(r.read())["detail"]
    sock = conn.sock
    assert r.status == status and named in detail and error in detail, (r.status, detail)
    conn.request("GET", "/api/limits")
    r2 = conn.getresponse()
    assert r2.status == 200 and json.loads(r2.read())["max_connections"] > 0
    assert conn.sock is sock   # the same connection
    conn.close()


def test_an_unexpected_error_is_an_ordinary_500_and_the_connection_kept(protocol_server, monkeypatch):
    """Starlette's catch-all raised the error again after its 500, and uvicorn then reset the
    kept-alive connection: the client's next request on it failed."""
    import http.client
    import json

    from app.store import Store

    def fails(self):
        raise RuntimeError("a bug")
    monkeypatch.setattr(Store, "list_datasets", fails)
    conn = http.client.HTTPConnection("127.0.0.1", protocol_server, timeout=60)
    for _ in range(2):
        conn.request("GET", "/api/datasets")
        r = conn.getresponse()
        body = json.loads(r.read())
        assert r.status == 500 and body["detail"] == "internal error: RuntimeError: a bug", body
        assert r.getheader("x-content-type-options") == "nosniff"   # through the guard
    sock = conn.sock
    conn.request("GET", "/api/limits")
    r2 = conn.getresponse()
    assert r2.status == 200 and json.loads(r2.read())["max_connections"] > 0
    assert conn.sock is sock
    conn.close()


# ------------------------------------------------------------------ (2) work whose client went away
@pytest.fixture
def pool_server(db_path):
    """A live uvicorn (in a thread) over an app with 1 synchronous worker and a queue of 2;
    yields ``(app, port)``."""
    import socket
    import threading
    import time

    import uvicorn

    from api_conftest import make_settings
    from app.main import create_app
    app = create_app(make_settings(db_path, sync_workers=1, max_sync_queue=2))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    th = threading.Thread(target=server.run, daemon=True)
    th.start()
    t0 = time.monotonic()
    while not server.started:
        assert time.monotonic() - t0 < 60 and th.is_alive()   # a bound on a hang
        time.sleep(0.02)
    yield app, port
    server.should_exit = True
    th.join(timeout=30)


def _until(cond, what, budget=60.0):
    """Wait for ``cond()``; ``budget`` [s] bounds a hang on a loaded machine, it claims no speed."""
    import time
    t0 = time.monotonic()
    while not cond():
        assert time.monotonic() - t0 < budget, what
        time.sleep(0.02)


def _post_raw(port, path, body):
    """Send a JSON POST on a new socket and return the socket (its answer unread)."""
    import json
    import socket
    data = json.dumps(body).encode()
    s = socket.create_connection(("127.0.0.1", port))
    s.sendall(b"POST %s HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
              b"Content-Length: %d\r\n\r\n%s" % (path.encode(), len(data), data))
    return s


def test_analyses_whose_client_left_never_start_or_stop_at_their_next_progress(pool_server,
                                                                             monkeypatch):
    """One worker: a running diagnosis and a waiting one. The waiting one's client closes its
    socket: it leaves the queue and never starts. The running one's client closes: its next
    progress callback stops it (it would run until released otherwise)."""
    import threading
    import time

    import httpx

    from app.routers import analysis
    from pneucore.progress import Cancelled
    app, port = pool_server
    calls, outcomes, release = [], [], threading.Event()

    def held(req, store, limits, progress=None, **k):   # a diagnosis reporting progress
        calls.append(time.monotonic())
        try:
            while not release.is_set():
                progress(0.5, "held")
                time.sleep(0.02)
        except Cancelled as exc:
            outcomes.append(type(exc).__name__)
            raise
        outcomes.append("finished")
        return {"held": True}
    monkeypatch.setattr(analysis, "run_diagnose", held)
    body = {"model": model(), "experiments": [{"dataset_id": "sample-clean-free-pulses"}]}
    pool = app.state.sync_pool
    running = _post_raw(port, "/api/diagnose", body)
    _until(lambda: len(calls) == 1, "the first diagnosis did not start")
    waiting = _post_raw(port, "/api/diagnose", body)
    _until(lambda: pool.admitted == 2, "the second diagnosis was not queued")
    waiting.close()
    _until(lambda: pool.admitted == 1, "the queued diagnosis of a gone client stayed queued")
    running.close()
    _until(lambda: outcomes, "the running diagnosis of a gone client was not stopped")
    assert outcomes == ["ClientGone"] and len(calls) == 1   # the queued one never started
    _until(lambda: pool.admitted == 0, "a slot was not given back")
    release.set()   # a client that stays gets its answer
    with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=60) as c:
        r = c.post("/api/diagnose", json=body)
    assert r.status_code == 200 and r.json() == {"held": True} and len(calls) == 2


def test_time_in_the_queue_counts_against_the_request_time_limit(db_path, monkeypatch):
    """request_time_limit = 1 s and one worker held: the waiting request is 504 once its time
    is up, without starting; and a request admitted late has only what is left of its time."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    from api_conftest import api
    from app.jobs import JobTimeout
    from app.routers import analysis
    from app.services import deadline_progress
    from app.sync_pool import CURRENT, Ticket
    calls, release = [], threading.Event()

    def held(*a, **k):   # holds the worker without reporting progress
        calls.append(1)
        assert release.wait(120)
        return {"held": True}
    monkeypatch.setattr(analysis, "run_diagnose", held)
    body = {"model": model(), "experiments": [{"dataset_id": "sample-clean-free-pulses"}]}
    with api(db_path, sync_workers=1, max_sync_queue=2, request_time_limit=1.0) as c, \
            ThreadPoolExecutor(2) as ex:
        first = ex.submit(c.post, "/api/diagnose", json=body)
        _until(lambda: calls, "the first diagnosis did not start")
        second = c.post("/api/diagnose", json=body)   # waits 1 s in the queue, then 504
        assert second.status_code == 504, second.text
        assert "never started" in second.json()["detail"] and \
            "request_time_limit" in second.json()["detail"]
        release.set()
        assert first.result(timeout=120).status_code == 200 and len(calls) == 1
    # the deadline of a request counts from its admission: 5 s waited of a 1 s limit is over
    from app.config import Limits
    token = CURRENT.set(Ticket(admitted=__import__("time").monotonic() - 5.0))
    try:
        check = deadline_progress(Limits(request_time_limit=1.0), "diagnosis", "/api/jobs/diagnose")
    finally:
        CURRENT.reset(token)
    with pytest.raises(JobTimeout, match="waiting for a worker"):
        check(0.0, "start")


# ------------------------------------------------------------------ (1) a memory budget for every format
def _never(*a, **k):
    raise AssertionError("decoded although over the memory budget")


def _mat(variables):
    import scipy.io
    buf = io.BytesIO()
    scipy.io.savemat(buf, variables, do_compression=True)
    return buf.getvalue()


def _columns(n):
    import numpy as np
    t = np.arange(n) * 1e-3
    return {"t": t, "u": (t > 0.005).astype(float), "p_a": 2e5 + 1e3 * t, "x": 0.01 + 0.001 * t}


def test_a_csv_of_many_short_rows_is_refused_before_it_is_parsed(db_path, monkeypatch):
    """100,000 rows of "0,0" are 400 kB: 200,000 cells, about 26 MB for the reader (128 bytes a
    cell), over a 2 MB budget: refused naming it, the reader never called."""
    from api_conftest import api
    from app import services
    with api(db_path, max_request_memory=2_000_000) as c:
        ok = c.post("/api/datasets", files={"file": ("a.csv", small_csv(200), "text/csv")})
        assert ok.status_code == 201, ok.text   # 200 rows x 4 columns: 100 kB, within it
        monkeypatch.setattr(services, "read_measurement", _never)
        r = c.post("/api/datasets", files={"file": ("h.csv", "t,u\n" + "0,0\n" * 100_000, "text/csv")})
    assert r.status_code == 422 and "max_request_memory" in r.text and "nothing was decoded" in r.text, \
        r.text[:300]


@pytest.mark.parametrize("path", ["/api/datasets", "/api/compare"])
def test_a_json_body_of_many_values_is_413_before_it_is_parsed(db_path, path):
    """300,000 zeros (600 kB) would take about 36 MB parsed (120 bytes a value): over a 2 MB
    budget, 413 naming it, for a dataset and for inline measurements of an analysis."""
    import orjson

    from api_conftest import api
    n = 300_000
    meas = {"t": [0] * n, "u": [0] * n}
    body = {"measurement": meas} if path == "/api/datasets" else \
        {"model": model(), "experiments": [{"measurement": meas, "scenario": {}}]}
    with api(db_path, max_request_memory=2_000_000) as c:
        r = c.post(path, content=orjson.dumps(body), headers={"content-type": "application/json"})
        assert r.status_code == 413 and "max_request_memory" in r.json()["detail"], r.text[:300]
        small = {"measurement": {k: v.tolist() for k, v in _columns(50).items()}}
        assert c.post("/api/datasets", json=small).status_code == 201


def test_a_compressed_mat_bomb_is_refused_from_its_headers(db_path, monkeypatch):
    """20 MB of uint8 zeros compress to about 20 kB; read as uint8 and converted to float64 they
    take 180 MB, over a 50 MB budget: refused from the variable's header, no reader started
    (neither the upload nor the preview)."""
    import numpy as np

    from api_conftest import api
    from pneucore.data import fileformats
    bomb = _mat({"t": np.zeros((20 * 2**20, 1), dtype=np.uint8)})
    assert len(bomb) < 200_000   # precondition: a small body
    in_struct = _mat({"s": {"t": np.zeros(3), "u": np.zeros((20 * 2**20, 1), dtype=np.uint8)}})
    sound = _mat({"s": _columns(2000)})   # a struct of columns: its fields are counted, within it
    with api(db_path, max_request_memory=50 * 2**20) as c:
        r = c.post("/api/datasets", files={"file": ("s.mat", sound, "application/octet-stream")})
        assert r.status_code == 201 and r.json()["n_samples"] == 2000, r.text[:300]
        monkeypatch.setattr(fileformats, "mat_columns_isolated", _never)
        for body in (bomb, in_struct):
            for path in ("/api/datasets", "/api/datasets/inspect"):
                r = c.post(path, files={"file": ("b.mat", body, "application/octet-stream")})
                assert r.status_code == 422 and "max_request_memory" in r.text, (path, r.text[:300])


def test_the_matlab_estimate_counts_classes_structs_and_cells():
    """The headers' estimate against the sizes it stands for: each value as its class and as
    float64 (the .npz reader's rule), struct fields and cells followed."""
    import numpy as np

    from app.request_memory import mat_bytes
    n = 1000
    cols = _columns(n)
    budget = 10**9
    assert mat_bytes(_mat(cols), budget) == 4 * n * 16                      # doubles
    assert mat_bytes(_mat({"s": cols}), budget) == pytest.approx(4 * n * 16, abs=64)   # + names
    assert mat_bytes(_mat({"i": np.zeros(n, np.int8)}), budget) == n * 9    # 1 byte + float64
    cell = np.empty(2, dtype=object)
    cell[0], cell[1] = np.zeros(10), np.zeros(20, np.float32)
    assert mat_bytes(_mat({"c": cell}), budget) == 10 * 16 + 20 * 12
    assert mat_bytes(_mat({"t": np.zeros(10**6)}), 1000) > 1000            # stops at the budget


def test_a_tdms_file_over_the_budget_is_refused_from_its_metadata(db_path, monkeypatch):
    """4 channels of 50,000 doubles: 3.2 MB read and converted; refused under a 1 MB budget
    without reading a channel, stored under the default one."""
    from nptdms import ChannelObject, TdmsWriter

    from api_conftest import api
    from pneucore.data import fileformats
    buf = io.BytesIO()
    with TdmsWriter(buf) as w:
        w.write_segment([ChannelObject("g", k, v) for k, v in _columns(50_000).items()])
    data = buf.getvalue()
    with api(db_path) as c:
        assert c.post("/api/datasets", files={"file": ("a.tdms", data, "application/octet-stream")}
                      ).status_code == 201
    with api(db_path, max_request_memory=2**20) as c:
        monkeypatch.setattr(fileformats, "_tdms_columns", _never)
        r = c.post("/api/datasets", files={"file": ("a.tdms", data, "application/octet-stream")})
        assert r.status_code == 422 and "max_request_memory" in r.text and "3 MB" in r.text, r.text[:300]


@pytest.mark.parametrize("table, column, value", [("sessions", "experiments", "[{"),
                                                  ("sessions", "experiments", '{"a": 1}')])
def test_a_damaged_session_is_409_naming_it(client, db_path, table, column, value):
    """A session whose experiments no longer decode (its versions are compared on them)."""
    import contextlib
    import sqlite3
    r = client.post("/api/sessions", json={"name": "s", "model": model()})
    assert r.status_code == 201, r.text[:300]
    sid = r.json()["id"]
    key = "id" if table == "sessions" else "session"
    with contextlib.closing(sqlite3.connect(db_path, isolation_level=None)) as db:
        db.execute(f"UPDATE {table} SET {column}=? WHERE {key}=?", (value, sid))
    for r in (client.get(f"/api/sessions/{sid}"),
              client.post(f"/api/sessions/{sid}/versions", json={"model": model()})):
        assert r.status_code == 409, (r.status_code, r.text[:300])
        assert f"session {sid!r} is damaged" in r.json()["detail"], r.text[:300]
    assert [s["id"] for s in client.get("/api/sessions").json()] == [sid]   # listed still
    assert client.delete(f"/api/sessions/{sid}").status_code == 204
