"""Benchmark: the initial-state estimate of an experiment, cached once per experiment.

Run from the repository root::

    python benchmarks/bench_initial_state.py [--runs N]

Every replay of an experiment (each simulation of a calibration or a
diagnosis) builds its scenario, whose missing initial pressures and position
are estimated from the first samples (``Experiment._first``). The estimate
depends on the measurement only, so it is computed once per experiment and
reused. This script times a full diagnosis of the ``leak-and-lag`` sample
with the cache (as shipped) and with the estimate recomputed at every replay
(the cache bypassed), and counts the estimates; the median of ``--runs`` runs
after a warm-up each.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from pneucore import model_preset  # noqa: E402
from pneucore.analysis.diagnose import diagnose  # noqa: E402
from pneucore.data.experiment import Experiment, as_experiments  # noqa: E402
from pneucore.data.samples import load_sample  # noqa: E402


def one(cached):
    """One diagnosis (seconds, number of estimates), with or without the cache."""
    real_first, real_est = Experiment._first, Experiment._estimate_first
    calls = [0]

    def counting(self, name, w):
        calls[0] += 1
        return real_est(self, name, w)

    Experiment._estimate_first = counting
    if not cached:
        Experiment._first = lambda self, name, max_window=200: self._estimate_first(name, max_window)
    try:
        exps = as_experiments(load_sample("leak-and-lag"))
        t0 = time.perf_counter()
        diagnose(model_preset("paper-4way"), exps)
        return time.perf_counter() - t0, calls[0]
    finally:
        Experiment._first, Experiment._estimate_first = real_first, real_est


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=5)
    a = ap.parse_args()
    load = os.getloadavg()[0]
    one(True), one(False)                     # warm-up
    off, on = [], []
    for _ in range(a.runs):                   # alternated, so that load changes hit both alike
        off.append(one(False))
        on.append(one(True))
    t_off, n_off = statistics.median(t for t, _ in off), off[0][1]
    t_on, n_on = statistics.median(t for t, _ in on), on[0][1]
    print(f"machine load (1 min): {load:.2f}")
    print(f"diagnosis, estimate at every replay: {t_off:.3f} s ({n_off} estimates)")
    print(f"diagnosis, estimate cached         : {t_on:.3f} s ({n_on} estimates)")
    print(f"ratio: {t_off / t_on:.2f}x")


if __name__ == "__main__":
    main()
