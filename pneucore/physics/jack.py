"""Geometry of the jack: areas, chamber volumes and wall areas (paper Eq. 17, 23-24).

Position ``x`` runs from 0 (chamber A smallest) to the stroke. Chamber A
pushes towards +x (extension), chamber B towards -x.
"""
import math

from numba import njit


def annulus_area(bore, rod):
    """Piston annulus area ``pi/4 (D^2 - d^2)``.

    Parameters
    ----------
    bore : float
        Bore (piston) diameter [m]
    rod : float
        Rod diameter on that side, 0 for no rod [m]

    Returns
    -------
    A : float
        Pressurised area [m^2]
    """
    return math.pi / 4.0 * (bore * bore - rod * rod)


def rod_area(rod):
    """Rod cross-section ``pi/4 d^2`` [m^2], on which ambient pressure acts (Eq. 17)."""
    return math.pi / 4.0 * rod * rod


@njit(cache=True, error_model="numpy")
def chamber_volumes(x, A_a, A_b, stroke, V0_a, V0_b):
    """Chamber volumes, paper Eq. 23-24.

    ``V_a = A_a x + V0_a`` and ``V_b = A_b (stroke - x) + V0_b``.

    Parameters
    ----------
    x : float
        Piston position from the A end [m]
    A_a, A_b : float
        Annulus areas of chambers A and B [m^2]
    stroke : float
        Stroke [m]
    V0_a, V0_b : float
        Dead volumes at the ends of stroke [m^3]

    Returns
    -------
    V_a, V_b : float
        Gas volumes [m^3]
    """
    return A_a * x + V0_a, A_b * (stroke - x) + V0_b


@njit(cache=True, error_model="numpy")
def wall_area(V, A, bore, rod):
    """Heat-exchange area of a chamber: lateral area of the gas column plus both end faces.

    The gas column has length ``L = V / A`` (dead volume included, as an
    equivalent length); its wall is the barrel (``pi D L``), the rod surface
    (``pi d L``) and the two annular end faces (piston and head, ``2 A``).

    Parameters
    ----------
    V : float
        Chamber volume [m^3]
    A : float
        Annulus area [m^2]
    bore : float
        Bore [m]
    rod : float
        Rod diameter in that chamber [m]

    Returns
    -------
    S : float
        Wall area [m^2]
    """
    L = V / A
    return math.pi * (bore + rod) * L + 2.0 * A


@njit(cache=True, error_model="numpy")
def net_pressure_force(p_a, p_b, p_atm, A_a, A_b, A_rod_a, A_rod_b, load):
    """Net force on the piston towards +x from pressures and load (paper Eq. 17).

    ``F = p_a A_a - p_b A_b + p_atm (A_rod_a - A_rod_b) - F_load``

    Parameters
    ----------
    p_a, p_b : float
        Chamber pressures [Pa]
    p_atm : float
        Ambient pressure on the rod ends [Pa]
    A_a, A_b : float
        Annulus areas [m^2]
    A_rod_a, A_rod_b : float
        Rod cross-sections [m^2]
    load : float
        External load force, pushing towards x = 0 [N]

    Returns
    -------
    F : float
        Force towards +x before friction [N]
    """
    return p_a * A_a - p_b * A_b + p_atm * (A_rod_a - A_rod_b) - load


#: Standard acceleration of gravity [m/s^2] (CGPM 1901, ISO 80000-3)
G_STANDARD = 9.80665
#: Bound of the mounting angle: vertical, rod up (+90) or rod down (-90) [deg]
ANGLE_MAX = 90.0


def gravity_load(mass, angle):
    """Weight of the moving mass along the rod, pushing towards x = 0 [N].

    ``F_g = m g sin(alpha)``: with the jack horizontal (``alpha = 0``) gravity
    takes no part in the piston's balance (paper Eq. 17); with the rod pointing
    up (``alpha = 90 deg``) extension lifts the whole weight, with the rod
    pointing down (``alpha = -90 deg``) the weight pulls the rod out. It adds
    to the load of Eq. 17.

    Parameters
    ----------
    mass : float
        Moving mass: piston, rod and load [kg]
    angle : float
        Mounting angle of the rod over the horizontal, -90 to 90 [deg]

    Returns
    -------
    F : float
        Force towards x = 0 [N]

    Examples
    --------
    A 1.47 kg mass lifted by a vertical jack weighs 14.4 N:

    >>> round(gravity_load(1.47, 90.0), 2)
    14.42
    >>> gravity_load(2.0, 0.0)
    0.0
    """
    return mass * G_STANDARD * math.sin(math.radians(angle))


@njit(cache=True, error_model="numpy")
def spring_force(x, rate, preload):
    """Force of a return spring on the piston, pushing towards x = 0 [N].

    A linear (Hooke) spring compressed by the stroke: ``F_s = F_0 + k x``, the
    preload ``F_0`` at x = 0 (the spring-return single-acting cylinder's
    retracted position) growing by the rate ``k`` over the stroke. It enters
    Eq. 17 as a position-dependent load.

    Parameters
    ----------
    x : float
        Piston position [m]
    rate : float
        Spring rate k [N/m]
    preload : float
        Spring force at x = 0 [N]

    Returns
    -------
    F : float
        Force towards x = 0 [N]
    """
    return preload + rate * x
