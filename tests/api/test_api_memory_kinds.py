"""Every heavy endpoint and job goes through the same memory admission (issue 40, item 4).

Sizing, the identifications, the closed-loop simulation, studies, closed-loop studies and
tunings, a large request body and an upload's decoding each have their estimate
(:mod:`app.analysis_memory`, one function per kind) held on ``Limits.analysis_memory_budget``
as the analyses do: a synchronous request that does not fit is 503 with ``Retry-After``, a
job waits in the queue saying so, and what is held is given back on success, error and
cancel.
"""
from __future__ import annotations

import threading

import pytest

from api_conftest import api, db_path, wait_job  # noqa: F401
from app.analysis_memory import FLOOR_BYTES
from app.request_memory import JSON_VALUE_BYTES
from test_api_control import _study as control_study
from test_api_identify import _points
from test_api_sizing import _body as sizing_body
from test_api_studies import study_body

#: A budget every request of this file fits alone [bytes]; the tests hold all of it but a
#: byte to make any estimate not fit
BUDGET = 2_000_000_000


def _friction_body():
    import math
    n = 400
    t = [i / 100.0 for i in range(n)]
    x = [0.02 * math.sin(0.5 * math.pi * v) for v in t]
    from pneucore import model_preset
    rec = {"name": "r", "t": t, "x": x, "p_a": [3e5] * n, "p_b": [1e5] * n, "F": [100.0] * n}
    return {"model": model_preset("paper-4way"), "experiments": [rec]}


def _closed_loop():
    s = control_study()
    return {"model": s["model"], "scenario": s["scenario"]}


#: Synchronous heavy endpoints: path, body, the work patched to end at once
#: (module, name), so that success is cheap
SYNC = {
    "sizing": ("/api/sizing", sizing_body, ("app.sizing_service", "size")),
    "identify-valve": ("/api/identify/valve", lambda: {"edge": "P-A", "points": _points()},
                       ("app.services", "_identify_valve")),
    "identify-friction": ("/api/identify/friction", _friction_body,
                          ("app.services", "_identify_friction")),
    "closed-loop": ("/api/simulate", _closed_loop, None),
}

#: Jobs: path, body, the work patched (module, name)
JOBS = {
    "sizing": ("/api/jobs/sizing", sizing_body, ("app.routers.jobs", "run_sizing")),
    "identify-valve": ("/api/jobs/identify/valve", lambda: {"edge": "P-A", "points": _points()},
                       ("app.services", "_identify_valve")),
    "identify-friction": ("/api/jobs/identify/friction", _friction_body,
                          ("app.services", "_identify_friction")),
    "control-study": ("/api/jobs/control-study", lambda: {"study": control_study()},
                      ("app.routers.control", "run_control_study")),
    "tune": ("/api/jobs/tune-controller",
             lambda: {"study": control_study(), "gains": {"kp": [5, 10]}},
             ("app.routers.control", "run_tune")),
    "study": ("/api/studies", lambda: study_body(workers=0), ("app.services", "run_study")),
}


def _patch(monkeypatch, target, error=None):
    """The work of ``target`` replaced by one answering ``{}`` (or raising ``error``) at once."""
    if target is None:
        return

    def fake(*a, **k):
        if error is not None:
            raise error
        return {}
    monkeypatch.setattr(target[0] + "." + target[1], fake)


def _free(c):
    state = c.app.state.memory.state()
    return state["held"], state["running"]


def _job_id(r):
    j = r.json()
    return j.get("job_id") or j["id"]


def _waiting(c, jid):
    """The job's record once it says it waits for memory (its thread reaches the budget in a
    few ms; 10 s bound a hang)."""
    for _ in range(1000):
        j = c.get(f"/api/jobs/{jid}").json()
        if j["step"].startswith("waiting for memory"):
            return j
        threading.Event().wait(0.01)
    return j


