"""Heat exchange between the gas of a chamber and its walls: heat models by name.

Each model is a small pure function (its equation and source in its
docstring) plus a :class:`HeatModel` entry in :data:`HEAT_MODELS` that says
which parameters (:data:`HEAT_PARAMETERS`, one source for their units,
defaults and bounds) it uses and how they drive the compiled core: the core
evaluates one law for every exchanging model,

.. math::
    \\Phi = h\\, S\\, (T_w - T), \\qquad
    h = h_0 + c_n\\, h_{nat}(p, T, T_w) + c_j\\, h_{jet}(q_{in}, T)

(paper Eq. 9 with ``h_0`` the fixed coefficient, :func:`natural_convection_coefficient`
and :func:`jet_convection_coefficient`); a model is a choice of ``h_0``,
``c_n`` and ``c_j`` written into the core's parameter slots. Every
exchanging model may also have a wall with thermal capacity (a wall
temperature state per chamber, :func:`wall_rate`; ``wall_mass = 0`` keeps
the wall at the ambient temperature as Eq. 9 assumes) and any
non-isothermal model a gas-temperature sensor with a response time (an
observation model: states ``T_a_sensor``, ``T_b_sensor`` that the comparison
reads instead of ``T_a``, ``T_b``).

The simulator picks a model by name (``model.heat.model``), as pvlib picks a
temperature model.
"""
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from pneucore.physics.gas import air_conductivity, air_viscosity
from pneucore.physics.sensors import TEMPERATURE_SENSOR
from pneucore.physics.states import StateTerm, register_state_term

#: Standard acceleration of gravity [m/s^2] (CGPM 1901)
G_STANDARD = 9.80665


