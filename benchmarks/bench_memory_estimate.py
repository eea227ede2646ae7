"""The API's memory estimate against the measured peak, up to the cost limit (issue 40, item 4).

For each record length (a locked 1 s hold plus a free cyclic record of ``T`` s at 1 kHz,
``bench_long_records.py``'s rig: ``paper-4way`` with a hidden piston leak, the catalogue model
as the start) and each kind of analysis (compare, calibrate, diagnose, refine), one analysis
runs in a forked child of this process, as the API runs it, and the growth of the child's
resident memory (peak minus start, ``/proc/self/clear_refs`` then ``VmHWM``,
:func:`bench_long_records.peak_rss`) is set beside the estimate the admission holds for it
(:func:`app.analysis_memory.samples_estimate`). ``--traced`` also runs each under
:mod:`tracemalloc` (numpy's arrays included; slower) and takes the larger of the two.
A ratio (estimate / measured) under 1 is an under-estimate.

The default lengths reach the cost limit (``Limits.max_analysis_seconds``, 200 s:
1 + 199 s = 200 s, 200,002 samples... capped at ``max_analysis_samples``: 1 + 198.9 s).

Usage::

    python benchmarks/bench_memory_estimate.py [--lengths 20,60,120,198.9]
        [--kinds compare,calibrate,diagnose,refine] [--traced] [--json out.json]

Memory is measured here, never asserted by a timed test.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path[:0] = [ROOT, HERE]

import bench_long_records as B  # noqa: E402
from machine import machine_info, save_figures  # noqa: E402

from app.analysis_memory import samples_estimate  # noqa: E402
from pneucore import model_preset  # noqa: E402
from pneucore.analysis.diagnose import diagnose  # noqa: E402
from pneucore.description.model import Model  # noqa: E402


def measure(kind, exps, traced=False):
    """``(resident growth, traced peak or None, wall seconds)`` of one ``kind`` analysis on
    ``exps`` [bytes, bytes, s]."""
    fn = B.analysis(kind, Model.from_dict(model_preset("paper-4way")), exps)
    t0 = time.perf_counter()
    rss = B.peak_rss(fn)
    wall = time.perf_counter() - t0
    peak = B.peak_memory(fn)[0] if traced else None
    return rss, peak, wall


def load():
    try:
        return os.getloadavg()[0]
    except OSError:
        return None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lengths", default="20,60,120,198.9",
                    help="cyclic record lengths T [s], each after a 1 s hold")
    ap.add_argument("--kinds", default="compare,calibrate,diagnose,refine")
    ap.add_argument("--traced", action="store_true", help="also the tracemalloc peak (slower)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    # the core compiled and the caches filled here, inherited by every measured child
    diagnose(Model.from_dict(model_preset("paper-4way")), B.length_set(B.true_model(), 1.0)[:1])
    info = machine_info("scipy")
    print(info)
    rows = []
    print(f"{'record':>16} {'samples':>8} {'kind':>9} {'estimate':>10} {'measured':>10} "
          f"{'ratio':>6} {'wall':>7} {'load':>5}")
    for T in (float(x) for x in a.lengths.split(",")):
        exps = B.length_set(B.true_model(), T)
        samples = sum(e.measurement.n for e in exps)
        for kind in a.kinds.split(","):
            before = load()
            rss, peak, wall = measure(kind, exps, a.traced)
            measured = max(x for x in (rss, peak) if x is not None)
            est = samples_estimate(kind, samples)
            row = {"T": T, "seconds": 1 + T, "samples": samples, "kind": kind, "estimate": est,
                   "rss": rss, "traced": peak, "measured": measured, "ratio": est / measured,
                   "wall_s": wall, "load": [before, load()]}
            rows.append(row)
            print(f"{f'1 s + {T:g} s':>16} {samples:>8,} {kind:>9} {est / 1e6:>8.0f}MB "
                  f"{measured / 1e6:>8.0f}MB {est / measured:>6.2f} {wall:>6.0f}s "
                  f"{before:>5.1f}" + (f"   (resident {rss / 1e6:.0f}, traced {peak / 1e6:.0f} MB)"
                                       if peak is not None else ""), flush=True)
    save_figures(a.json, {"machine": info, "rows": rows})


if __name__ == "__main__":
    main()
