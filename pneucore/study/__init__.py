"""Robustness studies: one model and scenario over many parameter sets, on a pool or a Dask cluster.

The pieces live in ``study_*`` modules; this one gathers the public API and
the command line.

* Definition (:mod:`pneucore.study.definition`): :class:`Study`, grids and the
  distributions of the registry :data:`DISTRIBUTIONS` (uniform, normal,
  lognormal; :func:`register_distribution` adds one) with bounds, seed, at most
  :data:`MAX_RUNS` runs; ``Study.from_dict`` raises
  :class:`~pneucore.description.validation.FieldError` naming the field.
* Metrics (:mod:`pneucore.study.metrics`): the registry :data:`METRICS` with
  units (:func:`register_metric` adds one).
* Execution (:mod:`pneucore.study.execute`): :func:`run_study` - local process
  pool, or ``dask.distributed`` when a scheduler address is given (argument,
  ``$PNEUCORE_DASK_SCHEDULER`` or ``--scheduler``); batches stored in SQLite as
  they finish; resumable.
* Results (:mod:`pneucore.study.results`): :func:`study_results` -
  distributions, percentiles, sensitivity ranking (PRCC / Spearman, or the
  variance decomposition of a complete full factorial), raw arrays.

Command line::

    python -m pneucore.study run study.json --db studies.sqlite3 [--scheduler tcp://host:8786]
        [--workers N] [--batch-size N] [--id ID]
    python -m pneucore.study results --db studies.sqlite3 --id ID [--json out.json]
    python -m pneucore.study list --db studies.sqlite3

Example
-------
>>> from pneucore.study import run_study, study_results
>>> from pneucore import model_preset, scenario_preset
>>> study = {"model": model_preset("paper-4way"), "scenario": scenario_preset("paper-fig10-pulses"),
...          "parameters": {"friction.extend.fc0": {"distribution": "uniform", "min": 4, "max": 16}},
...          "samples": 100, "seed": 1}
>>> summary = run_study(study, "studies.sqlite3")          # doctest: +SKIP
>>> study_results("studies.sqlite3", summary["id"])["metrics"]["t95"]["percentiles"]  # doctest: +SKIP
"""
from __future__ import annotations

import argparse
import json
import sys
import time

from pneucore.study.definition import (DISTRIBUTIONS, MAX_RUNS, MIN_MASS, Distribution, Study, StudyParameter,
                        register_distribution)
from pneucore.study.execute import (ENV_SCHEDULER, SCHEDULER_TIMEOUT, SchedulerError, StudyInterrupted,
                         check_run_options, connect_scheduler, max_workers, queue_study, run_batch,
                         run_study)
from pneucore.study.metrics import METRICS, Metric, RunSeries, register_metric, run_metrics
from pneucore.study.results import (factorial_indices, rank_correlations, runs_csv, runs_npz, study_results,
                                    study_status)
from pneucore.study.store import STATUSES, delete_study, list_studies, set_study_status
from pneucore.description.validation import FieldError

__all__ = [
    "Study", "StudyParameter", "DISTRIBUTIONS", "MAX_RUNS", "MIN_MASS", "METRICS", "run_metrics",
    "Distribution", "register_distribution", "Metric", "RunSeries", "register_metric",
    "run_study", "run_batch", "connect_scheduler", "queue_study", "check_run_options", "SchedulerError", "StudyInterrupted",
    "ENV_SCHEDULER", "SCHEDULER_TIMEOUT", "study_results", "study_status", "list_studies",
    "delete_study", "rank_correlations", "factorial_indices", "main",
    "requeue_study", "set_study_status", "STATUSES", "runs_csv", "runs_npz", "max_workers",
]


def requeue_study(store_path, study_id):
    """Mark a stored study ``queued``, so that the next start resumes it.

    For a study stopped by a shutdown of the service: its stored runs are kept
    and :func:`run_study` with ``study_id`` computes only the missing ones.

    Parameters
    ----------
    store_path : str
        SQLite file of the study store
    study_id : str
        The study's id
    """
    set_study_status(store_path, study_id, "queued")


def _fmt(v, unit):
    if v is None:
        return "-"
    if unit == "Pa":
        return f"{v / 1e5:.4g} bar"
    if unit == "m":
        return f"{v * 1e3:.4g} mm"
    if unit == "s":
        return f"{v * 1e3:.4g} ms"
    return f"{v:.4g} {unit}"


