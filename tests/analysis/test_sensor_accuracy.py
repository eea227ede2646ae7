"""Per-signal sensor accuracy in a measurement's metadata (issue 22, item 6): stated in any
unit the columns accept, converted as a difference, refused with the field named, and used by
the fit as each signal's weight in place of the noise estimated from the record."""
import copy

import pytest
from fastapi.testclient import TestClient

from pneucore import Model, model_preset
from pneucore.analysis.calibrate import Objective, fit, signal_sigmas
from pneucore.data.experiment import Experiment
from pneucore.data.measurement import Measurement, MeasurementError, sensor_accuracy
from pneucore.data.synthetic import synthetic_experiments
from pneucore.description.paths import parse_parameters


def test_accuracy_is_a_difference_in_si():
    # a gauge unit's ambient and the Celsius zero do not apply to a difference: 0.01 bar(g)
    # is 1,000 Pa exactly, 1 degC is 1 K, 2 degF is 10/9 K (rounding only)
    acc = sensor_accuracy({"p_b[bar(g)]": 0.01, "T_a[degC]": 1.0, "T_b[degF]": 2.0,
                           "x[mm]": 0.05})
    assert acc["p_b"] == pytest.approx(1000.0, rel=1e-12)
    assert acc["T_a"] == pytest.approx(1.0, rel=1e-12)
    assert acc["T_b"] == pytest.approx(10.0 / 9.0, rel=1e-12)
    assert acc["x"] == pytest.approx(5e-5, rel=1e-12)


@pytest.mark.parametrize("given, where, words", [
    ({"p_a": -300.0}, "meta.accuracy.p_a", "[Pa]"),
    ({"x[mm]": 0}, "meta.accuracy.x[mm]", "[mm]"),
    ({"p_a": float("inf")}, "meta.accuracy.p_a", "finite positive"),
    ({"p_a": True}, "meta.accuracy.p_a", "finite positive"),
    ({"p_a[furlong]": 1.0}, "meta.accuracy.p_a[furlong]", "unknown unit"),
    ({"pressure": 1.0}, "meta.accuracy.pressure", "unknown column name"),
    ({"t": 1e-3}, "meta.accuracy.t", "measured signal"),
    ({"p_a": 1.0, "p_a[bar]": 1e-5}, "meta.accuracy.p_a[bar]", "twice"),
    ([300.0], "meta.accuracy", "dict"),
])
def test_bad_accuracy_names_the_field(given, where, words):
    with pytest.raises(MeasurementError) as exc:
        sensor_accuracy(given)
    assert exc.value.column == where
    assert words in str(exc.value)


def _experiments(seed=3):
    true = model_preset("paper-4way")
    true["effects"] = {"dead_volume": {"volume_a": 2e-5, "volume_b": 2e-5}}
    exps = synthetic_experiments(true, seed=seed, which=["free-pulses"])
    for e in exps:                       # as a request or a file gives it: plain columns
        e["measurement"] = e["measurement"].to_dict()
    return true, exps


def test_a_record_states_accuracy_for_what_it_holds_only():
    _, exps = _experiments()
    d = copy.deepcopy(exps[0]["measurement"])
    d["meta"] = {"accuracy": {"T_a": 1.0}}
    with pytest.raises(MeasurementError) as exc:
        Measurement.from_dict(d)
    assert exc.value.column == "meta.accuracy.T_a"


def test_the_fit_weighs_by_the_stated_accuracy():
    _, exps = _experiments()
    model = Model.from_dict(model_preset("paper-4way"))
    plain = Experiment.from_dict(exps[0])
    d = copy.deepcopy(exps[0])
    d["measurement"]["meta"] = {"accuracy": {"p_a[bar]": 0.02, "x[mm]": 0.01}}
    stated = Experiment.from_dict(d)
    est, given = signal_sigmas(plain), signal_sigmas(stated)
    # stated where given (converted to SI), estimated from the record elsewhere
    assert given["p_a"] == pytest.approx(2000.0, rel=1e-12)
    assert given["x"] == pytest.approx(1e-5, rel=1e-12)
    assert given["p_b"] == est["p_b"]
    assert Objective(model, [stated], []).sigma == [given]


def test_the_weights_drive_a_misspecified_fit():
    # the position sensor reads 30 % high (a wrong gain) while the pressures are right: fitted
    # on both, the supply pressure is pulled away from its truth by the position; trusting the
    # pressures (a tight stated accuracy there, a loose one on x) must keep it nearer the
    # truth than trusting the position
    true, exps = _experiments()
    true["effects"] = {}
    exps = synthetic_experiments(true, seed=5, which=["free-pulses"])
    base = exps[0]
    base["measurement"] = base["measurement"].to_dict()
    base["measurement"]["x"] = [None if v is None else 1.3 * v for v in base["measurement"]["x"]]
    start = model_preset("paper-4way")
    start["supply"]["pressure"] = 6.0e5
    model = Model.from_dict(start)
    specs = parse_parameters(model, {"supply.pressure": {}})

    def supply(acc):
        d = copy.deepcopy(base)
        d["measurement"]["meta"] = {"accuracy": acc}
        return fit(model, [Experiment.from_dict(d)], specs, max_nfev=30) \
            .values["supply.pressure"]["value"]

    trust_p = supply({"p_a": 100.0, "p_b": 100.0, "x": 1e-2})
    trust_x = supply({"p_a": 1e5, "p_b": 1e5, "x": 1e-6})
    truth = true["supply"]["pressure"]
    # the pressures alone put the supply within 1 % of its truth (noise and 12-bit
    # quantisation only); the inflated position pulls it elsewhere by far more than that
    assert abs(trust_p - truth) < 0.01 * truth, trust_p
    assert abs(trust_x - truth) > 3 * abs(trust_p - truth), (trust_p, trust_x)


def test_api_refuses_a_bad_accuracy_naming_it(tmp_path):
    from app.config import Settings
    from app.main import create_app
    _, exps = _experiments()
    e = copy.deepcopy(exps[0])
    e["measurement"]["meta"] = {"accuracy": {"p_a[bar]": -0.01}}
    with TestClient(create_app(Settings(db_path=str(tmp_path / "store.sqlite"))),
                    base_url="http://127.0.0.1") as client:
        r = client.post("/api/compare", json={"model": model_preset("paper-4way"),
                                              "experiments": [e]})
    assert r.status_code == 422, r.text
    text = r.text
    assert "experiments[0].measurement" in text and "meta.accuracy.p_a[bar]" in text
    assert "[bar]" in text
