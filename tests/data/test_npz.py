"""pneucore.data.npz: the .npz archives of simulation answers, read back by numpy.load
(without pickle) and by zipfile, against numpy's own writer (numpy.savez)."""
from __future__ import annotations

import io
import json
import zipfile

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis.extra import numpy as hnp

from pneucore import Model, Scenario, model_preset, scenario_preset, simulate
from pneucore.data.npz import npz_bytes, simulation_npz

ARRAYS = {
    "f8": np.linspace(0.0, 1.0, 7),
    "f4": np.arange(5, dtype=np.float32) / 3,
    "i4_big_endian": np.arange(4, dtype=">i4"),
    "u1": np.array([0, 255], dtype=np.uint8),
    "bool": np.array([True, False, True]),
    "c16": np.array([1 + 2j, -3.5j]),
    "text": np.array(["stick", "slip", "é"]),
    "bytes": np.array([b"ab", b"c"]),
    "scalar": np.array(101325.0),
    "matrix": np.arange(6.0).reshape(2, 3),
    "fortran": np.asfortranarray(np.arange(6.0).reshape(2, 3)),
    "strided": np.arange(10.0)[::3],
    "empty": np.array([], dtype=float),
    "special": np.array([np.nan, np.inf, -np.inf, -0.0, 5e-324]),
}


def _load(data):
    return np.load(io.BytesIO(data))   # allow_pickle=False: numpy's default


def test_numpy_reads_back_every_array_as_numpy_savez_writes_it():
    data = npz_bytes(ARRAYS)
    ours, ref = _load(data), _load(_savez(ARRAYS))
    assert sorted(ours.files) == sorted(ref.files) == sorted(ARRAYS)
    for name, arr in ARRAYS.items():
        got = ours[name]
        assert got.dtype == ref[name].dtype == arr.dtype, name
        assert got.shape == arr.shape, name
        assert np.array_equal(got, arr, equal_nan=arr.dtype.kind in "fc"), name
        assert got.tobytes() == ref[name].tobytes(), name   # bit for bit (-0.0, NaN payloads)


def _savez(arrays):
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def test_the_archive_is_a_valid_zip_with_checked_crcs():
    data = npz_bytes(ARRAYS, {"meta.json": b'{"a": 1}'})
    with zipfile.ZipFile(io.BytesIO(data)) as z:
        assert z.testzip() is None   # every member's CRC-32 checks
        assert sorted(z.namelist()) == sorted([n + ".npy" for n in ARRAYS] + ["meta.json"])
        assert all(i.compress_type == zipfile.ZIP_STORED for i in z.infolist())
        assert z.read("meta.json") == b'{"a": 1}'
    assert _load(data)["meta.json"] == b'{"a": 1}'   # a member that is not an array: its bytes


def test_a_corrupted_archive_is_detected():
    data = bytearray(npz_bytes({"x": np.arange(100.0)}))
    data[200] ^= 0xFF   # a byte of the array's data
    with pytest.raises(zipfile.BadZipFile):
        _load(bytes(data))["x"]


def test_the_same_arrays_give_the_same_bytes():
    assert npz_bytes(ARRAYS) == npz_bytes(dict(ARRAYS))


@pytest.mark.parametrize("arr", [np.array([{"a": 1}], dtype=object),
                                 np.zeros(2, dtype=[("a", "f8"), ("b", "i4")])],
                         ids=["object", "structured"])
def test_arrays_that_would_need_pickle_are_refused(arr):
    with pytest.raises(TypeError, match="npz"):
        npz_bytes({"x": arr})


@pytest.mark.parametrize("name", ["", "../x", "a/b", "a\\b", "/abs", "a b", "..", "x" * 101, "é"])
def test_member_names_are_plain_file_names(name):
    with pytest.raises(ValueError, match="member name"):
        npz_bytes({name: np.zeros(1)})


def test_a_member_given_twice_is_refused():
    with pytest.raises(ValueError, match="twice"):
        npz_bytes({"a": np.zeros(1)}, {"a.npy": b""})


@settings(max_examples=60, deadline=None)   # deadline: the first example imports hypothesis' numpy
@given(hnp.arrays(dtype=hnp.scalar_dtypes().filter(lambda d: d.kind in "biufcUS"),
                  shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=5)))
def test_any_plain_array_reads_back_bit_for_bit(arr):
    got = _load(npz_bytes({"a": arr}))["a"]
    assert got.dtype == arr.dtype and got.shape == arr.shape
    assert got.tobytes() == np.ascontiguousarray(arr).tobytes()


def test_a_simulation_reads_back_with_its_metadata():
    res = simulate(Model.from_dict(model_preset("paper-4way")),
                   Scenario.from_dict(scenario_preset("paper-fig10-pulses")))
    z = _load(simulation_npz(res))
    assert sorted(z.files) == sorted(list(res.series) + ["meta.json"])
    for name, values in res.series.items():
        if values.dtype.kind == "f":
            assert z[name].tobytes() == np.ascontiguousarray(values).tobytes(), name
        else:
            assert z[name].tolist() == values.tolist(), name
    meta = json.loads(z["meta.json"])
    assert meta == json.loads(json.dumps(res.summary()))
    assert meta["units"]["p_a"] == "Pa" and meta["stats"]["steps"] == res.stats["steps"]
