"""``simulate(model, scenario)``: assemble the compiled core's inputs, run it, wrap the result."""
from __future__ import annotations

import math
import threading
import time

import numpy as np
from numba import njit

from pneucore.core import layout as L
from pneucore.description.effects import EFFECTS, CoreBuild, effect_warnings, effective_model
from pneucore.physics.flow import FLOW_LAWS
from pneucore.physics.friction import FRICTION_LAWS
from pneucore.physics.gas import density
from pneucore.physics.heat import HEAT_MODELS
from pneucore.core.integrator import (ERR_EVENTS_OVERFLOW, N_STATS, OK, STATUS_MESSAGES, core_for,
                                     has_lines, integrate)
from pneucore.description.model import Model, check_resolvable
from pneucore.description.validation import choice
from pneucore.result import CoreRun
from pneucore.core.rhs import law_table, no_terms
from pneucore.description.scenario import Scenario
from pneucore.physics.valve import pack_tables, switched_command


class SimulationError(RuntimeError):
    """The integration could not proceed; ``result`` holds the samples computed so far."""

    def __init__(self, message, result=None):
        super().__init__(message)
        self.result = result


def output_samples(duration, sample_period):
    """Number of output samples of a run: ``t = 0, T_s, 2 T_s, ...`` up to ``duration``.

    The quotient is floored with an allowance of 1e-9 sample for its binary rounding
    (1.0 / 0.001 is 999.9999999999999 in floating point, and means 1001 samples).

    Parameters
    ----------
    duration : float
        Simulated time [s]
    sample_period : float
        Output sample period [s]
    """
    return int(math.floor(duration / sample_period + 1e-9)) + 1


def _initial_mode(model, scenario):
    if scenario.locked:
        return L.MODE_LOCKED
    if scenario.x0 <= 0.0:
        return L.MODE_STOP_LOW
    if scenario.x0 >= model.jack.stroke:
        return L.MODE_STOP_HIGH
    return L.MODE_STICK


_HOOKS = {}


def _compose_hooks(hooks):
    """One compiled hook calling each user effect's terms with its own parameters and states.

    Memoised on the user functions and their layout, so the specialised core
    (:func:`pneucore.core.integrator.specialize`) is compiled once per process.
    """
    key = tuple(hooks)
    if key in _HOOKS:
        return _HOOKS[key]
    fn = no_terms
    for terms, off, n, i0 in hooks:
        prev = fn

        def make(prev, terms, off, n, i0):
            @njit
            def hook(t, y, sig, prm_user, out, dy):
                prev(t, y, sig, prm_user, out, dy)
                terms(t, y, sig, prm_user[off:off + n], out, dy, i0)
            return hook
        fn = make(prev, terms, off, n, i0)
    _HOOKS[key] = fn
    return fn


#: The core's slot of each friction coefficient, per direction: ``(side, ((key, slot), ...))``
_FRICTION_SLOTS = tuple(
    (side, tuple((key, L.PRM_INDEX[f"{code}_{key.upper().replace('_', '')}"])
                 for key in ("fc0", "fc_a", "fc_b", "kv0", "kv_a", "kv_b")))
    for side, code in (("extend", "FE"), ("retract", "FR")))


