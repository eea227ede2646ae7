"""Latency benchmark of the REST API's simulate endpoint over real HTTP.

Run from the repository root::

    python benchmarks/bench_api.py [--json PATH] [--requests N] [--clients C] [--per-client K]

Set-up: ``uvicorn app.main:app`` started in a subprocess as ``python -m app`` runs it
(one worker, the HTTP protocol :data:`app.http_protocol.PROTOCOL`: uvicorn's httptools
protocol writing each response in one system call; uvloop), on a free localhost port,
with ``PNEUCORE_DB`` pointing to a temporary SQLite file, without the access log. After
a warm-up (the first call may load or compile the numba core), ``POST /api/simulate``
with the ``paper-4way`` model and the ``paper-fig10-pulses`` scenario (1 s, 1 kHz, all
default series, about 0.24 MB of JSON) is measured with two clients:

* **httpx** (as a Python script would call the API; the client itself costs about
  0.3 ms of CPU a request on this answer, and under 20 threads in one process more
  than the server does) and
* **lean**: the standard library's ``http.client`` for the sequential requests and
  one asyncio event loop with one connection per client for the concurrent ones
  (about 0.1 ms a request: what a client on another machine, or a browser, adds to
  the server's own time):

* **sequential**: ``--requests`` (200) requests one after the other on one
  keep-alive connection: median, p95, min, max latency; with the lean client also
  with ``Accept: application/x-npz`` (the same answer as a NumPy archive, 0.17 MB);
* **concurrent**: ``--clients`` (20) clients, each on its own connection,
  sending ``--per-client`` (10) requests back to back: median and p95
  latency over all requests, and the throughput (lean: JSON and ``.npz``);
* the server's CPU time per request in each phase (from ``/proc``: less sensitive to
  the machine's load than the wall times);
* **HTTP alone**: the same requests, sequential, lean client, answered with the same
  bytes (JSON and ``.npz``) by a server that does no work (``benchmarks/http_alone.py``,
  under the same uvicorn set-up): the floor under the round trip. Added to the
  endpoint's work measured in process, it gives the least the round trip can be with
  that work (printed as a ratio to ``simulate()``), and what the round trip spends
  above it;
* for reference, the in-process cost of what the endpoint does (parse and
  validate, :func:`pneucore.simulate`, the result's ``to_dict``, orjson), stage by
  stage, without HTTP.

Every response is checked after its timing (status 200, same bytes as the first one).
Targets: sequential median <= 2x the in-process ``simulate()`` (the ratio is printed,
with the load average: both sides are measured in the same run); median <= 30 ms with
20 concurrent clients; both judged for each client.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
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
    """``uvicorn app.main:app`` in a subprocess on a temporary database, as ``python -m app``
    runs it (without the access log); ``target`` another ASGI app under the same set-up
    (:mod:`http_alone`), ``env`` more environment variables for it."""

    def __init__(self, port, db_path, log_path, http="app", loop="auto", target="app.main:app", env=None):
        if http == "app":
            from app.http_protocol import PROTOCOL as http
        env = dict(os.environ, PNEUCORE_DB=db_path, PYTHONUNBUFFERED="1", **(env or {}))
        env["PYTHONPATH"] = ROOT + os.pathsep + HERE + os.pathsep + env.get("PYTHONPATH", "")
        self.log = open(log_path, "w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "uvicorn", target, "--host", "127.0.0.1",
             "--port", str(port), "--workers", "1", "--log-level", "warning", "--no-access-log",
             "--http", http, "--loop", loop],
            cwd=ROOT, env=env, stdout=self.log, stderr=subprocess.STDOUT)
        self.port = port
        self.url = f"http://127.0.0.1:{port}"

    def cpu_s(self):
        """CPU time (user + system) the server process has used so far [s]."""
        with open(f"/proc/{self.proc.pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

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


class _Lean:
    """A response of the lean clients, with what :func:`check` reads."""

    def __init__(self, status, content):
        self.status_code, self.content = status, content

    @property
    def text(self):
        return self.content.decode("utf-8", "replace")


#: The ``Accept`` header of each answer form measured (JSON: the default, no header)
ACCEPT = {"json": None, "npz": "application/x-npz"}


def _request_bytes(raw, accept=None):
    """``POST /api/simulate`` with the JSON body ``raw``, as bytes on the wire."""
    extra = b"accept: %s\r\n" % accept.encode() if accept else b""
    return (b"POST /api/simulate HTTP/1.1\r\nhost: 127.0.0.1\r\ncontent-type: application/json\r\n"
            b"content-length: %d\r\n" % len(raw)) + extra + b"\r\n" + raw


def sequential_httpx(client, url, raw, hdr, n, ref):
    lat = []
    for _ in range(n):
        t0 = time.perf_counter()
        r = client.post(url + "/api/simulate", content=raw, headers=hdr)
        lat.append(time.perf_counter() - t0)
        check(r, ref)
    return lat


def sequential_lean(port, raw, n, ref, accept=None):
    """``n`` requests one after the other on one keep-alive ``http.client`` connection."""
    import http.client
    conn = http.client.HTTPConnection("127.0.0.1", port)
    hdr = {"host": "127.0.0.1", "content-type": "application/json"}
    if accept:
        hdr["accept"] = accept
    lat = []
    try:
        for i in range(n + 5):   # the first five open the connection and warm it
            t0 = time.perf_counter()
            conn.request("POST", "/api/simulate", body=raw, headers=hdr)
            r = conn.getresponse()
            body = r.read()
            if i >= 5:
                lat.append(time.perf_counter() - t0)
            check(_Lean(r.status, body), ref)
    finally:
        conn.close()
    return lat


def _one_lean(port, raw, accept):
    """One request with ``http.client``: the answer's bytes (the reference of a phase)."""
    import http.client
    conn = http.client.HTTPConnection("127.0.0.1", port)
    try:
        conn.request("POST", "/api/simulate", body=raw,
                     headers={"content-type": "application/json", **({"accept": accept} if accept else {})})
        r = conn.getresponse()
        body = r.read()
        check(_Lean(r.status, body), None)
        return body
    finally:
        conn.close()


