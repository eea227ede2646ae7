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
        JSON for :meth:`pneucore.spec.model.Model.from_dict`
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
    D, L = g["diameter"], g["length"]
    volume = math.pi * D * D / 4.0 * L
    area = math.pi * D * L + 2.0 * math.pi * D * D / 4.0
    model = vessel_model(volume, D, area, g["orifice"], g["Cd"], g["p_atm"], g["T_atm"], heat,
                         name="vessel-filling (Thorncroft et al. 2007)")
    _, p = _read_csv(os.path.join(data_dir, "pressure.csv"))
    _, T = _read_csv(os.path.join(data_dir, "gas_temperature.csv"))
    t = np.unique(np.concatenate([[0.0], p[:, 0], T[:, 0]]))
    p_col = np.full(t.shape, np.nan)
    T_col = np.full(t.shape, np.nan)
    p_col[np.searchsorted(t, p[:, 0])] = p[:, 1] * 1e5
    T_col[np.searchsorted(t, T[:, 0])] = T[:, 1]
    meas = {"name": "vessel-filling", "t": t.tolist(), "u": [1.0] * len(t),
            "p_a": [None if math.isnan(v) else v for v in p_col],
            "T_a": [None if math.isnan(v) else v for v in T_col]}
    exp = {"name": "vessel-filling", "measurement": meas,
           "scenario": {"locked": True, "x0": 0.0, "initial": {"p_a": g["p0"], "T_a": g["T_atm"]},
                        "solver": {"max_step": 0.5}}}
    return model, exp


#: Wall of the published vessel: steel mass from its geometry, steel's specific heat
VESSEL_WALL = {"wall_mass": cylinder_wall_mass(FILLING_TEST["diameter"], FILLING_TEST["length"],
                                               FILLING_TEST["wall"]),
               "wall_specific_heat": STEEL_SPECIFIC_HEAT}