# ---------------------------------------------------------------------------
# the laws (compiled; also callable from Python on scalars)
# ---------------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def convective_heat_flow(h, S, T_wall, T):
    """Fixed-coefficient convective exchange, paper Eq. 9.

    .. math:: \\Phi = \\varphi\\, s_e\\, (T_w - T)

    Parameters
    ----------
    h : float
        Convection coefficient [W/(m^2 K)]
    S : float
        Exchange (wall) area [m^2]
    T_wall : float
        Wall temperature, the ambient temperature unless the wall has a capacity [K]
    T : float
        Gas temperature [K]

    Returns
    -------
    Q : float
        Heat flow into the gas [W]

    Examples
    --------
    Gas 20 K above the wall, h = 25 W/(m^2 K) over 0.01 m^2, loses 5 W:

    >>> round(convective_heat_flow(25.0, 0.01, 293.15, 313.15), 12)
    -5.0
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


@njit(cache=True, error_model="numpy")
def churchill_chu_cylinder_nusselt(Ra, Pr):
    """Mean Nusselt number of a horizontal cylinder in natural convection.

    Churchill & Chu (1975), valid for ``1e-5 < Ra_D < 1e12``:

    .. math::
        Nu_D = \\left\\{0.60 + \\frac{0.387\\, Ra_D^{1/6}}
               {[1 + (0.559/Pr)^{9/16}]^{8/27}}\\right\\}^2

    Source: S. W. Churchill, H. H. S. Chu, "Correlating equations for laminar
    and turbulent free convection from a horizontal cylinder", Int. J. Heat
    Mass Transfer 18 (1975) 1049-1053 (Incropera & DeWitt, Eq. 9.34).

    Parameters
    ----------
    Ra : float
        Rayleigh number on the diameter [-]
    Pr : float
        Prandtl number [-]

    Returns
    -------
    Nu : float
        Nusselt number on the diameter [-]

    Examples
    --------
    A 0.1 m pipe 140 K above room air (Ra_D = 5.09e6, Pr = 0.69):

    >>> round(churchill_chu_cylinder_nusselt(5.09e6, 0.69), 1)
    23.1

    and the conduction limit of the correlation, ``0.6^2``:

    >>> round(churchill_chu_cylinder_nusselt(0.0, 0.71), 2)
    0.36
    """
    f = (1.0 + (0.559 / Pr) ** (9.0 / 16.0)) ** (8.0 / 27.0)
    s = 0.60 + 0.387 * Ra ** (1.0 / 6.0) / f
    return s * s


@njit(cache=True, error_model="numpy")
def natural_convection_coefficient(p, T, T_wall, D, r, cp):
    """Natural-convection coefficient between the gas and the wall of a horizontal cylinder.

    Air's properties at the chamber's state and the film temperature
    ``T_f = (T + T_w) / 2``: density ``rho = p / (r T_f)``, viscosity and
    conductivity by Sutherland's laws (:func:`pneucore.physics.gas.air_viscosity`,
    :func:`pneucore.physics.gas.air_conductivity`), ``beta = 1 / T_f`` (ideal gas):

    .. math::
        Ra = \\frac{g \\beta |T_w - T| D^3 \\rho^2 c_p}{\\mu k}, \\quad
        Pr = \\frac{c_p \\mu}{k}, \\quad h = Nu_D(Ra, Pr)\\, k / D

    with ``Nu_D`` of Churchill & Chu (:func:`churchill_chu_cylinder_nusselt`).
    ``h`` grows with the pressure (``Ra ~ p^2``) and the temperature difference.

    Parameters
    ----------
    p : float
        Gas pressure [Pa]
    T : float
        Gas temperature [K]
    T_wall : float
        Wall temperature [K]
    D : float
        Cylinder (bore) diameter [m]
    r : float
        Specific gas constant [J/(kg K)]
    cp : float
        Specific heat at constant pressure [J/(kg K)]

    Returns
    -------
    h : float
        Convection coefficient [W/(m^2 K)]

    Examples
    --------
    Air at 1 bar, 20 K above the wall of a 0.2 m cylinder: a few W/(m^2 K),
    the textbook order of magnitude for free convection in gases:

    >>> round(natural_convection_coefficient(1e5, 315.0, 295.0, 0.2, 287.05, 1004.7), 2)
    4.11
    """
    T_f = 0.5 * (T + T_wall)
    rho = p / (r * T_f)
    mu = air_viscosity(T_f)
    k = air_conductivity(T_f)
    Ra = G_STANDARD * abs(T_wall - T) / T_f * D * D * D * rho * rho * cp / (mu * k)
    return churchill_chu_cylinder_nusselt(Ra, cp * mu / k) * k / D


@njit(cache=True, error_model="numpy")
def jet_convection_coefficient(q_in, d_in, T, D):
    """Forced-convection coefficient of the jet of gas entering a chamber.

    Woodfield, Monde & Mitsutake (2007), measured during the filling of a
    vessel with hydrogen, nitrogen and argon (their Nu = 0.56 Re^0.67 +
    0.104 Ra^0.352; this is the forced term, the natural one is
    :func:`natural_convection_coefficient`):

    .. math::
        Re_d = \\frac{4 q_{in}}{\\pi d_{in} \\mu(T)}, \\quad
        Nu_D = 0.56\\, Re_d^{0.67}, \\quad h = Nu_D\\, k(T) / D

    Source: P. L. Woodfield, M. Monde, Y. Mitsutake, "Measurement of averaged
    heat transfer coefficients in high-pressure vessel during charging with
    hydrogen, nitrogen or argon gas", J. Thermal Science and Technology 2
    (2007) 180-191 (the mixed form is also HydDown's, Andreasen 2021).

    Parameters
    ----------
    q_in : float
        Mass flow entering the chamber [kg/s] (0 when none enters)
    d_in : float
        Inlet (jet) diameter [m]
    T : float
        Gas temperature [K]
    D : float
        Chamber diameter [m]

    Returns
    -------
    h : float
        Convection coefficient [W/(m^2 K)]

    Examples
    --------
    1 g/s of air through a 2.7 mm inlet into a 0.2 m vessel: Re ~ 2.5e4,
    h of several tens of W/(m^2 K), ten times the natural convection:

    >>> round(jet_convection_coefficient(1e-3, 2.71e-3, 295.0, 0.2), 1)
    65.3
    """
    if q_in <= 0.0:
        return 0.0
    Re = 4.0 * q_in / (math.pi * d_in * air_viscosity(T))
    return 0.56 * Re ** 0.67 * air_conductivity(T) / D


@njit(cache=True, error_model="numpy", _nrt=False)
def exchange_coefficient(h0, c_n, c_j, d_in, D, r, gamma, p, T, T_wall, q_in):
    """Coefficient ``h`` [W/(m^2 K)] of the core's heat law for one chamber (module docstring).

    Parameters
    ----------
    h0 : float
        Fixed coefficient of Eq. 9 [W/(m^2 K)]
    c_n, c_j : float
        Multipliers of the natural and jet terms [-] (0 = term off)
    d_in : float
        Inlet (jet) diameter [m]
    D : float
        Chamber (bore) diameter [m]
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]
    p : float
        Gas pressure [Pa]
    T : float
        Gas temperature [K]
    T_wall : float
        Wall temperature [K]
    q_in : float
        Mass flow entering the chamber [kg/s]
    """
    h = h0
    cp = gamma * r / (gamma - 1.0)
    if c_n > 0.0:
        h += c_n * natural_convection_coefficient(p, T, T_wall, D, r, cp)
    if c_j > 0.0:
        h += c_j * jet_convection_coefficient(q_in, d_in, T, D)
    return h


@njit(cache=True, error_model="numpy")
def wall_rate(Q_gas, S, T_wall, T_amb, mass, c, h_out):
    """Temperature rate of a chamber wall with thermal capacity.

    .. math:: m_w c_w \\frac{dT_w}{dt} = -\\Phi + h_o S (T_{amb} - T_w)

    the wall gives ``Phi`` (Eq. 9) to the gas and takes heat from the ambient
    through an outer coefficient over the same area (thin wall, uniform
    temperature: a Biot number well below 1, as for a steel vessel).

    Parameters
    ----------
    Q_gas : float
        Heat flow from the wall into the gas [W]
    S : float
        Wall area [m^2]
    T_wall : float
        Wall temperature [K]
    T_amb : float
        Ambient temperature [K]
    mass : float
        Wall mass [kg]
    c : float
        Wall specific heat [J/(kg K)]
    h_out : float
        Outer coefficient, wall to ambient [W/(m^2 K)]

    Returns
    -------
    dTw : float
        [K/s]

    Examples
    --------
    A 1 kg steel wall giving 50 W to the gas, no outer exchange, cools at 0.1 K/s:

    >>> wall_rate(50.0, 0.1, 295.0, 295.0, 1.0, 500.0, 0.0)
    -0.1
    """
    return (-Q_gas + h_out * S * (T_amb - T_wall)) / (mass * c)


@njit(cache=True, error_model="numpy", _nrt=False)
def wall_state_rate(y_s, p, T, Q, S, T_amb, prm, k0):
    """State-term rate of a chamber wall [K/s] (:func:`wall_rate`; signature of
    :mod:`pneucore.physics.states`): ``y_s`` the wall temperature [K], ``prm[k0:k0 + 3]``
    its mass [kg], specific heat [J/(kg K)] and outer coefficient [W/(m^2 K)]."""
    return wall_rate(Q, S, y_s, T_amb, prm[k0], prm[k0 + 1], prm[k0 + 2])


def _wall_start(p_a, p_b, T_a, T_b, T_amb, p_sup):
    # the walls start at the ambient temperature
    return (T_amb, 1e-6 * T_amb), (T_amb, 1e-6 * T_amb)


#: Walls with a thermal capacity (``heat.wall_mass``, effect ``wall_heat_capacity``): states
#: ``T_wall_a``, ``T_wall_b``; the exchange law reads them as the wall temperature
WALL = register_state_term(StateTerm(
    "wall", wall_state_rate,
    (("mass", "kg"), ("specific_heat", "J/(kg K)"), ("outer_coefficient", "W/(m^2 K)")),
    ("T_wall_a", "T_wall_b"), "K", _wall_start, frozen_with_constant_b=True,
    description="lumped wall heat balance of each chamber"))


# ---------------------------------------------------------------------------
# parameters and models (the registry)
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class HeatParameter:
    """A parameter of the heat models (``model.heat.<name>``, calibration path ``heat.<name>``).

    Parameters
    ----------
    name : str
        Field name
    unit : str
        SI unit
    default : float
        Value when the model gives none
    min, max : float
        Bounds for validation and calibration
    description : str
        One line
    """
    name: str
    unit: str
    default: float
    min: float
    max: float
    description: str

    def to_dict(self):
        return {"name": self.name, "unit": self.unit, "default": self.default, "min": self.min,
                "max": self.max, "description": self.description}


#: Every heat-model parameter, once (unit, default, bounds)
HEAT_PARAMETERS = {p.name: p for p in (
    HeatParameter("coefficient", "W/(m^2 K)", 25.0, 0.0, 1e6,
                  "fixed convection coefficient h of Eq. 9"),
    HeatParameter("natural_multiplier", "-", 1.0, 0.0, 20.0,
                  "factor on the natural-convection Nusselt number (1 = the correlation)"),
    HeatParameter("jet_multiplier", "-", 1.0, 0.0, 20.0,
                  "factor on the inflow-jet Nusselt number (1 = the correlation)"),
    HeatParameter("inlet_diameter", "m", 4e-3, 1e-4, 0.1,
                  "diameter of the inlet through which the jet enters"),
    HeatParameter("wall_mass", "kg", 0.0, 0.0, 1e4,
                  "mass of each chamber's wall (0 = wall held at the ambient temperature)"),
    HeatParameter("wall_specific_heat", "J/(kg K)", 500.0, 50.0, 5000.0,
                  "specific heat of the wall (steel: 500)"),
    HeatParameter("outer_coefficient", "W/(m^2 K)", 10.0, 0.0, 1e4,
                  "convection coefficient from the wall's outer face to the ambient"),
    HeatParameter("sensor_time_constant", "s", 0.0, 0.0, 100.0,
                  "response time of the gas-temperature sensors (0 = ideal)"),
)}

_WALL = ("wall_mass", "wall_specific_heat", "outer_coefficient")
_SENSOR = ("sensor_time_constant",)


class HeatModel:
    """A registered heat model.

    Parameters
    ----------
    name : str
        Registry name
    func : callable
        The model's pure law (its docstring gives the equation and source)
    isothermal : bool
        The core freezes the gas temperature
    parameters : tuple of str
        Names in :data:`HEAT_PARAMETERS` this model uses
    description : str
        One line
    fixed, natural, jet : bool
        Which terms of the core's law (module docstring) the model switches on
    fit_parameters : tuple of str
        The exchange parameters a calibration of this model fits
        (:func:`pneucore.analysis.heat_compare.compare_heat_models`)
    """

    def __init__(self, name, func, isothermal, parameters, description, fixed=False,
                 natural=False, jet=False, fit_parameters=()):
        self.name = name
        self.func = func
        self.isothermal = isothermal
        self.parameters = tuple(parameters)
        self.description = description
        self.fixed = fixed
        self.natural = natural
        self.jet = jet
        self.fit_parameters = tuple(fit_parameters)

    @property
    def uses_coefficient(self):
        """True when the fixed coefficient ``h`` of Eq. 9 is part of the model."""
        return self.fixed

    def __call__(self, *args):
        """Apply the model's law to scalars or arrays (arguments as :attr:`func`)."""
        out = np.vectorize(self.func, otypes=[float])(*args)
        return float(out) if np.ndim(out) == 0 else out

    def core_coefficient(self, h):
        """Coefficient [W/(m^2 K)] written into the compiled core's parameter vector."""
        return float(h) if self.fixed else 0.0

    def core_values(self, heat):
        """This model's slots of the core's parameter vector from ``heat`` (a
        :class:`pneucore.description.model.Heat`): ``{slot name: value}``, slot names of
        :data:`pneucore.core.layout.PRM_INDEX`."""
        out = {"H": self.core_coefficient(heat.coefficient),
               "ISOTHERMAL": 1.0 if self.isothermal else 0.0}
        if self.natural:
            out["HEAT_NAT"] = heat.natural_multiplier
        if self.jet:
            out["HEAT_JET"] = heat.jet_multiplier
            out["HEAT_D_IN"] = heat.inlet_diameter
        return out

    def add_states(self, heat, build, T_a, T_b):
        """Declare the wall and sensor states this model's parameters ask for.

        Parameters
        ----------
        heat : Heat
            The model's heat section
        build : pneucore.description.effects.CoreBuild
            The core being assembled
        T_a, T_b : float
            Initial gas temperatures [K] (the sensors start there)
        """
        if "wall_mass" in self.parameters and heat.wall_mass > 0.0:
            add_wall(build, heat.wall_mass, heat.wall_specific_heat, heat.outer_coefficient)
        if "sensor_time_constant" in self.parameters and heat.sensor_time_constant > 0.0:
            add_temperature_sensor(build, heat.sensor_time_constant, T_a, T_b)

    def to_dict(self):
        """``{name, description, parameters: [{name, unit, default, min, max, description}]}``."""
        return {"name": self.name, "description": self.description,
                "parameters": [HEAT_PARAMETERS[p].to_dict() for p in self.parameters]}


