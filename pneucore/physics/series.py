"""Restrictions in series without a volume between them: the ISO 6358-3 combination.

A one-way flow control screwed into a cylinder port, the valve's metering
edge and a silencer on its exhaust pass the same mass flow one after the
other, with no volume between them worth a state. ISO 6358-3:2014 (Sect. 5,
components in series) computes the overall flow-rate characteristic of such a
chain numerically: the mass flow is the same through every component (no
volume stores any), each component obeys its own ISO 6358 law (paper
Eq. 4-5), and the upstream stagnation temperature is the same for all of
them (adiabatic throttling of an ideal gas keeps the stagnation enthalpy), so
the factor ``rho_0 sqrt(T_0 / T_1)`` is common to the chain and the flow can
be written per unit of it, ``Q = C p phi(p_d / p_u)``.

:func:`series_characteristic` marches down the chain: given a flow ``Q`` and
the pressure upstream of a component, Eq. 4 inverted gives the pressure
downstream of it in closed form,

.. math::
    p_d = p_u \\left[ b + (1 - b) \\sqrt{1 - (Q / (C p_u))^{1/m}} \\right],

impossible when ``Q > C p_u`` (the component cannot pass that flow). The
chain's sonic conductance is the largest flow that gets through to a
downstream pressure of zero, per unit of the inlet pressure, and its critical
ratio ``b`` the highest outlet-to-inlet ratio at which that flow still gets
through: the ratio at which the chain chokes (one component choked, those
downstream of it subsonic), which is how ISO 6358-1 defines b. Between b and 1
the chain's flow is represented by Eq. 4 with these C and b (m = 0.5), as
ISO 6358-3 does for the system's characteristic; choked flow is exact.

The closed-form approximations found in catalogues (``1/C^3 = sum 1/C_i^3``,
or the effective areas' ``1/S^2 = sum 1/S_i^2`` of JIS B 8390) are off by 3 to
8 % for two or three comparable components with b = 0.2-0.45 (measured against
this marching solution), which is why the numerical method is used.
"""
import math


def downstream_pressure(p_u, Q, C, b, m=0.5):
    """Pressure downstream of an ISO 6358 restriction passing the flow ``Q`` (Eq. 4 inverted).

    Parameters
    ----------
    p_u : float
        Upstream absolute pressure [Pa]
    Q : float
        Flow per unit of ``rho_0 sqrt(T_0 / T_u)``, i.e. ``C p_u phi`` [m^3/s]
    C : float
        Sonic conductance [m^3/(s Pa)]
    b : float
        Critical pressure ratio [-]
    m : float
        Subsonic index [-]

    Returns
    -------
    p_d : float or None
        The highest downstream pressure at which the restriction passes ``Q`` [Pa]; None when
        it cannot (``Q > C p_u``)

    Examples
    --------
    A choked restriction (Q = C p_u) passes its flow down to its critical ratio:

    >>> downstream_pressure(7e5, 7e-3, 1e-8, 0.3)
    210000.0
    """
    cap = C * p_u
    if Q > cap:
        return None
    if Q <= 0.0:
        return p_u
    phi = Q / cap
    w = phi ** (1.0 / m)
    return p_u * (b + (1.0 - b) * math.sqrt(max(1.0 - w, 0.0)))


def chain_outlet(p_in, Q, elements):
    """Outlet pressure of a chain of restrictions passing the flow ``Q``, or None.

    Parameters
    ----------
    p_in : float
        Inlet absolute pressure [Pa]
    Q : float
        Flow per unit of ``rho_0 sqrt(T_0 / T_in)`` [m^3/s]
    elements : sequence of tuple
        ``(C [m^3/(s Pa)], b [-], m [-])`` from upstream to downstream

    Returns
    -------
    p_out : float or None
        The highest outlet pressure at which the chain passes ``Q`` [Pa]; None when one of
        its components cannot
    """
    p = p_in
    for C, b, m in elements:
        p = downstream_pressure(p, Q, C, b, m)
        if p is None:
            return None
    return p


def series_characteristic(elements):
    """Sonic conductance and critical ratio of restrictions in series (ISO 6358-3, Sect. 5).

    Parameters
    ----------
    elements : sequence of tuple
        ``(C [m^3/(s Pa)], b [-], m [-])`` from upstream to downstream

    Returns
    -------
    C : float
        Sonic conductance of the chain [m^3/(s Pa)]
    b : float
        Critical pressure ratio of the chain [-]

    Examples
    --------
    One restriction is its own chain; two identical ones (C = 1 dm^3/(s bar), b = 0.3)
    pass 76 % of the flow of one, choked below an overall ratio of 0.23:

    >>> series_characteristic([(1e-8, 0.3, 0.5)])
    (1e-08, 0.3)
    >>> C, b = series_characteristic([(1e-8, 0.3, 0.5), (1e-8, 0.3, 0.5)])
    >>> round(C / 1e-8, 3), round(b, 3)
    (0.757, 0.227)
    """
    elements = [(float(C), float(b), float(m)) for C, b, m in elements]
    if len(elements) == 1:
        return elements[0][0], elements[0][1]
    if any(C <= 0.0 for C, _, _ in elements):
        return 0.0, elements[0][1]
    # the flow through a unit inlet pressure: feasible below the chain's conductance, not
    # above; bisection to the last bit (the outlet pressure is monotone in the flow)
    lo, hi = 0.0, min(C for C, _, _ in elements)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if chain_outlet(1.0, mid, elements) is None:
            hi = mid
        else:
            lo = mid
    return lo, chain_outlet(1.0, lo, elements)


def combine_table(C_edge, b_edge, m_edge, upstream=(), downstream=()):
    """An edge table with fixed restrictions in series: the characteristic at each opening.

    Parameters
    ----------
    C_edge : sequence of float
        The edge's sonic conductance at each opening [m^3/(s Pa)]
    b_edge : sequence of float
        Its critical ratio at each opening [-]
    m_edge : sequence of float or None
        Its subsonic index at each opening; None = 0.5 [-]
    upstream : sequence of tuple
        ``(C [m^3/(s Pa)], b [-])`` of the restrictions between the upstream node and the edge
    downstream : sequence of tuple
        ``(C [m^3/(s Pa)], b [-])`` of those between the edge and the downstream node

    Returns
    -------
    C, b, m : list of float
        The chain's table: conductance [m^3/(s Pa)], critical ratio [-] and subsonic index
        (0.5, the form of ISO 6358-3's system characteristic) [-]; a closed opening (C = 0)
        stays closed with the edge's own b
    """
    m_edge = [0.5] * len(C_edge) if m_edge is None else m_edge
    up = [(C, b, 0.5) for C, b in upstream]
    down = [(C, b, 0.5) for C, b in downstream]
    Cs, bs, ms = [], [], []
    for C, b, m in zip(C_edge, b_edge, m_edge):
        if C <= 0.0:
            Cs.append(0.0)
            bs.append(b)
            ms.append(m)
            continue
        Cc, bc = series_characteristic(up + [(C, b, m)] + down)
        Cs.append(Cc)
        bs.append(bc)
        ms.append(0.5)
    return Cs, bs, ms
