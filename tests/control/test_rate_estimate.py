"""What a controller reads besides the position (issue 42, item 1): the velocity and the
acceleration estimated from the SENSED position by the filtered differentiator
(:func:`pneucore.physics.sensors.estimate_rates`, ``scenario.controller.rate_filter``), and the
pressures quantised to the transducers' resolution (``sensor_lag.pressure_resolution``).

The theory: each stage is ``s / (tau s + 1)`` discretised by backward differences,
``V(z) / X(z) = (1 - z^-1) / (tau + T_s - tau z^-1)``, ``a = tau / (tau + T_s)``."""
import math

import numpy as np
import pytest

from pneucore.control.closed_loop import RATE_FILTER, simulate_closed_loop
from pneucore.control.models import servo_model
from pneucore.control.setpoints import Setpoint
from pneucore.description.validation import FieldError
from pneucore.physics.sensors import N_SST, SST_A, SST_V, estimate_rates

TS = 1e-3       # the default controller sample period [s]
TAU = RATE_FILTER
RAMP = {"kind": "ramp", "x0": 0.1, "x1": 0.15, "t0": 0.1, "t1": 0.6}     # 0.1 m/s
PID_FF = {"kp": 15, "ki": 40, "kd": 0.1, "kff": 0.5}


def estimates(x, tau=TAU, ts=TS):
    """The estimator run over a sequence of sensed positions: (v [m/s], a [m/s^2])."""
    st = np.zeros(N_SST)
    v, a = np.empty(len(x)), np.empty(len(x))
    for k, xk in enumerate(x):
        estimate_rates(float(xk), st, ts, tau)
        v[k], a[k] = st[SST_V], st[SST_A]
    return v, a


def transfer(f, tau=TAU, ts=TS):
    """``V/X`` of the estimator at frequency ``f`` [Hz] [1/s]."""
    zi = np.exp(-2j * np.pi * f * ts)
    return (1 - zi) / (tau + ts - tau * zi)


def run(model, controller, duration, x0=0.1, p=5.3e5):
    return simulate_closed_loop(model, {"duration": duration, "sample_period": TS, "x0": x0,
                                        "initial": {"p_a": p, "p_b": p},
                                        "controller": controller})


def test_on_a_ramp_the_estimate_converges_to_the_slope_as_the_closed_form_says():
    # from rest, x_k = c k T_s: v_k = c (1 - a^k) and a_k = c (1 - a)^2 k a^(k-1) / T_s
    c, n = 0.1, 60
    k = np.arange(n)
    v, acc = estimates(c * TS * k)
    a = TAU / (TAU + TS)
    # float rounding of 60 recursions only (relative 1e-12 is a thousand ulps)
    assert np.allclose(v, c * (1 - a ** k), rtol=1e-12, atol=1e-15)
    assert np.allclose(acc[1:], c * (1 - a) ** 2 * k[1:] * a ** (k[1:] - 1) / TS,
                       rtol=1e-12, atol=1e-12)
    # converged: within c a^59 (3.9e-12 of the slope) after 60 samples
    assert v[-1] == pytest.approx(c, rel=1e-10) and abs(acc[-1]) < 1e-7
    # tau = 0: the plain backward difference, the slope from the second sample on
    v0, _ = estimates(c * TS * k, tau=0.0)
    assert np.allclose(v0[1:], c, rtol=1e-12)


@pytest.mark.parametrize("f", [5.0, 20.0, 80.0])
def test_on_a_sine_the_gain_and_lag_are_the_filters_transfer_function(f):
    # x = A sin(w t) sampled: after the transient (a^1000 = 1e-176) the estimate is
    # A |H| sin(w t + arg H); a least-squares fit of sin and cos over 2000 samples recovers
    # it to rounding (1e-9 relative is a million times the fit's own error)
    amp = 1e-3
    t = np.arange(3000) * TS
    v, _ = estimates(amp * np.sin(2 * np.pi * f * t))
    late = slice(1000, None)
    M = np.column_stack([np.sin(2 * np.pi * f * t[late]), np.cos(2 * np.pi * f * t[late])])
    s, co = np.linalg.lstsq(M, v[late], rcond=None)[0]
    H = transfer(f)
    assert complex(s, co) / amp == pytest.approx(complex(H.real, H.imag), rel=1e-9)
    # against the true derivative A w cos(w t): behind by 90 deg - arg H, gain |H| / w
    # (4.49 deg and 0.997 at 5 Hz, 17.5 deg and 0.955 at 20 Hz, 52.1 deg and 0.628 at the
    # 80 Hz cut-off: the docs' table); at low frequency the lag tends to the continuous
    # filter's atan(w tau) plus the backward difference's half sample (7e-5 rad apart at
    # 5 Hz, a third-order term: 1e-4 rad bounds it there only)
    if f == 5.0:
        w = 2 * np.pi * f
        assert math.pi / 2 - np.angle(H) == pytest.approx(math.atan(w * TAU) + w * TS / 2,
                                                          abs=1e-4)


