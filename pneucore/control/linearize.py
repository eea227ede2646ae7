"""Linearisation of the actuator at an operating point (issue 42, item 5).

The state-space model ``dx/dt = A dx + B du``, ``dy = C dx + D du`` is taken from the very
right-hand side the integrator uses (:func:`pneucore.core.rhs.rhs`: the chamber energy and
mass balances, paper Eq. 14-15 with Eq. 23-24, and Newton's law with friction, Eq. 17-20)
by central differences, the piston free (sliding mode, so the mechanical states are not
frozen). The input is the valve command ``u`` [-], the output the position ``x`` [m].

For closed chambers (valve inside its overlap, no leak) and no friction the mechanical
pair of poles has the natural frequency of the pneumatic spring

.. math:: \\omega_n = \\sqrt{k (A_a^2 p_a / V_a + A_b^2 p_b / V_b) / m}

with ``k = 1`` for an isothermal gas and ``k = gamma`` for an adiabatic one (absolute
pressures, chamber volumes including the dead volumes): :func:`closed_form_natural_frequency`.

Notes
-----
* The Coulomb friction of Eq. 18 is constant along a sliding direction: it shifts the
  equilibrium, not the linear dynamics; the viscous part and its pressure dependence
  (Eq. 19-20) enter ``A``.
* A valve with spool overlap (the paper's 15 %, Fig. 2) has no flow gain at ``u = 0``:
  ``B`` is then zero there and the transfer position/command vanishes; give
  ``operating_point.u`` beyond the overlap, or a critically lapped valve, to see it.
* User effects that add compiled terms are included only through the default hook
  (:func:`pneucore.core.rhs.rhs`): a model with such an effect is refused.
"""
from __future__ import annotations

import math

import numpy as np

from pneucore.core import layout as L
from pneucore.core.rhs import rhs
from pneucore.physics.jack import net_pressure_force
from pneucore.description.effects import EFFECTS
from pneucore.description.model import Model
from pneucore.description.validation import FieldError

#: Relative central-difference step on each state, against its scale (atol / rtol of the
#: core): the truncation error is O(step^2) ~ 1e-12, the rounding error ~ 1e-16 / 1e-6 =
#: 1e-10 relative: both far below the 2 % the closed-form check asks for
REL_STEP = 1e-6
#: Command step [-] of the input column (an opening of 1e-4 is within one table segment)
DU = 1e-4


def equilibrium_pressures(model, x, p_a=None, p_b=None):
    """Chamber pressures [Pa abs] that balance the piston at rest (paper Eq. 17, net force 0).

    With one pressure given the other is solved from the force balance; with neither, the
    mean of the two is held at the middle of supply and ambient, ``(p_s + p_atm) / 2`` (the
    null of a symmetric, critically lapped valve, Eq. 1-3 with equal conductances).

    Parameters
    ----------
    model : Model
        The actuator (effective: effects' transforms applied)
    x : float
        Position [m] (not used by the force balance without a spring; kept for the spring)
    p_a, p_b : float or None
        Chamber pressures [Pa abs]; None = solved

    Returns
    -------
    p_a, p_b : float
        Pressures [Pa abs]
    """
    j = model.jack
    p_atm = model.ambient.pressure

    def force(pa, pb):
        return net_pressure_force(pa, pb, p_atm, j.area_a, j.area_b, j.rod_area_a, j.rod_area_b,
                                  j.total_load)
    if p_a is not None and p_b is not None:
        return float(p_a), float(p_b)
    if p_a is not None:
        return float(p_a), float((force(p_a, 0.0)) / j.area_b)
    if p_b is not None:
        return float(-force(0.0, p_b) / j.area_a), float(p_b)
    p_mean = 0.5 * (model.supply.pressure + p_atm)
    # F(pa, pb) = pa A_a - pb A_b + F0 = 0 with pa + pb = 2 p_mean
    f0 = force(0.0, 0.0)
    pa = (2.0 * p_mean * j.area_b - f0) / (j.area_a + j.area_b)
    return float(pa), float(2.0 * p_mean - pa)


