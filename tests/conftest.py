"""Shared fixtures. The first simulation of a session compiles the core (~12 s) unless cached."""
import pytest

from pneucore import model_preset, scenario_preset


@pytest.fixture
def paper4():
    """The paper-4way model preset as a plain dict (a fresh copy per test)."""
    return model_preset("paper-4way")


@pytest.fixture
def pulses():
    """The Fig. 10 pulse scenario as a plain dict."""
    return scenario_preset("paper-fig10-pulses")
