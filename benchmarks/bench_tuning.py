"""Speed of a controller tuning (issue 42, item 7: "a tuning over 1,000 closed-loop runs within
30 s on 2 cores"): :func:`pneucore.control.robustness.tune_controller` on the study pool.

Run from the repository root::

    python benchmarks/bench_tuning.py [--workers N] [--duration S] [--json PATH]

The case: the servo actuator (:func:`pneucore.control.models.servo_model`) with the paper's
Coulomb friction, a PID on a 10 mm step; the ensemble a 5 x 5 grid of moving mass (1-4 kg)
and Coulomb level (``friction.*.fc0``, 6-14 N), 25 runs; the gain grid 8 ``kp`` x 5 ``ki``,
40 sets: 1,000 closed-loop runs of ``--duration`` s (default 1 s) at 1 kHz output.

Reported: the tuning's wall time (the pool's start included: its forkserver is started by
the first tuning of a process, hence a warm-up tuning on a small grid first, as a server's
second job would find it), the median time of one closed-loop run alone in this process, and
their ratio (1,000 / workers would be a perfect pool); the machine (``nproc``, the load
average before and after). Speed is measured here, never asserted by a test.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from pneucore.control.closed_loop import simulate_closed_loop  # noqa: E402
from pneucore.control.models import servo_model  # noqa: E402
from pneucore.control.robustness import tune_controller  # noqa: E402


def definition(duration):
    return {"model": servo_model(coulomb=True),
            "scenario": {"duration": duration, "x0": 0.1,
                         "initial": {"p_a": 5.3e5, "p_b": 5.3e5},
                         "controller": {"kind": "pid", "gains": {"kp": 15, "ki": 40, "kd": 0.1},
                                        "setpoint": [[0, 0.1], [0.05, 0.11]]}},
            "parameters": {"jack.moving_mass": {"grid": [1.0, 1.75, 2.5, 3.25, 4.0]},
                           "friction.*.fc0": {"grid": [6.0, 8.0, 10.0, 12.0, 14.0]}}}


GAINS = {"kp": [5.0, 7.5, 10.0, 12.5, 15.0, 17.5, 20.0, 25.0],
         "ki": [0.0, 10.0, 20.0, 40.0, 60.0]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--workers", type=int, default=None, help="pool size (default: the CPUs)")
    ap.add_argument("--duration", type=float, default=1.0, help="simulated time per run [s]")
    ap.add_argument("--single-runs", type=int, default=20)
    ap.add_argument("--kp", type=int, default=len(GAINS["kp"]),
                    help="the first N kp values only (a smaller tuning: N x 5 x 25 runs)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    d = definition(a.duration)
    engine = {} if a.workers is None else {"workers": a.workers}
    load0 = os.getloadavg()
    # one run alone, in this process (compile and cache load excluded)
    scen = dict(d["scenario"])
    simulate_closed_loop(d["model"], scen)
    ts = []
    for _ in range(a.single_runs):
        t0 = time.perf_counter()
        simulate_closed_loop(d["model"], scen)
        ts.append(time.perf_counter() - t0)
    single = statistics.median(ts)
    # warm-up: the pool's forkserver started, the core loaded in it
    tune_controller(d, {"kp": [10.0, 15.0]}, "settling_time", engine=engine)
    gains = dict(GAINS, kp=GAINS["kp"][:a.kp])
    n = len(gains["kp"]) * len(gains["ki"]) * 25
    t0 = time.perf_counter()
    out = tune_controller(d, gains, "settling_time", engine=engine)
    wall = time.perf_counter() - t0
    load1 = os.getloadavg()
    res = {"runs": n, "duration_s": a.duration, "workers": a.workers or len(os.sched_getaffinity(0)),
           "nproc": os.cpu_count(), "load_before": [round(x, 2) for x in load0],
           "load_after": [round(x, 2) for x in load1], "tuning_wall_s": wall,
           "single_run_ms": 1e3 * single, "ratio_tuning_over_single_run": wall / single,
           "per_run_ms_in_tuning": 1e3 * wall / n, "best": out["best"]}
    if out["best"]["worst"] is None:
        res["best"] = {"gains": out["best"]["gains"]}
    for k, v in res.items():
        print(f"{k:30s} {v:.4g}" if isinstance(v, float) else f"{k:30s} {v}")
    print(f"target: 1,000 closed-loop runs within 30 s on 2 cores ({n} runs here):",
          "met" if wall * 1000 / n <= 30.0 else "NOT met")
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=2))
    return res


if __name__ == "__main__":
    main()