def closed_form_natural_frequency(model, x, p_a, p_b, k):
    """Natural frequency [rad/s] of the pneumatic spring, closed chambers, no friction:
    ``sqrt(k (A_a^2 p_a / V_a + A_b^2 p_b / V_b) / m)``.

    Parameters
    ----------
    model : Model
        The actuator
    x : float
        Position [m]
    p_a, p_b : float
        Chamber pressures [Pa abs]
    k : float
        Polytropic exponent: 1 isothermal, gamma adiabatic [-]

    Examples
    --------
    >>> from pneucore import model_preset
    >>> from pneucore.description.model import Model
    >>> m = Model.from_dict(model_preset("paper-4way"))
    >>> round(closed_form_natural_frequency(m, 0.125, 4e5, 4e5, 1.0) / (2 * math.pi), 1)
    7.3
    """
    j = model.jack
    V_a, V_b = j.volumes(x)
    return math.sqrt(k * (j.area_a ** 2 * p_a / V_a + j.area_b ** 2 * p_b / V_b) / j.moving_mass)


def _check_effects(model):
    hooked = [n for n in model.effects if n in EFFECTS and EFFECTS[n].terms is not None]
    if hooked:
        raise FieldError("model.effects", f"effects {hooked} add compiled terms the "
                         "linearisation does not include; remove them to linearise [-]")


def linearize(model, x=None, p_a=None, p_b=None, u=0.0, frequencies=None):
    """State-space model of the actuator at an operating point.

    Parameters
    ----------
    model : Model or dict
        The actuator
    x : float or None
        Position [m]; None = mid-stroke
    p_a, p_b : float or None
        Chamber pressures [Pa abs]; None = the equilibrium (:func:`equilibrium_pressures`):
        both None, the valve's null (:func:`_null_pressures`) where it has flow gain
    u : float
        Valve command at the operating point [-]
    frequencies : array_like or None
        Frequencies of the response position/command [Hz]; None = 60 points, 0.1-1000 Hz

    Returns
    -------
    lin : dict
        ``A`` (n x n) [state unit / (s state unit)], ``B`` (n x 1), ``C`` (1 x n), ``D``
        (1 x 1), ``states`` (names), ``state_units``, ``poles`` (complex) [1/s],
        ``natural_frequency`` [Hz] and ``damping`` [-] of the mechanical mode,
        ``operating_point`` ``{x [m], p_a, p_b [Pa], u [-]}``, ``frequency_response``
        ``{f [Hz], magnitude [m], phase [deg]}`` of x/u, and ``closed_form``: the
        natural frequency [Hz] of :func:`closed_form_natural_frequency` with k = 1 and
        k = gamma
    """
    from pneucore.simulate import build_core
    from pneucore.description.effects import effective_model
    from pneucore.description.scenario import Scenario

    model = Model.from_dict(model) if not isinstance(model, Model) else model
    _check_effects(model)
    eff = effective_model(model)
    stroke = eff.jack.stroke
    if x is None:
        x = 0.5 * stroke
    if not (math.isfinite(x) and 0.0 < x < stroke):
        raise FieldError("operating_point.x", f"position {x!r} m must lie strictly within "
                         f"the stroke (0, {stroke:g}) m")
    for name, p in (("p_a", p_a), ("p_b", p_b)):
        if p is not None and not (math.isfinite(p) and p > 0.0):
            raise FieldError(f"operating_point.{name}", f"pressure {p!r} must be a finite "
                             "absolute pressure > 0 [Pa]")
    lo, hi = model.valve.opening_range
    if not (math.isfinite(u) and lo <= u <= hi):
        raise FieldError("operating_point.u", f"command {u!r} is outside the valve's range "
                         f"[{lo:g}, {hi:g}] [-]")
    if eff.b_chamber_pressure is not None:
        p_b = eff.b_chamber_pressure
    null = p_a is None and p_b is None
    p_a, p_b = equilibrium_pressures(eff, x, p_a, p_b)
    if eff.b_chamber_pressure is not None:
        p_b = eff.b_chamber_pressure
    if null:
        p_a, p_b = _null_pressures(model, eff, x, u, p_a, p_b)
    initial = {"p_a": p_a} if eff.b_chamber_pressure is not None else {"p_a": p_a, "p_b": p_b}
    scen = Scenario.from_dict({"x0": x, "initial": initial, "command": [[0.0, u]],
                               "duration": 1.0}, model)
    core = build_core(model, scen)
    y0 = core["y0"].copy()
    prm, iy, tx, tC, tb, tm, toff, prm_user, scratch = core["model"]
    scale = np.maximum(np.abs(y0), core["atol"] / scen.solver.rtol)
    n = y0.shape[0]
    mode = L.MODE_SLIDE_POS
    aux = np.zeros(L.N_AUX)

    def f(y, uu):
        dy = np.zeros(n)
        rhs(0.0, y, mode, uu, prm, iy, tx, tC, tb, tm, toff, prm_user, scratch, dy, aux)
        return dy

    A = np.empty((n, n))
    for j in range(n):
        d = REL_STEP * scale[j]
        yp = y0.copy()
        ym = y0.copy()
        yp[j] += d
        ym[j] -= d
        A[:, j] = (f(yp, u) - f(ym, u)) / (2.0 * d)
    up, um = min(u + DU, hi), max(u - DU, lo)
    B = ((f(y0, up) - f(y0, um)) / (up - um)).reshape(n, 1)
    C = np.zeros((1, n))
    C[0, L.Y_X] = 1.0
    D = np.zeros((1, 1))
    poles = np.linalg.eigvals(A)
    wn, zeta = _mechanical_mode(A, scale)
    if frequencies is None:
        frequencies = np.logspace(-1, 3, 60)
    freq = np.asarray(frequencies, float)
    G = np.array([(C @ np.linalg.solve(2j * math.pi * fk * np.eye(n) - A, B) + D)[0, 0]
                  for fk in freq])
    gamma = eff.gas.gamma
    names = core["state_names"]
    return {
        "A": A, "B": B, "C": C, "D": D, "states": names,
        "state_units": [L.STATE_UNITS.get(s, "") for s in names],
        "poles": poles,
        "natural_frequency": wn / (2.0 * math.pi), "damping": zeta,
        "operating_point": {"x": float(x), "p_a": float(p_a), "p_b": float(p_b), "u": float(u)},
        "frequency_response": {"f": freq, "magnitude": np.abs(G),
                               "phase": np.degrees(np.unwrap(np.angle(G)))},
        "closed_form": {
            "isothermal": closed_form_natural_frequency(eff, x, p_a, p_b, 1.0) / (2 * math.pi),
            "adiabatic": closed_form_natural_frequency(eff, x, p_a, p_b, gamma) / (2 * math.pi)},
    }


