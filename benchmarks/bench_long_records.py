"""Diagnosis cost against record length and number of experiments (issue 26).

Run from the repository root::

    python benchmarks/bench_long_records.py [--lengths 1,1.7,5,20,60] [--counts 2,5,10]
                                            [--refine-lengths 20] [--json PATH]
                                            [--scheduler tcp://host:8786 | --scheduler local:2]

The rig is the paper's 4/2 jack (``paper-4way``) with a hidden piston leak
(conductance :data:`LEAK`), diagnosed from the catalogue model with nothing
declared:

* **record length**: a locked 1 s hold test plus a free cyclic record of ``T`` seconds
  (a machine cycling once a second: extend pulse, dwell, retract pulse, dwell), 1 kHz,
  pressures and position recorded;
* **number of experiments**: ``n`` tests of 2 s each at supply pressures from 5 to 7 bar
  (abs), every other one locked (a hold), the others free and cycling.

For each it prints the wall time of one diagnosis round (and with ``--memory`` its peak
memory: the most the round holds above what it started with, traced by :mod:`tracemalloc`,
which numpy reports its arrays to, against the bytes of the records' series, so that a
per-candidate copy of every series would show as a ratio growing with the candidates)
(:func:`pneucore.analysis.diagnose.diagnose`) and, for ``--refine-lengths``, of the
refinement loop (:func:`pneucore.analysis.history.refine`), with the exponent ``b`` of
``time ~ a * size^b`` fitted by least squares on the logarithms (size: simulated seconds
of record in all, or the number of experiments). Speed is measured here, never asserted by
a test.

With ``--scheduler`` each row also times the same round with its candidate refits on a Dask
cluster (``diagnose(..., scheduler=...)``): a scheduler's address, or ``local:N`` for a
LocalCluster of ``N`` single-threaded worker processes started here; the row says whether the
verdict and the leading candidate's fitted values are the local round's.
"""
from __future__ import annotations

import argparse
import copy
import math
import os
import sys
import time
import tracemalloc

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

import numpy as np  # noqa: E402

from pneucore import model_preset  # noqa: E402
from pneucore.analysis.diagnose import diagnose  # noqa: E402
from pneucore.analysis.history import refine  # noqa: E402
from pneucore.data.experiment import as_experiments  # noqa: E402
from pneucore.data.synthetic import diagnostic_scenarios, synthesize  # noqa: E402
from pneucore.spec.model import Model  # noqa: E402
from pneucore.spec.scenario import pulse_train  # noqa: E402
from machine import machine_info, save_figures  # noqa: E402

#: Hidden piston leak of the true rig: its conductance [kg/(s Pa)]
LEAK = 1.5e-10


def true_model():
    m = model_preset("paper-4way")
    m["effects"] = {"piston_leakage": {"conductance": LEAK}}
    return m


def cyclic(duration, x0=0.05):
    """A machine cycling once a second for ``duration`` seconds (scenario dict)."""
    events = []
    for k in range(int(math.ceil(duration))):
        for t, u in ((k + 0.1, 0.7), (k + 0.55, -0.7)):
            if t < duration - 0.06:
                events.append((t, u))
    return {"duration": duration, "sample_period": 0.001, "command": pulse_train(events, 0.06),
            "locked": False, "x0": x0}


def hold(true, duration=1.0):
    """The catalogue's locked hold test, ``duration`` seconds long (scenario dict)."""
    sc = copy.deepcopy(diagnostic_scenarios(true)["locked-hold"])
    sc["duration"] = duration
    return sc


def experiment(true, scen, name, seed, supply=None):
    t = copy.deepcopy(true)
    if supply is not None:
        t["supply"]["pressure"] = supply
    signals = ("p_a", "p_b") if scen["locked"] else ("p_a", "p_b", "x")
    e = {"name": name, "scenario": {"locked": scen["locked"], "x0": scen["x0"]},
         "measurement": synthesize(t, scen, signals, None, 12, seed, name)}
    if supply is not None:
        e["supply_pressure"] = supply
    return e


def length_set(true, T):
    """A locked 1 s hold plus a free cyclic record of ``T`` seconds."""
    return as_experiments([experiment(true, hold(true), "hold", 1),
                           experiment(true, cyclic(T), "cyclic", 2)])