def concurrent_httpx(url, raw, hdr, clients, per_client, ref):
    """``clients`` threads, each with its own httpx client and connection."""
    import httpx
    results, errors = [], []
    barrier = threading.Barrier(clients + 1)

    def client_loop():
        mine = []
        with httpx.Client(timeout=120.0) as cc:
            cc.get(url + "/api/limits")  # open the connection before the clock starts
            barrier.wait()
            for _ in range(per_client):
                t0 = time.perf_counter()
                r = cc.post(url + "/api/simulate", content=raw, headers=hdr)
                mine.append(time.perf_counter() - t0)
                try:
                    check(r, ref)
                except Exception as exc:  # reported after the run
                    errors.append(str(exc))
        results.extend(mine)

    threads = [threading.Thread(target=client_loop) for _ in range(clients)]
    for t in threads:
        t.start()
    barrier.wait()
    t0 = time.perf_counter()
    for t in threads:
        t.join()
    wall = time.perf_counter() - t0
    if errors:
        raise RuntimeError(f"{len(errors)} concurrent requests failed, e.g. {errors[0]}")
    return results, wall


def concurrent_lean(port, raw, clients, per_client, ref, accept=None):
    """``clients`` connections driven by one asyncio loop (HTTP/1.1 by hand: the request's
    bytes, then the status line, the headers and ``Content-Length`` bytes of body)."""
    import asyncio
    req = _request_bytes(raw, accept)

    async def one(reader, writer):
        writer.write(req)
        head = await reader.readuntil(b"\r\n\r\n")
        lines = head.decode("latin-1").split("\r\n")
        status = int(lines[0].split()[1])
        length = next(int(v) for k, _, v in (ln.partition(":") for ln in lines[1:])
                      if k.strip().lower() == "content-length")
        return _Lean(status, await reader.readexactly(length))

    async def main():
        conns = [await asyncio.open_connection("127.0.0.1", port, limit=1 << 20)
                 for _ in range(clients)]
        for reader, writer in conns:   # warm each connection before the clock starts
            check(await one(reader, writer), ref)
        lat = []

        async def client_loop(reader, writer):
            for _ in range(per_client):
                t0 = time.perf_counter()
                r = await one(reader, writer)
                lat.append(time.perf_counter() - t0)
                check(r, ref)
        t0 = time.perf_counter()
        await asyncio.gather(*(client_loop(r, w) for r, w in conns))
        wall = time.perf_counter() - t0
        for _, writer in conns:
            writer.close()
        return lat, wall
    return asyncio.run(main())


