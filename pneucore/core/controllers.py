"""Compiled controller laws of the closed loop (issue 42): evaluated by the integrator at each
sample instant ``t_k = k T_s`` (:func:`pneucore.core.integrator.integrate_closed`), their output
held until the next (zero-order hold). No Python runs on this path.

A law reads the measured signals ``meas`` (``MEAS_*`` slots: position [m] as the position
sensor reports it, velocity [m/s] and acceleration [m/s^2] estimated from that position
(:func:`pneucore.physics.sensors.estimate_rates`), chamber pressures [Pa abs] as the pressure
transducers report them, the areas [m^2]), the reference ``(x_ref [m], v_ref [m/s], a_ref [m/s^2])`` at ``t_k``, its
gains ``g`` (``G_*`` slots of each kind, SI) and its memory ``cst`` (``CST_*``), and returns the
valve command, clipped to the valve's range ``[u_lo, u_hi]``.

The laws (codes ``CTL_*``; names, gains and checks in :mod:`pneucore.control.controllers`):

* PID with a first-order filtered derivative and anti-windup by conditional integration
  (the integral is frozen while the output saturates in the direction of the error), and an
  optional dead band on the error (inside it the valve is centred and the integral frozen);
* sliding mode with a boundary layer: ``s = (v_ref - v) + lambda (x_ref - x)``,
  ``u = k sat(s / phi)`` (the variable structure control the paper's conclusion cites for its
  position controllers, made continuous in a layer of width ``phi`` against chattering);
* on/off with a dead band: full opening ``level`` towards the error outside ``+-deadband``,
  the valve centred inside (three positions of a 4/2 valve; a 3/2 valve: supply or exhaust);
* PVA state feedback with feedforward: ``u = kp e + kv (v_ref - v) + ka (a_ref - a)
  + ff_v v_ref + ff_a a_ref``;
* force loop: a pressure-difference (force) inner loop under a PD position loop,
  ``F_ref = kx e + kd (v_ref - v)``, ``u = kf (F_ref - (p_a A_a - p_b A_b))``;
* PWM of an on/off valve: at the start of each PWM period (a whole number of samples) the
  duty ``min(kp |e|, 1)`` towards the error (zero inside the dead band); the valve at
  ``level`` for that share of the period's samples, centred for the rest.
"""
import math

from numba import njit

CTL_PID, CTL_SLIDING, CTL_ONOFF, CTL_PVA, CTL_FORCE, CTL_USER, CTL_PWM = range(7)

# measured signals
MEAS_X, MEAS_V, MEAS_A, MEAS_PA, MEAS_PB, MEAS_AA, MEAS_AB, MEAS_T = range(8)
N_MEAS = 8

# controller memory: integral [m s], previous error [m], filtered derivative [-], last
# output [-], valve switchings [-] (changes of the sign of the output), started flag
CST_INT, CST_EPREV, CST_DFILT, CST_ULAST, CST_SWITCHES, CST_STARTED, CST_PWM_K, \
    CST_PWM_DUTY = range(8)
N_CST = 16
#: First memory slot free for a user's law (slots CST_USER0 .. N_CST - 1)
CST_USER0 = 8

# gains of each kind (slots in ``g``)
G_KP, G_KI, G_KD, G_TF, G_DEADBAND, G_KFF = range(6)                 # pid
G_LAMBDA, G_K, G_PHI = range(3)                                       # sliding mode
G_OO_DEADBAND, G_LEVEL = range(2)                                     # on/off
G_PVA_KP, G_PVA_KV, G_PVA_KA, G_FFV, G_FFA = range(5)                 # pva
G_KX, G_FKD, G_KF = range(3)                                          # force loop
G_PWM_KP, G_PWM_PERIOD, G_PWM_DEADBAND, G_PWM_LEVEL = range(4)        # pwm
N_GAINS = 8


@njit(cache=True, error_model="numpy", _nrt=False)
def _clip(u, lo, hi):
    return lo if u < lo else (hi if u > hi else u)


@njit(cache=True, error_model="numpy", _nrt=False)
def user_law(g, x_ref, v_ref, a_ref, meas, cst, Ts, u_lo, u_hi):
    """The user law slot (``CTL_USER``): the valve's centre. A user's controller
    (:func:`pneucore.control.controllers.register_user_controller`) runs in a core compiled
    with this name bound to its own law (:func:`pneucore.core.integrator.closed_core_with_law`),
    same signature: gains, reference [m, m/s, m/s^2], measured signals (``MEAS_*``), memory
    (slots from ``CST_USER0`` free), sample period [s], valve range [-]; returns the command."""
    return 0.5 * (u_lo + u_hi)


