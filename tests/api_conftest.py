"""Shared helpers and fixtures of the REST API tests (``tests/test_api_*.py``).

Not a ``conftest.py`` on purpose: the test modules import what they use
(``from api_conftest import client, ...``), so the pneucore unit tests are
untouched. Every app is built with ``create_app(Settings(db_path=tmp))`` and
used as a context manager, so the lifespan opens the SQLite store and seeds
the sample datasets.
"""
from __future__ import annotations

import contextlib
import copy
import math
import socket
import sys
import threading
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # ``app`` is not installed; plain ``pytest`` must find it too
    sys.path.insert(0, str(ROOT))

from fastapi.testclient import TestClient

from app.config import Limits, Settings
from app.main import create_app
from pneucore import model_preset, scenario_preset
from pneucore.data.samples import DATA_DIR, list_samples, load_sample

#: Sample dataset ids seeded on first start (``sample-<sample>-<experiment>``)
SAMPLE_IDS = [f"sample-{s['id']}-{e['name']}" for s in list_samples() for e in s["experiments"]]
LEAK_IDS = ["sample-piston-leak-locked-hold", "sample-piston-leak-free-pulses"]
CLEAN_IDS = ["sample-clean-locked-hold", "sample-clean-free-pulses"]

#: Polling budget of a job: generous, a bound on a hang, not a speed claim
JOB_WAIT_S = 120.0


# ----------------------------------------------------------------------------- apps
def make_settings(db_path, **limits) -> Settings:
    """Settings on ``db_path`` with some :class:`Limits` fields overridden."""
    return Settings(db_path=str(db_path), limits=Limits(**limits))


@contextlib.contextmanager
def api(db_path, **limits):
    """A started app (lifespan run) on ``db_path``; server errors come back as 500s."""
    app = create_app(make_settings(db_path, **limits))
    with TestClient(app, base_url="http://127.0.0.1", raise_server_exceptions=False) as c:
        yield c


@pytest.fixture
def db_path(tmp_path):
    return tmp_path / "api.sqlite3"


@pytest.fixture
def client(db_path):
    """A fresh app with default limits on a temporary database."""
    with api(db_path) as c:
        yield c


@contextlib.contextmanager
def live_server(db_path, **limits):
    """A real uvicorn server (one worker, in a thread) on a free localhost port; yields its URL."""
    import uvicorn
    app = create_app(make_settings(db_path, **limits))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning",
                                           lifespan="on"))
    th = threading.Thread(target=server.run, daemon=True)
    th.start()
    t0 = time.monotonic()
    while not server.started:
        # start-up budget: a bound on a hang, not a speed claim
        assert time.monotonic() - t0 < 30.0, "uvicorn did not start"
        assert th.is_alive(), "uvicorn thread died during start-up"
        time.sleep(0.01)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        th.join(timeout=30)


# ----------------------------------------------------------------------------- bodies
def model(name="paper-4way", **changes):
    """A model preset dict; ``changes`` maps dotted paths to new values."""
    m = model_preset(name)
    for path, value in changes.items():
        set_path(m, path, value)
    return m


def scenario(name="paper-fig10-pulses", **changes):
    s = scenario_preset(name)
    for path, value in changes.items():
        set_path(s, path, value)
    return s


def set_path(d, path, value):
    """``set_path(d, "jack.rod_a", 0.04)``; ``/`` separates keys holding dots (``valve/ports/P-A``)."""
    keys = path.split("/") if "/" in path else path.split(".")
    for k in keys[:-1]:
        d = d[int(k)] if isinstance(d, list) else d[k]
    last = keys[-1]
    if isinstance(d, list):
        d[int(last)] = value
    else:
        d[last] = value


def sim_body(m=None, s=None, **extra):
    return {"model": m if m is not None else model(), "scenario": s if s is not None else scenario(),
            **extra}


def measurement_json(meas, nulls=()):
    """A :class:`pneucore.data.measurement.Measurement` as the API's JSON (NaN -> null).

    ``nulls`` lists (signal, index) samples to blank out (missing samples).
    """
    d = {"t": [float(v) for v in meas.t]}
    for k, v in meas.signals.items():
        d[k] = [None if not math.isfinite(float(x)) else float(x) for x in v]
    for sig, i in nulls:
        if sig in d:  # a locked test has no x column
            d[sig][i] = None
    return d


def inline_experiment(sample, name, nulls=()):
    """One experiment of a shipped sample with its measurement inline (JSON-ready)."""
    for e in load_sample(sample):
        if e["name"] == name:
            return {"name": e["name"], "scenario": dict(e["scenario"]),
                    "measurement": measurement_json(e["measurement"], nulls)}
    raise KeyError(name)


def sample_csv_text(sample, name):
    """The CSV text of a shipped sample experiment (units in the headers)."""
    return (DATA_DIR / f"{sample}--{name}.csv").read_text()


def small_csv(n=20, header="t[s],u[-],p_a[bar],x[mm]"):
    """A small valid CSV: 1 kHz, valve opens at row 6, p_a in bar, x in mm."""
    rows = [f"{i * 0.001:.3f},{0 if i < 5 else 1},{1 + 0.01 * i:.2f},{10 + i}" for i in range(n)]
    return header + "\n" + "\n".join(rows) + "\n"


# ----------------------------------------------------------------------------- checks
def assert_field_error(resp, field, *, type=None, msg_contains=(), status=422):
    """The response is a 422 whose first error names ``field`` (dotted path)."""
    assert resp.status_code == status, (resp.status_code, resp.text[:800])
    detail = resp.json()["detail"]
    assert isinstance(detail, list) and detail, detail
    err = detail[0]
    assert err.get("field") == field, err
    assert err["loc"][0] == "body", err
    if type is not None:
        assert err["type"] == type, err
    msg = err["msg"]
    for part in ([msg_contains] if isinstance(msg_contains, str) else msg_contains):
        assert part.lower() in msg.lower(), err
    return err


def n_datasets(c):
    return len(c.get("/api/datasets").json())


def wait_job(c, job_id, budget=JOB_WAIT_S, poll=0.02):
    """Poll a job until done or error; returns (final job, list of observed snapshots)."""
    seen = []
    t0 = time.monotonic()
    while True:
        r = c.get(f"/api/jobs/{job_id}")
        assert r.status_code == 200, r.text
        j = r.json()
        seen.append({k: j[k] for k in ("status", "progress", "step")})
        if j["status"] in ("done", "error"):
            # read the record once more: the worker publishes "done"/"error" a few statements
            # before finished/progress/error (see test_api_jobs::test_terminal_status_is_published_last)
            time.sleep(poll)
            j = c.get(f"/api/jobs/{job_id}").json()
            seen.append({k: j[k] for k in ("status", "progress", "step")})
            return j, seen
        # polling budget: a bound on a hung job, not a speed claim
        assert time.monotonic() - t0 < budget, f"job {job_id} still {j['status']} after {budget} s"
        time.sleep(poll)


def deep(x):
    return copy.deepcopy(x)
