"""MATLAB files read in a child process (pneucore.data.matfile): a file that crashes scipy's
compiled reader is a MeasurementError, and the reading is the same as in process."""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from pneucore.data.fileformats import read_measurement
from pneucore.data.matfile import mat_columns, mat_columns_isolated
from pneucore.data.measurement import MeasurementError

#: 1,960 bytes made by flipping bytes of a valid MATLAB 5 file (tests/fuzz of the uploads):
#: scipy 1.17.1's reader dies of it with a segmentation fault in scipy.io.matlab._mio5
CRASHER = Path(__file__).parent / "files" / "crashes-scipy-loadmat.mat"


def _mat(**variables):
    from scipy.io import savemat
    buf = io.BytesIO()
    savemat(buf, variables)
    return buf.getvalue()


def test_a_file_that_crashes_the_reader_is_an_error_not_the_end_of_the_process():
    data = CRASHER.read_bytes()   # its header is damaged too: the .mat name makes it MATLAB
    with pytest.raises(MeasurementError, match="MATLAB"):
        read_measurement(data, "upload.mat")   # isolated by default
    # this process is still here, and still reads good files
    good = _mat(t=np.arange(12) * 1e-3, u=np.ones(12), p_a=np.full(12, 2e5))
    assert read_measurement(good, "good.mat").measured_signals == ("p_a",)


def test_the_child_reads_what_this_process_reads():
    data = _mat(Zeit=np.arange(20) * 5.0, pA=np.linspace(0, 5, 20),
                rig={"Weg": np.linspace(10, 60, 20), "name": "bench 3"},
                units={"Zeit": "ms", "pA": "bar(g)", "Weg": "mm"})
    here, there = mat_columns(data), mat_columns_isolated(data)
    assert [lab for lab, _ in here[0]] == [lab for lab, _ in there[0]] == ["Zeit", "pA", "Weg"]
    for (_, a), (_, b) in zip(here[0], there[0]):
        assert a.dtype == b.dtype == np.float64 and np.array_equal(a, b)
    assert here[1] == there[1] == ["ms", "bar(g)", "mm"] and here[2] == there[2] == {}


def test_the_readers_own_errors_come_back_from_the_child():
    with pytest.raises(MeasurementError, match="no numeric vector"):
        mat_columns_isolated(_mat(name="no numbers here"))
    with pytest.raises(MeasurementError, match="v7.3"):
        mat_columns_isolated(b"MATLAB 7.3 MAT-file" + b"\0" * 200)


def test_a_child_that_takes_too_long_is_an_error():
    # a start-up of the interpreter takes far longer than 1 ms: the bound is what is tested
    with pytest.raises(MeasurementError, match="more than"):
        mat_columns_isolated(_mat(t=np.arange(3.0)), timeout=0.001)


def test_many_files_at_once_share_a_few_children(monkeypatch):
    # at most MAT_MAX_CHILDREN readers run at once; the others wait for a turn
    import threading
    import time

    import pneucore.data.matfile as mf
    running, peak, lock = [0], [0], threading.Lock()
    real_run = mf.subprocess.run

    def counting_run(*a, **k):
        with lock:
            running[0] += 1
            peak[0] = max(peak[0], running[0])
        try:
            time.sleep(0.05)
            return real_run(*a, **k)
        finally:
            with lock:
                running[0] -= 1
    monkeypatch.setattr(mf.subprocess, "run", counting_run)
    data = _mat(t=np.arange(12) * 1e-3, u=np.ones(12), p_a=np.full(12, 2e5))
    threads = [threading.Thread(target=mf.mat_columns_isolated, args=(data,)) for _ in range(3 * mf.MAT_MAX_CHILDREN)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert peak[0] == mf.MAT_MAX_CHILDREN
