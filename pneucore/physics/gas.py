"""Ideal-gas constants for dry air and the ISO reference atmosphere.

The paper (Maré, Geider & Colin) treats air as an ideal gas with constant
specific heats (Eq. 10-11): ``P = rho r T`` and ``cp = cv + r``.
"""
from numba import njit

#: Specific gas constant of dry air [J/(kg K)]
R_AIR = 287.05
#: Ratio of specific heats of air [-]
GAMMA_AIR = 1.4
#: ISO 6358 / ISO 8778 reference density of air [kg/m^3]
RHO_REF = 1.185
#: ISO 6358 / ISO 8778 reference temperature [K]
T_REF = 293.15
#: 0 °C in kelvin (the Celsius scale's zero, SI brochure 2.3.1) [K]
T_ZERO_CELSIUS = 273.15
#: One pound-force per square inch [Pa] (0.45359237 kg x 9.80665 m/s^2 / 0.0254^2 m^2)
PSI = 6894.757293168361
#: Standard atmospheric pressure used as default ambient [Pa]
P_ATM = 1.013e5
#: Lowest absolute pressure of a source (supply or ambient) [Pa]: below it the mean free path
#: of air, ``mu / p * sqrt(pi r T / 2)`` (6.6 um at 1 kPa and 293 K, kinetic theory), exceeds
#: about 1 % of a 0.5 mm valve passage and the flow leaves the continuum regime that the
#: ISO 6358 and nozzle laws (and the chamber equations) assume (Knudsen number > 0.01)
P_CONTINUUM_MIN = 1e3


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
    p : float
        Absolute pressure [Pa]
    T : float
        Temperature [K]
    r : float
        Specific gas constant [J/(kg K)]

    Returns
    -------
    rho : float
        Density [kg/m^3]
    """
    return p / (r * T)


# --- transport properties of air (Sutherland's laws) -------------------------
# F. M. White, Viscous Fluid Flow, 3rd ed. (2006), Tables 1-2 and 1-3: within 2 %
# (viscosity) and 2 % (conductivity) of measured air data from 170 to 1900 K.

#: Sutherland reference viscosity, temperature and constant of air [Pa s], [K], [K]
MU_REF, MU_T_REF, MU_SUTHERLAND = 1.716e-5, 273.0, 111.0
#: Sutherland reference conductivity, temperature and constant of air [W/(m K)], [K], [K]
K_REF, K_T_REF, K_SUTHERLAND = 0.0241, 273.0, 194.0


@njit(cache=True, error_model="numpy")
def air_viscosity(T):
    """Dynamic viscosity of air by Sutherland's law (White 2006, Table 1-2).

    .. math:: \\mu = \\mu_0 (T/T_0)^{3/2} (T_0 + S) / (T + S)

    Parameters
    ----------
    T : float
        Temperature [K]

    Returns
    -------
    mu : float
        Dynamic viscosity [Pa s]

    Examples
    --------
    At 300 K (Incropera & DeWitt, Table A.4: 1.846e-5 Pa s):

    >>> round(air_viscosity(300.0) * 1e5, 3)
    1.847
    """
    return MU_REF * (T / MU_T_REF) ** 1.5 * (MU_T_REF + MU_SUTHERLAND) / (T + MU_SUTHERLAND)


@njit(cache=True, error_model="numpy")
def air_conductivity(T):
    """Thermal conductivity of air by Sutherland's law (White 2006, Table 1-3).

    .. math:: k = k_0 (T/T_0)^{3/2} (T_0 + S_k) / (T + S_k)

    Parameters
    ----------
    T : float
        Temperature [K]

    Returns
    -------
    k : float
        Thermal conductivity [W/(m K)]

    Examples
    --------
    At 300 K (Incropera & DeWitt, Table A.4: 0.0263 W/(m K)):

    >>> round(air_conductivity(300.0), 4)
    0.0262
    """
    return K_REF * (T / K_T_REF) ** 1.5 * (K_T_REF + K_SUTHERLAND) / (T + K_SUTHERLAND)
