"""Ideal-gas constants for dry air and the ISO reference atmosphere.

The paper (Maré, Geider & Colin) treats air as an ideal gas with constant
specific heats (Eq. 10-11): ``P = rho r T`` and ``cp = cv + r``.
"""

#: Specific gas constant of dry air [J/(kg K)]
R_AIR = 287.05
#: Ratio of specific heats of air [-]
GAMMA_AIR = 1.4
#: ISO 6358 / ISO 8778 reference density of air [kg/m^3]
RHO_REF = 1.185
#: ISO 6358 / ISO 8778 reference temperature [K]
T_REF = 293.15
#: Standard atmospheric pressure used as default ambient [Pa]
P_ATM = 1.013e5


def cv(r=R_AIR, gamma=GAMMA_AIR):
    """Specific heat at constant volume ``cv = r / (gamma - 1)`` [J/(kg K)]."""
    return r / (gamma - 1.0)


def cp(r=R_AIR, gamma=GAMMA_AIR):
    """Specific heat at constant pressure ``cp = gamma r / (gamma - 1)`` [J/(kg K)] (Eq. 11)."""
    return gamma * r / (gamma - 1.0)


def density(p, T, r=R_AIR):
    """Ideal-gas density ``rho = p / (r T)`` (Eq. 10).

    Parameters
    ----------
    p : float  Absolute pressure [Pa]
    T : float  Temperature [K]
    r : float  Specific gas constant [J/(kg K)]

    Returns
    -------
    rho : float  Density [kg/m^3]
    """
    return p / (r * T)
