"""A one-way flow control at a cylinder port with the volume between it and the valve.

A speed controller screwed into a cylinder's port (the usual mounting: SMC's AS series,
Festo's GRLA) is a throttle in parallel with a check valve. Meter-out, the check valve
lets the air into the chamber freely and the throttle holds back the air leaving it;
meter-in, the other way round. Between the controller and the valve's edge lie the tube
and its fittings, a volume of gas: the chamber exhausts through the throttle into that
volume, and the valve's exhaust edge empties it to the atmosphere. Where that volume is
negligible the throttle and the edge are two restrictions in series with nothing between
them, which ISO 6358-3 combines into one characteristic
(:mod:`pneucore.physics.series`, the flow controls' ``volume`` 0); where it is not, it
fills and empties as a chamber of fixed volume does, which is the node here.

The node
--------
One gas volume ``V`` per port, the node the port's valve edges see (their flows and
enthalpy enter it as they would enter the chamber), with its mass ``m`` and temperature
``T`` as states, by the chamber's own conservation laws with a fixed volume (paper
Eq. 14-15, enthalpy carried upwind):

.. math::
    \\frac{dm}{dt} = q_v - q_c, \\qquad
    m c_v \\frac{dT}{dt} = H_v - H_c - c_v T (q_v - q_c) + h S (T_w - T)

``q_v``, ``H_v`` the valve edges' mass and enthalpy flows into the port, ``q_c`` the
flow from the node into the chamber through the controller:

* from the chamber to the node (``p_c > p``), meter-out: the throttle alone,
  ``q_c = -q_{ISO}(p_c, T_c; p, T; C, b)`` (paper Eq. 4-5); meter-in: the throttle and the
  open check valve in parallel, each passing its own ISO 6358 flow;
* from the node to the chamber, the other way round.

A parallel pair passes the sum of its flows, no combination rule needed; the check
valve's cracking pressure is neglected (a few kPa against the bar across it in a stroke).
The wall exchange is Eq. 9 with the model's coefficient ``h`` over the wall of a tube of
the common 4 mm bore holding ``V`` (:data:`NODE_BORE`: ``S = 4 V / d``), at the ambient
temperature; with the model's isothermal heat model the node is isothermal too, as the
line's cells are (:mod:`pneucore.physics.tube`). The gas's inertia in the tube is left out:
a line whose delay or waves matter is the ``tubing`` effect in segments.

An end cushion's needle on the port sits between the chamber and the node, in series with
the controller on the gas leaving the chamber, bounded by the controller's flow as it is
bounded by a valve edge's without the node (:func:`pneucore.physics.cushion.cushioned_outflow`).
"""
import math

from numba import njit

from pneucore.physics.chamber import chamber_rates, enthalpy_flow
from pneucore.physics.cushion import cushioned_outflow
from pneucore.physics.flow import iso6358_mass_flow
from pneucore.physics.states import LineTerm, register_line_term

#: Bore of the tube whose wall the node's gas exchanges heat with: the 4 mm bore of the 6 mm
#: tube a cylinder-port speed controller for small bores takes [m]
NODE_BORE = 4e-3

#: The controller throttles the gas leaving the chamber (meter-out) or entering it (meter-in)
METER_OUT, METER_IN = 1.0, -1.0

#: The parameters of one port's node, in the order of its slots (name, unit)
NODE_PARAMETERS = (("volume", "m^3"), ("C", "m^3/(s Pa)"), ("b", "-"),
                   ("C_check", "m^3/(s Pa)"), ("b_check", "-"), ("direction", "-"),
                   ("wall_conductance", "W/K"), ("wall_temperature", "K"))


def node_slots(volume, C, b, C_check, b_check, direction, h=0.0, T_wall=293.15):
    """The slot values of one port's node (:data:`NODE_PARAMETERS` order).

    Parameters
    ----------
    volume : float
        Volume between the controller and the valve's edge [m^3]
    C, b : float
        The throttle's sonic conductance [m^3/(s Pa)] and critical ratio [-]
    C_check, b_check : float
        The check valve's, open [m^3/(s Pa)], [-]
    direction : float
        :data:`METER_OUT` or :data:`METER_IN` [-]
    h : float
        Heat exchange coefficient with the wall (the model's, paper Eq. 9; 0 = adiabatic)
        [W/(m^2 K)]
    T_wall : float
        Wall temperature (the ambient's) [K]

    Returns
    -------
    values : tuple of float
        The slots, the wall's conductance ``h S`` [W/K] with ``S = 4 V / NODE_BORE`` [m^2]

    Examples
    --------
    10 cm^3 behind a meter-out throttle, h = 25 W/(m^2 K): a wall of 0.01 m^2, 0.25 W/K:

    >>> node_slots(1e-5, 3e-9, 0.3, 1e-8, 0.3, METER_OUT, 25.0)[6]
    0.25
    """
    S = 4.0 * volume / NODE_BORE
    return (float(volume), float(C), float(b), float(C_check), float(b_check), float(direction),
            float(h) * S, float(T_wall))


