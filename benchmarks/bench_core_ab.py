"""A/B of the compiled core between two source trees, in alternating child processes.

Run from the repository root::

    python benchmarks/bench_core_ab.py --before PATH_TO_OLD_TREE [--after .] [--pairs 3]

Each child imports ``pneucore`` from its tree (``PYTHONPATH``; numba caches per tree) and times
:func:`pneucore.simulate` on model ``paper-4way`` + scenario ``paper-fig10-pulses`` (1 s, four
pulses): the base model 300 times, and with 2 m of 4 mm line in 4 segments on both ports 30
times, after one warm-up call each. Printed per child: best and median wall time [ms], the
integrator's steps and the final position (the two trees should agree to the last bit where
the change is not meant to change the physics); then the best-of ratios after / before per
pair, which a loaded machine affects alike.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

CHILD = r'''
import json, statistics, time
from pneucore import model_preset, scenario_preset, simulate
from pneucore.description.model import Model
from pneucore.description.scenario import Scenario
m = model_preset("paper-4way")
s = scenario_preset("paper-fig10-pulses")
mt = dict(m, effects={"tubing": {"length_a": 2.0, "length_b": 2.0, "segments": 4}})
out = {}
for name, mod, n in (("base", m, 300), ("tubes4", mt, 30)):
    M, S = Model.from_dict(mod), Scenario.from_dict(s)
    simulate(M, S)
    ts = []
    for _ in range(n):
        t0 = time.perf_counter()
        r = simulate(M, S)
        ts.append(time.perf_counter() - t0)
    out[name] = (min(ts), statistics.median(ts), r.stats["steps"], float(r.x[-1]))
print(json.dumps(out))
'''


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="the old tree (a git worktree)")
    ap.add_argument("--after", default=".", help="the new tree")
    ap.add_argument("--pairs", type=int, default=3)
    a = ap.parse_args(argv)
    trees = {"before": os.path.abspath(a.before), "after": os.path.abspath(a.after)}
    res = {k: [] for k in trees}
    for _ in range(a.pairs):
        for k, path in trees.items():
            env = dict(os.environ, PYTHONPATH=path, OMP_NUM_THREADS="1")
            o = subprocess.run([sys.executable, "-c", CHILD], cwd=path, env=env,
                               capture_output=True, text=True, check=True)
            d = json.loads(o.stdout.strip().splitlines()[-1])
            res[k].append(d)
            print(k, {n: {"best_ms": round(v[0] * 1e3, 3), "median_ms": round(v[1] * 1e3, 3),
                          "steps": v[2], "x_end": v[3]} for n, v in d.items()}, flush=True)
    for n in ("base", "tubes4"):
        ratios = [round(x[n][0] / y[n][0], 3) for x, y in zip(res["after"], res["before"])]
        print(f"{n}: best-of ratio after / before per pair {ratios}")


if __name__ == "__main__":
    main()
