"""The package as a user installs it from an index: a wheel built from the source tree,
installed in a fresh virtual environment away from the checkout, starts the service and
answers a simulation (issue 40, item 1: a hand-kept package list had left
``pneucore.identify`` and ``pneucore.analysis.diagnosis`` out of the wheel, and the service
did not start from it).

One wheel is built for the module (a copy of the checkout's files, so the checkout gets no
``build/`` folder). The virtual environment sees the test environment's packages
(``--system-site-packages``: numpy, numba and FastAPI are not downloaded again) but its own
``pneucore``, and every check runs from a folder outside the checkout, so nothing can be
imported from the source tree by accident: each check asserts where the package came from.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
import urllib.request
import venv
import zipfile
from pathlib import Path

import pytest

from service import free_port

ROOT = Path(__file__).resolve().parent.parent
#: what never goes into the copy the wheel is built from (caches, builds, local databases)
IGNORE = shutil.ignore_patterns(".git", "__pycache__", "build", "dist", "*.egg-info", ".venv*",
                                "*.sqlite3*", ".pytest_cache", "node_modules", "site")


def _run(args, cwd, env=None, timeout=600):
    r = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, f"{' '.join(map(str, args))} failed:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r.stdout


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """``(python, wheel, workdir)``: the venv's interpreter with the wheel installed, the
    wheel's path and an empty working folder outside the checkout."""
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    shutil.copytree(ROOT, src, ignore=IGNORE)
    dist = tmp / "dist"
    # pip's own build isolation, as `pip install .` does it (the build backend pyproject names)
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(dist), str(src)], cwd=tmp)
    (wheel,) = dist.glob("pneucore-*.whl")
    env_dir = tmp / "venv"
    venv.EnvBuilder(system_site_packages=True, with_pip=False).create(env_dir)
    py = env_dir / ("Scripts/python.exe" if os.name == "nt" else "bin/python")
    # the test environment's pip installs into the venv (--prefix-free: --target would skip
    # the entry points); --no-deps: the venv already sees the dependencies
    _run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps", str(wheel)],
         cwd=tmp)
    work = tmp / "work"
    work.mkdir()
    return py, wheel, work


def _clean_env(**extra):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PNEUCORE_DASK_SCHEDULER")}
    env.update(extra)
    return env


def test_the_wheel_holds_every_package_and_data_file_of_the_tree(installed):
    """Every package folder of ``pneucore/`` and ``app/``, every file the installed package
    reads (sample datasets, the cylinder series) and every file of the page is in the wheel."""
    _, wheel, _ = installed
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = []
    for top in ("pneucore", "app"):
        for path in (ROOT / top).rglob("*"):
            if "__pycache__" in path.parts or path.is_dir() or path.suffix in (".pyc", ".nbi", ".nbc"):
                continue
            rel = path.relative_to(ROOT).as_posix()
            if rel not in names:
                missing.append(rel)
    for path in (ROOT / "static").iterdir():
        if path.is_file() and f"app/static/{path.name}" not in names:
            missing.append(f"static/{path.name}")
    assert not missing, f"files of the tree the wheel leaves out: {missing}"


def test_every_module_imports_from_the_installed_wheel(installed):
    py, _, work = installed
    code = (
        "import importlib, json, pkgutil, pneucore, app\n"
        "bad = {}\n"
        "for pkg in (pneucore, app):\n"
        "    for m in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + '.'):\n"
        "        if m.name.endswith('__main__'):\n"
        "            continue\n"
        "        try:\n"
        "            importlib.import_module(m.name)\n"
        "        except Exception as e:\n"
        "            bad[m.name] = repr(e)\n"
        "print(json.dumps({'file': pneucore.__file__, 'app': app.__file__, 'bad': bad}))\n")
    out = json.loads(_run([str(py), "-c", code], cwd=work, env=_clean_env()).strip().splitlines()[-1])
    venv_dir = str(py.parent.parent.resolve())
    assert out["file"].startswith(venv_dir) and out["app"].startswith(venv_dir), out
    assert not out["bad"], f"modules that fail to import from the wheel: {out['bad']}"


def test_the_service_started_from_the_wheel_serves_the_page_and_a_simulation(installed, tmp_path):
    py, _, work = installed
    port = free_port()
    script = py.parent / ("pneucore-serve.exe" if os.name == "nt" else "pneucore-serve")
    log = open(tmp_path / "server.log", "w+")
    proc = subprocess.Popen([str(script), "--port", str(port)], cwd=work, stdout=log,
                            stderr=subprocess.STDOUT, start_new_session=True,
                            env=_clean_env(PNEUCORE_DB=str(tmp_path / "w.sqlite3")))
    url = f"http://127.0.0.1:{port}"

    def get(path, timeout=10):
        with urllib.request.urlopen(url + path, timeout=timeout) as r:
            return r.status, r.read()
    try:
        deadline = time.time() + 120   # the start imports numba and FastAPI on a loaded machine
        while True:
            assert proc.poll() is None, f"the service exited: {log.seek(0) or log.read()}"
            try:
                if get("/api/presets")[0] == 200:
                    break
            except OSError:
                pass
            assert time.time() < deadline, f"no answer within 120 s: {log.seek(0) or log.read()}"
            time.sleep(0.3)
        status, page = get("/")
        assert status == 200 and b"<html" in page.lower()
        assert get("/static/app.js")[0] == 200
        # the sample datasets come from the wheel's data files
        datasets = json.loads(get("/api/datasets")[1])
        assert any("leak-and-lag" in d["id"] for d in datasets), datasets
        model = json.loads(get("/api/presets/paper-4way")[1])
        body = json.dumps({"model": model, "scenario": {
            "duration": 0.2, "sample_period": 0.001, "command": [[0.0, 0.0], [0.05, 1.0]],
            "locked": False, "x0": 0.0}}).encode()
        req = urllib.request.Request(url + "/api/simulate", data=body,
                                     headers={"content-type": "application/json"})
        # the wheel's core compiles at its first simulation (about a minute on 2 cores)
        with urllib.request.urlopen(req, timeout=600) as r:
            sim = json.loads(r.read())
        assert r.status == 200
        x = sim["series"]["x"]
        assert len(x) == 201 and max(x) > 0.005, "the piston did not move under a full opening"
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
        log.close()
