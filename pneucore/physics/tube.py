"""A pneumatic line (tube) between valve and cylinder: lumped (its volume and its ISO 6358
characteristic), or in segments inside the compiled core.

Lumped (the ``tubing`` effect's ``segments`` = 1, the default): its volume
``pi d^2 L / 4`` joins the chamber's dead volume (paper Eq. 23-24) and its flow
resistance is a restriction in series with the valve edges of its port (ISO 6358-3,
:mod:`pneucore.physics.series`). A lumped line neglects the transport delay ``L / c``
(6 ms for 2 m of line at c = 343 m/s) and the pressure waves a distributed line
carries; beyond a few metres, or for signals faster than ``c / (4 L)``, the line is
resolved in segments (below; :func:`pneucore.physics.line.line_regime` says how many).

The characteristic is that of adiabatic flow with wall friction from a reservoir
through the tube (Fanno flow; Shapiro, *The Dynamics and Thermodynamics of
Compressible Fluid Flow*, 1953, ch. 6): the inlet Mach number ``M1`` of the
choked line satisfies

.. math::
    \\bar f \\frac{L}{d} = \\frac{1 - M_1^2}{\\gamma M_1^2}
        + \\frac{\\gamma + 1}{2 \\gamma}
          \\ln \\frac{(\\gamma + 1) M_1^2}{2 + (\\gamma - 1) M_1^2},

the choked mass flow is the isentropic inlet's at ``M1``, which gives
``C = q / (rho_0 p_0)``, and the critical ratio ``b`` is the outlet pressure of
the choked line over the inlet stagnation pressure, ``b = (p_1/p_0) (p*/p_1)``.
The Darcy friction factor is Hagen-Poiseuille's ``64 / Re`` below Re = 2300 and
Haaland's smooth-tube relation above Re = 4000 (Haaland, J. Fluids Eng. 105, 1983, 89),
linear in Re between (:func:`darcy_friction`, the one law of both lines),
evaluated at the choked flow from the given upstream pressure. A tube of length
zero is the ideal nozzle of its bore (b = 0.528, Eq. 3).

The line in segments
--------------------
With ``segments`` = N > 1 the line is N finite volumes on a staggered grid, the
layout of the pipeline codes that carry waves in stiff system models (mass and energy
in the cells, momentum on the faces; Patankar, *Numerical Heat Transfer and Fluid
Flow*, 1980, sect. 6.3; the lumped-segment pipeline of Krus, Weddfelt & Palmberg,
J. Dyn. Sys. Meas. Control 116, 1994, 132). Each of the N cells holds ``V / N`` of the
line's volume with its gas mass and temperature, as the chamber (paper Eq. 14-15 with
a fixed volume, enthalpy carried upwind), exchanging heat with the line's wall at the
ambient temperature by Eq. 9 with the model's coefficient ``h`` over the cell's wall
``pi d L / N``: over a wave's transit the cells are adiabatic (for 4 mm of bore at 7
bar and h = 25 W/(m^2 K), ``rho c_v d / (4 h)`` = 0.24 s against 6 ms for 2 m), so the
sound speed is ``sqrt(gamma R T)``, the one the oracle and acoustics give (an isothermal
cell would carry the step 15 % late: the test tells the two apart), while over strokes
the line's gas returns towards the wall's temperature; with the model's isothermal heat
model the cells are isothermal too (the heat models that compute ``h`` from a
correlation give the cells the model's fixed part of it, 0 when it has none: adiabatic
cells). Each of the N faces (cell to cell, the last
one into the chamber) carries a mass flow ``q`` with the inertia of the gas between
the two cell centres, ``L/N`` long:

.. math:: \frac{dq}{dt} = \frac{A (p_i - p_{i+1})}{L / N}
    - \frac{f q |q|}{2 d \rho A},

the wall friction the same Darcy law as the lumped line's Fanno flow (Hagen-Poiseuille
``64 / Re`` below :data:`RE_LAMINAR`, Haaland above :data:`RE_TURBULENT`, linear between:
:func:`darcy_friction`, :func:`segment_friction`), the
density the mean of the two cells'. The valve's edges feed the first cell with their own
law (their table without the line in series: the line's resistance is now along it);
the chamber keeps its own dead volume. The convective momentum flux ``d(rho u^2 A)/dx``
is left out (the acoustic form of the momentum equation): against the finite-volume
oracle of :mod:`pneucore.physics.line` (which keeps it) a 6 bar step through 5 m of
4 mm line is followed to 1.9 % rms of the step with 10 segments, and a 0.1 bar step to
4.6 % with 20; kept, with the flux taken at the cell centres, the small step was
followed to 7.5 % and the 6 bar step with a large valve failed (the step size fell
below its minimum: a centred flux has no dissipation at the shock). Without that flux
the segments do not choke on their own: the valve's edge, in series, does.

Why N is a parameter rather than chosen from the command: a model's structure
(its states) then does not jump while a fit varies a length or a scenario's timing,
and ``segments`` = 1 is today's lumped line bit for bit. The simulation warns
(``stats.warnings``) where the chosen N is too coarse for the command
(:func:`pneucore.physics.line.line_regime`: the lumped line from 3 quarter-wave periods
``4 L / c`` of the command's shortest hold on, else 8 cells per quarter wave).
"""
import math

