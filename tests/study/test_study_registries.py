"""The study registries drive the computation: a registered metric is computed, stored and
summarised; a registered distribution is validated and sampled."""
import numpy as np
import pytest

from pneucore import FieldError, model_preset
from pneucore.study import (DISTRIBUTIONS, METRICS, Distribution, Study, register_distribution,
                            register_metric, run_study, study_results)

#: A short extension pulse (0.3 s): the piston moves and stops
SHORT = {"duration": 0.3, "sample_period": 0.001, "command": [[0, 0], [0.02, 0.7], [0.06, 0]],
         "x0": 0.1}


@pytest.fixture
def registries():
    """Restore both registries after the test (they are module-level state)."""
    metrics, dists = dict(METRICS), dict(DISTRIBUTIONS)
    yield
    METRICS.clear()
    METRICS.update(metrics)
    DISTRIBUTIONS.clear()
    DISTRIBUTIONS.update(dists)


def test_a_registered_metric_is_computed_stored_and_summarised(registries, tmp_path):
    register_metric("x_mean", "m", "time-average position (samples' mean)",
                    lambda run: float(np.mean(run.x)))
    d = {"model": model_preset("paper-4way"), "scenario": dict(SHORT),
         "parameters": {"supply.pressure": {"grid": [5e5, 7e5]}},
         "metrics": ["x_final", "x_mean"]}
    db = str(tmp_path / "s.sqlite3")
    out = study_results(db, run_study(d, db, workers=0)["id"])
    assert out["metrics"]["x_mean"]["unit"] == "m"
    means = out["runs"]["metrics"]["x_mean"]
    finals = out["runs"]["metrics"]["x_final"]
    # the piston starts at 0.1 m and extends: its mean lies between start and end, per run
    assert len(means) == 2 and all(0.1 < m < f for m, f in zip(means, finals))
    # an unregistered name is refused, naming the field
    with pytest.raises(FieldError) as e:
        Study.from_dict({**d, "metrics": ["x_median"]})
    assert e.value.path == "metrics[0]"


def test_a_registered_distribution_is_validated_and_sampled(registries):
    # log-uniform on [min, max]: x = min (max/min)^u, the inverse CDF of a uniform ln x
    register_distribution("loguniform", Distribution(
        ("min", "max"), (), positive=("min", "max"),
        inverse_cdf=lambda p, u: p.min * (p.max / p.min) ** u, mass=lambda p: 1.0))
    d = {"model": model_preset("paper-4way"), "scenario": dict(SHORT),
         "parameters": {"heat.coefficient": {"distribution": "loguniform", "min": 1.0, "max": 100.0}},
         "samples": 2000, "seed": 4}
    s = Study.from_dict(d)
    h = s.values()[:, 0]
    u = np.random.default_rng(4).random((2000, 1))[:, 0]      # the study's documented draw
    np.testing.assert_array_equal(h, 1.0 * 100.0 ** u)
    # log-uniform: half the draws below the geometric mean 10 (binomial sd 1.1 %; 5 sd)
    assert abs(np.mean(h < 10.0) - 0.5) < 0.056
    assert Study.from_dict(s.to_dict()).values().tobytes() == s.values().tobytes()  # round trip
    # its "positive" fields are checked, naming the field
    bad = {**d, "parameters": {"heat.coefficient": {"distribution": "loguniform", "min": -1.0,
                                                    "max": 100.0}}}
    with pytest.raises(FieldError) as e:
        Study.from_dict(bad)
    assert e.value.path == "parameters.heat.coefficient.min"
    # and the error for an unknown one lists the registry
    del DISTRIBUTIONS["loguniform"]
    with pytest.raises(FieldError, match="loguniform") as e:
        Study.from_dict(d)
    assert e.value.path == "parameters.heat.coefficient.distribution" and "lognormal" in str(e.value)
