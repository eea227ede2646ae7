"""Cold-start benchmark: first simulation with an empty numba cache, and the first API answer.

Run from the repository root::

    python benchmarks/bench_cold_start.py [--repeat N] [--json PATH]
    python benchmarks/bench_cold_start.py --fresh-venv        # also: pip install into a new venv

Figures (each in a fresh subprocess, with the machine's load average printed next to it,
since on a shared machine the compile time scales with the load):

* **first simulation, empty cache**: ``import pneucore`` then the first
  :func:`pneucore.simulate` of ``paper-4way`` + ``paper-fig10-pulses`` with
  ``NUMBA_CACHE_DIR`` pointing at an empty temporary directory (compile + run),
  ``--repeat`` times, wall and CPU time (the CPU time depends less on the
  load: compare builds by it); then the same with the cache just written;
* **import app.main** (the web app, cache warm);
* **first API answer**: ``python -m app`` launched with an empty cache, then
  ``POST /api/simulate`` as soon as it answers ``/api/limits``: seconds from the
  launch to ready and to the first answer;
* with ``--fresh-venv`` (or ``--python PATH`` of an existing fresh install): the
  same first API answer from a non-editable ``pip install`` of this repository in
  a new virtual environment, with numba's default cache location
  (``site-packages/pneucore/__pycache__``), and whether the cache was written there.

Targets: first simulation <= 10 s with an empty cache; first API answer <= 15 s
after a fresh install.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
sys.path.insert(1, ROOT)      # the repository's pneucore, installed or not
from machine import machine_info, save_figures  # noqa: E402

MODEL, SCENARIO = "paper-4way", "paper-fig10-pulses"
TARGET_FIRST_SIM_S = 10.0
TARGET_FIRST_API_S = 15.0

_CHILD = r"""
import json, time
t0 = time.perf_counter()
import pneucore
from pneucore import simulate, model_preset, scenario_preset
t1 = time.perf_counter()
c1 = time.process_time()
res = simulate(model_preset({model!r}), scenario_preset({scenario!r}))
t2 = time.perf_counter()
c2 = time.process_time()
print(json.dumps({{"import_s": t1 - t0, "first_call_s": t2 - t1, "first_call_cpu_s": c2 - c1,
                  "steps": res.stats["steps"], "file": pneucore.__file__}}))
