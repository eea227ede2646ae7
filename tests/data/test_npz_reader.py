"""NumPy .npz files read as measurements (pneucore.data.fileformats): pneucore's own
simulation archives read back like its CSV export, a user's numpy.savez file with units in
its names, and hostile archives (pickles, ZIP bombs, too many members, damaged members,
workbooks) refused with a MeasurementError before anything unsafe is read."""
from __future__ import annotations

import io
import json
import pickle
import struct
import zipfile

import numpy as np
import pytest

from pneucore import model_preset, scenario_preset, simulate
from pneucore.data.fileformats import (NPZ_MAX_MEMBER_BYTES, NPZ_MAX_MEMBERS, detect_format,
                                       inspect_file, read_measurement)
from pneucore.data.measurement import MeasurementError
from pneucore.data.npz import simulation_npz


def _savez(**arrays):
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def test_a_simulation_archive_reads_back_like_the_csv_export():
    res = simulate(model_preset("paper-4way"), scenario_preset("paper-fig10-pulses"))
    data = simulation_npz(res)
    assert detect_format(data, "anything.bin") == "npz"   # by its bytes, not its name
    m = read_measurement(data, "sim.npz")
    rep = m.meta["import"]
    assert rep["format"] == "npz" and rep["pneucore_export"]
    for s in ("p_a", "p_b", "x", "v", "T_a", "T_b"):   # exact: float64 both ways
        assert np.array_equal(m.signals[s], res.series[s]), s
    assert np.array_equal(m.t, res.t) and np.array_equal(m.signals["u"], res.series["u"])
    # the simulated flows, rod force and supply pressure read back as the signals a flow meter,
    # a load cell and a gauge give (issue 29); the masses are no signal
    for s, series in (("q_a", "q_a"), ("q_s", "q_supply"), ("p_s", "p_supply"), ("F", "rod_force")):
        assert np.array_equal(m.signals[s], res.series[series]), s
    assert "m_a" in rep["ignored_columns"] and "mode" in rep["skipped_members"]


def test_a_user_archive_with_units_in_its_names():
    t = np.arange(30) * 5.0
    data = _savez(**{"Zeit[ms]": t, "Ventil[%]": np.where(t < 50, 0.0, 100.0),
                     "p_A[bar(g)]": np.linspace(0.0, 3.0, 30), "Weg[mm]": np.linspace(10, 40, 30)})
    m = read_measurement(data, "rig.npz", ambient_pressure=95_000.0)
    np.testing.assert_allclose(m.t, t / 1000)   # default rtol: float rounding of the scale
    np.testing.assert_allclose(m.signals["p_a"], np.linspace(0.0, 3.0, 30) * 1e5 + 95_000.0)
    np.testing.assert_allclose(m.signals["x"], np.linspace(10, 40, 30) / 1000)
    preview = inspect_file(data, "rig.npz")
    assert preview["format"] == "npz" and preview["mapping"]["p_A[bar(g)]"] == "p_a"


def test_an_object_array_is_never_unpickled(tmp_path):
    marker = tmp_path / "unpickled"

    class Payload:
        def __reduce__(self):
            return (open, (str(marker), "w"))
    obj = np.empty(1, dtype=object)
    obj[0] = Payload()
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("t.npy", _npy_bytes(np.arange(12.0)))
        z.writestr("u.npy", _npy_bytes(np.zeros(12)))
        z.writestr("p_a.npy", _npy_bytes(np.full(12, 2e5)))
        hdr = "{'descr': '|O', 'fortran_order': False, 'shape': (1,), }"
        hdr += " " * (-(10 + len(hdr) + 1) % 64) + "\n"
        z.writestr("evil.npy", b"\x93NUMPY\x01\x00" + struct.pack("<H", len(hdr)) + hdr.encode()
                   + pickle.dumps(obj, protocol=2))
    m = read_measurement(buf.getvalue(), "evil.npz")
    assert not marker.exists()
    assert m.meta["import"]["skipped_members"] == ["evil"]


def _npy_bytes(a):
    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


def test_a_zip_bomb_is_not_inflated():
    # one member of zeros that would inflate to 64 MB: skipped from its declared size, unread;
    # with no other column the file is refused
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("p_a.npy", _npy_bytes(np.zeros(8 * 1024 * 1024)))
    data = buf.getvalue()
    assert len(data) < 200_000 and zipfile.ZipFile(io.BytesIO(data)).infolist()[0].file_size > NPZ_MAX_MEMBER_BYTES
    with pytest.raises(MeasurementError, match="no numeric vector"):
        read_measurement(data, "bomb.npz")


