"""Cross-solver check: pneucore (RODAS4 core, default settings) against an independent scipy solution.

The reference is ``benchmarks/scipy_reference.py``: the same base-model
equations written separately in numpy/scipy, on different chamber states
(pressure and temperature instead of mass and temperature), integrated by
scipy's Radau IIA (order 5) at rtol 1e-10 with stick/slip/stop as terminal
events. The accuracy contract under test: with default settings, the paper's
Eq. 25 error ``sqrt(sum (a - b)^2 / sum b^2)`` against a tight-tolerance
solution is below 1e-4 on every signal (p_a, p_b, T_a, T_b, x, v).
"""
import copy
import functools
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                                "benchmarks"))

from scipy_reference import eq25_error, simulate_scipy  # noqa: E402

from pneucore import model_preset, scenario_preset, simulate  # noqa: E402

SIGNALS = ("p_a", "p_b", "T_a", "T_b", "x", "v")

# The accuracy contract of the issue: Eq. 25 agreement better than 1e-4 on every
# signal with default settings. Measured: <= 1.2e-5 (v), <= 3.6e-6 on the others.
EQ25_CONTRACT = 1e-4

# Reference settings: Radau IIA at rtol 1e-10 (atol = rtol x the per-state floors of
# scipy_reference). test_reference_is_converged shows its own error is <= 1e-7, i.e.
# at least 1000x below the contract, so any failure is pneucore's, not the reference's.
REF = {"method": "Radau", "rtol": 1e-10}
# Two unrelated tight solutions (LSODA and Radau, both rtol 1e-10) must agree to 1e-7:
# measured <= 5e-10, so 1e-7 leaves room for platform differences while staying
# 1000x below the contract.
REF_SELF_TOL = 1e-7

# Event times (slip, stick, reverse, stop) of the paper presets: pneucore locates events
# to 1e-9 s on its own solution, so the difference to the reference comes from its
# rtol 1e-5 state error divided by the event function's rate of change. Measured
# <= 1.5e-7 s on the three presets; 1e-5 s is 10x tighter than the 1e-4 s asked for
# and still 100x below a 1 ms sample period, while a wrong switching law (e.g. the
# wrong friction quadrant or a missed back-step) moves events by >= 1e-4 s.
EVENT_TOL = 1e-5

# Extended cases (other heat models, Saint-Venant law, end stops, linear command,
# asymmetric rod and load): a velocity zero reached with a tiny deceleration (a
# 1 ms micro-reversal before sticking, with the Saint-Venant law) is ill-conditioned:
# the 1e-5 state error moves that stick by 8.8e-5 s (it converges: 1e-5 s at
# rtol 1e-6, 6e-8 s at rtol 1e-8). Allow 5e-4 s there; the other events of these
# cases agree to <= 7.2e-7 s.
EVENT_TOL_EXTENDED = 5e-4

CASES = [
    ("paper-4way", "paper-fig10-pulses"),
    ("paper-3way", "paper-fig9-switching"),
    ("paper-4way", "paper-fig6-locked-max"),
]

# kinds that each preset case must produce, so the event comparison is not vacuous
EXPECTED_KINDS = {
    "paper-fig10-pulses": {"command", "slip", "stick", "reverse"},
    "paper-fig9-switching": {"command", "slip", "reverse"},
    "paper-fig6-locked-max": {"command"},
}


def _variant(name):
    """Extended cross-check cases beyond the three presets of the contract."""
    m4 = model_preset("paper-4way")
    pulses = scenario_preset("paper-fig10-pulses")
    if name in ("isothermal", "adiabatic"):
        m4["heat"]["model"] = name
        return m4, pulses
    if name == "saint_venant":
        m4["valve"]["flow_law"] = "saint_venant"
        return m4, pulses
    strokes = {"duration": 1.0, "sample_period": 1e-3, "x0": 0.1,
               "command": [[0.0, 0.0], [0.05, 1.0], [0.5, -1.0]]}
    if name == "end_stops":
        return m4, strokes
    if name == "load_single_rod":
        m4["jack"]["load_force"] = 50.0
        m4["jack"]["rod_b"] = 0.0
        return m4, strokes
    if name == "linear_command":
        return m4, {"duration": 1.0, "sample_period": 1e-3, "x0": 0.1,
                    "command_interpolation": "linear",
                    "command": [[0.0, 0.0], [0.1, 0.0], [0.3, 0.8], [0.5, -0.8], [0.8, 0.0]]}
    if name == "fig7_locked_min":
        return m4, scenario_preset("paper-fig7-locked-min")
    raise KeyError(name)


