"""Sample times at and a hair past the scenario's duration (issue 39, item 0).

A record's time column built as ``np.arange(n) * dt`` ends at ``(n - 1) * dt`` in floating
point, e.g. ``1400 * 0.001 = 1.4000000000000001`` for a 1.4 s test: every such sample is either
simulated or refused with a 422 naming it; none is left unwritten (a 500 before the fix).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from api_conftest import client, db_path, model  # noqa: F401
from pneucore.simulate import checked_sample_times, simulate


def _experiment(n, dt, duration=None, t_last=None):
    t = np.arange(n + 1) * dt
    if t_last is not None:
        t[-1] = t_last
    u = (t >= 0.05).astype(float)
    p = 1.013e5 + 3e5 * np.clip(t - 0.05, 0, None)
    scen = {"locked": True, "x0": 0.1}
    if duration is not None:
        scen["duration"] = duration
    return {"name": "arange", "scenario": scen,
            "measurement": {"t": t.tolist(), "u": u.tolist(), "p_a": p.tolist()}}


# 1400 * 0.001 = 1.4000000000000001, 300 * 0.001 = 0.30000000000000004: past the duration by
# one rounding (the duration declared 1.4 s / 0.3 s as a user would type it)
@pytest.mark.parametrize("n,dt,duration", [(1400, 0.001, 1.4), (700, 0.001, 0.7), (7, 0.1, 0.7)])
@pytest.mark.parametrize("path", ["/api/compare", "/api/diagnose"])
def test_arange_time_column_through_the_api(client, n, dt, duration, path):
    assert n * dt > duration     # the premise: the last sample lies a hair past the duration
    body = {"model": model(), "experiments": [_experiment(n, dt, duration)]}
    if path == "/api/diagnose":
        body.update(candidates=["piston_leakage"], uncertain=[])
    r = client.post(path, json=body)
    assert r.status_code in (200, 422), r.text[:800]
    if r.status_code == 422:
        assert "t" in r.text
    else:
        assert "IndexError" not in r.text


def test_every_sample_written_at_and_past_the_duration():
    from pneucore import model_preset, scenario_preset
    m = model_preset("paper-4way")
    s = scenario_preset("paper-fig10-pulses")
    s["duration"] = 0.7
    t = np.arange(701) * 0.001          # ends at 0.7000000000000001 > 0.7
    assert t[-1] > 0.7
    res = simulate(m, s, t_out=t)
    assert len(res.series["t"]) == 701
    assert all(res.series["mode"] != "")            # every sample was written
    for k in ("p_a", "x", "v"):
        assert np.all(np.isfinite(res.series[k])), k
    # the last sample is the state at the duration (the rounding is not a later time)
    assert res.series["t"][-1] == pytest.approx(0.7, abs=1e-15)


@pytest.mark.parametrize("past", [1e-3, 1e-6])
def test_a_sample_clearly_past_the_duration_is_refused(past):
    with pytest.raises(ValueError, match="t_out"):
        checked_sample_times([0.0, 0.1, 0.3 + past], 0.3)


def test_a_hair_past_is_the_duration():
    t = checked_sample_times([0.0, 0.1, 0.30000000000000004], 0.3)
    assert t[-1] == 0.3 and math.isfinite(t[-1])


@pytest.mark.parametrize("past", [1e-9, 0.05])
def test_a_record_past_the_declared_duration_is_refused_naming_it(client, past):
    # samples after the duration were dropped without a word: each is simulated or refused
    exp = _experiment(700, 0.001, 0.7)
    exp["measurement"]["t"][-1] = 0.7 + past if past < 0.001 else exp["measurement"]["t"][-1] + past
    r = client.post("/api/compare", json={"model": model(), "experiments": [exp]})
    assert r.status_code == 422, r.text[:500]
    err = r.json()["detail"][0]
    assert err["field"] == "experiments[0].scenario.duration" and "1 sample(s) after it" in err["msg"]
