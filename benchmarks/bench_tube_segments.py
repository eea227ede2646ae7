"""Benchmark: the ``tubing`` line in segments against the base model, per simulated second.

Run from the repository root::

    python benchmarks/bench_tube_segments.py [--runs N] [--pairs K] [--segments 2 4 8]
                                             [--json PATH]

Case: model ``paper-4way`` + scenario ``paper-fig10-pulses`` (1 s, four valve pulses), the
base model alone, then with 2 m of 4 mm line on both ports at each number of segments
(1 = the lumped line). The cases alternate in one process, ``--pairs`` rounds of
``--runs`` calls of :func:`pneucore.simulate` each (validation and result included), so
that a loaded machine slows them alike; printed: the median over the rounds of each
round's median wall time per simulated second [ms], its ratio to the base model's in the
same round, and the integrator's steps. Target (issue 23): a model with tubes on both ports
<= 3x the base model's time per simulated second.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, HERE)

from machine import machine_info, save_figures  # noqa: E402

from pneucore import model_preset, scenario_preset, simulate  # noqa: E402

TARGET_RATIO = 3.0


def _case(segments):
    m = model_preset("paper-4way")
    if segments:
        m["effects"] = {"tubing": {"length_a": 2.0, "length_b": 2.0, "segments": segments}}
    return m


def _round(model, scenario, runs):
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        res = simulate(model, scenario)
        times.append(time.perf_counter() - t0)
    return statistics.median(times) / scenario["duration"] * 1e3, res.stats.get("steps")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20, help="calls per case and round")
    ap.add_argument("--pairs", type=int, default=4, help="alternating rounds")
    ap.add_argument("--segments", type=int, nargs="+", default=[1, 2, 4, 8])
    ap.add_argument("--json", default=None, help="write the figures to this file")
    args = ap.parse_args(argv)
    sc = scenario_preset("paper-fig10-pulses")
    cases = [0] + list(args.segments)
    models = {n: _case(n) for n in cases}
    for n in cases:
        simulate(models[n], sc)                      # compile / load, and warm
    ms = {n: [] for n in cases}
    ratios = {n: [] for n in cases}
    steps = {}
    for _ in range(args.pairs):
        base, _steps = _round(models[0], sc, args.runs)
        ms[0].append(base)
        steps[0] = _steps
        for n in args.segments:
            t, steps[n] = _round(models[n], sc, args.runs)
            ms[n].append(t)
            ratios[n].append(t / base)
    print(f"{'case':<22}{'ms / sim. s':>12}{'ratio':>8}  ratios per round        steps")
    for n in cases:
        name = "base (no tube)" if n == 0 else f"tubes, {n} segment{'s' if n > 1 else ''}"
        r = "" if n == 0 else f"{statistics.median(ratios[n]):8.2f}  " + \
            " ".join(f"{x:.2f}" for x in ratios[n])
        print(f"{name:<22}{statistics.median(ms[n]):12.3f}{r:>8}  {steps[n]}")
    print(f"target: tubes on both ports <= {TARGET_RATIO:g}x the base model")
    save_figures(args.json, {
        "machine": machine_info(),
        "ms_per_simulated_s": {str(n): statistics.median(ms[n]) for n in cases},
        "ratio_to_base": {str(n): statistics.median(ratios[n]) for n in args.segments},
        "steps": {str(n): steps[n] for n in cases},
        "target_ratio": TARGET_RATIO})


if __name__ == "__main__":
    main()
