"""Start-up of the local study pool's worker processes: a warm forkserver and a parent watchdog.

Importing :mod:`pneucore.study._warm` imports pneucore's simulator and runs
one tiny simulation (:func:`warm`), so that numba has loaded the compiled
core from its on-disk cache (or compiled it, once, on a cold cache). The
local pool's ``multiprocessing`` context is a *forkserver* that preloads it:
the forkserver pays the imports and the cache load once, and every pool
worker is then a fork of that warm, single-threaded process (a few tens of
milliseconds instead of 1-2 s of imports and cache loading per worker; see
``benchmarks/bench_study.py --startup``). The forkserver lives as long as
the process that started it and exits when that process dies.

:func:`init_worker` (the pool's initializer) starts a watchdog thread that
ends the worker when the process that created the pool dies, even by
``kill -9``: it waits on a Linux pidfd of that process (``os.pidfd_open``),
or else polls whether it still exists; a pool worker never outlives its
server as an orphan.
"""
from __future__ import annotations

import multiprocessing
import os
import threading
import time

#: Polling interval of the watchdog where pidfds are unavailable [s]
WATCH_INTERVAL = 0.5


def warm():
    """Load the compiled core now (errors are left for the first real run to report)."""
    try:
        from pneucore.description.presets import model_preset, scenario_preset
        from pneucore.simulate import simulate
        from pneucore.study.metrics import run_metrics
        scenario = scenario_preset("paper-fig10-pulses")
        scenario["duration"] = 0.02
        run_metrics(simulate(model_preset("paper-4way"), scenario))
        # and the closed loop's core (closed-loop studies and tunings run on the same pool)
        from pneucore.control.closed_loop import simulate_closed_loop
        simulate_closed_loop(model_preset("paper-4way"), {
            "duration": 0.005, "x0": 0.1, "controller": {"kind": "onoff", "setpoint": [[0, 0.1]]}})
    except Exception:  # pragma: no cover - a broken install fails at the first run instead
        pass


def context():
    """The ``multiprocessing`` context of the local pool: a forkserver preloading this module.

    Falls back to ``spawn`` where forkserver is unavailable (not POSIX).
    """
    try:
        ctx = multiprocessing.get_context("forkserver")
    except ValueError:  # pragma: no cover - Windows
        return multiprocessing.get_context("spawn")
    ctx.set_forkserver_preload(_preload())
    _start_forkserver()
    return ctx


_START_LOCK = threading.Lock()


def _start_forkserver():
    """Start the forkserver now, seeing this process's ``sys.path`` (Python 3.11's forkserver
    ignores it, and would preload whatever pneucore its default path finds)."""
    import sys
    from multiprocessing import forkserver
    with _START_LOCK:
        old = os.environ.get("PYTHONPATH")
        paths = [p or os.getcwd() for p in sys.path if p == "" or os.path.isdir(p)]
        os.environ["PYTHONPATH"] = os.pathsep.join(paths)
        try:
            forkserver.ensure_running()
        finally:
            if old is None:
                os.environ.pop("PYTHONPATH", None)
            else:
                os.environ["PYTHONPATH"] = old


def _preload():
    """Modules the forkserver imports once: the caller's main module (which every worker
    re-imports, as with ``spawn``; preloaded, that costs nothing) and the warm core."""
    import sys
    main = sys.modules.get("__main__")
    name = getattr(getattr(main, "__spec__", None), "name", None)
    out = []
    if name:                                   # python -m pkg: workers re-run pkg/__main__.py
        out.append(name)
    elif os.path.isfile(getattr(main, "__file__", None) or ""):
        out.append("__main__")                 # python script.py: imported once, by path
    return out + ["pneucore.study._warm"]


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # pragma: no cover - exists, another user's (a reused pid)
        return False
    return True


def _watch(pid):
    """Block until process ``pid`` ends, then end this process at once."""
    try:
        import select
        fd = os.pidfd_open(pid)
    except (AttributeError, OSError):
        fd = None
    if fd is not None:
        p = select.poll()
        p.register(fd, select.POLLIN)
        while not p.poll(None):
            pass
    else:  # pragma: no cover - kernels before 5.3
        while _alive(pid):
            time.sleep(WATCH_INTERVAL)
    os._exit(0)


def init_worker(server_pid):
    """Pool initializer: exit when process ``server_pid`` (the pool's creator) dies.

    Parameters
    ----------
    server_pid : int
        Process id of the process that created the pool [-]
    """
    if not _alive(server_pid):
        os._exit(0)
    threading.Thread(target=_watch, args=(server_pid,), daemon=True,
                     name="pneucore-parent-watchdog").start()
    from pneucore import simulate  # noqa: F401  (already imported when forked from the warm forkserver

