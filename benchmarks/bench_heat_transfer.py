"""Heat models that transfer (issue 22, item 7): fitted on a vessel's filling, predicting what was
not fitted.

Run from the repository root::

    python benchmarks/bench_heat_transfer.py [--data ../shared/data/vessel-filling]
                                             [--discharge DIR [--discharge-p0 7.9e5]]

Prints the transfer table: per heat model the fitted multipliers (a multiplier is the ratio to
the published correlation: Churchill & Chu 1975 for natural convection, Woodfield, Monde &
Mitsutake 2007 for the inflow jet), the pressure error (paper Eq. 25) and gas-temperature rms of
the fit and of the prediction. Every fit weighs each sample by its signal's stated accuracy
(0.3 % of a bar on pressure, 1 K on temperature: the published record's digitisation scatter).

* **Reference vessels** (the published vessel's geometry, orifice and 26 kg steel wall, by the
  independent :func:`pneucore.physics.vessel.reference_vessel_run`): filled from 3.7 kPa to the
  atmosphere and discharged from 7.9 bar through the same orifice (the conditions of the
  discharge record issue 22 cites, which is not in ``shared/``). Fitted on the filling, the
  discharge predicted. Two truths: the simulator's own correlations at multipliers 2 / 0.5
  (tau 2 s, six-slab wall), and Woodfield's natural law Nu = 0.104 Ra^0.352 at 1 / 0.5 (tau 4 s,
  eight slabs of a 15 W/(m K) wall); and a control, a fixed coefficient of 15 W/(m^2 K) (no
  physical law behind it: a physical model is not expected to transfer there); and thin walls
  (1 mm steel, a 3 mm polymer liner), whose temperature moves: the model with its lumped wall
  of the known mass against the same model with the wall held at ambient.
* **The published filling** (Thorncroft, Patton & Gordon 2007): fitted on t <= 20 s (the
  filling proper), the relaxation t > 20 s predicted; and the published correlations unfitted.

Goal (issue 22): discharge p <= 1.0 %, gas T rms <= 8 K, multipliers within a factor 3 of the
published correlations. Not a timed test: it prints what it measures.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from machine import machine_info, save_figures  # noqa: E402
from pneucore.analysis.heat_compare import record_errors, transfer  # noqa: E402
from pneucore.physics.vessel import (FILLING_TEST, VESSEL_ACCURACY, VESSEL_WALL, filling_test,  # noqa: E402
                                     read_vessel_record, reference_inner_coefficient,
                                     reference_records, vessel_dimensions, vessel_experiment,
                                     published_vessel)

D, D_IN = FILLING_TEST["diameter"], FILLING_TEST["orifice"]
SENSOR = {"sensor_time_constant": 1.0}
#: The candidates: heat section and the parameters fitted
MODELS = [
    ("natural_and_jet", {"model": "natural_and_jet", "natural_multiplier": 1.0,
                         "jet_multiplier": 1.0, "inlet_diameter": D_IN, **SENSOR, **VESSEL_WALL},
     ["natural_multiplier", "jet_multiplier", "sensor_time_constant"]),
    ("natural_and_jet, natural at 1", {"model": "natural_and_jet", "natural_multiplier": 1.0,
                                       "jet_multiplier": 1.0, "inlet_diameter": D_IN, **SENSOR,
                                       **VESSEL_WALL},
     ["jet_multiplier", "sensor_time_constant"]),
    ("natural_convection", {"model": "natural_convection", "natural_multiplier": 1.0, **SENSOR,
                            **VESSEL_WALL},
     ["natural_multiplier", "sensor_time_constant"]),
    ("convective (fixed h)", {"model": "convective", "coefficient": 10.0, **SENSOR, **VESSEL_WALL},
     ["coefficient", "sensor_time_constant"]),
]
#: The goal of issue 22
GOAL_P, GOAL_T, GOAL_FACTOR = 1.0e-2, 8.0, 3.0


def verdict(row):
    """'meets' when the prediction and the multipliers meet the goal, else what misses."""
    miss = []
    pr = row["predicted"]
    if pr["p"] is not None and pr["p"] > GOAL_P:
        miss.append("p")
    if pr["T"] is not None and pr["T"] > GOAL_T:
        miss.append("T")
    for k, v in row["values"].items():
        if k.endswith("multiplier") and not 1 / GOAL_FACTOR <= v <= GOAL_FACTOR:
            miss.append(k.split("_")[0])
    out = "meets" if not miss else "misses " + "+".join(miss)
    return out + (" (at bound: " + ", ".join(k.split("_")[0] for k in row.get("at_bound", ())) + ")"
                  if row.get("at_bound") else "")


#: Every table shown, for ``--json``: {title: [{model, fitted, fit errors, predicted errors}]}
FIGURES = {}


def show(title, rows, labels):
    FIGURES[title] = [{"model": r["name"], "fitted": r["values"], labels[0]: r["fit"],
                       labels[1]: r["predicted"]} for r in rows]
    print(f"\n{title}")
    print(f"{'model':<32} {labels[0] + ' p':>10} {'T':>8}  {labels[1] + ' p':>11} {'T':>8}  "
          f"{'goal':<34} fitted (multiplier = x published correlation)")
    for r in rows:
        f, p = r["fit"], r["predicted"]
        vals = ", ".join(f"{k} {v:.3g}" for k, v in r["values"].items()) or "none"
        fp = f"{100 * f['p']:.2f} %" if f["p"] is not None else "-"
        fT = f"{f['T']:.2f} K" if f["T"] is not None else "-"
        print(f"{r['name']:<32} {fp:>10} {fT:>8}  {100 * p['p']:>9.2f} % {p['T']:>6.2f} K  "
              f"{verdict(r):<34} {vals}")


def discharge(natural, jet, end=60.0, n=241):
    """Mean-gas pressure [Pa] and temperature [K] of the published vessel discharged from 7.9 bar."""
    import numpy as np
    from pneucore.simulate import simulate
    from pneucore.description.model import Model
    heat = {**MODELS[0][1], "natural_multiplier": natural, "jet_multiplier": jet,
            "sensor_time_constant": 0.0}
    sc = {"locked": True, "x0": 0.0, "duration": end, "command": [[0.0, 1.0]],
          "initial": {"p_a": 7.9e5, "T_a": FILLING_TEST["T_atm"]}, "solver": {"max_step": 0.5}}
    r = simulate(Model.from_dict(published_vessel(heat)), sc, t_out=np.linspace(0.0, end, n))
    return np.asarray(r.observed("p_a")), np.asarray(r.observed("T_a"))


def spread(split_fit):
    """What the explanations of the real filling predict for the 7.9 bar discharge.

    The filling is fitted as well by weak natural convection (the fit's multipliers) as by
    Churchill-Chu at 1 with a thermocouple slow in still gas (README): their discharges differ
    by this much, so the filling alone cannot establish a discharge prediction within the goal.
    """
    import numpy as np
    from pneucore.analysis.metrics import eq25_error
    p1, T1 = discharge(1.0, split_fit["jet_multiplier"])
    print("\nthe real filling's explanations, predicting the 7.9 bar discharge (mean gas, 60 s), "
          "against Churchill-Chu at 1:")
    for label, cn in (("natural as fitted up to 20 s", split_fit["natural_multiplier"]),
                      ("natural 0.3", 0.3), ("natural 1 (Churchill-Chu)", 1.0)):
        p, T = discharge(cn, split_fit["jet_multiplier"])
        print(f"  {label:<30} c_n {cn:<6.3g} lowest T {T.min():6.1f} K   p differs "
              f"{100 * eq25_error(p1, p):5.2f} %, T differs {np.sqrt(np.mean((T - T1) ** 2)):5.1f} K rms")


def slow_sensor(data, natural=1.0, jet=0.15, switch=19.0, end=78.0):
    """The second explanation of the real relaxation: Churchill-Chu at ``natural``, and a
    thermocouple fast while the jet blows and slow in still gas after ``switch`` [s].

    A check, not a model of the package: the mean-gas temperature is simulated densely
    (no sensor) and the two-regime first-order lag applied after, its two time constants
    fitted on the whole record. Prints them and the rms before and after 20 s.
    """
    import math
    import numpy as np
    from scipy.optimize import least_squares
    from pneucore.simulate import simulate
    from pneucore.description.model import Model
    t, _, T_meas = read_vessel_record(data)
    ok = np.isfinite(T_meas)
    tm, Tm = t[ok], T_meas[ok]
    grid = np.linspace(0.0, end, 3121)
    heat = {**MODELS[0][1], "natural_multiplier": natural, "jet_multiplier": jet,
            "sensor_time_constant": 0.0}
    sc = {"locked": True, "x0": 0.0, "duration": end, "command": [[0.0, 1.0]],
          "initial": {"p_a": FILLING_TEST["p0"], "T_a": FILLING_TEST["T_atm"]},
          "solver": {"max_step": 0.5}}
    T = np.asarray(simulate(Model.from_dict(published_vessel(heat)), sc, t_out=grid).observed("T_a"))

    def read(tau_jet, tau_still):
        s = np.empty_like(T)
        s[0] = T[0]
        for i in range(1, grid.size):
            tau = tau_jet if grid[i] < switch else tau_still
            s[i] = s[i - 1] + (1.0 - math.exp(-(grid[i] - grid[i - 1]) / tau)) * (T[i] - s[i - 1])
        return np.interp(tm, grid, s) - Tm

    sol = least_squares(lambda x: read(*np.exp(x)), [0.0, 2.0], bounds=([-5, -5], [5, 5]))
    r = read(*np.exp(sol.x))
    late = tm > 20.0
    print(f"\nslow sensor in still gas (Churchill-Chu x{natural:g}, jet x{jet:g}, lag applied "
          f"after the simulation): tau {math.exp(sol.x[0]):.2f} s while the jet blows, "
          f"{math.exp(sol.x[1]):.1f} s after {switch:g} s; T rms {np.sqrt(np.mean(r ** 2)):.2f} K "
          f"in all, {np.sqrt(np.mean(r[late] ** 2)):.2f} K after 20 s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", default=os.path.join(os.path.dirname(HERE), "..", "shared", "data",
                                                   "vessel-filling"))
    ap.add_argument("--discharge", default=None,
                    help="folder of a recorded discharge of the same vessel, in the filling's "
                         "format (pressure.csv in bar, gas_temperature.csv in K): predicted by "
                         "each model fitted on the whole filling")
    ap.add_argument("--discharge-p0", type=float, default=7.9e5,
                    help="initial absolute pressure of that discharge [Pa]")
    ap.add_argument("--quick", action="store_true",
                    help="reference A and the real filling only (the suite's run)")
    ap.add_argument("--json", default=None, help="write the tables to this file")
    args = ap.parse_args()
    t0 = time.perf_counter()
    truths = [
        ("reference A: Churchill-Chu x2, jet x0.5, tau 2 s, 6-slab wall",
         reference_records(reference_inner_coefficient(D, D_IN, "churchill_chu", 2.0, 0.5), 2.0,
                           seed=0)),
        ("reference B: Woodfield natural x1, jet x0.5, tau 4 s, 8 slabs at 15 W/(m K)",
         reference_records(reference_inner_coefficient(D, D_IN, "woodfield", 1.0, 0.5), 4.0,
                           seed=1, layers=8, wall_conductivity=15.0, outer_coefficient=3.0)),
        ("reference C: a fixed h = 15 W/(m^2 K), tau 1 s (no physical law: transfer not expected)",
         reference_records(lambda p, T, Tw, q: 15.0, 1.0, seed=2)),
    ]
    if args.quick:
        truths = truths[:1]
    for title, (fill, dis) in truths:
        rows = [transfer(published_vessel(h), fill, dis, fit, name=n) for n, h, fit in MODELS]
        show(title + " (fitted on the filling, discharge predicted)", rows,
             ("filling", "discharge"))
    V, S, _ = vessel_dimensions()
    walls = [("1 mm steel (3.0 kg)", {"wall_mass": 7800.0 * S * 1e-3, "wall_thickness": 1e-3}),
             ("3 mm HDPE liner (1.1 kg, k 0.40 W/(m K), 10 slabs)",
              {"wall_mass": 950.0 * S * 3e-3, "wall_thickness": 3e-3, "wall_specific_heat": 1900.0,
               "wall_conductivity": 0.40, "layers": 10})]
    name, heat, fit = MODELS[0]
    for title, wall in ([] if args.quick else walls):
        fill, dis = reference_records(
            reference_inner_coefficient(D, D_IN, "churchill_chu", 2.0, 0.5), 2.0, seed=3, **wall)
        c = wall.get("wall_specific_heat", 500.0)
        rows = [transfer(published_vessel({**heat, "wall_mass": m, "wall_specific_heat": c}), fill, dis, fit,
                         name=label)
                for label, m in ((f"{name}, lumped wall {wall['wall_mass']:.2g} kg",
                                  wall["wall_mass"]), (f"{name}, wall at ambient", 0.0))]
        show(f"reference D: a thin wall, {title}; the law of A (fitted on the filling, discharge "
             f"predicted)", rows, ("filling", "discharge"))
    if os.path.exists(os.path.join(args.data, "pressure.csv")):
        _, real = filling_test(args.data)
        rows = [transfer(published_vessel(h), real, None, fit, t_split=20.0, name=n) for n, h, fit in MODELS]
        pub_heat = {**MODELS[0][1], "sensor_time_constant": 0.0}
        rows.append({"name": "published correlations, no fit", "values": {},
                     "fit": record_errors(published_vessel(pub_heat), real, t_max=20.0),
                     "predicted": record_errors(published_vessel(pub_heat), real, t_min=20.0)})
        show("published filling (Thorncroft et al. 2007): fitted on t <= 20 s, t > 20 s held out",
             rows, ("t<=20s", "t>20s"))
        if not args.quick:
            spread(rows[0]["values"])
            slow_sensor(args.data)
        if args.discharge:
            t, p, T = read_vessel_record(args.discharge)
            dis = vessel_experiment("recorded discharge", t, p, T, args.discharge_p0,
                                    FILLING_TEST["T_atm"], accuracy=VESSEL_ACCURACY)
            rows = [transfer(published_vessel(h), real, dis, fit, name=n) for n, h, fit in MODELS]
            show("recorded discharge predicted by the models fitted on the whole filling", rows,
                 ("filling", "discharge"))
    else:
        print(f"\n(published filling not found at {args.data}: skipped)")
    print(f"\ngoal: predicted p <= {100 * GOAL_P:.1f} %, T rms <= {GOAL_T:g} K, multipliers within "
          f"x{GOAL_FACTOR:g} of the correlations; {time.perf_counter() - t0:.0f} s in all")
    save_figures(args.json, {"machine": machine_info("scipy"), "tables": FIGURES})


if __name__ == "__main__":
    main()
