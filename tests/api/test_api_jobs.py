"""Jobs: POST /api/jobs/{diagnose,calibrate,compare} -> 202 + id, GET /api/jobs/{id} until done;
bad input is a 422 up front, time limits stop a job with a clear error, the server keeps going."""

import pytest

from api_conftest import (CLEAN_IDS, LEAK_IDS, api, assert_field_error, client, db_path,  # noqa: F401
                          model, sim_body, wait_job)

LEAK = [{"dataset_id": i} for i in LEAK_IDS]
CLEAN = [{"dataset_id": i} for i in CLEAN_IDS]
BODIES = {
    "diagnose": lambda: {"model": model(), "experiments": LEAK},
    "compare": lambda: {"model": model(), "experiments": LEAK, "heat_models": True, "residuals": False},
    "calibrate": lambda: {"model": model(), "experiments": LEAK, "parameters": {
        "effects.piston_leakage.conductance": {"min": 0, "max": 1e-9, "value": 5e-11}}},
}


def _submit(c, kind, body=None):
    r = c.post(f"/api/jobs/{kind}", json=body if body is not None else BODIES[kind]())
    assert r.status_code == 202, r.text[:500]
    j = r.json()
    assert j["kind"] == kind and j["status"] in ("queued", "running")
    assert j["result"] is None and j["error"] is None
    return j["id"]


def test_diagnose_job_progress_and_result(client):
    jid = _submit(client, "diagnose")
    j, seen = wait_job(client, jid)
    assert j["status"] == "done", j["error"]
    assert j["progress"] == 1.0 and j["step"] == "done" and j["error"] is None
    assert j["started"] >= j["created"] and j["finished"] >= j["started"]
    progress = [s["progress"] for s in seen]
    assert progress == sorted(progress), progress  # never goes back
    assert progress[-1] == 1.0
    steps = {s["step"] for s in seen}
    assert any(s not in ("queued", "started", "done") for s in steps), steps  # real step texts
    assert j["result"]["verdict"] == "piston_leakage"
    # the job's result is the synchronous endpoint's result
    sync = client.post("/api/diagnose", json=BODIES["diagnose"]()).json()
    assert j["result"]["verdict"] == sync["verdict"]
    assert [x["effect"] for x in j["result"]["ranking"]] == [x["effect"] for x in sync["ranking"]]


def test_compare_and_calibrate_jobs(client):
    ids = {k: _submit(client, k) for k in ("compare", "calibrate")}
    assert len(set(ids.values())) == 2
    j, _ = wait_job(client, ids["compare"])
    assert j["status"] == "done", j["error"]
    assert set(j["result"]["heat_models"]) == {"isothermal", "adiabatic", "convective"}
    j, _ = wait_job(client, ids["calibrate"])
    assert j["status"] == "done", j["error"]
    v = j["result"]["values"]["effects.piston_leakage.conductance"]
    assert v["value"] == pytest.approx(8e-11, rel=0.01)  # hidden truth; noise-limited fit, ~0.1 % stderr


def test_unknown_job_404(client):
    r = client.get("/api/jobs/nope")
    assert r.status_code == 404 and "nope" in r.json()["detail"]


# ------------------------------------------------------------------------------ 422 up front
@pytest.mark.parametrize("kind", list(BODIES))
def test_invalid_body_is_422_not_a_failed_job(client, kind):
    b = BODIES[kind]()
    b["experiments"] = [{"dataset_id": "nope"}]
    assert_field_error(client.post(f"/api/jobs/{kind}", json=b), "experiments[0].dataset_id")
    b = BODIES[kind]()
    b["model"]["jack"]["rod_a"] = 0.04
    assert_field_error(client.post(f"/api/jobs/{kind}", json=b), "model.jack.rod_a")
    b = BODIES[kind]()
    del b["model"]
    r = client.post(f"/api/jobs/{kind}", json=b)
    assert r.status_code == 422 and r.json()["detail"][0]["type"] == "missing"
    b = BODIES[kind]()
    from app.config import Limits
    b["experiments"] = CLEAN[:1] * (Limits().max_experiments + 1)   # one past the limit
    assert_field_error(client.post(f"/api/jobs/{kind}", json=b), "experiments")


def _post_expect_422(c, kind, body):
    """POST a job that must be refused up front. If it is accepted instead, wait for the job to
    end (no worker left running past the app) and fail with what became of it."""
    r = c.post(f"/api/jobs/{kind}", json=body)
    if r.status_code == 202:
        j, _ = wait_job(c, r.json()["id"])
        pytest.fail(f"accepted as job (202), which then ended {j['status']!r}: {j['error']}")
    assert r.status_code == 422, r.text[:300]
    return r


