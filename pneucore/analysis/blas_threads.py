"""One BLAS thread while a fit or a diagnosis runs: the parallelism is the simulations'.

A fit's linear algebra is on tall, narrow matrices (a few thousand residuals
by a dozen parameters: the SVD of the trust-region step, the QR of a
projection). OpenBLAS splits each such call over its own threads, which then
compete with the worker threads running the compiled simulator
(:data:`pneucore.analysis.calibrate.THREADS`) for the same cores: on the
2-core machine, under load, the SVD of a 5000 x 12 matrix takes 70 ms with
OpenBLAS threading and 2 ms without (``benchmarks/bench_diagnosis_threads.py``).
:func:`single_threaded_blas` sets every loaded OpenBLAS to one thread for
the duration of the call it decorates (reference-counted, so nested and
concurrent calls restore the setting once, when the last one ends), through
OpenBLAS's own ``*_set_num_threads`` entry points (what ``threadpoolctl``
does). Where no OpenBLAS is found it does nothing.
"""
from __future__ import annotations

import ctypes
import functools
import glob
import os
import threading

_PREFIXES = ("openblas", "scipy_openblas")
_SUFFIXES = ("", "64_")
_lock = threading.Lock()
_depth = 0
_saved = []


def _libraries():
    """``(set, get)`` ctypes functions of every OpenBLAS loaded in this process."""
    paths = set()
    try:
        with open("/proc/self/maps") as f:
            for line in f:
                p = line.split()[-1] if line.strip() else ""
                if p.startswith("/") and "openblas" in os.path.basename(p).lower():
                    paths.add(p)
    except OSError:
        pass
    if not paths:   # not Linux: the wheels' bundled libraries
        import numpy
        import scipy
        for mod in (numpy, scipy):
            d = os.path.dirname(os.path.dirname(mod.__file__))
            paths.update(glob.glob(os.path.join(d, f"{mod.__name__}.libs", "*openblas*")))
    out = []
    for p in sorted(paths):
        try:
            lib = ctypes.CDLL(p)
        except OSError:
            continue
        for pre in _PREFIXES:
            for suf in _SUFFIXES:
                s = getattr(lib, f"{pre}_set_num_threads{suf}", None)
                g = getattr(lib, f"{pre}_get_num_threads{suf}", None)
                if s is not None and g is not None:
                    g.restype = ctypes.c_int
                    out.append((s, g))
                    break
            else:
                continue
            break
    return out


_LIBS = None


def _enter():
    global _depth, _LIBS, _saved
    with _lock:
        if _depth == 0:
            if _LIBS is None:
                _LIBS = _libraries()
            _saved = []
            for s, g in _LIBS:
                _saved.append((s, int(g())))
                s(1)
        _depth += 1


def _exit():
    global _depth
    with _lock:
        _depth -= 1
        if _depth == 0:
            for s, n in _saved:
                s(n)


def single_threaded_blas(fn):
    """Decorator: ``fn`` runs with every loaded OpenBLAS at one thread."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        _enter()
        try:
            return fn(*args, **kwargs)
        finally:
            _exit()
    return wrapper


def blas_threads():
    """Current thread counts of the loaded OpenBLAS libraries (for tests and benchmarks)."""
    global _LIBS
    with _lock:
        if _LIBS is None:
            _LIBS = _libraries()
        return [int(g()) for _, g in _LIBS]
