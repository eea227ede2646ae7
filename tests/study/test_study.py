"""Robustness studies: definition checks, metrics, sampling, local pool, Dask LocalCluster,
killed workers, interrupted and resumed studies, results and sensitivity."""
import contextlib
import json
import math
import multiprocessing
import os
import signal
import socket
import sqlite3
import subprocess
import sys
import time

import numpy as np
import pytest
from scipy import stats

from dask_cluster import local_cluster

from pneucore import FieldError, model_preset, scenario_preset, simulate
from pneucore.study import (MAX_RUNS, METRICS, SchedulerError, Study, StudyInterrupted, factorial_indices, main,
                            rank_correlations, run_metrics, run_study, study_results, study_status)
from pneucore.study.metrics import air_consumption

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

#: A short extension pulse (0.3 s): the piston moves ~75 mm, overshoots and sticks
SHORT = {"duration": 0.3, "sample_period": 0.001, "command": [[0, 0], [0.02, 0.7], [0.06, 0]],
         "x0": 0.1}


def short_study(samples=40, seed=3, **extra):
    d = {"model": model_preset("paper-4way"), "scenario": dict(SHORT),
         "parameters": {"friction.extend.fc0": {"distribution": "uniform", "min": 4.0, "max": 16.0},
                        "supply.pressure": {"distribution": "normal", "mean": 6e5, "std": 4e4,
                                            "min": 4.5e5, "max": 7.5e5}},
         "samples": samples, "seed": seed}
    d.update(extra)
    return d


def paper_study(samples, seed=7):
    """The realistic case: paper-4way with the Fig. 10 pulse train (1 s)."""
    return {"model": model_preset("paper-4way"), "scenario": scenario_preset("paper-fig10-pulses"),
            "parameters": {"friction.extend.fc0": {"distribution": "uniform", "min": 4.0, "max": 16.0},
                           "supply.pressure": {"distribution": "uniform", "min": 5e5, "max": 7e5}},
            "samples": samples, "seed": seed}


def runs_of(db, sid):
    return study_results(db, sid)["runs"]


def n_studies(db):
    if not os.path.exists(db):
        return 0
    with sqlite3.connect(db) as c:
        return c.execute("SELECT COUNT(*) FROM studies").fetchone()[0]


# -- definition ----------------------------------------------------------------------------
def test_definition_round_trips_to_json():
    d = short_study()
    d["parameters"]["heat.coefficient"] = {"grid": [15, 25, 35]}
    d["parameters"]["valve.ports.*.C"] = {"distribution": "lognormal", "median": 1.0, "sigma": 0.1,
                                          "max": 1.3}
    d["metrics"] = ["t95", "air_consumption"]
    s = Study.from_dict(d)
    text = s.to_json()
    s2 = Study.from_json(text)
    assert s2.to_json() == text
    assert json.loads(text)["parameters"]["heat.coefficient"] == {"grid": [15.0, 25.0, 35.0]}
    assert s.design == "mixed" and s.n_runs == 3 * 40
    np.testing.assert_array_equal(s.values(), s2.values())  # same definition, same parameter sets