VARIANTS = ["isothermal", "adiabatic", "saint_venant", "end_stops", "load_single_rod",
            "linear_command", "fig7_locked_min"]


@functools.lru_cache(maxsize=None)
def _runs(key):
    """pneucore default run and tight reference of a case (computed once per session)."""
    if isinstance(key, tuple):
        model, scenario = model_preset(key[0]), scenario_preset(key[1])
    else:
        model, scenario = _variant(key)
    res = simulate(copy.deepcopy(model), copy.deepcopy(scenario))
    ref = simulate_scipy(model, scenario, **REF)
    return res, ref


def _errors(res, ref):
    assert np.array_equal(res.t, ref["t"])
    return {k: eq25_error(res.series[k], ref[k]) for k in SIGNALS}


def _check_events(res, ref, tol):
    pc = [(e["kind"], e["mode"], e["t"]) for e in res.events]
    sp = [(e["kind"], e["mode"], float(e["t"])) for e in ref["events"]]
    assert [e[:2] for e in pc] == [e[:2] for e in sp], f"event sequences differ:\n{pc}\n{sp}"
    dt = [abs(a[2] - b[2]) for a, b in zip(pc, sp)]
    worst = max(dt, default=0.0)
    assert worst < tol, f"event time difference {worst:.3g} s >= {tol:g} s: {list(zip(pc, dt))}"
    # sampled modes agree except possibly at samples falling between the two event times
    n_diff = int(np.sum(np.asarray(res.mode) != np.asarray(
        ["slide" if m.startswith("slide") else "stop" if m.startswith("stop") else m
         for m in ref["mode"]])))
    assert n_diff <= len(pc), f"{n_diff} samples in different piston modes"
    return pc


@pytest.mark.parametrize("case", CASES, ids=["-".join(c) for c in CASES])
def test_eq25_agreement_with_tight_reference(case):
    res, ref = _runs(case)
    err = _errors(res, ref)
    bad = {k: v for k, v in err.items() if not v < EQ25_CONTRACT}
    assert not bad, f"Eq. 25 error >= {EQ25_CONTRACT:g}: {bad} (all: {err})"


@pytest.mark.parametrize("case", CASES, ids=["-".join(c) for c in CASES])
def test_event_times_match(case):
    res, ref = _runs(case)
    pc = _check_events(res, ref, EVENT_TOL)
    assert EXPECTED_KINDS[case[1]] <= {e[0] for e in pc}


@pytest.mark.parametrize("case", CASES, ids=["-".join(c) for c in CASES])
def test_reference_is_converged(case):
    """Two unrelated tight scipy solutions agree far below the contract."""
    _, ref = _runs(case)
    other = simulate_scipy(model_preset(case[0]), scenario_preset(case[1]), method="LSODA",
                           rtol=1e-10)
    err = {k: eq25_error(other[k], ref[k]) for k in SIGNALS}
    assert max(err.values()) < REF_SELF_TOL, err


@pytest.mark.parametrize("name", VARIANTS)
def test_extended_cases(name):
    res, ref = _runs(name)
    err = _errors(res, ref)
    bad = {k: v for k, v in err.items() if not v < EQ25_CONTRACT}
    assert not bad, f"Eq. 25 error >= {EQ25_CONTRACT:g}: {bad} (all: {err})"
    _check_events(res, ref, EVENT_TOL_EXTENDED)
    if name in ("end_stops", "load_single_rod"):
        assert any(e["kind"] == "stop" for e in res.events)


def test_eq25_error_definition():
    """The metric itself: relative to the reference (second argument), 0/0 -> 0."""
    b = np.array([1.0, 2.0, 2.0])
    assert eq25_error(b, b) == 0.0
    assert eq25_error(b + np.array([0.0, 0.0, 3.0]), b) == pytest.approx(1.0)
    assert eq25_error(np.zeros(3), np.zeros(3)) == 0.0
    assert eq25_error(np.ones(3), np.zeros(3)) == np.inf