def build_core(model, scenario):
    """Assemble the flat arrays of the compiled core.

    Returns
    -------
    core : dict
        ``y0``, ``atol``, ``mode0``, ``model`` tuple, ``hook``, the law tables
        ``flow_laws`` and ``friction_laws`` (:func:`pneucore.core.rhs.law_table`),
        ``state_names`` and the effective model (effects' transforms applied)
    """
    eff = effective_model(model)
    j, g = eff.jack, eff.gas
    prm = np.zeros(L.N_PRM_ALL)
    P = L.PRM_INDEX
    prm[P["R"]] = g.r
    prm[P["GAMMA"]] = g.gamma
    prm[P["SUP"]] = eff.supply.pressure
    prm[P["T_SUP"]] = eff.supply.temperature
    prm[P["ATM"]] = eff.ambient.pressure
    prm[P["T_ATM"]] = eff.ambient.temperature
    prm[P["A_A"]] = j.area_a
    prm[P["A_B"]] = j.area_b
    prm[P["A_ROD_A"]] = j.rod_area_a
    prm[P["A_ROD_B"]] = j.rod_area_b
    prm[P["STROKE"]] = j.stroke
    prm[P["V0_A"]] = j.dead_volume_a
    prm[P["V0_B"]] = j.dead_volume_b
    prm[P["MASS"]] = j.moving_mass
    prm[P["LOAD"]] = j.total_load
    prm[P["BORE"]] = j.bore
    prm[P["ROD_A"]] = j.rod_a
    prm[P["ROD_B"]] = j.rod_b
    prm[P["WALL_A"]] = j.wall_area_a or 0.0
    prm[P["WALL_B"]] = j.wall_area_b or 0.0
    heat = HEAT_MODELS[eff.heat.model]
    for slot, value in heat.core_values(eff.heat).items():
        prm[P[slot]] = value
    for side, slots in _FRICTION_SLOTS:
        fs = getattr(eff.friction, side)
        for key, slot in slots:
            prm[slot] = getattr(fs, key)
    prm[P["STRIBECK_RATIO"]] = 1.0
    prm[P["STRIBECK_V"]] = 0.01
    # the laws by name, through the registries (a law may have been unregistered since
    # the model was validated)
    flow_law = FLOW_LAWS[choice(eff.valve.flow_law, FLOW_LAWS, "valve.flow_law")]
    friction_law = FRICTION_LAWS[choice(eff.friction.law, FRICTION_LAWS, "friction.law")]
    prm[P["FLOW_LAW"]] = flow_law.code
    prm[P["FRICTION_LAW"]] = friction_law.code
    prm[P["R_LAM"]] = eff.valve.laminar_ratio
    if eff.b_chamber_pressure is not None:
        prm[P["B_CONST"]] = eff.b_chamber_pressure
    for k, name in enumerate(L.PORT_NAMES):
        port = eff.valve.ports.get(name)
        if port is not None:
            prm[P["CMAX_PA"] + k] = port.C_max
            prm[P["BMAX_PA"] + k] = port.b_at_C_max
    tx, tC, tb, tm, toff = pack_tables(eff.valve.core_ports())

    # initial state (Eq. 22-24): m = p V / (r T)
    ini = scenario.initial
    x0 = min(max(scenario.x0, 0.0), j.stroke)
    V_a, V_b = j.volumes(x0)
    T_amb = eff.ambient.temperature
    isothermal = heat.isothermal
    T_a = T_amb if isothermal or ini.T_a is None else ini.T_a
    T_b = T_amb if isothermal or ini.T_b is None else ini.T_b
    p_a = ini.p_a if ini.p_a is not None else eff.ambient.pressure
    if eff.b_chamber_pressure is not None:
        p_b = eff.b_chamber_pressure
        T_b = T_amb
    else:
        p_b = ini.p_b if ini.p_b is not None else eff.ambient.pressure
    y_base = [density(p_a, T_a, g.r) * V_a, T_a, density(p_b, T_b, g.r) * V_b, T_b, x0, 0.0]

    iy = -np.ones(L.N_IY_ALL, np.int64)
    iy[L.IY_NUSER] = 0
    u0 = _command_at_zero(scenario)
    build = CoreBuild(prm, iy, eff, {"u0": u0, "p_a": p_a, "p_b": p_b, "T_a": T_a, "T_b": T_b})
    heat.add_states(eff.heat, build, T_a, T_b)
    user_params, hooks = [], []
    for name, params in model.effects.items():
        e = EFFECTS[name]
        if e.pack is not None:
            e.pack(params, build)
        if e.terms is not None:
            i0 = L.N_BASE_STATES + len(build.states)
            for k, sname in enumerate(e.states):
                build.add_state(sname, params.get(f"{sname}_0", 0.0), 1e-9)
            hooks.append((e.terms, len(user_params), len(e.parameters), i0))
            user_params += [params[p.name] for p in e.parameters]
            if iy[L.IY_USER0] < 0 and e.states:
                iy[L.IY_USER0] = i0
            iy[L.IY_NUSER] += len(e.states)
    hook = _compose_hooks(hooks) if hooks else no_terms
    iy[L.IY_HOOK] = 1 if hooks else 0
    # the core cached on disk knows the built-in laws; a law registered at run time needs
    # a core compiled over the registries' tables (one for every such law: compiled once)
    builtin = flow_law.builtin and friction_law.builtin
    flow_table = law_table(FLOW_LAWS, builtin_only=builtin)
    friction_table = law_table(FRICTION_LAWS, builtin_only=builtin)

    rtol = scenario.solver.rtol
    r, T_ref = g.r, T_amb
    # absolute tolerance per state: a fraction rtol of a small but meaningful magnitude
    m_floor_a = 0.1 * eff.ambient.pressure * j.dead_volume_a / (r * T_ref)
    m_floor_b = 0.1 * eff.ambient.pressure * j.dead_volume_b / (r * T_ref)
    atol_base = [rtol * m_floor_a, rtol * T_ref, rtol * m_floor_b, rtol * T_ref,
                 rtol * j.stroke, rtol * 0.1]
    y0 = np.array(y_base + [s[1] for s in build.states])
    atol = np.array(atol_base + [max(s[2], 1e-30) for s in build.states])
    names = list(L.BASE_STATE_NAMES) + [s[0] for s in build.states]
    core_model = (prm, iy, tx, tC, tb, tm, toff, np.array(user_params, float),
                  np.zeros(L.N_SCRATCH))
    return {"y0": y0, "atol": atol, "mode0": _initial_mode(eff, scenario), "model": core_model,
            "hook": hook, "flow_laws": flow_table, "friction_laws": friction_table,
            "state_names": names, "effective_model": eff}


