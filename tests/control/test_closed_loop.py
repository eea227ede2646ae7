"""The loop closed inside the compiled core (issue 42): a P step against the linearised closed
loop, PID without and with Coulomb friction, the dead band and the sliding law, bad input."""
import math

import numpy as np
import pytest

from pneucore import model_preset
from pneucore.control.closed_loop import ControlError, simulate_closed_loop
from pneucore.control.linearize import discretize, linearize
from pneucore.control.metrics import control_metrics
from pneucore.control.models import servo_model
from pneucore.description.validation import FieldError

TS = 1e-3       # the default controller sample period [s]


def run(model, controller, duration=1.5, x0=0.1, p=5.3e5, **kw):
    scen = {"duration": duration, "sample_period": TS, "x0": x0,
            "initial": {"p_a": p, "p_b": p}, "controller": controller}
    return simulate_closed_loop(model, scen, **kw)


def test_small_p_step_matches_the_linearised_closed_loop():
    # the linear plant at the valve's null (A, B, C from the core's right-hand side), sampled
    # with the same zero-order hold, under the same P law: a 0.5 mm step. Settling time and
    # overshoot within the 5 % (measured 1.9 % and 0.6 %: the flow's dependence on
    # the chamber pressure at a nonzero opening is of second order in the step)
    m = servo_model()
    x0, step, kp = 0.1, 5e-4, 15.0
    lin = linearize(m, x=x0)
    op = lin["operating_point"]
    A, B, C = lin["A"], lin["B"], lin["C"]
    n = A.shape[0]
    Ad, Bd = discretize(A, B, TS)
    N = 1500
    z = np.zeros(n)
    xs = np.empty(N)
    for k in range(N):
        xs[k] = x0 + C[0] @ z
        z = Ad @ z + Bd * (kp * (x0 + step - xs[k]))
    t = np.arange(N) * TS
    ml = control_metrics(t, xs, np.full(N, x0 + step), [(0.0, x0, x0 + step)])
    res = run(m, {"kind": "pid", "gains": {"kp": kp}, "setpoint": [[0, x0 + step]]},
              duration=(N - 1) * TS, p=op["p_a"])
    mn = res.stats["control"]
    assert ml["overshoot"] > 0.1                    # an underdamped loop: overshoot to compare
    assert mn["overshoot"] == pytest.approx(ml["overshoot"], rel=0.05)
    assert mn["settling_time"] == pytest.approx(ml["settling_time"], rel=0.05)
    assert np.allclose(res.series["x_ref"], x0 + step)


def test_pid_on_a_frictionless_jack_reaches_zero_steady_state_error():
    # a 10 mm step; the remaining error below 10 um: 0.1 % of the move, above the solver's
    # position tolerance (rtol 1e-5 x 0.25 m stroke = 2.5 um). The integral's unwinding
    # decays with a time constant of ~0.3 s (measured), hence 3 s (0.3 um left at the end)
    res = run(servo_model(), {"kind": "pid", "gains": {"kp": 15, "ki": 40, "kd": 0.1},
                              "setpoint": [[0, 0.1], [0.05, 0.11]]}, duration=3.0)
    c = res.stats["control"]
    assert abs(c["steady_state_error"]) < 1e-5
    assert c["settling_time"] is not None and c["rise_time"] > 0
    assert res.stats["control"]["stable"]


CF_GAINS = {"kp": 15, "ki": 60}


def test_coulomb_friction_makes_the_pid_hunt_and_the_dead_band_or_sliding_law_stop_it():
    # stick-slip with integral action: a limit cycle (measured 1 mm at 1.1 Hz). Thresholds:
    # hunting above 0.2 mm (a fifth of it), none below 1 um (the position tolerance's order)
    m = servo_model(coulomb=True)
    sp = [[0, 0.1], [0.1, 0.11]]
    hunt = run(m, {"kind": "pid", "gains": CF_GAINS, "setpoint": sp}, duration=3.0)
    c = hunt.stats["control"]
    assert c["hunting_amplitude"] > 2e-4 and c["hunting_frequency"] > 0.2
    band = run(m, {"kind": "pid", "gains": dict(CF_GAINS, deadband=5e-4), "setpoint": sp},
               duration=3.0).stats["control"]
    assert band["hunting_amplitude"] < 1e-6
    assert abs(band["steady_state_error"]) <= 5e-4 + 1e-6      # within the dead band
    sliding = run(m, {"kind": "sliding_mode", "gains": {"lambda": 20, "k": 1.0, "phi": 0.1},
                      "setpoint": sp}, duration=3.0).stats["control"]
    assert sliding["hunting_amplitude"] < 1e-6