def add_wall(build, mass, c, h_out):
    """Give each chamber a wall with thermal capacity (state term :data:`WALL`).

    Parameters
    ----------
    build : pneucore.description.effects.CoreBuild
        The core being assembled
    mass : float
        Wall mass of each chamber [kg]
    c : float
        Wall specific heat [J/(kg K)]
    h_out : float
        Outer coefficient to the ambient [W/(m^2 K)]
    """
    build.add_term(WALL, (mass, c, h_out))


def add_temperature_sensor(build, tau, T_a, T_b):
    """First-order gas-temperature sensors (state term
    :data:`pneucore.physics.sensors.TEMPERATURE_SENSOR`): states ``T_a_sensor``, ``T_b_sensor``.

    Parameters
    ----------
    build : pneucore.description.effects.CoreBuild
        The core being assembled
    tau : float
        Sensor time constant [s]
    T_a, T_b : float
        Initial gas temperatures [K] (the sensors start there)
    """
    build.add_term(TEMPERATURE_SENSOR, (tau,))


#: Registry of heat models by name (``model.heat.model``)
HEAT_MODELS = {m.name: m for m in (
    HeatModel("isothermal", isothermal_heat_flow, True, (),
              "gas temperature held at the wall (ambient) temperature"),
    HeatModel("adiabatic", adiabatic_heat_flow, False, _SENSOR,
              "no heat exchange with the walls"),
    HeatModel("convective", convective_heat_flow, False, ("coefficient",) + _WALL + _SENSOR,
              "fixed-coefficient convection to the walls, paper Eq. 9", fixed=True,
              fit_parameters=("coefficient",)),
    HeatModel("natural_convection", natural_convection_coefficient, False,
              ("natural_multiplier",) + _WALL + _SENSOR,
              "natural convection in a horizontal cylinder of the bore's diameter (Churchill & Chu "
              "1975), air's properties at the chamber's pressure and film temperature",
              natural=True, fit_parameters=("natural_multiplier",)),
    HeatModel("natural_and_jet", jet_convection_coefficient, False,
              ("natural_multiplier", "jet_multiplier", "inlet_diameter") + _WALL + _SENSOR,
              "natural convection plus the forced convection of the inflow jet while gas enters "
              "(Woodfield, Monde & Mitsutake 2007: Nu = 0.56 Re^0.67 + Nu_natural)",
              natural=True, jet=True, fit_parameters=("natural_multiplier", "jet_multiplier")),
)}

