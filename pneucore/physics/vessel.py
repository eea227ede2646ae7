"""A rigid gas vessel filled or emptied through an orifice, built from the jack's model objects.

A vessel is a chamber whose volume does not change: a locked-piston chamber
A (``scenario.locked``) of the vessel's volume (its dead volume at ``x = 0``),
fed through the P-A edge of a 3/2 valve held open, with the vessel's inner
wall area as the exchange area and its diameter as the bore (the length of
the natural-convection correlation, :func:`pneucore.physics.heat.natural_convection_coefficient`).

The orifice is a sharp orifice of diameter ``d`` and discharge coefficient
``Cd``: its effective area ``Cd pi d^2 / 4`` through the ideal-nozzle law
(Saint-Venant, paper Eq. 1-3, ``valve.flow_law = "saint_venant"``), the law
with which such a ``Cd`` is defined and measured (ISO 5167-2 defines Cd on the
incompressible flow; for gases the nozzle equation with Cd is the standard
practice of e.g. the TNO Yellow Book, Ch. 2, as HydDown uses it). The
conductance ``C`` is the one with the same choked flow
(:func:`orifice_conductance`, the inverse of :func:`pneucore.physics.flow.saint_venant_area`).

:func:`filling_test` builds the published test of
``shared/data/vessel-filling`` (Thorncroft, Patton & Gordon 2007).
"""
from __future__ import annotations

import csv
import math
import os

import numpy as np

from pneucore.physics.flow import saint_venant_critical_ratio
from pneucore.physics.gas import GAMMA_AIR, R_AIR, RHO_REF, T_REF

#: Density of steel [kg/m^3] and its specific heat [J/(kg K)] (values of the data's README)
STEEL_DENSITY, STEEL_SPECIFIC_HEAT = 7800.0, 500.0

#: The published test (shared/data/vessel-filling/README.md): inner diameter, length and wall
#: thickness [m], orifice diameter [m] and discharge coefficient [-], initial pressure [Pa],
#: atmosphere [Pa] and temperature [K] (the vessel starts at it)
FILLING_TEST = {"diameter": 0.20, "length": 0.515, "wall": 8.18e-3, "orifice": 2.71e-3, "Cd": 0.84,
                "p0": 3.7e3, "p_atm": 1.00e5, "T_atm": 295.0}


def orifice_conductance(d, Cd, r=R_AIR, gamma=GAMMA_AIR):
    """Sonic conductance of a sharp orifice with the choked flow of the ideal nozzle.

    .. math::
        C = \\frac{C_d \\pi d^2/4}{\\rho_0 \\sqrt{r T_0}}
            \\sqrt{\\gamma \\left(\\frac{2}{\\gamma+1}\\right)^{(\\gamma+1)/(\\gamma-1)}}

    (paper Eq. 2 equated with Eq. 5, ISO 6358 reference ``rho_0``, ``T_0``).

    Parameters
    ----------
    d : float
        Orifice diameter [m]
    Cd : float
        Discharge coefficient [-]
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]

    Returns
    -------
    C : float
        Sonic conductance [m^3/(s Pa)]

    Examples
    --------
    The 2.71 mm orifice of the vessel test, Cd = 0.84: about 0.97 dm^3/(s bar):

    >>> round(orifice_conductance(2.71e-3, 0.84) * 1e8, 3)
    0.965
    """
    k = gamma * (2.0 / (gamma + 1.0)) ** ((gamma + 1.0) / (gamma - 1.0))
    return Cd * math.pi * d * d / 4.0 * math.sqrt(k) / (RHO_REF * math.sqrt(r * T_REF))


def cylinder_wall_mass(D, L, e, density=STEEL_DENSITY):
    """Mass of a closed cylindrical shell: lateral wall and two flat ends [kg].

    Parameters
    ----------
    D : float
        Inner diameter [m]
    L : float
        Inner length [m]
    e : float
        Wall thickness [m]
    density : float
        Wall density [kg/m^3]
    """
    Ro = D / 2.0 + e
    return density * (math.pi * (Ro * Ro - D * D / 4.0) * L + 2.0 * math.pi * Ro * Ro * e)


