"""Latency benchmark of the REST API's simulate endpoint over real HTTP.

Run from the repository root::

    python benchmarks/bench_api.py [--json PATH] [--requests N] [--clients C] [--per-client K]

Set-up: ``uvicorn app.main:app`` (one worker, as ``python -m app`` runs it) is
started in a subprocess on a free localhost port, with ``PNEUCORE_DB`` pointing
to a temporary SQLite file. After a warm-up (the first call may load or
compile the numba core), ``POST /api/simulate`` with the ``paper-4way`` model
and the ``paper-fig10-pulses`` scenario (1 s, 1 kHz, all default series, about
0.25 MB of JSON) is measured:

* **sequential**: ``--requests`` (200) requests one after the other on one
  keep-alive connection: median, p95, min, max latency;
* **concurrent**: ``--clients`` (20) clients, each on its own connection,
  sending ``--per-client`` (10) requests back to back: median and p95
  latency over all requests, and the throughput;
* for reference, the in-process cost of what the endpoint does (parse and
  validate, :func:`pneucore.simulate`, the result's ``to_dict``, orjson), stage by
  stage, without HTTP.

Every response is checked after its timing (status 200, same bytes as the first one).
Targets: sequential median <= 2x the in-process ``simulate()`` (the ratio is printed,
with the load average: both sides are measured in the same run); median <= 30 ms with
20 concurrent clients. uvicorn picks httptools and uvloop when installed, as
``python -m app`` does.
"""
from __future__ import annotations

import argparse
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info as _machine_info, save_figures  # noqa: E402

MODEL, SCENARIO = "paper-4way", "paper-fig10-pulses"
TARGET_MEDIAN_MS = 30.0
#: Round trip over HTTP against the in-process simulate() (medians)
TARGET_RATIO = 2.0


def machine_info():
    return _machine_info("fastapi", "uvicorn", "httpx")


def _load():
    with open("/proc/loadavg") as f:
        return float(f.read().split()[0])


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def percentile(values, q):
    """Nearest-rank percentile (q in [0, 100])."""
    v = sorted(values)
    k = max(0, min(len(v) - 1, int(round(q / 100.0 * len(v) + 0.5)) - 1))
    return v[k]


def summary(lat_s):
    ms = [x * 1e3 for x in lat_s]
    return {"n": len(ms), "median_ms": statistics.median(ms), "p95_ms": percentile(ms, 95),
            "mean_ms": statistics.fmean(ms), "min_ms": min(ms), "max_ms": max(ms)}


class Server:
    """``uvicorn app.main:app`` in a subprocess on a temporary database."""

    def __init__(self, port, db_path, log_path, http="auto", loop="auto"):
        env = dict(os.environ, PNEUCORE_DB=db_path, PYTHONUNBUFFERED="1")
        env["PYTHONPATH"] = ROOT + os.pathsep + env.get("PYTHONPATH", "")
        self.log = open(log_path, "w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "uvicorn", "app.main:app", "--host", "127.0.0.1",
             "--port", str(port), "--workers", "1", "--log-level", "warning", "--no-access-log",
             "--http", http, "--loop", loop],
            cwd=ROOT, env=env, stdout=self.log, stderr=subprocess.STDOUT)
        self.url = f"http://127.0.0.1:{port}"

    def wait_ready(self, client, timeout=120.0):
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < timeout:
            if self.proc.poll() is not None:
                raise RuntimeError(f"uvicorn exited with code {self.proc.returncode}")
            try:
                if client.get(self.url + "/api/limits").status_code == 200:
                    return time.perf_counter() - t0
            except Exception:
                pass
            time.sleep(0.05)
        raise RuntimeError(f"uvicorn not ready after {timeout} s")

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()


def check(resp, ref):
    """Status 200 and the same bytes as the first response (orjson output is deterministic)."""
    if resp.status_code != 200:
        raise RuntimeError(f"HTTP {resp.status_code}: {resp.text[:300]}")
    if ref is not None and resp.content != ref:
        raise RuntimeError("a response differs from the first one")