from numba import njit

from pneucore.physics.chamber import chamber_rates, enthalpy_flow
from pneucore.physics.cushion import cushioned_outflow
from pneucore.physics.gas import GAMMA_AIR, R_AIR, RHO_REF, T_REF
from pneucore.physics.states import LineTerm, register_line_term

#: Reynolds number below which the flow in the line is laminar [-]
RE_LAMINAR = 2300.0
#: Reynolds number above which the line in segments takes the turbulent friction; between
#: the two its friction factor is interpolated linearly in Re (:func:`darcy_friction`), the
#: transition zone of Moody's chart, where a tube's friction is intermittent and not
#: predictable to better than this [-]
RE_TURBULENT = 4000.0


def line_volume(diameter, length):
    """Inner volume of a line, ``pi d^2 L / 4``.

    Parameters
    ----------
    diameter : float
        Inner diameter [m]
    length : float
        Length [m]

    Returns
    -------
    V : float
        Volume [m^3]

    Examples
    --------
    2 m of 4 mm bore hold 25.1 cm^3:

    >>> round(line_volume(4e-3, 2.0) * 1e6, 2)
    25.13
    """
    return math.pi * diameter * diameter / 4.0 * length


def air_viscosity_sutherland(T):
    """Dynamic viscosity of air, Sutherland's law (mu_0 = 1.716e-5 Pa s at 273.15 K, S = 110.4 K).

    Parameters
    ----------
    T : float
        Temperature [K]

    Returns
    -------
    mu : float
        Viscosity [Pa s]
    """
    return 1.716e-5 * (T / 273.15) ** 1.5 * (273.15 + 110.4) / (T + 110.4)


@njit(cache=True, error_model="numpy", _nrt=False)
def darcy_friction(Re):
    """Darcy friction factor of a smooth tube, the one law of both lines (the lumped line's
    Fanno characteristic, :func:`tube_characteristic`, and the segments' wall friction,
    :func:`segment_friction`): Hagen-Poiseuille's ``64 / Re`` below :data:`RE_LAMINAR`,
    Haaland's smooth-tube relation (J. Fluids Eng. 105, 1983, 89) above
    :data:`RE_TURBULENT`, and between the two linear in Re from the one to the other, the
    transition zone of Moody's chart (continuous: a jump makes the integrator's step
    control reject steps, and the lumped line's fixed-point iteration oscillate).

    Parameters
    ----------
    Re : float
        Reynolds number [-]

    Returns
    -------
    f : float
        Darcy friction factor [-]

    Examples
    --------
    Laminar, and Haaland's 0.0233 at Re = 3e4 (Blasius's smooth-tube ``0.3164 Re^-1/4``
    gives 0.0240 there):

    >>> round(darcy_friction(1000.0), 4), round(darcy_friction(3e4), 4)
    (0.064, 0.0233)
    """
    if Re < RE_LAMINAR:
        return 64.0 / Re
    f = (-1.8 * math.log10(6.9 / max(Re, RE_TURBULENT))) ** -2
    if Re < RE_TURBULENT:
        w = (Re - RE_LAMINAR) / (RE_TURBULENT - RE_LAMINAR)
        f = (1.0 - w) * 64.0 / RE_LAMINAR + w * f
    return f