def vessel_model(volume, D, wall_area, d, Cd, pressure, temperature, heat=None, name="vessel"):
    """Model JSON of a rigid vessel filled from a source through a sharp orifice.

    Parameters
    ----------
    volume : float
        Inner volume [m^3]
    D : float
        Inner diameter (the bore: natural-convection length) [m]
    wall_area : float
        Inner wall area (exchange area) [m^2]
    d : float
        Orifice diameter [m]
    Cd : float
        Orifice discharge coefficient [-]
    pressure, temperature : float
        Source (supply) and ambient pressure [Pa] and temperature [K]
    heat : dict or None
        The ``heat`` section (None = the convective default)
    name : str
        Model name

    Returns
    -------
    model : dict
        JSON for :meth:`pneucore.description.model.Model.from_dict`
    """
    C = orifice_conductance(d, Cd)
    b = saint_venant_critical_ratio(GAMMA_AIR)   # unused by the nozzle law; the table needs one
    src = {"pressure": pressure, "temperature": temperature}
    m = {
        "name": name,
        "description": f"rigid vessel of {volume * 1e3:.4g} L through a {d * 1e3:.3g} mm orifice "
                       f"(Cd {Cd:g}): a locked chamber A",
        "jack": {"bore": D, "rod_a": 0.0, "rod_b": 0.0, "stroke": 0.01, "dead_volume_a": volume,
                 "dead_volume_b": volume, "moving_mass": 1.0, "wall_area_a": wall_area},
        "valve": {"kind": "3/2", "flow_law": "saint_venant", "b_chamber_pressure": pressure,
                  "ports": {"P-A": {"opening": [0.0, 1.0], "C": [C, C], "b": [b, b]},
                            "A-R": {"opening": [0.0, 1.0], "C": [0.0, 0.0], "b": [b, b]}}},
        "supply": dict(src), "ambient": dict(src),
    }
    if heat is not None:
        m["heat"] = dict(heat)
    return m


def _read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], np.array([[float(v) for v in r] for r in rows[1:] if r], float)


def published_vessel(heat=None):
    """Model JSON of the published vessel (:data:`FILLING_TEST`), open to the 1.00 bar atmosphere.

    The same model fills (from a vacuum) and discharges (from a pressure): only the
    experiment's initial state differs.

    Parameters
    ----------
    heat : dict or None
        The model's ``heat`` section

    Returns
    -------
    model : dict
        Model JSON (:func:`vessel_model`)
    """
    g = FILLING_TEST
    volume, area, D = vessel_dimensions()
    return vessel_model(volume, D, area, g["orifice"], g["Cd"], g["p_atm"], g["T_atm"], heat,
                        name="vessel-filling (Thorncroft et al. 2007)")


def read_vessel_record(data_dir):
    """A vessel record in the published data's format, on one merged time base.

    ``pressure.csv`` (``t [s], p [bar]`` absolute) and ``gas_temperature.csv``
    (``t [s], T [K]``), each with a header line, sampled at their own times.

    Parameters
    ----------
    data_dir : str
        Folder holding the two files

    Returns
    -------
    t : numpy.ndarray
        Merged sample times from 0 [s]
    p, T : numpy.ndarray
        Pressure [Pa] and temperature [K] (NaN where the other signal was sampled)
    """
    _, p = _read_csv(os.path.join(data_dir, "pressure.csv"))
    _, T = _read_csv(os.path.join(data_dir, "gas_temperature.csv"))
    t = np.unique(np.concatenate([[0.0], p[:, 0], T[:, 0]]))
    p_col = np.full(t.shape, np.nan)
    T_col = np.full(t.shape, np.nan)
    p_col[np.searchsorted(t, p[:, 0])] = p[:, 1] * 1e5
    T_col[np.searchsorted(t, T[:, 0])] = T[:, 1]
    return t, p_col, T_col


