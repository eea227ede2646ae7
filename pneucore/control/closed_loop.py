"""Closed-loop simulation (issue 42, item 1): the controller evaluated inside the compiled core
at its own sample period (zero-order hold), on the measured signals, writing the valve command
(:func:`pneucore.core.integrator.integrate_closed`). No Python runs between two samples.

A controller spec (the scenario's ``controller`` in the API) is::

    {"kind": "pid", "gains": {"kp": 20, "ki": 5, "kd": 0.2},
     "setpoint": [[0, 0.1], [0.05, 0.15]], "sample_period": 0.001, "settle_band": 0.001}

(SI: m, s; ``kp`` in 1/m is the valve opening per metre of error; ``seed`` [-], default 0,
seeds the sensors' noise; ``rate_filter`` [s] and ``ideal_rates`` [-]: see below.) The result is the :class:`pneucore.result.SimulationResult` of an
open-loop run plus ``series["x_ref"]`` [m] and ``stats["control"]``
(:func:`pneucore.control.metrics.control_metrics`, and the controller's kind, gains and sample
period).

The controller reads the position and the pressures through the model's sensors, the
``sensor_lag`` effect (:func:`sensor_signals`; laws in :mod:`pneucore.physics.sensors`): the
position sensor's resolution [m], lag [s] and noise [m], the transducers' lag [s], noise [Pa]
and resolution [Pa]. The velocity and acceleration the laws read are estimated from the sensed
position by a filtered differentiator (:func:`pneucore.physics.sensors.estimate_rates`, time
constant ``rate_filter`` [s], default :data:`RATE_FILTER`); ``"ideal_rates": true`` gives the
laws the piston's true velocity and acceleration instead (a simulation's idealisation, no
rig has it). The series keep the true position ``x`` and add what the controller read:
``series["v_est"]`` [m/s] and ``series["a_est"]`` [m/s^2] (the estimates), ``x_sensed`` [m]
where the model has a position sensor, ``p_a_sensed``, ``p_b_sensed`` [Pa] where its
transducers have noise or a resolution. The metrics judge the true position.
"""
from __future__ import annotations

import math

import numpy as np

from pneucore.control.controllers import controller_kind
from pneucore.control.metrics import control_metrics
from pneucore.control.setpoints import Setpoint
from pneucore.core import controllers as C
from pneucore.core import layout as L
from pneucore.core.integrator import (ERR_EVENTS_OVERFLOW, N_STATS, OK, STATUS_MESSAGES,
                                     closed_core_for, closed_core_with_law)
from pneucore.core import rhs as rhs_module
from pneucore.physics import sensors as S
from pneucore.core.rhs import no_terms
from pneucore.result import CoreRun
from pneucore.simulate import (SimulationError, build_core, mark_unreached, output_buffers,
                               output_times)
from pneucore.description.model import Model, check_resolvable
from pneucore.description.scenario import Scenario
from pneucore.description.validation import FieldError

#: Shortest controller sample period [s]: 10 us, ten times the solver's smallest useful step
MIN_SAMPLE_PERIOD = 1e-5

#: Default time constant of the filtered differentiator that estimates the velocity and the
#: acceleration the laws read from the sensed position [s]: 2 ms, a cut-off of 80 Hz, eight
#: to ten times the servo jack's pneumatic natural frequency (8.4 Hz at mid-stroke, 10.2 Hz at
#: a fifth of the stroke, :func:`pneucore.control.linearize.linearize`), and the PID's own
#: default derivative filter (:func:`pneucore.physics.sensors.estimate_rates`)
RATE_FILTER = 2e-3
#: Longest rate filter accepted [s]: one second would lag any servo axis out of control
MAX_RATE_FILTER = 1.0

#: The fields of a controller spec
CONTROLLER_FIELDS = ("kind", "gains", "setpoint", "sample_period", "settle_band", "seed",
                     "rate_filter", "ideal_rates")


class ControlError(SimulationError):
    """A closed loop that could not be run to its end (unstable gains); ``result`` holds the
    run up to where it stopped."""