def _timed(out, args, server, phase, fn, *a):
    """``fn(*a)``'s latencies summarised in ``out[phase]``, with ``server``'s CPU time a request
    (and, for the concurrent phases, the clients, their wall time and the throughput)."""
    cpu0 = server.cpu_s()
    res = fn(*a)
    lat, wall = res if isinstance(res, tuple) else (res, None)
    out[phase] = summary(lat)
    out[phase]["server_cpu_ms"] = (server.cpu_s() - cpu0) / len(lat) * 1e3
    if wall is not None:
        out[phase].update({"clients": args.clients, "per_client": args.per_client,
                           "wall_s": wall, "throughput_rps": len(lat) / wall})


def http_alone(args, out, raw, ref, npz_ref, tmp):
    """The floor under the round trip: the same request answered with the API's own answer
    bytes (JSON, ``.npz``) by a server that does no work (:mod:`http_alone`), under the same
    uvicorn set-up, with the lean client, sequentially (``out["http_alone_lean"]`` and
    ``out["http_alone_lean_npz"]``)."""
    import httpx
    from http_alone import ENV_JSON, ENV_NPZ
    env = {}
    for var, data, name in ((ENV_JSON, ref, "answer.json"), (ENV_NPZ, npz_ref, "answer.npz")):
        env[var] = os.path.join(tmp, name)
        with open(env[var], "wb") as fh:
            fh.write(data)
    alone = Server(free_port(), os.path.join(tmp, "unused.sqlite3"), os.path.join(tmp, "alone.log"),
                   args.http, args.loop, target="http_alone:app", env=env)
    try:
        with httpx.Client(timeout=60.0) as c:
            alone.wait_ready(c)
        _timed(out, args, alone, "http_alone_lean", sequential_lean, alone.port, raw, args.requests, ref)
        _timed(out, args, alone, "http_alone_lean_npz", sequential_lean, alone.port, raw, args.requests,
               npz_ref, ACCEPT["npz"])
    finally:
        alone.stop()