BAD = [
    # (mutation, field path the message must start with)
    (lambda d: d["parameters"].update({"jack.bore_x": {"grid": [1]}}), "parameters.jack.bore_x"),
    (lambda d: d["parameters"].update({"pump.speed": {"grid": [1]}}), "parameters.pump.speed"),
    (lambda d: d["parameters"]["supply.pressure"].update(std=-1e4), "parameters.supply.pressure.std"),
    (lambda d: d["parameters"]["supply.pressure"].update(std=0), "parameters.supply.pressure.std"),
    (lambda d: d["parameters"]["friction.extend.fc0"].update(min=16, max=4),
     "parameters.friction.extend.fc0"),
    (lambda d: d["parameters"]["friction.extend.fc0"].update(min=5, max=5),
     "parameters.friction.extend.fc0"),
    # bar instead of Pa: the bounds keep no probability mass
    (lambda d: d["parameters"]["supply.pressure"].update(min=4.5, max=7.5), "parameters.supply.pressure"),
    (lambda d: d["parameters"].update({"heat.coefficient": {"distribution": "lognormal", "median": 25,
                                                            "sigma": 0.2, "max": -1}}),
     "parameters.heat.coefficient"),
    (lambda d: d["parameters"].update({"heat.coefficient": {"distribution": "lognormal", "median": -2,
                                                            "sigma": 0.2}}),
     "parameters.heat.coefficient.median"),
    (lambda d: d["parameters"]["friction.extend.fc0"].update(distribution="weibull"),
     "parameters.friction.extend.fc0.distribution"),
    (lambda d: d["parameters"]["friction.extend.fc0"].pop("max"), "parameters.friction.extend.fc0.max"),
    (lambda d: d["parameters"]["friction.extend.fc0"].update(mode=3), "parameters.friction.extend.fc0.mode"),
    (lambda d: d["parameters"].update({"jack.bore": {"grid": [0.032, -0.04]}}), "parameters.jack.bore.grid[1]"),
    (lambda d: d["parameters"].update({"jack.bore": {"grid": []}}), "parameters.jack.bore.grid"),
    (lambda d: d["parameters"]["friction.extend.fc0"].update(min=-3), "parameters.friction.extend.fc0.min"),
    (lambda d: d.update(samples=MAX_RUNS + 1), "samples"),
    (lambda d: d.update(samples=0), "samples"),
    (lambda d: d.update(samples=None), "samples"),
    (lambda d: d.update(samples=2.5), "samples"),
    (lambda d: d.update(parameters={"jack.bore": {"grid": list(np.linspace(0.02, 0.04, 1001))},
                                    "jack.moving_mass": {"grid": list(np.linspace(1, 3, 1001))}}),
     "parameters"),
    (lambda d: d.update(parameters={"jack.bore": {"grid": [0.03, 0.032]}}, samples=5), "samples"),
    (lambda d: d.update(parameters={}), "parameters"),
    (lambda d: d.update(seed=-1), "seed"),
    (lambda d: d.update(seed="x"), "seed"),
    (lambda d: d.update(metrics=["t95", "t99"]), "metrics[1]"),
    (lambda d: d.update(metrics=["t95", "t95"]), "metrics[1]"),
    (lambda d: d["model"]["jack"].update(rod_a=0.05), "model.jack.rod_a"),
    (lambda d: d["scenario"].update(x0=0.3), "scenario.x0"),
    (lambda d: d.update(sample=40), "sample"),
    (lambda d: d.pop("model"), "model"),
]


@pytest.fixture
def no_work(monkeypatch):
    """Any pool, Dask engine or simulation started during the test fails it."""
    import pneucore.study.execute as ex

    def forbidden(*a, **k):
        raise AssertionError("work started before the input was checked")
    for name in ("_LocalEngine", "_DaskEngine", "_InlineEngine", "run_batch", "run_block", "simulate"):
        monkeypatch.setattr(ex, name, forbidden)


@pytest.mark.parametrize("mutate,path", BAD)
def test_bad_definition_fails_fast_naming_the_field(tmp_path, mutate, path, no_work):
    d = short_study()
    mutate(d)
    db = str(tmp_path / "s.sqlite3")
    with pytest.raises(FieldError) as err:
        run_study(d, db, workers=2)
    # "before any work" is checked by the no_work fixture (engines and simulate forbidden),
    # not by timing, which depends on the machine's load
    assert str(err.value).startswith(path + ":") and err.value.path == path, str(err.value)
    assert n_studies(db) == 0


@pytest.mark.parametrize("kwargs,path", [
    ({"workers": -1}, "workers"), ({"workers": 1.5}, "workers"), ({"batch_size": 0}, "batch_size"),
    ({"study_id": "a b"}, "study_id"), ({"workers": 2, "scheduler": "tcp://127.0.0.1:1"}, "workers"),
    ({"scheduler": "tcp://"}, "scheduler"), ({"scheduler": 42}, "scheduler"),
])
def test_bad_options_fail_fast(tmp_path, kwargs, path, no_work):
    db = str(tmp_path / "s.sqlite3")
    with pytest.raises(FieldError) as err:
        run_study(short_study(), db, **kwargs)
    # no work started: the no_work fixture forbids the engines and simulate
    assert err.value.path == path, str(err.value)
    assert n_studies(db) == 0


def _closed_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def test_unreachable_scheduler_fails_fast(tmp_path, monkeypatch, no_work):
    db = str(tmp_path / "s.sqlite3")
    addr = f"tcp://127.0.0.1:{_closed_port()}"
    for kwargs in ({"scheduler": addr}, {}):
        if not kwargs:  # the same through the environment variable
            monkeypatch.setenv("PNEUCORE_DASK_SCHEDULER", addr)
        t0 = time.perf_counter()
        with pytest.raises(SchedulerError) as err:
            run_study(short_study(), db, scheduler_timeout=2.0, **kwargs)
        # it does not hang: the 2 s connection timeout bounds it; 15 s is the timeout plus
        # a cold import of dask.distributed on a loaded CI machine
        assert time.perf_counter() - t0 < 15.0
        assert err.value.path == "scheduler" and addr in str(err.value)
    assert n_studies(db) == 0