@njit(cache=True, error_model="numpy", _nrt=False, inline="always")
def controller_flow(p_n, T_n, p_c, T_c, C, b, C_check, b_check, direction, r_lam, r, gamma):
    """Mass flow from the node into the chamber through the controller [kg/s].

    Parameters
    ----------
    p_n, T_n : float
        The node's pressure [Pa] and temperature [K]
    p_c, T_c : float
        The chamber's [Pa], [K]
    C, b : float
        The throttle's sonic conductance [m^3/(s Pa)] and critical ratio [-]
    C_check, b_check : float
        The check valve's, open [m^3/(s Pa)], [-]
    direction : float
        > 0 meter-out (the check valve opens towards the chamber), < 0 meter-in [-]
    r_lam : float
        Pressure ratio of the laminar transition [-]
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]

    Examples
    --------
    Meter-out, the chamber at 6 bar exhausting into a node at 1.5 bar through a throttle of
    3e-9 m^3/(s Pa) (b 0.3, choked): rho_0 C p_c = 1.185 x 3e-9 x 6e5 = 2.133 g/s leaves it;
    the same pressures the other way pass the check valve too (1e-8 more: 9.24 g/s):

    >>> q = controller_flow(1.5e5, 293.15, 6e5, 293.15, 3e-9, 0.3, 1e-8, 0.3, 1.0, 0.999, 287.05, 1.4)
    >>> round(q * 1e3, 3)
    -2.133
    >>> q = controller_flow(6e5, 293.15, 1.5e5, 293.15, 3e-9, 0.3, 1e-8, 0.3, 1.0, 0.999, 287.05, 1.4)
    >>> round(q * 1e3, 2)
    9.24
    """
    q = iso6358_mass_flow(p_n, T_n, p_c, T_c, C, b, 0.5, r_lam, r, gamma)
    # the check valve opens for the flow into the chamber (meter-out) or out of it (meter-in)
    if (direction > 0.0 and p_n > p_c) or (direction < 0.0 and p_c > p_n):
        q += iso6358_mass_flow(p_n, T_n, p_c, T_c, C_check, b_check, 0.5, r_lam, r, gamma)
    return q


@njit(cache=True, error_model="numpy", _nrt=False)
def node_state(y, i0, prm, k0, r):
    """Pressure [Pa] and temperature [K] of the node, which the port's valve edges see (line
    term ``node``, :mod:`pneucore.physics.states`)."""
    T = y[i0 + 1]
    return y[i0] * r * T / prm[k0], T


@njit(cache=True, error_model="numpy", _nrt=False)
def node_rates(y, dy, i0, prm, k0, q_v, H_v, p_c, T_c, r, cp, cv, isothermal, C_end, b_end,
               r_lam, gamma):
    """Derivatives of the node's mass and temperature; the mass and enthalpy flows into the
    chamber (line term ``rate``, :mod:`pneucore.physics.states`; module docstring).

    The valve's flow ``q_v`` [kg/s] with its enthalpy ``H_v`` [W] enters the node; the
    chamber is at ``p_c`` [Pa], ``T_c`` [K]. With ``C_end`` >= 0 [m^3/(s Pa)] an end
    cushion's needle (critical ratio ``b_end``) bounds the gas leaving the chamber.
    """
    V = prm[k0]
    m = y[i0]
    T = y[i0 + 1]
    p = m * r * T / V
    q_c = controller_flow(p, T, p_c, T_c, prm[k0 + 1], prm[k0 + 2], prm[k0 + 3], prm[k0 + 4],
                          prm[k0 + 5], r_lam, r, gamma)
    if C_end >= 0.0 and q_c < 0.0:
        q_c = -cushioned_outflow(-q_c, p_c, T_c, p, T, C_end, b_end, r_lam, r, gamma)
    H_c = enthalpy_flow(q_c, T, T_c, cp)
    # the node's own balance: what the valve brings, less what passes to the chamber (the
    # chamber's H_c: the node's gas going in, the chamber's coming back)
    H = H_v - H_c
    dm, dT = chamber_rates(m, T, p, 0.0, q_v - q_c, H, prm[k0 + 6] * (prm[k0 + 7] - T), cv,
                           isothermal)
    dy[i0] = dm
    dy[i0 + 1] = dT
    return q_c, H_c


@njit(cache=True, error_model="numpy", _nrt=False)
def node_cells(prm, k0, i0, cell):
    """The node is one cell holding both its states (line term ``cells``)."""
    cell[i0] = 0
    cell[i0 + 1] = 0
    return 2, 1


#: The node's states per port, ``node_<port>_<kind>``, and their units
NODE_STATES = (("m", "kg"), ("T", "K"))


def node_state_unit(name):
    """Unit of a node state named ``node_<port>_<kind>``, or None for another name.

    Examples
    --------
    >>> node_state_unit("node_b_T"), node_state_unit("p_a")
    ('K', None)
    """
    parts = name.split("_")
    if len(parts) == 3 and parts[0] == "node" and parts[1] in ("a", "b"):
        return dict(NODE_STATES).get(parts[2])
    return None


#: The node of a flow control with a volume before it (effects ``meter_out_throttle`` and
#: ``meter_in_throttle`` with ``volume_a`` or ``volume_b`` > 0): states per port
#: ``node_<port>_m``, ``node_<port>_T``
PORT_NODE = register_line_term(LineTerm(
    "flow_control_node", node_state, node_rates, node_cells, NODE_PARAMETERS,
    description="a flow control at the cylinder's port and the volume between it and the "
                "valve: one gas volume with its mass and temperature"))
