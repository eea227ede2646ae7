"""Jobs are SQLite records on their own pools: an analysis never waits behind studies, and a job
running when the server is killed (kill -9) reads "interrupted" afterwards, not 404."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import httpx

from api_conftest import LEAK_IDS, model
from app.jobs import JobManager
from app.store import Store
from service import free_port

ROOT = Path(__file__).resolve().parents[2]
#: a bound on a hang, not a speed claim
WAIT_S = 120.0


def _until(cond, what, budget=WAIT_S):
    t0 = time.monotonic()
    while not cond():
        assert time.monotonic() - t0 < budget, what
        time.sleep(0.01)


def test_analysis_jobs_do_not_wait_behind_studies(tmp_path):
    """Two studies hold every study thread; a diagnosis still starts and finishes at once."""
    jobs = JobManager(workers=1, max_jobs=16, store=Store(str(tmp_path / "j.sqlite3")))
    release = threading.Event()
    try:
        studies = [jobs.submit("study", lambda job: release.wait(WAIT_S) and "study done")
                   for _ in range(3)]
        _until(lambda: sum(j.status == "running" for j in studies) == 2, "studies did not start")
        diag = jobs.submit("diagnose", lambda job: "diagnosis done")
        _until(lambda: diag.status == "done", "the diagnosis waited behind the studies")
        assert diag.result == "diagnosis done"
        assert [j.status for j in studies].count("queued") == 1   # studies queue among themselves
    finally:
        release.set()
        jobs.shutdown()


def test_job_records_survive_a_new_manager(tmp_path):
    """What a job had is kept: a finished job keeps its result; one cut off reads interrupted."""
    store = Store(str(tmp_path / "j.sqlite3"))
    jobs = JobManager(workers=1, store=store)
    gate = threading.Event()

    def slow(job):
        job.report(0.4, "refitting candidate 2 of 4")
        gate.wait(WAIT_S)
        return {"never": "stored"}
    done = jobs.submit("compare", lambda job: {"overall": 0.05, "series": [1.0, float("nan")]})
    _until(lambda: done.status == "done", "job did not finish")
    cut = jobs.submit("diagnose", slow)
    queued = jobs.submit("calibrate", lambda job: 1)
    _until(lambda: cut.progress == 0.4, "job did not report")
    time.sleep(0.6)   # past PROGRESS_WRITE_S: the next report is written
    cut.report(0.5, "refitting candidate 3 of 4")
    # the process "dies" here: a new manager opens the same file
    again = JobManager(workers=1, store=Store(store.path))
    d = again.get(done.id).to_dict()
    assert d["status"] == "done" and d["result"] == {"overall": 0.05, "series": [1.0, None]}
    c = again.get(cut.id).to_dict()
    assert c["status"] == "interrupted" and c["progress"] == 0.5
    assert c["step"] == "refitting candidate 3 of 4" and "running" in c["error"]
    q = again.get(queued.id).to_dict()
    assert q["status"] == "interrupted" and "queued" in q["error"]
    assert again.get("nope") is None
    gate.set()
    jobs.shutdown()
    again.shutdown()


def _start(db, port, log):
    env = dict(os.environ, PNEUCORE_DB=str(db))
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    proc = subprocess.Popen([sys.executable, "-m", "uvicorn", "app.main:app", "--host", "127.0.0.1",
                             "--port", str(port), "--log-level", "warning"], cwd=ROOT, env=env,
                            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    url = f"http://127.0.0.1:{port}"

    def up():
        assert proc.poll() is None, "the service exited"
        try:
            with urllib.request.urlopen(url + "/api/limits", timeout=2) as r:
                return r.status == 200
        except OSError:
            return False
    _until(up, "the service did not start", 90)   # a cold numba cache compiles at import
    return proc, url


def _kill9(proc):
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(30)


def test_kill_9_leaves_jobs_interrupted_not_404(tmp_path):
    db, log = tmp_path / "k.sqlite3", open(tmp_path / "server.log", "w")
    port = free_port()
    proc, url = _start(db, port, log)
    try:
        body = {"model": model(), "experiments": [{"dataset_id": i} for i in LEAK_IDS]}
        with httpx.Client(base_url=url, timeout=60) as c:
            ids = []
            for _ in range(6):   # two threads: the rest wait queued
                r = c.post("/api/jobs/diagnose", json=body)
                assert r.status_code == 202, r.text
                ids.append(r.json()["id"])
            _until(lambda: any(c.get(f"/api/jobs/{i}").json()["status"] == "running" for i in ids),
                   "no job started")
        _kill9(proc)
        proc, url = _start(db, port, log)
        with httpx.Client(base_url=url, timeout=60) as c:
            got = [c.get(f"/api/jobs/{i}") for i in ids]
            assert [r.status_code for r in got] == [200] * len(ids)
            states = [r.json() for r in got]
            assert {s["status"] for s in states} <= {"done", "interrupted"}
            cut = [s for s in states if s["status"] == "interrupted"]
            assert cut, "every job finished before the kill"
            for s in cut:
                assert s["result"] is None and "server stopped" in s["error"]
                assert 0.0 <= s["progress"] < 1.0
            for s in states:
                if s["status"] == "done":
                    assert s["result"]["verdict"] == "piston_leakage"
            # the service works on: a new job runs to the end
            r = c.post("/api/jobs/diagnose", json=body)
            jid = r.json()["id"]
            _until(lambda: c.get(f"/api/jobs/{jid}").json()["status"] == "done", "job after restart")
    finally:
        try:
            _kill9(proc)
        except ProcessLookupError:
            pass
        log.close()


def test_time_limit_holds_without_progress_reports(tmp_path):
    """A job whose work never reports progress still ends at its time limit (+ the watchdog's
    grace): its record says why at once, and the result its thread returns later is dropped."""
    from app.jobs import WATCHDOG_GRACE_S
    store = Store(str(tmp_path / "j.sqlite3"))
    jobs = JobManager(workers=1, store=store, time_limit=0.3)
    release, returned = threading.Event(), threading.Event()

    def silent(job):
        release.wait(WAIT_S)
        returned.set()
        return {"late": True}
    try:
        job = jobs.submit("diagnose", silent)
        _until(lambda: job.status == "error", "the job outlived its time limit")
        assert job.finished - job.started >= 0.3
        # the watchdog wakes every 0.25 s; 5 s more is a bound on a loaded machine, not a speed claim
        assert job.finished - job.started < 0.3 + WATCHDOG_GRACE_S + 5.0
        assert "time limit of 0.3 s" in job.error
        assert store.job(job.id)["status"] == "error"
        release.set()
        _until(returned.is_set, "the job's thread did not return")
        time.sleep(0.1)   # let the thread's epilogue run
        assert job.status == "error" and job.result is None
        assert store.job(job.id)["status"] == "error"
    finally:
        release.set()
        jobs.shutdown()