def filling_test(data_dir, heat=None):
    """The published vessel-filling test (``shared/data/vessel-filling``) as a model and experiment.

    A 16.18 L horizontal steel cylinder (D 0.20 m, L 0.515 m, wall 8.18 mm),
    evacuated to 3.7 kPa at 295 K, opened at t = 0 to the atmosphere (1.00 bar,
    295 K) through a 2.71 mm sharp orifice, Cd 0.84 (the data's README).
    Pressure and gas temperature are measured on different time bases; the
    measurement merges them (a signal is missing where the other was sampled).

    Parameters
    ----------
    data_dir : str
        Folder holding ``pressure.csv`` and ``gas_temperature.csv``
    heat : dict or None
        The model's ``heat`` section

    Returns
    -------
    model : dict
        Model JSON (:func:`vessel_model`)
    experiment : dict
        Experiment JSON (measurement inline, locked scenario, initial state)
    """
    g = FILLING_TEST
    model = published_vessel(heat)
    t, p_col, T_col = read_vessel_record(data_dir)
    meas = {"name": "vessel-filling", "t": t.tolist(), "u": [1.0] * len(t),
            "p_a": [None if math.isnan(v) else v for v in p_col],
            "T_a": [None if math.isnan(v) else v for v in T_col],
            "meta": {"accuracy": dict(VESSEL_ACCURACY)}}
    exp = {"name": "vessel-filling", "measurement": meas,
           "scenario": {"locked": True, "x0": 0.0, "initial": {"p_a": g["p0"], "T_a": g["T_atm"]},
                        "solver": {"max_step": 0.5}}}
    return model, exp


#: Wall of the published vessel: steel mass from its geometry, steel's specific heat
VESSEL_WALL = {"wall_mass": cylinder_wall_mass(FILLING_TEST["diameter"], FILLING_TEST["length"],
                                               FILLING_TEST["wall"]),
               "wall_specific_heat": STEEL_SPECIFIC_HEAT}


#: Thermal conductivity of carbon steel [W/(m K)] (Incropera & DeWitt, Table A.1, plain carbon
#: steel at 300 K: 60.5; AISI 1010: 63.9; AISI 4130: 42.7: the low end, the slowest wall)
STEEL_CONDUCTIVITY = 43.0


def nozzle_mass_flow(p_up, T_up, p_down, area, r=R_AIR, gamma=GAMMA_AIR, r_lin=0.999):
    """Mass flow of an ideal nozzle of effective area ``Cd A`` (de Saint-Venant), from up to down.

    .. math::
        q = C_d A\\, p_u \\sqrt{\\frac{2\\gamma}{(\\gamma-1) r T_u}
            \\left(\\rho_r^{2/\\gamma} - \\rho_r^{(\\gamma+1)/\\gamma}\\right)}

    with ``rho_r = max(p_d / p_u, (2/(gamma+1))^(gamma/(gamma-1)))`` (choked below the
    critical ratio), linear in ``1 - p_d/p_u`` above ``r_lin`` (the square root's infinite
    slope at equal pressures is not physical: the flow turns laminar there). Written here
    from the textbook formula (Anderson, Modern Compressible Flow, Ch. 5), independently of
    :mod:`pneucore.physics.flow`, for :func:`reference_vessel_run`.

    Parameters
    ----------
    p_up : float
        Upstream pressure [Pa]
    T_up : float
        Upstream temperature [K]
    p_down : float
        Downstream pressure [Pa]
    area : float
        Effective area ``Cd A`` [m^2]
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]
    r_lin : float
        Pressure ratio above which the flow is linearised [-]

    Returns
    -------
    q : float
        Mass flow [kg/s] (>= 0)

    Examples
    --------
    Choked air from 1 bar, 295 K through the 2.71 mm orifice (Cd 0.84): ``Cd A`` =
    4.845e-6 m^2 times ``p sqrt(gamma / (r T)) (2/(gamma+1))^3`` = 235 kg/(m^2 s), 1.14 g/s:

    >>> round(nozzle_mass_flow(1e5, 295.0, 1e3, 0.84 * math.pi * 2.71e-3 ** 2 / 4) * 1e3, 2)
    1.14
    """
    crit = (2.0 / (gamma + 1.0)) ** (gamma / (gamma - 1.0))

    def flow(ratio):
        ratio = max(ratio, crit)
        return area * p_up * math.sqrt(2.0 * gamma / ((gamma - 1.0) * r * T_up)
                                       * (ratio ** (2.0 / gamma) - ratio ** ((gamma + 1.0) / gamma)))

    ratio = p_down / p_up
    if ratio >= 1.0:
        return 0.0
    if ratio > r_lin:
        return flow(r_lin) * (1.0 - ratio) / (1.0 - r_lin)
    return flow(ratio)


