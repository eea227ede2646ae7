"""A pneumatic line resolved along its length: a 1D finite-volume model, and when it is needed.

The project's ``tubing`` effect lumps a line by default (:mod:`pneucore.physics.tube`):
its volume joins the chamber and its resistance sits in series with the valve edges; the
pressure at the chamber's end follows the valve's at once. A real line carries pressure
waves at the speed of sound ``c``: a change at the valve reaches the chamber ``L / c``
later, and the line rings at its quarter-wave frequency ``c / (4 L)`` (closed far end).
The effect's ``segments`` resolve it inside the compiled core. This module is the
independent check of both (another scheme, grid and integrator), and says where lumping
is adequate and how many segments a line needs (:func:`line_regime`).

Model
-----
One-dimensional compressible flow in a straight tube of inner diameter ``d`` [m] and
length ``L`` [m] with wall friction (the Euler equations with a friction source; Shapiro,
*The Dynamics and Thermodynamics of Compressible Fluid Flow*, 1953, ch. 6; the
finite-volume form of LeVeque, *Finite Volume Methods for Hyperbolic Problems*, 2002,
ch. 4 and 6)::

    d(rho)/dt   + d(rho u)/dx         = 0
    d(rho u)/dt + d(rho u^2 + p)/dx   = -f(Re) rho |u| u / (2 d)
    d(E)/dt     + d(u (E + p))/dx     = 0                 (adiabatic: E = p/(gamma-1) + rho u^2/2)

with ``rho`` the density [kg/m^3], ``u`` the velocity [m/s], ``p`` the pressure [Pa].
``thermo="adiabatic"`` keeps the energy equation (an adiabatic wall does no work and
passes no heat: the Fanno flow of :mod:`~pneucore.physics.tube`, sound speed
``c = sqrt(gamma R T)``); ``thermo="isothermal"`` replaces it by ``p = rho R T0``
(the wall holds the gas at ``T0``: slow flows in thin tubes, sound speed ``sqrt(R T0)``).
The Darcy factor ``f`` is the one of :func:`~pneucore.physics.tube.darcy_friction`
(``64 / Re`` below Re = 2300, where the source is Hagen-Poiseuille's ``-32 mu u / d^2``,
Haaland's smooth-tube relation above), with ``Re = rho |u| d / mu`` and ``mu`` at ``T0``
as the lumped characteristic takes it.

Discretisation: ``N`` equal cells; MUSCL reconstruction of ``(rho, u, p)`` with the
minmod limiter and the local Lax-Friedrichs (Rusanov) flux (LeVeque 2002, sec. 6.9 and
12.5): conservative, so the mass in the line changes only by the boundary fluxes. The
ODEs in time are integrated by :func:`scipy.integrate.solve_ivp` (explicit Runge-Kutta
for waves, BDF with the banded sparsity for slow charging), an integrator independent of
the project's core.

Boundaries: the inlet face meets a reservoir at a stagnation pressure history ``p0(t)``
and temperature ``T0`` (inflow: isentropic, or isothermal, expansion to the first cell's
velocity; outflow: the reservoir's pressure); the far face is a closed end (a wall), a
closed volume ``V`` [m^3] (the face's mass and energy fluxes enter it; its momentum is
taken by its walls), or an outlet at a given static pressure (the ghost state keeps the last
cell's outgoing Riemann invariant and entropy; it is the sonic state when the line chokes). Cumulative inlet and outlet masses are integrated alongside, so the mass
balance can be checked to round-off.

The line's transport delay and wave behaviour follow the pipeline models of Krus,
Weddfelt and Palmberg ("Fast pipeline models for simulation of hydraulic and pneumatic
systems", J. Dyn. Sys. Meas. Control 116, 1994, 132-136), where a line is a lumped
capacitance and resistance only while its delay ``L / c`` is short against the time
scale of the signal it carries.
"""
import math
from dataclasses import dataclass

import numpy as np

from pneucore.physics.gas import GAMMA_AIR, R_AIR, T_REF
from pneucore.physics.tube import MAX_SEGMENTS, RE_LAMINAR, air_viscosity_sutherland, darcy_friction