@pytest.mark.parametrize("kind", sorted(SYNC))
def test_a_synchronous_request_that_does_not_fit_is_503_and_answered_once_it_fits(
        db_path, monkeypatch, kind):
    path, body, target = SYNC[kind]
    _patch(monkeypatch, target)
    with api(db_path, analysis_memory_budget=BUDGET) as c:
        with c.app.state.memory.hold(BUDGET - 1):   # the analyses running hold all but a byte
            busy = c.post(path, json=body())
        free = c.post(path, json=body())
        end = _free(c)
    assert busy.status_code == 503, busy.text[:400]
    assert int(busy.headers["retry-after"]) > 0
    assert busy.json()["estimate"] >= FLOOR_BYTES and "analysis_memory_budget" in busy.json()["detail"]
    assert free.status_code == 200, free.text[:400]
    assert end == (0, 0)


@pytest.mark.parametrize("kind", sorted(SYNC))
def test_a_synchronous_request_gives_its_estimate_back_on_an_error(db_path, monkeypatch, kind):
    path, body, target = SYNC[kind]
    if target is None:
        target = ("pneucore.control.closed_loop", "simulate_closed_loop")
    _patch(monkeypatch, target, RuntimeError("a bug"))
    with api(db_path, analysis_memory_budget=BUDGET) as c:
        r = c.post(path, json=body())
        end = _free(c)
    assert r.status_code == 500, r.text[:400]
    assert end == (0, 0)


@pytest.mark.parametrize("kind", sorted(JOBS))
@pytest.mark.parametrize("outcome", ["done", "error"])
def test_a_job_waits_for_memory_then_runs_and_gives_it_back(db_path, monkeypatch, kind, outcome):
    path, body, target = JOBS[kind]
    _patch(monkeypatch, target, RuntimeError("a bug") if outcome == "error" else None)
    with api(db_path, analysis_memory_budget=BUDGET) as c:
        with c.app.state.memory.hold(BUDGET - 1):
            r = c.post(path, json=body())
            assert r.status_code == 202, r.text[:400]
            waiting = _waiting(c, _job_id(r))
        done, _ = wait_job(c, _job_id(r))
        end = _free(c)
    assert waiting["status"] == "queued" and "analysis_memory_budget" in waiting["step"], waiting
    assert done["status"] == outcome, done
    assert end == (0, 0)


def test_a_study_deleted_while_it_waits_for_memory_gives_nothing_held(db_path):
    with api(db_path, analysis_memory_budget=BUDGET) as c:
        with c.app.state.memory.hold(BUDGET - 1):
            r = c.post("/api/studies", json=study_body(workers=0))
            assert r.status_code == 202, r.text[:400]
            _waiting(c, r.json()["job_id"])
            assert c.delete(f"/api/studies/{r.json()['id']}").status_code == 204
        done, _ = wait_job(c, r.json()["job_id"])
        end = _free(c)
    assert done["status"] == "error" and "deleted" in done["error"], done
    assert end == (0, 0)


def test_a_large_body_is_held_while_answered_and_counted_in_its_jobs_estimate(db_path):
    body = _friction_body()
    n = 4_000   # about 200 kB of JSON: past the 64 kB parsed on the event loop
    body["experiments"][0] = {k: (v * 10 if isinstance(v, list) else v)
                              for k, v in body["experiments"][0].items()}
    body["experiments"][0]["t"] = [i / 100.0 for i in range(n)]
    with api(db_path, analysis_memory_budget=BUDGET) as c:
        with c.app.state.memory.hold(BUDGET - 1):
            busy = c.post("/api/identify/friction", json=body)
        jobs = c.app.state.jobs
        seen = []
        real = jobs.submit
        jobs.submit = lambda kind, fn, **k: (seen.append(k.get("memory")), real(kind, fn, **k))[1]
        r = c.post("/api/jobs/identify/friction", json=body)
        wait_job(c, r.json()["id"])
        end = _free(c)
    assert busy.status_code == 503 and "request body" in busy.json()["detail"], busy.text[:400]
    # the body's values at the figure the 413 uses: 5 lists of 4,000 values at least
    assert busy.json()["estimate"] >= 5 * n * JSON_VALUE_BYTES
    from app.analysis_memory import identify_estimate
    assert seen[0] >= identify_estimate("friction", n) + 5 * n * JSON_VALUE_BYTES
    assert end == (0, 0)


