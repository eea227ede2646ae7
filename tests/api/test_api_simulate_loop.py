"""POST /api/simulate: small runs answered on the event loop by the express lane
(app/express_lane.py), the rest in a worker thread by the route (app/routers/simulate.py),
with the same answers and errors either way."""
from __future__ import annotations

import asyncio
import io
import json
import types

import numpy as np
import pytest

from api_conftest import api, client, db_path, live_server, scenario, sim_body  # noqa: F401 (fixtures)

import app.express_lane as lane
import app.routers.simulate as router
from app.responses import answer_form

NPZ = {"accept": "application/x-npz"}


@pytest.fixture(scope="module", autouse=True)
def compiled():
    """The core compiled (or loaded from the cache) in this process, as after the service's
    warm-up: before that, every run goes to a thread (test_nothing_compiles_on_the_loop)."""
    from pneucore.simulate import warm_up
    warm_up()


@pytest.fixture
def where(monkeypatch):
    """Records, for each simulation the lane or the route runs, whether it ran on the event
    loop and the step budget it got."""
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
    monkeypatch.setattr(lane, "simulate", spy)
    return seen


def _route_only(monkeypatch):
    """The lane takes nothing: every request goes to the route (a worker thread)."""
    monkeypatch.setattr(lane, "loop_candidate", lambda req: False)


def test_the_pulse_case_is_answered_on_the_loop(client, where):
    r = client.post("/api/simulate", json=sim_body())
    assert r.status_code == 200
    assert [p for p, _ in where] == ["loop"]
    assert where[0][1] == lane.LOOP_MAX_STEPS   # the loop's budget, not the request's


@pytest.mark.parametrize("accept", [{}, NPZ], ids=["json", "npz"])
def test_the_lane_and_the_route_answer_the_same_bytes_and_headers(client, where, monkeypatch, accept):
    on_loop = client.post("/api/simulate", json=sim_body(), headers=accept)
    _route_only(monkeypatch)
    in_thread = client.post("/api/simulate", json=sim_body(), headers=accept)
    assert [p for p, _ in where] == ["loop", "thread"]
    assert on_loop.status_code == in_thread.status_code == 200
    assert on_loop.content == in_thread.content
    assert dict(on_loop.headers) == dict(in_thread.headers)   # type, length, security headers


def test_the_npz_answer_holds_the_json_answer(client):
    js = client.post("/api/simulate", json=sim_body()).json()
    r = client.post("/api/simulate", json=sim_body(), headers=NPZ)
    assert r.headers["content-type"] == "application/x-npz"
    assert 'filename="simulation.npz"' in r.headers["content-disposition"]
    z = np.load(io.BytesIO(r.content))   # allow_pickle=False: numpy's default
    assert sorted(z.files) == sorted(list(js["series"]) + ["meta.json"])
    for name, values in js["series"].items():
        if name == "mode":
            assert z[name].tolist() == values
        else:   # orjson writes the shortest text that reads back to the same double
            assert np.array_equal(z[name], np.array(values, dtype=float), equal_nan=True), name
    meta = json.loads(z["meta.json"])
    assert meta == {k: v for k, v in js.items() if k != "series"}
    assert len(r.content) < 0.8 * len(client.post("/api/simulate", json=sim_body()).content)


def test_the_npz_answer_honours_series(client):
    r = client.post("/api/simulate", json=sim_body(series=["t", "x"]), headers=NPZ)
    z = np.load(io.BytesIO(r.content))
    assert sorted(z.files) == ["meta.json", "t", "x"]
    assert json.loads(z["meta.json"])["units"] == {"t": "s", "x": "m"}


@pytest.mark.parametrize("accept, form", [
    ("", "json"), ("*/*", "json"), ("application/json", "json"), ("text/csv", "csv"),
    ("application/x-npz", "npz"), ("Application/X-NPZ; q=0.9", "npz"),
    ("application/json;q=0.5, application/x-npz", "npz"),
    ("application/x-npz;q=0.2, text/csv;q=0.8", "csv"),
    ("text/csv, application/x-npz", "csv"),            # a tie: the first listed
    ("application/x-npz;q=nan", "json"), ("application/x-npz;q=x", "json"),
    ("image/png", "json")])
def test_accept_chooses_the_form(accept, form):
    assert answer_form(accept, offered=("json", "csv", "npz")) == form