#: The models shipped with the package: they cannot be replaced or removed
BUILTIN_HEAT_MODELS = frozenset(HEAT_MODELS)
#: Parameters the core reads for each term of its law (:meth:`HeatModel.pack`)
_TERM_PARAMETERS = {"fixed": ("coefficient",), "natural": ("natural_multiplier",),
                    "jet": ("jet_multiplier", "inlet_diameter")}


def register_heat_model(name, func, description, parameters=(), fixed=False, natural=False,
                        jet=False, isothermal=False, fit_parameters=None, replace=False):
    """Add a heat model that a model selects by name (``heat.model``).

    A heat model is a choice of the terms of the law the compiled core evaluates
    (module docstring: ``h = h_0 + c_n h_nat + c_j h_jet``, paper Eq. 9 with the
    natural and jet correlations), with the parameters it exposes
    (:data:`HEAT_PARAMETERS`: units, defaults and bounds, with the optional wall and
    temperature sensor). Selecting it writes its terms into the core's parameter slots
    (:meth:`HeatModel.pack`): no compilation, the cached core runs it.

    Parameters
    ----------
    name : str
        Registry name
    func : callable
        The model's pure law for scalars (its docstring gives the equation and source)
    description : str
        One line, shown by GET /api/heat-models
    parameters : tuple of str
        Names in :data:`HEAT_PARAMETERS` the model exposes; each term switched on
        needs its own (``coefficient`` for ``fixed``, ``natural_multiplier`` for
        ``natural``, ``jet_multiplier`` and ``inlet_diameter`` for ``jet``)
    fixed, natural, jet : bool
        The terms of the core's law the model switches on
    isothermal : bool
        The core freezes the gas temperature (no other term then)
    fit_parameters : tuple of str or None
        Parameters a calibration of this model fits (default: the terms' own)
    replace : bool
        Allow replacing a model registered at run time (a built-in one cannot be)

    Returns
    -------
    model : HeatModel
        The registered entry

    Examples
    --------
    Paper Eq. 9's fixed coefficient plus natural convection, side by side:

    >>> m = register_heat_model("fixed_and_natural", convective_heat_flow,
    ...                         "Eq. 9 plus natural convection", ("coefficient", "natural_multiplier"),
    ...                         fixed=True, natural=True)
    >>> m.fit_parameters
    ('coefficient', 'natural_multiplier')
    >>> unregister_heat_model("fixed_and_natural")
    """
    if not isinstance(name, str) or not name:
        raise ValueError("a heat model's name must be a non-empty string")
    if name in BUILTIN_HEAT_MODELS:
        raise ValueError(f"{name!r} is a built-in heat model and cannot be replaced")
    if name in HEAT_MODELS and not replace:
        raise ValueError(f"{name!r} is already registered (replace=True to replace it)")
    parameters = tuple(parameters)
    unknown = [p for p in parameters if p not in HEAT_PARAMETERS]
    if unknown:
        raise ValueError(f"unknown heat parameters {unknown}; known: {sorted(HEAT_PARAMETERS)}")
    terms = {"fixed": fixed, "natural": natural, "jet": jet}
    if isothermal and any(terms.values()):
        raise ValueError("an isothermal model has no exchange terms")
    own = tuple(p for term, on in terms.items() if on for p in _TERM_PARAMETERS[term])
    missing = [p for p in own if p not in parameters]
    if missing:
        raise ValueError(f"the terms switched on read the parameters {missing}: list them")
    fit = own if fit_parameters is None else tuple(fit_parameters)
    model = HeatModel(name, func, isothermal, parameters, description, fixed=fixed,
                      natural=natural, jet=jet,
                      fit_parameters=tuple(p for p in fit if p != "inlet_diameter"))
    HEAT_MODELS[name] = model
    return model


def unregister_heat_model(name):
    """Remove a heat model registered with :func:`register_heat_model` (a built-in one stays).

    Parameters
    ----------
    name : str
        Its registry name (an unknown name is ignored)
    """
    if name in BUILTIN_HEAT_MODELS:
        raise ValueError(f"{name!r} is a built-in heat model and cannot be removed")
    HEAT_MODELS.pop(name, None)
