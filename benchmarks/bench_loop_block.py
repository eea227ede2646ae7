"""How long one large request blocks every other client (the event loop), and body-limit refusals.

While a ~19 MB CSV upload or a ~19 MB JSON comparison request is processed, a
second client polls ``GET /api/limits`` every 20 ms; the figure is the longest
wait of that poll (a loop blocked by parsing shows up as one long wait).
Then a 100 MB JSON body is sent: with the limit it is refused (413) as soon as
the limit is passed. Usage::

    python benchmarks/bench_loop_block.py               # this checkout, real uvicorn on 127.0.0.1
    python benchmarks/bench_loop_block.py --url http://127.0.0.1:18901   # another server
"""
from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from pathlib import Path

import httpx
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))


def big_csv(mb=19.0):
    head = "t[s],u[-],p_a[bar],p_b[bar],x[mm]\n"
    i = 0
    out = [head]
    size = len(head)
    while size < mb * 1e6:
        line = f"{i * 1e-4:.4f},{1 if (i // 5000) % 2 else 0},{3 + 1e-6 * i:.6f},{2 - 1e-7 * i:.7f},{(i % 1000) / 10:.1f}\n"
        out.append(line)
        size += len(line)
        i += 1
    return "".join(out)


def big_json(mb=19.0):
    from pneucore import model_preset
    n = int(mb * 1e6 / 60)
    t = (np.arange(n) * 1e-4).tolist()
    meas = {"t": t, "u": [0.0] * n, "p_a": (3e5 + np.arange(n) * 1e-3).tolist(),
            "p_b": (2e5 - np.arange(n) * 1e-3).tolist()}
    return json.dumps({"model": model_preset("paper-4way"),
                       "experiments": [{"measurement": meas, "scenario": {"locked": True, "x0": 0.1}}]})


def worst_wait(url, send):
    """Longest gap between answers of a 20 ms poll while ``send()`` runs [s], and send's status."""
    waits, stop = [], threading.Event()

    def poll():
        with httpx.Client(base_url=url, timeout=600) as c:
            while not stop.is_set():
                t0 = time.perf_counter()
                c.get("/api/limits")
                waits.append(time.perf_counter() - t0)
                time.sleep(0.02)
    th = threading.Thread(target=poll)
    th.start()
    time.sleep(0.3)
    t0 = time.perf_counter()
    status = send()
    took = time.perf_counter() - t0
    time.sleep(0.3)
    stop.set()
    th.join()
    return max(waits), took, status


def run(url):
    csv, js = big_csv(), big_json()
    print(f"CSV {len(csv) / 1e6:.1f} MB, JSON {len(js) / 1e6:.1f} MB")
    with httpx.Client(base_url=url, timeout=600) as c:
        c.get("/api/limits")
        w, took, st = worst_wait(url, lambda: c.post("/api/datasets", content=csv,
                                                      headers={"content-type": "text/csv"}).status_code)
        print(f"CSV upload: {st} in {took:.2f} s; longest wait of the other client {1e3 * w:.0f} ms")
        w, took, st = worst_wait(url, lambda: c.post("/api/compare", content=js,
                                                      headers={"content-type": "application/json"}).status_code)
        print(f"JSON compare: {st} in {took:.2f} s; longest wait of the other client {1e3 * w:.0f} ms")
        huge = js.encode() * 6
        w, took, st = worst_wait(url, lambda: c.post("/api/compare", content=huge,
                                                      headers={"content-type": "application/json"}).status_code)
        print(f"{len(huge) / 1e6:.0f} MB JSON: {st} in {took:.2f} s; longest wait of the other client "
              f"{1e3 * w:.0f} ms")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--url")
    a = p.parse_args()
    if a.url:
        run(a.url)
        return
    import tempfile

    from api_conftest import live_server
    with tempfile.TemporaryDirectory() as tmp, live_server(Path(tmp) / "b.sqlite3") as url:
        run(url)


if __name__ == "__main__":
    main()