def test_an_uploads_decoding_is_held_on_the_budget(db_path):
    csv = "t,p_a,p_b\n" + "".join(f"{i / 1000},{5e5},{1e5}\n" for i in range(20_000))
    with api(db_path, analysis_memory_budget=BUDGET) as c:
        with c.app.state.memory.hold(BUDGET - 1):
            busy = c.post("/api/datasets", files={"file": ("r.csv", csv.encode(), "text/csv")})
        free = c.post("/api/datasets", files={"file": ("r.csv", csv.encode(), "text/csv")})
        end = _free(c)
    assert busy.status_code == 503 and "upload" in busy.json()["detail"], busy.text[:400]
    assert free.status_code == 201, free.text[:400]
    assert end == (0, 0)


def test_every_kind_over_the_whole_budget_is_422_naming_its_field(db_path):
    with api(db_path, analysis_memory_budget=FLOOR_BYTES // 2) as c:
        for path, body, field in (
                ("/api/sizing", sizing_body(), "requirement"),
                ("/api/jobs/sizing", sizing_body(), "requirement"),
                ("/api/jobs/control-study", {"study": control_study()}, "study.samples"),
                ("/api/studies", study_body(workers=1), "workers"),
                ("/api/simulate", _closed_loop(), "scenario.duration")):
            r = c.post(path, json=body)
            assert r.status_code == 422, (path, r.text[:400])
            assert r.json()["detail"][0]["field"] == field, (path, r.json())
            assert "analysis_memory_budget" in r.json()["detail"][0]["msg"]


def test_every_route_that_takes_a_json_body_counts_a_large_one():
    """A large JSON body is parsed off the event loop and held on the budget by the routers'
    route class (:class:`app.bodies.OffLoopRoute`): the heat models', the calibration's, the
    reports' and the friction map's bodies carry records as the analyses' do, and were not
    counted. Every POST/PUT/PATCH route of the API is served by that class."""
    from fastapi.routing import APIRoute
    from app.bodies import OffLoopRoute
    from app.main import create_app

    def routes(rs):   # the app's routes, through the routers it includes
        for r in rs:
            inner = getattr(r, "original_router", None)
            if inner is not None:
                yield from routes(inner.routes)
            else:
                yield "", r
    body = [(prefix + r.path, r) for prefix, r in routes(create_app().routes)
            if isinstance(r, APIRoute) and {"POST", "PUT", "PATCH"} & set(r.methods)]
    assert len(body) > 30 and any("heat-models" in p for p, _ in body)
    plain = [p for p, r in body if not isinstance(r, OffLoopRoute)]
    assert plain == [], plain



def test_a_closed_loop_jobs_estimate_counts_the_pool_processes_its_runs_take(monkeypatch):
    """A closed-loop study or tuning runs on the studies' engine: on the local pool each
    process holds its own run (and its interpreter), so the job's estimate counts them as a
    study's does; on a cluster the runs are not this server's (the gap the memory guide
    reported: one run in the job's thread was counted where the pool's processes ran)."""
    import pneucore.study.execute as X
    from app.analysis_memory import CONTROL_RUN_BYTES, study_estimate
    from app.config import Limits
    from app.control_schemas import ControlStudyRequest
    from app.control_service import check_control_study
    from pneucore.simulate import output_samples
    req = ControlStudyRequest(study=control_study())
    samples = output_samples(0.5, 1e-3)          # the study's scenario: 0.5 s at 1 kHz
    runs = 2                                     # its grid of two masses
    est = {}
    for n in (1, 4):
        monkeypatch.setattr(X, "default_workers", lambda n=n: n)
        est[n] = check_control_study(req, Limits())
        # the study's figure for the same pool, and each run's row of the answer: exactly
        assert est[n] == study_estimate(samples, n) + runs * CONTROL_RUN_BYTES
    assert est[4] > est[1]
    # on a cluster: the floor and the answer's rows, whatever the local pool
    far = check_control_study(req, Limits(), "tcp://cluster:8786")
    assert far == study_estimate(samples, 4, local=False) + runs * CONTROL_RUN_BYTES < est[1]
