"""Benchmark of robustness studies: a local process pool against a Dask LocalCluster.

Run from the repository root::

    python benchmarks/bench_study.py [--runs N] [--json PATH] [--batch-size B] [--skip-dask]

Case: ``--runs`` (default 10,000) simulations of model ``paper-4way`` with
scenario ``paper-fig10-pulses`` (1 s, four valve pulses, 1 kHz output),
varying ``friction.extend.fc0`` (uniform 4-16 N) and ``supply.pressure``
(normal 6 bar abs, std 0.4 bar, truncated to 4.5-7.5 bar), seed 1; every
metric of :mod:`pneucore.study_metrics` per run; results stored in a
temporary SQLite file.

Figures printed (and written to ``--json PATH``):

* **serial in-process** cost per run (``workers=0`` on a sample of runs:
  parameter set, validation, simulation, metrics), for reference;
* **local pool** (``run_study`` default: a spawned process pool, one worker
  per available CPU): wall time of the whole call, pool start-up included;
* **Dask LocalCluster** with 1 and 2 worker processes (1 thread each): wall
  time of ``run_study`` (connection, worker imports and all); the cluster's
  own start-up is reported apart;
* whether all engines stored bit-identical numbers, and machine information
  (including the load average, since other processes may share the machine).

Target (printed next to the figure): the 10,000 runs on the local pool in
<= 60 s on a 2-core machine.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info as _machine_info  # noqa: E402

TARGET_S = 60.0
SERIAL_SAMPLE = 500


def study_definition(runs):
    from pneucore import model_preset, scenario_preset
    return {"name": f"bench {runs} runs",
            "model": model_preset("paper-4way"), "scenario": scenario_preset("paper-fig10-pulses"),
            "parameters": {
                "friction.extend.fc0": {"distribution": "uniform", "min": 4.0, "max": 16.0},
                "supply.pressure": {"distribution": "normal", "mean": 6e5, "std": 4e4,
                                    "min": 4.5e5, "max": 7.5e5}},
            "samples": runs, "seed": 1}


def machine_info():
    return _machine_info("dask", "distributed")


def load():
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover
        return None


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000, help="runs per engine (default 10000)")
    parser.add_argument("--batch-size", type=int, default=None, help="runs per task (default: automatic)")
    parser.add_argument("--json", help="write the figures to this JSON file")
    parser.add_argument("--skip-dask", action="store_true", help="local pool only")
    args = parser.parse_args(argv)

    from pneucore.study import run_study, study_results

    out = {"case": "paper-4way + paper-fig10-pulses (1 s), fc0 ~ U(4, 16) N, supply ~ N(6, 0.4) bar "
                   "truncated to [4.5, 7.5] bar", "runs": args.runs, "machine": machine_info(),
           "load_average_start": load(), "target_local_pool_s": TARGET_S}
    print(f"machine: {out['machine']['cpu']}, {out['machine']['cores']} cores, "
          f"Python {out['machine']['python']}, "
          f"numba {out['machine']['numba']}, dask {out['machine'].get('distributed', '-')}")
    print(f"load average at start: {out['load_average_start']}")
    definition = study_definition(args.runs)
    tmp = tempfile.mkdtemp(prefix="bench_study_")
    db = os.path.join(tmp, "bench.sqlite3")

    # -- serial reference (warm: this process has simulated before timing) ----------------
    n_serial = min(SERIAL_SAMPLE, args.runs)
    run_study(study_definition(4), workers=0)
    t0 = time.perf_counter()
    run_study(study_definition(n_serial), workers=0)
    serial = (time.perf_counter() - t0) / n_serial
    out["serial_ms_per_run"] = serial * 1e3
    out["serial_estimate_s"] = serial * args.runs
    print(f"serial in-process: {serial * 1e3:.3f} ms per run ({n_serial} runs) -> "
          f"{serial * args.runs:.1f} s estimated for {args.runs} runs")

    runs = {}
    engines = []

    def record(label, key, summary, wall, extra=None):
        row = {"engine": label, "wall_s": wall, "runs": summary["computed"],
               "runs_per_s": summary["computed"] / wall, "batch_size": summary["batch_size"],
               "batches": summary["batches"], "failed": summary["failed"],
               "detail": summary["engine"], **(extra or {})}
        engines.append(row)
        runs[key] = study_results(db, summary["id"])["runs"]
        print(f"{label:28s} {wall:7.2f} s  {row['runs_per_s']:8.1f} runs/s  "
              f"(batches of {row['batch_size']}, {summary['failed']} failed)"
              + (f"  [cluster start {extra['cluster_start_s']:.2f} s]" if extra else ""))

    # -- local pool ------------------------------------------------------------------------------
    t0 = time.perf_counter()
    s = run_study(definition, db, batch_size=args.batch_size, study_id="local")
    wall = time.perf_counter() - t0
    record(f"local pool ({s['engine'].split('(')[1].rstrip(')')})", "local", s, wall)
    out["local_pool_s"] = wall
    out["local_pool_target_met"] = wall <= TARGET_S or args.runs < 10_000

    # -- Dask LocalCluster, 1 and 2 workers ---------------------------------------------------
    if not args.skip_dask:
        from distributed import LocalCluster
        for n in (1, 2):
            t0 = time.perf_counter()
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=logging.ERROR)
            start = time.perf_counter() - t0
            try:
                t0 = time.perf_counter()
                s = run_study(definition, db, scheduler=cluster.scheduler_address,
                              batch_size=args.batch_size, study_id=f"dask{n}")
                wall = time.perf_counter() - t0
            finally:
                cluster.close()
            record(f"Dask LocalCluster, {n} worker{'s' if n > 1 else ''}", f"dask{n}", s, wall,
                   {"cluster_start_s": start})
            out[f"dask_{n}_workers_s"] = wall
        out["dask_speedup_2_over_1"] = out["dask_1_workers_s"] / out["dask_2_workers_s"]
        print(f"Dask scaling 1 -> 2 workers: x{out['dask_speedup_2_over_1']:.2f}")

    out["engines"] = engines
    ref = runs["local"]
    out["identical_results"] = all(r == ref for r in runs.values())
    out["load_average_end"] = load()
    print(f"identical numbers across engines: {out['identical_results']}")
    if args.runs >= 10_000:
        print(f"target: local pool <= {TARGET_S:.0f} s for 10,000 runs: "
              f"{'met' if out['local_pool_target_met'] else 'NOT met'} ({out['local_pool_s']:.1f} s)")
    print(f"load average at end: {out['load_average_end']}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=2)
        print(f"wrote {args.json}")
    for f in os.listdir(tmp):
        os.remove(os.path.join(tmp, f))
    os.rmdir(tmp)
    return 0


if __name__ == "__main__":
    sys.exit(main())
