"""A pressure sensor's gain error scales the pressure above ambient, for every pressure signal:
the supply gauge p_s (issue 29's signal) as the chamber ones (it used to scale p_s about 0 Pa,
so a supply gauge's span error came out as a gain plus a spurious offset of ~5 kPa)."""
from types import SimpleNamespace

import numpy as np
import pytest

from pneucore.analysis.hypotheses import sensor_findings
from pneucore.data.measurement import SIGNAL_UNITS, sensor_zero

AMBIENT = 101300.0


@pytest.mark.parametrize("signal", sorted(SIGNAL_UNITS))
def test_the_zero_of_a_gain_is_ambient_for_every_pressure_and_zero_otherwise(signal):
    assert sensor_zero(signal, AMBIENT) == (AMBIENT if SIGNAL_UNITS[signal] == "Pa" else 0.0)


@pytest.mark.parametrize("signal", ["p_a", "p_s"])
def test_a_gauge_sensors_span_error_is_found_as_a_gain_alone(signal):
    # a supply line sagging and recovering between 6 and 7 bar gauge, read by a gauge sensor
    # whose span is 5 % high: read = ambient + 1.05 (true - ambient), plus 300 Pa noise
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 1.0, 2000)
    true = AMBIENT + 6.5e5 + 0.5e5 * np.sin(2 * np.pi * 3 * t)
    read = AMBIENT + 1.05 * (true - AMBIENT) + rng.normal(0.0, 300.0, t.size)
    rp = SimpleNamespace(measured={signal: read}, simulated={signal: true})
    (f,) = sensor_findings([rp], ambient=AMBIENT)
    # a gain about ambient explains it alone; about 0 Pa it would need an offset of
    # -0.05 x 101300 = -5 kPa beside it (kind "gain and offset")
    assert f["kind"] == "gain", f
    # least squares on 2000 samples with 300 Pa noise over a 1 bar swing: the gain to ~1e-4
    assert f["gain"] == pytest.approx(0.05, abs=1e-3)