def reference_vessel_run(t_eval, p0, T0, p_src, T_src, volume, area, orifice_area, h_inner,
                         wall_mass, wall_thickness, wall_specific_heat=STEEL_SPECIFIC_HEAT,
                         wall_conductivity=STEEL_CONDUCTIVITY, layers=6, outer_coefficient=5.0,
                         sensor_time_constant=0.0, r=R_AIR, gamma=GAMMA_AIR):
    """A finer, independent vessel model: the reference that heat models are tested against.

    Not the simulator's core (no shared code but the heat correlation the caller passes):
    mass and energy of an ideal gas in a rigid volume fed or emptied through an ideal
    nozzle (:func:`nozzle_mass_flow`) from a source at ``p_src``, ``T_src``,

    .. math::
        \\dot m = q, \\qquad m c_v \\dot T = q_{in} (c_p T_{src} - c_v T) + q_{out} r T
        + h S (T_{w,1} - T)

    a wall conducted through its thickness in ``layers`` slabs of equal mass (plane wall:
    the 8 mm of the published vessel against its 100 mm radius), the inner slab exchanging
    with the gas by ``h_inner(p, T, T_w1, q_in)``, the outer one with the ambient (``T_src``)
    by ``outer_coefficient``, and a first-order thermocouple ``dT_s/dt = (T - T_s)/tau``.
    Integrated by scipy's Radau (implicit, 5th order) with tight tolerances.

    Parameters
    ----------
    t_eval : array_like
        Output times [s] (from 0)
    p0, T0 : float
        Initial gas pressure [Pa] and temperature [K] (the wall and sensor start at ``T_src``
        and ``T0``)
    p_src, T_src : float
        Source (the atmosphere: filling below it, discharge above it) pressure [Pa] and
        temperature [K]
    volume : float
        Inner volume [m^3]
    area : float
        Inner wall area [m^2] (the outer one taken equal)
    orifice_area : float
        Effective orifice area ``Cd pi d^2/4`` [m^2]
    h_inner : callable
        ``h_inner(p [Pa], T [K], T_wall [K], q_in [kg/s])`` -> inner coefficient [W/(m^2 K)]
    wall_mass : float
        Wall mass [kg]
    wall_thickness : float
        Wall thickness [m]
    wall_specific_heat : float
        [J/(kg K)]
    wall_conductivity : float
        [W/(m K)]
    layers : int
        Slabs through the thickness [-]
    outer_coefficient : float
        Outer face to ambient [W/(m^2 K)]
    sensor_time_constant : float
        Thermocouple time constant [s] (0 = ideal)
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]

    Returns
    -------
    run : dict
        ``t`` [s], ``p`` [Pa], ``T`` (mean gas) [K], ``T_sensor`` [K], ``T_wall`` (inner slab) [K]
    """
    from scipy.integrate import solve_ivp

    cv = r / (gamma - 1.0)
    cp = gamma * cv
    n = int(layers)
    cw = wall_mass * wall_specific_heat / n                        # per slab [J/K]
    g_wall = wall_conductivity * area / (wall_thickness / n)       # slab to slab [W/K]
    tau = float(sensor_time_constant)

    def rhs(t, y):
        m, T, Ts = y[0], y[1], y[2]
        Tw = y[3:]
        p = m * r * T / volume
        if p_src > p:
            q_in, q_out = nozzle_mass_flow(p_src, T_src, p, orifice_area, r, gamma), 0.0
        else:
            q_in, q_out = 0.0, nozzle_mass_flow(p, T, p_src, orifice_area, r, gamma)
        Q = h_inner(p, T, Tw[0], q_in) * area * (Tw[0] - T)
        dm = q_in - q_out
        dT = (q_in * (cp * T_src - cv * T) - q_out * r * T + Q) / (m * cv)
        dTs = (T - Ts) / tau if tau > 0.0 else 0.0
        flux = np.empty(n + 1)                                     # into slab i from i-1
        flux[0] = -Q
        flux[1:n] = g_wall * (Tw[:-1] - Tw[1:])
        flux[n] = outer_coefficient * area * (Tw[-1] - T_src)
        dTw = (flux[:n] - flux[1:]) / cw
        return np.concatenate([[dm, dT, dTs], dTw])

    t_eval = np.asarray(t_eval, float)
    m0 = p0 * volume / (r * T0)
    y0 = np.concatenate([[m0, T0, T0], np.full(n, T_src)])
    sol = solve_ivp(rhs, (0.0, float(t_eval[-1])), y0, method="Radau", t_eval=t_eval,
                    rtol=1e-8, atol=np.concatenate([[1e-9 * m0, 1e-6, 1e-6], np.full(n, 1e-6)]),
                    max_step=0.5)
    if not sol.success:
        raise RuntimeError(f"reference vessel run failed: {sol.message}")
    m, T, Ts = sol.y[0], sol.y[1], sol.y[2]
    return {"t": sol.t, "p": m * r * T / volume, "T": T, "T_sensor": Ts if tau > 0.0 else T,
            "T_wall": sol.y[3]}


