"""numba's on-disk cache never outlives an edit of a core module (pneucore/core/cache.py).

numba keys a cached function on its own file only; without the guard, an edit
of ``flow.py`` alone would leave the compiled ``integrate`` (which links the
flow law) stale, and the edit would silently have no effect.
"""
import os
import shutil
import subprocess
import sys

import pneucore
from pneucore.core import cache as _cache

PKG = os.path.dirname(os.path.abspath(pneucore.__file__))

RUN = ("from pneucore import simulate, model_preset, scenario_preset;"
       "r = simulate(model_preset('paper-4way'), scenario_preset('paper-fig10-pulses'));"
       "print(repr(float(r.p_a[300])))")


def test_check_removes_cache_entries_only_when_a_source_changes(tmp_path):
    src, cache = tmp_path / "src", tmp_path / "cache"
    src.mkdir()
    cache.mkdir()
    (src / "flow.py").write_text("X = 1\n")
    (src / "rhs.py").write_text("Y = 2\n")
    entries = ["integrator.integrate-400.py311.nbi", "integrator.integrate-400.py311.1.nbc"]
    for name in entries + ["unrelated.txt"]:
        (cache / name).write_text("x")
    assert _cache.check(str(src), str(cache)) == 2          # no stamp yet: entries dropped
    for name in entries:
        (cache / name).write_text("x")
    assert _cache.check(str(src), str(cache)) == 0          # unchanged sources: kept
    assert all((cache / n).exists() for n in entries)
    (src / "flow.py").write_text("X = 3\n")                 # an edit of one module only
    assert _cache.check(str(src), str(cache)) == 2
    assert not any((cache / n).exists() for n in entries)
    assert (cache / "unrelated.txt").exists()


def test_edit_of_the_flow_law_alone_takes_effect(tmp_path):
    """End to end in fresh processes (two cold compiles, ~25 s): run, edit flow.py only
    (double the ISO 6358 flow), run again: the result must change."""
    work = tmp_path / "pkg"
    shutil.copytree(PKG, work / "pneucore", ignore=shutil.ignore_patterns("__pycache__"))
    env = dict(os.environ, PYTHONPATH=str(work), NUMBA_CACHE_DIR=str(tmp_path / "numba-cache"))

    def run():
        out = subprocess.run([sys.executable, "-c", RUN], env=env, cwd=str(tmp_path),
                             capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, out.stderr
        return float(out.stdout.strip().splitlines()[-1])

    before = run()
    flow = work / "pneucore" / "physics" / "flow.py"
    text = flow.read_text()
    old = "        return C * RHO_REF * p1 * math.sqrt(T_REF / T1) * _iso_phi_linearised("
    assert text.count(old) == 1
    flow.write_text(text.replace(old, "        return 2.0 * C * RHO_REF * p1 * math.sqrt(T_REF / T1)"
                                      " * _iso_phi_linearised("))
    after = run()
    # doubling the charging flow raises p_a at t = 0.3 s (mid-pulse) by far more than
    # any solver tolerance: 1 % is a lower bound on a change measured at ~34 %
    assert after > 1.01 * before
