"""Run the web service in a subprocess for browser tests (shared by the page test files)."""
from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def running_service(tmp: Path, db: Path, extra_env=None):
    """uvicorn serving ``app.main:app`` on a free localhost port with database ``db``; yields its URL.

    The service gets its own process group, killed at the end, so the pool workers of a study
    still running when a test failed do not outlive it.
    """
    env = dict(os.environ, PNEUCORE_DB=str(db))
    env.pop("PNEUCORE_DASK_SCHEDULER", None)
    env.update(extra_env or {})
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    port = free_port()
    log = open(tmp / "server.log", "w+")
    proc = subprocess.Popen([sys.executable, "-m", "uvicorn", "app.main:app", "--host", "127.0.0.1",
                             "--port", str(port), "--log-level", "warning"],
                            cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True)
    url = f"http://127.0.0.1:{port}"
    deadline = time.time() + 60   # a cold numba cache compiles the core at the first request
    try:
        while True:
            if proc.poll() is not None:
                log.seek(0)
                pytest.fail(f"the service exited with code {proc.returncode}:\n{log.read()}")
            try:
                with urllib.request.urlopen(url + "/api/presets", timeout=2) as r:
                    if r.status == 200:
                        break
            except OSError:
                pass
            if time.time() > deadline:
                log.seek(0)
                pytest.fail(f"the service did not answer /api/presets within 60 s:\n{log.read()}")
            time.sleep(0.2)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        log.close()