def _command_at_zero(scenario):
    u = scenario.command[0][1]
    for t, v in scenario.command:
        if t <= 0.0:
            u = v
    return u


def command_time_scale(scenario):
    """The shortest interval over which the command changes: between successive changes of a
    held command (a pulse's width), over a linear ramp, or from the last change to the end.

    Parameters
    ----------
    scenario : Scenario
        The scenario

    Returns
    -------
    time_scale : float or None
        Shortest interval [s]; None when the command never changes

    Examples
    --------
    A 30 ms pulse at 0.1 s in a 1 s run:

    >>> from pneucore.description.scenario import Scenario
    >>> command_time_scale(Scenario.from_dict({"command": [[0, 0], [0.1, 1], [0.13, 0]]}))
    0.03
    """
    cmd = np.asarray(scenario.command, float)
    t, u = cmd[:, 0], cmd[:, 1]
    moved = np.flatnonzero(np.diff(u) != 0.0) + 1          # breakpoints where u changes
    if moved.size == 0:
        return None
    if scenario.command_interpolation == "linear":
        spans = t[moved] - t[moved - 1]                     # the ramps
        ends = np.append(t[moved], scenario.duration)
        spans = np.concatenate([spans[spans > 0.0], np.diff(ends)])
    else:
        spans = np.diff(np.append(t[moved], scenario.duration))
    spans = spans[spans > 0.0]
    return float(round(spans.min(), 12)) if spans.size else None


def simulate(model, scenario, raise_on_error=True, t_out=None):
    """Simulate the actuator.

    Parameters
    ----------
    model : Model or dict
        The actuator (validated; see :class:`pneucore.description.model.Model`)
    scenario : Scenario or dict
        Command, duration, sampling, initial state; a dict is
        validated, a :class:`~pneucore.description.scenario.Scenario` is trusted as
        :meth:`~pneucore.description.scenario.Scenario.from_dict` built it and only checked against
        ``model`` (after editing a Scenario's fields, rebuild it with ``from_dict``)
    raise_on_error : bool
        Raise :class:`SimulationError` if the solver cannot proceed
        (the partial result is attached); else return the partial result with
        ``result.status`` set
    t_out : array_like or None
        Sample times [s], increasing, within [0, duration]
        (e.g. a measurement's irregular time base); None = every ``sample_period``

    Returns
    -------
    result : SimulationResult
        Sampled series, events and solver statistics; a scenario with ``start: cyclic``
        starts from :func:`cyclic_start`'s state, reported in ``stats["cyclic"]`` (``state``:
        ``p_a``, ``p_b`` [Pa abs], ``T_a``, ``T_b`` [K], ``x0`` [m], ``v0`` [m/s]; ``cycles``,
        ``residual``, ``converged``, ``tolerance``)

    Examples
    --------
    >>> from pneucore import simulate, model_preset, scenario_preset
    >>> res = simulate(model_preset("paper-4way"), scenario_preset("paper-fig10-pulses"))
    >>> res.p_a.shape
    (1001,)
    """
    cyclic = None
    if _start_of(scenario) == "cyclic":
        cyclic = cyclic_start(model, scenario)
        run = simulate_run(model, scenario, t_out, start=(cyclic["y0"], cyclic["mode0"]))
    else:
        run = simulate_run(model, scenario, t_out)
    res = run.result()
    if cyclic is not None:
        res.stats["cyclic"] = {k: cyclic[k] for k in ("state", "cycles", "residual", "converged",
                                                        "tolerance")}
        if not cyclic["converged"]:
            res.stats.setdefault("warnings", []).append(
                f"cyclic steady state not reached in {cyclic['cycles']} cycles: the last cycle's "
                f"end differs from its start by {cyclic['residual']} (SI units)")
    if run.status != OK and raise_on_error:
        raise SimulationError(f"simulation stopped at t = {run.t_reached:.6g} s: "
                              f"{STATUS_MESSAGES[run.status]}", res)
    return res


