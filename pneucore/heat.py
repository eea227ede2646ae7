"""Heat exchange between the gas of a chamber and the jack walls (paper Eq. 9).

Each heat model is a small pure function of the same signature,
``heat_flow(h, S, T_wall, T) -> Q`` (heat flow *into* the gas [W]), plus a
flag saying whether the model pins the gas temperature (isothermal). The
simulator picks one by name through :data:`HEAT_MODELS`
(``model.heat.model = "convective"``), as pvlib picks a temperature model.
"""
import numpy as np
from numba import njit


@njit(cache=True, error_model="numpy")
def convective_heat_flow(h, S, T_wall, T):
    """Fixed-coefficient convective exchange, paper Eq. 9.

    .. math:: \\Phi = \\varphi\\, s_e\\, (T_w - T)

    Parameters
    ----------
    h : float  Convection coefficient [W/(m^2 K)]
    S : float  Exchange (wall) area [m^2]
    T_wall : float  Wall temperature, taken as the ambient temperature [K]
    T : float  Gas temperature [K]

    Returns
    -------
    Q : float  Heat flow into the gas [W]
    """
    return h * S * (T_wall - T)


def adiabatic_heat_flow(h, S, T_wall, T):
    """No exchange with the walls: ``Q = 0`` [W] whatever ``h``."""
    return 0.0


def isothermal_heat_flow(h, S, T_wall, T):
    """Isothermal gas: the walls supply whatever heat keeps ``T = T_wall``.

    The flow itself is implicit (infinite coefficient); the simulator holds
    the gas temperature at the wall temperature and this returns 0 [W].
    """
    return 0.0


class HeatModel:
    """A registered heat model.

    ``coefficient(h)`` maps the user's coefficient to the one the compiled core
    uses, and ``isothermal`` tells the core to freeze the temperature.
    """

    def __init__(self, name, func, isothermal, uses_coefficient, description):
        self.name = name
        self.func = func
        self.isothermal = isothermal
        self.uses_coefficient = uses_coefficient
        self.description = description

    def __call__(self, h, S, T_wall, T):
        """Heat flow into the gas [W] for coefficient ``h`` [W/(m^2 K)], wall area ``S`` [m^2],
        wall temperature ``T_wall`` [K] and gas temperature ``T`` [K] (scalars or arrays)."""
        out = np.vectorize(self.func, otypes=[float])(h, S, T_wall, T)
        return float(out) if np.ndim(out) == 0 else out

    def core_coefficient(self, h):
        """Coefficient [W/(m^2 K)] written into the compiled core's parameter vector."""
        return float(h) if self.uses_coefficient else 0.0


#: Registry of heat models by name (``model.heat.model``)
HEAT_MODELS = {
    "isothermal": HeatModel("isothermal", isothermal_heat_flow, True, False,
                            "gas temperature held at the wall (ambient) temperature"),
    "adiabatic": HeatModel("adiabatic", adiabatic_heat_flow, False, False,
                           "no heat exchange with the walls"),
    "convective": HeatModel("convective", convective_heat_flow, False, True,
                            "fixed-coefficient convection to the walls, paper Eq. 9"),
}
