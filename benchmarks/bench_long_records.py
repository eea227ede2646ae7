"""Diagnosis cost against record length and number of experiments (issue 26).

Run from the repository root::

    python benchmarks/bench_long_records.py [--lengths 1,1.7,5,20,60] [--counts 2,5,10]
                                            [--refine-lengths 20] [--pairs 20] [--memory]
                                            [--json PATH]
                                            [--scheduler local|dask|tcp://host:8786]
                                            [--workers N | --workers 1,2,4,8,16]

A worker sweep on a many-core machine (one round on 1 s + 20 s and one on 10 x 2 s per count;
``--scheduler dask`` needs dask.distributed there, ``local`` only numpy, scipy and numba)::

    python benchmarks/bench_long_records.py --scheduler local --workers 1,2,4,8,16 --json local.json
    python benchmarks/bench_long_records.py --scheduler dask --workers 1,2,4,8,16 --json dask.json

The rig is the paper's 4/2 jack (``paper-4way``) with a hidden piston leak
(conductance :data:`LEAK`), diagnosed from the catalogue model with nothing
declared:

* **record length**: a locked 1 s hold test plus a free cyclic record of ``T`` seconds
  (a machine cycling once a second: extend pulse, dwell, retract pulse, dwell), 1 kHz,
  pressures and position recorded;
* **number of experiments**: ``n`` tests of 2 s each at supply pressures from 5 to 7 bar
  (abs), every other one locked (a hold), the others free and cycling;
* **pairs** (``--pairs T``): a locked hold and a free cyclic record of ``T`` seconds each (the
  issue's 2 x 20 s), the round and the refinement loop timed.

For each it prints the wall time of one diagnosis round (and with ``--memory`` its peak
memory: the most the round holds above what it started with, traced by :mod:`tracemalloc`,
which numpy reports its arrays to, against the bytes of the records' series, so that a
per-candidate copy of every series would show as a ratio growing with the candidates; and the
growth of the resident memory of a forked child running the same round, :func:`peak_rss`,
what a server's process takes; ``--memory-kinds compare,calibrate,refine,heat`` measures
those analyses too, the figures of the API's memory estimate, app/analysis_memory.py)
(:func:`pneucore.analysis.diagnose.diagnose`) and, for ``--refine-lengths``, of the
refinement loop (:func:`pneucore.analysis.history.refine`), with the exponent ``b`` of
``time ~ a * size^b`` fitted by least squares on the logarithms (size: simulated seconds
of record in all, or the number of experiments). Speed is measured here, never asserted by
a test.

``--scheduler`` says where a round's independent work runs (the sensitivities, the candidates'
refits, the per-experiment consistency fits; :mod:`pneucore.analysis.parallel`): ``local``, this
process's threads (``--workers`` of them); ``dask``, a Dask LocalCluster of ``--workers``
single-threaded worker processes started here (each task's own fit on one thread); or a
scheduler's address. With several ``--workers`` every case runs at each count (by default one
round on 1 s + 20 s and one on 10 x 2 s) and a compact table gives each round's time, the
speed-up over the first count and the parallel efficiency; every row says whether the verdict,
the ranking and the leading candidate's fitted values are those of the first count (to 1e-9).
The script imports pneucore, numpy, scipy and numba only (and dask.distributed with ``dask``).
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
from pneucore.description.model import Model  # noqa: E402
from pneucore.description.scenario import pulse_train  # noqa: E402
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
    out = (f"   peak {row['peak_mb']:.1f} MB for {row['records_mb']:.2f} MB of records "
           f"({row['peak_mb'] / row['records_mb']:.0f}x, "
           f"{1e6 * row['peak_mb'] / row['samples']:.0f} B a sample)")
    if row.get("rss_mb") is not None:
        out += f", resident +{row['rss_mb']:.1f} MB ({1e6 * row['rss_mb'] / row['samples']:.0f} B a sample)"
    for kind, m in row.get("kinds", {}).items():
        out += (f"\n{'':>40}{kind}: peak {m['peak_mb']:.1f} MB ({1e6 * m['peak_mb'] / row['samples']:.0f} B "
                f"a sample)" + (f", resident +{m['rss_mb']:.1f} MB" if m.get("rss_mb") is not None else ""))
    return out


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


def _vm_kb(field):
    """A ``Vm...`` line of /proc/self/status [kB]; None where there is none."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return None


