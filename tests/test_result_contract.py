"""The result's mode column and the scenario checks that ``simulate`` keeps on its fast path.

``SimulationResult.mode`` is text (``stick``, ``slide``, ``stop``, ``locked``; ``""`` for a
sample the solver never reached), made from the integer codes of the compiled core
through a lookup table; the REST answer carries the same strings. ``simulate`` trusts a
:class:`~pneucore.description.scenario.Scenario` built by ``Scenario.from_dict`` and does not
validate it again, but still checks it against the model it is run with.
"""
import numpy as np
import pytest

from pneucore import FieldError, Model, Scenario, model_preset, scenario_preset, simulate

MODES = {"stick", "slide", "stop", "locked"}


def test_mode_column_names_the_piston_state(paper4, pulses):
    res = simulate(paper4, pulses)
    assert res.mode.dtype.kind == "U" and res.mode.shape == res.t.shape
    assert set(res.mode) == {"stick", "slide"}       # four pulses: the piston moves and stops
    resting = res.mode == "stick"
    # a stuck piston does not move: exactly zero velocity (the state is frozen, not solved)
    assert np.all(res.v[resting] == 0.0)
    # every change of the column is a logged slip or stick event in between the two samples
    ev = [e["t"] for e in res.events if e["kind"] in ("slip", "stick")]
    for k in np.flatnonzero(res.mode[1:] != res.mode[:-1]):
        assert any(res.t[k] <= t <= res.t[k + 1] for t in ev), res.t[k]
    d = res.to_dict()
    assert d["series"]["mode"] == res.mode.tolist()
    assert all(type(m) is str for m in d["series"]["mode"])


def test_locked_piston_is_locked_throughout():
    scen = scenario_preset("paper-fig10-pulses")
    scen.update(locked=True, duration=0.1)
    res = simulate(model_preset("paper-4way"), scen)
    assert set(res.mode) == {"locked"}


def test_unreached_samples_have_an_empty_mode(paper4, pulses):
    pulses["solver"] = {"max_steps": 10}
    res = simulate(paper4, pulses, raise_on_error=False)
    after = res.t > res.stats["t_reached"]
    assert after.any() and not after.all()
    assert set(res.mode[after]) == {""}
    assert set(res.mode[~after]) <= MODES
    assert set(res.to_dict()["series"]["mode"][int(np.argmax(after)):]) == {""}


def test_to_dict_without_inputs_leaves_out_model_and_scenario(paper4, pulses):
    res = simulate(paper4, pulses)
    full, bare = res.to_dict(), res.to_dict(inputs=False)
    assert set(full) - set(bare) == {"model", "scenario"}
    assert Model.from_dict(full["model"]).to_dict() == full["model"]
    assert Scenario.from_dict(full["scenario"]).to_dict() == full["scenario"]


def test_built_scenario_is_still_checked_against_the_model(paper4, pulses):
    scen = Scenario.from_dict(dict(pulses, x0=0.2))      # built without a model: x0 unchecked
    short = dict(paper4, jack=dict(paper4["jack"], stroke=0.1))
    with pytest.raises(FieldError) as exc:
        simulate(short, scen)
    assert exc.value.path == "scenario.x0"
    # a 4/2 command of -1 is outside a 3/2 valve's range [0, 1]: the first such breakpoint is named
    cmd = [[0.0, 0.0], [0.1, 0.5], [0.2, -1.0], [0.3, -1.0]]
    scen = Scenario.from_dict(dict(pulses, command=cmd))
    with pytest.raises(FieldError) as exc:
        simulate(model_preset("paper-3way"), scen)
    assert exc.value.path == "scenario.command[2][1]"


def test_built_scenario_gives_the_same_result_as_its_dict(paper4, pulses):
    a = simulate(paper4, pulses)
    b = simulate(Model.from_dict(paper4), Scenario.from_dict(pulses))
    for name in a.series:
        assert np.array_equal(a.series[name], b.series[name]), name