@njit(cache=True, error_model="numpy", _nrt=False)
def control_law(code, g, x_ref, v_ref, a_ref, meas, cst, Ts, u_lo, u_hi):
    """Valve command [-] of controller ``code`` at one sample instant (see the module).

    Parameters
    ----------
    code : int
        ``CTL_*``
    g : ndarray
        Gains (``G_*`` slots of the kind), SI
    x_ref, v_ref, a_ref : float
        Reference position [m], velocity [m/s], acceleration [m/s^2]
    meas : ndarray
        Measured signals (``MEAS_*``)
    cst : ndarray
        Controller memory (``CST_*``), updated
    Ts : float
        Sample period [s]
    u_lo, u_hi : float
        Valve command range [-]

    Returns
    -------
    u : float
        Valve command, held to the next sample [-]
    """
    x = meas[MEAS_X]
    v = meas[MEAS_V]
    e = x_ref - x
    mid = 0.5 * (u_lo + u_hi)
    half = 0.5 * (u_hi - u_lo)
    if code == CTL_PID:
        if cst[CST_STARTED] == 0.0:
            cst[CST_EPREV] = e
        db = g[G_DEADBAND]
        if abs(e) <= db:
            # inside the dead band: valve centred, integral frozen, derivative state kept
            cst[CST_EPREV] = e
            u = mid
        else:
            tf = g[G_TF]
            cst[CST_DFILT] = (tf * cst[CST_DFILT] + g[G_KD] * (e - cst[CST_EPREV])) / (tf + Ts)
            cst[CST_EPREV] = e
            u_free = g[G_KP] * e + g[G_KI] * cst[CST_INT] + cst[CST_DFILT] + g[G_KFF] * v_ref
            # conditional integration: not while saturated in the direction of the error
            if not ((u_free >= u_hi and e > 0.0) or (u_free <= u_lo and e < 0.0)):
                cst[CST_INT] += e * Ts
            u = mid + g[G_KP] * e + g[G_KI] * cst[CST_INT] + cst[CST_DFILT] + g[G_KFF] * v_ref
    elif code == CTL_SLIDING:
        s = (v_ref - v) + g[G_LAMBDA] * e
        r = s / g[G_PHI]
        if r > 1.0:
            r = 1.0
        elif r < -1.0:
            r = -1.0
        u = mid + g[G_K] * r
    elif code == CTL_ONOFF:
        db = g[G_OO_DEADBAND]
        if e > db:
            u = mid + g[G_LEVEL] * half
        elif e < -db:
            u = mid - g[G_LEVEL] * half
        else:
            u = mid
    elif code == CTL_PVA:
        u = mid + g[G_PVA_KP] * e + g[G_PVA_KV] * (v_ref - v) + g[G_PVA_KA] * (a_ref - meas[MEAS_A]) \
            + g[G_FFV] * v_ref + g[G_FFA] * a_ref
    elif code == CTL_PWM:
        n = max(1, int(round(g[G_PWM_PERIOD] / Ts)))
        k = int(cst[CST_PWM_K])
        if k == 0:
            duty = min(g[G_PWM_KP] * abs(e), 1.0)
            if abs(e) <= g[G_PWM_DEADBAND]:
                duty = 0.0
            cst[CST_PWM_DUTY] = duty if e >= 0.0 else -duty
        d = cst[CST_PWM_DUTY]
        if k < int(round(abs(d) * n)):
            u = mid + (g[G_PWM_LEVEL] * half if d > 0.0 else -g[G_PWM_LEVEL] * half)
        else:
            u = mid
        cst[CST_PWM_K] = float((k + 1) % n)
    elif code == CTL_USER:
        u = user_law(g, x_ref, v_ref, a_ref, meas, cst, Ts, u_lo, u_hi)
    else:
        f_ref = g[G_KX] * e + g[G_FKD] * (v_ref - v)
        f_meas = meas[MEAS_PA] * meas[MEAS_AA] - meas[MEAS_PB] * meas[MEAS_AB]
        u = mid + g[G_KF] * (f_ref - f_meas)
    if not math.isfinite(u):
        u = mid
    u = _clip(u, u_lo, u_hi)
    # valve switchings: changes of the output's side of the centre (or on/off level)
    side = 0.0 if abs(u - mid) <= 1e-12 * half else (1.0 if u > mid else -1.0)
    if cst[CST_STARTED] != 0.0:
        last = cst[CST_ULAST]
        side_last = 0.0 if abs(last - mid) <= 1e-12 * half else (1.0 if last > mid else -1.0)
        if side != side_last:
            cst[CST_SWITCHES] += 1.0
    cst[CST_ULAST] = u
    cst[CST_STARTED] = 1.0
    return u