#: Ratio of the signal's time scale to the line's quarter-wave period ``4 L / c`` above which
#: the lumped line is adequate [-]. Measured (tests/physics/test_tube_line.py, a volume filled
#: through 2 m of 4 mm line from 1 to 7 bar, 25 cells): the lumped line's half-fill time is off
#: the finite-volume line's by 0.31 % at 32 quarter-wave periods, 1.4 % at 9.8, 4.4 % at 3.4,
#: 13 % at 1.1, 29 % at 0.50 and 51 % at 0.28, about 0.15 / ratio: from 3 periods on,
#: lumping costs under about 5 %
LUMPED_MARGIN = 3.0

#: Cells per quarter wave of the signal a finite-volume line needs to carry it [-]
#: (a MUSCL scheme resolves a wave with about 8 cells to a few per cent of its amplitude)
CELLS_PER_QUARTER_WAVE = 8

_THERMO = ("adiabatic", "isothermal")


def sound_speed(T=T_REF, thermo="adiabatic", r=R_AIR, gamma=GAMMA_AIR):
    """Speed of sound, ``sqrt(gamma R T)`` (adiabatic) or ``sqrt(R T)`` (isothermal).

    Parameters
    ----------
    T : float
        Temperature [K]
    thermo : str
        ``adiabatic`` or ``isothermal`` [-]
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]

    Returns
    -------
    c : float
        Speed of sound [m/s]

    Examples
    --------
    Air at 20 degC: 343 m/s (any acoustics table):

    >>> round(sound_speed(293.15), 1)
    343.2
    """
    if thermo not in _THERMO:
        raise ValueError(f"thermo: one of {_THERMO}, not {thermo!r}")
    return math.sqrt((gamma if thermo == "adiabatic" else 1.0) * r * T)


def delay_cells(length, sample_period, T=T_REF):
    """Finite volumes that resolve a line's transport delay to one sample of a record.

    A record sampled every ``dt`` sees a line's delay ``L / c`` once it spans more than a
    sample: a chamber's pressure stays put for ``L / c`` after the valve opens, where the
    lumped line (no delay) has it rising at once. A line in ``N`` finite volumes passes a
    front one cell per ``L / (N c)``; with that no longer than a sample the delay is
    resolved to one sample: ``N = ceil(L / (c dt))``, 1 (lumped) where the delay is within a
    sample, at most :data:`pneucore.physics.tube.MAX_SEGMENTS`.

    Parameters
    ----------
    length : float
        Line length [m]
    sample_period : float
        The record's sample period [s]
    T : float
        Gas temperature [K]

    Returns
    -------
    cells : int
        Finite volumes [-]

    Examples
    --------
    2.5 m of tube at 1 kHz: a delay of 7.3 ms, 8 cells; 0.3 m: within a sample, lumped:

    >>> delay_cells(2.5, 1e-3, 293.15), delay_cells(0.3, 1e-3, 293.15)
    (8, 1)
    """
    if not (length > 0.0 and sample_period > 0.0):
        return 1
    # a part in a million below a whole number counts as it (a fit ending on the bound c dt)
    n = math.ceil(length / (sound_speed(T) * sample_period) - 1e-6)
    return int(min(max(n, 1), MAX_SEGMENTS))


def line_regime(diameter, length, time_scale, T=T_REF):
    """Whether the lumped line is adequate for a signal of the given time scale.

    The line's transport delay is ``L / c`` and its first resonance (closed far end) the
    quarter-wave frequency ``c / (4 L)``. The lumped line (a volume and a resistance) is
    adequate while the signal's time scale is at least :data:`LUMPED_MARGIN` quarter-wave
    periods ``4 L / c``; a faster signal needs the line resolved in finite volumes, about
    :data:`CELLS_PER_QUARTER_WAVE` per quarter wave of the signal (at least 4 cells).

    Parameters
    ----------
    diameter : float
        Inner diameter [m] (the regime does not depend on it; kept for the caller's record)
    length : float
        Length [m]
    time_scale : float
        Time scale of the signal the line carries, e.g. the shortest interval between
        command changes [s]
    T : float
        Gas temperature [K]

    Returns
    -------
    regime : dict
        ``lumped`` (bool), ``delay`` = L / c [s], ``quarter_wave_period`` = 4 L / c [s],
        ``ratio`` = time_scale / (4 L / c) [-], ``cells`` advised for a finite-volume line [-]

    Examples
    --------
    2 m of tube under a 100 ms pulse: lumped is adequate (delay 5.8 ms, 23 ms quarter
    wave); under a 20 ms pulse it is not, and 10 cells resolve it:

    >>> r = line_regime(4e-3, 2.0, 0.1)
    >>> r["lumped"], round(r["delay"] * 1e3, 2)
    (True, 5.83)
    >>> r = line_regime(4e-3, 2.0, 0.02)
    >>> r["lumped"], r["cells"]
    (False, 10)
    """
    c = sound_speed(T)
    delay = length / c
    period = 4.0 * delay
    ratio = math.inf if period <= 0.0 else time_scale / period
    cells = max(4, int(math.ceil(CELLS_PER_QUARTER_WAVE * period / max(time_scale, 1e-300))))
    return {"lumped": bool(ratio >= LUMPED_MARGIN), "delay": delay, "quarter_wave_period": period,
            "ratio": ratio, "cells": 1 if ratio >= LUMPED_MARGIN else cells}


