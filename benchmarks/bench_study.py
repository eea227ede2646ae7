"""Benchmark of robustness studies: runs/s per worker count on the local pool and a Dask
LocalCluster, worker start-up, and the extrapolation to a 1,000,000-run study.

Run from the repository root (on any machine: the worker counts default to 1, 2, 4, ...
up to the CPUs available)::

    python benchmarks/bench_study.py [--runs N] [--workers 1,2,4] [--skip-dask]
                                     [--skip-startup] [--batch-size B] [--big N]
                                     [--json PATH]

Case: ``--runs`` (default 10,000) simulations of model ``paper-4way`` with
scenario ``paper-fig10-pulses`` (1 s, four valve pulses, 1 kHz output),
varying ``friction.extend.fc0`` (uniform 4-16 N) and ``supply.pressure``
(normal 6 bar abs, std 0.4 bar, truncated to 4.5-7.5 bar), seed 1; every
metric of :mod:`pneucore.study.metrics` per run; results stored in a
temporary SQLite file.

Figures printed (and written to ``--json PATH``):

* **serial in-process** cost per run (``workers=0``: parameter set,
  validation, simulation, metrics): the per-worker compute rate ``r``;
* **runs/s per worker count** on the local pool (``run_study(workers=W)``,
  wall time of the whole call, pool start-up included) and on a Dask
  LocalCluster of ``W`` single-threaded worker processes (the cluster's own
  start-up and its workers' warm-up reported apart: a cluster's workers are
  usually long-lived), with the parallel efficiency ``runs/s / (W r)``; for
  Dask also the workers' busy fraction and compute time per run from Dask's
  task stream, and the CPU the client side used (driver, store, scheduler):
  whether the workers ever waited for the client;
* **worker start-up**: for a pool of the largest worker count, the time at
  which each worker has finished its first run, for the warm forkserver
  (pneucore preloaded; cold = the forkserver's first start in the process,
  warm = a later pool) and, for comparison, for ``spawn`` (what the pool
  used before): the first worker and the largest delay of the others after it
  (target <= 0.5 s);
* **1,000,000-run extrapolation**: the model ``T = N / min(W r e, S)`` with the
  measured per-worker rate ``r``, the efficiency ``e`` measured at the largest
  worker count (pool start-up included, so conservative) and the store rate
  ``S`` measured in this run as ``bench_study_store.py`` measures it (finished
  runs fed to the store, 20,000 of them), printed for this machine's worker
  count and for 16 workers; plus the measured summary time;
* **a real big study** (``--big N``, e.g. 1000000): ``N`` runs at the largest
  worker count on the local pool and (unless ``--skip-dask``) on a Dask
  LocalCluster, each stored in its own SQLite file, with the wall time, the
  runs/s, the summary's time and the file's size, beside the model's prediction;
* bit-identical results across engines, machine information and the load
  average (other processes may share the machine).
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, ROOT)
sys.path.insert(0, HERE)
from machine import machine_info as _machine_info, save_figures  # noqa: E402

SERIAL_SAMPLE = 500
STARTUP_TARGET_S = 0.5
BIG = 1_000_000
STORE_SAMPLE = 20_000   # runs fed to the store to measure its rate (0.1 s at 200,000 runs/s)


def study_definition(runs):
    from pneucore import model_preset, scenario_preset
    return {"name": f"bench {runs} runs",
            "model": model_preset("paper-4way"), "scenario": scenario_preset("paper-fig10-pulses"),
            "parameters": {
                "friction.extend.fc0": {"distribution": "uniform", "min": 4.0, "max": 16.0},
                "supply.pressure": {"distribution": "normal", "mean": 6e5, "std": 4e4,
                                    "min": 4.5e5, "max": 7.5e5}},
            "samples": runs, "seed": 1}


def load():
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover
        return None


def first_run(text):
    """Pool task of the start-up figure: one real run, then a pause so every worker gets one."""
    from pneucore.study.execute import run_block
    run_block(text, [0])
    t = time.time()
    time.sleep(0.3)
    return os.getpid(), t


def startup(kind, n, text):
    """Times [s, from the pool's creation] at which each of ``n`` workers finished its first run."""
    import concurrent.futures as cf
    import multiprocessing

    from pneucore.study import _worker as _study_worker
    t0 = time.time()
    if kind == "spawn":
        pool = cf.ProcessPoolExecutor(n, mp_context=multiprocessing.get_context("spawn"))
    else:
        pool = cf.ProcessPoolExecutor(n, mp_context=_study_worker.context(),
                                      initializer=_study_worker.init_worker, initargs=(os.getpid(),))
    try:
        done = [f.result() for f in [pool.submit(first_run, text) for _ in range(n)]]
    finally:
        pool.shutdown(wait=True)
    first = {}
    for pid, t in done:
        first[pid] = min(first.get(pid, t), t)
    return sorted(t - t0 for t in first.values())


def measure_store_rate(runs=STORE_SAMPLE):
    """Finished runs the store takes per second [runs/s] (``bench_study_store.py``'s measure)."""
    from bench_study_store import definition, feed_store, synthetic_blocks
    from pneucore.study.definition import Study
    study = Study.from_dict(definition(runs))
    blocks = list(synthetic_blocks(study, 250))
    with tempfile.TemporaryDirectory() as d:
        return runs / feed_store(os.path.join(d, "store.sqlite3"), "rate", study, blocks)


def dask_study(definition, db, workers, batch_size, study_id):
    """One study on a fresh Dask LocalCluster of ``workers`` single-threaded worker processes.

    The cluster is started (``cluster_start_s``), its workers are warmed by a small study
    (import and compiled-cache load in each fresh worker process, ``warm_up_s``), then the
    study is timed (``wall_s``) under Dask's task stream, which gives the time the workers
    spent computing (``worker_busy``: compute time over ``workers x wall_s``; 1 means
    they never waited for the client) and the compute time per run on the workers; the
    CPU time of this process (the client, the driver that stores the results, and the
    LocalCluster's scheduler, which runs in it) is ``client_cpu_cores`` [cores].
    """
    from distributed import Client, LocalCluster, get_task_stream
    from pneucore.study import run_study
    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(cluster)
    start = time.perf_counter() - t0
    try:
        t0 = time.perf_counter()
        run_study(study_definition(4 * workers), scheduler=client, batch_size=1)
        warm = time.perf_counter() - t0
        c0, t0 = time.process_time(), time.perf_counter()
        with get_task_stream(client) as ts:
            s = run_study(definition, db, scheduler=client, batch_size=batch_size, study_id=study_id)
        wall = time.perf_counter() - t0
        cpu = time.process_time() - c0
    finally:
        client.close()
        cluster.close()
    compute = sum(ss["stop"] - ss["start"] for task in ts.data for ss in task["startstops"]
                  if ss["action"] == "compute")
    return s, wall, {"cluster_start_s": start, "warm_up_s": warm,
                     "worker_busy": compute / (workers * wall),
                     "worker_ms_per_run": compute / max(1, s["computed"]) * 1e3,
                     "client_cpu_cores": cpu / wall}


def dask_note(extra):
    return (f"  [cluster start {extra['cluster_start_s']:.1f} s, warm-up {extra['warm_up_s']:.1f} s; "
            f"workers busy {extra['worker_busy']:.2f} at {extra['worker_ms_per_run']:.3f} ms a run; "
            f"client {extra['client_cpu_cores']:.2f} cores]")


def big_study(n, workers, batch_size, skip_dask, tmp, predicted_s):
    """One study of ``n`` runs on ``workers`` local workers (and Dask workers): measured figures."""
    from pneucore.study import run_study, study_results
    rows = []
    engines = ["local"] + ([] if skip_dask else ["dask"])
    print(f"big study: {n:,} runs on {workers} workers (model's prediction {predicted_s:.0f} s "
          f"+ start-up)")
    for engine in engines:
        db = os.path.join(tmp, f"big-{engine}.sqlite3")
        extra = {}
        if engine == "dask":
            s, wall, extra = dask_study(study_definition(n), db, workers, batch_size, f"big-{engine}")
        else:
            t0 = time.perf_counter()
            s = run_study(study_definition(n), db, workers=workers, batch_size=batch_size,
                          study_id=f"big-{engine}")
            wall = time.perf_counter() - t0
        t0 = time.perf_counter()
        res = study_results(db, s["id"], include_runs=False)
        summary_s = time.perf_counter() - t0
        size = sum(os.path.getsize(db + x) for x in ("", "-wal") if os.path.exists(db + x))
        row = {"engine": engine, "workers": workers, "runs": s["computed"], "failed": s["failed"],
               "wall_s": wall, "runs_per_s": s["computed"] / wall, "summary_s": summary_s,
               "stored": res["stored"], "file_bytes": size, "batch_size": s["batch_size"],
               "predicted_s": predicted_s, **extra}
        rows.append(row)
        print(f"  {engine:6s} {wall:8.1f} s {row['runs_per_s']:10,.0f} runs/s, {s['failed']} failed, "
              f"summary {summary_s:.2f} s, store file {size / 1e6:.0f} MB"
              + (dask_note(extra) if extra else ""))
        for x in ("", "-wal", "-shm"):
            if os.path.exists(db + x):
                os.remove(db + x)
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000, help="runs per engine (default 10000)")
    parser.add_argument("--workers", default=None,
                        help="worker counts, comma-separated (default 1, 2, 4, ... up to the CPUs)")
    parser.add_argument("--batch-size", type=int, default=None, help="runs per task (default: automatic)")
    parser.add_argument("--json", help="write the figures to this JSON file")
    parser.add_argument("--skip-dask", action="store_true", help="local pool only")
    parser.add_argument("--skip-startup", action="store_true", help="no start-up figure")
    parser.add_argument("--big", type=int, default=0,
                        help="also run one study of this many runs at the largest worker count")
    args = parser.parse_args(argv)

    from pneucore.study import Study, run_study, study_results
    from pneucore.study.execute import max_workers

    cpus = max_workers()
    counts = ([int(x) for x in args.workers.split(",")] if args.workers
              else sorted({min(cpus, 2 ** k) for k in range(0, 10) if 2 ** k <= cpus} | {cpus}))
    out = {"case": "paper-4way + paper-fig10-pulses (1 s), fc0 ~ U(4, 16) N, supply ~ N(6, 0.4) bar "
                   "truncated to [4.5, 7.5] bar", "runs": args.runs, "workers": counts,
           "machine": _machine_info("dask", "distributed"), "load_average_start": load()}
    m = out["machine"]
    print(f"machine: {m['cpu']}, {m['cores']} cores ({m['usable_cores']} usable), Python {m['python']}, "
          f"numba {m['numba']}, dask {m.get('distributed', '-')}; load average {out['load_average_start']}")
    definition = study_definition(args.runs)
    tmp = tempfile.mkdtemp(prefix="bench_study_")
    db = os.path.join(tmp, "bench.sqlite3")

    # -- serial reference (warm: this process has simulated before timing) ----------------
    n_serial = min(SERIAL_SAMPLE, args.runs)
    run_study(study_definition(4), workers=0)
    t0 = time.perf_counter()
    run_study(study_definition(n_serial), workers=0)
    serial = (time.perf_counter() - t0) / n_serial
    rate1 = 1.0 / serial
    out["serial_ms_per_run"] = serial * 1e3
    print(f"serial in-process: {serial * 1e3:.3f} ms per run = {rate1:,.0f} runs/s per worker "
          f"({n_serial} runs)")

    # -- worker start-up -----------------------------------------------------------------------
    text = Study.from_dict(study_definition(10)).to_json()
    if not args.skip_startup:
        n = max(counts)
        for label, kind in (("forkserver, cold (first pool of the process)", "forkserver"),
                            ("forkserver, warm (a later pool)", "forkserver"), ("spawn (before)", "spawn")):
            ts = startup(kind, n, text)
            after = max(ts) - ts[0] if len(ts) > 1 else 0.0
            out.setdefault("startup", []).append({"pool": label, "first_s": ts[0], "others_after_first_s": after,
                                                  "workers_seen": len(ts)})
            print(f"start-up, {label:46s} first worker {ts[0]:6.2f} s, the other {len(ts) - 1} within "
                  f"{after:5.2f} s after it (target <= {STARTUP_TARGET_S} s)")

    rows, runs = [], {}

    def record(engine, w, summary, wall, extra=None):
        rate = summary["computed"] / wall
        row = {"engine": engine, "workers": w, "wall_s": wall, "runs": summary["computed"],
               "runs_per_s": rate, "efficiency": rate / (w * rate1), "batch_size": summary["batch_size"],
               "detail": summary["engine"], **(extra or {})}
        rows.append(row)
        runs[f"{engine}{w}"] = study_results(db, summary["id"])["runs"]
        print(f"{engine:6s} {w:3d} worker{'s' if w > 1 else ' '} {wall:8.2f} s {rate:10,.0f} runs/s  "
              f"efficiency {row['efficiency']:5.2f}  (batches of {row['batch_size']})"
              + (dask_note(extra) if extra else ""))

    print(f"{args.runs} runs per engine:")
    for w in counts:
        t0 = time.perf_counter()
        s = run_study(definition, db, workers=w, batch_size=args.batch_size, study_id=f"local{w}")
        record("local", w, s, time.perf_counter() - t0)
    if not args.skip_dask:
        for w in counts:
            s, wall, extra = dask_study(definition, db, w, args.batch_size, f"dask{w}")
            record("dask", w, s, wall, extra)
    out["engines"] = rows
    ref = runs[f"local{counts[0]}"]
    out["identical_results"] = all(r == ref for r in runs.values())
    print(f"identical numbers across engines and worker counts: {out['identical_results']}")

    # -- summary of this study, and the 1,000,000-run extrapolation ------------------------------
    t0 = time.perf_counter()
    study_results(db, f"local{counts[-1]}", include_runs=False)
    out["summary_s"] = time.perf_counter() - t0
    best = max((r for r in rows if r["engine"] == "local"), key=lambda r: r["workers"])
    eff = best["efficiency"]
    store_rate = measure_store_rate()
    print(f"store rate (finished runs fed to the store, as bench_study_store.py): "
          f"{store_rate:,.0f} runs/s")
    out["model"] = {"per_worker_runs_per_s": rate1, "efficiency": eff, "store_runs_per_s": store_rate}
    print(f"summary of this {args.runs}-run study: {out['summary_s']:.2f} s")
    for w in sorted({best["workers"], 16}):
        rate = min(w * rate1 * eff, store_rate)
        t = BIG / rate
        out["model"][f"T_1M_{w}_workers_s"] = t
        print(f"1,000,000 runs on {w:2d} workers (model: {w} x {rate1:,.0f} runs/s x efficiency "
              f"{eff:.2f}, store cap {store_rate:,.0f} runs/s): {t:7.0f} s = {t / 60:5.1f} min "
              f"(+ start-up; measured here at {args.runs:,} runs: {best['wall_s']:.1f} s "
              f"on {best['workers']} workers)")
    if args.big:
        out["big"] = big_study(args.big, best["workers"], args.batch_size, args.skip_dask, tmp,
                               out["model"][f"T_1M_{best['workers']}_workers_s"] * args.big / BIG)
    out["load_average_end"] = load()
    print(f"load average at end: {out['load_average_end']}")
    save_figures(args.json, out)
    for f in os.listdir(tmp):
        os.remove(os.path.join(tmp, f))
    os.rmdir(tmp)
    return 0


if __name__ == "__main__":
    sys.exit(main())
