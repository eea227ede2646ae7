"""Does a diagnosis round use both cores? One round and the refine loop at 1 and 2 workers.

Run from the repository root::

    python benchmarks/bench_diagnosis_threads.py [--json PATH] [--runs N] [--profile]

The work of a round (sensitivities of the base hypotheses, the score pass,
the candidate refits and their finite-difference Jacobians) runs in
``pneucore.analysis.calibrate.THREADS`` worker threads; the compiled
integrator (:func:`pneucore.core.integrator.integrate`, ``nogil=True``) runs
outside the GIL, the Python around it (experiment replay, scenario
validation, model packing) does not. Cases, on two experiments of 1 s at
1 kHz (targets from the issue, on this 2-core machine):

* **one round** (:func:`pneucore.analysis.diagnose.diagnose`) on the
  ``effect/piston_leakage`` rig case of :data:`pneucore.data.synthetic.RIG_CASES`,
  nothing declared; target <= 3 s;
* **the refine loop** (:func:`pneucore.analysis.history.refine`) on the
  ``effect/leak+spool`` rig case; target <= 15 s.

Each is timed with 1 and with 2 workers, alternately (the machine is shared:
the ratio of times taken in one run is what to read), after a warm-up.
``--profile`` prints where one round spends its time in one thread: the share
in the compiled integrator, in the fits' linear algebra, and in the Python
around them. The fits run with one OpenBLAS thread
(:mod:`pneucore.analysis.blas_threads`): OpenBLAS's own threads on these tall,
narrow matrices competed with the simulation workers for the two cores.
"""
from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from pneucore.analysis import calibrate  # noqa: E402
from pneucore.analysis.diagnose import diagnose  # noqa: E402
from pneucore.analysis.history import refine  # noqa: E402
from pneucore.data.experiment import as_experiments  # noqa: E402
from pneucore.data.synthetic import RIG_CASES, rig_case  # noqa: E402
from machine import save_figures  # noqa: E402

TARGET_ROUND_S = 3.0
TARGET_REFINE_S = 15.0


def _case(name):
    c = rig_case(name, **dict(RIG_CASES)[name])
    return c.start, as_experiments(c.experiments)


def _timed(fn, workers):
    calibrate.THREADS = workers
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


class _Inline:
    """A stand-in for ThreadPoolExecutor that maps in the calling thread (so cProfile sees it)."""

    def __init__(self, workers=1):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def map(self, fn, items):
        return list(map(fn, items))


def profile_round(start, exps):
    """Share of one round, run in one thread, spent in the compiled integrator, the BLAS calls
    of the fits (SVD, QR) and the Python around them."""
    from pneucore.analysis import diagnose as D
    from pneucore.analysis import hypotheses as H
    from pneucore.analysis.diagnosis import evidence as E, stages as S
    saved = (S.ThreadPoolExecutor, E.ThreadPoolExecutor, calibrate.ThreadPoolExecutor,
             H.ThreadPoolExecutor)
    S.ThreadPoolExecutor = E.ThreadPoolExecutor = calibrate.ThreadPoolExecutor = \
        H.ThreadPoolExecutor = _Inline
    try:
        pr = cProfile.Profile()
        pr.enable()
        D.diagnose(start, exps)
        pr.disable()
    finally:
        (S.ThreadPoolExecutor, E.ThreadPoolExecutor, calibrate.ThreadPoolExecutor,
         H.ThreadPoolExecutor) = saved
    st = pstats.Stats(pr)
    total = max(v[3] for v in st.stats.values())   # the outermost cumulative time
    integ = sum(v[2] for k, v in st.stats.items() if k[2] == "integrate" and "integrator" in k[0])
    blas = sum(v[2] for k, v in st.stats.items() if k[2] in ("svd", "qr", "lstsq"))
    print(f"one round in one thread: {total:.2f} s profiled; compiled integrator {integ:.2f} s "
          f"({100 * integ / total:.0f} %), SVD/QR/lstsq {blas:.2f} s ({100 * blas / total:.0f} %), "
          f"the rest (Python around them) {100 * (1 - (integ + blas) / total):.0f} %")
    st.sort_stats("tottime").print_stats(12)
    return {"profiled_s": total, "integrator_s": integ, "blas_s": blas}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="PATH")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--profile", action="store_true")
    a = ap.parse_args(argv)
    default = calibrate.THREADS
    one = _case("effect/piston_leakage")
    two = _case("effect/leak+spool")
    jobs = {"round": lambda: diagnose(*one), "refine": lambda: refine(*two)}
    out = {"cpu": os.cpu_count(), "load_before": os.getloadavg()[0]}
    for name, fn in jobs.items():
        _timed(fn, default)   # warm-up (compilation, caches)
        times = {1: [], 2: []}
        for _ in range(a.runs):
            for w in (1, 2):
                times[w].append(_timed(fn, w))
        med = {w: statistics.median(t) for w, t in times.items()}
        out[name] = {"s_1_worker": med[1], "s_2_workers": med[2], "speedup": med[1] / med[2],
                     "runs": times}
        target = TARGET_ROUND_S if name == "round" else TARGET_REFINE_S
        print(f"{name:7s}: 1 worker {med[1]:.2f} s, 2 workers {med[2]:.2f} s; speed-up x{med[1] / med[2]:.2f}"
              f" (target {target:g} s)", flush=True)
    if a.profile:
        out["profile"] = profile_round(*one)
    calibrate.THREADS = default
    out["load_after"] = os.getloadavg()[0]
    print(f"cpu {out['cpu']}, load {out['load_before']:.1f} -> {out['load_after']:.1f}")
    save_figures(a.json, out)
    return out


if __name__ == "__main__":
    main()
