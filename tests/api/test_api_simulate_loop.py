"""POST /api/simulate: small runs answered on the event loop, the rest in a worker thread
(app/routers/simulate.py), with the same answers and errors either way."""
from __future__ import annotations

import asyncio
import types

import pytest

from api_conftest import api, client, db_path, scenario, sim_body  # noqa: F401 (fixtures)

import app.routers.simulate as router


@pytest.fixture(scope="module", autouse=True)
def compiled():
    """The core compiled (or loaded from the cache) in this process, as after the service's
    warm-up: before that, every run goes to a thread (test_nothing_compiles_on_the_loop)."""
    from pneucore.simulate import warm_up
    warm_up()


@pytest.fixture
def where(monkeypatch):
    """Records, for each simulation the router runs, whether it ran on the event loop and
    the step budget it got."""
    seen = []
    real = router.simulate

    def spy(model, scen, *a, **k):
        try:
            asyncio.get_running_loop()
            place = "loop"
        except RuntimeError:
            place = "thread"
        seen.append((place, scen.solver.max_steps))
        return real(model, scen, *a, **k)
    monkeypatch.setattr(router, "simulate", spy)
    return seen


def test_the_pulse_case_is_answered_on_the_loop(client, where):
    r = client.post("/api/simulate", json=sim_body())
    assert r.status_code == 200
    assert [p for p, _ in where] == ["loop"]
    assert where[0][1] == router.LOOP_MAX_STEPS   # the loop's budget, not the request's


def test_while_other_requests_are_in_progress_runs_go_to_a_thread(client, where, monkeypatch):
    # under uvicorn, app.http_protocol counts the requests received and not yet answered
    monkeypatch.setattr(router, "requests_in_progress", lambda: 3)
    assert client.post("/api/simulate", json=sim_body()).status_code == 200
    monkeypatch.setattr(router, "requests_in_progress", lambda: 1)   # this one alone
    assert client.post("/api/simulate", json=sim_body()).status_code == 200
    assert [p for p, _ in where] == ["thread", "loop"]


def test_a_run_past_the_loop_budget_is_redone_in_a_thread(client, where, monkeypatch):
    ref = client.post("/api/simulate", json=sim_body())
    assert ref.status_code == 200
    steps = ref.json()["stats"]["steps"]
    where.clear()
    monkeypatch.setattr(router, "LOOP_MAX_STEPS", steps // 4)   # the pulse case needs more
    r = client.post("/api/simulate", json=sim_body())
    assert r.status_code == 200
    assert [p for p, _ in where] == ["loop", "thread"]
    assert where[1][1] > steps // 4                  # the thread has the request's whole budget
    assert r.content == ref.content                  # same answer, byte for byte


def test_a_request_budget_under_the_loop_budget_fails_on_the_loop(client, where):
    # the request's own budget (10 steps) is what runs out: the error is final, no retry
    r = client.post("/api/simulate", json=sim_body(s=scenario(solver={"max_steps": 10})))
    assert r.status_code == 422
    err = r.json()["detail"][0]
    assert err["type"] == "simulation_error" and "max_steps" in err["msg"]
    assert [p for p, _ in where] == ["loop"]


def test_past_the_loop_budget_the_request_budget_still_applies(db_path, where, monkeypatch):
    monkeypatch.setattr(router, "LOOP_MAX_STEPS", 20)
    with api(db_path, max_steps=50) as c:   # the API's limit (50) is under the run's needs
        r = c.post("/api/simulate", json=sim_body())
    assert r.status_code == 422 and r.json()["detail"][0]["type"] == "simulation_error"
    assert [(p, n) for p, n in where] == [("loop", 20), ("thread", 50)]


def test_many_samples_go_to_a_thread(client, where):
    s = scenario(sample_period=1.0 / router.LOOP_MAX_SAMPLES)   # 1 s: more samples than the loop takes
    assert client.post("/api/simulate", json=sim_body(s=s)).status_code == 200
    assert [p for p, _ in where] == ["thread"]


def test_many_breakpoints_go_to_a_thread(client, where):
    n = router.LOOP_MAX_COMMAND_POINTS + 1
    s = scenario(command=[[i / n, 0.0] for i in range(n)])
    assert client.post("/api/simulate", json=sim_body(s=s)).status_code == 200
    assert [p for p, _ in where] == ["thread"]


def test_csv_answers_go_to_a_thread(client, where):
    r = client.post("/api/simulate", json=sim_body(), headers={"accept": "text/csv"})
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/csv")
    assert [p for p, _ in where] == ["thread"]


def test_nothing_compiles_on_the_loop(client, where, monkeypatch):
    # while the core is not compiled (or loaded) in this process, every run goes to a thread
    monkeypatch.setattr(router, "integrate", types.SimpleNamespace(overloads={}))
    assert client.post("/api/simulate", json=sim_body()).status_code == 200
    assert [p for p, _ in where] == ["thread"]


def test_user_terms_go_to_a_thread(monkeypatch):
    # a user effect with compiled terms needs a specialised core (compiled on first use)
    from app.schemas import SimulateRequest
    fx = dict(router.EFFECTS, my_terms=types.SimpleNamespace(terms=object()))
    monkeypatch.setattr(router, "EFFECTS", fx)
    plain = SimulateRequest.model_validate(sim_body())
    assert router._loop_candidate(plain)
    body = sim_body()
    body["model"]["effects"] = {"my_terms": {}}
    assert not router._loop_candidate(SimulateRequest.model_validate(body))


def test_a_law_registered_at_run_time_goes_to_a_thread():
    # its core is compiled in memory on first use (~10 s): never on the loop
    from numba import njit

    from app.schemas import SimulateRequest
    from pneucore.physics.friction import (register_friction_law, sliding_friction,
                                           unregister_friction_law)

    @njit
    def half(v, direction, fc, kv, ratio, v_s):
        return 0.5 * sliding_friction(v, direction, fc, kv, ratio, v_s)

    body = sim_body()
    body["model"].setdefault("friction", {})["law"] = "test_loop_half"
    register_friction_law("test_loop_half", half, description="0.5 x Eq. 18 (test)")
    try:
        assert not router._loop_candidate(SimulateRequest.model_validate(body))
        assert router._loop_candidate(SimulateRequest.model_validate(sim_body()))
    finally:
        unregister_friction_law("test_loop_half")
