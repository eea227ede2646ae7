"""Fits and diagnoses run with one OpenBLAS thread, and give the setting back."""
import threading

import numpy as np
import pytest
import scipy.linalg  # noqa: F401  (loads scipy's OpenBLAS too)

from pneucore.analysis.blas_threads import blas_threads, single_threaded_blas


def test_one_blas_thread_inside_and_the_setting_restored_after():
    before = blas_threads()
    if not before:
        pytest.skip("no OpenBLAS loaded (another BLAS: nothing to set)")
    seen = []

    @single_threaded_blas
    def inner():
        seen.append(blas_threads())
        return np.linalg.svd(np.ones((50, 3)), full_matrices=False)[1][0]

    @single_threaded_blas
    def outer():
        inner()                      # nested: still one thread, not restored yet
        seen.append(blas_threads())

    outer()
    assert all(all(n == 1 for n in s) for s in seen), seen
    assert blas_threads() == before


def test_concurrent_calls_restore_once_the_last_one_ends():
    before = blas_threads()
    gate = threading.Barrier(2)
    seen = []

    @single_threaded_blas
    def work():
        gate.wait(timeout=10)
        seen.append(blas_threads())
        gate.wait(timeout=10)       # both inside until both have looked

    ts = [threading.Thread(target=work) for _ in range(2)]
    for t in ts:
        t.start()
    for t in ts:
        t.join(timeout=20)
    assert len(seen) == 2 and all(all(n == 1 for n in s) for s in seen), seen
    assert blas_threads() == before


def test_a_failing_call_restores_the_setting():
    before = blas_threads()

    @single_threaded_blas
    def boom():
        raise RuntimeError("x")

    try:
        boom()
    except RuntimeError:
        pass
    assert blas_threads() == before


def test_the_fit_and_the_diagnosis_are_the_wrapped_entry_points():
    # a function inserted above ``fit`` once took its decorator, and the fit ran with every
    # BLAS thread again: each entry point must carry it itself
    import inspect

    from pneucore.analysis import calibrate, diagnose
    for fn in (calibrate.fit, diagnose.diagnose):
        assert inspect.unwrap(fn) is not fn, fn.__name__
        assert inspect.getsource(fn).lstrip().startswith("@single_threaded_blas"), fn.__name__
