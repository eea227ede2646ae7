"""The server's resident memory with every worker busy, against its analysis memory budget
(issue 40, item 4).

A fresh child process builds the app (``--workers`` synchronous workers, the budget
``--budget`` MB), answers one small diagnosis (the core compiled, the caches filled), resets
its peak resident size (``/proc/self/clear_refs``), then ``--clients`` clients each ask for
a diagnosis of a 1 s locked hold plus ``--records`` cyclic records of ``--length`` s each at
1 kHz (``bench_long_records.py``'s rig, each record its own noise), retrying ``--retry`` s after each 503 until answered. It
reports the growth of the peak resident memory over the start, the most analyses running
and the most held on the budget at once (sampled every 20 ms), the 503s, and each
diagnosis's estimate: the growth must stay under the budget. With ``--budget 0`` the budget
is the sum of every client's estimate (nothing refused: the figure without admission).

The API's cost limit (``Limits.max_analysis_seconds``, 200 s, and ``max_analysis_samples``,
200,000, over all of a request's records) is out of one record's reach (a record is limited to
120 s): ``--records 2 --length 99.45`` loads it (1 s + 2 x 99.45 s = 199.9 s, 199,903
samples).

Usage: ``python benchmarks/bench_analysis_budget.py [--length 20] [--records 1] [--clients 4]
[--workers 4] [--budget 400] [--retry 1] [--json out.json]``.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path[:0] = [ROOT, HERE]


def _vm_kb(field):
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    return None


def _body(length, records=1):
    """The diagnosis request: a 1 s hold and ``records`` cyclic records of ``length`` s."""
    import bench_long_records as B
    from pneucore import model_preset
    from pneucore.data.experiment import as_experiments
    true = B.true_model()
    exps = []
    sets = as_experiments([B.experiment(true, B.hold(true), "hold", 1)]
                          + [B.experiment(true, B.cyclic(length), f"cyclic {i + 1}", 2 + i)
                             for i in range(records)])
    for e in sets:
        m = e.measurement
        meas = {"t": m.t.tolist(), **{k: v.tolist() for k, v in m.signals.items()}}
        exps.append({"name": e.name, "scenario": dict(e.scenario), "measurement": meas})
    return {"model": model_preset("paper-4way"), "experiments": exps}


def child(length, clients, workers, budget_mb, retry, records=1):
    """The measured run in this (fresh) process; prints its figures as JSON."""
    from fastapi.testclient import TestClient

    from app.analysis_memory import body_estimate, samples_estimate
    from app.request_memory import json_values
    from app.config import Limits, Settings
    from app.main import create_app
    body = _body(length, records)
    samples = sum(len(e["measurement"]["t"]) for e in body["experiments"])
    estimate = samples_estimate("diagnose", samples)
    # a body over 64 kB is held on the budget too, its parsed values (app.bodies)
    body_held = body_estimate(json_values(json.dumps(body).encode()))
    budget = int(budget_mb * 1e6) if budget_mb > 0 else (estimate + body_held) * clients
    with tempfile.TemporaryDirectory() as tmp:
        app = create_app(Settings(db_path=os.path.join(tmp, "b.sqlite3"), seed_samples=False,
                                  resume_studies=False,
                                  limits=Limits(sync_workers=workers, max_sync_queue=clients,
                                                analysis_memory_budget=budget,
                                                request_time_limit=3600.0)))
        with TestClient(app, base_url="http://127.0.0.1") as c:
            r = c.post("/api/diagnose", json=_body(1.0))   # compiled, caches filled
            assert r.status_code == 200, r.text[:300]
            with open("/proc/self/clear_refs", "w") as fh:
                fh.write("5")   # the peak resident size from here
            start = _vm_kb("VmRSS")
            seen = {"running": 0, "held": 0}
            done = threading.Event()

            def watch():
                while not done.wait(0.02):
                    st = app.state.memory.state()
                    seen["running"] = max(seen["running"], st["running"])
                    seen["held"] = max(seen["held"], st["held"])
            refused = []

            def client():
                while True:
                    r = c.post("/api/diagnose", json=body)
                    if r.status_code != 503:
                        if r.status_code != 200:   # what refused it, for the report
                            print(f"answer {r.status_code}: {r.text[:300]}", file=sys.stderr)
                        return r.status_code
                    refused.append(r.json())
                    time.sleep(retry)
            threading.Thread(target=watch, daemon=True).start()
            t0 = time.perf_counter()
            threads = []
            statuses = []
            for _ in range(clients):
                th = threading.Thread(target=lambda: statuses.append(client()))
                th.start()
                threads.append(th)
            for th in threads:
                th.join()
            seconds = time.perf_counter() - t0
            done.set()
            peak = _vm_kb("VmHWM")
    print(json.dumps({"length_s": length, "records": records, "samples": samples, "clients": clients,
                      "workers": workers, "budget_mb": budget / 1e6,
                      "estimate_mb": estimate / 1e6, "body_estimate_mb": body_held / 1e6,
                      "start_rss_mb": start / 1e3,
                      "growth_mb": (peak - start) / 1e3, "most_running": seen["running"],
                      "most_held_mb": seen["held"] / 1e6, "refused_503": len(refused),
                      "statuses": sorted(statuses), "seconds": seconds}))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--length", type=float, default=20.0, help="cyclic record after the 1 s hold [s]")
    ap.add_argument("--records", type=int, default=1,
                    help="cyclic records of --length s each after the 1 s hold [-]")
    ap.add_argument("--clients", type=int, default=4)
    ap.add_argument("--workers", type=int, default=4, help="sync_workers [-]")
    ap.add_argument("--budget", type=float, default=400.0,
                    help="analysis_memory_budget [MB]; 0 = every client's estimate (none refused)")
    ap.add_argument("--retry", type=float, default=1.0, help="seconds before a refused client retries")
    ap.add_argument("--json", default=None)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        return child(a.length, a.clients, a.workers, a.budget, a.retry, a.records)
    from machine import machine_info, save_figures
    info = machine_info("scipy", "fastapi")
    print("machine:", info)
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", "--length",
                          str(a.length), "--records", str(a.records), "--clients", str(a.clients), "--workers", str(a.workers),
                          "--budget", str(a.budget), "--retry", str(a.retry)],
                         capture_output=True, text=True, env=env, cwd=ROOT, timeout=3600)
    if out.returncode != 0:
        sys.exit(out.stderr[-3000:])
    # what refused an analysis (a 4xx other than the budget's 503), as the child wrote it
    for line in out.stderr.splitlines():
        if line.startswith("answer "):
            print(line)
    fig = json.loads(out.stdout.strip().splitlines()[-1])
    print(json.dumps(fig, indent=1))
    print(f"peak resident growth {fig['growth_mb']:.0f} MB for a budget of {fig['budget_mb']:.0f} MB "
          f"({fig['most_running']} diagnoses at once at most, {fig['refused_503']} answers 503)")
    save_figures(a.json, {"machine": info, **fig})


if __name__ == "__main__":
    main()
