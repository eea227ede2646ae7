"""Benchmark of the storing and summarising side of robustness studies, in isolation.

Run from the repository root::

    python benchmarks/bench_study_store.py [--runs N] [--batch B] [--json PATH]

A study definition of ``--runs`` (default 100,000) Monte Carlo runs of two
parameters (the pulse case of ``bench_study.py``) is stored in a temporary
SQLite file, then fed *finished* runs with synthetic metric values (all 12
metrics, 0.5 % failed runs with an error message), ``--batch`` runs per
transaction (default 250, the automatic batch of a large study), exactly as
the driver writes what its workers return
(:func:`pneucore.study.store.write_runs`). No simulation runs: this measures
how many runs per second the store can take, i.e. how many workers it can
serve before it throttles them (a worker computes about 1,000 runs/s of the
pulse case).

Figures printed (and written to ``--json PATH``):

* **store rate** [runs/s]: finished runs written per second (target >= 20,000);
* **summary** [s]: :func:`pneucore.study.results.study_results` without the raw
  runs (percentiles of every metric, PRCC and Spearman of every metric on every
  parameter) on the stored study (target <= 1 s for 100,000 runs);
* the same with the raw runs (what ``GET /api/studies/{id}/results`` sends by
  default) and the CSV and .npz exports, for reference;
* the machine and its load average (other processes may share it).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, ROOT)
sys.path.insert(0, HERE)
from machine import machine_info, save_figures  # noqa: E402

STORE_TARGET = 20_000.0      # runs/s
SUMMARY_TARGET = 1.0         # s, for 100,000 runs


def definition(runs):
    from pneucore import model_preset, scenario_preset
    return {"name": f"synthetic {runs} runs", "model": model_preset("paper-4way"),
            "scenario": scenario_preset("paper-fig10-pulses"),
            "parameters": {"friction.extend.fc0": {"distribution": "uniform", "min": 4.0, "max": 16.0},
                           "supply.pressure": {"distribution": "normal", "mean": 6e5, "std": 4e4,
                                               "min": 4.5e5, "max": 7.5e5}},
            "samples": runs, "seed": 1}


def synthetic_blocks(study, batch, seed=0):
    """The study's runs in batches, with metrics that depend on the parameters plus noise."""
    from pneucore.study.store import RunBlock
    rng = np.random.default_rng(seed)
    P = study.values()
    n, names = study.n_runs, study.metric_names
    base = (P[:, 1:2] / 6e5) - 0.01 * P[:, 0:1]
    M = base * np.linspace(0.5, 2.0, len(names)) + 0.01 * rng.standard_normal((n, len(names)))
    failed = rng.random(n) < 0.005
    M[failed] = np.nan
    errors = np.where(failed, "SimulationError: step budget exceeded", None)
    for k in range(0, n, batch):
        sl = slice(k, min(n, k + batch))
        yield RunBlock(np.arange(sl.start, sl.stop, dtype=np.int64), P[sl], M[sl], list(errors[sl]))


def feed_store(path, study_id, study, blocks):
    """Store ``study`` in the SQLite file ``path`` and write its finished ``blocks`` as the
    driver does (:func:`pneucore.study.store.write_runs`); returns the writing's time [s]."""
    from pneucore.study import store
    db = store.connect(path)
    try:
        store.create_study(db, study_id, study.to_json())
        t0 = time.perf_counter()
        for b in blocks:
            store.write_runs(db, study_id, b)
        elapsed = time.perf_counter() - t0
        store.set_status(db, study_id, "done")
        return elapsed
    finally:
        db.close()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=100_000)
    ap.add_argument("--batch", type=int, default=250)
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)

    from pneucore.study.definition import Study
    from pneucore.study.results import runs_csv, runs_npz, study_results

    study = Study.from_dict(definition(a.runs))
    blocks = list(synthetic_blocks(study, a.batch))
    out = {"runs": a.runs, "batch": a.batch, "machine": machine_info()}
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "store.sqlite3")
        t_store = feed_store(path, "bench", study, blocks)
        out["store_s"] = t_store
        out["store_runs_per_s"] = a.runs / t_store
        print(f"store: {a.runs} finished runs in batches of {a.batch}: {t_store:.2f} s = "
              f"{a.runs / t_store:,.0f} runs/s (target >= {STORE_TARGET:,.0f})")

        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            res = study_results(path, "bench", include_runs=False)
            times.append(time.perf_counter() - t0)
        assert res["stored"] == a.runs
        out["summary_s"] = min(times)
        print(f"summary without the runs (percentiles, PRCC, Spearman of {len(res['metrics'])} metrics): "
              f"best of 3 {min(times):.3f} s, median {sorted(times)[1]:.3f} s "
              f"(target <= {SUMMARY_TARGET:g} s for 100,000 runs)")

        import orjson
        t0 = time.perf_counter()
        full = orjson.dumps(study_results(path, "bench", include_runs=True))
        out["results_with_runs_s"] = time.perf_counter() - t0
        out["results_with_runs_bytes"] = len(full)
        print(f"results with the raw runs, JSON-encoded: {out['results_with_runs_s']:.3f} s, "
              f"{len(full) / 1e6:.1f} MB")
        t0 = time.perf_counter()
        size = sum(len(c) for c in runs_csv(path, "bench"))
        out["csv_s"] = time.perf_counter() - t0
        out["csv_bytes"] = size
        print(f"CSV export: {out['csv_s']:.3f} s, {size / 1e6:.1f} MB")
        t0 = time.perf_counter()
        size = len(runs_npz(path, "bench"))
        out["npz_s"] = time.perf_counter() - t0
        out["npz_bytes"] = size
        print(f".npz export: {out['npz_s']:.3f} s, {size / 1e6:.1f} MB")
        out["file_bytes"] = os.path.getsize(path) + sum(
            os.path.getsize(path + x) for x in ("-wal",) if os.path.exists(path + x))
        print(f"store file: {out['file_bytes'] / 1e6:.1f} MB "
              f"({out['file_bytes'] / a.runs:.0f} bytes per run)")
    print(f"machine: {out['machine']}")
    save_figures(a.json, out)
    return out


if __name__ == "__main__":
    main()
