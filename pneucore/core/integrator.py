"""Event-exact stiff integration of the actuator model (compiled with numba).

Method: RODAS4, the 6-stage, order-4(3), L-stable and stiffly accurate
Rosenbrock method of Hairer & Wanner (Solving ODEs II, 2nd ed., 1996,
Sect. IV.7), with a finite-difference Jacobian refreshed every step and
step-size control on the embedded error estimate. L-stability matters here:
near pressure equilibrium the laminar branch of the valve law and a small
dead volume give chamber eigenvalues of 1e4-1e5 1/s, which an explicit
method could only follow with tiny steps.

Discontinuities are events, as the paper's ACSL "schedule" back-step:

* command breakpoints: the step is cut to land on them exactly;
* stick to slip: net force crosses the static friction limit;
* slip to stick (or reversal): velocity crosses zero;
* end-stop hits: position reaches 0 or the stroke (inelastic stop).

State events are located on the cubic Hermite interpolant of the step by
the Illinois method to ``EVENT_TOL`` seconds, then the step is redone
exactly from its start to the event time (the back-step) before the mode
changes. Within one mode the equations are smooth.

Compile options, chosen by measurement (``benchmarks/bench_simulator.py``):

* every function below :func:`integrate` is compiled without numba's
  reference-counting runtime (``_nrt=False``): none allocates, and with the
  runtime each array argument of each call costs an atomic increment and
  decrement; only :func:`integrate` allocates its work arrays, and the
  user-effect layer :func:`pneucore.core.rhs.call_user_terms` keeps the runtime
  (a user's terms may allocate; callees inherit the caller's setting);
* small functions called with several arrays from hot loops (the LU
  factorisation and solve, the Hermite interpolant, the event functions and
  the valve edge in :mod:`pneucore.core.rhs`) are inlined at numba IR level
  (``inline="always"``): an array argument is passed as seven machine words,
  and these calls cost more than the work they do. Inlining the right-hand
  side itself, or ``_feval``, was slower and compiled longer.

Together these took the pulse benchmark from 1.22 to 0.54 ms per simulated
second (the integration core alone from 1.00 to 0.35 ms).

The first compile (numba's cache empty) is cut by compiling less, never
different code (results are bit-for-bit those of the wrapped build):

* the functions below :func:`integrate` are compiled without numba's CPython
  and C-callable wrappers (``no_cpython_wrapper``, ``no_cfunc_wrapper``): only
  compiled code calls them. The right-hand side and the component laws are
  public, so the core calls wrapper-less copies of them
  (:func:`_without_wrappers`);
* integer counters first assigned a constant are typed ``int64`` up front
  (``locals``), so no callee is compiled a second time for a literal type.

Together about 20 % less CPU time for the first compile (12.5 to 9.9 s on
average over three pairs on the shared 2-core machine, load 7-11;
``benchmarks/bench_cold_start.py``).
"""
import math

import numpy as np
from numba import jit, njit, types

from pneucore.core import layout as L
from pneucore.physics.chamber import chamber_pressure
from pneucore.physics.friction import coulomb_level
from pneucore.physics.jack import chamber_volumes, net_pressure_force, spring_force
from pneucore.core.rhs import call_line_cells, line_terms, rhs, static_friction
from pneucore.core.controllers import control_law
from pneucore.physics.sensors import (SENS_IDEAL_RATES, SENS_P_Q, SENS_RATE_TAU, SST_A, SST_V,
                                      estimate_rates, quantise, sense_position)
from numba.core.registry import CPUDispatcher


def _code_names(code):
    """Global names a code object (and the code objects nested in it) refers to."""
    names = set(code.co_names)
    for c in code.co_consts:
        if hasattr(c, "co_names"):
            names |= _code_names(c)
    return names


def _without_wrappers(dispatcher, memo):
    """A copy of a compiled function, and of every compiled function it calls by a global
    name, that numba compiles without its CPython and C-callable wrappers and without
    its own on-disk cache entry.

    The right-hand side and the component laws it calls (``flow``, ``chamber``, ...) are
    public functions that Python code calls too, so they keep their wrappers; the core
    only calls them from compiled code, where the wrappers (one more function to generate
    and compile per law) and the per-function cache entries are dead weight: about 30
    functions of the first compile. The compiled code itself is unchanged (the cached
    :func:`integrate` carries its callees). Memoised in ``memo`` so that a law called from
    several places is copied once.
    """
    import types as pytypes

    if dispatcher in memo:
        return memo[dispatcher]
    f = dispatcher.py_func
    glb = dict(f.__globals__)
    opts = {k: v for k, v in dispatcher.targetoptions.items() if k != "cache"}
    opts.update(no_cpython_wrapper=True, no_cfunc_wrapper=True)
    copy = jit(**opts)(pytypes.FunctionType(f.__code__, glb, f.__name__, f.__defaults__,
                                            f.__closure__))
    memo[dispatcher] = copy
    for name in _code_names(f.__code__):
        if name in glb:
            glb[name] = _strip_wrappers(glb[name], memo)
    return copy


def _strip_wrappers(value, memo):
    """``value`` with each compiled function in it (itself, or in a tuple such as the law
    tables of :mod:`pneucore.core.rhs`) replaced by its wrapper-less copy."""
    if isinstance(value, CPUDispatcher):
        return _without_wrappers(value, memo)
    if isinstance(value, tuple):
        return tuple(_strip_wrappers(v, memo) for v in value)
    return value


_COPIES = {}
rhs, static_friction, chamber_pressure, coulomb_level, chamber_volumes, net_pressure_force, \
    spring_force = (_without_wrappers(d, _COPIES)
                    for d in (rhs, static_friction, chamber_pressure, coulomb_level,
                              chamber_volumes, net_pressure_force, spring_force))

#: Event location tolerance on time [s] (the contract is 1e-6 s)
EVENT_TOL = 1e-9

# RODAS4 coefficients in the W-transformed form (Hairer & Wanner; as in KPP's
# Rosenbrock integrator): G = 1/(h gamma) - J;
# G K_i = f(t + alpha_i h, y + sum_j A_ij K_j) + sum_j C_ij / h K_j + gamma_i h f_t;
# y_new = y + sum_i M_i K_i; error estimate = K_6.
_GAMMA = 0.25
_ALPHA = np.array([0.0, 0.386, 0.210, 0.630, 1.0, 1.0])
_GAMMAS = np.array([0.25, -0.1043, 0.1035, -0.3620000000000023e-01, 0.0, 0.0])
_A = np.zeros((6, 6))
_A[1, 0] = 1.544
_A[2, 0] = 0.9466785280815826
_A[2, 1] = 0.2557011698983284
_A[3, 0] = 3.314825187068521
_A[3, 1] = 2.896124015972201
_A[3, 2] = 0.9986419139977817
_A[4, 0] = 1.221224509226641
_A[4, 1] = 6.019134481288629
_A[4, 2] = 12.53708332932087
_A[4, 3] = -0.6878860361058950
_A[5, 0:4] = _A[4, 0:4]
_A[5, 4] = 1.0
_C = np.zeros((6, 6))
_C[1, 0] = -5.6688
_C[2, 0] = -2.430093356833875
_C[2, 1] = -0.2063599157091915
_C[3, 0] = -0.1073529058151375
_C[3, 1] = -9.594562251023355
_C[3, 2] = -20.47028614809616
_C[4, 0] = 7.496443313967647
_C[4, 1] = -10.24680431464352
_C[4, 2] = -33.99990352819905
_C[4, 3] = 11.70890893206160
_C[5, 0] = 8.083246795921522
_C[5, 1] = -7.981132988064893
_C[5, 2] = -31.52159432874371
_C[5, 3] = 16.31930543123136
_C[5, 4] = -6.058818238834054
_M = np.array([1.221224509226641, 6.019134481288629, 12.53708332932087,
               -0.6878860361058950, 1.0, 1.0])

#: Decorator of the functions below :func:`integrate`: cached, no reference-counting
#: runtime, and no CPython or C-callable wrapper (they are only called from compiled
#: code; each wrapper is one more function to generate and compile, about 1.3 s of
#: the first call over all of them)
_internal = njit(cache=True, error_model="numpy", _nrt=False, no_cpython_wrapper=True,
                 no_cfunc_wrapper=True)
#: The same, inlined at numba IR level into each caller
_inline = njit(cache=True, error_model="numpy", _nrt=False, no_cpython_wrapper=True,
               no_cfunc_wrapper=True, inline="always")

# status codes returned by :func:`integrate`
OK, ERR_MAX_STEPS, ERR_STEP_UNDERFLOW, ERR_EVENTS_OVERFLOW, ERR_NONPHYSICAL, ERR_CHATTER = range(6)
STATUS_MESSAGES = (
    "ok",
    "the solver exceeded its maximum number of steps (solver.max_steps)",
    "the step size fell below its minimum: the model is too stiff or discontinuous here",
    "too many events (more than solver.max_events stick/slip/stop/command events)",
    "a chamber reached a non-physical state (mass or temperature <= 0, or not finite)",
    "stick/slip chattering: mode changes without the time advancing",
)
# statistics slots
ST_STEPS, ST_REJECTED, ST_FEVALS, ST_JACOBIANS, ST_EVENTS, ST_BACKSTEPS = range(6)
N_STATS = 6