def parse_controller(spec, model, duration, path="scenario.controller"):
    """A controller spec checked against the model: ``(kind, gains vector, setpoint, T_s,
    band)``; every error a FieldError naming its field and unit."""
    if not isinstance(spec, dict):
        raise FieldError(path, "must be an object {kind, gains, setpoint, sample_period}")
    for k in spec:
        if k not in CONTROLLER_FIELDS:
            raise FieldError(f"{path}.{k}", "unknown field; fields: kind, gains, setpoint, "
                                            "sample_period [s], settle_band [m], seed [-], "
                                            "rate_filter [s], ideal_rates [-]")
    kind = controller_kind(spec.get("kind"), f"{path}.kind")
    if model.valve.kind not in kind.valves:
        raise FieldError(f"{path}.kind", f"a {kind.name} controller sets a proportional "
                         f"opening; the {model.valve.kind} valve (range "
                         f"{list(model.valve.opening_range)} [-]) cannot take it; valves it "
                         f"drives: {list(kind.valves)} (use onoff for an on/off valve)")
    gains = kind.pack(spec.get("gains", {}), f"{path}.gains")
    Ts = spec.get("sample_period", 1e-3)
    if isinstance(Ts, bool) or not isinstance(Ts, (int, float)) or not math.isfinite(Ts) \
            or not MIN_SAMPLE_PERIOD <= Ts <= duration:
        raise FieldError(f"{path}.sample_period", f"must be a finite period within "
                         f"[{MIN_SAMPLE_PERIOD:g}, duration {duration:g}] s, got {Ts!r}")
    if "setpoint" not in spec:
        raise FieldError(f"{path}.setpoint", "is required: [[t [s], x [m]], ...] or a shape")
    sp = Setpoint(spec["setpoint"], f"{path}.setpoint")
    sp.check_within(model.jack.stroke, duration)
    band = spec.get("settle_band")
    if band is not None and (isinstance(band, bool) or not isinstance(band, (int, float))
                             or not math.isfinite(band) or band <= 0):
        raise FieldError(f"{path}.settle_band", f"must be a finite band > 0 [m], got {band!r}")
    seed = spec.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2 ** 63:
        raise FieldError(f"{path}.seed", f"must be a whole number >= 0 [-] (the sensors' "
                                         f"noise), got {seed!r}")
    tau = spec.get("rate_filter", RATE_FILTER)
    if isinstance(tau, bool) or not isinstance(tau, (int, float)) or not math.isfinite(tau) \
            or not 0.0 <= tau <= MAX_RATE_FILTER:
        raise FieldError(f"{path}.rate_filter", f"must be a finite time constant from 0 to "
                         f"{MAX_RATE_FILTER:g} [s] (the velocity and acceleration estimator's "
                         f"filter; 0 = the plain backward difference), got {tau!r}")
    ideal = spec.get("ideal_rates", False)
    if not isinstance(ideal, bool):
        raise FieldError(f"{path}.ideal_rates", f"must be true or false [-], got {ideal!r}")
    return kind, gains, sp, float(Ts), band


def sensor_signals(model, Ts, n, seed, rate_filter=RATE_FILTER, ideal_rates=False):
    """The closed loop's sensors, from the model's ``sensor_lag`` effect (the one description
    of its sensors: :mod:`pneucore.physics.sensors`): the sensors' parameters for the core,
    and the noise of each sample instant, drawn before the run.

    Parameters
    ----------
    model : Model
        The actuator
    Ts : float
        Controller sample period [s]
    n : int
        Sample instants [-]
    seed : int
        Seed of ``numpy.random.default_rng`` [-]: the same seed, the same noise
    rate_filter : float
        Time constant of the velocity and acceleration estimator
        (:func:`pneucore.physics.sensors.estimate_rates`) [s]
    ideal_rates : bool
        The laws read the piston's true velocity and acceleration instead [-]

    Returns
    -------
    sens : ndarray
        The sensors' parameters (:data:`pneucore.physics.sensors.SENS_Q` ... slots: position
        resolution [m], position lag [s], T_s [s], rate filter [s], ideal-rates flag [-],
        pressure resolution [Pa])
    noise : ndarray
        ``(n, 3)``: noise on the position [m] and on the pressures of A and B [Pa] at each
        instant ``k T_s`` (zeros without noise)
    declared : tuple of bool
        The model has a position sensor that is not ideal (the result then carries
        ``series["x_sensed"]``), pressure transducers with noise or a resolution
        (``series["p_a_sensed"]``, ``series["p_b_sensed"]``) [-]
    """
    p = model.effects.get("sensor_lag") or {}
    q = float(p.get("position_resolution", 0.0))
    tau = float(p.get("position_time_constant", 0.0))
    sx = float(p.get("position_noise", 0.0))
    sp = float(p.get("pressure_noise", 0.0))
    qp = float(p.get("pressure_resolution", 0.0))
    noise = np.zeros((n, 3))
    if sx > 0.0 or sp > 0.0:
        # one draw of the three columns together: a seed gives the same noise whichever
        # of them the model turns on
        noise[:] = np.random.default_rng(seed).standard_normal((n, 3)) * np.array([sx, sp, sp])
    sens = np.zeros(S.N_SENS)
    sens[S.SENS_Q] = q
    sens[S.SENS_TAU] = tau
    sens[S.SENS_TS] = Ts
    sens[S.SENS_RATE_TAU] = rate_filter
    sens[S.SENS_IDEAL_RATES] = 1.0 if ideal_rates else 0.0
    sens[S.SENS_P_Q] = qp
    return sens, noise, (q > 0.0 or tau > 0.0 or sx > 0.0, sp > 0.0 or qp > 0.0)


