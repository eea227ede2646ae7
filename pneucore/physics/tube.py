"""A pneumatic line (tube) between valve and cylinder: its volume and its ISO 6358 characteristic.

The line is lumped: its volume ``pi d^2 L / 4`` joins the chamber's dead volume
(paper Eq. 23-24) and its flow resistance is a restriction in series with the
valve edges of its port (ISO 6358-3, :mod:`pneucore.physics.series`). A lumped
line neglects the transport delay ``L / c`` (6 ms for 2 m of line at
c = 343 m/s) against the stroke times of a second or less that the model
resolves, and the pressure waves a distributed line carries; beyond a few
metres, or for signals faster than ``c / (4 L)``, a line of finite volumes is the
model to use (:mod:`pneucore.physics.line`, whose ``line_regime`` says which).

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
Haaland's smooth-tube relation above (Haaland, J. Fluids Eng. 105, 1983, 89),
evaluated at the choked flow from the given upstream pressure. A tube of length
zero is the ideal nozzle of its bore (b = 0.528, Eq. 3).
"""
import math

from pneucore.physics.gas import GAMMA_AIR, R_AIR, RHO_REF, T_REF

#: Reynolds number below which the flow in the line is laminar [-]
RE_LAMINAR = 2300.0


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


def darcy_friction(Re):
    """Darcy friction factor of a smooth tube: ``64 / Re`` (laminar), Haaland's relation above.

    Parameters
    ----------
    Re : float
        Reynolds number [-]

    Returns
    -------
    f : float
        Darcy friction factor [-]
    """
    if Re < RE_LAMINAR:
        return 64.0 / Re
    return (-1.8 * math.log10(6.9 / Re)) ** -2


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
        f_new = darcy_friction(4.0 * q / (math.pi * diameter * mu))
        if abs(f_new - f) <= 1e-12 * f:
            break
        f = 0.5 * (f + f_new)        # damped: the laminar-turbulent switch would oscillate
    C = q / (RHO_REF * p0 * math.sqrt(T_REF / T0))
    b = (1.0 + 0.5 * k * M * M) ** (-gamma / k) * M * math.sqrt((gamma + 1.0) / (2.0 + k * M * M))
    return C, b