def vessel_dimensions(test=None):
    """Inner volume [m^3], inner wall area [m^2] and diameter [m] of a test's cylinder.

    Parameters
    ----------
    test : dict or None
        ``diameter`` and ``length`` [m] (default :data:`FILLING_TEST`)
    """
    g = FILLING_TEST if test is None else test
    D, L = g["diameter"], g["length"]
    return math.pi * D * D / 4.0 * L, math.pi * D * L + 2.0 * math.pi * D * D / 4.0, D


#: Accuracy of the published vessel record's signals, as its measurement metadata states it
#: (one standard deviation, SI): the digitisation scatter that shared/data/vessel-filling's
#: README gives ("a few tenths of a percent on pressure and about 1 K on temperature": 0.3 %
#: of one bar, 1 K); the reference records state the same sensors'
VESSEL_ACCURACY = {"p_a": 300.0, "T_a": 1.0}


def vessel_experiment(name, t, p, T, p0, T0, max_step=0.5, accuracy=None):
    """Experiment JSON of a vessel record: pressure and gas temperature at times ``t``.

    Parameters
    ----------
    name : str
        Record name
    t : array_like
        Sample times [s]
    p, T : array_like
        Absolute pressure [Pa] and gas temperature [K] (NaN = not sampled)
    p0, T0 : float
        Initial pressure [Pa] and temperature [K] at t = 0
    max_step : float
        Largest solver step [s]
    accuracy : dict or None
        The sensors' stated accuracy, ``{signal: one standard deviation [SI]}`` (the
        measurement's ``meta.accuracy``); None: none stated (the fits estimate the noise)

    Returns
    -------
    experiment : dict
        For :func:`pneucore.data.experiment.as_experiments`
    """
    def col(v):
        return [None if not math.isfinite(x) else float(x) for x in v]
    meas = {"name": name, "t": [float(x) for x in t], "u": [1.0] * len(t), "p_a": col(p),
            "T_a": col(T)}
    if accuracy is not None:
        meas["meta"] = {"accuracy": dict(accuracy)}
    return {"name": name, "measurement": meas,
            "scenario": {"locked": True, "x0": 0.0, "initial": {"p_a": float(p0), "T_a": float(T0)},
                         "solver": {"max_step": max_step}}}