def _null_pressures(model, eff, x, u, p_a, p_b):
    """The valve's null pressures at the command ``u``: the force balance (Eq. 17) with chamber
    A's pressure where the flow into it for ``u + DU`` is the opposite of that for ``u - DU``
    (supply and exhaust edges pass the same flow, paper Eq. 4-5), found by bisection between
    ambient and supply. A valve with no flow either side (inside an overlap) keeps ``p_a``,
    ``p_b`` (:func:`equilibrium_pressures`). This is the operating point of a critically
    lapped valve at rest, about which its flow gain is the same both ways."""
    from pneucore.simulate import build_core
    from pneucore.description.scenario import Scenario

    lo_u, hi_u = model.valve.opening_range
    if eff.b_chamber_pressure is not None or u - DU < lo_u or u + DU > hi_u:
        return p_a, p_b
    scen = Scenario.from_dict({"x0": x, "initial": {"p_a": p_a, "p_b": p_b},
                               "command": [[0.0, u]], "duration": 1.0}, model)
    core = build_core(model, scen)
    y0 = core["y0"]
    prm, iy, tx, tC, tb, tm, toff, prm_user, scratch = core["model"]
    aux = np.zeros(L.N_AUX)
    n = y0.shape[0]

    def imbalance(pa):
        pa, pb = equilibrium_pressures(eff, x, pa, None)
        y = y0.copy()
        y[L.Y_MA] *= pa / p_a
        y[L.Y_MB] *= pb / p_b
        q = []
        for uu in (u + DU, u - DU):
            dy = np.zeros(n)
            rhs(0.0, y, L.MODE_STICK, uu, prm, iy, tx, tC, tb, tm, toff, prm_user, scratch, dy,
                aux)
            q.append(dy[L.Y_MA])
        return q[0] + q[1], q[0] - q[1]
    lo, hi = eff.ambient.pressure * 1.001, eff.supply.pressure * 0.999
    f_lo, gain = imbalance(lo)
    f_hi, _ = imbalance(hi)
    if gain == 0.0 or f_lo * f_hi > 0.0:
        return p_a, p_b
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        f_mid, _ = imbalance(mid)
        if (f_mid > 0.0) == (f_lo > 0.0):
            lo, f_lo = mid, f_mid
        else:
            hi = mid
    return equilibrium_pressures(eff, x, 0.5 * (lo + hi), None)