def _start_of(scenario):
    """The scenario's ``start`` (a dict's, or a Scenario's), ``given`` when absent."""
    if isinstance(scenario, Scenario):
        return scenario.start
    return scenario.get("start", "given") if isinstance(scenario, dict) else "given"


def checked_sample_times(t_out, duration):
    """``t_out`` as a new float array, checked: finite, increasing, within [0, ``duration``].

    Parameters
    ----------
    t_out : array_like
        Sample times [s]
    duration : float
        Simulated time [s]

    Returns
    -------
    t_out : ndarray
        The sample times (a copy) [s]; a time past ``duration`` by a rounding (relative 1e-12,
        e.g. ``1400 * 0.001 = 1.4000000000000001`` for 1.4 s) is set to ``duration``: the
        integrator stops there and would never write a sample after it
    """
    t_out = np.array(t_out, dtype=float)
    # 1e-12 relative: a time column built as n * dt is off by a few ulps (2.2e-16 each), far
    # below any sample period, and anything later is a real sample after the end
    if t_out.shape[0] == 0 or not np.all(np.isfinite(t_out)) \
            or np.any(np.diff(t_out) <= 0) or t_out[0] < 0 or t_out[-1] > duration * (1 + 1e-12):
        raise ValueError("t_out: sample times must be finite, increasing and within "
                         "[0, scenario.duration]")
    np.minimum(t_out, duration, out=t_out)
    if t_out.shape[0] > 1 and t_out[-2] >= t_out[-1]:
        # two samples within a rounding of the end: not increasing once the last is the end
        raise ValueError("t_out: the last two sample times are both at scenario.duration "
                         f"({duration:g} s) within a rounding")
    return t_out


#: The cyclic steady state's tolerances (:func:`cyclic_start`): the start and end of a cycle
#: agree within these. A pressure 1e-4 of the supply (70 Pa at 7 bar) changes the drive force
#: by about 1e-4 of its value, a gas temperature of 0.01 K the chamber's mass by 3e-5: the
#: next cycle's stroke times then move by well under 0.1 % (the test against 40 repeated
#: cycles checks it). Position: 1e-5 of the stroke; velocity 1e-4 m/s (at rest, in practice).
#: Every other state (wall temperatures, tube segments, spool): 1e-4 of its size plus 100 of
#: its integration tolerances
CYCLIC_P_TOL = 1e-4        # fraction of the supply pressure [-]
CYCLIC_T_TOL = 0.01        # [K]
CYCLIC_X_TOL = 1e-5        # fraction of the stroke [-]
CYCLIC_V_TOL = 1e-4        # [m/s]
CYCLIC_REL_TOL = 1e-4      # other states, relative [-]
#: Most cycles :func:`cyclic_start` repeats before it gives up (without wall heat capacity
#: the chambers' state repeats within a few cycles; a wall's thermal mass needs more) [-]
CYCLIC_MAX_CYCLES = 30
#: The base states compared with their own tolerances: mass, temperature A; B; x; v
_CYCLIC_BASE = 6


