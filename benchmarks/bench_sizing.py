"""Benchmark of the sizing search (issue 25): wall time against families and worker threads.

Run from the repository root::

    python benchmarks/bench_sizing.py [--families 468] [--workers 1,2] [--json PATH]
                                      [--cushion LENGTH,CAPACITY]

The requirement is the README's example (0.2 m stroke, 5 kg at 30 degrees, 50 N, 7 bar abs,
0.6 s each way, 1 m of tube, stroke-end speed at most 1 m/s); the choices are every shipped
cylinder (13), every shipped valve (6) and the shipped tubes plus a 3 mm bore (6):
468 families, each with its meter-out settings solved. ``--families N`` takes the first N
families' worth of cylinders (rounded to whole cylinders) to show how the time scales with
the number of families; each size is run at each worker count of ``--workers``.

Figures printed (and written to ``--json PATH``):

* **wall time** [s] per (families, workers): target <= 10 s for about 500 families on
  the 2-core machine;
* the **CPU time** [s] of the process: on a machine shared with other work (a load average
  above its cores) it is the figure that compares across runs; wall time on an idle
  machine is about CPU time over the workers that find a free core;
* **families per second** (the family is the unit of work: a force check, two fully-open
  runs, two meter-out roots of about five probe runs each, two final runs);
* the machine and its load average before and after (other processes may share it).

``--cushion 0.02,0.05`` adds end cushions to the requirement (``cushion_length`` [m],
``cushion_capacity`` [J]): every family's needles are then solved where a stroke meets its end
above the capacity, the needle alone first, then the meter-out throttle and the needle together
(:meth:`pneucore.sizing.search._Direction.solve_pair`); the figures add the count of families
failing with ``cushion`` and of directions whose throttle and needle were solved together.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, ROOT)
sys.path.insert(0, HERE)
from machine import machine_info, save_figures  # noqa: E402

TARGET_S = 10.0          # wall time for about 500 families [s]

REQUIREMENT = {"stroke": 0.2, "moving_mass": 5.0, "load_force": 50.0, "angle": 30.0,
               "supply_pressure": 7e5, "extend_time": 0.6, "retract_time": 0.6,
               "max_end_speed": 1.0, "tube_length": 1.0}
VALVES = ["ckd-4ga", "ckd-4gb"]
TUBES = ["pu-tube", 0.003]


def choices_for(families):
    """Choices with whole cylinders giving at most ``families`` families (at least one)."""
    from pneucore.sizing.series import load_series
    s = load_series()
    cyl = [f"{name}:{m['name']}" for name, series in s["cylinders"].items()
           for m in series["members"]]
    per_cyl = sum(len(s["valves"][v]["members"]) for v in VALVES) * \
        (len(s["tubes"]["pu-tube"]["members"]) + 1)
    n = max(1, min(len(cyl), families // per_cyl))
    return {"bore": cyl[:n], "valve": VALVES, "tube_inner_diameter": TUBES}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--families", type=str, default="468",
                   help="comma-separated family counts (whole cylinders; default 468: all)")
    p.add_argument("--workers", type=str, default="1,2", help="comma-separated thread counts")
    p.add_argument("--json", help="write the figures to this JSON file")
    p.add_argument("--cushion", default=None,
                   help="LENGTH,CAPACITY: end cushions in the requirement [m, J]")
    a = p.parse_args(argv)
    requirement = dict(REQUIREMENT)
    if a.cushion:
        length, capacity = (float(v) for v in a.cushion.split(","))
        requirement.update(cushion_length=length, cushion_capacity=capacity)
    from pneucore.sizing import size
    from pneucore.simulate import warm_up
    warm_up()      # the compiled core loaded before any timing
    figures = {"machine": machine_info("scipy"), "load_before": list(os.getloadavg()),
               "target_s": TARGET_S, "runs": []}
    for fam in (int(x) for x in a.families.split(",")):
        ch = choices_for(fam)
        for w in (int(x) for x in a.workers.split(",")):
            t0, c0 = time.perf_counter(), time.process_time()
            ans = size(requirement, ch, workers=w)
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            feasible = [d for d in ans["designs"] if d["feasible"]]
            row = {"families": ans["families"], "workers": w, "wall_s": wall, "cpu_s": cpu,
                   "families_per_s": ans["families"] / wall,
                   "feasible": len(feasible), "reasons": ans["reasons"],
                   # directions braked by a solved needle with a meter-out throttle beside it
                   "pairs": sum(1 for d in feasible if d.get("cushion")
                                for k in ("extend", "retract")
                                if d["cushion"][k]["needle_solved"]
                                and d["settings"][f"{k}_meter_out_C"] > 0.0),
                   "load_1min": os.getloadavg()[0]}
            figures["runs"].append(row)
            print(f"{row['families']:5d} families  {w} worker(s)  {wall:7.2f} s  (CPU {cpu:6.2f} s)  "
                  f"{row['families_per_s']:7.1f} families/s  {row['feasible']} feasible  "
                  f"(load {row['load_1min']:.1f})  reasons {row['reasons']}"
                  + (f"  throttle+needle directions {row['pairs']}" if a.cushion else ""))
    figures["load_after"] = list(os.getloadavg())
    print(f"machine: {figures['machine']['cpu']}, {figures['machine']['usable_cores']} usable "
          f"cores; load average before {figures['load_before'][0]:.2f}, after "
          f"{figures['load_after'][0]:.2f}")
    save_figures(a.json, figures)
    return 0


if __name__ == "__main__":
    sys.exit(main())