def peak_rss(fn):
    """Growth of the resident memory (peak minus start) while ``fn()`` runs in a forked child
    [bytes], what the server's process would take on top of what it holds (the compiled core,
    the modules: inherited, not counted); None where fork or /proc is missing. The child resets
    its peak (``/proc/self/clear_refs``) before the work, so the parent's own peak is not read."""
    if not hasattr(os, "fork") or _vm_kb("VmHWM") is None:
        return None
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:   # the child: run, write the growth, exit at once
        os.close(r)
        grow = -1
        try:
            with open("/proc/self/clear_refs", "w") as fh:
                fh.write("5")   # resets VmHWM to the current resident size
            start = _vm_kb("VmRSS")
            fn()
            grow = (_vm_kb("VmHWM") - start) * 1024
        finally:
            os.write(w, str(grow).encode())
            os._exit(0)
    os.close(w)
    with os.fdopen(r) as fh:
        text = fh.read()
    os.waitpid(pid, 0)
    grow = int(text or -1)
    return grow if grow >= 0 else None


#: Analyses whose peak ``--memory-kinds`` measures on each case besides the diagnosis round
#: (the API's memory estimate per kind, app/analysis_memory.py, rests on these figures)
MEMORY_KINDS = ("compare", "calibrate", "refine", "heat", "simulate")


def analysis(kind, start, exps, sched=None):
    """A callable running one analysis of ``kind`` on ``exps`` as the API runs it."""
    if kind == "diagnose":
        return lambda: diagnose(start, exps, scheduler=sched)
    if kind == "compare":
        from pneucore.analysis.compare import compare
        return lambda: compare(start, exps).to_dict()
    if kind == "calibrate":
        from pneucore.analysis.calibrate import calibrate
        params = {"effects.piston_leakage.conductance": {"value": 1e-10, "min": 0.0,
                                                         "max": 1e-8}}
        s = start.copy()
        s.effects["piston_leakage"] = {"conductance": 1e-10}
        return lambda: calibrate(s, exps, params).summary()
    if kind == "refine":
        return lambda: refine(start, exps, scheduler=sched)
    if kind == "heat":
        from pneucore.analysis.heat_compare import compare_heat_models
        return lambda: compare_heat_models(start, exps[:1])
    if kind == "simulate":   # each record's scenario simulated and answered as POST /api/simulate
        import orjson

        def answers():
            for e in exps:
                res = e.simulate(start)
                orjson.dumps(res.to_dict(arrays=True, inputs=False),
                             option=orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS)
        return answers
    raise ValueError(kind)


def set_threads(n):
    """This process's threads for a diagnosis's independent work (the finite-difference
    columns, the sensitivities, the candidates' refits) [-]."""
    import pneucore.analysis.calibrate as calibrate
    calibrate.THREADS = max(1, int(n))


def open_cluster(scheduler, workers):
    """``(scheduler, close)`` for a configuration: ``local`` (this process's threads: None),
    ``dask`` (a LocalCluster of ``workers`` single-threaded worker processes started here, each
    with one thread for its tasks' own fits), or a Dask scheduler's address (as given)."""
    if scheduler == "local":
        return None, lambda: None
    try:
        import distributed
    except ImportError:
        sys.exit("--scheduler dask needs dask.distributed on this machine "
                 "(pip install dask distributed), or run --scheduler local")
    if scheduler != "dask":
        return scheduler, lambda: None
    import logging
    cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                       dashboard_address="127.0.0.1:0",
                                       silence_logs=logging.CRITICAL)
    client = distributed.Client(cluster, set_as_default=False)
    client.run(set_threads, 1)   # one core a worker: N workers are N cores

    def close():
        client.close()
        cluster.close()
    return client, close


def same_answer(d, ref):
    """Are diagnosis ``d``'s verdict, ranking and leading fitted values ``ref``'s (to 1e-9: the
    same arithmetic on the same inputs, on other threads or in another process)?"""
    if ref is None:
        return True
    same = d.verdict == ref.verdict and [r["effect"] for r in d.ranking] == \
        [r["effect"] for r in ref.ranking]
    if same and d.ranking:
        a, b = ref.ranking[0]["params"], d.ranking[0]["params"]
        same = all(abs(b[p]["value"] - v["value"]) <= 1e-9 * abs(v["value"]) for p, v in a.items())
    return bool(same)


def pair_set(true, T):
    """A locked hold and a free cyclic record, ``T`` seconds each (the issue's 2 x 20 s)."""
    return as_experiments([experiment(true, hold(true, T), "hold", 1),
                           experiment(true, cyclic(T), "cyclic", 2)])