def test_diagnose_job_unknown_candidate_is_422(client):
    r = _post_expect_422(client, "diagnose", {**BODIES["diagnose"](), "candidates": ["warp_drive"]})
    assert_field_error(r, "candidates[0]")


def test_diagnose_job_unknown_uncertain_path_is_422(client):
    _post_expect_422(client, "diagnose", {**BODIES["diagnose"](), "uncertain": ["heat.bogus"]})


def test_calibrate_job_unknown_parameter_is_422(client):
    r = _post_expect_422(client, "calibrate", {**BODIES["calibrate"](),
                                               "parameters": {"heat.bogus": {"min": 0, "max": 1}}})
    assert_field_error(r, "parameters.heat.bogus")


def test_compare_job_unknown_heat_model_is_422(client):
    _post_expect_422(client, "compare", {**BODIES["compare"](), "heat_models": ["bogus"]})


# ------------------------------------------------------------------------------ limits
def test_diagnose_job_time_limit(db_path):
    with api(db_path, job_time_limit=0.01) as c:
        jid = _submit(c, "diagnose")
        j, _ = wait_job(c, jid)
        assert j["status"] == "error" and j["result"] is None
        assert "time limit" in j["error"] and "0.01 s" in j["error"], j["error"]
        assert j["step"] == "failed" and j["finished"] is not None
        # the server keeps answering, and the worker takes the next job
        assert c.get("/api/presets").status_code == 200
        assert c.post("/api/simulate", json=sim_body(series=["x"])).status_code == 200
        j2, _ = wait_job(c, _submit(c, "diagnose"))
        assert j2["status"] == "error" and "time limit" in j2["error"]


@pytest.mark.parametrize("kind", ["compare", "calibrate"])
def test_every_job_kind_obeys_the_time_limit(db_path, kind):
    # both jobs do tens of simulations (~10 ms each): far beyond a 10 ms budget
    with api(db_path, job_time_limit=0.01) as c:
        j, _ = wait_job(c, _submit(c, kind))
        assert j["status"] == "error", (f"{kind} job ran {j['finished'] - j['started']:.3f} s "
                                        f"under a 0.01 s limit and ended {j['status']!r}")
        assert "time limit" in j["error"]


def test_queue_limit_429(db_path):
    with api(db_path, max_jobs=1) as c:
        first = _submit(c, "diagnose")  # ~0.5 s of work: still active when the next one comes
        r = c.post("/api/jobs/diagnose", json=BODIES["diagnose"]())
        assert r.status_code == 429 and "limit 1" in r.json()["detail"]
        j, _ = wait_job(c, first)
        assert j["status"] == "done"
        jid = _submit(c, "compare")  # room again once the first is finished
        assert wait_job(c, jid)[0]["status"] == "done"


def test_server_answers_while_a_job_runs(client):
    jid = _submit(client, "diagnose")
    r = client.post("/api/simulate", json=sim_body(series=["x"]))
    assert r.status_code == 200
    assert client.get(f"/api/jobs/{jid}").status_code == 200
    assert wait_job(client, jid)[0]["status"] == "done"


def test_polling_a_finished_job_is_stable(client):
    jid = _submit(client, "compare")
    j, _ = wait_job(client, jid)
    # polling a finished job returns the same record each time
    assert client.get(f"/api/jobs/{jid}").json() == client.get(f"/api/jobs/{jid}").json() == j


def test_terminal_status_is_published_last(db_path, monkeypatch):
    """What a GET sees at the instant a job turns "done"/"error" must be the complete record.

    The spy records the job's JSON right when the worker assigns the terminal status, i.e.
    exactly what a concurrent GET /api/jobs/{id} can return at that moment (deterministic
    stand-in for the poller winning the race).
    """
    import app.jobs as jobs_mod
    snaps = []
    orig = jobs_mod.Job.__setattr__

    def spy(self, name, value):
        orig(self, name, value)
        if name == "status" and value in ("done", "error"):
            snaps.append(self.to_dict())
    monkeypatch.setattr(jobs_mod.Job, "__setattr__", spy)
    with api(db_path) as c:
        wait_job(c, _submit(c, "compare"))
    with api(db_path, job_time_limit=0.01) as c:
        wait_job(c, _submit(c, "diagnose"))
    done, err = snaps
    assert done["status"] == "done" and err["status"] == "error"
    problems = []
    if done["progress"] != 1.0 or done["step"] != "done" or done["finished"] is None:
        problems.append(f"done but progress={done['progress']}, step={done['step']!r}, "
                        f"finished={done['finished']}")
    if err["error"] is None or err["step"] != "failed" or err["finished"] is None:
        problems.append(f"error but error={err['error']!r}, step={err['step']!r}, "
                        f"finished={err['finished']}")
    assert not problems, problems