def fanno_length(M, gamma=GAMMA_AIR):
    """Friction length ``f L*/d`` that takes a flow at Mach ``M`` to Mach 1 (Fanno flow).

    Parameters
    ----------
    M : float
        Mach number at the inlet, 0 < M <= 1 [-]
    gamma : float
        Ratio of specific heats [-]

    Returns
    -------
    fl : float
        Darcy friction factor times length over diameter [-]
    """
    M2 = M * M
    return (1.0 - M2) / (gamma * M2) + (gamma + 1.0) / (2.0 * gamma) * math.log(
        (gamma + 1.0) * M2 / (2.0 + (gamma - 1.0) * M2))


def _inlet_mach(fl, gamma):
    """The inlet Mach number of a choked line of friction length ``fl`` (bisection)."""
    if fl <= 0.0:
        return 1.0
    lo, hi = 1e-8, 1.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if fanno_length(mid, gamma) > fl:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def tube_characteristic(diameter, length, p0, T0=T_REF, r=R_AIR, gamma=GAMMA_AIR):
    """Sonic conductance C and critical ratio b of a line fed at ``p0`` (Fanno flow, see module).

    Parameters
    ----------
    diameter : float
        Inner diameter [m]
    length : float
        Length [m]
    p0 : float
        Upstream (stagnation) absolute pressure at which the friction factor is evaluated [Pa]
    T0 : float
        Upstream temperature [K]
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]

    Returns
    -------
    C : float
        Sonic conductance [m^3/(s Pa)]
    b : float
        Critical pressure ratio [-]

    Examples
    --------
    2 m of 4 mm bore at 7 bar: about the conductance of the paper's valve, 1 dm^3/(s bar):

    >>> C, b = tube_characteristic(4e-3, 2.0, 7e5)
    >>> round(C / 1e-8, 2), round(b, 2)
    (1.06, 0.26)
    """
    A = math.pi * diameter * diameter / 4.0
    k = gamma - 1.0
    mu = air_viscosity_sutherland(T0)
    f = 0.02
    M = 1.0
    q = 0.0
    for _ in range(60):
        M = _inlet_mach(f * length / diameter, gamma)
        q = A * p0 * math.sqrt(gamma / (r * T0)) * M * (1.0 + 0.5 * k * M * M) ** (
            -(gamma + 1.0) / (2.0 * k))
        # the law's Python text (``py_func``): outside the transition zone the lumped line's
        # characteristic is then the one computed before the law was compiled, bit for bit
        # (numba's log10 and power round differently from CPython's in the last bit)
        f_new = darcy_friction.py_func(4.0 * q / (math.pi * diameter * mu))
        if abs(f_new - f) <= 1e-12 * f:
            break
        f = 0.5 * (f + f_new)        # damped: the laminar-turbulent switch would oscillate
    C = q / (RHO_REF * p0 * math.sqrt(T_REF / T0))
    b = (1.0 + 0.5 * k * M * M) ** (-gamma / k) * M * math.sqrt((gamma + 1.0) / (2.0 + k * M * M))
    return C, b


# --- the line in segments, inside the compiled core ----------------------------------------
#: Most segments a line may have per port [-]: the core stores its Jacobian and the step's
#: matrix dense (the evaluations are grouped and the factorisation follows the profile,
#: :mod:`pneucore.core.integrator`, but assembling them costs the square of the states), and
#: 3 states a segment on two ports at 32 segments already make 198 states;
#: 32 segments resolve a signal of one quarter-wave period of the line at
#: :data:`pneucore.physics.line.CELLS_PER_QUARTER_WAVE` cells per quarter wave four times over
MAX_SEGMENTS = 32

#: The states of a line in segments, per cell or face, in the order of their blocks: the
#: state ``line_<port>_<kind><i>`` (i from 1 at the valve), its kind and unit
LINE_STATES = (("m", "kg"), ("T", "K"), ("q", "kg/s"))


def line_state_unit(name):
    """Unit of a line state named ``line_<port>_<kind><i>``, or None for another name.

    Parameters
    ----------
    name : str
        State name [-]

    Returns
    -------
    unit : str or None
        Its SI unit [-]

    Examples
    --------
    >>> line_state_unit("line_a_q3"), line_state_unit("p_a")
    ('kg/s', None)
    """
    parts = name.split("_")
    if len(parts) == 3 and parts[0] == "line" and parts[1] in ("a", "b"):
        for kind, unit in LINE_STATES:
            if parts[2].startswith(kind) and parts[2][len(kind):].isdigit():
                return unit
    return None


