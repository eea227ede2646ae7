"""Adjustable end cushions: a spear on the piston, a cushion seal, a needle and a check valve.

Over the last ``l_c`` of its travel towards an end the piston's cushion spear enters
the cushion seal of that end cap and cuts the chamber off from its port: the gas
ahead of the piston (the trapped cushion volume ``A l_c + V_0``, the chamber's dead
volume ``V_0`` included) can leave only through the adjustable needle, an ISO 6358
restriction of conductance ``C`` and critical ratio ``b``; a check valve in parallel
lets air into the chamber freely, so the piston leaves the end as if there were no
cushion (Beater, *Pneumatic Drives*, Springer 2007, Sect. 6.3; SMC *Best Pneumatics*,
"Air cushion": the cushion needle sets how much of the kinetic energy the
compressed air absorbs).

In the core the needle sits in series with the valve edge the gas leaves by, with no
volume between: the flow out of the chamber through an edge is the needle's flow to
that edge's far node, bounded by the edge's own flow (in series the flow is at most
either element's; a cushion needle is a small fraction of the port's conductance,
so the needle sets it). Flow into the chamber passes the check valve as the valve
lets it. With a ``tubing`` line in segments on the port the needle sits at the line's
chamber end instead, between the chamber and the line's last cell, bounded by the last
face's flow (:func:`pneucore.physics.tube.line_rates`); with a lumped line it stays in
series with the edge, and the line's volume, part of the chamber's dead volume, is then
inside the trapped cushion volume.

Stroke-end energy: the piston meets the end stop with the kinetic energy
``E = m v^2 / 2``; catalogues give the energy a cushion absorbs at most
(its capacity [J]) and a selection checks ``E`` against it (SMC, *Best Pneumatics*,
"Allowable kinetic energy"; :func:`kinetic_energy`).
"""
from numba import njit

from pneucore.physics.flow import iso6358_mass_flow


@njit(cache=True, error_model="numpy", _nrt=False)
def in_cushion(x, stroke, length_low, length_high, end):
    """Whether the piston at ``x`` is inside the cushion of one end.

    Parameters
    ----------
    x : float
        Piston position [m]
    stroke : float
        Stroke [m]
    length_low : float
        Cushion length at the x = 0 end (chamber A) [m] (0 = no cushion)
    length_high : float
        Cushion length at the x = stroke end (chamber B) [m] (0 = no cushion)
    end : int
        0 for the x = 0 end, 1 for the x = stroke end

    Examples
    --------
    >>> in_cushion(0.01, 0.25, 0.015, 0.0, 0), in_cushion(0.02, 0.25, 0.015, 0.0, 0)
    (True, False)
    """
    if end == 0:
        return length_low > 0.0 and x < length_low
    return length_high > 0.0 and x > stroke - length_high


@njit(cache=True, error_model="numpy", _nrt=False)
def cushioned_outflow(q_edge, p, T, p_far, T_far, C, b, r_lam, r, gamma):
    """Flow [kg/s] out of a cushioned chamber through one valve edge.

    Parameters
    ----------
    q_edge : float
        The edge's flow out of the chamber without the cushion [kg/s] (< 0: inflow)
    p, T : float
        Chamber pressure [Pa] and temperature [K]
    p_far, T_far : float
        Pressure [Pa] and temperature [K] of the edge's far node (exhaust or supply)
    C : float
        Needle sonic conductance [m^3/(s Pa)]
    b : float
        Needle critical pressure ratio [-]
    r_lam : float
        Pressure ratio of the laminar transition [-]
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]

    Returns
    -------
    q : float
        ``q_edge`` for an inflow (check valve), else the needle's flow bounded by ``q_edge``

    Examples
    --------
    A chamber at 6 bar exhausting to 1 bar through an edge passing 5 g/s and a needle
    of 1e-9 m^3/(s Pa): the choked needle passes rho_0 C p sqrt(T_0 / T) = 1.185 x 1e-9 x 6e5, 0.711 g/s:

    >>> q = cushioned_outflow(5e-3, 6e5, 293.15, 1e5, 293.15, 1e-9, 0.3, 0.999, 287.05, 1.4)
    >>> round(q * 1e3, 3)
    0.711
    """
    if q_edge <= 0.0:
        return q_edge
    q_n = iso6358_mass_flow(p, T, p_far, T_far, C, b, 0.5, r_lam, r, gamma)
    if q_n < q_edge:
        return max(q_n, 0.0)
    return q_edge


def kinetic_energy(mass, speed):
    """Kinetic energy of the moving mass [J].

    Parameters
    ----------
    mass : float
        Moving mass [kg]
    speed : float
        Piston speed [m/s]

    Examples
    --------
    SMC's example: 2 kg arriving at 0.5 m/s carries 0.25 J:

    >>> kinetic_energy(2.0, 0.5)
    0.25
    """
    return 0.5 * mass * speed * speed