def test_the_closed_loop_laws_read_the_estimate_from_the_sensed_position():
    # PVA on a step: the series v_est, a_est are the estimator run on the position at the
    # sample instants (the model has no position sensor: sensed = true), and the valve
    # command is the PVA law on them, not on the piston's own velocity
    g = {"kp": 15, "kv": 0.05, "ka": 0.001, "ff_v": 0.02}
    ctl = {"kind": "pva", "gains": g, "setpoint": [[0, 0.1], [0.05, 0.11]]}
    res = run(servo_model(), ctl, duration=0.3)
    v, a = estimates(res.x)
    # the last output sample is the run's end, where the controller no longer acts (the
    # series hold the last reading): compared up to it; 1e-12 m/s is float rounding
    assert np.allclose(res.series["v_est"][:-1], v[:-1], rtol=1e-9, atol=1e-12)
    assert np.allclose(res.series["a_est"][:-1], a[:-1], rtol=1e-9, atol=1e-9)
    xr, vr, ar = Setpoint(ctl["setpoint"]).evaluate(res.t)

    def pva(v, a):
        return np.clip(g["kp"] * (xr - res.x) + g["kv"] * (vr - v) + g["ka"] * (ar - a)
                       + g["ff_v"] * vr, -1, 1)[:-1]
    # the command held from each instant is the law's output there (1e-12: rounding)
    assert np.allclose(res.u[:-1], pva(res.series["v_est"], res.series["a_est"]), atol=1e-12)
    # the estimate lags: the law on the piston's own velocity gives another command
    # (by up to 2.5e-3 of the valve's range on this step; 1e-4 is 25x below)
    assert np.max(np.abs(res.u[:-1] - pva(res.v, res.series["a"]))) > 1e-4
    # ideal_rates: the law reads the piston's true velocity and acceleration (no estimate
    # series); the acceleration the law read at an instant is the right-hand side's there,
    # as is the output sample's (1e-9: the solver's state at the instant, same both)
    ideal = run(servo_model(), dict(ctl, ideal_rates=True), duration=0.3)
    assert "v_est" not in ideal.series and "a_est" not in ideal.series
    xr_i = xr
    u_i = np.clip(g["kp"] * (xr_i - ideal.x) + g["kv"] * (vr - ideal.v)
                  + g["ka"] * (ar - ideal.series["a"]) + g["ff_v"] * vr, -1, 1)[:-1]
    assert np.allclose(ideal.u[:-1], u_i, atol=1e-9)


def test_closed_loop_sine_estimate_matches_the_transfer_function():
    # PID tracking a 5 Hz, 5 mm sine: the fundamental of v_est over whole periods is the
    # fundamental of x times H(5 Hz) (the estimator is linear); the piston's motion is not
    # a pure sine, and its harmonics and the first second's transient leave the fit within
    # 1e-3 (measured 2.4e-5 in gain, 5e-5 rad in phase)
    f = 5.0
    res = run(servo_model(), {"kind": "pid", "gains": {"kp": 15, "ki": 40, "kd": 0.1},
                              "setpoint": {"kind": "sine", "center": 0.125, "amplitude": 0.005,
                                           "frequency": f, "t0": 0}},
              duration=2.0, x0=0.125)
    w = (res.t >= 1.0) & (res.t < 2.0)          # five whole periods
    M = np.column_stack([np.sin(2 * np.pi * f * res.t[w]), np.cos(2 * np.pi * f * res.t[w]),
                         np.ones(w.sum())])
    cx = np.linalg.lstsq(M, res.x[w], rcond=None)[0]
    cv = np.linalg.lstsq(M, res.series["v_est"][w], rcond=None)[0]
    ratio = complex(*cv[:2]) / complex(*cx[:2])
    H = transfer(f)
    assert abs(ratio) == pytest.approx(abs(H), rel=1e-3)
    assert np.angle(ratio) == pytest.approx(np.angle(H), abs=1e-3)
    # 4.5 degrees behind the true velocity at 5 Hz, gain 0.997
    assert math.degrees(math.pi / 2 - np.angle(H)) == pytest.approx(4.49, abs=0.01)