"""

_IMPORT_APP = r"""
import json, time
t0 = time.perf_counter()
import app.main
print(json.dumps({"import_app_s": time.perf_counter() - t0}))
"""


def load():
    """1-minute load average (the number of runnable processes, for 2 cores here)."""
    try:
        with open("/proc/loadavg") as f:
            return float(f.read().split()[0])
    except OSError:
        return float("nan")


def _env(cache=None, pythonpath=True):
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    env.pop("NUMBA_CACHE_DIR", None)
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = cache
    if pythonpath:
        env["PYTHONPATH"] = ROOT + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _child(code, env, python=sys.executable, cwd=ROOT):
    l0 = load()
    proc = subprocess.run([python, "-c", code], env=env, cwd=cwd, capture_output=True, text=True,
                          timeout=900)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-2000:])
    d = json.loads(proc.stdout.strip().splitlines()[-1])
    d["load"] = max(l0, load())
    return d


def first_simulation(repeat):
    """Cold (empty cache) then cached first simulate() in fresh processes."""
    out = {"cold": [], "cached": []}
    for _ in range(repeat):
        cache = tempfile.mkdtemp(prefix="pneucore-cold-")
        try:
            code = _CHILD.format(model=MODEL, scenario=SCENARIO)
            out["cold"].append(_child(code, _env(cache)))
            out["cached"].append(_child(code, _env(cache)))
        finally:
            shutil.rmtree(cache, ignore_errors=True)
    out["import_app"] = _child(_IMPORT_APP, _env())
    return out


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def first_api_answer(python=sys.executable, cache=None, pythonpath=True, cwd=ROOT):
    """Seconds from launching ``python -m app`` to ready and to the first simulate answer."""
    from pneucore import model_preset, scenario_preset
    body = json.dumps({"model": model_preset(MODEL), "scenario": scenario_preset(SCENARIO)}).encode()
    tmp = tempfile.mkdtemp(prefix="pneucore-cold-api-")
    port = _free_port()
    env = _env(cache, pythonpath)
    env.update(PNEUCORE_DB=os.path.join(tmp, "db.sqlite3"), PNEUCORE_PORT=str(port))
    log = open(os.path.join(tmp, "server.log"), "w")
    l0 = load()
    t0 = time.perf_counter()
    proc = subprocess.Popen([python, "-m", "app"], cwd=cwd, env=env, stdout=log,
                            stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}"
    try:
        ready = None
        while time.perf_counter() - t0 < 600:
            if proc.poll() is not None:
                raise RuntimeError(f"the service exited with code {proc.returncode}")
            try:
                with urllib.request.urlopen(url + "/api/limits", timeout=5) as r:
                    if r.status == 200:
                        ready = time.perf_counter() - t0
                        break
            except OSError:
                time.sleep(0.05)
        req = urllib.request.Request(url + "/api/simulate", data=body,
                                     headers={"content-type": "application/json"})
        with urllib.request.urlopen(req, timeout=600) as r:
            status, n = r.status, len(r.read())
        first = time.perf_counter() - t0
        if status != 200:
            raise RuntimeError(f"HTTP {status}")
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
        log.close()
        shutil.rmtree(tmp, ignore_errors=True)
    return {"ready_s": ready, "first_answer_s": first, "bytes": n, "load": max(l0, load())}


def fresh_venv(python=None):
    """pip install this repository (non-editable) into a new venv; first API answer from it."""
    tmp = None
    out = {}
    if python is None:
        tmp = tempfile.mkdtemp(prefix="pneucore-venv-")
        venv = os.path.join(tmp, "v")
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "venv", venv], check=True)
        python = os.path.join(venv, "bin", "python")
        subprocess.run([python, "-m", "pip", "install", "-q", ROOT], check=True,
                       stdout=subprocess.DEVNULL)
        out["install_s"] = time.perf_counter() - t0
    try:
        where = subprocess.run([python, "-c", "import os, pneucore; print(os.path.dirname(pneucore.__file__))"],
                               cwd=tempfile.gettempdir(), capture_output=True, text=True,
                               env=_env(None, pythonpath=False))
        pkg = where.stdout.strip().splitlines()[-1]
        out["package"] = pkg
        # from a neutral directory, without PYTHONPATH: the installed copy is imported
        out.update(first_api_answer(python, cache=None, pythonpath=False, cwd=tempfile.gettempdir()))
        cache_dir = os.path.join(pkg, "__pycache__")
        out["cache_files_in_site_packages"] = sum(
            1 for f in os.listdir(cache_dir) if f.endswith((".nbi", ".nbc"))) \
            if os.path.isdir(cache_dir) else 0
        out["second_start"] = first_api_answer(python, cache=None, pythonpath=False,
                                               cwd=tempfile.gettempdir())
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3, help="cold first simulations (3)")
    ap.add_argument("--fresh-venv", action="store_true",
                    help="also pip install the repository into a new venv and time its first answer")
    ap.add_argument("--python", help="interpreter of an existing fresh install (instead of --fresh-venv)")
    ap.add_argument("--json", metavar="PATH", help="write the figures to this JSON file")
    args = ap.parse_args(argv)

    info = machine_info()
    print(f"machine: {info['cpu']}, {info['cores']} cores ({info['usable_cores']} usable), "
          f"python {info['python']}, numpy {info['numpy']}, numba {info['numba']}")
    out = {"machine": info, "case": {"model": MODEL, "scenario": SCENARIO}}
    sims = first_simulation(args.repeat)
    out["first_simulation"] = sims
    cold = sorted(d["first_call_s"] for d in sims["cold"])
    for d in sims["cold"]:
        print(f"first simulation, empty cache: {d['first_call_s']:6.2f} s (import {d['import_s']:.2f} s; "
              f"CPU time {d['first_call_cpu_s']:.2f} s)   load {d['load']:.1f}")
    for d in sims["cached"]:
        print(f"first simulation, cached:      {d['first_call_s']:6.2f} s (import {d['import_s']:.2f} s)"
              f"   load {d['load']:.1f}")
    print(f"import app.main (cached):      {sims['import_app']['import_app_s']:6.2f} s"
          f"   load {sims['import_app']['load']:.1f}")
    api_cache = tempfile.mkdtemp(prefix="pneucore-cold-")
    try:
        api = first_api_answer(cache=api_cache)
    finally:
        shutil.rmtree(api_cache, ignore_errors=True)
    out["first_api_answer"] = api
    print(f"python -m app, empty cache: ready {api['ready_s']:.2f} s, first simulate answer "
          f"{api['first_answer_s']:.2f} s   load {api['load']:.1f}")
    if args.fresh_venv or args.python:
        fv = fresh_venv(args.python)
        out["fresh_install"] = fv
        if "install_s" in fv:
            print(f"fresh venv: pip install {fv['install_s']:.0f} s")
        print(f"fresh install ({fv['package']}): ready {fv['ready_s']:.2f} s, first simulate answer "
              f"{fv['first_answer_s']:.2f} s   load {fv['load']:.1f}; numba cache files written "
              f"next to the package: {fv['cache_files_in_site_packages']}; second start: first "
              f"answer {fv['second_start']['first_answer_s']:.2f} s")
    med = cold[len(cold) // 2]
    print(f"target: first simulation <= {TARGET_FIRST_SIM_S:g} s with an empty cache -> "
          f"{'PASS' if med <= TARGET_FIRST_SIM_S else 'FAIL'} (median {med:.2f} s)")
    if "fresh_install" in out:
        f = out["fresh_install"]["first_answer_s"]
        print(f"target: first API answer <= {TARGET_FIRST_API_S:g} s after a fresh install -> "
              f"{'PASS' if f <= TARGET_FIRST_API_S else 'FAIL'} ({f:.2f} s)")
    save_figures(args.json, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