def cases(true, lengths, counts, duration, ref_len, ref_cnt, pairs=()):
    """``[(key, label, experiments, refine too)]``: the length set, the count set, then the
    pairs of ``T`` s records (their refinement loop timed too)."""
    out = []
    for T in lengths:
        out.append((("length", T), "1 s hold + %g s cyclic" % T, length_set(true, T), T in ref_len))
    for n in counts:
        out.append((("count", n), "%d x %g s" % (n, duration), count_set(true, n, duration),
                    n in ref_cnt))
    for T in pairs:
        out.append((("pair", T), "%g s hold + %g s cyclic" % (T, T), pair_set(true, T), True))
    return out


def run_config(start, todo, scheduler, workers, memory, refs, repeat, memory_kinds=()):
    """Every case on one configuration (``scheduler``, ``workers``): its rows."""
    set_threads(workers)
    sched, close = open_cluster(scheduler, workers)
    rows = []
    try:
        # the workers' imports and compiled caches, outside the timings
        diagnose(start, todo[0][2][:1], scheduler=sched)
        for key, label, exps, with_refine in todo:
            n = sum(e.measurement.n for e in exps)
            t_round, d = min((timed(lambda: diagnose(start, exps, scheduler=sched))
                              for _ in range(max(repeat, 1))), key=lambda td: td[0])
            row = {"case": label, "samples": n, "round_s": t_round, "verdict": d.verdict or "none",
                   "same": same_answer(d, refs.get(key)), "lost": (d.cluster or {}).get("lost")}
            refs.setdefault(key, d)
            if key[0] == "length":
                row.update(cyclic_s=key[1], simulated_s=1.0 + key[1])
            elif key[0] == "pair":
                row.update(pair_s=key[1], simulated_s=2.0 * key[1])
            else:
                row.update(experiments=key[1], simulated_s=sum(e.measurement.duration for e in exps))
            if with_refine:
                row["refine_s"], _ = timed(lambda: refine(start, exps, scheduler=sched))
            if memory:
                peak, _ = peak_memory(lambda: diagnose(start, exps, scheduler=sched))
                row["peak_mb"], row["records_mb"] = peak / 1e6, record_bytes(exps) / 1e6
                rss = peak_rss(lambda: diagnose(start, exps, scheduler=sched))
                row["rss_mb"] = None if rss is None else rss / 1e6
                row["kinds"] = {}
                for kind in memory_kinds:
                    fn = analysis(kind, start, exps, sched)
                    peak, _ = peak_memory(fn)
                    rss = peak_rss(fn)
                    row["kinds"][kind] = {"peak_mb": peak / 1e6,
                                          "rss_mb": None if rss is None else rss / 1e6}
            rows.append(row)
            print(f"{workers:>7} {label:>22} {n:>8} {t_round:>8.2f} {row['verdict']:>18} "
                  f"{row.get('refine_s', float('nan')):>9.2f} "
                  f"{'same' if row['same'] else 'DIFFERENT':>9}" + _memory_text(row)
                  + (f"   cluster lost: {row['lost']}" if row["lost"] else ""), flush=True)
    finally:
        close()
    return rows