@dataclass
class LineResult:
    """The sampled solution of :func:`simulate_line`.

    Parameters
    ----------
    t : numpy.ndarray
        Sample times [s]
    x : numpy.ndarray
        Cell centres from the inlet [m]
    p : numpy.ndarray
        Cell pressures, shape (samples, cells) [Pa]
    u : numpy.ndarray
        Cell velocities, shape (samples, cells) [m/s]
    T : numpy.ndarray
        Cell temperatures, shape (samples, cells) [K]
    p_end : numpy.ndarray
        Pressure at the far end: the volume's, else the last cell's [Pa]
    q_in : numpy.ndarray
        Mass flow through the inlet face, into the line [kg/s]
    q_out : numpy.ndarray
        Mass flow through the far face, out of the line [kg/s]
    m_line : numpy.ndarray
        Mass in the line [kg]
    m_volume : numpy.ndarray
        Mass in the far-end volume (0 without one) [kg]
    m_in : numpy.ndarray
        Mass that entered through the inlet since t = 0 [kg]
    m_out : numpy.ndarray
        Mass that left through an outlet since t = 0 [kg]
    nfev : int
        Right-hand side evaluations [-]
    """
    t: np.ndarray
    x: np.ndarray
    p: np.ndarray
    u: np.ndarray
    T: np.ndarray
    p_end: np.ndarray
    q_in: np.ndarray
    q_out: np.ndarray
    m_line: np.ndarray
    m_volume: np.ndarray
    m_in: np.ndarray
    m_out: np.ndarray
    nfev: int


def _minmod(a, b):
    return np.where(a * b > 0.0, np.sign(a) * np.minimum(np.abs(a), np.abs(b)), 0.0)