def test_a_form_the_endpoint_does_not_offer_is_not_chosen():
    assert answer_form("application/x-npz", offered=("json", "csv")) == "json"


def test_a_run_past_the_loop_budget_is_redone_in_a_thread(client, where, monkeypatch):
    ref = client.post("/api/simulate", json=sim_body())
    assert ref.status_code == 200
    steps = ref.json()["stats"]["steps"]
    where.clear()
    monkeypatch.setattr(lane, "LOOP_MAX_STEPS", steps // 4)   # the pulse case needs more
    r = client.post("/api/simulate", json=sim_body())
    assert r.status_code == 200
    assert [p for p, _ in where] == ["loop", "thread"]
    assert where[1][1] > steps // 4                  # the thread has the request's whole budget
    assert r.content == ref.content                  # same answer, byte for byte


def test_a_failed_run_is_reported_by_the_route(client, where):
    # the request's own budget (10 steps) runs out on the loop; the route runs it again (at
    # most the loop's budget of work lost) and gives the documented 422
    r = client.post("/api/simulate", json=sim_body(s=scenario(solver={"max_steps": 10})))
    assert r.status_code == 422
    err = r.json()["detail"][0]
    assert err["type"] == "simulation_error" and "max_steps" in err["msg"]
    assert [p for p, _ in where] == ["loop", "thread"]


@pytest.mark.parametrize("mutate, field", [
    (lambda b: b["model"]["jack"].update(bore=-1.0), "model.jack.bore"),
    (lambda b: b["scenario"].update(duration="long"), "scenario.duration"),
    (lambda b: b.update(series=["nope"]), "series")])
def test_bad_fields_are_the_routes_422_naming_them(client, where, mutate, field):
    body = sim_body()
    mutate(body)
    r = client.post("/api/simulate", json=body)
    assert r.status_code == 422
    assert any(field in json.dumps(e) for e in r.json()["detail"]), r.json()


def test_malformed_json_is_the_routes_422(client, where):
    r = client.post("/api/simulate", content=b'{"model": ', headers={"content-type": "application/json"})
    assert r.status_code == 422 and where == []


def test_past_the_loop_budget_the_request_budget_still_applies(db_path, where, monkeypatch):
    monkeypatch.setattr(lane, "LOOP_MAX_STEPS", 20)
    with api(db_path, max_steps=50) as c:   # the API's limit (50) is under the run's needs
        r = c.post("/api/simulate", json=sim_body())
    assert r.status_code == 422 and r.json()["detail"][0]["type"] == "simulation_error"
    assert [(p, n) for p, n in where] == [("loop", 20), ("thread", 50)]


def test_many_samples_go_to_a_thread(client, where):
    s = scenario(sample_period=1.0 / lane.LOOP_MAX_SAMPLES)   # 1 s: more samples than the loop takes
    assert client.post("/api/simulate", json=sim_body(s=s)).status_code == 200
    assert [p for p, _ in where] == ["thread"]


def test_many_breakpoints_go_to_a_thread(client, where):
    n = lane.LOOP_MAX_COMMAND_POINTS + 1
    s = scenario(command=[[i / n, 0.0] for i in range(n)])
    assert client.post("/api/simulate", json=sim_body(s=s)).status_code == 200
    assert [p for p, _ in where] == ["thread"]


def test_a_large_body_goes_to_the_route(client, where):
    from app.bodies import LOOP_PARSE_BYTES
    body = sim_body()
    body["model"]["description"] = "x" * LOOP_PARSE_BYTES   # read and parsed off the loop
    r = client.post("/api/simulate", json=body)
    assert r.status_code in (200, 422)   # whatever the route says of the field
    assert [p for p, _ in where] in ([], ["thread"])


def test_csv_answers_go_to_a_thread(client, where):
    r = client.post("/api/simulate", json=sim_body(), headers={"accept": "text/csv"})
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/csv")
    assert [p for p, _ in where] == ["thread"]


def test_a_body_that_is_not_json_goes_to_the_route(client, where):
    r = client.post("/api/simulate", content=json.dumps(sim_body()).encode(),
                    headers={"content-type": "text/plain"})
    assert r.status_code == 422 and where == []


def test_a_header_given_twice_is_read_as_the_route_reads_it(client, where):
    # the first of two content types is the one FastAPI's route reads: text, not JSON
    body = json.dumps(sim_body()).encode()
    r = client.post("/api/simulate", content=body,
                    headers=[("content-type", "text/plain"), ("content-type", "application/json")])
    assert r.status_code == 422 and where == []
    r = client.post("/api/simulate", content=body,
                    headers=[("content-type", "application/json"), ("accept", "application/x-npz"),
                             ("accept", "application/json")])
    assert r.status_code == 200 and r.headers["content-type"] == "application/x-npz"
    assert [p for p, _ in where] == ["loop"]


def test_the_guard_still_stands_before_the_lane(db_path, where):
    from fastapi.testclient import TestClient

    from app.config import Settings
    from app.main import create_app
    app = create_app(Settings(db_path=str(db_path), token="s3cret-token-for-tests"))
    with TestClient(app, base_url="http://127.0.0.1") as c:
        assert c.post("/api/simulate", json=sim_body()).status_code == 401
        assert c.post("/api/simulate", json=sim_body(),
                      headers={"origin": "http://evil.example"}).status_code == 403
        ok = c.post("/api/simulate", json=sim_body(),
                    headers={"authorization": "Bearer s3cret-token-for-tests"})
        assert ok.status_code == 200 and "frame-ancestors 'none'" in ok.headers["content-security-policy"]
    with TestClient(app, base_url="http://evil.example") as c:
        assert c.post("/api/simulate", json=sim_body()).status_code == 400
    assert [p for p, _ in where] == ["loop"]


def test_nothing_compiles_on_the_loop(client, where, monkeypatch):
    # while the core is not compiled (or loaded) in this process, every run goes to a thread
    monkeypatch.setattr(lane, "integrate", types.SimpleNamespace(overloads={}))
    assert client.post("/api/simulate", json=sim_body()).status_code == 200
    assert [p for p, _ in where] == ["thread"]


def test_user_terms_go_to_a_thread(monkeypatch):
    # a user effect with compiled terms needs a specialised core (compiled on first use)
    from app.schemas import SimulateRequest
    fx = dict(lane.EFFECTS, my_terms=types.SimpleNamespace(terms=object()))
    monkeypatch.setattr(lane, "EFFECTS", fx)
    plain = SimulateRequest.model_validate(sim_body())
    assert lane.loop_candidate(plain)
    body = sim_body()
    body["model"]["effects"] = {"my_terms": {}}
    assert not lane.loop_candidate(SimulateRequest.model_validate(body))


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
        assert not lane.loop_candidate(SimulateRequest.model_validate(body))
        assert lane.loop_candidate(SimulateRequest.model_validate(sim_body()))
    finally:
        unregister_friction_law("test_loop_half")


def test_concurrent_clients_get_the_answers_they_would_get_alone(db_path):
    # a real server, 12 clients at once, each sending every kind of request in its own order:
    # answered on the loop (JSON, .npz), in a thread (CSV, many samples), refused (a bad field),
    # failed on the loop and reported by the route (a budget of 10 steps). Each answer must be
    # the one the request gets alone, byte for byte
    import random
    from concurrent.futures import ThreadPoolExecutor

    import httpx
    bad = sim_body()
    bad["model"]["jack"]["bore"] = -1.0
    cases = {
        "json": (sim_body(), {}),
        "npz": (sim_body(), NPZ),
        "csv": (sim_body(), {"accept": "text/csv"}),
        "bad": (bad, {}),
        "samples": (sim_body(s=scenario(sample_period=1.0 / lane.LOOP_MAX_SAMPLES)), {}),
        "budget": (sim_body(s=scenario(solver={"max_steps": 10})), {}),
    }
    with live_server(db_path) as url:
        def post(c, k):
            body, headers = cases[k]
            r = c.post("/api/simulate", json=body, headers=headers)
            return r.status_code, r.content

        with httpx.Client(base_url=url, timeout=120) as c:   # timeout: a bound on a hang
            alone = {k: post(c, k) for k in cases}
        assert [alone[k][0] for k in cases] == [200, 200, 200, 422, 200, 422]

        def one_client(seed):
            order = list(cases) * 2
            random.Random(seed).shuffle(order)
            with httpx.Client(base_url=url, timeout=120) as c:
                return [(k, post(c, k)) for k in order]
        with ThreadPoolExecutor(12) as pool:
            together = [a for answers in pool.map(one_client, range(12)) for a in answers]
    assert len(together) == 12 * 2 * len(cases)
    wrong = [k for k, got in together if got != alone[k]]
    assert not wrong, wrong