def in_process(body, runs=50):
    """Median wall times in this process (no HTTP) of what the endpoint does, stage by stage:
    request validation (pydantic) and parsing, :func:`pneucore.simulate`, the answer's dict
    and its orjson rendering (``total``: the JSON answer's whole work), and the ``.npz``
    answer's writing in its place (``npz``; ``total_npz``: that answer's whole work);
    ``simulate`` alone is the in-process simulation the round trip is compared with, from
    built objects;
    ``simulate_from_dicts`` is :func:`pneucore.simulate` on the request's own model and
    scenario dicts (validation included, as ``bench_simulator.py`` measures it)."""
    from app.config import Limits
    from app.deps import parse_model, parse_scenario
    from app.responses import JSON
    from app.services import result_json, result_npz
    from app.schemas import SimulateRequest
    from pneucore import simulate
    limits = Limits()
    stages = {"parse": [], "simulate": [], "to_dict": [], "orjson": [], "total": [], "npz": [],
              "total_npz": [], "simulate_from_dicts": []}
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
        result_npz(res, req.series)
        t5 = time.perf_counter()
        simulate(body["model"], body["scenario"])   # as a Python user calls it on the same input
        t6 = time.perf_counter()
        if i >= 3:
            for k, v in zip(stages, (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t4 - t0, t5 - t4,
                                     t2 - t0 + t5 - t4, t6 - t5)):
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
    try:   # the API's server, then the floor's; the temporary files go in any case
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

                def timed(phase, fn, *a):
                    _timed(out, args, server, phase, fn, *a)
                timed("sequential", sequential_httpx, c, server.url, raw, hdr, args.requests, ref)
            timed("sequential_lean", sequential_lean, server.port, raw, args.requests, ref)
            npz_ref = _one_lean(server.port, raw, ACCEPT["npz"])
            out["response_bytes_npz"] = len(npz_ref)
            timed("sequential_lean_npz", sequential_lean, server.port, raw, args.requests, npz_ref,
                  ACCEPT["npz"])
            timed("concurrent", concurrent_httpx, server.url, raw, hdr, args.clients, args.per_client, ref)
            timed("concurrent_lean", concurrent_lean, server.port, raw, args.clients, args.per_client, ref)
            timed("concurrent_lean_npz", concurrent_lean, server.port, raw, args.clients, args.per_client,
                  npz_ref, ACCEPT["npz"])
        finally:
            server.stop()
        http_alone(args, out, raw, ref, npz_ref, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    out["load"].append(_load())
    out["in_process_ms"] = in_process(body)
    p = out["in_process_ms"]
    out["ratio_to_simulation"] = out["sequential"]["median_ms"] / p["simulate"]
    out["ratio_to_endpoint_work"] = out["sequential"]["median_ms"] / p["total"]
    out["lean_ratio_to_simulation"] = out["sequential_lean"]["median_ms"] / p["simulate"]
    out["lean_ratio_to_endpoint_work"] = out["sequential_lean"]["median_ms"] / p["total"]
    out["lean_npz_ratio_to_simulation"] = out["sequential_lean_npz"]["median_ms"] / p["simulate"]
    out["lean_ratio_to_simulation_from_dicts"] = out["sequential_lean"]["median_ms"] / p["simulate_from_dicts"]
    out["lean_npz_ratio_to_simulation_from_dicts"] = (out["sequential_lean_npz"]["median_ms"]
                                                      / p["simulate_from_dicts"])
    # the floor: HTTP and the endpoint's work measured in process, nothing else
    out["work_bound_ms"] = {"json": out["http_alone_lean"]["median_ms"] + p["total"],
                            "npz": out["http_alone_lean_npz"]["median_ms"] + p["total_npz"]}
    out["work_bound_ratio"] = {k: v / p["simulate"] for k, v in out["work_bound_ms"].items()}
    out["above_work_bound_ms"] = {"json": out["sequential_lean"]["median_ms"] - out["work_bound_ms"]["json"],
                                  "npz": out["sequential_lean_npz"]["median_ms"] - out["work_bound_ms"]["npz"]}
    out["pass"] = {
        "ratio": out["ratio_to_simulation"] <= TARGET_RATIO,
        "ratio_lean": out["lean_ratio_to_simulation"] <= TARGET_RATIO,
        "ratio_lean_npz": out["lean_npz_ratio_to_simulation"] <= TARGET_RATIO,
        "concurrent_p50": out["concurrent"]["median_ms"] <= TARGET_MEDIAN_MS,
        "concurrent_p50_lean": out["concurrent_lean"]["median_ms"] <= TARGET_MEDIAN_MS,
        "concurrent_p50_lean_npz": out["concurrent_lean_npz"]["median_ms"] <= TARGET_MEDIAN_MS,
        "sequential_median": out["sequential"]["median_ms"] <= TARGET_MEDIAN_MS}
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
          f"response {out['response_bytes'] / 1e3:.0f} kB (JSON), {out['response_bytes_npz'] / 1e3:.0f} kB (npz)")
    for key, what in (("sequential", "httpx"), ("sequential_lean", "lean "), ("sequential_lean_npz", "npz  ")):
        s = out[key]
        print(f"sequential {what} {s['n']:4d} requests: median {s['median_ms']:6.2f} ms  p95 "
              f"{s['p95_ms']:6.2f} ms  (min {s['min_ms']:.2f}, max {s['max_ms']:.1f}); server CPU "
              f"{s['server_cpu_ms']:.2f} ms/request")
    for key, what in (("concurrent", "httpx"), ("concurrent_lean", "lean "), ("concurrent_lean_npz", "npz  ")):
        c = out[key]
        print(f"concurrent {what} {c['clients']} clients x {c['per_client']}: median {c['median_ms']:6.1f} ms  "
              f"p95 {c['p95_ms']:6.1f} ms  (max {c['max_ms']:.1f}); {c['throughput_rps']:.0f} requests/s; "
              f"server CPU {c['server_cpu_ms']:.2f} ms/request")
    p = out["in_process_ms"]
    print(f"in-process  (no HTTP) median {p['total']:.2f} ms = validate+parse {p['parse']:.2f} + "
          f"simulate {p['simulate']:.2f} + answer dict {p['to_dict']:.2f} + orjson {p['orjson']:.2f} ms; "
          f"the .npz answer instead of dict + orjson {p['npz']:.2f} ms; simulate() from the request's dicts "
          f"(validation included) {p['simulate_from_dicts']:.2f} ms")
    print(f"round trip / in-process simulate(): httpx {out['ratio_to_simulation']:.2f}x, lean "
          f"{out['lean_ratio_to_simulation']:.2f}x, npz {out['lean_npz_ratio_to_simulation']:.2f}x; / the endpoint's whole work without HTTP: httpx "
          f"{out['ratio_to_endpoint_work']:.2f}x, lean {out['lean_ratio_to_endpoint_work']:.2f}x")
    print(f"round trip / simulate() from the request's dicts: lean {out['lean_ratio_to_simulation_from_dicts']:.2f}x, "
          f"npz {out['lean_npz_ratio_to_simulation_from_dicts']:.2f}x")
    a, w = out["work_bound_ms"], out["work_bound_ratio"]
    print(f"HTTP alone (the same answers from a server that does no work, lean client): JSON "
          f"{out['http_alone_lean']['median_ms']:.2f} ms, npz {out['http_alone_lean_npz']['median_ms']:.2f} ms; "
          f"+ the endpoint's work in process: JSON {a['json']:.2f} ms = {w['json']:.2f}x simulate(), npz "
          f"{a['npz']:.2f} ms = {w['npz']:.2f}x (the least the round trip can be with this work); the round "
          f"trip above that: JSON {out['above_work_bound_ms']['json']:+.2f} ms, npz "
          f"{out['above_work_bound_ms']['npz']:+.2f} ms")
    if "load" in out:
        print(f"load average (1 min) before / after: {out['load'][0]:.1f} / {out['load'][1]:.1f}")
    v = {k: "PASS" if ok else "FAIL" for k, ok in out["pass"].items()}
    print(f"targets: round trip <= {TARGET_RATIO:g}x the in-process simulation -> httpx {v['ratio']} "
          f"({out['ratio_to_simulation']:.2f}x), lean {v['ratio_lean']} ({out['lean_ratio_to_simulation']:.2f}x), "
          f"npz {v['ratio_lean_npz']} ({out['lean_npz_ratio_to_simulation']:.2f}x); "
          f"concurrent p50 <= {TARGET_MEDIAN_MS:g} ms -> httpx {v['concurrent_p50']} "
          f"({out['concurrent']['median_ms']:.1f} ms), lean {v['concurrent_p50_lean']} "
          f"({out['concurrent_lean']['median_ms']:.1f} ms), npz {v['concurrent_p50_lean_npz']} "
          f"({out['concurrent_lean_npz']['median_ms']:.1f} ms)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="PATH", help="write the figures to this JSON file")
    ap.add_argument("--requests", type=int, default=200, help="sequential requests (200)")
    ap.add_argument("--clients", type=int, default=20, help="concurrent clients (20)")
    ap.add_argument("--per-client", type=int, default=10, help="requests per concurrent client (10)")
    ap.add_argument("--warmup", type=int, default=10, help="warm-up requests (10)")
    ap.add_argument("--http", default="app", help="uvicorn's HTTP protocol: app (as python -m app: "
                    "app.http_protocol.PROTOCOL, default), auto (httptools when installed), "
                    "httptools or h11")
    ap.add_argument("--loop", default="auto", help="uvicorn's event loop: auto, uvloop or asyncio")
    args = ap.parse_args(argv)
    out = run(args)
    report(out)
    save_figures(args.json, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