def load():
    """The load average (1, 5, 15 min), or None where the system has none."""
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def sweep_table(configs, scheduler):
    """The compact table of a worker sweep: each case's round time per worker count, with the
    speed-up over the first count and the parallel efficiency (speed-up / worker ratio)."""
    labels = [r["case"] for r in configs[0]["rows"]]
    base = {r["case"]: r["round_s"] for r in configs[0]["rows"]}
    w0 = configs[0]["workers"]
    print(f"\nscaling of a round ({scheduler}): seconds, speed-up over {w0} worker(s), "
          "parallel efficiency")
    print(f"{'workers':>7} " + " ".join(f"{lb:>30}" for lb in labels) + "  answer")
    out = []
    for c in configs:
        w = c["workers"]
        cells, row = [], {"workers": w}
        for r in c["rows"]:
            sp = base[r["case"]] / r["round_s"]
            eff = sp / (w / w0)
            cells.append(f"{r['round_s']:.2f} s {sp:5.2f}x {100 * eff:4.0f} %")
            row[r["case"]] = {"round_s": r["round_s"], "speedup": sp, "efficiency": eff}
        row["same"] = all(r["same"] for r in c["rows"])
        print(f"{w:>7} " + " ".join(f"{x:>30}" for x in cells)
              + ("  same" if row["same"] else "  DIFFERENT"))
        out.append(row)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lengths", default=None,
                    help="cyclic record lengths after the 1 s hold [s], comma-separated "
                         "(default 1,1.7,5,20,60; with several --workers, 20)")
    ap.add_argument("--counts", default=None, help="numbers of 2 s experiments (default 2,5,10; "
                                                   "with several --workers, 10)")
    ap.add_argument("--duration", type=float, default=2.0, help="length of each counted test [s]")
    ap.add_argument("--refine-lengths", default=None,
                    help="cyclic lengths whose refinement loop is timed too [s] (default 20; "
                         "with several --workers, none; '' for none)")
    ap.add_argument("--refine-counts", default="",
                    help="numbers of experiments whose refinement loop is timed too")
    ap.add_argument("--pairs", default="",
                    help="lengths T of a T s locked hold plus a T s cyclic record, round and "
                         "refinement loop timed [s] (the issue's 2 x 20 s: --pairs 20)")
    ap.add_argument("--memory", action="store_true",
                    help="also trace each round's peak memory (a second, untimed round)")
    ap.add_argument("--memory-kinds", default="",
                    help="with --memory, also the peak of these analyses on each case, "
                         "comma-separated among " + ",".join(MEMORY_KINDS) + " (the figures of "
                         "the API's memory estimate, app/analysis_memory.py)")
    ap.add_argument("--json", default=None, help="write the figures to this file")
    ap.add_argument("--scheduler", default="local",
                    help="where a round's independent work runs: local (this process's "
                         "threads), dask (a Dask LocalCluster of --workers single-threaded "
                         "worker processes started here), or a Dask scheduler's address")
    ap.add_argument("--workers", default=None,
                    help="threads (local) or LocalCluster worker processes (dask): one count, "
                         "or a comma-separated sweep such as 1,2,4,8,16 (default: local 2, "
                         "dask the usable cores)")
    ap.add_argument("--repeat", type=int, default=1, help="rounds timed per case (the best is kept)")
    a = ap.parse_args(argv)
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    workers = [int(x) for x in a.workers.split(",") if x] if a.workers else \
        [2 if a.scheduler == "local" else usable]
    sweep = len(workers) > 1
    lengths = [float(x) for x in (a.lengths if a.lengths is not None
                                  else ("20" if sweep else "1,1.7,5,20,60")).split(",") if x]
    counts = [int(x) for x in (a.counts if a.counts is not None
                               else ("10" if sweep else "2,5,10")).split(",") if x]
    ref_len = {float(x) for x in (a.refine_lengths if a.refine_lengths is not None
                                  else ("" if sweep else "20")).split(",") if x}
    ref_cnt = {int(x) for x in a.refine_counts.split(",") if x}
    true = true_model()
    start = Model.from_dict(model_preset("paper-4way"))
    info = machine_info("scipy", "dask", "distributed")
    print("machine:", info)
    print("load average:", load())
    # compile and warm the caches outside the timings
    diagnose(start, length_set(true, 1.0)[:1])
    pairs = [float(x) for x in a.pairs.split(",") if x]
    todo = cases(true, lengths, counts, a.duration, ref_len, ref_cnt, pairs)

    figures = {"machine": info, "scheduler": a.scheduler if a.scheduler in ("local", "dask")
               else "a Dask scheduler", "load_average_start": load(), "configs": []}
    print(f"\n{'workers':>7} {'record':>22} {'samples':>8} {'round s':>8} {'verdict':>18} "
          f"{'refine s':>9} {'answer':>9}")
    refs = {}
    for w in workers:
        kinds = [k for k in a.memory_kinds.split(",") if k] if a.memory else []
        figures["configs"].append({"workers": w, "rows": run_config(start, todo, a.scheduler, w,
                                                                    a.memory, refs, a.repeat,
                                                                    kinds)})
    figures["load_average_end"] = load()

    first = figures["configs"][0]["rows"]
    figures["length"] = [r for r in first if "cyclic_s" in r]
    figures["count"] = [r for r in first if "experiments" in r]
    figures["pair"] = [r for r in first if "pair_s" in r]
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
    if sweep:
        figures["sweep"] = sweep_table(figures["configs"], figures["scheduler"])
    print("load average at the end:", figures["load_average_end"])
    save_figures(a.json, {k: v for k, v in figures.items() if v is not None})


if __name__ == "__main__":
    main()
