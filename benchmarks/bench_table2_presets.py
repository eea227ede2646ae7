"""The locked-chamber presets against the paper's own Table 2 (issue 22, item 8).

Run from the repository root::

    python benchmarks/bench_table2_presets.py            # the table for the presets as they are
    python benchmarks/bench_table2_presets.py --fit      # refit the tests' unprinted values
    python benchmarks/bench_table2_presets.py --fit --coefficient 100   # the same at another h

Table 2 of Maré, Geider & Colin gives the Eq. 25 pressure error of the convective, adiabatic and
isothermal models against the locked-chamber measurements (Figs. 6-7), per valve move (opens /
closes) and chamber volume (smallest / largest). The convective model's error is the table's
noise level: removed in quadrature, the rest is the distance between the convective model and
each other one (:func:`pneucore.analysis.heat_compare.table2_target`). The presets (``paper-4way``
with ``paper-fig6-locked-max`` and ``paper-fig7-locked-min``) are run under the three heat models
and the same distances measured on them; a cell above the noise agrees when the ratio is within
a factor 1.5, a cell below it when the distance stays under the triangle bound.

The paper does not print the valve openings nor the timing of its tests. ``--fit`` chooses them
(``paper-4way`` itself, heat coefficient and dead volumes included, is left as it is unless
``--coefficient`` asks for another h):

* **largest chamber** (``paper-fig6-locked-max``): the opening step ``u_o``, its hold ``T_o``, the
  exhausting step ``-u_c`` and the record after it ``T_c``: four values for four cells, solved
  by least squares on the logarithm of the ratios (bounded: openings past the 15 % overlap up
  to 1, holds 0.1-30 s), started from (0.27, 6 s, 0.35, 1.5 s);
* **smallest chamber** (``paper-fig7-locked-min``): both opening cells are below the noise, so
  the opening step stays at 1 (as before) and its hold is fixed at 3 s (four heat time
  constants of the 5 cm^3 chamber: the convective gas is back at the wall's temperature when
  the exhaust starts); ``u_c`` and ``T_c`` are solved for the two closing cells, started from
  (0.155, 0.5 s).

Each step starts at 0.05 s as before. Prints the fitted values, then the table (paper vs preset,
per cell, ratio). Not a timed test: it prints what it measures.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

from machine import machine_info  # noqa: E402
from pneucore.analysis.heat_compare import (TABLE2_MOVES, TABLE2_TESTS,  # noqa: E402
                                            heat_model_distances, table2_rows, table2_target,
                                            table2_text)
from pneucore.description.presets import model_preset, scenario_preset  # noqa: E402

#: The valve's step starts here in both tests, as in the presets before the fit [s]
T_STEP = 0.05
#: Openings past the 4/2 valve's 15 % overlap (a step at 0.15 moves no air) up to full [-]
U_BOUNDS = (0.151, 1.0)
#: Holds from 0.1 s to 30 s
T_BOUNDS = (0.1, 30.0)
#: Smallest chamber: opening step kept at full, its hold fixed (see the module's docstring)
MIN_OPEN, MIN_HOLD = 1.0, 3.0
#: Starting points of the fits: (u_o, T_o, u_c, T_c) and (u_c, T_c)
START_MAX = (0.27, 6.0, 0.35, 1.5)
START_MIN = (0.155, 0.5)


def locked_test(volume, u_open, t_open, u_close, t_close):
    """The Table 2 test of one chamber volume with the given openings [-] and holds [s]."""
    sd = scenario_preset(TABLE2_TESTS[volume])
    t_c = T_STEP + t_open
    sd["command"] = [[0.0, 0.0], [T_STEP, u_open], [t_c, -u_close]]
    sd["duration"] = t_c + t_close
    return sd


def residuals(model, volume, values):
    """Log ratio of each cell above the noise; below it, how far the distance passes its bound."""
    dist = heat_model_distances(model, locked_test(volume, *values))
    out = []
    for move in TABLE2_MOVES:
        for name in ("adiabatic", "isothermal"):
            target, bound = table2_target(move, volume, name)
            d = dist[move][name]
            out.append(np.log(d / target) if target is not None else max(0.0, np.log(d / bound)))
    return np.array(out)


def fit_max(model):
    """Fit (u_o, T_o, u_c, T_c) of the largest-chamber test; the holds in logarithm."""
    def f(x):
        return residuals(model, "max", (x[0], np.exp(x[1]), x[2], np.exp(x[3])))
    u0, to, uc, tc = START_MAX
    lo = [U_BOUNDS[0], np.log(T_BOUNDS[0]), U_BOUNDS[0], np.log(T_BOUNDS[0])]
    hi = [U_BOUNDS[1], np.log(T_BOUNDS[1]), U_BOUNDS[1], np.log(T_BOUNDS[1])]
    sol = least_squares(f, [u0, np.log(to), uc, np.log(tc)], bounds=(lo, hi), diff_step=1e-2)
    x = sol.x
    return (x[0], np.exp(x[1]), x[2], np.exp(x[3])), sol.nfev


def fit_min(model, start=START_MIN):
    """Fit (u_c, T_c) of the smallest-chamber test, its opening step and hold fixed."""
    def f(x):
        return residuals(model, "min", (MIN_OPEN, MIN_HOLD, x[0], np.exp(x[1])))
    sol = least_squares(f, [start[0], np.log(start[1])],
                        bounds=([U_BOUNDS[0], np.log(T_BOUNDS[0])], [U_BOUNDS[1], np.log(T_BOUNDS[1])]),
                        diff_step=1e-2)
    return (MIN_OPEN, MIN_HOLD, sol.x[0], np.exp(sol.x[1])), sol.nfev


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fit", action="store_true", help="refit the tests' openings and timing")
    ap.add_argument("--coefficient", type=float, default=None,
                    help="heat coefficient of paper-4way for the fit [W/(m^2 K)] (default: the preset's)")
    ap.add_argument("--start-min", default=None,
                    help="start of the smallest chamber's fit: u_c,T_c [-, s] (the fit has several roots)")
    ap.add_argument("--json", default=None, help="write the rows here")
    args = ap.parse_args(argv)
    print(json.dumps(machine_info("scipy")))
    model = model_preset("paper-4way")
    if args.coefficient is not None:
        model["heat"]["coefficient"] = args.coefficient
    print(f"paper-4way: heat coefficient {model['heat']['coefficient']:g} W/(m^2 K), dead volumes "
          f"{model['jack']['dead_volume_a'] * 1e6:g} cm^3")
    print("\nPresets as they are:")
    t0 = time.perf_counter()
    rows = table2_rows(model)
    print(table2_text(rows))
    print(f"({time.perf_counter() - t0:.2f} s)")
    if args.fit:
        t0 = time.perf_counter()
        vmax, nmax = fit_max(model)
        start = tuple(float(v) for v in args.start_min.split(",")) if args.start_min else START_MIN
        vmin, nmin = fit_min(model, start)
        print(f"\nFitted ({time.perf_counter() - t0:.1f} s, {nmax} + {nmin} evaluations of 3 runs):")
        for vol, v in (("max", vmax), ("min", vmin)):
            print(f"  {TABLE2_TESTS[vol]}: opening step {v[0]:.4g} held {v[1]:.4g} s, then "
                  f"{-v[2]:.4g} for {v[3]:.4g} s")
        rows = table2_rows(model, {"max": locked_test("max", *vmax), "min": locked_test("min", *vmin)})
        print(table2_text(rows))
    worst = max(max(r["ratio"], 1 / r["ratio"]) for r in rows if r["ratio"] is not None)
    print(f"\nworst factor above the noise: {worst:.3f}; cells meeting the criterion: "
          f"{sum(r['ok'] for r in rows)} / {len(rows)}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
