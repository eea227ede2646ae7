"""Benchmark of the model-versus-measurement analysis: diagnosis and calibration.

Run from the repository root::

    python benchmarks/bench_analysis.py [--json PATH] [--runs N]

Cases (targets from the issue, on this 2-core machine):

* **full diagnosis** over the whole effect catalog on two experiments of
  1 s at 1 kHz (the shipped ``piston-leak`` sample: a locked hold test and a
  free pulse test): score pass on every candidate, refit of the leading four;
  target <= 10 s;
* **calibration of three parameters** (``heat.coefficient``,
  ``friction.extend.fc0``, ``jack.moving_mass``) on the same two experiments
  from a mis-set start; target <= 2 s.

Each figure is the median of ``--runs`` runs after a warm-up run (numba
compilation excluded; it is measured by ``bench_simulator.py``).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from pneucore import model_preset  # noqa: E402
from pneucore.calibrate import calibrate  # noqa: E402
from pneucore.diagnose import diagnose  # noqa: E402
from pneucore.experiment import as_experiments  # noqa: E402
from pneucore.samples import load_sample  # noqa: E402

TARGET_DIAGNOSIS_S = 10.0
TARGET_CALIBRATION_S = 2.0


def _median_time(fn, runs):
    fn()  # warm-up (compilation, caches)
    times = []
    out = None
    for _ in range(runs):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="PATH", help="write the figures to this JSON file")
    ap.add_argument("--runs", type=int, default=5)
    a = ap.parse_args(argv)
    model = model_preset("paper-4way")
    exps = as_experiments(load_sample("piston-leak"))

    t_diag, d = _median_time(lambda: diagnose(model, exps), a.runs)
    start = model_preset("paper-4way")
    start["heat"]["coefficient"] = 15.0
    start["friction"]["extend"]["fc0"] = 5.0
    start["jack"]["moving_mass"] = 2.4
    params = {"heat.coefficient": {"min": 0.1, "max": 200}, "friction.extend.fc0": {},
              "jack.moving_mass": {}}
    clean = as_experiments(load_sample("clean"))
    t_cal, cal = _median_time(lambda: calibrate(start, clean, params), a.runs)

    figures = {
        "diagnosis_s": t_diag, "diagnosis_target_s": TARGET_DIAGNOSIS_S,
        "diagnosis_verdict": d.verdict,
        "diagnosis_candidates": len([s for s in d.score_pass if "skipped" not in s]),
        "calibration_s": t_cal, "calibration_target_s": TARGET_CALIBRATION_S,
        "calibration_nfev": cal.nfev,
        "calibration_values": {k: v["value"] for k, v in cal.values.items()},
        "cpu": os.cpu_count(),
    }
    print(f"full diagnosis (whole catalog, 2 experiments x 1 s @ 1 kHz): {t_diag:.2f} s "
          f"(target <= {TARGET_DIAGNOSIS_S:g} s) -> verdict {d.verdict}")
    print(f"calibration of 3 parameters (2 experiments): {t_cal:.2f} s "
          f"(target <= {TARGET_CALIBRATION_S:g} s), {cal.nfev} residual evaluations, "
          f"values {figures['calibration_values']}")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(figures, fh, indent=1)
    return figures


if __name__ == "__main__":
    main()