class _Line:
    """The semi-discrete right-hand side (see module): state = [rho_i, (rho u)_i, (E_i),
    volume mass, (volume internal energy), cumulative inlet mass, cumulative outlet mass]."""

    def __init__(self, diameter, length, n_cells, p_in, T0, end, volume, p_out, thermo, r, gamma,
                 mu):
        self.d, self.L, self.N = diameter, length, n_cells
        self.A = math.pi * diameter * diameter / 4.0
        self.dx = length / n_cells
        self.p_in, self.T0, self.end, self.V, self.p_out = p_in, T0, end, volume, p_out
        self.adiabatic = thermo == "adiabatic"
        self.k = 3 if self.adiabatic else 2
        self.r, self.gamma = r, gamma
        self.cp = gamma * r / (gamma - 1.0)
        self.mu = air_viscosity_sutherland(T0) if mu is None else mu
        self.has_volume = end == "volume"
        self.nv = (2 if self.adiabatic else 1) if self.has_volume else 0
        self.n = self.k * n_cells + self.nv + 2
        self.friction = np.vectorize(darcy_friction, otypes=[float])

    # primitive <-> conservative ------------------------------------------------------
    def primitive(self, y):
        N = self.N
        rho = y[0:N]
        u = y[N:2 * N] / rho
        if self.adiabatic:
            p = (self.gamma - 1.0) * (y[2 * N:3 * N] - 0.5 * rho * u * u)
        else:
            p = rho * self.r * self.T0
        return rho, u, p

    def flux(self, rho, u, p):
        F = [rho * u, rho * u * u + p]
        if self.adiabatic:
            E = p / (self.gamma - 1.0) + 0.5 * rho * u * u
            F.append(u * (E + p))
        return F

    def sound(self, rho, p):
        return np.sqrt((self.gamma if self.adiabatic else 1.0) * p / rho)

    def conserved(self, rho, u, p):
        U = [rho, rho * u]
        if self.adiabatic:
            U.append(p / (self.gamma - 1.0) + 0.5 * rho * u * u)
        return U

    def volume_state(self, y):
        i = self.k * self.N
        m = y[i]
        if self.adiabatic:
            p = (self.gamma - 1.0) * y[i + 1] / self.V
        else:
            p = m * self.r * self.T0 / self.V
        return m / self.V, p

    # boundaries ------------------------------------------------------------------------
    def inlet_ghost(self, t, rho1, u1, p1):
        p0 = float(self.p_in(t))
        if self.adiabatic:
            T1 = p1 / (rho1 * self.r)
            u_max = math.sqrt(2.0 * self.gamma * self.r * self.T0 / (self.gamma + 1.0))
            u = min(u1, u_max)
            if u >= 0.0:
                T = self.T0 - 0.5 * u * u / self.cp
                p = p0 * (T / self.T0) ** (self.gamma / (self.gamma - 1.0))
            elif not math.isfinite(T1):
                T, p = T1, math.nan
            else:
                T, p = T1, p0
        else:
            u = u1
            T = self.T0
            p = p0 * math.exp(-0.5 * max(u, 0.0) ** 2 / (self.r * self.T0))
        return p / (self.r * T), u, p

    def outlet_ghost(self, y, rhoN, uN, pN):
        if self.end == "volume":
            rho_v, p_v = self.volume_state(y)
            return rho_v, uN, p_v
        # given outlet pressure, by the outgoing characteristic (Hirsch, Numerical Computation
        # of Internal and External Flows, vol. 2, 1990, ch. 19): the ghost keeps the last
        # cell's Riemann invariant J+ and entropy and takes p_out, unless p_out is below the
        # pressure at which that state is sonic: then the ghost is the sonic state (choked)
        g = self.gamma if self.adiabatic else 1.0
        cN = np.sqrt(g * pN / rhoN)                  # NaN on a bad trial step
        if not uN > 0.0:                             # inflow from the outlet: its own gas
            T = self.T0
            return self.p_out / (self.r * T), uN, self.p_out
        if self.adiabatic:
            k = self.gamma - 1.0
            J = uN + 2.0 * cN / k
            c_star = k * J / (self.gamma + 1.0)
            p_star = pN * (c_star / cN) ** (2.0 * self.gamma / k)
            p = max(self.p_out, p_star)
            rho = rhoN * (p / pN) ** (1.0 / self.gamma)
            u = J - 2.0 * np.sqrt(self.gamma * p / rho) / k
        else:
            J = uN + cN * np.log(rhoN)
            rho = max(self.p_out / (self.r * self.T0), np.exp((J - cN) / cN))
            u = J - cN * np.log(rho)
            p = rho * self.r * self.T0
        return rho, u, p

    # right-hand side ---------------------------------------------------------------------
    def rhs(self, t, y):
        with np.errstate(invalid="ignore", divide="ignore"):
            # a trial step that drives a density or pressure negative gives NaN, which
            # solve_ivp's error control rejects (a smaller step), instead of an exception
            return self._rhs(t, y)

    def _rhs(self, t, y):
        N, k = self.N, self.k
        rho, u, p = self.primitive(y)
        g_in = self.inlet_ghost(t, rho[0], u[0], p[0])
        W = np.empty((3, N + 2))
        W[:, 1:N + 1] = rho, u, p
        W[:, 0] = g_in
        wall = self.end == "closed"
        if not wall:
            W[:, N + 1] = self.outlet_ghost(y, rho[-1], u[-1], p[-1])
        else:
            W[:, N + 1] = rho[-1], -u[-1], p[-1]
        s = np.zeros_like(W)
        s[:, 1:N + 1] = _minmod(W[:, 1:N + 1] - W[:, 0:N], W[:, 2:N + 2] - W[:, 1:N + 1])
        WL = W[:, 0:N + 1] + 0.5 * s[:, 0:N + 1]      # left state of face j (j = 0..N)
        WR = W[:, 1:N + 2] - 0.5 * s[:, 1:N + 2]
        if wall:                                       # mirror: no mass through the wall
            WR[:, N] = WL[0, N], -WL[1, N], WL[2, N]
        if np.any(WL[0] <= 0.0) or np.any(WL[2] <= 0.0) or np.any(WR[0] <= 0.0) \
                or np.any(WR[2] <= 0.0):          # limiter keeps this off; first order if not
            WL, WR = W[:, 0:N + 1], W[:, 1:N + 2].copy()
            if wall:
                WR[:, N] = W[0, N], -W[1, N], W[2, N]
        cL, cR = self.sound(WL[0], WL[2]), self.sound(WR[0], WR[2])
        FL, FR = self.flux(*WL), self.flux(*WR)
        UL, UR = self.conserved(*WL), self.conserved(*WR)
        a = np.maximum(np.abs(WL[1]) + cL, np.abs(WR[1]) + cR)
        F = [0.5 * (fl + fr) - 0.5 * a * (ur - ul) for fl, fr, ul, ur in zip(FL, FR, UL, UR)]
        if wall:
            F[0][N] = 0.0                              # exactly, not to round-off
        dy = np.empty_like(y)
        for j in range(k):
            dy[j * N:(j + 1) * N] = -(F[j][1:] - F[j][:-1]) / self.dx
        # wall friction on the momentum (Darcy; Hagen-Poiseuille below RE_LAMINAR)
        Re = rho * np.abs(u) * self.d / self.mu
        src = -32.0 * self.mu * u / (self.d * self.d)
        turb = Re >= RE_LAMINAR
        if np.any(turb):
            f = self.friction(Re[turb])
            src[turb] = -f * rho[turb] * np.abs(u[turb]) * u[turb] / (2.0 * self.d)
        dy[N:2 * N] += src
        i = k * N
        q_in, q_out = F[0][0] * self.A, F[0][N] * self.A
        if self.has_volume:
            dy[i] = q_out
            if self.adiabatic:
                dy[i + 1] = F[2][N] * self.A
            i += self.nv
            dy[i + 1] = 0.0
        else:
            dy[i + 1] = q_out
        dy[i] = q_in
        return dy

    def sparsity(self):
        """Jacobian sparsity: a cell's fluxes see two cells each side; the boundary cells,
        the volume and the counters are coupled densely (a few rows)."""
        from scipy.sparse import csr_matrix        # here: importing the module stays light
        N, k, n = self.N, self.k, self.n
        S = np.zeros((n, n), dtype=np.int8)
        idx = np.arange(N)
        for a in range(k):
            for b in range(k):
                for off in range(-2, 3):
                    ok = (idx + off >= 0) & (idx + off < N)
                    S[a * N + idx[ok], b * N + idx[ok] + off] = 1
        edge = [j * N + i for j in range(k) for i in (0, 1, 2, N - 3, N - 2, N - 1)]
        rows = edge + list(range(k * N, n))
        S[np.ix_(rows, rows)] = 1
        return csr_matrix(S)