def in_process(body, runs=50):
    """Median wall times in this process (no HTTP) of what the endpoint does, stage by stage:
    request validation (pydantic) and parsing, :func:`pneucore.simulate`, the answer's dict
    and its orjson rendering; ``simulate`` alone is the in-process simulation the round trip
    is compared with."""
    from app.config import Limits
    from app.deps import parse_model, parse_scenario
    from app.responses import JSON
    from app.services import result_json
    from app.schemas import SimulateRequest
    from pneucore import simulate
    limits = Limits()
    stages = {"parse": [], "simulate": [], "to_dict": [], "orjson": [], "total": []}
    for i in range(runs + 3):
        t0 = time.perf_counter()
        req = SimulateRequest.model_validate(body)
        m = parse_model(req.model)
        s = parse_scenario(req.scenario, m, limits)
        t1 = time.perf_counter()
        res = simulate(m, s)
        t2 = time.perf_counter()
        d = result_json(res, req.series)   # as the router does
        t3 = time.perf_counter()
        JSON(d)
        t4 = time.perf_counter()
        if i >= 3:
            for k, v in zip(stages, (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t4 - t0)):
                stages[k].append(v)
    return {k: statistics.median(v) * 1e3 for k, v in stages.items()}


def run(args):
    import httpx
    from pneucore import model_preset, scenario_preset
    body = {"model": model_preset(MODEL), "scenario": scenario_preset(SCENARIO)}
    # the request body encoded once, as a client holding its JSON would send it
    raw, hdr = json.dumps(body).encode(), {"content-type": "application/json"}
    out = {"case": {"model": MODEL, "scenario": SCENARIO, "endpoint": "POST /api/simulate",
                    "series": "default (all)"},
           "machine": machine_info(), "target": {"sequential_median_ms": TARGET_MEDIAN_MS}}
    out["load"] = [_load()]
    tmp = tempfile.mkdtemp(prefix="pneucore-bench-api-")
    db, log = os.path.join(tmp, "bench.sqlite3"), os.path.join(tmp, "uvicorn.log")
    server = Server(free_port(), db, log, args.http, args.loop)
    out["uvicorn"] = {"http": args.http, "loop": args.loop}
    try:
        limits = httpx.Limits(max_connections=args.clients + 4, max_keepalive_connections=args.clients + 4)
        with httpx.Client(timeout=120.0, limits=limits) as c:
            out["startup_s"] = server.wait_ready(c)
            t0 = time.perf_counter()
            first = c.post(server.url + "/api/simulate", content=raw, headers=hdr)
            out["first_request_s"] = time.perf_counter() - t0
            check(first, None)
            ref = first.content
            out["response_bytes"] = len(first.content)
            for _ in range(args.warmup):
                check(c.post(server.url + "/api/simulate", content=raw, headers=hdr), ref)

            lat = []
            for _ in range(args.requests):
                t0 = time.perf_counter()
                r = c.post(server.url + "/api/simulate", content=raw, headers=hdr)
                lat.append(time.perf_counter() - t0)
                check(r, ref)
            out["sequential"] = summary(lat)

        results, errors = [], []
        barrier = threading.Barrier(args.clients + 1)

        def client_loop():
            mine = []
            with httpx.Client(timeout=120.0) as cc:
                cc.get(server.url + "/api/limits")  # open the connection before the clock starts
                barrier.wait()
                for _ in range(args.per_client):
                    t0 = time.perf_counter()
                    r = cc.post(server.url + "/api/simulate", content=raw, headers=hdr)
                    mine.append(time.perf_counter() - t0)
                    try:
                        check(r, ref)
                    except Exception as exc:  # reported after the run
                        errors.append(str(exc))
            results.extend(mine)

        threads = [threading.Thread(target=client_loop) for _ in range(args.clients)]
        for t in threads:
            t.start()
        barrier.wait()
        t0 = time.perf_counter()
        for t in threads:
            t.join()
        wall = time.perf_counter() - t0
        if errors:
            raise RuntimeError(f"{len(errors)} concurrent requests failed, e.g. {errors[0]}")
        conc = summary(results)
        conc.update({"clients": args.clients, "per_client": args.per_client, "wall_s": wall,
                     "throughput_rps": len(results) / wall})
        out["concurrent"] = conc
    finally:
        server.stop()
    out["load"].append(_load())
    out["in_process_ms"] = in_process(body)
    seq, p = out["sequential"]["median_ms"], out["in_process_ms"]
    out["ratio_to_simulation"] = seq / p["simulate"]
    out["ratio_to_endpoint_work"] = seq / p["total"]
    out["pass"] = {"sequential_median": seq <= TARGET_MEDIAN_MS,
                   "ratio": out["ratio_to_simulation"] <= TARGET_RATIO,
                   "concurrent_p50": out["concurrent"]["median_ms"] <= TARGET_MEDIAN_MS}
    return out