def count_set(true, n, duration=2.0):
    """``n`` tests of ``duration`` seconds at supply pressures from 5 to 7 bar (abs)."""
    out = []
    for i in range(n):
        supply = 5e5 + 2e5 * i / max(n - 1, 1)
        scen = hold(true, duration) if i % 2 else cyclic(duration)
        out.append(experiment(true, scen, f"test {i + 1}", 10 + i, supply))
    return as_experiments(out)


def exponent(sizes, times):
    """``b`` of ``time ~ a size^b`` (least squares on the logarithms); None with < 2 points."""
    if len(sizes) < 2:
        return None
    return float(np.polyfit(np.log(sizes), np.log(times), 1)[0])


def _memory_text(row):
    if "peak_mb" not in row:
        return ""
    return (f"   peak {row['peak_mb']:.1f} MB for {row['records_mb']:.2f} MB of records "
            f"({row['peak_mb'] / row['records_mb']:.0f}x)")


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def record_bytes(exps):
    """Bytes of the records' series as float64: time plus every measured signal [bytes]."""
    return sum(8 * e.measurement.n * (1 + len(e.measurement.measured_signals)) for e in exps)


def peak_memory(fn):
    """``(peak bytes above the start, result)`` of ``fn()`` under :mod:`tracemalloc` (numpy's
    arrays included); run apart from the timings, which tracing slows down."""
    tracemalloc.start()
    try:
        base, _ = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        out = fn()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return peak - base, out


def open_cluster(spec):
    """``(scheduler, close)`` for ``--scheduler``: an address as given, or ``local:N`` for a
    LocalCluster of ``N`` single-threaded worker processes (closed by ``close()``)."""
    if not spec:
        return None, lambda: None
    if spec.startswith("local:"):
        import logging

        import distributed
        cluster = distributed.LocalCluster(n_workers=int(spec.split(":", 1)[1]), threads_per_worker=1,
                                           processes=True, dashboard_address="127.0.0.1:0",
                                           silence_logs=logging.CRITICAL)
        client = distributed.Client(cluster, set_as_default=False)

        def close():
            client.close()
            cluster.close()
        return client, close
    return spec, lambda: None


def on_cluster(row, d_local, fn):
    """Time ``fn()`` (the round on the cluster) into ``row``: its wall time, and whether its
    verdict and its leading candidate's fitted values are the local round's (to 1e-9: the same
    arithmetic on the same inputs in another process)."""
    row["dask_round_s"], d = timed(fn)
    same = d.verdict == d_local.verdict and [r["effect"] for r in d.ranking] == \
        [r["effect"] for r in d_local.ranking]
    if same and d.ranking:
        a, b = d_local.ranking[0]["params"], d.ranking[0]["params"]
        same = all(abs(b[p]["value"] - v["value"]) <= 1e-9 * abs(v["value"]) for p, v in a.items())
    row["dask_same"] = bool(same)