@pytest.mark.parametrize("q", [1e-4, 3.7e-5])
def test_a_quantised_encoder_gives_a_velocity_within_the_noise_bound(q):
    # the estimator is linear: the estimate from the quantised position minus the estimate
    # from the true one is the estimator run on the quantisation error e_k, |e_k| <= q/2;
    # summed by parts, |(1 - a)/T_s (e_k - (1 - a) sum a^(j-1) e_(k-j))| <= q / (tau + T_s).
    # With e_k white and uniform (Widrow's model) its RMS is
    # (1 - a)/T_s q/sqrt(12) sqrt(2/(1 + a)).
    m = servo_model()
    m["effects"] = {"sensor_lag": {"time_constant": 0.0, "position_resolution": q}}
    res = run(m, {"kind": "pid", "gains": PID_FF, "setpoint": RAMP}, duration=0.8)
    v_true_x, _ = estimates(res.x)
    d = (res.series["v_est"] - v_true_x)[:-1]
    bound = q / (TAU + TS)
    assert np.max(np.abs(d)) <= bound * (1 + 1e-9)        # the bound, to rounding
    # the bound is reached in practice: measured 96-98 % of it
    assert np.max(np.abs(d)) > 0.9 * bound
    a = TAU / (TAU + TS)
    sigma = (1 - a) / TS * q / math.sqrt(12) * math.sqrt(2 / (1 + a))
    moving = (res.t > 0.2) & (res.t < 0.6)
    # 400 samples estimate an RMS to 1/sqrt(2 n) = 3.5 %; the 0.1 mm count is one count
    # per sample at 0.1 m/s, its errors correlated (measured 11 % below the white model),
    # the 37 um count 2.7 counts per sample (measured 1 % above): 20 % covers both
    assert np.std(d[moving[:-1]]) == pytest.approx(sigma, rel=0.2)


def test_quantised_pressures_shift_the_force_loops_rest_by_what_the_law_misreads():
    # force_pid under a 20 N load: the loop comes to rest (valve centred, v_est = 0) where
    # kx e = Q(p_a) A - Q(p_b) A (the double-rod jack: A on both sides), the force read
    # through the transducers of resolution q. The ideal transducers rest at e = F_L / kx
    # (4 mm); the quantised ones off it by at most q A / kx, predicted from the final true
    # pressures alone.
    A = math.pi * (0.032 ** 2 - 0.012 ** 2) / 4
    kx, load = 5000.0, 20.0
    for q in (2000.0, 5000.0):
        m = servo_model()
        m["jack"]["load_force"] = load
        m["effects"] = {"sensor_lag": {"time_constant": 0.0, "pressure_resolution": q}}
        res = run(m, {"kind": "force_pid", "gains": {"kx": kx, "kd": 75, "kf": 2e-3},
                      "setpoint": [[0, 0.1], [0.05, 0.11]]}, duration=1.5)
        pa, pb = res.p_a[-2], res.p_b[-2]
        # what the law read: levels of the grid, within half a count of the chamber's
        # pressure at each instant (the model has no transducer lag); rounding 1e-9
        for sensed, true in ((res.series["p_a_sensed"], res.p_a), (res.series["p_b_sensed"], res.p_b)):
            assert np.allclose(sensed / q, np.round(sensed / q), atol=1e-9)
            assert np.max(np.abs(sensed - true)[:-1]) <= q / 2 * (1 + 1e-9)
        e = 0.11 - res.x[-2]
        predicted = (q * round(pa / q) - q * round(pb / q)) * A / kx
        # at rest to 1 nm (the valve's residual opening 2e-9 and the solver's tolerance
        # hold the piston within 1e-9 m of the balance): measured 3e-10 m
        assert e == pytest.approx(predicted, abs=1e-9)
        # off the ideal rest by a measurable amount (0.13 mm and 0.15 mm), within q A / kx
        assert 1e-5 < abs(e - load / kx) <= q * A / kx


@pytest.mark.parametrize("field,value", [
    ("rate_filter", -1e-3), ("rate_filter", float("nan")), ("rate_filter", 2.0),
    ("rate_filter", "fast"), ("ideal_rates", 1), ("ideal_rates", "yes")])
def test_bad_rate_options_name_the_field_and_unit(field, value):
    with pytest.raises(FieldError) as exc:
        run(servo_model(), {"kind": "pva", "gains": {"kp": 15}, "setpoint": [[0, 0.1]],
                            field: value}, duration=0.1)
    assert exc.value.path == f"scenario.controller.{field}"
    assert ("[s]" if field == "rate_filter" else "[-]") in str(exc.value)


def test_bad_pressure_resolution_names_the_field_and_unit():
    m = servo_model()
    m["effects"] = {"sensor_lag": {"pressure_resolution": -100.0}}
    with pytest.raises(FieldError) as exc:
        run(m, {"kind": "force_pid", "gains": {"kx": 5000, "kf": 2e-3}, "setpoint": [[0, 0.1]]},
            duration=0.1)
    assert exc.value.path == "effects.sensor_lag.pressure_resolution"
    assert "[Pa]" in str(exc.value)