def _mechanical_mode(A, scale):
    """Natural frequency [rad/s] and damping [-] of the mode in which the piston takes most
    part: eigenvectors of the state matrix in scaled states (each state over its scale), the
    pair of eigenvalues whose vectors weigh most on ``x`` and ``v``. A complex pair gives
    ``|s|`` and ``-Re s / |s|``; two real ones ``sqrt(s1 s2)`` and ``-(s1 + s2) / (2 w_n)``.
    """
    Ds = np.diag(scale)
    As = np.linalg.solve(Ds, A @ Ds)
    w, V = np.linalg.eig(As)
    Vn = V / np.linalg.norm(V, axis=0)
    weight = np.abs(Vn[L.Y_X]) + np.abs(Vn[L.Y_V])
    order = np.argsort(-weight)
    s1 = w[order[0]]
    if abs(s1.imag) > 0.0:
        wn = abs(s1)
        return float(wn), float(-s1.real / wn) if wn > 0 else 0.0
    s2 = w[order[1]]
    prod = (s1 * s2).real
    if prod <= 0.0:
        return 0.0, float("nan")
    wn = math.sqrt(prod)
    return wn, float(-(s1 + s2).real / (2.0 * wn))


def discretize(A, B, sample_period):
    r"""The state-space model ``dx/dt = A x + B u`` sampled with a zero-order hold (a controller
    that holds its output between samples, as the closed loop's core does).

    .. math:: A_d = e^{A T_s}, \qquad B_d = \int_0^{T_s} e^{A s} \, ds \; B

    both read off one matrix exponential of the augmented matrix ``[[A, B], [0, 0]] T_s``
    (Van Loan 1978, "Computing integrals involving the matrix exponential").

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix (:func:`linearize`'s ``A``) [SI per s]
    B : array_like, shape (n,) or (n, 1)
        Input matrix, one input (:func:`linearize`'s ``B``) [SI per s]
    sample_period : float
        Controller sample period T_s [s]

    Returns
    -------
    Ad : ndarray, shape (n, n)
        Discrete state matrix [-]
    Bd : ndarray, shape (n,)
        Discrete input matrix [SI]

    Examples
    --------
    An integrator ``dx/dt = u`` held for 0.1 s moves by 0.1 u:

    >>> Ad, Bd = discretize([[0.0]], [1.0], 0.1)
    >>> float(Ad[0, 0]), round(float(Bd[0]), 12)
    (1.0, 0.1)
    """
    from scipy.linalg import expm
    A = np.asarray(A, float)
    B = np.asarray(B, float).reshape(A.shape[0], -1)[:, 0]
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n] = A * sample_period
    M[:n, n] = B * sample_period
    E = expm(M)
    return E[:n, :n], E[:n, n]


def to_json(lin):
    """:func:`linearize`'s result as plain JSON (complex poles as ``[re, im]``)."""
    fr = lin["frequency_response"]
    return {
        "natural_frequency": lin["natural_frequency"], "damping": lin["damping"],
        "poles": [[float(p.real), float(p.imag)] for p in lin["poles"]],
        "A": lin["A"].tolist(), "B": lin["B"].tolist(), "C": lin["C"].tolist(),
        "D": lin["D"].tolist(), "states": list(lin["states"]),
        "state_units": lin["state_units"], "operating_point": lin["operating_point"],
        "frequency_response": {"f": fr["f"].tolist(), "magnitude": fr["magnitude"].tolist(),
                               "phase": fr["phase"].tolist()},
        "closed_form": lin["closed_form"],
    }