@_internal
def command_segment(t, cmd_t, cmd_u, linear):
    """Command segment containing ``t``: (start time, value at start, slope, end time).

    ``hold``: value ``cmd_u[k]`` from ``cmd_t[k]`` to ``cmd_t[k+1]``;
    ``linear``: straight line between breakpoints. Before the first breakpoint
    the first value holds; after the last, the last value.
    """
    n = cmd_t.shape[0]
    k = 0
    while k + 1 < n and cmd_t[k + 1] <= t:
        k += 1
    if t < cmd_t[0]:
        return t, cmd_u[0], 0.0, cmd_t[0]
    if k + 1 >= n:
        return cmd_t[k], cmd_u[k], 0.0, np.inf
    slope = 0.0
    if linear:
        slope = (cmd_u[k + 1] - cmd_u[k]) / (cmd_t[k + 1] - cmd_t[k])
    return cmd_t[k], cmd_u[k], slope, cmd_t[k + 1]


@_inline
def _lu_factor(A, piv, dinv, n):
    """In-place LU factorisation with partial pivoting; ``dinv`` gets the inverse pivots.

    Returns False if the matrix is singular or not finite. (The inverse
    pivots turn the back substitution's divisions into products: a 6x6 system
    is solved six times per step, and divisions dominated its cost.)
    """
    for k in range(n):
        p = k
        amax = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > amax:
                amax = abs(A[i, k])
                p = i
        piv[k] = p
        if amax == 0.0 or not math.isfinite(amax):
            return False
        if p != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
        inv = 1.0 / A[k, k]
        dinv[k] = inv
        for i in range(k + 1, n):
            A[i, k] *= inv
            f = A[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
    return True


@_inline
def _lu_solve(A, piv, dinv, b, n):
    """Solve ``A x = b`` in place with the factors of :func:`_lu_factor`."""
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= A[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= A[i, j] * b[j]
        b[i] = s * dinv[i]


@_internal
def _lu_factor_profile(A, piv, dinv, n, lo, hi):
    """:func:`_lu_factor` over the nonzero profile of each row: ``lo[i]`` and ``hi[i]`` are
    the first and last columns where row ``i`` may be nonzero (on entry: the structural
    pattern's, :func:`_profile`; updated here with the elimination's fill and the row
    interchanges, and kept for :func:`_lu_solve_profile`). The same partial pivoting and operations as the dense
    factorisation, skipping only products with entries known to be zero: for a matrix
    ordered so that its nonzeros cluster near the diagonal (a line in segments cell by
    cell, the dense block last) the work falls from ``n^3 / 3`` to a few times ``n``
    times the profile's width.

    Returns False if the matrix is singular or not finite.
    """
    for k in range(n):
        p = k
        amax = abs(A[k, k])
        for i in range(k + 1, n):
            if lo[i] <= k and abs(A[i, k]) > amax:
                amax = abs(A[i, k])
                p = i
        piv[k] = p
        if amax == 0.0 or not math.isfinite(amax):
            return False
        if p != k:
            for j in range(min(lo[k], lo[p]), max(hi[k], hi[p]) + 1):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
            tmp_i = lo[k]
            lo[k] = lo[p]
            lo[p] = tmp_i
            tmp_i = hi[k]
            hi[k] = hi[p]
            hi[p] = tmp_i
        inv = 1.0 / A[k, k]
        dinv[k] = inv
        hk = hi[k]
        for i in range(k + 1, n):
            if lo[i] > k:
                continue
            A[i, k] *= inv
            f = A[i, k]
            if f != 0.0:
                for j in range(k + 1, hk + 1):
                    A[i, j] -= f * A[k, j]
                if hk > hi[i]:
                    hi[i] = hk
    return True


@_internal
def _lu_solve_profile(A, piv, dinv, b, n, lo, hi):
    """Solve ``A x = b`` in place with the factors of :func:`_lu_factor_profile`."""
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(n):
        s = b[i]
        for j in range(lo[i], i):
            s -= A[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, hi[i] + 1):
            s -= A[i, j] * b[j]
        b[i] = s * dinv[i]


@_internal
def _feval(t, y, mode, seg_t0, seg_u0, seg_slope, model, dy, aux):
    prm, iy, tx, tC, tb, tm, toff, prm_user, scratch = model
    u = seg_u0 + seg_slope * (t - seg_t0)
    rhs(t, y, mode, u, prm, iy, tx, tC, tb, tm, toff, prm_user, scratch, dy, aux)


@_inline
def _hermite(theta, h, y0, f0, y1, f1, out):
    t2 = theta * theta
    t3 = t2 * theta
    h10 = t3 - 2.0 * t2 + theta
    h01 = -2.0 * t3 + 3.0 * t2
    h11 = t3 - t2
    # written as y0 + h01 (y1 - y0) + ...: exact when the state is constant (h00 + h01 = 1)
    for i in range(y0.shape[0]):
        out[i] = y0[i] + h01 * (y1[i] - y0[i]) + h10 * h * f0[i] + h11 * h * f1[i]


@_internal
def _rodas_step(t, y, h, f0, J, ft, mode, seg_t0, seg_u0, seg_slope, model,
                ynew, err, K, W, piv, dinv, ytmp, ftmp, aux, stats):
    """One RODAS4 step of size h from (t, y); returns False if W is singular or the result is not finite."""
    n = y.shape[0]
    hinv = 1.0 / h
    fac = hinv / _GAMMA
    for i in range(n):
        for j in range(n):
            W[i, j] = -J[i, j]
        W[i, i] += fac
    if not _lu_factor(W, piv, dinv, n):
        return False
    for s in range(6):
        if s == 0:
            for i in range(n):
                ftmp[i] = f0[i]
        else:
            for i in range(n):
                acc = y[i]
                for j in range(s):
                    acc += _A[s, j] * K[j, i]
                ytmp[i] = acc
            _feval(t + _ALPHA[s] * h, ytmp, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
            stats[ST_FEVALS] += 1
        for i in range(n):
            acc = ftmp[i] + _GAMMAS[s] * h * ft[i]
            for j in range(s):
                acc += _C[s, j] * hinv * K[j, i]
            K[s, i] = acc
        _lu_solve(W, piv, dinv, K[s], n)
    for i in range(n):
        acc = y[i]
        for s in range(6):
            acc += _M[s] * K[s, i]
        ynew[i] = acc
        err[i] = K[5, i]
        if not math.isfinite(acc):
            return False
    return True


@_internal
def _rodas_step_profile(t, y, h, f0, J, ft, mode, seg_t0, seg_u0, seg_slope, model,
                        ynew, err, K, W, piv, dinv, ytmp, ftmp, aux, stats, lin):
    """:func:`_rodas_step` for a model with lines in segments.

    ``lin`` (:func:`integrate_lines`) holds the profile: ``order, lo, hi, work, lo0, hi0,
    rowptr, cols`` first; the matrix ``W`` is assembled from the structural pattern with its
    rows and columns in the order ``order`` (:func:`_profile`) and factorised over its
    profile (:func:`_lu_factor_profile`).
    A function of its own so that the dense path's call stays that of :func:`_rodas_step`
    (passing the profile's arrays with every step made the base model 3.6 % slower on the
    pulse benchmark).
    """
    n = y.shape[0]
    hinv = 1.0 / h
    fac = hinv / _GAMMA
    order, lo, hi, work, lo0, hi0, rowptr, cols = lin[0], lin[1], lin[2], lin[3], lin[4], \
        lin[5], lin[6], lin[7]
    for a in range(n):
        for b in range(n):
            W[a, b] = 0.0
        ia = order[a]
        for q in range(rowptr[a], rowptr[a + 1]):
            b = cols[q]
            W[a, b] = -J[ia, order[b]]
        W[a, a] += fac
        lo[a] = lo0[a]
        hi[a] = hi0[a]
    if not _lu_factor_profile(W, piv, dinv, n, lo, hi):
        return False
    for s in range(6):
        if s == 0:
            for i in range(n):
                ftmp[i] = f0[i]
        else:
            for i in range(n):
                acc = y[i]
                for j in range(s):
                    acc += _A[s, j] * K[j, i]
                ytmp[i] = acc
            _feval(t + _ALPHA[s] * h, ytmp, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
            stats[ST_FEVALS] += 1
        for i in range(n):
            acc = ftmp[i] + _GAMMAS[s] * h * ft[i]
            for j in range(s):
                acc += _C[s, j] * hinv * K[j, i]
            K[s, i] = acc
        for a in range(n):
            work[a] = K[s, order[a]]
        _lu_solve_profile(W, piv, dinv, work, n, lo, hi)
        for a in range(n):
            K[s, order[a]] = work[a]
    for i in range(n):
        acc = y[i]
        for s in range(6):
            acc += _M[s] * K[s, i]
        ynew[i] = acc
        err[i] = K[5, i]
        if not math.isfinite(acc):
            return False
    return True


@_internal
def _frozen(j, mode, prm):
    """True when state ``j`` has a structurally zero derivative in this mode.

    Its Jacobian column can then be skipped: the stage increments of a frozen
    state are exactly zero, so the column never multiplies anything.
    """
    if (j == L.Y_X or j == L.Y_V) and mode != L.MODE_SLIDE_POS and mode != L.MODE_SLIDE_NEG:
        return True
    if (j == L.Y_MB or j == L.Y_TB) and prm[L.P_B_CONST] > 0.0:
        return True
    if (j == L.Y_TA or j == L.Y_TB) and prm[L.P_ISOTHERMAL] > 0.0:
        return True
    return False


@_internal
def _jacobian(t, y, f0, mode, seg_t0, seg_u0, seg_slope, model, scale, J, ft,
              ytmp, ftmp, aux, stats):
    """Forward-difference Jacobian, skipping the columns of frozen states."""
    n = y.shape[0]
    prm = model[0]
    for j in range(n):
        if _frozen(j, mode, prm):
            for i in range(n):
                J[i, j] = 0.0
            continue
        yj = y[j]
        d = 1.5e-8 * max(abs(yj), scale[j])
        for i in range(n):
            ytmp[i] = y[i]
        ytmp[j] = yj + d
        dinv = 1.0 / (ytmp[j] - yj)
        _feval(t, ytmp, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
        stats[ST_FEVALS] += 1
        for i in range(n):
            J[i, j] = (ftmp[i] - f0[i]) * dinv
    if seg_slope != 0.0:
        dt = 1.5e-8 * max(abs(t), 1e-3)
        _feval(t + dt, y, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
        dtinv = 1.0 / dt
        for i in range(n):
            ft[i] = (ftmp[i] - f0[i]) * dtinv
        stats[ST_FEVALS] += 1
    else:
        for i in range(n):
            ft[i] = 0.0
    stats[ST_JACOBIANS] += 1


@_internal
def _sparsity(prm, iy, n, S, cell, port):
    """Structural sparsity of the Jacobian: ``S[i, j] = 1`` where the derivative of state ``i``
    may depend on state ``j``, from the model's layout (never from an evaluation: a choked
    edge's flow has an exactly zero derivative in its downstream pressure that becomes
    nonzero once it unchokes).

    The states of a line term keep the registry's contract (:mod:`pneucore.physics.states`):
    a state of cell ``c`` depends on the states of cells ``c - 1`` to ``c + 1`` of its port,
    the first cell's also on the valve's flow into the port and the last cell's on the
    chamber. What those read is the right-hand side's (:func:`pneucore.core.rhs.rhs`):

    * the valve's flow into a port with a line reads, besides the line's first cell (its
      node), the spool's states and the supply line's mass (the edges' opening and upstream
      pressure); a cushion's needle on such a port sits at the chamber's end;
    * the chamber end reads the chamber's pressure and temperature: its mass, temperature
      and the piston's position (the volume, the cushion);
    * of the other states, only the supply line's mass reads a line's first cell (the
      valve's draw), and any may read its last cell (the flow into the chamber, its
      enthalpy, the jet-convection heat model and what reads the heat flow).

    Every other state may depend on every other (the chambers, the piston, the spool, walls
    and sensors: a dense block); a model with a user hook, which sees the whole state
    vector, is dense throughout. ``tests/core/test_jacobian_groups.py`` checks that no
    dependence is missed (a structural zero where the plain differences find none).

    Parameters
    ----------
    prm : ndarray
        Model parameters
    iy : ndarray of int
        Positions of optional states
    n : int
        Number of states [-]
    S : ndarray of uint8
        Output, ``(n, n)``
    cell, port : ndarray of int
        Work vectors of ``n``: the cell and port of each line state (-1 elsewhere)
    """
    for i in range(n):
        cell[i] = -1
        port[i] = -1
    last0 = -1
    last1 = -1
    if iy[L.IY_HOOK] <= 0:
        for k in range(2):
            i0, ns, nc = call_line_cells(line_terms, k, iy, prm, cell)
            for i in range(i0, i0 + ns):
                port[i] = k
            if k == 0:
                last0 = nc - 1
            else:
                last1 = nc - 1
    i_sp = iy[L.IY_SPOOL]
    i_sr = iy[L.IY_SPOOL_RATE]
    i_ms = iy[L.IY_SUPPLY_M]
    for i in range(n):
        for j in range(n):
            pi = port[i]
            pj = port[j]
            if pi < 0 and pj < 0:
                dep = True
            elif pi < 0:
                # the rest of the model reading a line: its last cell, anything; its first
                # cell, the supply line's mass
                cj = cell[j]
                dep = cj == (last0 if pj == 0 else last1) or (cj == 0 and i == i_ms)
            elif pj < 0:
                # a line reading the rest: its first cell the valve's other inputs, its last
                # cell the chamber of its port and the piston's position
                ci = cell[i]
                dep = False
                if ci == 0:
                    dep = j == i_sp or j == i_sr or j == i_ms
                if ci == (last0 if pi == 0 else last1):
                    if pi == 0:
                        dep = dep or j == L.Y_MA or j == L.Y_TA or j == L.Y_X
                    else:
                        dep = dep or j == L.Y_MB or j == L.Y_TB or j == L.Y_X
            else:
                dep = pi == pj and abs(cell[i] - cell[j]) <= 1
            S[i, j] = 1 if dep else 0


@_internal
def _colour(S, n, active, colour, used):
    """Curtis-Powell-Reid grouping of the Jacobian's columns (Curtis, Powell & Reid, J. Inst.
    Maths Applics 13, 1974, 117): greedily, each active column takes the first group none of
    whose columns shares a row with it, so that one evaluation with all of a group's columns
    perturbed gives each of them its own rows. Inactive (frozen) columns get group -1.

    Parameters
    ----------
    S : ndarray of uint8
        Structural sparsity (:func:`_sparsity`)
    n : int
        Number of states [-]
    active : ndarray of uint8
        1 for the columns to group [-]
    colour : ndarray of int
        Output: each column's group [-]
    used : ndarray of uint8
        Work matrix ``(n, n)``: rows taken by each group

    Returns
    -------
    n_groups : int
        Number of groups [-]
    """
    for g in range(n):
        for i in range(n):
            used[g, i] = 0
    n_groups = 0
    for j in range(n):
        colour[j] = -1
        if active[j] == 0:
            continue
        g = 0
        while True:
            free = True
            for i in range(n):
                if S[i, j] != 0 and used[g, i] != 0:
                    free = False
                    break
            if free:
                break
            g += 1
        colour[j] = g
        for i in range(n):
            if S[i, j] != 0:
                used[g, i] = 1
        if g + 1 > n_groups:
            n_groups = g + 1
    return n_groups


@_internal
def _jacobian_grouped(t, y, f0, mode, seg_t0, seg_u0, seg_slope, model, scale, J, ft,
                      ytmp, ftmp, aux, stats, S, colours, n_groups, dcol):
    """Forward-difference Jacobian by column groups (:func:`_colour`): one evaluation per
    group, each column's increment the one :func:`_jacobian` takes; entries outside the
    structural pattern ``S`` stay zero (``J`` is zero there on entry).

    ``colours`` holds the groupings of :func:`_groups` (``-1`` for a frozen column, whose
    column is zeroed), ``n_groups`` their numbers of groups; the mode picks one.
    """
    n = y.shape[0]
    k = 0 if mode == L.MODE_SLIDE_POS or mode == L.MODE_SLIDE_NEG else 1
    colour = colours[k]
    for i in range(n):
        ytmp[i] = y[i]
    for j in range(n):
        if colour[j] < 0:
            for i in range(n):
                J[i, j] = 0.0
    for g in range(n_groups[k]):
        for j in range(n):
            if colour[j] == g:
                yj = y[j]
                d = 1.5e-8 * max(abs(yj), scale[j])
                ytmp[j] = yj + d
                dcol[j] = 1.0 / (ytmp[j] - yj)
        _feval(t, ytmp, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
        stats[ST_FEVALS] += 1
        for j in range(n):
            if colour[j] == g:
                dinv = dcol[j]
                for i in range(n):
                    if S[i, j] != 0:
                        J[i, j] = (ftmp[i] - f0[i]) * dinv
                ytmp[j] = y[j]
    if seg_slope != 0.0:
        dt = 1.5e-8 * max(abs(t), 1e-3)
        _feval(t + dt, y, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
        dtinv = 1.0 / dt
        for i in range(n):
            ft[i] = (ftmp[i] - f0[i]) * dtinv
        stats[ST_FEVALS] += 1
    else:
        for i in range(n):
            ft[i] = 0.0
    stats[ST_JACOBIANS] += 1


@_internal
def _profile_order(n, cell, port, order):
    """The order of the states in which the linear systems of a model with lines in segments
    are factorised (:func:`_lu_factor_profile`): each line's states cell by cell (port A's,
    then port B's), then every other state (the dense block) last. A line state then reaches
    only a few columns on either side of the diagonal, besides the dense block.

    Parameters
    ----------
    n : int
        Number of states [-]
    cell, port : ndarray of int
        Cell and port of each line state, -1 elsewhere (:func:`_sparsity`)
    order : ndarray of int
        Output: ``order[a]``, the state at position ``a`` [-]
    """
    a = 0
    for k in range(2):
        c = 0
        while True:
            found = False
            for i in range(n):
                if port[i] == k and cell[i] == c:
                    order[a] = i
                    a += 1
                    found = True
            if not found:
                break
            c += 1
    for i in range(n):
        if port[i] < 0:
            order[a] = i
            a += 1


@_internal
def _profile(S, n, order, lo0, hi0, rowptr, cols, fill):
    """The structural pattern ``S`` in the factorisation's order (:func:`_profile_order`), the
    diagonal included: each row's first and last columns into ``lo0``, ``hi0``, and, with
    ``fill``, its columns into ``cols`` from ``rowptr[a]`` to ``rowptr[a + 1]``.

    Returns
    -------
    nnz : int
        Number of structural nonzeros [-]
    """
    q = 0
    for a in range(n):
        rowptr[a] = q
        ia = order[a]
        lo0[a] = a
        hi0[a] = a
        for b in range(n):
            if S[ia, order[b]] != 0 or a == b:
                if fill:
                    cols[q] = b
                q += 1
                if b < lo0[a]:
                    lo0[a] = b
                if b > hi0[a]:
                    hi0[a] = b
    rowptr[n] = q
    return q


@_internal
def _groups(prm, iy, n, S, colours, n_groups, cell, port, active, used):
    """The structural pattern (:func:`_sparsity`) into ``S`` and the column groups
    (:func:`_colour`) of the two sets of frozen states into ``colours``: row 0 for the
    sliding modes, row 1 for the others (the piston's states frozen).

    Each grouping's number of groups goes into ``n_groups[0]``, ``n_groups[1]``.

    Returns
    -------
    sparse : bool
        Whether the pattern has a structural zero. A dense pattern (a model without a line
        in segments) gives every column a group of its own, and the core then keeps the
        plain forward differences (:func:`_jacobian`), bit for bit as before the groups
    """
    _sparsity(prm, iy, n, S, cell, port)
    for k in range(2):
        mode = L.MODE_SLIDE_POS if k == 0 else L.MODE_STICK
        for j in range(n):
            active[j] = 0 if _frozen(j, mode, prm) else 1
        n_groups[k] = _colour(S, n, active, colours[k], used)
    for i in range(n):
        for j in range(n):
            if S[i, j] == 0:
                return True
    return False


@_internal
def _rest_forces(y, prm, aux):
    """Net force and static limits of a resting piston from the state alone (no valve flows).

    Fills ``aux[AUX_FNET]``, ``aux[AUX_FS_E]``, ``aux[AUX_FS_R]`` as the full
    right-hand side would (Eq. 17 and 20), at a fraction of its cost; used by
    the event probes when no user effect adds a force.
    """
    r = prm[L.P_R]
    p_atm = prm[L.P_ATM]
    V_a, V_b = chamber_volumes(y[L.Y_X], prm[L.P_A_A], prm[L.P_A_B], prm[L.P_STROKE],
                               prm[L.P_V0_A], prm[L.P_V0_B])
    p_a = chamber_pressure(y[L.Y_MA], y[L.Y_TA], V_a, r)
    if prm[L.P_B_CONST] > 0.0:
        p_b = prm[L.P_B_CONST]
    else:
        p_b = chamber_pressure(y[L.Y_MB], y[L.Y_TB], V_b, r)
    aux[L.AUX_FNET] = net_pressure_force(p_a, p_b, p_atm, prm[L.P_A_A], prm[L.P_A_B],
                                         prm[L.P_A_ROD_A], prm[L.P_A_ROD_B], prm[L.P_LOAD])
    k_s = prm[L.P_SPRING_K]
    f_s = prm[L.P_SPRING_F0]
    if k_s != 0.0 or f_s != 0.0:
        aux[L.AUX_FNET] -= spring_force(y[L.Y_X], k_s, f_s)
    ratio = prm[L.P_STRIBECK_RATIO]
    v_s = prm[L.P_STRIBECK_V]
    law = int(prm[L.P_FRICTION_LAW])
    aux[L.AUX_FS_E] = static_friction(law, coulomb_level(prm[L.P_FE_FC0], prm[L.P_FE_FCA],
                                                         prm[L.P_FE_FCB], p_a, p_b, p_atm),
                                      ratio, v_s)
    aux[L.AUX_FS_R] = static_friction(law, coulomb_level(prm[L.P_FR_FC0], prm[L.P_FR_FCA],
                                                         prm[L.P_FR_FCB], p_a, p_b, p_atm),
                                      ratio, v_s)


@_internal
def _resting_aux(t, y, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux):
    """Net force and static limits of a resting piston into ``aux``.

    From the state alone (:func:`_rest_forces`) unless a user effect adds
    terms, whose force only the full right-hand side knows.
    """
    if model[1][L.IY_HOOK] > 0:
        _feval(t, y, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
    else:
        _rest_forces(y, model[0], aux)


@_inline
def _event_values(mode, y, aux, stroke, out):
    """Event functions of the current mode; an event fires when one becomes > 0."""
    out[0] = -np.inf
    out[1] = -np.inf
    if mode == L.MODE_STICK or mode == L.MODE_STOP_LOW:
        out[0] = aux[L.AUX_FNET] - aux[L.AUX_FS_E]          # release towards +x
    if mode == L.MODE_STICK or mode == L.MODE_STOP_HIGH:
        out[1] = -aux[L.AUX_FNET] - aux[L.AUX_FS_R]         # release towards -x
    if mode == L.MODE_SLIDE_POS:
        out[0] = -y[L.Y_V]                                   # velocity reaches zero
        out[1] = y[L.Y_X] - stroke                           # end stop at the stroke
    elif mode == L.MODE_SLIDE_NEG:
        out[0] = y[L.Y_V]
        out[1] = -y[L.Y_X]                                   # end stop at x = 0


@_internal
def _needs_aux(mode):
    return mode == L.MODE_STICK or mode == L.MODE_STOP_LOW or mode == L.MODE_STOP_HIGH


@_internal
def _record(ev_t, ev_kind, ev_mode, n_ev, t, kind, mode):
    if n_ev < ev_t.shape[0]:
        ev_t[n_ev, 0] = t
        ev_kind[n_ev] = kind
        ev_mode[n_ev] = mode
    return n_ev + 1


@_internal
def _settle(t, y, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux, ev_t, ev_kind, ev_mode, n_ev):
    """Leave a resting mode at once if the net force already exceeds the static limit."""
    if _needs_aux(mode):
        _resting_aux(t, y, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
        F = aux[L.AUX_FNET]
        if (mode == L.MODE_STICK or mode == L.MODE_STOP_LOW) and F > aux[L.AUX_FS_E]:
            y[L.Y_V] = 0.0
            return L.MODE_SLIDE_POS, _record(ev_t, ev_kind, ev_mode, n_ev, t, L.EV_SLIP, L.MODE_SLIDE_POS)
        if (mode == L.MODE_STICK or mode == L.MODE_STOP_HIGH) and -F > aux[L.AUX_FS_R]:
            y[L.Y_V] = 0.0
            return L.MODE_SLIDE_NEG, _record(ev_t, ev_kind, ev_mode, n_ev, t, L.EV_SLIP, L.MODE_SLIDE_NEG)
    return mode, n_ev


@_internal
def _transition(t, y, mode, k, stroke, seg_t0, seg_u0, seg_slope, model, ftmp, aux,
                ev_t, ev_kind, ev_mode, n_ev):
    """Apply the mode change of event ``k`` fired in ``mode``; returns (new mode, n_ev)."""
    if mode == L.MODE_STICK or mode == L.MODE_STOP_LOW or mode == L.MODE_STOP_HIGH:
        new = L.MODE_SLIDE_POS if k == 0 else L.MODE_SLIDE_NEG
        y[L.Y_V] = 0.0
        return new, _record(ev_t, ev_kind, ev_mode, n_ev, t, L.EV_SLIP, new)
    if k == 1:
        # end stop: inelastic, the piston stays until the net force pulls it away; the
        # velocity it arrives with (the state at the located event time) is logged with it
        v_impact = y[L.Y_V]
        y[L.Y_V] = 0.0
        if mode == L.MODE_SLIDE_POS:
            y[L.Y_X] = stroke
            new = L.MODE_STOP_HIGH
        else:
            y[L.Y_X] = 0.0
            new = L.MODE_STOP_LOW
        if n_ev < ev_t.shape[0]:
            ev_t[n_ev, 1] = v_impact
        n_ev = _record(ev_t, ev_kind, ev_mode, n_ev, t, L.EV_STOP, new)
        return _settle(t, y, new, seg_t0, seg_u0, seg_slope, model, ftmp, aux,
                       ev_t, ev_kind, ev_mode, n_ev)
    # velocity reached zero: stick if the net force is within the static limit
    y[L.Y_V] = 0.0
    _resting_aux(t, y, L.MODE_STICK, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
    F = aux[L.AUX_FNET]
    if mode == L.MODE_SLIDE_POS and -F > aux[L.AUX_FS_R]:
        return L.MODE_SLIDE_NEG, _record(ev_t, ev_kind, ev_mode, n_ev, t, L.EV_REVERSE, L.MODE_SLIDE_NEG)
    if mode == L.MODE_SLIDE_NEG and F > aux[L.AUX_FS_E]:
        return L.MODE_SLIDE_POS, _record(ev_t, ev_kind, ev_mode, n_ev, t, L.EV_REVERSE, L.MODE_SLIDE_POS)
    return L.MODE_STICK, _record(ev_t, ev_kind, ev_mode, n_ev, t, L.EV_STICK, L.MODE_STICK)


@_internal
def _event_at(theta, k, mode, h, y0, f0, y1, f1, t0, stroke, seg_t0, seg_u0, seg_slope,
              model, ytmp, ftmp, aux, ev):
    _hermite(theta, h, y0, f0, y1, f1, ytmp)
    if _needs_aux(mode):
        _resting_aux(t0 + theta * h, ytmp, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
    _event_values(mode, ytmp, aux, stroke, ev)
    return ev[k]


# The event location and the back-step below run only when an event is bracketed (a few
# dozen times per simulated second), so they are called helpers of :func:`integrate`. The
# per-step parts (step-size control, sample writing) stay written out in it: as called
# helpers they made the pulse benchmark 15 % slower (a dozen arrays passed per step, seven
# machine words each), and inlined at numba's IR level they lengthened the first compile
# by a quarter (bench_simulator.py and bench_cold_start.py, November 2026).
@_internal
def _locate_event(theta_p, k, mode, h, y0, f0, y1, f1, t0, stroke, seg_t0, seg_u0, seg_slope,
                  model, ytmp, ftmp, aux, ev, g_start, g_end):
    """Event time of event function ``k``, which is <= 0 at the step's start (``g_start``)
    and > 0 at the fraction ``theta_p`` of the step (``g_end``): the Illinois method on the
    step's cubic Hermite interpolant, from the bracket ``[theta_p - 1/3, theta_p]`` (or
    ``[0, theta_p]``), to ``EVENT_TOL`` seconds.

    Returns
    -------
    theta : float
        Upper end of the final bracket, as a fraction of the step [-]
    """
    lo = theta_p - 1.0 / 3.0
    hi = theta_p
    g_lo = _event_at(lo, k, mode, h, y0, f0, y1, f1, t0, stroke, seg_t0, seg_u0, seg_slope,
                     model, ytmp, ftmp, aux, ev)
    g_hi = g_end
    if g_lo > 0.0:
        lo = 0.0
        g_lo = g_start
    side = 0
    while (hi - lo) * h > EVENT_TOL:
        if g_hi != g_lo:
            mid = hi - g_hi * (hi - lo) / (g_hi - g_lo)
        else:
            mid = 0.5 * (lo + hi)
        if not (lo < mid < hi):
            mid = 0.5 * (lo + hi)
        # keep the bracket shrinking geometrically
        if (hi - lo) * h > 1e3 * EVENT_TOL and side != 0 and side % 4 == 0:
            mid = 0.5 * (lo + hi)
        g_mid = _event_at(mid, k, mode, h, y0, f0, y1, f1, t0, stroke, seg_t0, seg_u0, seg_slope,
                          model, ytmp, ftmp, aux, ev)
        if g_mid > 0.0:
            hi = mid
            g_hi = g_mid
            g_lo *= 0.5 if side < 0 else 1.0
            side = -1 if side >= 0 else side - 1
        else:
            lo = mid
            g_lo = g_mid
            g_hi *= 0.5 if side > 0 else 1.0
            side = 1 if side <= 0 else side + 1
        if side > 1000 or side < -1000:
            break
    return hi


@_internal
def _back_step(t, t_ev, theta, h, y, f0, y1, f1, J, ft, mode, seg_t0, seg_u0, seg_slope, model,
               yh, ysave, err, K, W, piv, dinv, ytmp, ftmp, aux, stats, lin):
    """Redo the step from ``(t, y)`` exactly to the event time ``t_ev`` (the paper's ACSL
    back-step) and put the state there into ``y``; the step's interpolant at ``theta``
    when that step fails. ``lin``: the profile of a model with lines in segments
    (:func:`integrate_lines`), or None."""
    n = y.shape[0]
    hb = t_ev - t
    for i in range(n):
        ysave[i] = y[i]
    ok = False
    if hb > 0.0:
        if lin is not None:
            ok = _rodas_step_profile(t, ysave, hb, f0, J, ft, mode, seg_t0, seg_u0, seg_slope,
                                     model, yh, err, K, W, piv, dinv, ytmp, ftmp, aux, stats,
                                     lin)
        else:
            ok = _rodas_step(t, ysave, hb, f0, J, ft, mode, seg_t0, seg_u0, seg_slope, model,
                             yh, err, K, W, piv, dinv, ytmp, ftmp, aux, stats)
        stats[ST_BACKSTEPS] += 1
    if not ok:
        _hermite(theta, h, y, f0, y1, f1, yh)
    for i in range(n):
        y[i] = yh[i]


@njit(cache=True, error_model="numpy")
def finite_difference_jacobians(t, y, mode, u, model, atol, rtol):
    """The core's two forward-difference Jacobians at one state, for checks: the plain one
    (:func:`_jacobian`, one evaluation per active column) and the grouped one
    (:func:`_jacobian_grouped`, one evaluation per column group), with the increments the
    integrator takes. Compiled on first call (not part of the integration core).

    Parameters
    ----------
    t : float
        Time [s]
    y : ndarray
        State (state units)
    mode : int
        Piston mode (``layout.MODE_*``)
    u : float
        Valve command, held [-]
    model : tuple
        The core's model tuple (:func:`pneucore.simulate.build_core`), without user effects
    atol : ndarray
        Absolute tolerance per state (state units)
    rtol : float
        Relative tolerance [-]

    Returns
    -------
    J_dense, J_grouped : ndarray
        ``(n, n)`` Jacobians [state unit / (s state unit)]
    S : ndarray of uint8
        Structural pattern (:func:`_sparsity`)
    n_groups : ndarray of int
        Groups of the sliding modes and of the others [-]
    n_evaluations : ndarray of int
        Right-hand side evaluations each Jacobian took [-]
    """
    n = y.shape[0]
    scale = atol / rtol
    f0 = np.empty(n)
    aux = np.zeros(L.N_AUX)
    _feval(t, y, mode, 0.0, u, 0.0, model, f0, aux)
    S = np.empty((n, n), np.uint8)
    colours = np.empty((2, n), np.int64)
    n_groups = np.zeros(2, np.int64)
    _groups(model[0], model[1], n, S, colours, n_groups, np.empty(n, np.int64),
            np.empty(n, np.int64), np.empty(n, np.uint8), np.empty((n, n), np.uint8))
    Jd = np.zeros((n, n))
    Jg = np.zeros((n, n))
    ft = np.zeros(n)
    ytmp = np.empty(n)
    ftmp = np.empty(n)
    stats_d = np.zeros(N_STATS, np.int64)
    stats_g = np.zeros(N_STATS, np.int64)
    _jacobian(t, y, f0, mode, 0.0, u, 0.0, model, scale, Jd, ft, ytmp, ftmp, aux, stats_d)
    _jacobian_grouped(t, y, f0, mode, 0.0, u, 0.0, model, scale, Jg, ft, ytmp, ftmp, aux,
                      stats_g, S, colours, n_groups, np.empty(n))
    evals = np.empty(2, np.int64)
    evals[0] = stats_d[ST_FEVALS]
    evals[1] = stats_g[ST_FEVALS]
    return Jd, Jg, S, n_groups, evals


@_internal
def _control_segment(t, y, mode, seg_t0, seg_u0, seg_slope, model, ctl, k, ftmp, aux):
    """The held command segment of a closed loop from sample instant ``k`` (``t = k T_s``):
    the controller's law (:func:`pneucore.core.controllers.control_law`) on the signals
    measured at ``t`` and the reference at ``t_k``; the segment ends at ``(k + 1) T_s``.

    ``ctl`` is ``(code, gains, ref, T_s, memory, (u_lo, u_hi), i_sensor, meas, sens,
    noise, sens_state, sensed)`` (:func:`integrate_closed`). The position is read through
    the model's position sensor (:func:`pneucore.physics.sensors.sense_position`: lag, noise,
    resolution); the velocity and acceleration are estimated from that sensed position
    (:func:`pneucore.physics.sensors.estimate_rates`, the filtered differentiator), or are
    the piston's own where ``sens[SENS_IDEAL_RATES]`` is set; the pressures are the
    transducers' states when the model has the pressure-sensor lag (``i_sensor >= 0``), else
    the chambers', plus their noise, quantised to the transducers' resolution. What the law
    read is written to ``sensed[k]``: x [m], v [m/s], a [m/s^2], p_a, p_b [Pa].
    """
    code, g, ref, Ts, cst, urange, i_sens, meas, sens, noise, sst, sensed = ctl
    # the right-hand side at the held command gives the pressures and the acceleration
    _feval(t, y, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
    prm = model[0]
    kk = min(k, ref.shape[0] - 1)
    meas[0] = sense_position(y[L.Y_X], sens, sst, noise[kk, 0])
    if sens[SENS_IDEAL_RATES] != 0.0:
        meas[1] = y[L.Y_V]
        meas[2] = aux[L.AUX_ACC]
    else:
        estimate_rates(meas[0], sst, Ts, sens[SENS_RATE_TAU])
        meas[1] = sst[SST_V]
        meas[2] = sst[SST_A]
    if i_sens >= 0:
        pa = y[i_sens]
        pb = y[i_sens + 1]
    else:
        pa = aux[L.AUX_PA]
        pb = aux[L.AUX_PB]
    meas[3] = quantise(pa + noise[kk, 1], sens[SENS_P_Q])
    meas[4] = quantise(pb + noise[kk, 2], sens[SENS_P_Q])
    meas[5] = prm[L.P_A_A]
    meas[6] = prm[L.P_A_B]
    meas[7] = t
    for i in range(5):
        sensed[kk, i] = meas[i]
    u = control_law(code, g, ref[kk, 0], ref[kk, 1], ref[kk, 2], meas, cst, Ts, urange[0],
                    urange[1])
    return t, u, 0.0, (k + 1) * Ts


# Counters and indices typed as plain int64: a variable first assigned a constant
# (``n_ev = 0``, ``k_ev = -1``) would otherwise be typed as a literal and have every
# callee it reaches compiled once more for that literal (four extra compiles, ~2 s of
# the first call).
_INT_LOCALS = {"n_ev": types.int64, "k_ev": types.int64, "k0": types.int64,
               "k_ctl": types.int64}


@njit(cache=True, nogil=True, error_model="numpy", locals=_INT_LOCALS)
def _run(y0, mode0, model, cmd_t, cmd_u, linear, t_end, t_out, rtol, atol,
         h_max, h_init, max_steps, y_out, aux_out, mode_out, u_out,
         ev_t, ev_kind, ev_mode, stats, lin, ctl=None):
    """The integration of :func:`integrate` (its arguments and returns), with ``ctl`` the
    controller of a closed loop (:func:`integrate_closed`) or None, and ``lin`` the
    structure of a model with lines in segments (:func:`integrate_lines`) or None. Compiled
    once for each: with None, numba prunes the branches on ``lin`` before typing them, so
    the core of a model without a line compiles none of the grouped Jacobian and profile
    factorisation (they made the first compile a third longer)."""
    prm = model[0]
    n = y0.shape[0]
    stroke = prm[L.P_STROKE]
    y = y0.copy()
    y1 = np.empty(n)
    yh = np.empty(n)
    err = np.empty(n)
    f0 = np.empty(n)
    f1 = np.empty(n)
    ftmp = np.empty(n)
    ytmp = np.empty(n)
    ysave = np.empty(n)
    K = np.empty((6, n))
    J = np.zeros((n, n))          # zero: the grouped Jacobian writes its pattern only
    W = np.empty((n, n))
    ft = np.zeros(n)
    piv = np.empty(n, np.int64)
    dinv = np.empty(n)
    aux = np.zeros(L.N_AUX)
    ev = np.empty(2)
    ev0 = np.empty(2)
    ev1 = np.empty(2)
    scale = np.empty(n)
    for i in range(n):
        scale[i] = atol[i] / rtol

    t = 0.0
    n_out = t_out.shape[0]
    k_out = 0
    n_ev = 0
    h = h_init
    mode = mode0
    k_ctl = 0
    if ctl is not None:
        seg_t0, seg_u0, seg_slope, seg_end = _control_segment(
            t, y, mode, 0.0, 0.0, 0.0, model, ctl, k_ctl, ftmp, aux)
    else:
        seg_t0, seg_u0, seg_slope, seg_end = command_segment(t, cmd_t, cmd_u, linear)
    mode, n_ev = _settle(t, y, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux,
                         ev_t, ev_kind, ev_mode, n_ev)
    fresh = True          # f0 must be recomputed (start, event, command switch)
    stuck_count = 0
    max_events = ev_t.shape[0]
    hmin_rel = 1e-13

    while True:
        # samples at the current time (also t = 0)
        if fresh:
            _feval(t, y, mode, seg_t0, seg_u0, seg_slope, model, f0, aux)
            stats[ST_FEVALS] += 1
            fresh = False
        # (sample writing is written out in the three places: a helper taking the output
        # arrays costs ~0.1 ms per simulated second in call overhead)
        while k_out < n_out and t_out[k_out] <= t:
            for i in range(n):
                y_out[k_out, i] = y[i]
            _feval(t_out[k_out], y, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
            for i in range(L.N_AUX):
                aux_out[k_out, i] = aux[i]
            mode_out[k_out] = mode
            u_out[k_out] = seg_u0 + seg_slope * (t_out[k_out] - seg_t0)
            k_out += 1
        if t >= t_end:
            break
        if stats[ST_STEPS] + stats[ST_REJECTED] >= max_steps:
            return ERR_MAX_STEPS, n_ev, t
        if n_ev >= max_events:
            return ERR_EVENTS_OVERFLOW, n_ev, t

        t_stop = min(seg_end, t_end)
        hh = min(h, h_max, t_stop - t)
        last = False
        if t + hh >= t_stop * (1.0 - 1e-15) or t_stop - (t + hh) < 1e-12:
            hh = t_stop - t
            last = True

        if lin is not None:
            _jacobian_grouped(t, y, f0, mode, seg_t0, seg_u0, seg_slope, model, scale, J, ft,
                              ytmp, ftmp, aux, stats, lin[8], lin[9], lin[10], lin[11])
        else:
            _jacobian(t, y, f0, mode, seg_t0, seg_u0, seg_slope, model, scale, J, ft,
                      ytmp, ftmp, aux, stats)
        # --- attempt steps until one is accepted --------------------------------
        while True:
            if lin is not None:
                ok = _rodas_step_profile(t, y, hh, f0, J, ft, mode, seg_t0, seg_u0, seg_slope,
                                         model, y1, err, K, W, piv, dinv, ytmp, ftmp, aux, stats,
                                         lin)
            else:
                ok = _rodas_step(t, y, hh, f0, J, ft, mode, seg_t0, seg_u0, seg_slope, model,
                                 y1, err, K, W, piv, dinv, ytmp, ftmp, aux, stats)
            enorm = np.inf
            if ok and y1[L.Y_MA] > 0.0 and y1[L.Y_TA] > 0.0 and y1[L.Y_MB] > 0.0 and y1[L.Y_TB] > 0.0:
                s = 0.0
                for i in range(n):
                    sc = atol[i] + rtol * max(abs(y[i]), abs(y1[i]))
                    e = err[i] / sc
                    s += e * e
                enorm = math.sqrt(s / n)
            if enorm <= 1.0:
                break
            stats[ST_REJECTED] += 1
            if stats[ST_STEPS] + stats[ST_REJECTED] >= max_steps:
                return ERR_MAX_STEPS, n_ev, t
            if math.isfinite(enorm):
                hh *= max(0.2, 0.9 * enorm ** -0.25)
            else:
                hh *= 0.25
            last = False
            if hh < hmin_rel * max(1.0, t):
                if not ok or not math.isfinite(enorm):
                    return ERR_NONPHYSICAL, n_ev, t
                return ERR_STEP_UNDERFLOW, n_ev, t
        stats[ST_STEPS] += 1
        if enorm > 0.0:
            fac = min(6.0, max(0.2, 0.9 * enorm ** -0.25))
        else:
            fac = 6.0
        h_next = hh * fac
        t1 = t_stop if last else t + hh
        _feval(t1, y1, mode, seg_t0, seg_u0, seg_slope, model, f1, aux)
        stats[ST_FEVALS] += 1

        # --- state events within (t, t1] -----------------------------------------
        k_ev = -1
        k0 = 0
        th_best = 2.0
        if mode != L.MODE_LOCKED:
            _event_at(0.0, k0, mode, hh, y, f0, y1, f1, t, stroke, seg_t0, seg_u0, seg_slope,
                      model, ytmp, ftmp, aux, ev0)
            # probe the end and two interior points so a brief excursion is not missed
            for probe in range(3):
                theta_p = (probe + 1) / 3.0
                _event_at(theta_p, k0, mode, hh, y, f0, y1, f1, t, stroke, seg_t0, seg_u0,
                          seg_slope, model, ytmp, ftmp, aux, ev1)
                for k in range(2):
                    if ev1[k] > 0.0 and ev0[k] <= 0.0 and k_ev < 0:
                        hi = _locate_event(theta_p, k, mode, hh, y, f0, y1, f1, t, stroke, seg_t0,
                                           seg_u0, seg_slope, model, ytmp, ftmp, aux, ev, ev0[k],
                                           ev1[k])
                        if hi < th_best:
                            th_best = hi
                            k_ev = k
                if k_ev >= 0:
                    break

        if k_ev >= 0:
            # samples strictly before the event come from this step's interpolant
            t_ev = t + th_best * hh
            while k_out < n_out and t_out[k_out] < t_ev:
                theta = (t_out[k_out] - t) / hh
                _hermite(theta, hh, y, f0, y1, f1, ytmp)
                for i in range(n):
                    y_out[k_out, i] = ytmp[i]
                _feval(t_out[k_out], ytmp, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
                for i in range(L.N_AUX):
                    aux_out[k_out, i] = aux[i]
                mode_out[k_out] = mode
                u_out[k_out] = seg_u0 + seg_slope * (t_out[k_out] - seg_t0)
                k_out += 1
            # back-step: redo the step exactly from t to the event time
            _back_step(t, t_ev, th_best, hh, y, f0, y1, f1, J, ft, mode, seg_t0, seg_u0, seg_slope,
                       model, yh, ysave, err, K, W, piv, dinv, ytmp, ftmp, aux, stats, lin)
            hb = t_ev - t
            t = t_ev
            if hb <= 10.0 * EVENT_TOL:
                stuck_count += 1
                if stuck_count > 1000:
                    return ERR_CHATTER, n_ev, t
            else:
                stuck_count = 0
            # confirm on the exact state (interpolant and exact step may differ slightly)
            if _needs_aux(mode):
                _resting_aux(t, y, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
            _event_values(mode, y, aux, stroke, ev)
            n_before = n_ev
            if ev[k_ev] > -1e-9 * (1.0 + abs(aux[L.AUX_FNET])) or mode == L.MODE_SLIDE_POS \
                    or mode == L.MODE_SLIDE_NEG:
                mode, n_ev = _transition(t, y, mode, k_ev, stroke, seg_t0, seg_u0, seg_slope, model,
                                         ftmp, aux, ev_t, ev_kind, ev_mode, n_ev)
            if n_ev > n_before:
                stats[ST_EVENTS] += n_ev - n_before
            fresh = True
            h = max(min(hh, h_next), 1e-7)
            continue

        # --- accepted step without state event: samples in (t, t1] --------------------
        # (a sample exactly at a command breakpoint is taken after the switch: the
        # command is right-continuous, u(t_k) = u_k)
        at_switch = last and t_stop == seg_end and t_stop < t_end
        while k_out < n_out and (t_out[k_out] < t1 or (t_out[k_out] == t1 and not at_switch)):
            theta = (t_out[k_out] - t) / (t1 - t)
            _hermite(theta, t1 - t, y, f0, y1, f1, ytmp)
            for i in range(n):
                y_out[k_out, i] = ytmp[i]
            _feval(t_out[k_out], ytmp, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux)
            for i in range(L.N_AUX):
                aux_out[k_out, i] = aux[i]
            mode_out[k_out] = mode
            u_out[k_out] = seg_u0 + seg_slope * (t_out[k_out] - seg_t0)
            k_out += 1
        stuck_count = 0
        for i in range(n):
            y[i] = y1[i]
            f0[i] = f1[i]
        t = t1
        if not last or t_stop < seg_end:
            h = h_next
        else:
            h = max(h_next, hh)
        if last and t_stop == seg_end and t < t_end:
            if ctl is not None:
                # controller sample instant: the law's new output, held to the next one (not
                # logged as an event: a thousand per second would fill the log)
                k_ctl += 1
                seg_t0, seg_u0, seg_slope, seg_end = _control_segment(
                    t, y, mode, seg_t0, seg_u0, seg_slope, model, ctl, k_ctl, ftmp, aux)
            else:
                # command breakpoint: new segment, log a switch if the value jumps
                u_left = seg_u0 + seg_slope * (t - seg_t0)
                seg_t0, seg_u0, seg_slope, seg_end = command_segment(t, cmd_t, cmd_u, linear)
                if seg_u0 != u_left:
                    n_ev = _record(ev_t, ev_kind, ev_mode, n_ev, t, L.EV_COMMAND, mode)
                    stats[ST_EVENTS] += 1
                    h = min(h, 1e-4)
            fresh = True
            mode, n_ev = _settle(t, y, mode, seg_t0, seg_u0, seg_slope, model, ftmp, aux,
                                 ev_t, ev_kind, ev_mode, n_ev)
    return OK, n_ev, t


@njit(cache=True, nogil=True, error_model="numpy", locals=_INT_LOCALS)
def integrate(y0, mode0, model, cmd_t, cmd_u, linear, t_end, t_out, rtol, atol,
              h_max, h_init, max_steps, y_out, aux_out, mode_out, u_out,
              ev_t, ev_kind, ev_mode, stats):
    """Integrate from t = 0 to ``t_end`` and sample at ``t_out``.

    Parameters
    ----------
    y0 : ndarray
        Initial state (copied)
    mode0 : int
        Initial piston mode (``layout.MODE_*``); resting modes are
        released at once if the force allows
    model : tuple
        ``(prm, iy, tx, tC, tb, tm, toff, prm_user, scratch)``, see :mod:`pneucore.core.rhs`
    cmd_t, cmd_u : ndarray
        Command breakpoints [s], [-]
    linear : bool
        Linear interpolation of the command (else zero-order hold)
    t_end : float
        End time [s]
    t_out : ndarray
        Increasing sample times in [0, t_end] [s]
    rtol : float
        Relative tolerance [-]
    atol : ndarray
        Absolute tolerance per state (state units)
    h_max, h_init : float
        Largest and first step [s]
    max_steps : int
        Step budget
    y_out, aux_out, mode_out, u_out : ndarray
        Outputs at ``t_out``
    ev_t, ev_kind, ev_mode : ndarray
        Event log: ``ev_t[k] = (time [s], piston velocity at an end stop's impact [m/s])``
        (the second column is written for ``stop`` events only), ``layout.EV_*``, mode after
    stats : ndarray of int
        Solver statistics (``ST_*`` slots)

    Returns
    -------
    status : int
        ``OK`` or an ``ERR_*`` code (see ``STATUS_MESSAGES``)
    n_events : int
        Number of events (may exceed the log size on overflow)
    t_reached : float
        Time reached [s]
    """
    return _run(y0, mode0, model, cmd_t, cmd_u, linear, t_end, t_out, rtol, atol, h_max, h_init,
                max_steps, y_out, aux_out, mode_out, u_out, ev_t, ev_kind, ev_mode, stats, None)


@njit(cache=True, nogil=True, error_model="numpy")
def integrate_lines(y0, mode0, model, cmd_t, cmd_u, linear, t_end, t_out, rtol, atol,
                    h_max, h_init, max_steps, y_out, aux_out, mode_out, u_out,
                    ev_t, ev_kind, ev_mode, stats):
    """:func:`integrate` for a model with lines in segments (same arguments and returns): the
    Jacobian's columns grouped on its structural sparsity (:func:`_groups`), the step's
    linear systems factorised over their profile (:func:`_profile`). A core of its own,
    compiled on first use, so that the core of a model without a line compiles none of it;
    a model whose pattern is dense after all (a user hook) runs the plain core.
    """
    n = y0.shape[0]
    S = np.empty((n, n), np.uint8)
    colours = np.empty((2, n), np.int64)
    n_groups = np.zeros(2, np.int64)
    cell = np.empty(n, np.int64)
    port = np.empty(n, np.int64)
    if not _groups(model[0], model[1], n, S, colours, n_groups, cell, port,
                   np.empty(n, np.uint8), np.empty((n, n), np.uint8)):
        return _run(y0, mode0, model, cmd_t, cmd_u, linear, t_end, t_out, rtol, atol, h_max,
                    h_init, max_steps, y_out, aux_out, mode_out, u_out, ev_t, ev_kind, ev_mode,
                    stats, None)
    order = np.arange(n)
    lo0 = np.empty(n, np.int64)
    hi0 = np.empty(n, np.int64)
    rowptr = np.zeros(n + 1, np.int64)
    _profile_order(n, cell, port, order)
    cols = np.empty(_profile(S, n, order, lo0, hi0, rowptr, order, False), np.int64)
    _profile(S, n, order, lo0, hi0, rowptr, cols, True)
    lin = (order, np.empty(n, np.int64), np.empty(n, np.int64), np.empty(n), lo0, hi0, rowptr,
           cols, S, colours, n_groups, np.empty(n))
    return _run(y0, mode0, model, cmd_t, cmd_u, linear, t_end, t_out, rtol, atol, h_max, h_init,
                max_steps, y_out, aux_out, mode_out, u_out, ev_t, ev_kind, ev_mode, stats, lin)


@njit(cache=True, nogil=True, error_model="numpy")
def integrate_closed(y0, mode0, model, ctl, t_end, t_out, rtol, atol, h_max, h_init, max_steps,
                     y_out, aux_out, mode_out, u_out, ev_t, ev_kind, ev_mode, stats):
    """:func:`integrate` with the loop closed inside the core (issue 42): the valve command is
    a controller's output, evaluated at the sample instants ``k T_s`` on the measured state and
    held between them (zero-order hold), in place of a command table. Each instant ends a
    step exactly, as a command breakpoint does; no event is logged for it. The other
    arguments and the returns are :func:`integrate`'s (``u_out``: the controller's output at
    the samples [-]). Models with lines in segments run with the dense Jacobian.

    Parameters
    ----------
    ctl : tuple
        ``(code, gains, ref, T_s, memory, urange, i_sensor, meas, sens, noise, sens_state,
        sensed)``: controller code (``pneucore.core.controllers.CTL_*``) [-], gains (SI),
        reference ``(n, 3)`` of ``x [m], v [m/s], a [m/s^2]`` at ``t_k = k T_s``, sample
        period [s], controller memory (``CST_*``, updated: the valve switchings are read
        from it), valve range ``(u_lo, u_hi)`` [-], first pressure-sensor state or -1, work
        vector of ``N_MEAS`` floats, sensor parameters
        (:data:`pneucore.physics.sensors.SENS_Q` ...: position resolution [m], position lag
        [s], T_s [s], rate filter time constant [s], ideal-rates flag [-], pressure resolution
        [Pa]), noise ``(n, 3)`` added at ``t_k`` to the position [m] and the two pressures
        [Pa], the sensors' state (``N_SST`` floats, zeros), what the law read at each
        ``t_k`` ``(n, 5)``: x [m], v [m/s], a [m/s^2], p_a, p_b [Pa] (written)
    """
    cmd = np.zeros(1)
    return _run(y0, mode0, model, cmd, cmd, False, t_end, t_out, rtol, atol, h_max, h_init,
                max_steps, y_out, aux_out, mode_out, u_out, ev_t, ev_kind, ev_mode, stats, None,
                ctl)


def closed_core_for(hook, flow_laws, friction_laws):
    """:func:`integrate_closed`, or its copy for a user hook or other law tables
    (:func:`specialize`; see :func:`core_for`)."""
    from pneucore.core import rhs as rhs_module

    if hook is rhs_module.no_terms and flow_laws == rhs_module.flow_laws \
            and friction_laws == rhs_module.friction_laws:
        return integrate_closed
    specialize(hook, flow_laws, friction_laws)
    return _SPECIALIZED[(hook, tuple(flow_laws), tuple(friction_laws))]["integrate_closed"]


_WITH_LAW = {}


def closed_core_with_law(law):
    """A compiled copy of :func:`integrate_closed` whose controller code ``CTL_USER`` calls
    ``law`` (a user's controller, :func:`pneucore.control.controllers.register_user_controller`):
    :func:`pneucore.core.controllers.control_law` re-created with ``user_law`` bound to it, and
    every function of this module on the way to it (:func:`_chain`) re-created to call the
    copy, as :func:`specialize` does for a user hook. Compiled in memory on first use (about
    the first compile of the core), memoised per law; the default hook and law tables only.

    Parameters
    ----------
    law : numba dispatcher
        ``law(g, x_ref, v_ref, a_ref, meas, cst, Ts, u_lo, u_hi) -> u``

    Returns
    -------
    integrate_closed : numba dispatcher
        Same signature as :func:`integrate_closed`
    """
    from pneucore.core import controllers as ctl_module

    if law in _WITH_LAW:
        return _WITH_LAW[law]
    ctl_globals = dict(ctl_module.__dict__)
    ctl_globals["user_law"] = law
    glb = dict(globals())
    glb["control_law"] = _clone(ctl_module.control_law, ctl_globals)
    for name in _chain(globals(), __name__, ("control_law",)):
        glb[name] = _clone(globals()[name], glb)
    _WITH_LAW[law] = glb["integrate_closed"]
    return _WITH_LAW[law]


def has_lines(model):
    """Whether a core model tuple (:func:`pneucore.simulate.build_core`) holds a line in
    segments on either port (a line term's state position set), which
    :func:`integrate_lines` integrates.

    Parameters
    ----------
    model : tuple
        ``(prm, iy, ...)``

    Returns
    -------
    lines : bool
        A line term is present [-]
    """
    from pneucore.physics.states import LINE_TERMS

    iy = model[1]
    return any(iy[L.STATE_IY0[name] + k] >= 0 for name in LINE_TERMS for k in range(2))


_SPECIALIZED = {}

#: Names a specialised core rebinds in :mod:`pneucore.core.rhs`: the user hook and the law tables
_REBOUND = ("user_terms", "flow_laws", "friction_laws")


def _chain(namespace, module, seeds):
    """Compiled functions of ``module`` that refer to a name in ``seeds``, directly or
    through each other: those a specialised core must re-create (:func:`specialize`).

    Found from the code, so that a new helper on the way joins without an edit here
    (one left out would silently call the default core's right-hand side).

    Parameters
    ----------
    namespace : dict
        The module's globals
    module : str
        The module's name (functions defined elsewhere are not cloned)
    seeds : iterable of str
        Rebound names

    Returns
    -------
    names : tuple of str
        In a stable (sorted) order
    """
    funcs = {name: v for name, v in namespace.items()
             if isinstance(v, CPUDispatcher) and v.py_func.__module__ == module}
    refs = {name: _code_names(f.py_func.__code__) for name, f in funcs.items()}
    chain = set()
    targets = set(seeds)
    while True:
        new = {name for name in funcs if name not in chain and refs[name] & targets}
        if not new:
            return tuple(sorted(chain))
        chain |= new
        targets |= new


def _clone(dispatcher, glb):
    """A new dispatcher of ``dispatcher``'s Python function bound to the globals ``glb``.

    It keeps the original's compile options (notably ``_nrt=False``) except the
    on-disk cache: the clone's globals are not those of its source file.
    """
    import types

    f = dispatcher.py_func
    opts = {k: v for k, v in dispatcher.targetoptions.items() if k != "cache"}
    return jit(**opts)(types.FunctionType(f.__code__, glb, f.__name__, f.__defaults__,
                                          f.__closure__))


def specialize(hook=None, flow_laws=None, friction_laws=None, lines=False):
    """A compiled copy of :func:`integrate` (or :func:`integrate_lines`) with another user hook
    or other law tables.

    The default core (``rhs.user_terms = no_terms``, the built-in laws'
    tables ``rhs.flow_laws`` and ``rhs.friction_laws``) is compiled once and
    cached on disk. A model with user-registered effects, or naming a flow or
    friction law registered at run time, needs the same code with those names
    rebound: every function of the call chain is re-created with a globals
    dict in which ``user_terms`` is the user's hook, the tables are the
    registries' (:func:`pneucore.core.rhs.law_table`) and each chain function
    refers to its clone. Compiled in memory on first use, memoised per hook and
    tables: about the first compile of the core (12 s of CPU time for a
    registered flow law on the shared 2-core machine, against 10 s for the
    default core), since numba cannot cache a function whose globals are not
    its source file's.

    Parameters
    ----------
    hook : numba dispatcher or None
        ``hook(t, y, sig, prm_user, terms, dy)``; None: ``rhs.no_terms``
    flow_laws : tuple or None
        Flow-law table ``((code, law), ...)``; None: the built-in one
    friction_laws : tuple or None
        Friction-law table ``((code, force, static), ...)``; None: the built-in one
    lines : bool
        The copy of :func:`integrate_lines` (a model with lines in segments) [-]

    Returns
    -------
    integrate : numba dispatcher
        Same signature as :func:`integrate`
    """
    from pneucore.core import rhs as rhs_module

    hook = rhs_module.no_terms if hook is None else hook
    flow_laws = rhs_module.flow_laws if flow_laws is None else tuple(flow_laws)
    friction_laws = rhs_module.friction_laws if friction_laws is None else tuple(friction_laws)
    key = (hook, flow_laws, friction_laws)
    entry = "integrate_lines" if lines else "integrate"
    if key in _SPECIALIZED:
        return _SPECIALIZED[key][entry]
    # the rhs module's own names: the component laws as published, each cached on disk
    # (a process that loaded the default core from the cache has not compiled the
    # wrapper-less copies, and these would be compiled afresh in every process)
    rhs_globals = dict(rhs_module.__dict__)
    rhs_globals.update(user_terms=hook, flow_laws=flow_laws, friction_laws=friction_laws)
    rhs_chain = _chain(rhs_module.__dict__, rhs_module.__name__, _REBOUND)
    for name in rhs_chain:
        rhs_globals[name] = _clone(getattr(rhs_module, name), rhs_globals)
    glb = dict(globals())
    # this module's copies of rhs functions (rhs, static_friction) become the clones
    imported = {name for name, v in globals().items() if isinstance(v, CPUDispatcher)
                and v.py_func.__module__ == rhs_module.__name__ and name in rhs_chain}
    for name in imported:
        glb[name] = rhs_globals[name]
    for name in _chain(globals(), __name__, imported):
        glb[name] = _clone(globals()[name], glb)
    _SPECIALIZED[key] = {name: glb[name] for name in ("integrate", "integrate_lines",
                                                      "integrate_closed")}
    return glb[entry]


def core_for(hook, flow_laws, friction_laws, lines=False):
    """The compiled core for a user hook and law tables: :func:`integrate` itself when they
    are the defaults (cached on disk), else :func:`specialize`'s copy; :func:`integrate_lines`
    (or its copy) for a model with lines in segments.

    Parameters
    ----------
    hook : numba dispatcher
        User-effect hook (``rhs.no_terms`` when the model has none)
    flow_laws, friction_laws : tuple
        Law tables (:func:`pneucore.core.rhs.law_table`)
    lines : bool
        The model holds a line in segments (:func:`has_lines`) [-]
    """
    from pneucore.core import rhs as rhs_module

    if hook is rhs_module.no_terms and flow_laws == rhs_module.flow_laws \
            and friction_laws == rhs_module.friction_laws:
        return integrate_lines if lines else integrate
    return specialize(hook, flow_laws, friction_laws, lines)