def test_onoff_and_setpoint_shapes_run():
    m = servo_model()
    res = run(m, {"kind": "onoff", "gains": {"deadband": 1e-3, "level": 0.2},
                  "setpoint": {"kind": "jerk_limited", "x0": 0.1, "x1": 0.15, "t0": 0.1,
                               "v_max": 0.2, "a_max": 2.0, "j_max": 50.0}}, duration=1.0)
    assert res.stats["control"]["switchings"] >= 2
    assert res.series["x_ref"][-1] == pytest.approx(0.15)
    for sp in ({"kind": "ramp", "x0": 0.1, "x1": 0.12, "t0": 0.1, "t1": 0.3},
               {"kind": "sine", "center": 0.1, "amplitude": 0.005, "frequency": 2.0},
               {"kind": "recorded", "t": [0, 0.2, 0.4], "x": [0.1, 0.11, 0.105]}):
        r = run(m, {"kind": "pva", "gains": {"kp": 15, "kv": 0.05, "ff_v": 0.02},
                    "setpoint": sp}, duration=0.6)
        assert r.stats["control"]["rms_error"] < 5e-3


def test_unstable_gains_end_with_a_clear_message():
    # a gain 100x the tuned one on a 50 mm step: the piston slams between the end stops
    with pytest.raises(ControlError) as exc:
        run(servo_model(), {"kind": "pid", "gains": {"kp": 1500, "ki": 5000},
                            "setpoint": [[0, 0.1], [0.05, 0.15]]}, duration=1.0)
    assert "unstable" in str(exc.value) and "gains" in str(exc.value)


@pytest.mark.parametrize("ctl,field", [
    ({"kind": "pid", "gains": {"kp": float("nan")}, "setpoint": [[0, 0.1]]}, "scenario.controller.gains.kp"),
    ({"kind": "pid", "gains": {}, "setpoint": [[0, 0.1]]}, "scenario.controller.gains.kp"),
    ({"kind": "pid", "gains": {"kp": 1, "kq": 2}, "setpoint": [[0, 0.1]]}, "scenario.controller.gains.kq"),
    ({"kind": "pid", "gains": {"kp": 1}, "setpoint": [[0, 0.1], [0.1, 0.3]]}, "scenario.controller.setpoint[1][1]"),
    ({"kind": "pid", "gains": {"kp": 1}, "setpoint": {"kind": "sine", "center": 0.2, "amplitude": 0.1, "frequency": 1}}, "scenario.controller.setpoint"),
    ({"kind": "nope", "gains": {}, "setpoint": [[0, 0.1]]}, "scenario.controller.kind"),
    ({"kind": "pid", "gains": {"kp": 1}, "setpoint": [[0, 0.1]], "sample_period": 0}, "scenario.controller.sample_period"),
])
def test_bad_controller_input_names_the_field(ctl, field):
    with pytest.raises(FieldError) as exc:
        run(servo_model(), ctl, duration=0.1)
    assert exc.value.path == field


def test_a_proportional_controller_on_an_onoff_valve_is_refused():
    with pytest.raises(FieldError) as exc:
        simulate_closed_loop(model_preset("paper-3way"), {
            "duration": 0.1, "x0": 0.1, "controller": {"kind": "pid", "gains": {"kp": 10},
                                                       "setpoint": [[0, 0.1]]}})
    assert exc.value.path == "scenario.controller.kind" and "3/2" in str(exc.value)


def test_the_closed_loop_is_its_own_output_replayed_open_loop():
    # the controller's output at each 1 kHz instant, held, replayed through the open-loop
    # core: the same trajectory. Both integrate the same equations with the same step ends;
    # 1e-8 m is a thousandth of the solver's position tolerance (2.5 um) and still catches a
    # held value one sample late (measured difference 6e-11 m)
    from pneucore import simulate
    m = servo_model()
    base = {"duration": 0.5, "sample_period": TS, "x0": 0.1,
            "initial": {"p_a": 5.3e5, "p_b": 5.3e5}}
    res = simulate_closed_loop(m, dict(base, controller={
        "kind": "pid", "gains": {"kp": 15, "ki": 40, "kd": 0.1}, "setpoint": [[0, 0.1], [0.05, 0.11]]}))
    n = 500
    cmd = [[k * TS, float(res.series["u"][k])] for k in range(n)]
    rr = simulate(m, dict(base, command=cmd, solver={"max_events": 4000}))
    assert abs(rr.series["x"] - res.series["x"]).max() < 1e-8