def simulate_line(diameter, length, p_in, t_end, n_cells=50, T0=T_REF, end="closed", volume=0.0,
                  p_out=None, p_init=None, thermo="adiabatic", t_eval=None, method="RK45",
                  rtol=1e-6, atol=None, mu=None, r=R_AIR, gamma=GAMMA_AIR):
    """Integrate the finite-volume line (see module) from rest.

    Parameters
    ----------
    diameter : float
        Inner diameter [m]
    length : float
        Length [m]
    p_in : float or callable
        Reservoir stagnation pressure at the inlet, constant or a function of time [Pa]
    t_end : float
        Simulated time [s]
    n_cells : int
        Number of finite volumes [-]
    T0 : float
        Reservoir temperature, and the line's initial temperature [K]
    end : str
        Far end: ``closed`` (a wall), ``volume`` (a closed volume) or ``outlet`` (a given
        static pressure) [-]
    volume : float
        The far-end volume (``end="volume"``) [m^3]
    p_out : float or None
        Outlet static pressure (``end="outlet"``) [Pa]
    p_init : float or None
        Initial pressure of the line and the volume, gas at rest at ``T0`` (default: the
        outlet pressure, else the inlet's at t = 0) [Pa]
    thermo : str
        ``adiabatic`` (energy equation) or ``isothermal`` (T = T0 everywhere) [-]
    t_eval : array_like or None
        Sample times [s] (default: 201 samples over [0, t_end])
    method : str
        :func:`scipy.integrate.solve_ivp` method [-]
    rtol : float
        Relative tolerance [-]
    atol : float or None
        Absolute tolerance on the states (default: 1e-9 of each state's initial scale) [-]
    mu : float or None
        Dynamic viscosity (default: Sutherland at ``T0``) [Pa s]
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]

    Returns
    -------
    result : LineResult
        The sampled solution

    Examples
    --------
    A closed 5 m line stays at rest under its own pressure (conservation, no flow):

    >>> res = simulate_line(4e-3, 5.0, 3e5, 0.01, n_cells=10)
    >>> float(abs(res.p_end[-1] - 3e5) / 3e5) < 1e-9
    True
    """
    from scipy.integrate import solve_ivp   # here: simulate imports this module for line_regime
    if thermo not in _THERMO:
        raise ValueError(f"thermo: one of {_THERMO}, not {thermo!r}")
    if end not in ("closed", "volume", "outlet"):
        raise ValueError(f"end: closed, volume or outlet, not {end!r}")
    if not (diameter > 0.0 and length > 0.0 and n_cells >= 3):
        raise ValueError("diameter [m] and length [m] must be > 0, n_cells >= 3")
    if end == "volume" and not volume > 0.0:
        raise ValueError("volume [m^3] must be > 0 with end='volume'")
    if end == "outlet" and p_out is None:
        raise ValueError("p_out [Pa] is needed with end='outlet'")
    p_fun = p_in if callable(p_in) else (lambda t, _p=float(p_in): _p)
    line = _Line(diameter, length, n_cells, p_fun, T0, end, volume, p_out, thermo, r, gamma, mu)
    if p_init is None:
        p_init = p_out if end == "outlet" else float(p_fun(0.0))
    rho0 = p_init / (r * T0)
    y0 = np.zeros(line.n)
    N, k = n_cells, line.k
    y0[0:N] = rho0
    if line.adiabatic:
        y0[2 * N:3 * N] = p_init / (gamma - 1.0)
    scale = np.full(line.n, rho0)
    scale[N:2 * N] = rho0 * sound_speed(T0, thermo, r, gamma)
    if line.adiabatic:
        scale[2 * N:3 * N] = p_init / (gamma - 1.0)
    i = k * N
    if line.has_volume:
        y0[i] = rho0 * volume
        scale[i] = y0[i]
        if line.adiabatic:
            y0[i + 1] = p_init * volume / (gamma - 1.0)
            scale[i + 1] = y0[i + 1]
    m_scale = rho0 * (line.A * length + (volume if line.has_volume else 0.0))
    scale[-2:] = m_scale
    atol = 1e-9 * scale if atol is None else atol
    if t_eval is None:
        t_eval = np.linspace(0.0, t_end, 201)
    kw = {}
    if method in ("BDF", "Radau"):
        kw["jac_sparsity"] = line.sparsity()
    sol = solve_ivp(line.rhs, (0.0, t_end), y0, method=method, t_eval=t_eval, rtol=rtol,
                    atol=atol, **kw)
    if sol.status != 0:
        raise RuntimeError(f"solve_ivp: {sol.message}")
    Y = sol.y.T
    ps, us, Ts, qi, qo = [], [], [], [], []
    for t, y in zip(sol.t, Y):
        rho, u, p = line.primitive(y)
        ps.append(p)
        us.append(u)
        Ts.append(p / (rho * r))
        dy = line.rhs(t, y)
        qi.append(dy[-2])
        qo.append(dy[k * N] if line.has_volume else dy[-1])
    P = np.array(ps)
    m_line = Y[:, 0:N].sum(axis=1) * line.A * line.dx
    if line.has_volume:
        m_vol = Y[:, k * N]
        p_end = np.array([line.volume_state(y)[1] for y in Y])
    else:
        m_vol = np.zeros(len(sol.t))
        p_end = P[:, -1]
    return LineResult(t=sol.t, x=(np.arange(N) + 0.5) * line.dx, p=P, u=np.array(us),
                      T=np.array(Ts), p_end=p_end, q_in=np.array(qi), q_out=np.array(qo),
                      m_line=m_line, m_volume=m_vol, m_in=Y[:, -2], m_out=Y[:, -1],
                      nfev=sol.nfev)