#: The parameters of one port's segmented line, in the order of its slots (name, unit)
LINE_PARAMETERS = (("segments", "-"), ("cell_volume", "m^3"), ("area", "m^2"),
                   ("segment_length", "m"), ("diameter", "m"), ("viscosity", "Pa s"),
                   ("wall_coefficient", "W/(m^2 K)"), ("wall_temperature", "K"))


def line_slots(diameter, length, segments, T0=T_REF, h=0.0, T_wall=T_REF):
    """The slot values of one port's segmented line (:data:`LINE_PARAMETERS` order).

    Parameters
    ----------
    diameter : float
        Inner diameter [m]
    length : float
        Length [m]
    segments : int
        Number of segments [-]
    T0 : float
        Temperature at which the viscosity is taken (the supply's, as
        :func:`tube_characteristic` takes it) [K]
    h : float
        Heat exchange coefficient between the gas and the line's wall (the model's, paper
        Eq. 9; 0 = adiabatic cells) [W/(m^2 K)]
    T_wall : float
        Wall temperature (the ambient's) [K]

    Returns
    -------
    values : tuple of float
        segments [-], cell volume [m^3], bore area [m^2], segment length [m], diameter [m],
        viscosity [Pa s], wall coefficient [W/(m^2 K)], wall temperature [K]
    """
    n = int(segments)
    return (float(n), line_volume(diameter, length) / n, math.pi * diameter * diameter / 4.0,
            length / n, diameter, air_viscosity_sutherland(T0), float(h), float(T_wall))


@njit(cache=True, error_model="numpy", _nrt=False)
def segment_friction(q, rho, A, d, mu):
    """Wall friction on the gas of one segment, per unit length, as a rate of its mass flow
    [kg/s^2]: ``f q |q| / (2 d rho A)``, Darcy's ``f`` of :func:`darcy_friction`, which is
    Hagen-Poiseuille's ``32 mu q / (rho d^2)`` below :data:`RE_LAMINAR`.

    Parameters
    ----------
    q : float
        Mass flow [kg/s]
    rho : float
        Gas density [kg/m^3]
    A : float
        Bore area [m^2]
    d : float
        Inner diameter [m]
    mu : float
        Dynamic viscosity [Pa s]

    Examples
    --------
    Laminar: 0.1 g/s of air at 1.19 kg/m^3 in a 4 mm bore is 32 mu q / (rho d^2):

    >>> mu = 1.8e-5
    >>> round(segment_friction(1e-4, 1.19, 1.2566e-5, 4e-3, mu) / (32 * mu * 1e-4 / (1.19 * 16e-6)), 12)
    1.0
    """
    Re = abs(q) * d / (A * mu)
    if Re < RE_LAMINAR:
        return 32.0 * mu * q / (rho * d * d)      # 64 / Re written out: finite at q = 0
    f = darcy_friction(Re)
    return f * q * abs(q) / (2.0 * d * rho * A)


@njit(cache=True, error_model="numpy", _nrt=False)
def line_node(y, i0, prm, k0, r):
    """Pressure [Pa] and temperature [K] of the line's first cell, the node the port's valve
    edges see (line term ``node``, :mod:`pneucore.physics.states`)."""
    n = int(prm[k0])
    T = y[i0 + n]
    return y[i0] * r * T / prm[k0 + 1], T