def cyclic_start(model, scenario, max_cycles=CYCLIC_MAX_CYCLES):
    """The cyclic steady state: the start state that a cycle of ``scenario`` brings back.

    One cycle is the scenario's command over ``[0, duration]``; it is repeated from the end
    state of the previous one (a fixed-point iteration: the machine left running) until
    the start and the end of a cycle agree within :data:`CYCLIC_P_TOL` (pressures),
    :data:`CYCLIC_T_TOL` (gas temperatures), :data:`CYCLIC_X_TOL` (position),
    :data:`CYCLIC_V_TOL` (velocity) and :data:`CYCLIC_REL_TOL` (every other state). The first
    cycle starts from the scenario's ``initial`` and ``x0``. Every state is carried over
    (wall temperatures, tube segments, spool position included).

    Parameters
    ----------
    model : Model or dict
        The actuator
    scenario : Scenario or dict
        The cycle: its command over ``duration`` is one period (put the first switching
        after t = 0 for the stroke metrics to time it: a change at t = 0 is the initial
        command, no event)
    max_cycles : int
        Most cycles repeated [-]

    Returns
    -------
    start : dict
        ``y0`` (the full state vector) and ``mode0`` (the core's friction mode) to start from;
        ``state``: ``p_a``, ``p_b`` [Pa abs], ``T_a``, ``T_b`` [K], ``x0`` [m], ``v0`` [m/s];
        ``cycles`` repeated [-]; ``residual``: the last cycle's end minus its start, ``p_a``,
        ``p_b`` [Pa], ``T_a``, ``T_b`` [K], ``x`` [m], ``v`` [m/s]; ``converged`` [-];
        ``tolerance``: the bounds it was held to (same keys and units)

    Raises
    ------
    SimulationError
        A cycle the solver could not finish
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    scenario = Scenario.from_dict(scenario, model)
    check_resolvable(model, scenario.solver.rtol, scenario.solver.max_step)
    core = build_core(model, scenario)
    eff = core["effective_model"]
    j, r = eff.jack, eff.gas.r
    tol = {"p_a": CYCLIC_P_TOL * eff.supply.pressure, "p_b": CYCLIC_P_TOL * eff.supply.pressure,
           "T_a": CYCLIC_T_TOL, "T_b": CYCLIC_T_TOL, "x": CYCLIC_X_TOL * j.stroke,
           "v": CYCLIC_V_TOL}
    t_out = np.array([0.0, scenario.duration])

    def chambers(y):
        V_a, V_b = j.volumes(min(max(y[4], 0.0), j.stroke))
        return {"p_a": y[0] * r * y[1] / V_a, "p_b": y[2] * r * y[3] / V_b, "T_a": y[1],
                "T_b": y[3], "x": y[4], "v": y[5]}

    y0, mode0 = core["y0"].copy(), core["mode0"]
    residual, converged, cycles = None, False, 0
    while cycles < max_cycles:
        run = simulate_run(model, scenario, t_out, start=(y0, mode0))
        cycles += 1
        if run.status != OK:
            raise SimulationError(f"cycle {cycles} of the cyclic steady state stopped at "
                                  f"t = {run.t_reached:.6g} s: {STATUS_MESSAGES[run.status]}",
                                  run.result())
        y1, mode1 = run.y_out[-1].copy(), int(run.mode_out[-1])
        a, b = chambers(y0), chambers(y1)
        residual = {k: float(b[k] - a[k]) for k in tol}
        extra = np.abs(y1[_CYCLIC_BASE:] - y0[_CYCLIC_BASE:])
        extra_tol = CYCLIC_REL_TOL * np.maximum(np.abs(y0[_CYCLIC_BASE:]), np.abs(y1[_CYCLIC_BASE:])) \
            + 100.0 * core["atol"][_CYCLIC_BASE:]
        y0, mode0 = y1, mode1
        if all(abs(residual[k]) <= tol[k] for k in tol) and bool(np.all(extra <= extra_tol)):
            converged = True
            break
    s = chambers(y0)
    return {"y0": y0, "mode0": mode0, "cycles": cycles, "residual": residual,
            "converged": converged, "tolerance": tol,
            "state": {"p_a": float(s["p_a"]), "p_b": float(s["p_b"]), "T_a": float(s["T_a"]),
                      "T_b": float(s["T_b"]), "x0": float(s["x"]), "v0": float(s["v"])}}


def output_times(scenario, t_out=None, checked=False):
    """The sample times of a run (open or closed loop): ``t = 0, T_s, 2 T_s, ...`` up to the
    scenario's duration, the last one at most the duration; or ``t_out`` checked
    (:func:`checked_sample_times`).

    Parameters
    ----------
    scenario : Scenario
        Its ``duration`` [s] and ``sample_period`` [s]
    t_out : array_like or None
        Sample times [s]; None = every ``sample_period``
    checked : bool
        ``t_out`` is already a checked float array for this duration: used as it is [-]

    Returns
    -------
    t_out : ndarray
        Sample times [s]
    """
    if t_out is None:
        n_out = output_samples(scenario.duration, scenario.sample_period)
        t_out = np.arange(n_out) * scenario.sample_period
        t_out[-1] = min(t_out[-1], scenario.duration)
        return t_out
    return t_out if checked else checked_sample_times(t_out, scenario.duration)


def output_buffers(n_out, n):
    """The core's output arrays for ``n_out`` samples of ``n`` states: ``y_out``, ``aux_out``,
    ``mode_out``, ``u_out``, filled with "not written" (NaN, mode -1), not left
    uninitialised: a sample the core does not reach reads as missing, never as memory's
    leftovers."""
    return (np.full((n_out, n), np.nan), np.full((n_out, L.N_AUX), np.nan),
            np.full(n_out, -1, np.int64), np.full(n_out, np.nan))


def mark_unreached(t_out, t_reached, y_out, aux_out, mode_out, u_out):
    """Samples after ``t_reached`` [s] (a run that stopped early) marked missing in place:
    the core never wrote them."""
    bad = t_out > t_reached
    y_out[bad] = np.nan
    aux_out[bad] = np.nan
    u_out[bad] = np.nan
    mode_out[bad] = -1


def simulate_run(model, scenario, t_out=None, checked_times=False, start=None):
    """:func:`simulate`'s work, its outputs not yet wrapped: a :class:`pneucore.result.CoreRun`
    (:meth:`~pneucore.result.CoreRun.result` gives the :class:`SimulationResult`; a solver failure
    is in its ``status``, never raised).

    Parameters
    ----------
    model : Model or dict
        The actuator (see :func:`simulate`)
    scenario : Scenario or dict
        Command, duration, sampling, initial state (see :func:`simulate`)
    t_out : array_like or None
        Sample times [s] (see :func:`simulate`)
    checked_times : bool
        ``t_out`` comes from :func:`checked_sample_times` for this scenario's duration (an
        experiment replayed many times checks its times once): used as it is, not copied [-]
    start : tuple or None
        ``(y0, mode0)``: the full state vector and friction mode to start from instead of the
        scenario's initial state (:func:`cyclic_start`'s); None = the scenario's

    Returns
    -------
    run : CoreRun
        The compiled core's outputs, with the inputs and the effects' warnings
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    if isinstance(scenario, Scenario):
        # built, hence validated, by Scenario.from_dict: only the checks that need this
        # model (validating the whole scenario again cost 5 ms for 800 breakpoints)
        scenario.check_against(model)
    else:
        scenario = Scenario.from_dict(scenario, model)
    check_resolvable(model, scenario.solver.rtol, scenario.solver.max_step)
    core = build_core(model, scenario)
    t_out = output_times(scenario, t_out, checked_times)
    n_out = t_out.shape[0]
    y_start, mode_start = (core["y0"], core["mode0"]) if start is None else \
        (np.asarray(start[0], float), int(start[1]))
    y_out, aux_out, mode_out, u_out = output_buffers(n_out, core["y0"].shape[0])
    max_ev = scenario.solver.max_events
    cmd = np.asarray(scenario.command, float)
    valve = core["effective_model"].valve
    signal_times = None
    if valve.on_time > 0.0 or valve.off_time > 0.0:
        # the spool shifts its switching time after each command change (catalogue on/off times)
        cmd, signal_times = switched_command(cmd, valve.on_time, valve.off_time,
                                             valve.rest_opening)
    # the event log starts small and is redone once with the exact size if it overflows
    cap = min(max_ev, 256 + 4 * len(cmd))
    run = core_for(core["hook"], core["flow_laws"], core["friction_laws"],
                   has_lines(core["model"]))
    while True:
        ev_t = np.full((cap, 2), np.nan)    # time [s], impact velocity of a stop [m/s]
        ev_kind = np.empty(cap, np.int64)
        ev_mode = np.empty(cap, np.int64)
        stats = np.zeros(N_STATS, np.int64)
        status, n_ev, t_reached = run(
            y_start, mode_start, core["model"], cmd[:, 0].copy(),
            cmd[:, 1].copy(), scenario.command_interpolation == "linear", scenario.duration, t_out,
            scenario.solver.rtol, core["atol"], scenario.solver.max_step, 1e-6,
            scenario.solver.max_steps, y_out, aux_out, mode_out, u_out, ev_t, ev_kind, ev_mode, stats)
        if status == ERR_EVENTS_OVERFLOW and cap < max_ev:
            cap = max_ev
            continue
        break
    n_ev = min(n_ev, cap)
    if status == OK and n_out and mode_out[-1] < 0:
        # every sample lies in [0, duration] (checked above): one left unwritten by a run that
        # reached the end is a bug, not a missing sample to show blank
        raise RuntimeError(f"simulate: {int((mode_out < 0).sum())} sample(s) not written, the "
                           f"last at t = {t_out[-1]!r} s of a {scenario.duration!r} s run")
    if signal_times is not None and n_ev:
        ev_t, ev_kind, ev_mode = _signal_command_events(ev_t[:n_ev], ev_kind[:n_ev],
                                                        ev_mode[:n_ev], cmd[:, 0], signal_times)
    if status != OK:
        mark_unreached(t_out, t_reached, y_out, aux_out, mode_out, u_out)
    # only an effect that can warn needs the command's time scale (a scan of the command)
    time_scale = (command_time_scale(scenario)
                  if any(EFFECTS[n].warn is not None for n in model.effects) else None)
    warnings = [] if time_scale is None else effect_warnings(model, time_scale)
    return CoreRun(model, scenario, core, t_out, y_out, aux_out, mode_out, u_out, ev_t[:n_ev],
                   ev_kind[:n_ev], ev_mode[:n_ev], stats, status, t_reached, warnings)


