"""The core's column-grouped finite-difference Jacobian (:mod:`pneucore.core.integrator`:
the structural pattern ``_sparsity``, the Curtis-Powell-Reid groups ``_colour``,
``_jacobian_grouped``) against its plain forward differences (``_jacobian``, one evaluation
per state), at states of full strokes with lines in segments, cushions, meter-out throttles,
the jet-convection heat model, walls with a thermal capacity, temperature sensors, a spool
lag and a supply line (the states a line's ends read or are read by), in every piston mode.

Two things are checked at each state: the pattern misses no dependence (wherever it says a
derivative cannot depend on a state, the plain differences find exactly zero: a derivative
that does not read a state is evaluated from the same numbers and comes out bit for bit the
same), and the grouped Jacobian equals the plain one. A model without a line in segments has
a dense pattern, and the integrator then takes the plain differences, as before the groups.
"""
import numpy as np
import pytest

from pneucore import model_preset, simulate
from pneucore.core import layout as L
from pneucore.core.integrator import finite_difference_jacobians
from pneucore.physics.tube import line_volume
from pneucore.simulate import build_core
from pneucore.description.model import Model
from pneucore.description.scenario import Scenario

LENGTH, BORE = 1.0, 4e-3        # the line on each port [m]

#: A full stroke out and back from the lower stop, valve switched at 20 ms and 0.25 s
STROKES = {"duration": 0.45, "sample_period": 1e-3, "x0": 0.0, "locked": False,
           "command": [[0.0, 0.0], [0.02, 1.0], [0.25, -1.0]], "command_interpolation": "hold",
           "solver": {"rtol": 1e-6, "max_step": 0.002}}
#: Sample times [s]: at rest before the switch, the first millisecond after it (the supply
#: edge choked), mid-stroke, at and after the end stop, the return, near equilibrium
TIMES = (0.01, 0.0205, 0.022, 0.08, 0.2, 0.253, 0.3, 0.44)


def _model(segments, circuit):
    m = model_preset("paper-4way")
    m["effects"] = {"tubing": {"length_a": LENGTH, "length_b": LENGTH, "diameter_a": BORE,
                               "diameter_b": BORE, "segments": segments}}
    if circuit:
        m["heat"] = {"model": "natural_and_jet", "wall_mass": 0.3, "sensor_time_constant": 0.05}
        m["effects"]["valve_spool_dynamics"] = {"time_constant": 0.003}
        m["effects"]["supply_pressure_drop"] = {"C": 2e-8, "volume": 1e-4}
        m["effects"]["end_cushion"] = {"length_a": 0.015, "length_b": 0.015, "C_a": 4e-9,
                                       "C_b": 4e-9}
        m["effects"]["meter_out_throttle"] = {"C_a": 3e-9, "C_b": 3e-9}
    return m


@pytest.fixture(scope="module", params=[(1, True), (2, False), (2, True), (4, True)],
                ids=["lumped-circuit", "2-segments", "2-segments-circuit", "4-segments-circuit"])
def case(request):
    segments, circuit = request.param
    m = _model(segments, circuit)
    res = simulate(m, STROKES)
    assert res.status == 0, res.message
    core = build_core(Model.from_dict(m), Scenario.from_dict(STROKES))
    names = core["state_names"]
    t = np.asarray(res.t)
    states = []
    for time in TIMES:
        k = int(np.argmin(abs(t - time)))
        y = np.array([res.series[n][k] for n in names], float)
        states.append((float(t[k]), y, float(res.u[k])))
    return segments, core, states, res


