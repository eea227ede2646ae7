"""The replay's fast path (issue 26) gives what the full simulation result gives, bit for bit.

A fit replays each experiment thousands of times and reads only its measured signals: a
replay reads them off the compiled core's outputs (:class:`pneucore.result.CoreRun`) and
builds the full :class:`pneucore.result.SimulationResult` only when something asks for more
(the phase labels, the report). Here every replay is checked against :func:`pneucore.simulate`
run on the same model, scenario and sample times: the signals, the piston modes, the events
and the status must be equal, not close (the same arithmetic on the same arrays).
Cases: the paper's 4/2 jack under an experiment's own supply pressure and load, with a
transducer lag (the sensor's state is the signal read) and a piston leak; the 3/2 jack with
its chamber B held at a constant pressure (``m_b`` computed from ``p_b``); a run the solver
cannot finish (the samples it never reached).
"""
import functools
import pickle

import numpy as np
import pytest

from pneucore import model_preset, simulate
from pneucore.analysis.compare import replay
from pneucore.analysis.metrics import noise_sigma
from pneucore.data.experiment import as_experiments
from pneucore.data.synthetic import synthetic_experiments
from pneucore.description.model import Model


@functools.lru_cache(maxsize=None)
def _experiments(preset):
    """Two short synthetic tests (a locked hold and a free pulse test) of ``preset``, the free
    one at its own supply pressure and load."""
    exps = synthetic_experiments(model_preset(preset), seed=3)
    exps[-1]["supply_pressure"] = 5.5e5
    exps[-1]["load_force"] = 20.0
    return as_experiments(exps)


def _model(preset, effects=None):
    d = model_preset(preset)
    d["effects"] = effects or {}
    return Model.from_dict(d)


def _slow(model, e):
    """The experiment simulated the plain way: a full result."""
    m = e.model_for(model)
    scen = e.scenario_for(m)
    t = e.times
    return simulate(m, scen, raise_on_error=False, t_out=t[t <= scen.duration * (1 + 1e-12)])


def _same(rp, res):
    assert np.array_equal(rp.t, res.t)
    for s in rp.experiment.signals:
        assert np.array_equal(rp.simulated[s], res.observed(s), equal_nan=True), s
    assert rp.result.status == res.status and rp.result.message == res.message
    assert np.array_equal(rp.result.mode, res.mode)
    assert rp.result.events == res.events
    assert rp.result.stats == res.stats
    assert list(rp.result.series) == list(res.series)
    for k, v in res.series.items():
        assert np.array_equal(rp.result.series[k], v, equal_nan=v.dtype.kind == "f"), k


@pytest.mark.parametrize("preset, effects", [
    ("paper-4way", {"sensor_lag": {"time_constant": 0.004},
                    "piston_leakage": {"conductance": 2e-10}}),
    ("paper-3way", {}),
])
def test_replay_equals_the_full_simulation(preset, effects):
    model = _model(preset, effects)
    for e in _experiments(preset):
        rp = replay(model, e)
        _same(rp, _slow(model, e))


def test_signals_read_before_the_full_result_equal_it():
    # the lagged pressures come from the sensor's states, read off the core's outputs first
    model = _model("paper-4way", {"sensor_lag": {"time_constant": 0.004}})
    e = _experiments("paper-4way")[-1]
    rp = replay(model, e)
    assert rp.result._full is None          # nothing built yet: the fast path was taken
    res = _slow(model, e)
    assert not np.array_equal(res.observed("p_a"), res.p_a)   # the lag changes the signal read
    assert np.array_equal(rp.simulated["p_a"], res.observed("p_a"))


def test_a_run_the_solver_cannot_finish_is_replayed_the_same():
    model = _model("paper-4way")
    e = _experiments("paper-4way")[-1]
    e.scenario = {**e.scenario, "solver": {"max_steps": 40}}
    rp = replay(model, e)
    res = _slow(model, e)
    assert res.status != 0 and not rp.ok
    _same(rp, res)


def test_the_experiments_model_leaves_the_given_one_untouched():
    model = _model("paper-4way")
    load, supply = model.jack.load_force, model.supply.pressure
    e = _experiments("paper-4way")[-1]
    m = e.model_for(model)
    assert (m.jack.load_force, m.supply.pressure) == (20.0, 5.5e5)
    assert (model.jack.load_force, model.supply.pressure) == (load, supply)


def test_the_noise_found_once_is_the_records_own():
    e = _experiments("paper-4way")[0]
    for s in e.signals:
        assert e.noise(s) == noise_sigma(e.measurement.signals[s])
        assert e.noise(s) == e.noise(s)


def test_a_replay_travels_to_a_cluster_and_back():
    # a replay is pickled with what a Dask task receives (a null's replays): the lazy result
    # holds no compiled function, and builds the same full result on the other side
    model = _model("paper-4way", {"sensor_lag": {"time_constant": 0.004}})
    e = _experiments("paper-4way")[-1]
    back = pickle.loads(pickle.dumps(replay(model, e)))
    _same(back, _slow(model, e))