@njit(cache=True, error_model="numpy", _nrt=False)
def line_rates(y, dy, i0, prm, k0, q_v, H_v, p_c, T_c, r, cp, cv, isothermal, C_end, b_end,
               r_lam, gamma):
    """Derivatives of a segmented line's states; the mass and enthalpy flows into the chamber.

    The states of a port's line, from ``y[i0]``: the gas mass of each cell [kg], its
    temperature [K], then the mass flow through the face downstream of each cell [kg/s]
    (module section "The line in segments"). The valve's flow ``q_v`` [kg/s], with its
    enthalpy ``H_v`` [W], enters the first cell; the last face opens into the chamber at
    ``p_c`` [Pa], ``T_c`` [K]. With ``C_end`` >= 0 [m^3/(s Pa)] an end cushion's needle
    (critical ratio ``b_end`` [-], laminar ratio ``r_lam`` [-], ratio of specific heats
    ``gamma`` [-]) sits between the chamber and the last cell: the gas leaving the chamber
    passes it, bounded by the last face's flow, the gas entering passes the check valve
    (:func:`pneucore.physics.cushion.cushioned_outflow`, as at a valve edge without a line);
    ``C_end`` < 0: no cushion (a closed needle is ``C_end`` = 0). The last face keeps its
    momentum equation meanwhile (driven by the chamber's pressure over the last cell's): a
    needle with a volume of gas between it and the line's gas is not modelled, so while the
    needle bounds the flow the face's state is the flow the line would carry without it,
    not the flow that passes, and the check valve opens once that turns towards the
    chamber.
    Returns the mass flow [kg/s] and enthalpy flow [W] into the chamber (line term
    ``rate``, :mod:`pneucore.physics.states`).
    """
    n = int(prm[k0])
    V = prm[k0 + 1]
    A = prm[k0 + 2]
    dx = prm[k0 + 3]
    d = prm[k0 + 4]
    mu = prm[k0 + 5]
    hS = prm[k0 + 6] * math.pi * d * dx          # wall exchange of one cell [W/K]
    T_w = prm[k0 + 7]
    iT = i0 + n
    iq = i0 + 2 * n
    # the flow into the chamber: the last face's, through the cushion's needle where the gas
    # leaves a cushioned chamber
    q_c = y[iq + n - 1]
    T_last = y[iT + n - 1]
    if C_end >= 0.0 and q_c < 0.0:
        p_last = y[iT - 1] * r * T_last / V
        q_c = -cushioned_outflow(-q_c, p_c, T_c, p_last, T_last, C_end, b_end, r_lam, r, gamma)
    q_prev = q_v
    for i in range(n):
        m = y[i0 + i]
        T = y[iT + i]
        p = m * r * T / V
        rho = m / V
        q_face = y[iq + i]
        q_out = q_face if i + 1 < n else q_c
        # mass and energy of the cell (paper Eq. 14-15 with a fixed volume, heat from its
        # wall by Eq. 9)
        if i == 0:
            H = H_v
        else:
            H = enthalpy_flow(q_prev, y[iT + i - 1], T, cp)
        T_down = y[iT + i + 1] if i + 1 < n else T_c
        H += enthalpy_flow(-q_out, T_down, T, cp)
        dm, dT = chamber_rates(m, T, p, 0.0, q_prev - q_out, H, hS * (T_w - T), cv, isothermal)
        dy[i0 + i] = dm
        dy[iT + i] = dT
        # momentum of the face downstream (staggered grid): pressure difference and wall
        # friction on the gas between the two cell centres (module section "The line in
        # segments": the convective momentum flux is left out)
        if i + 1 < n:
            p2 = y[i0 + i + 1] * r * y[iT + i + 1] / V
            rho2 = y[i0 + i + 1] / V
        else:
            p2 = p_c
            rho2 = p_c / (r * T_c)
        dy[iq + i] = A * (p - p2) / dx - segment_friction(q_face, 0.5 * (rho + rho2), A, d, mu)
        q_prev = q_out
    return q_c, enthalpy_flow(q_c, T_last, T_c, cp)


@njit(cache=True, error_model="numpy", _nrt=False)
def line_cells(prm, k0, i0, cell):
    """The cell of each state of a segmented line (line term ``cells``,
    :mod:`pneucore.physics.states`): cell ``i`` holds ``m_i``, ``T_i`` and the flow of the face
    downstream of it, ``q_i`` (the last face, into the chamber, belongs to the last cell).

    :func:`line_rates` keeps the registry's contract: a cell's rates read the states of the
    cell itself, of the face upstream (the cell before) and of the cell downstream; only
    the first cell reads the valve's flow and only the last cell reads the chamber.

    Parameters
    ----------
    prm : ndarray
        The core's parameter vector (the port's slots from ``prm[k0]``)
    k0 : int
        First parameter slot of the port [-]
    i0 : int
        Position of the port's first state [-]
    cell : ndarray of int
        Output: ``cell[i0 + k]``, the cell of the port's ``k``-th state [-]

    Returns
    -------
    n_states, n_cells : int
        The port's states and cells [-]
    """
    n = int(prm[k0])
    for k in range(3 * n):
        cell[i0 + k] = k % n
    return 3 * n, n


#: The line in segments (effect ``tubing`` with ``segments`` > 1): states per port
#: ``line_<port>_m<i>``, ``line_<port>_T<i>``, ``line_<port>_q<i>``
SEGMENTED_LINE = register_line_term(LineTerm(
    "line", line_node, line_rates, line_cells, LINE_PARAMETERS,
    description="the line between valve and chamber in segments: mass and energy per cell, "
                "momentum per face"))