def report(out):
    m = out["machine"]
    print("pneucore REST API benchmark: POST /api/simulate, "
          f"{out['case']['model']} + {out['case']['scenario']} (all default series)")
    print(f"machine: {m['cpu']}, {m['cores']} cores ({m['usable_cores']} usable), {m['platform']}")
    print(f"         python {m['python']}, numpy {m['numpy']}, numba {m['numba']}, "
          f"fastapi {m['fastapi']}, uvicorn {m['uvicorn']} (1 worker, http {out['uvicorn']['http']}, "
          f"loop {out['uvicorn']['loop']}), httpx {m['httpx']}")
    print(f"server ready in {out['startup_s']:.2f} s; first request {out['first_request_s'] * 1e3:.0f} ms; "
          f"response {out['response_bytes'] / 1e3:.0f} kB")
    s = out["sequential"]
    print(f"sequential  {s['n']:4d} requests: median {s['median_ms']:6.1f} ms  p95 {s['p95_ms']:6.1f} ms  "
          f"(min {s['min_ms']:.1f}, max {s['max_ms']:.1f})")
    c = out["concurrent"]
    print(f"concurrent  {c['clients']} clients x {c['per_client']}: median {c['median_ms']:6.1f} ms  "
          f"p95 {c['p95_ms']:6.1f} ms  (max {c['max_ms']:.1f}); "
          f"{c['throughput_rps']:.0f} requests/s over {c['wall_s']:.2f} s")
    p = out["in_process_ms"]
    print(f"in-process  (no HTTP) median {p['total']:.2f} ms = validate+parse {p['parse']:.2f} + "
          f"simulate {p['simulate']:.2f} + answer dict {p['to_dict']:.2f} + orjson {p['orjson']:.2f} ms")
    print(f"round trip / in-process: {out['ratio_to_simulation']:.2f}x simulate() alone, "
          f"{out['ratio_to_endpoint_work']:.2f}x the endpoint's whole work without HTTP")
    if "load" in out:
        print(f"load average (1 min) before / after: {out['load'][0]:.1f} / {out['load'][1]:.1f}")
    v = {k: "PASS" if ok else "FAIL" for k, ok in out["pass"].items()}
    print(f"targets: round trip <= {TARGET_RATIO:g}x the in-process simulation -> {v['ratio']} "
          f"({out['ratio_to_simulation']:.2f}x); concurrent p50 <= {TARGET_MEDIAN_MS:g} ms -> "
          f"{v['concurrent_p50']} ({c['median_ms']:.1f} ms); sequential median <= "
          f"{TARGET_MEDIAN_MS:g} ms -> {v['sequential_median']} ({s['median_ms']:.1f} ms)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="PATH", help="write the figures to this JSON file")
    ap.add_argument("--requests", type=int, default=200, help="sequential requests (200)")
    ap.add_argument("--clients", type=int, default=20, help="concurrent clients (20)")
    ap.add_argument("--per-client", type=int, default=10, help="requests per concurrent client (10)")
    ap.add_argument("--warmup", type=int, default=10, help="warm-up requests (10)")
    ap.add_argument("--http", default="auto", help="uvicorn's HTTP protocol: auto (httptools when "
                    "installed, as python -m app), httptools or h11")
    ap.add_argument("--loop", default="auto", help="uvicorn's event loop: auto, uvloop or asyncio")
    args = ap.parse_args(argv)
    out = run(args)
    report(out)
    save_figures(args.json, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