def test_resume_checks_the_id(tmp_path):
    db = str(tmp_path / "s.sqlite3")
    with pytest.raises(FieldError, match="^study_id: no study"):
        run_study(None, db, study_id="nope")
    run_study(short_study(samples=2), db, workers=0, study_id="a")
    with pytest.raises(FieldError, match="^study_id: .*different definition"):
        run_study(short_study(samples=3), db, workers=0, study_id="a")
    with pytest.raises(FieldError, match="^study:"):
        run_study(None, db)


# -- sampling --------------------------------------------------------------------------------
def test_sampling_is_deterministic_and_truncated():
    d = short_study(samples=4000, seed=11)
    d["parameters"]["heat.coefficient"] = {"distribution": "lognormal", "median": 25.0, "sigma": 0.3}
    s = Study.from_dict(d)
    X = s.values()
    np.testing.assert_array_equal(X, Study.from_dict(d).values())           # same seed, same sets
    assert not np.array_equal(X, Study.from_dict({**d, "seed": 12}).values())
    assert s.paths == ["friction.extend.fc0", "heat.coefficient", "supply.pressure"]
    fc0, h, p = X[:, 0], X[:, 1], X[:, 2]
    assert fc0.min() >= 4.0 and fc0.max() <= 16.0 and p.min() >= 4.5e5 and p.max() <= 7.5e5
    n = len(p)
    # Kolmogorov-Smirnov against the exact truncated law; p-value > 1e-3 fails 1 in 1000 seeds
    # (the seed is fixed, so this is deterministic)
    tn = stats.truncnorm((4.5e5 - 6e5) / 4e4, (7.5e5 - 6e5) / 4e4, loc=6e5, scale=4e4)
    assert stats.kstest(p, tn.cdf).pvalue > 1e-3
    assert stats.kstest(fc0, stats.uniform(4, 12).cdf).pvalue > 1e-3
    assert stats.kstest(h, stats.lognorm(0.3, scale=25.0).cdf).pvalue > 1e-3
    # run r's values come from row r whatever the batch
    assert s.run_values(17) == {"friction.extend.fc0": fc0[17], "supply.pressure": p[17],
                                "heat.coefficient": h[17]}
    # the order of the JSON keys does not matter
    rev = {**d, "parameters": dict(reversed(list(d["parameters"].items())))}
    np.testing.assert_array_equal(Study.from_dict(rev).values(), X)
    assert n == 4000


def test_far_tail_truncation_stays_accurate():
    # bounds 6-7 std above the mean keep 1e-9 of the mass: sampled on the lower tail by symmetry
    d = short_study(samples=2000)
    d["parameters"]["supply.pressure"] = {"distribution": "normal", "mean": 5e5, "std": 2e4,
                                          "min": 6.2e5, "max": 6.4e5}
    p = Study.from_dict(d).values()[:, 1]  # paths: friction.extend.fc0, supply.pressure
    tn = stats.truncnorm(6.0, 7.0, loc=5e5, scale=2e4)
    assert p.min() >= 6.2e5 and p.max() <= 6.4e5
    assert stats.kstest(p, tn.cdf).pvalue > 1e-3  # as above


def test_grid_and_mixed_designs():
    d = short_study(samples=3)
    d["parameters"] = {"supply.pressure": {"grid": [5e5, 6e5]}, "jack.moving_mass": {"grid": [1, 2, 3]},
                       "friction.extend.fc0": {"distribution": "uniform", "min": 4, "max": 16}}
    s = Study.from_dict(d)
    X = s.values()
    assert s.n_runs == 2 * 3 * 3 and s.design == "mixed"
    # columns in path order; the first grid parameter varies slowest; each grid point
    # gets `samples` consecutive runs
    assert s.paths == ["friction.extend.fc0", "jack.moving_mass", "supply.pressure"]
    np.testing.assert_array_equal(X[:, 1], np.repeat([1.0, 2.0, 3.0], 6))
    np.testing.assert_array_equal(X[:, 2], np.tile(np.repeat([5e5, 6e5], 3), 3))
    assert len(set(X[:, 0])) == 18
    g = Study.from_dict({**d, "parameters": {k: v for k, v in d["parameters"].items() if "grid" in v},
                         "samples": None})
    assert g.n_runs == 6 and g.design == "factorial"