def test_too_many_members_are_refused_before_reading():
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for i in range(NPZ_MAX_MEMBERS + 1):
            z.writestr(f"c{i}.npy", b"")
    with pytest.raises(MeasurementError, match="members"):
        read_measurement(buf.getvalue(), "many.npz")


def test_a_damaged_member_names_itself():
    data = bytearray(_savez(t=np.arange(100.0), u=np.zeros(100), p_a=np.full(100, 2e5)))
    i = data.index(b"p_a.npy") + len(b"p_a.npy") + 200   # a byte of p_a's data
    data[i] ^= 0xFF
    with pytest.raises(MeasurementError) as exc:
        read_measurement(bytes(data), "damaged.npz")
    assert exc.value.column == "p_a" and "damaged" in str(exc.value)


@pytest.mark.parametrize("data, words", [
    (b"PK\x03\x04" + b"\x00" * 40, "not a readable"),                       # a truncated archive
    (None, "without .npy members"),                                          # a workbook-like ZIP
])
def test_zips_that_are_not_npz_files(data, words):
    if data is None:
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w") as z:
            z.writestr("xl/workbook.xml", "<workbook/>")
        data = buf.getvalue()
    with pytest.raises(MeasurementError, match=words):
        read_measurement(data, "book.xlsx")


def test_a_meta_json_that_is_not_json_gives_no_units():
    buf = io.BytesIO(_savez(t=np.arange(12.0), u=np.zeros(12), p_a=np.full(12, 2e5)))
    with zipfile.ZipFile(buf, "a") as z:
        z.writestr("meta.json", b"{not json")
    m = read_measurement(buf.getvalue(), "x.npz")
    assert not m.meta["import"].get("pneucore_export")
    assert json.dumps(m.meta["import"])   # the report stays plain JSON


# ------------------------------------------------------------------ issue 30: a memory budget
_BOMB_CHILD = r"""
import io, resource, sys, zipfile
import numpy as np
from pneucore.data.fileformats import read_measurement
from pneucore.data.measurement import MeasurementError
members, mapped = int(sys.argv[1]), sys.argv[2] == "mapped"
buf = io.BytesIO()
z0 = io.BytesIO(); np.save(z0, np.zeros(2_000_000)); zeros = z0.getvalue()
with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as z:
    z.writestr("t.npy", zeros); z.writestr("u.npy", zeros)
    for i in range(members):
        z.writestr(f"c{i}.npy", zeros)
data = buf.getvalue()
del buf, z0
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
columns = {f"c{i}": None for i in range(members)} if mapped else None
try:
    read_measurement(data, "bomb.npz", columns=columns)
    outcome = "read"
except MeasurementError as exc:
    outcome = str(exc)[:60]
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print((after - before) * 1024, len(data), outcome)
"""


@pytest.mark.parametrize("mapped", ["unknown", "mapped"])
def test_an_npz_bomb_is_refused_with_a_bounded_peak(mapped):
    """250 members of 2,000,000 zeros (4 MB on the wire, 4 GB decoded): the names are checked
    before any array is read, so the peak memory of the read stays far below one member per
    name (measured in a child process: ru_maxrss is the process's own peak)."""
    import subprocess
    import sys
    out = subprocess.run([sys.executable, "-c", _BOMB_CHILD, "250", mapped], capture_output=True,
                         text=True, timeout=300, check=True).stdout.split(maxsplit=2)
    peak, size = int(out[0]), int(out[1])
    assert size < 5_000_000
    # the bound: t and u decoded (2 x 2,000,000 doubles, read and converted: 64 MB) and
    # slack for the allocator; without the name check this read took about 4 GB
    assert peak < 150e6, (peak, out[2])
    if mapped == "unknown":
        assert "unknown column" in out[2] or "c0" in out[2], out[2]


def test_the_decoded_size_is_summed_against_the_budget_before_reading():
    data = _savez(t=np.arange(100_000.0), u=np.zeros(100_000), p_a=np.full(100_000, 2e5))
    with pytest.raises(MeasurementError, match="memory budget of 1000000 bytes"):
        read_measurement(data, "x.npz", memory_budget=1_000_000)
    assert read_measurement(data, "x.npz", memory_budget=10_000_000).n == 100_000


def test_a_header_declaring_more_values_than_the_member_holds_is_damaged():
    hdr = "{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000,), }"
    hdr += " " * (-(10 + len(hdr) + 1) % 64) + "\n"
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("t.npy", _npy_bytes(np.arange(12.0)))
        z.writestr("u.npy", b"\x93NUMPY\x01\x00" + struct.pack("<H", len(hdr)) + hdr.encode()
                   + b"\x00" * 96)
    with pytest.raises(MeasurementError, match="damaged") as exc:
        read_measurement(buf.getvalue(), "lie.npz")
    assert exc.value.column == "u"
