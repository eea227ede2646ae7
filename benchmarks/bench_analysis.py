"""Benchmark of the model-versus-measurement analysis: diagnosis and calibration.

Run from the repository root::

    python benchmarks/bench_analysis.py [--json PATH] [--runs N]

Cases (targets from the issue, on this 2-core machine):

* **full diagnosis** over the whole effect catalog on two experiments of
  1 s at 1 kHz (the shipped ``piston-leak`` sample: a locked hold test and a
  free pulse test): score pass on every candidate, refit of the leading three;
  target <= 10 s;
* **one diagnosis round on a rig as users meet it** (nothing declared: the base
  parameters to recalibrate are chosen from what the experiments identify, see
  :mod:`pneucore.analysis.hypotheses`): the ``effect/piston_leakage`` rig case of
  :data:`pneucore.data.synthetic.RIG_CASES`, two experiments of 1 s at 1 kHz;
  target <= 3 s;
* **the full refinement loop** (:func:`pneucore.analysis.history.refine`) on the
  ``effect/leak+spool`` rig case (two hidden effects behind base errors); target <= 15 s;
* **calibration of three parameters** (``heat.coefficient``,
  ``friction.extend.fc0``, ``jack.moving_mass``) on the same two experiments
  from a mis-set start; target <= 2 s.

Each figure is the median of ``--runs`` runs after a warm-up run (numba
compilation excluded; it is measured by ``bench_simulator.py``).
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
from pneucore.analysis.calibrate import calibrate  # noqa: E402
from pneucore.analysis.diagnose import diagnose  # noqa: E402
from pneucore.data.experiment import as_experiments  # noqa: E402
from pneucore.data.samples import load_sample  # noqa: E402
from machine import save_figures  # noqa: E402

TARGET_DIAGNOSIS_S = 10.0
TARGET_CALIBRATION_S = 2.0
TARGET_ROUND_S = 3.0
TARGET_REFINE_S = 15.0


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
    ap.add_argument("--rig-runs", type=int, default=1, help="runs of the (long) rig cases")
    a = ap.parse_args(argv)
    model = model_preset("paper-4way")
    exps = as_experiments(load_sample("piston-leak"))

    t_diag, d = _median_time(lambda: diagnose(model, exps), a.runs)
    from pneucore.analysis.history import refine
    from pneucore.data.synthetic import RIG_CASES, rig_case
    rig = rig_case("effect/piston_leakage", **dict(RIG_CASES)["effect/piston_leakage"])
    rig_exps = as_experiments(rig.experiments)
    t_round, d_round = _median_time(lambda: diagnose(rig.start, rig_exps), a.rig_runs)
    two = rig_case("effect/leak+spool", **dict(RIG_CASES)["effect/leak+spool"])
    two_exps = as_experiments(two.experiments)
    t_refine, (m_ref, hist, _) = _median_time(lambda: refine(two.start, two_exps), a.rig_runs)
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
        "round_s": t_round, "round_target_s": TARGET_ROUND_S, "round_verdict": d_round.verdict,
        "round_recalibrated": [r["path"] for r in d_round.recalibrate],
        "refine_s": t_refine, "refine_target_s": TARGET_REFINE_S,
        "refine_versions": [v.label for v in hist.versions],
        "cpu": os.cpu_count(), "load": os.getloadavg()[0],
    }
    print(f"full diagnosis (whole catalog, 2 experiments x 1 s @ 1 kHz): {t_diag:.2f} s "
          f"(target <= {TARGET_DIAGNOSIS_S:g} s) -> verdict {d.verdict}")
    print(f"one round, nothing declared (rig case, 2 experiments x 1 s @ 1 kHz): {t_round:.2f} s "
          f"(target <= {TARGET_ROUND_S:g} s) -> verdict {d_round.verdict}, "
          f"{len(d_round.recalibrate)} parameters recalibrated")
    print(f"full refinement loop (two hidden effects behind base errors): {t_refine:.2f} s "
          f"(target <= {TARGET_REFINE_S:g} s) -> {[v.label for v in hist.versions]}")
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    print(f"calibration of 3 parameters (2 experiments): {t_cal:.2f} s "
          f"(target <= {TARGET_CALIBRATION_S:g} s), {cal.nfev} residual evaluations, "
          f"values {figures['calibration_values']}")
    save_figures(a.json, figures)
    return figures


if __name__ == "__main__":
    main()