# -- metrics -----------------------------------------------------------------------------------
def test_metrics_match_the_simulated_arrays():
    res = simulate(model_preset("paper-4way"), SHORT)
    m = run_metrics(res)
    assert set(m) == set(METRICS)
    t, x = res.t, res.x
    x0, xf = x[0], x[-1]
    travel = xf - x0
    assert travel > 0.05  # an extension of several centimetres
    assert m["x_final"] == xf and m["x_max"] == x.max() and m["x_min"] == x.min()
    assert m["overshoot"] == x.max() - xf
    assert m["p_a_max"] == res.p_a.max() and m["p_b_max"] == res.p_b.max()
    assert m["T_max"] == max(res.T_a.max(), res.T_b.max())
    assert m["T_min"] == min(res.T_a.min(), res.T_b.min())
    assert m["stick_events"] == len(res.events_of("stick")) >= 1
    # t95: the linear interpolant of x crosses x0 + 0.95 travel there (1e-12 m: rounding),
    # and no sample before it had reached that level
    target = x0 + 0.95 * travel
    assert abs(np.interp(m["t95"], t, x) - target) < 1e-12
    assert np.all(x[t < m["t95"]] < target)
    # settling: |x - x_final| meets the band there (1e-12 m: rounding), inside it afterwards
    band = max(0.02 * abs(travel), 1e-3)
    ts = m["settling_time"]
    assert abs(np.interp(ts, t, np.abs(x - xf)) - band) < 1e-12
    assert np.all(np.abs(x[t > ts] - xf) <= band)
    assert np.any(np.abs(x[t < ts] - xf) > band)
    # air: trapezoidal integral of the supply mass flow, in normal litres (1.185 kg/m^3);
    # the same arithmetic, so exactly equal
    assert m["air_consumption"] == np.trapezoid(res.q_supply, t) / 1.185 * 1000


def test_retraction_and_no_travel_metrics():
    ret = simulate(model_preset("paper-4way"), {**SHORT, "command": [[0, 0], [0.02, -0.7], [0.06, 0]]})
    m = run_metrics(ret)
    assert m["x_final"] < ret.x[0]
    assert m["overshoot"] == m["x_final"] - ret.x.min() > 0  # symmetric definition
    still = run_metrics(simulate(model_preset("paper-4way"), {**SHORT, "command": [[0, 0]]}))
    assert still["t95"] is None and still["overshoot"] is None  # no travel: undefined, not NaN
    assert still["settling_time"] == 0.0 and still["air_consumption"] == 0.0


def test_air_consumption_is_the_mass_drawn_from_the_supply():
    """Locked piston, valve P-A open: every kilogram from the supply ends in chamber A."""
    sc = scenario_preset("paper-fig6-locked-max")
    sc.update(duration=0.5, sample_period=1e-4)
    res = simulate(model_preset("paper-4way"), sc)
    dm = res.m_a[-1] - res.m_a[0]               # kg; chamber B stays at ambient (no flow)
    assert np.all(res.q_b == 0.0)
    # 0.2 %: trapezoid on 0.1 ms samples across the valve-opening step (measured 0.04 %)
    assert air_consumption(res.t, res.q_supply) == pytest.approx(dm / 1.185 * 1000, rel=2e-3)
    assert run_metrics(res, ["air_consumption"]) == {"air_consumption": air_consumption(res.t, res.q_supply)}


def test_single_run_study_equals_direct_simulation():
    d = short_study()
    d.update(parameters={"supply.pressure": {"grid": [5.5e5]}}, samples=None)
    out = run_study(d, workers=0)
    assert out["computed"] == 1 and out["status"] == "done"
    model = model_preset("paper-4way")
    model["supply"]["pressure"] = 5.5e5
    direct = run_metrics(simulate(model, SHORT))
    assert out["results"]["runs"]["metrics"] == {k: [v] for k, v in direct.items()}