def _signal_command_events(ev_t, ev_kind, ev_mode, spool_t, signal_t):
    """The ``command`` events at the command signal's times (what SMC's stroke times count
    from), not at the spool's shift a switching time later; the events re-sorted by time."""
    ev_t = ev_t.copy()
    for i in np.flatnonzero(ev_kind == L.EV_COMMAND):
        j = int(np.argmin(np.abs(spool_t - ev_t[i, 0])))
        # the core logs the event at the breakpoint's own time (a float equal, or within
        # its step's rounding)
        if abs(spool_t[j] - ev_t[i, 0]) <= 1e-9 * max(1.0, abs(spool_t[j])):
            ev_t[i, 0] = signal_t[j]
    order = np.argsort(ev_t[:, 0], kind="stable")
    return ev_t[order], ev_kind[order], ev_mode[order]


def warm_up():
    """Compile the core, or load it from numba's on-disk cache, with one short simulation.

    Meant for a background thread at a service's start (``app.main``): the
    first compile takes seconds, and a user's first request then finds it done
    or in progress. numba serialises compilation, so a :func:`simulate` called
    meanwhile waits for this one instead of compiling again.

    Returns
    -------
    seconds : float
        Wall time taken [s]
    """
    from pneucore.description.presets import model_preset, scenario_preset
    t0 = time.perf_counter()
    scenario = scenario_preset("paper-fig10-pulses")
    scenario.update(duration=0.01, sample_period=0.001)
    simulate(model_preset("paper-4way"), scenario)
    return time.perf_counter() - t0


def start_warm_up():
    """Run :func:`warm_up` in a daemon thread, unless the core is already compiled here.

    Returns
    -------
    thread : threading.Thread or None
        The started thread (None when nothing to do)
    """
    if integrate.overloads:
        return None
    thread = threading.Thread(target=warm_up, name="pneucore-warm-up", daemon=True)
    thread.start()
    return thread