def simulate_closed_loop(model, scenario, controller=None, raise_on_error=True, t_out=None):
    """Simulate the actuator with the loop closed by a controller.

    Parameters
    ----------
    model : Model or dict
        The actuator
    scenario : Scenario or dict
        Duration, sampling, initial state, solver (its ``command`` is not used); a dict may
        carry the ``controller``
    controller : dict or None
        The controller spec (see the module); None: ``scenario["controller"]``
    raise_on_error : bool
        Raise :class:`ControlError` when the run cannot reach its end
    t_out : array_like or None
        Sample times [s]; None = every ``sample_period``

    Returns
    -------
    result : SimulationResult
        With ``series["x_ref"]`` [m] and ``stats["control"]``
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    if isinstance(scenario, Scenario):
        scenario.check_against(model)
    else:
        scenario = dict(scenario)
        if controller is None:
            controller = scenario.pop("controller", None)
        else:
            scenario.pop("controller", None)
        scenario = Scenario.from_dict(scenario, model)
    if controller is None:
        raise FieldError("scenario.controller", "is required for a closed-loop run")
    kind, gains, sp, Ts, band = parse_controller(controller, model, scenario.duration)
    seed = controller.get("seed", 0)
    rate_filter = float(controller.get("rate_filter", RATE_FILTER))
    ideal_rates = bool(controller.get("ideal_rates", False))
    check_resolvable(model, scenario.solver.rtol, scenario.solver.max_step)
    core = build_core(model, scenario)
    t_out = output_times(scenario, t_out)
    y_out, aux_out, mode_out, u_out = output_buffers(t_out.shape[0], core["y0"].shape[0])
    n_ref = int(math.floor(scenario.duration / Ts + 1e-9)) + 2
    t_ref = np.arange(n_ref) * Ts
    ref = np.ascontiguousarray(np.column_stack(sp.evaluate(t_ref)))
    lo, hi = model.valve.opening_range
    i_sens = int(core["model"][1][L.STATE_IY0["pressure_sensor"]])
    cst = np.zeros(C.N_CST)
    sens, noise, (position_declared, pressure_declared) = sensor_signals(
        model, Ts, n_ref, seed, rate_filter, ideal_rates)
    sst = np.zeros(S.N_SST)
    sensed = np.full((n_ref, 5), np.nan)
    ctl = (np.int64(kind.code), gains, ref, Ts, cst, np.array([lo, hi], float),
           np.int64(i_sens), np.zeros(C.N_MEAS), sens, noise, sst, sensed)
    if kind.law is not None:
        if core["hook"] is not no_terms or core["flow_laws"] != rhs_module.flow_laws \
                or core["friction_laws"] != rhs_module.friction_laws:
            raise FieldError("scenario.controller.kind", "a user's controller runs on a model "
                             "with the built-in laws and no effect adding compiled terms [-]")
        run = closed_core_with_law(kind.law)
    else:
        run = closed_core_for(core["hook"], core["flow_laws"], core["friction_laws"])
    max_ev = scenario.solver.max_events
    cap = min(max_ev, 256)
    while True:
        ev_t = np.full((cap, 2), np.nan)
        ev_kind = np.empty(cap, np.int64)
        ev_mode = np.empty(cap, np.int64)
        stats = np.zeros(N_STATS, np.int64)
        cst[:] = 0.0
        sst[:] = 0.0
        status, n_ev, t_reached = run(
            core["y0"], core["mode0"], core["model"], ctl, scenario.duration, t_out,
            scenario.solver.rtol, core["atol"], min(scenario.solver.max_step, Ts), 1e-6,
            scenario.solver.max_steps, y_out, aux_out, mode_out, u_out, ev_t, ev_kind,
            ev_mode, stats)
        if status == ERR_EVENTS_OVERFLOW and cap < max_ev:
            cap = max_ev
            continue
        break
    n_ev = min(n_ev, cap)
    if status != OK:
        mark_unreached(t_out, t_reached, y_out, aux_out, mode_out, u_out)
    res = CoreRun(model, scenario, core, t_out, y_out, aux_out, mode_out, u_out, ev_t[:n_ev],
                  ev_kind[:n_ev], ev_mode[:n_ev], stats, status, t_reached, []).result()
    x_ref = sp.evaluate(res.t)[0]
    res.series["x_ref"] = x_ref
    # what the controller read, held from each sample instant to the next (an output sample
    # at an instant shows that instant's reading; the run's end, an instant the controller no
    # longer acts at, the last reading); NaN where the run never got
    done = np.flatnonzero(np.isfinite(sensed[:, 0]))
    k = np.minimum(np.floor(res.t / Ts + 1e-9).astype(np.int64), done[-1] if done.size else 0)
    unreached = ~np.isfinite(res.series["x"])
    read = [("x_sensed", 0, position_declared), ("v_est", 1, not ideal_rates),
            ("a_est", 2, not ideal_rates), ("p_a_sensed", 3, pressure_declared),
            ("p_b_sensed", 4, pressure_declared)]
    for name, col, shown in read:
        if shown:
            sig = sensed[k, col]
            sig[unreached] = np.nan
            res.series[name] = sig
    moves = sp.moves()
    x_start = float(res.series["x"][0])
    if sp.kind in ("step", "multi_step", "recorded") and sp.pts[0, 1] != x_start \
            and (not moves or moves[0][0] > sp.pts[0, 0]):
        # the first setpoint away from where the piston starts is a move too
        moves.insert(0, (float(sp.pts[0, 0]), x_start, float(sp.pts[0, 1])))
    metrics = control_metrics(res.t, res.series["x"], x_ref, moves,
                              res.series.get("q_supply"), int(cst[C.CST_SWITCHES]), band)
    metrics.update(kind=kind.name, sample_period=Ts,
                   gains={g.name: float(gains[i]) for i, g in enumerate(kind.gains)})
    verdict = _stability(res, x_ref, model.jack.stroke, status, sp)
    metrics["stable"] = verdict is None
    res.stats["control"] = metrics
    if verdict is not None and raise_on_error:
        raise ControlError(verdict, res)
    if status != OK and raise_on_error:
        raise ControlError(f"closed-loop simulation stopped at t = {t_reached:.6g} s: "
                           f"{STATUS_MESSAGES[status]}", res)
    return res


def _stability(res, x_ref, stroke, status, sp):
    """None for a loop that behaves, else the message of an unstable one: the solver stopped
    (an oscillation between the end stops exhausts its steps or events), or the piston still
    swings over more than a tenth of the stroke between the end stops in the last 30 % of the
    run while the setpoint holds (a limit cycle that gains this large never settles)."""
    hint = ("the closed loop is unstable with these gains (scenario.controller.gains): "
            "lower the proportional gain, add damping (kd, or the sliding layer phi), or a "
            "dead band")
    if status != OK:
        return f"{hint}; the solver stopped at t = {res.t_reached if hasattr(res, 't_reached') else float('nan'):.6g} s" \
            if status in (1, 3, 5) else None
    t = res.t
    x = res.series["x"]
    late = t >= t[0] + 0.7 * (t[-1] - t[0])
    if sp.kind == "sine" or late.sum() < 3:
        return None
    swing = float(np.nanmax(x[late]) - np.nanmin(x[late]))
    held = float(np.nanmax(x_ref[late]) - np.nanmin(x_ref[late]))
    if swing - held > 0.1 * stroke:
        return f"{hint}: the piston still swings over {swing * 1e3:.0f} mm at the end of the run"
    return None