def test_failed_runs_record_their_error():
    d = short_study(samples=6)
    # a normal without bounds around a tiny mass draws negative masses: invalid models
    d["parameters"]["jack.moving_mass"] = {"distribution": "normal", "mean": 0.01, "std": 1.0}
    res = run_study(d, workers=0)["results"]
    bad = [e for e in res["runs"]["error"] if e]
    assert bad and all(e.startswith("FieldError: jack.moving_mass") for e in bad)
    assert res["failed"] == len(bad) and res["metrics"]["t95"]["failed"] == len(bad)
    assert res["metrics"]["t95"]["count"] == 6 - len(bad)
    # a solver failure: the message is kept, metrics are null
    d2 = short_study(samples=2)
    d2["scenario"]["solver"] = {"max_steps": 10}
    r2 = run_study(d2, workers=0)["results"]
    assert all(e.startswith("SimulationError: simulation stopped") for e in r2["runs"]["error"])
    assert r2["runs"]["metrics"]["x_final"] == [None, None]
    assert sum(e["count"] for e in r2["errors"]) == 2 and r2["failed"] == 2


def test_runs_npz_holds_the_stored_runs_and_their_failures(tmp_path):
    import io

    from pneucore.study import runs_npz, study_results
    d = short_study(samples=6)
    d["parameters"]["jack.moving_mass"] = {"distribution": "normal", "mean": 0.01, "std": 1.0}
    store_path = str(tmp_path / "s.sqlite3")
    sid = "npz"
    run_study(d, store_path, workers=0, study_id=sid)
    res = study_results(store_path, sid)
    runs = res["runs"]
    z = np.load(io.BytesIO(runs_npz(store_path, sid)))   # no pickle
    assert z["run_index"].tolist() == runs["index"]
    paths = z["param_paths"].tolist()
    assert paths == list(runs["params"]) and z["params"].shape == (6, len(paths))
    for j, p in enumerate(paths):
        assert z["params"][:, j].tolist() == runs["params"][p]   # exact: float64 both ways
    names = z["metric_names"].tolist()
    for j, n in enumerate(names):
        assert [None if math.isnan(v) else v for v in z["metrics"][:, j].tolist()] == runs["metrics"][n], n
        assert z["metric_units"][j] == METRICS[n][0]
    assert dict(zip(paths, z["param_units"].tolist()))["jack.moving_mass"] == "kg"
    failed = [(i, e) for i, e in zip(runs["index"], runs["error"]) if e]
    assert failed and list(zip(z["failed_index"].tolist(), z["failed_error"].tolist())) == failed
    with pytest.raises(KeyError):
        runs_npz(store_path, "nope")
    # a study queued and not started: empty matrices of the right width
    from pneucore.study import queue_study
    queue_study(short_study(samples=3), store_path, study_id="queued")
    z = np.load(io.BytesIO(runs_npz(store_path, "queued")))
    assert z["params"].shape == (0, 2) and z["metrics"].shape == (0, len(z["metric_names"]))


# -- sensitivity --------------------------------------------------------------------------------
def test_prcc_matches_the_inverse_correlation_formula():
    rng = np.random.default_rng(0)
    X = rng.random((300, 3))
    y = 3 * X[:, 0] + 0.5 * X[:, 1] ** 3 + 0.05 * rng.standard_normal(300)
    out = rank_correlations(X, y)
    # independent formula: partial correlations from the inverse of the rank correlation matrix
    R = np.column_stack([stats.rankdata(c) for c in (*X.T, y)])
    P = np.linalg.inv(np.corrcoef(R, rowvar=False))
    for j in range(3):
        expect = -P[j, 3] / math.sqrt(P[j, j] * P[3, 3])
        assert out[j]["prcc"] == pytest.approx(expect, abs=1e-10)  # same quantity; rounding only
        rho, p = stats.spearmanr(X[:, j], y)
        assert out[j]["spearman"] == pytest.approx(rho, abs=1e-12)  # scipy itself
    # strong inputs: PRCC well above the noise (its standard error is ~1/sqrt(300) = 0.06)
    assert out[0]["prcc"] > out[1]["prcc"] > 0.5 and out[0]["prcc_p"] < 1e-50
    # pure noise input: |PRCC| < 0.2 (3.4 standard errors) and not significant at 1e-3
    assert abs(out[2]["prcc"]) < 0.2 and out[2]["prcc_p"] > 1e-3


def test_factorial_indices_of_an_additive_function():
    a, b = np.array([0.0, 1.0, 2.0]), np.array([0.0, 3.0])
    y = (a[:, None] + b[None, :]).ravel()         # C order: first factor slowest
    S1, ST = factorial_indices(y, (3, 2))
    va, vb = a.var(), b.var()
    # additive: first-order = total = own variance share (exact up to rounding)
    assert S1 == pytest.approx([va / (va + vb), vb / (va + vb)], abs=1e-12)
    assert ST == pytest.approx(S1, abs=1e-12)


