"""Gas chamber: mass and energy conservation (paper Eq. 14-15, 22-24).

State per chamber: gas mass ``m`` and temperature ``T``; pressure follows
from the ideal-gas law ``p = m r T / V`` (Eq. 22-24). Enthalpy enters with
the upstream temperature and leaves with the chamber temperature.
"""
from numba import njit


@njit(cache=True, error_model="numpy")
def chamber_pressure(m, T, V, r):
    """Ideal-gas pressure ``p = m r T / V`` (Eq. 22-24).

    Parameters
    ----------
    m : float
        Gas mass [kg]
    T : float
        Gas temperature [K]
    V : float
        Volume [m^3]
    r : float
        Specific gas constant [J/(kg K)]

    Returns
    -------
    p : float
        Absolute pressure [Pa]
    """
    return m * r * T / V


@njit(cache=True, error_model="numpy")
def enthalpy_flow(q, T_source, T_chamber, cp):
    """Enthalpy carried by a mass flow ``q`` into the chamber [W].

    Gas entering (``q > 0``) carries ``cp T_source``; gas leaving carries the
    chamber's own ``cp T`` (paper Eq. 12-14).

    Parameters
    ----------
    q : float
        Mass flow into the chamber [kg/s]
    T_source : float
        Temperature upstream of an incoming flow [K]
    T_chamber : float
        Chamber gas temperature [K]
    cp : float
        Specific heat at constant pressure [J/(kg K)]
    """
    if q > 0.0:
        return cp * T_source * q
    return cp * T_chamber * q


@njit(cache=True, error_model="numpy")
def chamber_rates(m, T, p, dVdt, q, H, Q, cv, isothermal):
    """Mass and temperature derivatives of a chamber (paper Eq. 14-15).

    Mass (Eq. 15): ``dm/dt = q``. Energy (Eq. 14), written for ``T``:

    .. math:: m c_v \\frac{dT}{dt} = H - c_v T q - p \\frac{dV}{dt} + Q

    where ``H`` is the net enthalpy flow in (``sum q_i cp T_i - sum q_o cp T``)
    and ``Q`` the heat flow from the walls (Eq. 9). Isothermal: ``dT/dt = 0``.

    Parameters
    ----------
    m : float
        Gas mass [kg]
    T : float
        Gas temperature [K]
    p : float
        Pressure [Pa]
    dVdt : float
        Rate of change of the volume [m^3/s]
    q : float
        Net mass flow into the chamber [kg/s]
    H : float
        Net enthalpy flow into the chamber [W]
    Q : float
        Heat flow into the gas [W]
    cv : float
        Specific heat at constant volume [J/(kg K)]
    isothermal : bool
        Hold the temperature

    Returns
    -------
    dm, dT : float
        [kg/s], [K/s]
    """
    if isothermal:
        return q, 0.0
    return q, (H - cv * T * q - p * dVdt + Q) / (m * cv)