def test_a_users_controller_runs_in_the_core_like_the_built_in_one():
    # a user's P law, registered from Python, against the built-in PID with the same kp:
    # the same compiled arithmetic, hence the same run (1e-12 m: rounding only)
    from numba import njit

    from pneucore.control.controllers import register_user_controller, unregister_controller

    @njit
    def my_p(g, x_ref, v_ref, a_ref, meas, cst, Ts, u_lo, u_hi):
        return g[0] * (x_ref - meas[0])
    register_user_controller("my_p", my_p, [("kp", "1/m", None)])
    try:
        sp = [[0, 0.1], [0.05, 0.11]]
        mine = run(servo_model(), {"kind": "my_p", "gains": {"kp": 15}, "setpoint": sp}, duration=0.5)
        ref = run(servo_model(), {"kind": "pid", "gains": {"kp": 15}, "setpoint": sp}, duration=0.5)
        assert abs(mine.series["x"] - ref.series["x"]).max() < 1e-12
        assert mine.stats["control"]["kind"] == "my_p"
    finally:
        unregister_controller("my_p")


def test_pwm_drives_the_valve_on_off_and_reaches_the_dead_band():
    # duty kp |e| over 10 ms periods: the command takes the centre or +-level only, and the
    # piston ends within the dead band (1 mm) of a 10 mm step; the valve switches many times
    res = run(servo_model(), {"kind": "pwm", "gains": {"kp": 50, "period": 0.01, "deadband": 1e-3,
                                                       "level": 0.2},
                              "setpoint": [[0, 0.1], [0.05, 0.11]]}, duration=1.5)
    u = set(np.round(res.series["u"], 12))
    assert u <= {0.0, 0.2, -0.2}
    c = res.stats["control"]
    assert abs(c["steady_state_error"]) <= 1e-3 + 1e-6
    assert c["switchings"] >= 4


def _amplitude(t, y, f, t_from):
    """Amplitude of the f-Hz component of y over t >= t_from (least squares on sin, cos, 1)."""
    w = t >= t_from
    tt = t[w]
    X = np.column_stack([np.sin(2 * np.pi * f * tt), np.cos(2 * np.pi * f * tt), np.ones_like(tt)])
    c = np.linalg.lstsq(X, y[w], rcond=None)[0]
    return float(np.hypot(c[0], c[1]))


@pytest.mark.parametrize("f", [2.0, 6.0])
def test_small_sine_tracking_matches_the_linearised_closed_loop(f):
    # a 0.3 mm sine setpoint under P control at the valve's null: the tracked amplitude of
    # the nonlinear run against the linear model under the same law and ZOH, 5 % (the
    # issue's tolerance for the linear checks; measured gains 0.947 vs 0.950 at 2 Hz, 1.143 vs
    # 1.148 at 6 Hz: 0.4 %)
    m = servo_model()
    x0, amp, kp = 0.1, 3e-4, 15.0
    lin = linearize(m, x=x0)
    A, B, C = lin["A"], lin["B"], lin["C"]
    n = A.shape[0]
    Ad, Bd = discretize(A, B, TS)
    N = 2001
    t = np.arange(N) * TS
    ref = x0 + amp * np.sin(2 * np.pi * f * t)
    z = np.zeros(n)
    xs = np.empty(N)
    for k in range(N):
        xs[k] = x0 + C[0] @ z
        z = Ad @ z + Bd * (kp * (ref[k] - xs[k]))
    res = run(m, {"kind": "pid", "gains": {"kp": kp},
                  "setpoint": {"kind": "sine", "center": x0, "amplitude": amp, "frequency": f}},
              duration=(N - 1) * TS, p=lin["operating_point"]["p_a"])
    a_lin = _amplitude(t, xs, f, 1.0)
    a_sim = _amplitude(res.t, res.series["x"], f, 1.0)
    assert a_sim == pytest.approx(a_lin, rel=0.05)