def test_factorial_study_ranks_by_variance(tmp_path):
    d = short_study()
    d["parameters"] = {"supply.pressure": {"grid": [5e5, 6e5, 7e5]},
                       "jack.load_force": {"grid": [0.0, 1.0]}}
    d["samples"] = None
    db = str(tmp_path / "s.sqlite3")
    sid = run_study(d, db, workers=0)["id"]
    r = study_results(db, sid)
    rank = r["sensitivity"]["ranking"]["t95"]
    assert rank["method"] == "factorial_variance"
    top = rank["entries"][0]
    # +-1 bar of supply dominates t95 against a 1 N load change: more than 90 % of the variance
    assert top["parameter"] == "supply.pressure" and top["total"] > 0.9
    json.dumps(r, allow_nan=False)


# -- execution -------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The 40-run short study computed in this process: the numbers every engine must reproduce."""
    db = str(tmp_path_factory.mktemp("ref") / "ref.sqlite3")
    sid = run_study(short_study(), db, workers=0)["id"]
    return runs_of(db, sid)


def test_local_pool_small_study(tmp_path, reference):
    db = str(tmp_path / "s.sqlite3")
    seen = []
    out = run_study(short_study(), db, workers=2, batch_size=5, progress=lambda f, s: seen.append(f))
    assert out["status"] == "done" and out["computed"] == 40 and out["batches"] == 8
    assert "local process pool (2 workers)" in out["engine"]
    assert seen[0] == 0.0 and seen[-1] == 1.0 and seen == sorted(seen)
    assert runs_of(db, out["id"]) == reference  # bit-identical to the in-process computation
    r = study_results(db, out["id"])
    json.dumps(r, allow_nan=False)
    for name, d in r["metrics"].items():
        p = [d["percentiles"][k] for k in ("5", "25", "50", "75", "95")]
        assert d["count"] + d["undefined"] + d["failed"] == 40
        if d["count"] == 0:   # undefined in every run (a stroke metric of pulses reaching no end)
            assert p == [None] * 5 and d["min"] is None and d["max"] is None, name
            continue
        assert d["min"] <= p[0] <= p[1] <= p[2] <= p[3] <= p[4] <= d["max"], name
    rank = r["sensitivity"]["ranking"]
    assert rank["t95"]["method"] == "prcc"
    t95 = {e["parameter"]: e for e in rank["t95"]["entries"]}
    # more pressure: faster; more friction: slower (strong monotonic effects, |PRCC| > 0.9)
    assert t95["supply.pressure"]["prcc"] < -0.9 and t95["friction.extend.fc0"]["prcc"] > 0.9
    assert rank["air_consumption"]["entries"][0]["parameter"] == "supply.pressure"
    assert "runs" not in study_results(db, out["id"], include_runs=False)
    st = study_status(db, out["id"])
    assert st["fraction"] == 1.0 and st["status"] == "done"


class Stop(Exception):
    pass


def test_interrupted_study_resumes_without_recomputing(tmp_path, reference):
    db = str(tmp_path / "s.sqlite3")
    calls = []

    def progress(fraction, step):
        calls.append(fraction)
        if len(calls) == 3:  # the start report, then two stored batches
            raise Stop

    with pytest.raises(Stop):
        run_study(short_study(), db, workers=2, batch_size=5, progress=progress, study_id="s1")
    st = study_status(db, "s1")
    assert st["stored"] == 10 and st["status"] == "interrupted"
    out = run_study(None, db, workers=2, batch_size=5, study_id="s1")
    assert out["computed"] == 30 and out["already_stored"] == 10 and out["status"] == "done"
    assert runs_of(db, "s1") == reference  # same numbers as the uninterrupted study
    again = run_study(short_study(), db, workers=2, study_id="s1")
    assert again["computed"] == 0  # a finished study computes nothing


def test_killed_local_pool_worker_loses_no_run(tmp_path):
    db = str(tmp_path / "s.sqlite3")
    study = paper_study(240)
    before = {p.pid for p in multiprocessing.active_children()}
    killed = []

    def progress(fraction, step):
        if not killed and fraction > 0:  # after the first stored batch
            pool = [p for p in multiprocessing.active_children() if p.pid not in before]
            os.kill(pool[0].pid, signal.SIGKILL)
            killed.append(pool[0].pid)

    out = run_study(study, db, workers=2, batch_size=20, progress=progress)
    assert killed and out["status"] == "done" and out["computed"] == 240
    ref = run_study(study, workers=0)["results"]["runs"]
    assert runs_of(db, out["id"]) == ref


