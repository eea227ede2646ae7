"""A valve command proposed from a record's pressure edges (issue 28, item 1)."""
import numpy as np
import pytest

from pneucore.data.command import propose_command
from pneucore.data.measurement import Measurement
from pneucore.data.synthetic import synthesize
from pneucore.description.model import Model
from pneucore.description.presets import model_preset
from pneucore.description.scenario import pulse_train

PULSES = [(0.1, 1.0), (0.5, 1.0), (0.9, 1.0)]


def _rig(load=-30.0, width=0.05):
    d = model_preset("paper-3way")
    d["jack"]["load_force"] = load
    cmd = pulse_train(PULSES, width)
    # the piston at rest at its retracted end, as a rig's record starts
    meas = synthesize(Model.from_dict(d), {"command": cmd, "duration": 1.3, "x0": 0.0,
                                           "sample_period": 0.001}, signals=("p_a", "x"))
    del meas.signals["u"]
    return meas


@pytest.mark.parametrize("load", [0.0, -30.0])
def test_pulses_of_a_simulated_rig_are_found(load):
    # a 3/2 jack lifting a load by three 50 ms pulses: the piston's compression of the closed
    # chamber (a bounce, the load pushing back) rises slower than the supply filling it
    prop = propose_command(_rig(load))
    assert len(prop["pulses"]) == 3
    for (a, b), (t, _) in zip(prop["pulses"], PULSES):
        # within 2 samples (2 ms at 1 kHz): the 5 ms smoothing window, corrected for its centring
        assert abs(a - t) <= 0.002 and abs(b - (t + 0.05)) <= 0.002
    assert prop["command"][0] == [0.0, 0.0] and prop["source"] == "proposed"
    assert [u for _, u in prop["command"][1:]] == [1.0, 0.0] * 3


def test_levels_and_a_valve_held_open():
    t = np.arange(0, 0.5, 0.001)
    p = 1e5 + 5e5 * (t >= 0.2) * (1 - np.exp(-np.clip(t - 0.2, 0, None) / 0.01))
    prop = propose_command(Measurement(t, {"p_a": p}).validate(), open_level=0.6, closed_level=0.1)
    assert len(prop["pulses"]) == 1 and prop["pulses"][0][1] is None
    assert abs(prop["pulses"][0][0] - 0.2) <= 0.002     # 2 samples, as above
    assert prop["command"] == [[0.0, 0.1], [prop["pulses"][0][0], 0.6]]


def test_a_slow_leak_or_a_flat_record_opens_nothing():
    t = np.arange(0, 1.0, 0.001)
    for p in (3e5 - 5e4 * t, np.full(t.shape, 1e5)):
        rng = np.random.default_rng(0)
        prop = propose_command(Measurement(t, {"p_a": p + rng.normal(0, 300, t.size)}).validate())
        assert prop["pulses"] == [] and prop["command"] == [[0.0, 0.0]]


def test_no_pressure_is_an_error_naming_what_is_measured():
    t = np.arange(0, 0.1, 0.001)
    m = Measurement(t, {"x": t * 0.1}).validate()
    with pytest.raises(ValueError, match="no chamber pressure"):
        propose_command(m)
    m = Measurement(t, {"p_a": 1e5 + t}).validate()
    with pytest.raises(ValueError, match="measured: p_a"):
        propose_command(m, "p_b")
