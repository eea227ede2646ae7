"""Validate once, at the boundary (issue 13): a built Scenario is not validated again on every
replay, and the API checks a diagnosis request once (the library still checks it when called
directly from Python)."""
from __future__ import annotations

import copy
import time

import pytest

import pneucore.analysis.diagnose as diagnose_module
import pneucore.description.scenario as scenario_module
from api_conftest import LEAK_IDS, client, db_path, model  # noqa: F401
from pneucore.analysis.diagnose import diagnose
from pneucore.data.experiment import as_experiments
from pneucore.description.model import Model
from pneucore.description.presets import model_preset, scenario_preset
from pneucore.data.samples import load_sample
from pneucore.description.scenario import Scenario
from pneucore.description.validation import FieldError


@pytest.fixture
def validations(monkeypatch):
    """How many numbers the scenario parser validates (``pneucore.description.scenario.number`` calls)."""
    calls = []
    original = scenario_module.number

    def counting(*args, **kw):
        calls.append(args[1] if len(args) > 1 else kw.get("path"))
        return original(*args, **kw)
    monkeypatch.setattr(scenario_module, "number", counting)
    return calls


def _model(**changes):
    m = model_preset("paper-4way")
    m["jack"].update(changes)
    return Model.from_dict(m)


def test_a_built_scenario_is_not_validated_again(validations):
    m = _model()
    s = Scenario.from_dict(scenario_preset("paper-fig10-pulses"), m)
    assert validations
    validations.clear()
    assert Scenario.from_dict(s, m) is s
    assert validations == []
    # the checks that need the model still run: x0 beyond a shorter stroke
    s2 = Scenario.from_dict(dict(scenario_preset("paper-fig10-pulses"), x0=0.1), m)
    with pytest.raises(FieldError) as exc:
        Scenario.from_dict(s2, _model(stroke=0.05))
    assert exc.value.path == "scenario.x0"


def test_an_experiment_validates_its_scenario_once_per_model_shape(validations):
    m = _model()
    (e,) = as_experiments([load_sample("piston-leak")[1]], m.ambient.pressure)
    s = e.scenario_for(m)
    validations.clear()
    # replays on other parameter values (a calibration): the same Scenario, not validated again
    for mass in (1.0, 2.0, 3.0):
        m2 = m.copy()
        m2.jack.moving_mass = mass
        m2.friction.extend.fc0 = 5.0 * mass
        assert e.scenario_for(m2) is s
    assert validations == []
    # what the scenario depends on rebuilds it: the stroke (x0 is clipped to it) ...
    short = _model(stroke=0.5 * m.jack.stroke)
    assert e.scenario_for(short) is not s and e.scenario_for(short).x0 <= short.jack.stroke
    assert validations
    # ... and an edit of the experiment's scenario fields
    validations.clear()
    e.scenario = dict(e.scenario, x0=0.01)
    assert e.scenario_for(m).x0 == 0.01 and validations
    # the replay itself is unchanged: the cached scenario gives the same numbers
    fresh = copy.deepcopy(e)
    fresh._scenario_cache.clear()
    assert e.simulate(m).p_a.tolist() == fresh.simulate(m).p_a.tolist()


def test_the_library_still_validates_a_direct_call():
    m = _model()
    exps = as_experiments(load_sample("piston-leak"), m.ambient.pressure)
    with pytest.raises(FieldError) as exc:
        diagnose(m, exps, candidates=["no_such_effect"])
    assert exc.value.path == "candidates[0]"
    with pytest.raises(FieldError) as exc:
        diagnose(m, exps, uncertain=["jack.area_a"])
    assert exc.value.path == "uncertain[0]"


class _Stop(Exception):
    """Raised where the candidate effects are settled: the rest of the work is not needed."""


@pytest.fixture
def checks(monkeypatch):
    """Count check_request calls wherever it is imported; stop a diagnosis after its candidates."""
    calls = []
    original = diagnose_module.check_request

    def spy(*args, **kw):
        calls.append(args[1:] or kw)
        return original(*args, **kw)
    for target in ("pneucore.analysis.diagnose", "pneucore.analysis.history", "app.services"):
        monkeypatch.setattr(f"{target}.check_request", spy, raising=False)

    def stop(*args, **kw):
        raise _Stop("stopped after the candidates")
    monkeypatch.setattr(diagnose_module, "summarise", stop)
    return calls


@pytest.mark.parametrize("path, body", [
    ("/api/diagnose", {"candidates": ["piston_leakage"], "uncertain": ["friction.extend.fc0"]}),
    ("/api/refine", {"uncertain": ["friction.extend.fc0"], "max_rounds": 2}),
])
def test_the_api_checks_a_diagnosis_request_once(client, checks, path, body):
    r = client.post(path, json={"model": model(), "experiments": [{"dataset_id": i} for i in LEAK_IDS],
                                **body})
    assert r.status_code == 500 and "_Stop" in r.text, r.text[:300]   # stopped after the candidates
    assert len(checks) == 1, checks


@pytest.mark.parametrize("path, body", [
    ("/api/jobs/diagnose", {"candidates": ["piston_leakage"], "uncertain": ["friction.extend.fc0"]}),
    ("/api/jobs/refine", {"uncertain": ["friction.extend.fc0"], "max_rounds": 2}),
])
def test_a_job_runs_on_what_was_checked_at_submission(client, checks, path, body):
    r = client.post(path, json={"model": model(), "experiments": [{"dataset_id": i} for i in LEAK_IDS],
                                **body})
    assert r.status_code == 202, r.text[:300]
    t0 = time.monotonic()
    while (job := client.get(f"/api/jobs/{r.json()['id']}").json())["status"] in ("queued", "running"):
        assert time.monotonic() - t0 < 120, job   # a bound on a hang, not a speed claim
        time.sleep(0.05)
    assert job["status"] == "error" and "stopped after the candidates" in job["error"], job   # stopped on purpose
    assert len(checks) == 1, checks


def test_a_bad_request_is_still_a_422_naming_the_field(client, checks):
    r = client.post("/api/diagnose", json={"model": model(), "candidates": ["nope"],
                                           "experiments": [{"dataset_id": LEAK_IDS[0]}]})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "candidates[0]"