def test_sigkilled_study_resumes(tmp_path):
    """The whole study process (CLI, pool and all) is SIGKILLed mid-way, then resumed."""
    db = str(tmp_path / "s.sqlite3")
    spec = tmp_path / "study.json"
    study = paper_study(400, seed=5)
    spec.write_text(json.dumps(study))
    env = {**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", "")}
    env.pop("PNEUCORE_DASK_SCHEDULER", None)
    proc = subprocess.Popen([sys.executable, "-m", "pneucore.study", "run", str(spec), "--db", db,
                             "--workers", "2", "--batch-size", "10", "--id", "k1", "--quiet"],
                            env=env, cwd=str(tmp_path), start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    stored = 0
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            if os.path.exists(db):
                try:
                    with sqlite3.connect(db, timeout=1) as c:
                        stored = c.execute("SELECT COUNT(*) FROM study_runs").fetchone()[0]
                except sqlite3.OperationalError:
                    stored = 0
            if stored >= 20:
                break
            time.sleep(0.005)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)  # the CLI and its pool workers (its own session)
        err = proc.communicate()[1].decode()
    assert proc.returncode == -signal.SIGKILL, err
    st = study_status(db, "k1")
    assert 20 <= st["stored"] < 400 and st["status"] == "running"
    out = run_study(None, db, workers=2, study_id="k1")
    assert out["computed"] == 400 - st["stored"] and out["status"] == "done"
    ref = run_study(study, workers=0)["results"]["runs"]
    assert runs_of(db, "k1") == ref


def test_cli_run_and_results(tmp_path, capsys):
    spec = tmp_path / "study.json"
    spec.write_text(json.dumps(short_study(samples=6)))
    db = str(tmp_path / "s.sqlite3")
    assert main(["run", str(spec), "--db", db, "--workers", "0", "--id", "c1", "--quiet"]) == 0
    assert "study c1: done, 6 runs computed" in capsys.readouterr().out
    out_json = tmp_path / "r.json"
    assert main(["results", "--db", db, "--id", "c1", "--json", str(out_json)]) == 0
    text = capsys.readouterr().out
    assert "t95" in text and "air_consumption" in text
    assert json.loads(out_json.read_text())["stored"] == 6
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(short_study(samples=-1)))
    assert main(["run", str(bad), "--db", db]) == 2
    assert "samples:" in capsys.readouterr().err
    assert main(["list", "--db", db]) == 0 and "c1" in capsys.readouterr().out


# -- Dask ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def cluster():
    c = local_cluster(2)
    yield c
    c.close()


def test_dask_local_cluster_gives_the_same_numbers(tmp_path, cluster, reference):
    db = str(tmp_path / "s.sqlite3")
    out = run_study(short_study(), db, scheduler=cluster.scheduler_address, batch_size=5)
    assert out["computed"] == 40 and out["status"] == "done" and "dask.distributed" in out["engine"]
    assert runs_of(db, out["id"]) == reference


def test_dask_killed_worker_loses_no_run(tmp_path, cluster):
    from distributed import Client
    db = str(tmp_path / "s.sqlite3")
    study = paper_study(240)
    client = Client(cluster.scheduler_address, set_as_default=False)
    try:
        client.wait_for_workers(2, timeout=30)
        pids = client.run(os.getpid)  # worker address -> worker process id
        killed = {}

        def progress(fraction, step):
            if not killed and fraction > 0:  # after the first stored batch
                busy = client.processing()
                addr = max(pids, key=lambda a: len(busy.get(a, ())))
                killed.update(addr=addr, busy=len(busy.get(addr, ())))
                os.kill(pids[addr], signal.SIGKILL)

        out = run_study(study, db, scheduler=client, batch_size=20, progress=progress)
        assert killed["busy"] > 0  # the killed worker held tasks
        assert out["status"] == "done" and out["computed"] == 240
        client.wait_for_workers(2, timeout=30)  # the nanny restarted it
        assert pids[killed["addr"]] not in client.run(os.getpid).values()
    finally:
        client.close()
    ref = run_study(study, workers=0)["results"]
    assert runs_of(db, out["id"]) == ref["runs"]
    # the realistic case makes physical sense: more supply pressure, earlier t95;
    # more extension friction, smaller overshoot (|PRCC| > 0.5: a strong monotonic effect;
    # p < 1e-6 over 240 runs: not chance)
    rk = {m: {e["parameter"]: e for e in ref["sensitivity"]["ranking"][m]["entries"]}
          for m in ("t95", "overshoot")}
    assert rk["t95"]["supply.pressure"]["prcc"] < -0.5 and rk["t95"]["supply.pressure"]["prcc_p"] < 1e-6
    assert rk["overshoot"]["friction.extend.fc0"]["prcc"] < -0.5


