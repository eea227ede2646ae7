"""Records as real rigs give them (issue 28): clipped and quantised signals, known values,
sensor findings."""
import numpy as np
import pytest

from pneucore.analysis.calibrate import Objective
from pneucore.analysis.diagnose import check_request, diagnose
from pneucore.analysis.metrics import noise_sigma
from pneucore.data.experiment import Experiment, as_experiments
from pneucore.data.measurement import Measurement
from pneucore.data.synthetic import SENSOR_RANGES, quantise, rig_case
from pneucore.description.model import Model
from pneucore.description.presets import model_preset
from pneucore.description.validation import FieldError

LSB = (SENSOR_RANGES["p_a"][1] - SENSOR_RANGES["p_a"][0]) / 4095


def _clipped_pressure(n_zero, n_moving, sigma=300.0, seed=0):
    """A 12-bit gauge-pressure record: ``n_zero`` samples at the sensor's zero, then a
    pressure with Gaussian noise of ``sigma`` [Pa]."""
    rng = np.random.default_rng(seed)
    y = np.r_[np.zeros(n_zero), 3e5 + 1e5 * np.sin(np.linspace(0, 3, n_moving))]
    y = y + rng.normal(0, sigma, y.size) * (np.arange(y.size) >= n_zero)
    return quantise(y, *SENSOR_RANGES["p_a"], 12)


@pytest.mark.parametrize("share_zero", [0.0, 0.5, 0.9])
def test_the_noise_of_a_clipped_signal_comes_from_where_it_moves(share_zero):
    n = 4000
    y = _clipped_pressure(int(share_zero * n), n - int(share_zero * n))
    s = noise_sigma(y)
    # 300 Pa of noise plus the converter's LSB^2/12 (70 Pa rms) added in quadrature: 308 Pa;
    # 15 % covers the estimate's scatter on 400 moving samples (second differences, 1/sqrt(n))
    assert s == pytest.approx(np.hypot(300.0, LSB / np.sqrt(12)), rel=0.15)


def test_a_noiseless_quantised_signal_has_the_converters_floor_never_zero():
    # exactly 0 between pulses, a noiseless pulse: only the converter's resolution is left
    y = quantise(np.r_[np.zeros(3000), np.linspace(0, 5e5, 100), np.full(500, 5e5),
                       np.linspace(5e5, 0, 100), np.zeros(3000)], *SENSOR_RANGES["p_a"], 12)
    s = noise_sigma(y)
    # at least the uniform quantisation noise LSB / sqrt(12), at most one LSB
    assert LSB / np.sqrt(12) * (1 - 1e-9) <= s <= LSB


def test_a_clipped_pressure_keeps_its_weight_beside_the_position():
    # the weights of a fit are 1 / noise: a pressure reading exactly 0 most of the time must
    # not get the noise of nothing (a weight that drowns the position)
    t = np.arange(4000) * 1e-3
    p = _clipped_pressure(3600, 400) + 101300.0
    rng = np.random.default_rng(1)
    x = quantise(0.05 + 0.01 * np.sin(t) + rng.normal(0, 5e-5, t.size), *SENSOR_RANGES["x"], 12)
    exp = Experiment(Measurement(t, {"p_a": p, "x": x}).validate(), {"command": [[0, 0]]})
    obj = Objective(Model.from_dict(model_preset("paper-3way")), [exp], [])
    # the estimates within 15 % of the true noise, as above (5e-5 m on a 61 um LSB: 1.3 LSB)
    assert obj.sigma[0]["p_a"] == pytest.approx(np.hypot(300.0, LSB / np.sqrt(12)), rel=0.15)
    assert obj.sigma[0]["x"] == pytest.approx(np.hypot(5e-5, 0.25 / 4095 / np.sqrt(12)), rel=0.15)


def test_a_known_value_is_held_and_the_disagreement_is_a_finding():
    # the rig's mass is 2.5 times the declared 2 kg; declared known, it is never moved
    case = rig_case("mass", seed=3, base_errors={"jack.moving_mass": 1.5})
    model = Model.from_dict(case.start)
    d = diagnose(model, as_experiments(case.experiments), known=["jack.moving_mass"])
    assert d.model.jack.moving_mass == model.jack.moving_mass
    assert "jack.moving_mass" not in [q["path"] for q in d.recalibrate]
    found = {f["path"]: f for f in d.remaining["known_disagree"]}
    assert "jack.moving_mass" in found, d.message
    # the data point away from the declaration, towards the truth (5 kg), to first order
    assert found["jack.moving_mass"]["data_suggest"] > 1.3 * model.jack.moving_mass
    assert "disagree with the declared moving mass" in d.message
    assert d.to_dict()["known"] == ["jack.moving_mass"]


def test_known_paths_are_checked():
    model = Model.from_dict(model_preset("paper-4way"))
    with pytest.raises(FieldError) as exc:
        check_request(model, None, (), ["jack.area_a"])
    assert exc.value.path == "known[0]"
    with pytest.raises(FieldError) as exc:
        check_request(model, None, ["jack.moving_mass"], ["jack.moving_mass"])
    assert exc.value.path == "uncertain[0]" and "declared known" in exc.value.detail
