"""Independent numpy/scipy implementation of pneucore's base actuator model.

Why this module exists
----------------------
1. **Speed baseline.** It is what a careful engineer would write without a
   compiled core: the same equations in plain Python, integrated by
   :func:`scipy.integrate.solve_ivp` (LSODA by default). ``bench_simulator.py``
   times it against :func:`pneucore.simulate` at matched accuracy.
2. **Independent cross-check.** It is written from the equations of Maré,
   Geider & Colin (and pneucore's documented conventions), not from
   pneucore's compiled functions, and it uses a *different formulation*:
   the chamber states are pressure and temperature ``(p, T)`` instead of
   pneucore's mass and temperature ``(m, T)``, the integrator is a different
   family (BDF/Adams LSODA or Radau IIA instead of RODAS4), and the events
   are located by scipy's event machinery instead of pneucore's Illinois
   search on a Hermite interpolant. Agreement between the two therefore
   tests the algebra, the event logic and the error control of both.
   ``tests/core/test_cross_solver.py`` runs it at tight tolerance as a reference.

Only :class:`pneucore.Model` (``Model.from_dict``) is used, to validate the
input dict and read geometry helpers (``Jack.area_a`` ...). Effects are not
supported: the model must be the base model (``effects == {}``).

Equations (SI units, absolute pressures)
----------------------------------------
Valve edges (ISO 6358, paper Eq. 4-5), mass flow from the high-pressure
side ``u`` to the low-pressure side ``d`` with ratio ``r = p_d / p_u``::

    q = C rho0 p_u sqrt(T0 / T_u) phi(r),   rho0 = 1.185 kg/m^3, T0 = 293.15 K
    phi = 1 (r <= b),   phi = [1 - ((r - b) / (1 - b))^2]^m (r > b)
    above r_lam (0.999): phi = phi(r_lam) (1 - r) / (1 - r_lam)   (laminar linearisation)

C, b, m are interpolated linearly in the spool opening u, ends held
(``Saint-Venant`` flow law also provided). 4/2 valve: edges P-A, A-R, P-B,
B-R. 3/2 valve: P-A, A-R; chamber B held at ``b_chamber_pressure`` (default
supply / 2) and ambient temperature.

Chamber (mass and energy, paper Eq. 14-15 and 22-24), written on ``(p, T)``
with ``p V = m r T``, net mass flow in ``q``, enthalpy flow in
``H = cp sum(q_in T_up) - cp q_out T`` and wall heat ``Q = h S (T_amb - T)``::

    dp/dt = [(gamma - 1)(H + Q) - gamma p dV/dt] / V
    dT/dt = r T [H - cv T q - p dV/dt + Q] / (p V cv)
    isothermal: dT/dt = 0, dp/dt = (r T q - p dV/dt) / V
    adiabatic: h = 0;  S = pi (bore + rod) V / A + 2 A  (or the wall-area override)

Jack: ``V_a = A_a x + V0_a``, ``V_b = A_b (stroke - x) + V0_b``, net force
towards +x ``F = p_a A_a - p_b A_b + p_atm (A_rod_a - A_rod_b) - load``.

Friction (Eq. 18-20): sliding ``F_f = Kv v + Fc sign(v)`` with
``Fc = max(0, fc0 + fc_a (p_a - p_atm) + fc_b (p_b - p_atm))`` and ``Kv``
alike, the ``extend`` set for v > 0 and ``retract`` for v < 0.

Piston modes and their switching (terminal ``solve_ivp`` events, the
integration restarts in the new mode):

* stick: ``x, v`` frozen; slips towards +x when ``F > Fc_extend`` and
  towards -x when ``-F > Fc_retract``;
* slide+ / slide-: ``M dv/dt = F - F_f``; when ``v`` reaches 0 the piston
  reverses if the net force exceeds the opposite static limit, else sticks;
  reaching ``x = stroke`` (resp. 0) is an inelastic stop;
* stop@0 / stop@stroke: held at the end until the force pulls it away;
* locked (chamber tests): ``x = x0, v = 0`` throughout.

Command breakpoints are handled by restarting the integration at each
breakpoint (hold or linear interpolation between breakpoints).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from pneucore import Model

__all__ = ["simulate_scipy", "eq25_error", "MODE_DETAIL"]

# ISO 6358 / ISO 8778 reference conditions (the standard's values)
RHO0 = 1.185      # kg/m^3
T0 = 293.15       # K

STICK, SLIDE_POS, SLIDE_NEG, STOP_LOW, STOP_HIGH, LOCKED = range(6)
#: Mode names as pneucore logs them in ``result.events[i]["mode"]``
MODE_DETAIL = ("stick", "slide+", "slide-", "stop@0", "stop@stroke", "locked")
_RESTING = (STICK, STOP_LOW, STOP_HIGH)
_EDGES = ("P-A", "A-R", "P-B", "B-R")


def eq25_error(a, b):
    """Paper Eq. 25: ``sqrt(sum (a - b)^2 / sum b^2)``, ``b`` being the reference.

    Returns 0 when both series are identically zero (e.g. a locked piston's
    velocity), ``inf`` when only the reference is.
    """
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    num = float(np.sum((a - b) ** 2))
    den = float(np.sum(b ** 2))
    if den == 0.0:
        return 0.0 if num == 0.0 else math.inf
    return math.sqrt(num / den)


# ----------------------------------------------------------------------------
# flow laws: mass flow [kg/s] from the upstream (higher-pressure) side, ratio <= 1
# ----------------------------------------------------------------------------
def _phi_iso(ratio, b, m):
    if ratio <= b:
        return 1.0
    z = (ratio - b) / (1.0 - b)
    w = 1.0 - z * z
    return w ** m if w > 0.0 else 0.0


def _phi_sv(ratio, gamma):
    crit = (2.0 / (gamma + 1.0)) ** (gamma / (gamma - 1.0))
    if ratio <= crit:
        return 1.0
    sub = 2.0 * gamma / (gamma - 1.0) * (ratio ** (2.0 / gamma) - ratio ** ((gamma + 1.0) / gamma))
    son = gamma * (2.0 / (gamma + 1.0)) ** ((gamma + 1.0) / (gamma - 1.0))
    return math.sqrt(sub / son) if sub > 0.0 else 0.0


class _Actuator:
    """Parameters and right-hand side of the base model, states ``(p_a, T_a, p_b, T_b, x, v)``."""

    def __init__(self, model: Model):
        if model.effects:
            raise ValueError("simulate_scipy implements the base model only; "
                             f"remove model.effects {sorted(model.effects)}")
        j = model.jack
        self.r = r = model.gas.r
        self.gamma = g = model.gas.gamma
        self.cv = r / (g - 1.0)
        self.cp = g * r / (g - 1.0)
        self.p_sup, self.T_sup = model.supply.pressure, model.supply.temperature
        self.p_atm, self.T_atm = model.ambient.pressure, model.ambient.temperature
        self.A_a, self.A_b = j.area_a, j.area_b
        self.Ar_a, self.Ar_b = j.rod_area_a, j.rod_area_b
        self.stroke = j.stroke
        self.V0_a, self.V0_b = j.dead_volume_a, j.dead_volume_b
        self.mass = j.moving_mass
        self.load = j.load_force
        self.bore, self.rod_a, self.rod_b = j.bore, j.rod_a, j.rod_b
        self.S_a, self.S_b = j.wall_area_a, j.wall_area_b
        heat = model.heat.model
        self.isothermal = heat == "isothermal"
        self.h = model.heat.coefficient if heat == "convective" else 0.0
        fe, fr = model.friction.extend, model.friction.retract
        self.fe = (fe.fc0, fe.fc_a, fe.fc_b, fe.kv0, fe.kv_a, fe.kv_b)
        self.fr = (fr.fc0, fr.fc_a, fr.fc_b, fr.kv0, fr.kv_a, fr.kv_b)
        v = model.valve
        self.three_way = v.kind == "3/2"
        self.p_b_const = (v.b_chamber_pressure if v.b_chamber_pressure is not None
                          else 0.5 * self.p_sup) if self.three_way else None
        self.r_lam = v.laminar_ratio
        self.law = v.flow_law
        self.tables = []
        for name in _EDGES:
            port = v.ports.get(name)
            if port is None:
                self.tables.append(None)
            else:
                o = np.asarray(port.opening, float)
                m = np.asarray(port.m if port.m is not None else [0.5] * len(o), float)
                self.tables.append((o, np.asarray(port.C, float), np.asarray(port.b, float), m))
        if self.law == "saint_venant":
            k = g * (2.0 / (g + 1.0)) ** ((g + 1.0) / (g - 1.0))
            # nozzle area with the same choked flow as C (Eq. 2 = Eq. 5)
            self._sv_area_per_C = RHO0 * math.sqrt(r * T0) / math.sqrt(k)
            self._sv_k = k

    # -- valve ------------------------------------------------------------------
    def edge_coefficients(self, u):
        """(C, b, m) of the four edges at opening ``u`` (closed edge: C = 0)."""
        out = []
        for tab in self.tables:
            if tab is None:
                out.append((0.0, 0.5, 0.5))
            else:
                o, C, b, m = tab
                out.append((float(np.interp(u, o, C)), float(np.interp(u, o, b)),
                            float(np.interp(u, o, m))))
        return out

    def flow(self, p1, T1, p2, T2, C, b, m):
        """Mass flow from node 1 to node 2 [kg/s] (negative when 2 is upstream)."""
        if C <= 0.0 or p1 == p2:
            return 0.0
        if p1 > p2:
            pu, Tu, ratio, sign = p1, T1, p2 / p1, 1.0
        else:
            pu, Tu, ratio, sign = p2, T2, p1 / p2, -1.0
        rl = self.r_lam
        if self.law == "saint_venant":
            g = self.gamma
            phi = _phi_sv(ratio, g) if ratio <= rl else _phi_sv(rl, g) * (1.0 - ratio) / (1.0 - rl)
            s = C * self._sv_area_per_C
            return sign * s * pu * math.sqrt(self._sv_k / (self.r * Tu)) * phi
        phi = _phi_iso(ratio, b, m) if ratio <= rl else _phi_iso(rl, b, m) * (1.0 - ratio) / (1.0 - rl)
        return sign * C * RHO0 * pu * math.sqrt(T0 / Tu) * phi

    # -- forces -----------------------------------------------------------------
    def net_force(self, p_a, p_b):
        return (p_a * self.A_a - p_b * self.A_b + self.p_atm * (self.Ar_a - self.Ar_b) - self.load)

    def coulomb(self, fs, p_a, p_b):
        f = fs[0] + fs[1] * (p_a - self.p_atm) + fs[2] * (p_b - self.p_atm)
        return f if f > 0.0 else 0.0

    def viscous(self, fs, p_a, p_b):
        k = fs[3] + fs[4] * (p_a - self.p_atm) + fs[5] * (p_b - self.p_atm)
        return k if k > 0.0 else 0.0

    def pressures(self, y):
        p_b = self.p_b_const if self.three_way else y[2]
        return y[0], p_b

    # -- right-hand side ----------------------------------------------------------
    def rhs(self, t, y, mode, coeffs):
        p_a, T_a, p_b, T_b, x, v = y[0], y[1], y[2], y[3], y[4], y[5]
        if mode != SLIDE_POS and mode != SLIDE_NEG:
            v = 0.0
        if self.three_way:
            p_b, T_b = self.p_b_const, self.T_atm
        A_a, A_b = self.A_a, self.A_b
        V_a = A_a * x + self.V0_a
        V_b = A_b * (self.stroke - x) + self.V0_b
        (Cpa, bpa, mpa), (Car, bar, mar), (Cpb, bpb, mpb), (Cbr, bbr, mbr) = coeffs
        p_s, T_s, p0, Tatm, cp = self.p_sup, self.T_sup, self.p_atm, self.T_atm, self.cp
        f = self.flow
        q_pa = f(p_s, T_s, p_a, T_a, Cpa, bpa, mpa)
        q_ar = f(p_a, T_a, p0, Tatm, Car, bar, mar)
        q_a = q_pa - q_ar
        H_a = cp * q_pa * (T_s if q_pa > 0.0 else T_a) + cp * (-q_ar) * (Tatm if q_ar < 0.0 else T_a)
        dp_a, dT_a = self._chamber(p_a, T_a, V_a, A_a * v, q_a, H_a, A_a, self.rod_a, self.S_a)
        if self.three_way:
            dp_b = dT_b = 0.0
        else:
            q_pb = f(p_s, T_s, p_b, T_b, Cpb, bpb, mpb)
            q_br = f(p_b, T_b, p0, Tatm, Cbr, bbr, mbr)
            q_b = q_pb - q_br
            H_b = cp * q_pb * (T_s if q_pb > 0.0 else T_b) + cp * (-q_br) * (Tatm if q_br < 0.0 else T_b)
            dp_b, dT_b = self._chamber(p_b, T_b, V_b, -A_b * v, q_b, H_b, A_b, self.rod_b, self.S_b)
        if mode == SLIDE_POS:
            F = self.net_force(p_a, p_b)
            acc = (F - self.viscous(self.fe, p_a, p_b) * v - self.coulomb(self.fe, p_a, p_b)) / self.mass
            return [dp_a, dT_a, dp_b, dT_b, v, acc]
        if mode == SLIDE_NEG:
            F = self.net_force(p_a, p_b)
            acc = (F - self.viscous(self.fr, p_a, p_b) * v + self.coulomb(self.fr, p_a, p_b)) / self.mass
            return [dp_a, dT_a, dp_b, dT_b, v, acc]
        return [dp_a, dT_a, dp_b, dT_b, 0.0, 0.0]

    def _chamber(self, p, T, V, dV, q, H, A, rod, S_override):
        if self.isothermal:
            return (self.r * T * q - p * dV) / V, 0.0
        S = S_override if S_override else math.pi * (self.bore + rod) * V / A + 2.0 * A
        Q = self.h * S * (self.T_atm - T)
        g = self.gamma
        dp = ((g - 1.0) * (H + Q) - g * p * dV) / V
        dT = self.r * T * (H - self.cv * T * q - p * dV + Q) / (p * V * self.cv)
        return dp, dT

    # -- mode switching -------------------------------------------------------------
    def event_functions(self, mode):
        """Event functions of ``mode``; each fires when it crosses zero upwards."""
        fe, fr, stroke = self.fe, self.fr, self.stroke

        def release_pos(t, y):
            p_a, p_b = self.pressures(y)
            return self.net_force(p_a, p_b) - self.coulomb(fe, p_a, p_b)

        def release_neg(t, y):
            p_a, p_b = self.pressures(y)
            return -self.net_force(p_a, p_b) - self.coulomb(fr, p_a, p_b)

        def v_zero_pos(t, y):
            return -y[5]

        def v_zero_neg(t, y):
            return y[5]

        def stop_high(t, y):
            return y[4] - stroke

        def stop_low(t, y):
            return -y[4]

        table = {STICK: [(release_pos, "slip", SLIDE_POS), (release_neg, "slip", SLIDE_NEG)],
                 STOP_LOW: [(release_pos, "slip", SLIDE_POS)],
                 STOP_HIGH: [(release_neg, "slip", SLIDE_NEG)],
                 SLIDE_POS: [(v_zero_pos, "vzero", None), (stop_high, "stop", STOP_HIGH)],
                 SLIDE_NEG: [(v_zero_neg, "vzero", None), (stop_low, "stop", STOP_LOW)],
                 LOCKED: []}
        evs = table[mode]
        for fn, _, _ in evs:
            fn.terminal = True
            fn.direction = 1.0
        return evs

    def release(self, mode, y):
        """Mode a resting piston moves into at state ``y`` (``mode`` itself if it stays)."""
        if mode not in _RESTING:
            return mode
        p_a, p_b = self.pressures(y)
        F = self.net_force(p_a, p_b)
        if mode in (STICK, STOP_LOW) and F > self.coulomb(self.fe, p_a, p_b):
            return SLIDE_POS
        if mode in (STICK, STOP_HIGH) and -F > self.coulomb(self.fr, p_a, p_b):
            return SLIDE_NEG
        return mode

    def after_zero_velocity(self, mode, y):
        """Velocity reached zero while sliding: reverse or stick."""
        p_a, p_b = self.pressures(y)
        F = self.net_force(p_a, p_b)
        if mode == SLIDE_POS and -F > self.coulomb(self.fr, p_a, p_b):
            return SLIDE_NEG, "reverse"
        if mode == SLIDE_NEG and F > self.coulomb(self.fe, p_a, p_b):
            return SLIDE_POS, "reverse"
        return STICK, "stick"


def _scenario(d):
    """Scenario fields with pneucore's defaults (plain dict in, plain values out)."""
    ini = d.get("initial") or {}
    cmd = [(float(t), float(u)) for t, u in d.get("command", [[0.0, 0.0]])]
    return {"duration": float(d.get("duration", 1.0)),
            "sample_period": float(d.get("sample_period", 1e-3)),
            "command": cmd, "linear": d.get("command_interpolation", "hold") == "linear",
            "locked": bool(d.get("locked", False)), "x0": float(d.get("x0", 0.05)),
            "initial": {k: ini.get(k) for k in ("p_a", "p_b", "T_a", "T_b")}}