def test_time_limit_holds_while_no_batch_finishes(tmp_path):
    """One long batch and a time limit far below it: the driver stops at the limit (it does
    not wait for a batch to finish), stores "interrupted", and kills the busy worker."""
    db = str(tmp_path / "s.sqlite3")
    before = {p.pid for p in multiprocessing.active_children()}
    calls = []
    t0 = time.monotonic()
    with pytest.raises(StudyInterrupted, match="time limit of 1 s"):
        # 5,000 one-second runs in one batch: several seconds of work on any machine
        run_study(paper_study(5000), db, workers=1, batch_size=5000, time_limit=1.0,
                  progress=lambda f, s: calls.append(f), study_id="tl")
    elapsed = time.monotonic() - t0
    assert elapsed < 30.0, elapsed  # a bound on a hang (pool start-up included), not a speed claim
    assert len(calls) >= 2 and set(calls) == {0.0}  # heartbeats: the caller's checks ran too
    st = study_status(db, "tl")
    assert st["status"] == "interrupted" and st["stored"] == 0
    time.sleep(0.5)
    assert [p for p in multiprocessing.active_children() if p.pid not in before] == []


@pytest.fixture
def lone_cluster():
    """A LocalCluster of one worker process that a test may scale down or close."""
    c = local_cluster(1)
    yield c
    c.close()


@pytest.mark.parametrize("failure", ["every worker gone", "scheduler dead"])
def test_dask_failure_ends_interrupted_and_resumes(tmp_path, lone_cluster, reference, monkeypatch,
                                                   failure):
    """Issue 9 item 9: with every Dask worker gone (scheduler alive), or the scheduler itself
    dead, the study does not stay "running" for ever: it stops with StudyInterrupted, stores
    "interrupted", and resumes elsewhere to the uninterrupted numbers."""
    from pneucore.study import execute as study_exec
    monkeypatch.setattr(study_exec, "CLUSTER_GRACE", 1.0)   # instead of 10 s: a faster test
    monkeypatch.setattr(study_exec, "PROBE_INTERVAL", 0.2)
    db = str(tmp_path / "s.sqlite3")
    done = []

    def progress(fraction, step):
        if fraction > 0 and not done:   # after the first stored batch
            done.append(fraction)
            if failure == "every worker gone":
                lone_cluster.scale(0)
            else:
                lone_cluster.close()
    t0 = time.monotonic()
    with pytest.raises(StudyInterrupted):
        run_study(short_study(), db, scheduler=lone_cluster.scheduler_address, batch_size=1,
                  progress=progress, study_id="d1", scheduler_timeout=1.0)
    assert time.monotonic() - t0 < 60.0  # a bound on a hang (it used to wait for ever)
    st = study_status(db, "d1")
    assert st["status"] == "interrupted" and 0 < st["stored"] < 40, st
    out = run_study(None, db, workers=0, study_id="d1")
    assert out["status"] == "done" and out["computed"] == 40 - st["stored"]
    assert runs_of(db, "d1") == reference


def test_store_still_reads_runs_written_as_json_by_earlier_versions(tmp_path):
    """Runs are stored as packed float64 vectors now; a store whose rows hold the JSON objects
    of earlier versions reads to the same numbers (JSON floats round-trip exactly)."""
    db = str(tmp_path / "s.sqlite3")
    run_study(short_study(samples=4), db, workers=0, study_id="old")
    ref = study_results(db, "old")
    with contextlib.closing(sqlite3.connect(db)) as c, c:
        for i in (1, 3):
            params = {p: ref["runs"]["params"][p][i] for p in ref["runs"]["params"]}
            metrics = {m: ref["runs"]["metrics"][m][i] for m in ref["runs"]["metrics"]}
            c.execute("UPDATE study_runs SET params=?, metrics=? WHERE study_id='old' AND run_index=?",
                      (json.dumps(params), json.dumps(metrics), i))
        assert c.execute("SELECT typeof(params) FROM study_runs WHERE run_index=1").fetchone()[0] == "text"
    again = study_results(db, "old")
    assert again["runs"] == ref["runs"] and again["metrics"] == ref["metrics"]
