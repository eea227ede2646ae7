"""Peak memory of one request against its body's size, per request kind (issue 30).

Each figure comes from a fresh child process that builds the app on a temporary database,
answers one small request of the same kind first (modules imported, caches filled), then
builds the body and records its peak resident memory (``ru_maxrss``) before and after the
measured request: the growth is what that request cost the server. A MATLAB file is read in
a grandchild process (:func:`pneucore.data.matfile.mat_columns_isolated`): its peak is
reported apart (``child_peak_mb``).

Kinds: a JSON dataset (``POST /api/datasets`` with ``{"measurement": {...}}``), a CSV
upload, a NumPy ``.npz``, a MATLAB ``.mat`` (v5, compressed), a TDMS file, each with the
time and four signals at ``--rows`` samples; and hostile bodies under the body limit that
must be refused before they are decoded (``--hostile``): a CSV of millions of short rows, a
JSON list of millions of zeros, an ``.npz`` of many 2,000,000-value members, a compressed
``.mat`` variable of 200 MB of zeros.

Usage: ``python benchmarks/bench_request_memory.py [--rows 20000,200000] [--hostile]
[--json out.json]``.
"""
from __future__ import annotations

import argparse
import io
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path[:0] = [ROOT, HERE]

KINDS = ("json", "csv", "npz", "mat", "tdms")
HOSTILE = ("csv-short-rows", "json-zeros", "npz-members", "mat-zeros")


def _columns(rows):
    import numpy as np
    t = np.arange(rows) * 1e-4
    return {"t": t, "u": (np.sin(40 * t) > 0).astype(float), "p_a": 3e5 + 1e5 * np.sin(7 * t),
            "p_b": 2e5 + 1e5 * np.cos(7 * t), "x": 0.05 + 0.04 * np.sin(3 * t)}