def _command_piece(t, cmd, linear):
    """(u at t, slope) of the command piece starting at ``t`` (hold: slope 0)."""
    times = [c[0] for c in cmd]
    if t < times[0]:
        return cmd[0][1], 0.0
    k = max(i for i, tk in enumerate(times) if tk <= t)
    if k + 1 >= len(cmd) or not linear:
        return cmd[k][1], 0.0
    (ta, ua), (tb, ub) = cmd[k], cmd[k + 1]
    slope = (ub - ua) / (tb - ta)
    return ua + slope * (t - ta), slope


def _default_atol(act, rtol):
    # absolute floors: 1 % of ambient pressure, ambient temperature, stroke, 0.1 m/s
    return rtol * np.array([0.01 * act.p_atm, act.T_atm, 0.01 * act.p_atm, act.T_atm,
                            act.stroke, 0.1])


def simulate_scipy(model_dict, scenario_dict, method="LSODA", rtol=1e-8, atol=None,
                   max_step=0.01, return_events=True):
    """Simulate the base actuator model with ``scipy.integrate.solve_ivp``.

    Parameters
    ----------
    model_dict : dict  Model as for :func:`pneucore.simulate` (no effects)
    scenario_dict : dict  Scenario as for :func:`pneucore.simulate` (its ``solver`` block is ignored)
    method : str  ``solve_ivp`` method; a stiff one (``LSODA``, ``Radau``, ``BDF``)
    rtol : float  Relative tolerance
    atol : float or array of 6 or None  Absolute tolerance on ``(p_a, T_a, p_b, T_b, x, v)``;
        None = ``rtol`` times (0.01 p_atm, T_atm, 0.01 p_atm, T_atm, stroke, 0.1 m/s)
    max_step : float  Largest step [s] (keeps brief event-function excursions visible)

    Returns
    -------
    out : dict  Arrays ``t, u, p_a, p_b, T_a, T_b, x, v, mode`` on the scenario's
        sample grid, plus ``events`` (list of ``{"t", "kind", "mode"}`` as pneucore
        logs them) and ``nfev`` (right-hand-side evaluations).
    """
    model = Model.from_dict(model_dict)
    act = _Actuator(model)
    sc = _scenario(scenario_dict)
    T_amb, p_atm = act.T_atm, act.p_atm
    dur = sc["duration"]
    n_out = int(math.floor(dur / sc["sample_period"] + 1e-9)) + 1
    t_out = np.arange(n_out) * sc["sample_period"]
    t_out[-1] = min(t_out[-1], dur)
    Y = np.full((n_out, 6), np.nan)
    U = np.full(n_out, np.nan)
    M = np.full(n_out, -1, int)
    if atol is None:
        atol = _default_atol(act, rtol)

    # initial state
    ini = sc["initial"]
    x0 = min(max(sc["x0"], 0.0), act.stroke)
    p_a = ini["p_a"] if ini["p_a"] is not None else p_atm
    T_a = T_amb if act.isothermal or ini["T_a"] is None else ini["T_a"]
    if act.three_way:
        p_b, T_b = act.p_b_const, T_amb
    else:
        p_b = ini["p_b"] if ini["p_b"] is not None else p_atm
        T_b = T_amb if act.isothermal or ini["T_b"] is None else ini["T_b"]
    y = np.array([p_a, T_a, p_b, T_b, x0, 0.0])
    if sc["locked"]:
        mode = LOCKED
    elif x0 <= 0.0:
        mode = STOP_LOW
    elif x0 >= act.stroke:
        mode = STOP_HIGH
    else:
        mode = STICK

    cmd = sorted(sc["command"], key=lambda c: c[0])   # stable: equal times keep their order
    bounds = sorted({0.0, dur} | {t for t, _ in cmd if 0.0 < t < dur})
    events = []
    nfev = 0
    k_out = 0
    t = 0.0
    u_prev = None

    def take_samples(t_hi, fn, mode, u0, slope, ta, inclusive=False):
        # samples in [current, t_hi) (or up to t_hi inclusive), from the dense output at once
        nonlocal k_out
        k_hi = int(np.searchsorted(t_out, t_hi, side="right" if inclusive else "left"))
        if k_hi > k_out:
            ts = t_out[k_out:k_hi]
            Y[k_out:k_hi] = np.asarray(fn(ts)).T
            U[k_out:k_hi] = u0 + slope * (ts - ta)
            M[k_out:k_hi] = mode
            k_out = k_hi

    for ta, tb in zip(bounds[:-1], bounds[1:]):
        u0, slope = _command_piece(ta, cmd, sc["linear"])
        if u_prev is not None and u0 != u_prev:
            events.append({"t": ta, "kind": "command", "mode": MODE_DETAIL[mode]})
        if slope == 0.0:
            const = act.edge_coefficients(u0)
            coeffs_at = lambda tt, c=const: c                        # noqa: E731
        else:
            coeffs_at = lambda tt, u0=u0, s=slope, ta=ta: act.edge_coefficients(u0 + s * (tt - ta))  # noqa: E731
        new = act.release(mode, y)
        if new != mode:
            y[5] = 0.0
            mode = new
            events.append({"t": t, "kind": "slip", "mode": MODE_DETAIL[mode]})
        n_restart = 0
        while t < tb:
            evs = act.event_functions(mode)

            def fun(tt, yy, mode=mode):
                return act.rhs(tt, yy, mode, coeffs_at(tt))

            if tb - t <= 1e-13 * max(1.0, tb):
                t = tb
                break
            sol = solve_ivp(fun, (t, tb), y, method=method, rtol=rtol, atol=atol,
                            max_step=max_step, dense_output=True,
                            events=[e[0] for e in evs] or None)
            nfev += sol.nfev
            if sol.status < 0:
                raise RuntimeError(f"solve_ivp failed at t = {sol.t[-1]:.6g} s: {sol.message}")
            if sol.status == 1:
                # earliest terminal event
                k, t_ev = min(((i, te[0]) for i, te in enumerate(sol.t_events) if len(te)),
                              key=lambda p: p[1])
                fn, kind, target = evs[k]
                # take the root on its far side (g > 0), so the new mode starts
                # consistently (e.g. a slip with non-negative acceleration)
                d = 1e-15 * max(1.0, t_ev)
                while fn(t_ev, sol.sol(t_ev)) <= 0.0 and d < 1e-9:
                    t_ev += d
                    d *= 2.0
                take_samples(t_ev, sol.sol, mode, u0, slope, ta)
                y = np.array(sol.sol(t_ev), float)
                t = float(t_ev)
                if kind == "slip":
                    y[5] = 0.0
                    mode = target
                elif kind == "stop":
                    y[5] = 0.0
                    y[4] = act.stroke if target == STOP_HIGH else 0.0
                    mode = target
                    events.append({"t": t, "kind": "stop", "mode": MODE_DETAIL[mode]})
                    new = act.release(mode, y)
                    if new != mode:
                        mode, kind = new, "slip"
                else:
                    y[5] = 0.0
                    mode, kind = act.after_zero_velocity(mode, y)
                if kind != "stop":
                    events.append({"t": t, "kind": kind, "mode": MODE_DETAIL[mode]})
                n_restart += 1
                if n_restart > 100000:
                    raise RuntimeError("stick/slip chattering in the scipy reference")
                continue
            take_samples(tb, sol.sol, mode, u0, slope, ta, inclusive=tb >= dur)
            y = np.array(sol.y[:, -1], float)
            t = tb
        u_prev = u0 + slope * (tb - ta)
    # anything left (e.g. the last sample at the very end)
    while k_out < n_out:
        Y[k_out] = y
        U[k_out] = u_prev
        M[k_out] = mode
        k_out += 1

    if act.three_way:
        Y[:, 2] = act.p_b_const
        Y[:, 3] = T_amb
    out = {"t": t_out, "u": U, "p_a": Y[:, 0], "T_a": Y[:, 1], "p_b": Y[:, 2], "T_b": Y[:, 3],
           "x": Y[:, 4], "v": np.where(np.isin(M, (SLIDE_POS, SLIDE_NEG)), Y[:, 5], 0.0),
           "mode": np.array([MODE_DETAIL[m] for m in M]), "nfev": nfev}
    if return_events:
        out["events"] = events
    return out


if __name__ == "__main__":   # quick look: python benchmarks/scipy_reference.py
    import time

    from pneucore import model_preset, scenario_preset

    t0 = time.perf_counter()
    res = simulate_scipy(model_preset("paper-4way"), scenario_preset("paper-fig10-pulses"))
    print(f"{time.perf_counter() - t0:.3f} s, {res['nfev']} rhs evaluations")
    for e in res["events"]:
        print(e)