def summary_lines(res):
    """Human-readable lines of :func:`study_results` output."""
    lines = [f"study {res['id']} ({res['design']}): {res['stored']}/{res['n_runs']} runs stored, "
             f"{res['failed']} failed, status {res['status']}"]
    lines.append(f"{'metric':16s} {'mean':>12s} {'std':>12s} {'p5':>12s} {'p50':>12s} {'p95':>12s}  n")
    for name, d in res["metrics"].items():
        u, p = d["unit"], d["percentiles"]
        lines.append(f"{name:16s} {_fmt(d['mean'], u):>12s} {_fmt(d['std'], u):>12s} "
                     f"{_fmt(p['5'], u):>12s} {_fmt(p['50'], u):>12s} {_fmt(p['95'], u):>12s}  {d['count']}")
    lines.append("sensitivity (rank: parameter  PRCC [p]  Spearman [p]):")
    for name, r in res["sensitivity"]["ranking"].items():
        parts = []
        for e in r["entries"]:
            s = f"{e['parameter']} "
            s += "PRCC -" if e["prcc"] is None else f"PRCC {e['prcc']:+.3f} [{e['prcc_p']:.2g}]"
            if e.get("total") is not None:
                s += f" S_T {e['total']:.3f}"
            parts.append(s)
        lines.append(f"  {name:16s} ({r['method']}) " + "; ".join(parts))
    for e in res["errors"][:5]:
        lines.append(f"error x{e['count']}: {e['message']}")
    return lines


def main(argv=None):
    """``python -m pneucore.study run|results|list`` (exit 0 ok, 2 bad input, 3 interrupted)."""
    parser = argparse.ArgumentParser(prog="python -m pneucore.study",
                                     description="Robustness studies of pneumatic actuators")
    sub = parser.add_subparsers(dest="cmd", required=True)
    run = sub.add_parser("run", help="run or resume a study defined in a JSON file")
    run.add_argument("definition", nargs="?", help="study JSON file (optional with --id to resume)")
    run.add_argument("--db", required=True, help="SQLite store")
    run.add_argument("--scheduler", default=None,
                     help=f"Dask scheduler address (default ${ENV_SCHEDULER}, else the local pool)")
    run.add_argument("--workers", type=int, default=None, help="local pool size (0 = this process)")
    run.add_argument("--batch-size", type=int, default=None, help="runs per task")
    run.add_argument("--id", default=None, help="resume this study, or the id of a new one")
    run.add_argument("--quiet", action="store_true", help="no progress lines")
    res = sub.add_parser("results", help="summary of a stored study")
    res.add_argument("--db", required=True)
    res.add_argument("--id", required=True)
    res.add_argument("--json", help="write the full results (JSON) to this file")
    lst = sub.add_parser("list", help="list the stored studies")
    lst.add_argument("--db", required=True)
    args = parser.parse_args(argv)

    if args.cmd == "list":
        for s in list_studies(args.db):
            print(f"{s['id']}  {s['status']:11s} {s['stored']}/{s['n_runs']} runs, {s['failed']} failed  "
                  f"{s['name']}")
        return 0
    if args.cmd == "results":
        try:
            out = study_results(args.db, args.id)
        except KeyError as exc:
            print(f"error: {exc.args[0]}", file=sys.stderr)
            return 2
        for line in summary_lines(out):
            print(line)
        if args.json:
            with open(args.json, "w") as fh:
                json.dump(out, fh)
            print(f"wrote {args.json}")
        return 0

    last = [0.0]

    def progress(fraction, step):
        now = time.monotonic()
        if not args.quiet and (now - last[0] > 1.0 or fraction >= 1.0):
            last[0] = now
            print(f"[{fraction * 100:5.1f} %] {step}", file=sys.stderr, flush=True)

    try:
        definition = None
        if args.definition:
            with open(args.definition) as fh:
                definition = json.load(fh)
        summary = run_study(definition, args.db, scheduler=args.scheduler, workers=args.workers,
                            batch_size=args.batch_size, progress=progress, study_id=args.id)
    except (FieldError, OSError, json.JSONDecodeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except StudyInterrupted as exc:
        print(f"interrupted: {exc}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        print("interrupted; resume with --id", file=sys.stderr)
        return 3
    print(f"study {summary['id']}: {summary['status']}, {summary['computed']} runs computed "
          f"({summary['already_stored']} already stored), {summary['failed']} failed, "
          f"{summary['wall_time']:.1f} s on {summary.get('engine', '-')}")
    print(f"results: python -m pneucore.study results --db {args.db} --id {summary['id']}")
    return 0