def _body(kind, rows):
    """``(files or None, json or None, content bytes)`` of one request of ``kind``."""
    import numpy as np
    if kind == "json":
        cols = {k: v.tolist() for k, v in _columns(rows).items()}
        return None, {"name": "m", "measurement": cols}
    if kind == "csv":
        cols = _columns(rows)
        buf = io.StringIO()
        np.savetxt(buf, np.column_stack(list(cols.values())), delimiter=",", fmt="%.9g",
                   header=",".join(cols), comments="")
        return ("m.csv", buf.getvalue().encode(), "text/csv"), None
    if kind == "npz":
        buf = io.BytesIO()
        np.savez(buf, **_columns(rows))
        return ("m.npz", buf.getvalue(), "application/x-npz"), None
    if kind == "mat":
        import scipy.io
        buf = io.BytesIO()
        scipy.io.savemat(buf, {k: v.reshape(-1, 1) for k, v in _columns(rows).items()},
                         do_compression=True)
        return ("m.mat", buf.getvalue(), "application/octet-stream"), None
    if kind == "tdms":
        from nptdms import ChannelObject, TdmsWriter
        buf = io.BytesIO()
        with TdmsWriter(buf) as w:
            w.write_segment([ChannelObject("g", k, v) for k, v in _columns(rows).items()])
        return ("m.tdms", buf.getvalue(), "application/octet-stream"), None
    # hostile bodies, each under the 20 MB body limit
    if kind == "csv-short-rows":
        return ("h.csv", b"t,u\n" + b"0,0\n" * (19 * 2**20 // 4), "text/csv"), None
    if kind == "json-zeros":
        return None, {"measurement": {"t": [0] * (9 * 2**20), "u": [0]}}
    if kind == "npz-members":
        buf = io.BytesIO()
        np.savez_compressed(buf, **{f"c{i}": np.zeros(2_000_000) for i in range(60)})
        return ("h.npz", buf.getvalue(), "application/x-npz"), None
    if kind == "mat-zeros":
        import scipy.io
        buf = io.BytesIO()
        scipy.io.savemat(buf, {"t": np.zeros((200 * 2**20, 1), dtype=np.uint8)}, do_compression=True)
        return ("h.mat", buf.getvalue(), "application/octet-stream"), None
    raise ValueError(kind)


def _maxrss_mb(who=resource.RUSAGE_SELF):
    return resource.getrusage(who).ru_maxrss / 1024   # Linux: kB


def child(kind, rows):
    """One measured request in this (fresh) process; prints its figures as JSON."""
    import gc

    import orjson
    from fastapi.testclient import TestClient

    from app.config import Limits, Settings
    from app.main import create_app
    with tempfile.TemporaryDirectory() as tmp:
        app = create_app(Settings(db_path=os.path.join(tmp, "m.sqlite3"), seed_samples=False,
                                  resume_studies=False, limits=Limits()))
        with TestClient(app, base_url="http://127.0.0.1") as c:
            def send(files, body):
                if files is not None:
                    return c.post("/api/datasets", files={"file": files})
                # the JSON text sent as it is (httpx would encode it once more)
                return c.post("/api/datasets", content=orjson.dumps(body),
                              headers={"content-type": "application/json"})
            warm_kind = kind if kind in KINDS else {"csv-short-rows": "csv", "json-zeros": "json",
                                                    "npz-members": "npz", "mat-zeros": "mat"}[kind]
            r = send(*_body(warm_kind, 200))
            assert r.status_code == 201, r.text[:300]
            files, body = _body(kind, rows)
            size = len(files[1]) if files is not None else len(orjson.dumps(body))
            gc.collect()
            before = _maxrss_mb()
            t0 = time.perf_counter()
            r = send(files, body)
            seconds = time.perf_counter() - t0
            after = _maxrss_mb()
    detail = r.json().get("detail") if r.status_code >= 400 else None
    print(json.dumps({"kind": kind, "rows": rows, "status": r.status_code, "body_mb": size / 2**20,
                      "before_mb": before, "peak_mb": after, "growth_mb": after - before,
                      "child_peak_mb": _maxrss_mb(resource.RUSAGE_CHILDREN),
                      "seconds": seconds, "detail": str(detail)[:160] if detail else None}))


def measure(kind, rows):
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", kind, str(rows)],
                         capture_output=True, text=True, env=env, cwd=ROOT, timeout=900)
    if out.returncode != 0:
        raise RuntimeError(f"{kind} {rows}: {out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rows", default="20000,100000,200000",
                   help="samples of the measured files, comma-separated")
    p.add_argument("--kinds", default=",".join(KINDS))
    p.add_argument("--hostile", action="store_true", help="also the hostile bodies")
    p.add_argument("--json", default=None, help="write the figures to this file")
    p.add_argument("--child", nargs=2, metavar=("KIND", "ROWS"), help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child:
        return child(a.child[0], int(a.child[1]))
    from machine import machine_info, save_figures
    from app.config import Limits
    info = machine_info("fastapi", "scipy", "nptdms")
    print(f"machine: {info}")
    print(f"max_request_memory = {Limits().max_request_memory / 2**20:.0f} MB, "
          f"max_upload_bytes = {Limits().max_upload_bytes / 2**20:.0f} MB")
    runs = [(k, int(r)) for k in a.kinds.split(",") for r in a.rows.split(",")]
    if a.hostile:
        runs += [(k, 0) for k in HOSTILE]
    results = []
    print(f"{'kind':16s} {'rows':>8s} {'body MB':>8s} {'status':>6s} {'growth MB':>10s} "
          f"{'peak MB':>8s} {'child MB':>9s} {'s':>6s}")
    for kind, rows in runs:
        f = measure(kind, rows)
        results.append(f)
        print(f"{kind:16s} {rows:8d} {f['body_mb']:8.1f} {f['status']:6d} {f['growth_mb']:10.1f} "
              f"{f['peak_mb']:8.1f} {f['child_peak_mb']:9.1f} {f['seconds']:6.2f}"
              + (f"  {f['detail']}" if f["detail"] else ""))
    save_figures(a.json, {"machine": info, "runs": results})


if __name__ == "__main__":
    main()