def _dask_text(row):
    if "dask_round_s" not in row:
        return ""
    refine_text = f", refine {row['dask_refine_s']:.2f} s" if "dask_refine_s" in row else ""
    return (f"   on Dask {row['dask_round_s']:.2f} s ({'same' if row['dask_same'] else 'DIFFERENT'})"
            + refine_text)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lengths", default="1,1.7,5,20,60",
                    help="cyclic record lengths after the 1 s hold [s], comma-separated")
    ap.add_argument("--counts", default="2,5,10", help="numbers of 2 s experiments")
    ap.add_argument("--duration", type=float, default=2.0, help="length of each counted test [s]")
    ap.add_argument("--refine-lengths", default="20",
                    help="cyclic lengths whose refinement loop is timed too [s] ('' for none)")
    ap.add_argument("--refine-counts", default="",
                    help="numbers of experiments whose refinement loop is timed too")
    ap.add_argument("--memory", action="store_true",
                    help="also trace each round's peak memory (a second, untimed round)")
    ap.add_argument("--json", default=None, help="write the figures to this file")
    ap.add_argument("--scheduler", default=None,
                    help="also time each round with its candidate refits on a Dask cluster: a "
                         "scheduler address, or local:N for a LocalCluster of N worker processes")
    a = ap.parse_args(argv)
    lengths = [float(x) for x in a.lengths.split(",") if x]
    counts = [int(x) for x in a.counts.split(",") if x]
    ref_len = {float(x) for x in a.refine_lengths.split(",") if x}
    ref_cnt = {int(x) for x in a.refine_counts.split(",") if x}
    true = true_model()
    start = Model.from_dict(model_preset("paper-4way"))
    info = machine_info("scipy")
    print("machine:", info)
    # compile and warm the caches outside the timings
    diagnose(start, length_set(true, 1.0)[:1])
    scheduler, close_cluster = open_cluster(a.scheduler)
    if scheduler is not None:   # the workers' imports and compiled caches, outside the timings
        diagnose(start, length_set(true, 1.0)[:1], scheduler=scheduler)

    figures = {"machine": info, "length": [], "count": []}
    print(f"\n{'record':>22} {'samples':>8} {'round s':>8} {'verdict':>18} {'refine s':>9}")
    for T in lengths:
        exps = length_set(true, T)
        n = sum(e.measurement.n for e in exps)
        t_round, d = timed(lambda: diagnose(start, exps))
        row = {"cyclic_s": T, "simulated_s": 1.0 + T, "samples": n, "round_s": t_round,
               "verdict": d.verdict or "none"}
        if scheduler is not None:
            on_cluster(row, d, lambda: diagnose(start, exps, scheduler=scheduler))
        if T in ref_len:
            row["refine_s"], _ = timed(lambda: refine(start, exps))
            if scheduler is not None:
                row["dask_refine_s"], _ = timed(lambda: refine(start, exps, scheduler=scheduler))
        if a.memory:
            peak, _ = peak_memory(lambda: diagnose(start, exps))
            row["peak_mb"], row["records_mb"] = peak / 1e6, record_bytes(exps) / 1e6
        figures["length"].append(row)
        print(f"{'1 s hold + %g s cyclic' % T:>22} {n:>8} {t_round:>8.2f} {row['verdict']:>18} "
              f"{row.get('refine_s', float('nan')):>9.2f}" + _memory_text(row) + _dask_text(row))
    for n_exp in counts:
        exps = count_set(true, n_exp, a.duration)
        n = sum(e.measurement.n for e in exps)
        t_round, d = timed(lambda: diagnose(start, exps))
        row = {"experiments": n_exp, "simulated_s": n_exp * a.duration, "samples": n,
               "round_s": t_round, "verdict": d.verdict or "none"}
        if scheduler is not None:
            on_cluster(row, d, lambda: diagnose(start, exps, scheduler=scheduler))
        if n_exp in ref_cnt:
            row["refine_s"], _ = timed(lambda: refine(start, exps))
            if scheduler is not None:
                row["dask_refine_s"], _ = timed(lambda: refine(start, exps, scheduler=scheduler))
        if a.memory:
            peak, _ = peak_memory(lambda: diagnose(start, exps))
            row["peak_mb"], row["records_mb"] = peak / 1e6, record_bytes(exps) / 1e6
        figures["count"].append(row)
        print(f"{'%d x %g s' % (n_exp, a.duration):>22} {n:>8} {t_round:>8.2f} "
              f"{row['verdict']:>18} {row.get('refine_s', float('nan')):>9.2f}" + _memory_text(row)
              + _dask_text(row))
    close_cluster()
    if scheduler is not None:
        figures["scheduler"] = a.scheduler if a.scheduler.startswith("local:") else "a Dask scheduler"

    for key in ("length", "count"):
        mem = [r for r in figures[key] if "peak_mb" in r]
        if len(mem) >= 2:
            figures[f"memory_exponent_{key}"] = exponent([r["records_mb"] for r in mem],
                                                         [r["peak_mb"] for r in mem])
            print(f"peak memory ~ (record bytes)^{figures[f'memory_exponent_{key}']:.2f} ({key})")
    rows = figures["length"]
    b_len = exponent([r["simulated_s"] for r in rows], [r["round_s"] for r in rows])
    rows = figures["count"]
    b_cnt = exponent([r["experiments"] for r in rows], [r["round_s"] for r in rows])
    figures["exponent_length"] = b_len
    figures["exponent_count"] = b_cnt
    by_len = {r["cyclic_s"]: r["round_s"] for r in figures["length"]}
    if 20.0 in by_len and 1.7 in by_len:
        figures["ratio_20_to_1_7"] = by_len[20.0] / by_len[1.7]
        print(f"\nround on 1 + 20 s / round on 1 + 1.7 s: {figures['ratio_20_to_1_7']:.2f}")
    if b_len is not None:
        print(f"round time ~ (simulated seconds)^{b_len:.2f}")
    if b_cnt is not None:
        print(f"round time ~ (number of experiments)^{b_cnt:.2f}")
    save_figures(a.json, {k: v for k, v in figures.items() if v is not None})


if __name__ == "__main__":
    main()