def reference_records(h_inner, sensor_time_constant, p_discharge=7.9e5, filling_end=80.0,
                      discharge_end=60.0, period=0.5, noise=(200.0, 0.3), seed=0,
                      accuracy=VESSEL_ACCURACY, **wall):
    """A filling and a discharge of the published vessel by :func:`reference_vessel_run`.

    The filling is the published test (3.7 kPa to the 1.00 bar atmosphere, 295 K); the
    discharge starts at ``p_discharge`` and 295 K and empties through the same orifice to
    the same atmosphere (the issue-22 record's conditions). The sensor's reading is what is
    recorded, with Gaussian noise.

    Parameters
    ----------
    h_inner : callable
        Inner coefficient law (:func:`reference_vessel_run`)
    sensor_time_constant : float
        Thermocouple time constant [s]
    p_discharge : float
        Initial pressure of the discharge [Pa]
    filling_end, discharge_end : float
        Record lengths [s]
    period : float
        Sample period [s]
    noise : tuple
        Standard deviations of pressure [Pa] and temperature [K]
    seed : int
        Random seed
    accuracy : dict or None
        The sensors' stated accuracy (:func:`vessel_experiment`): by default the published
        record's, the same sensors; None: none stated
    **wall
        Overrides of :func:`reference_vessel_run`'s wall arguments

    Returns
    -------
    filling, discharge : dict
        Experiment JSON (:func:`vessel_experiment`)
    """
    g = FILLING_TEST
    V, S, _ = vessel_dimensions()
    area = g["Cd"] * math.pi * g["orifice"] ** 2 / 4.0
    kw = {"wall_mass": VESSEL_WALL["wall_mass"], "wall_thickness": g["wall"], **wall}
    rng = np.random.default_rng(seed)
    out = []
    for name, p0, end in (("filling", g["p0"], filling_end), ("discharge", p_discharge, discharge_end)):
        t = np.arange(0.0, end + 0.5 * period, period)
        run = reference_vessel_run(t, p0, g["T_atm"], g["p_atm"], g["T_atm"], V, S, area, h_inner,
                                   sensor_time_constant=sensor_time_constant, **kw)
        p = run["p"] + noise[0] * rng.standard_normal(t.size)
        T = run["T_sensor"] + noise[1] * rng.standard_normal(t.size)
        out.append(vessel_experiment(f"reference {name}", t, p, T, p0, g["T_atm"],
                                     accuracy=accuracy))
    return out[0], out[1]


def reference_inner_coefficient(D, d_in, natural="churchill_chu", natural_multiplier=1.0,
                                jet_multiplier=1.0, r=R_AIR, gamma=GAMMA_AIR):
    """An inner-coefficient law ``h(p, T, T_w, q_in)`` for :func:`reference_vessel_run`.

    ``natural_multiplier`` times a natural-convection correlation plus ``jet_multiplier``
    times Woodfield's jet term (:func:`pneucore.physics.heat.jet_convection_coefficient`).
    The natural correlation is either Churchill & Chu's for a horizontal cylinder
    (``"churchill_chu"``, :func:`pneucore.physics.heat.natural_convection_coefficient`, the
    simulator's own) or Woodfield, Monde & Mitsutake's natural term ``Nu_D = 0.104
    Ra_D^0.352`` (``"woodfield"``, J. Thermal Sci. Tech. 2 (2007) 180, measured inside a
    charged vessel): a law of another form than the simulator's, for testing whether a
    fitted multiplier transfers across a misspecified correlation.

    Parameters
    ----------
    D : float
        Vessel inner diameter [m]
    d_in : float
        Inlet diameter [m]
    natural : str
        ``"churchill_chu"`` or ``"woodfield"``
    natural_multiplier, jet_multiplier : float
        Factors on the correlations [-]
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]

    Returns
    -------
    h_inner : callable
        ``h_inner(p [Pa], T [K], T_wall [K], q_in [kg/s])`` -> [W/(m^2 K)]
    """
    from pneucore.physics.gas import air_conductivity, air_viscosity
    from pneucore.physics.heat import (G_STANDARD, jet_convection_coefficient,
                                       natural_convection_coefficient)
    cp = gamma * r / (gamma - 1.0)
    if natural not in ("churchill_chu", "woodfield"):
        raise ValueError(f"unknown natural-convection law {natural!r}")

    def h_nat(p, T, Tw):
        if natural == "churchill_chu":
            return natural_convection_coefficient(p, T, Tw, D, r, cp)
        T_f = 0.5 * (T + Tw)
        rho, mu, k = p / (r * T_f), air_viscosity(T_f), air_conductivity(T_f)
        Ra = G_STANDARD * abs(Tw - T) / T_f * D ** 3 * rho * rho * cp / (mu * k)
        return 0.104 * Ra ** 0.352 * k / D

    def h_inner(p, T, Tw, q_in):
        return (natural_multiplier * h_nat(p, T, Tw)
                + jet_multiplier * jet_convection_coefficient(q_in, d_in, T, D))
    return h_inner