def test_the_pattern_misses_no_dependence_and_the_groups_give_the_plain_jacobian(case):
    segments, core, states, _ = case
    n = core["y0"].shape[0]
    for t, y, u in states:
        for mode in range(len(L.MODE_NAMES)):
            Jd, Jg, S, n_groups, evals = finite_difference_jacobians(
                t, y, mode, u, core["model"], core["atol"], 1e-6)
            missed = np.argwhere((S == 0) & (Jd != 0.0))
            assert missed.size == 0, (t, mode, [(core["state_names"][i], core["state_names"][j])
                                                for i, j in missed[:5]])
            # a group's other columns do not reach a column's rows (that is what the groups
            # are), so each entry comes from the same numbers as the plain difference's:
            # equal to rounding (measured: identical)
            np.testing.assert_allclose(Jg, Jd, rtol=1e-12, atol=0.0)
            if segments == 1:
                # lumped: no line term, a dense pattern, a group per column: the integrator
                # keeps the plain differences (the previous core's arithmetic)
                assert S.all() and evals[0] == evals[1]
            else:
                # never more evaluations than the plain differences (with two segments and
                # a supply line, which reads both lines' first cells, about as many)
                assert not S.all()
                assert evals[1] <= evals[0]


def test_the_states_cover_choked_and_unchoked_supply_edges_and_all_moving_modes(case):
    """The states above are what the check is worth: the supply edge into port A choked
    (the first cell, or the chamber, below b times the supply) and unchoked, the piston
    sliding both ways and resting (every mode's frozen columns are exercised at every state
    by the loop over modes)."""
    segments, core, states, res = case
    prm = core["model"][0]
    names = core["state_names"]
    b, p_sup, r = prm[L.P_BMAX_PA], prm[L.P_SUP], prm[L.P_R]
    ratios = []
    for _, y, _ in states:
        if segments > 1:
            i = names.index("line_a_m1")
            p = y[i] * r * y[names.index("line_a_T1")] / (line_volume(BORE, LENGTH) / segments)
        else:
            x = y[L.Y_X]
            V = prm[L.P_V0_A] + prm[L.P_A_A] * x
            p = y[L.Y_MA] * r * y[L.Y_TA] / V
        ratios.append(p / p_sup)
    assert min(ratios) < b < max(ratios), (b, ratios)
    v = np.array([y[L.Y_V] for _, y, _ in states])
    assert v.max() > 0.1 and v.min() < -0.1       # sliding out and back [m/s]


@pytest.mark.parametrize("segments", [2, 4, 8])
def test_the_groups_do_not_grow_with_the_segments(segments):
    """Two lines of N cells each: the dense block (chambers, piston) and each line's last cell
    need groups of their own, a line's inner cells share theirs (a cell reaches its two
    neighbours only), so the evaluations per Jacobian stay at 12 however fine the lines,
    against 6 + 6 N for the plain differences."""
    m = _model(segments, False)
    core = build_core(Model.from_dict(m), Scenario.from_dict(STROKES))
    y = core["y0"]
    _, _, _, n_groups, evals = finite_difference_jacobians(
        0.0, y, L.MODE_SLIDE_POS, 1.0, core["model"], core["atol"], 1e-6)
    assert evals[0] == y.shape[0] == 6 + 6 * segments
    assert evals[1] == n_groups[0] == 12


def test_a_simulation_with_lines_in_segments_runs_the_grouped_core(case):
    """``simulate`` picks :func:`integrate_lines` for a model with lines in segments and the
    plain core otherwise; the grouped Jacobian shows in the evaluations per step (each step:
    one Jacobian, 5 stage evaluations, the samples' and the events' own; the plain
    differences alone would take one per state)."""
    from pneucore.core import integrator, rhs

    segments, core, _, res = case
    run = integrator.core_for(rhs.no_terms, core["flow_laws"], core["friction_laws"],
                              integrator.has_lines(core["model"]))
    n = core["y0"].shape[0]
    if segments == 1:
        assert run is integrator.integrate
    else:
        assert run is integrator.integrate_lines
        per_step = res.stats["rhs_evaluations"] / res.stats["jacobians"]
        if n >= 30:
            assert per_step < n - 4, (per_step, n)
