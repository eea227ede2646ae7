"""The three job estimates that were set, not measured, against their measured peaks (issue 40,
item 4): a study worker process, a friction-bench sample, a closed-loop run.

Each figure of :mod:`app.analysis_memory` below is measured at a few sizes and set beside the
estimate the admission holds:

- ``study`` (:data:`~app.analysis_memory.STUDY_WORKER_BYTES`): a robustness study
  (``bench_study.py``'s: ``paper-4way``, ``paper-fig10-pulses`` stretched to ``--study-durations``
  s at 1 kHz) on the local pool of ``--study-workers`` processes, run from this process as the
  server's job runs it. Every 20 ms the unique set size (USS: the pages a process holds alone,
  what it adds to the machine; the pages it shares with the warm forkserver are the server's)
  of each pool worker is read (``/proc/PID/smaps_rollup``: Private_Clean + Private_Dirty); the peak per worker is
  reported with the forkserver's own USS (started once per server, not per study);
- ``friction`` (:data:`~app.analysis_memory.IDENTIFY_FRICTION_BYTES_PER_SAMPLE`): POST
  /api/identify/friction's work (``app.services._identify_friction``, the answer's JSON
  written) on synthetic bench records (``tests/identify/test_friction_bench.py``'s law: two
  sinusoids at held pressures, 100 Hz), four fitted and one validated, ``--friction-samples``
  in all, with and without the extras; resident growth of a forked child
  (:func:`bench_long_records.peak_rss`) and the :mod:`tracemalloc` peak, the larger taken;
- ``control`` (:data:`~app.analysis_memory.CONTROL_RUN_BYTES`): a controller tuning
  (``bench_tuning.py``'s case, ``--control-duration`` s a run) of ``--control-runs`` runs on a
  pool of one worker: what the job's own process holds (the :mod:`tracemalloc` peak of the
  calling process, the answer included; the runs themselves are the pool's), per run.

Usage::

    python benchmarks/bench_job_memory.py [--kinds study,friction,control]
        [--study-workers 1,2] [--study-durations 1,10,60] [--study-runs 32]
        [--friction-samples 10000,50000,200000] [--control-runs 100,400,1000,3000] [--json out.json]

Memory is measured here, never asserted by a timed test.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import threading
import time
import tracemalloc

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path[:0] = [ROOT, HERE]

import numpy as np  # noqa: E402

import bench_long_records as B  # noqa: E402
from machine import machine_info, save_figures  # noqa: E402

from app.analysis_memory import (CONTROL_RUN_BYTES, IDENTIFY_FRICTION_BYTES_PER_SAMPLE,  # noqa: E402
                                 STUDY_WORKER_BYTES, control_estimate, identify_estimate,
                                 samples_estimate, study_estimate)

#: How often the pool workers' memory is read while a study runs [s]
SAMPLE_PERIOD = 0.02


def load():
    try:
        return round(os.getloadavg()[0], 2)
    except OSError:
        return None


# ----------------------------------------------------------------------------------- study
def _uss(pid):
    """Unique set size of process ``pid`` (its private pages, /proc/PID/smaps_rollup) [bytes];
    None where it cannot be read (gone, or no /proc)."""
    try:
        with open(f"/proc/{pid}/smaps_rollup") as fh:
            kb = sum(int(line.split()[1]) for line in fh
                     if line.startswith(("Private_Clean:", "Private_Dirty:")))
        return kb * 1024
    except (OSError, ValueError, IndexError):
        return None


def _children(pid):
    """Processes whose parent is ``pid`` [-] (/proc/PID/task/*/children)."""
    out = []
    try:
        for task in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{task}/children") as fh:
                out += [int(x) for x in fh.read().split()]
    except OSError:
        pass
    return out


def measure_study(workers, duration, runs):
    """``(peak USS per pool worker, forkserver USS, wall s)`` of one study [bytes, bytes, s];
    None for the first where /proc cannot be read."""
    from bench_study import study_definition
    from pneucore.study.execute import run_study
    d = study_definition(runs)
    d["scenario"] = dict(d["scenario"], duration=float(duration))
    me = os.getpid()
    peaks, server = {}, [0]
    done = threading.Event()

    def watch():
        while not done.is_set():
            # the forkserver is this process's child; the pool's workers are its children
            for child in _children(me):
                u = _uss(child)
                if u is not None:
                    server[0] = max(server[0], u)
                for worker in _children(child):
                    u = _uss(worker)
                    if u is not None:
                        peaks[worker] = max(peaks.get(worker, 0), u)
            done.wait(SAMPLE_PERIOD)

    t = threading.Thread(target=watch, daemon=True)
    t0 = time.perf_counter()
    t.start()
    try:
        run_study(d, workers=workers)
    finally:
        done.set()
        t.join()
    return (max(peaks.values()) if peaks else None), server[0], time.perf_counter() - t0


# -------------------------------------------------------------------------------- friction
def friction_records(samples, fs=100.0):
    """Five bench records of ``samples`` samples in all (four to fit, one to validate), as
    JSON-ready dicts: Eq. 17 with a quadrant and pressure dependent law, held pressures,
    load-cell and encoder noise (tests/identify/test_friction_bench.py's, vectorised)."""
    from pneucore import model_preset
    from pneucore.description.model import Model
    from pneucore.physics.gas import P_ATM
    model = Model.from_dict(model_preset("paper-4way"))
    j = model.jack
    law = {1: (12.0, 2e-5, 1e-5, 150.0, 1e-4, 0.0), -1: (18.0, 1e-5, 3e-5, 250.0, 0.0, 2e-4)}
    out = []
    for k, (pa_g, pb_g) in enumerate([(1.0, 0.0), (3.0, 1.0), (6.0, 2.0), (2.0, 5.0), (0.5, 6.0)]):
        n = samples // 5
        rng = np.random.default_rng(k)
        t = np.arange(n) / fs
        w1, w2, amp = 2 * math.pi * 0.3, 2 * math.pi * 0.81, 0.02
        x = amp * np.sin(w1 * t) + 0.3 * amp * np.sin(w2 * t)
        v = amp * w1 * np.cos(w1 * t) + 0.3 * amp * w2 * np.cos(w2 * t)
        a = -amp * w1 ** 2 * np.sin(w1 * t) - 0.3 * amp * w2 ** 2 * np.sin(w2 * t)
        p_a = P_ATM + pa_g * 1e5 + rng.normal(0, 200.0, n)
        p_b = P_ATM + pb_g * 1e5 + rng.normal(0, 200.0, n)
        s = np.where(v > 0, 1, -1)
        c = {key: np.where(s > 0, law[1][i], law[-1][i]) for i, key in enumerate(
            ("fc0", "fc_a", "fc_b", "kv0", "kv_a", "kv_b"))}
        fc = c["fc0"] + c["fc_a"] * (p_a - P_ATM) + c["fc_b"] * (p_b - P_ATM)
        kv = c["kv0"] + c["kv_a"] * (p_a - P_ATM) + c["kv_b"] * (p_b - P_ATM)
        F_p = p_a * j.area_a - p_b * j.area_b + P_ATM * (j.rod_area_a - j.rod_area_b)
        F = F_p - (s * fc + kv * v) - j.moving_mass * a + rng.normal(0, 0.3, n)
        x = x + rng.normal(0, 1e-6, n)
        out.append({"name": f"{pa_g:g}/{pb_g:g} bar", "t": t.tolist(), "x": x.tolist(),
                    "p_a": p_a.tolist(), "p_b": p_b.tolist(), "F": F.tolist()})
    return model.to_dict(), out


def measure_friction(samples, extras, traced=True, warm=False):
    """``(samples, resident growth, traced peak or None, wall s)`` of one friction
    identification as the API runs it [-, bytes, bytes, s]; ``warm``: run it once in this
    process instead (its lazy imports and first-call caches then inherited by the children
    measured after), nothing measured."""
    import orjson

    from app.schemas_identify import FrictionIdentifyRequest
    from app.services import _identify_friction, check_identify_friction
    model, recs = friction_records(samples)
    req = FrictionIdentifyRequest.model_validate({"model": model, "experiments": recs[:4],
                                                  "validate": recs[4:], "extras": list(extras)})
    c = check_identify_friction(req)
    n = sum(int(r.t.size) for r in list(c["fit"]) + list(c["validate"]))
    del model, recs

    def fn():
        orjson.dumps(_identify_friction(req, c, None), option=orjson.OPT_SERIALIZE_NUMPY)
    if warm:
        fn()
        return n, None, None, None
    t0 = time.perf_counter()
    rss = B.peak_rss(fn)
    wall = time.perf_counter() - t0
    peak = B.peak_memory(fn)[0] if traced else None
    return n, rss, peak, wall


# --------------------------------------------------------------------------------- control
def measure_control(kind, runs, duration):
    """``(runs, traced peak, held after, wall s)`` of one ``kind`` job (``tune``: a tuning of
    ``runs`` closed-loop runs, 25-run ensembles times kp values; ``study``: a closed-loop study
    of ``runs`` moving masses) in this process, the pool of one worker simulating
    [-, bytes, bytes, s]."""
    import orjson

    from bench_tuning import definition
    from pneucore.control.robustness import closed_loop_study, tune_controller
    d = definition(duration)
    if kind == "tune":
        ensemble = 25   # bench_tuning's 5 x 5 grid
        sets = max(1, round(runs / ensemble))
        kp = [5.0 + 20.0 * i / max(1, sets - 1) for i in range(sets)]
        n = sets * ensemble
        work = lambda: tune_controller(d, {"kp": kp}, engine={"workers": 1})  # noqa: E731
    else:
        n = runs
        d["parameters"] = {"jack.moving_mass": {"grid": [1.0 + 3.0 * i / max(1, n - 1)
                                                         for i in range(n)]}}
        work = lambda: closed_loop_study(d, engine={"workers": 1},  # noqa: E731
                                         specification={"settling_time": 0.5})
    tracemalloc.start()
    try:
        base, _ = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        t0 = time.perf_counter()
        out = work()
        orjson.dumps(out, option=orjson.OPT_SERIALIZE_NUMPY)
        wall = time.perf_counter() - t0
        held, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return n, peak - base, held - base, wall


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kinds", default="study,friction,control")
    ap.add_argument("--study-workers", default="1,2")
    ap.add_argument("--study-durations", default="1,10,60", help="simulated seconds a run [s]")
    ap.add_argument("--study-runs", type=int, default=32, help="runs per worker")
    ap.add_argument("--friction-samples", default="10000,50000,200000")
    ap.add_argument("--control-runs", default="100,400,1000,3000")
    ap.add_argument("--control-duration", type=float, default=0.5, help="a run [s]")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    kinds = a.kinds.split(",")
    info = machine_info("scipy")
    print(info)
    fig = {"machine": info, "set": {"STUDY_WORKER_BYTES": STUDY_WORKER_BYTES,
                                    "IDENTIFY_FRICTION_BYTES_PER_SAMPLE":
                                        IDENTIFY_FRICTION_BYTES_PER_SAMPLE,
                                    "CONTROL_RUN_BYTES": CONTROL_RUN_BYTES}}
    if "study" in kinds:
        from pneucore.study.execute import run_study
        from bench_study import study_definition
        run_study(study_definition(2), workers=1)   # the forkserver warm, as a server's is
        rows = fig["study"] = []
        print(f"{'workers':>7} {'run [s]':>7} {'runs':>5} {'USS/worker':>11} {'forkserver':>11} "
              f"{'estimate/worker':>16} {'ratio':>6} {'wall':>6} {'load':>5}")
        for W in (int(x) for x in a.study_workers.split(",")):
            for T in (float(x) for x in a.study_durations.split(",")):
                before = load()
                uss, fs, wall = measure_study(W, T, a.study_runs * W)
                run_samples = int(round(T * 1000)) + 1
                est = study_estimate(run_samples, W) / W
                rows.append({"workers": W, "duration": T, "runs": a.study_runs * W,
                             "uss_per_worker": uss, "forkserver_uss": fs,
                             "estimate_per_worker": est,
                             "ratio": None if not uss else est / uss, "wall_s": wall,
                             "load": [before, load()]})
                print(f"{W:>7} {T:>7g} {a.study_runs * W:>5} {(uss or 0) / 1e6:>9.1f}MB "
                      f"{(fs or 0) / 1e6:>9.1f}MB {est / 1e6:>14.1f}MB "
                      f"{(est / uss if uss else float('nan')):>6.2f} {wall:>5.0f}s {before:>5.1f}",
                      flush=True)
    if "friction" in kinds:
        # the identification's lazy imports and caches loaded here (a server has them after
        # its first request), inherited by every measured child
        first = int(a.friction_samples.split(",")[0])
        for extras in ((), ("offset",)):
            measure_friction(first, extras, warm=True)
        rows = fig["friction"] = []
        print(f"{'samples':>8} {'extras':>6} {'resident':>9} {'traced':>9} {'B/sample':>9} "
              f"{'estimate':>9} {'ratio':>6} {'wall':>6} {'load':>5}")
        for S in (int(x) for x in a.friction_samples.split(",")):
            for extras in ((), ("offset", "area_a", "area_b", "mass")):
                before = load()
                n, rss, peak, wall = measure_friction(S, extras)
                measured = max(x for x in (rss, peak) if x is not None)
                est = identify_estimate("friction", n)
                rows.append({"samples": n, "extras": list(extras), "rss": rss, "traced": peak,
                             "measured": measured, "bytes_per_sample": measured / n,
                             "estimate": est, "ratio": est / measured, "wall_s": wall,
                             "load": [before, load()]})
                print(f"{n:>8,} {len(extras):>6} {(rss or 0) / 1e6:>7.1f}MB {peak / 1e6:>7.1f}MB "
                      f"{measured / n:>9,.0f} {est / 1e6:>7.1f}MB {est / measured:>6.2f} "
                      f"{wall:>5.1f}s {before:>5.1f}", flush=True)
    if "control" in kinds:
        for kind in ("tune", "study"):   # the first job's imports and pool start
            measure_control(kind, 25, a.control_duration)
        rows = fig["control"] = []
        samples = int(round(a.control_duration * 1000)) + 1
        print(f"{'job':>5} {'runs':>6} {'traced peak':>11} {'held':>9} {'B/run':>7} "
              f"{'estimate':>9} {'ratio':>6} {'wall':>6} {'load':>5}")
        for kind in ("tune", "study"):
            for R in (int(x) for x in a.control_runs.split(",")):
                before = load()
                n, peak, held, wall = measure_control(kind, R, a.control_duration)
                est = control_estimate(samples, n)
                rows.append({"job": kind, "runs": n, "traced_peak": peak, "held": held,
                             "bytes_per_run": peak / n, "estimate": est,
                             "estimate_runs_part": n * CONTROL_RUN_BYTES,
                             "floor_part": samples_estimate("simulate", samples),
                             "ratio": est / peak, "wall_s": wall, "load": [before, load()]})
                print(f"{kind:>5} {n:>6} {peak / 1e6:>9.2f}MB {held / 1e6:>7.2f}MB "
                      f"{peak / n:>7,.0f} {est / 1e6:>7.1f}MB {est / peak:>6.2f} {wall:>5.1f}s "
                      f"{before:>5.1f}", flush=True)
    save_figures(a.json, fig)


if __name__ == "__main__":
    main()
