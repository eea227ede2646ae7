"""The load cell, flow meters and supply gauge of a rig (issue 29): ``F`` [N], ``q_a``, ``q_b``,
``q_s`` [kg/s] and ``p_s`` [Pa abs], read from every file format in the units rigs log them.

Flows given as volume at the ISO 8778 reference atmosphere (ANR, "normal" litres) become mass
flows through the one reference density ``RHO_REF`` = 1.185 kg/m^3 of pneucore.physics.gas.
"""
from __future__ import annotations

import io

import numpy as np
import pytest

from pneucore.data.fileformats import inspect_file, read_measurement
from pneucore.data.measurement import MeasurementError, read_csv
from pneucore.physics.gas import RHO_REF

N = 12
AMBIENT = 101300.0

# Hand conversions, one per unit (RHO_REF = 1.185 kg/m^3):
#   100 L/min ANR = 0.1 m^3 / 60 s = 1.6667e-3 m^3/s ANR; * 1.185 kg/m^3 = 1.975e-3 kg/s
#   -60 NL/min    = -1e-3 m^3/s;                           * 1.185        = -1.185e-3 kg/s
#   3.6 m^3/h ANR = 3.6 / 3600 = 1e-3 m^3/s;               * 1.185        = 1.185e-3 kg/s
#   0.25 kN = 250 N;  5 bar(g) at 1.013 bar ambient = 6.013e5 Pa abs
HAND = {"F": 250.0, "q_a": 1.975e-3, "q_b": -1.185e-3, "q_s": 1.185e-3, "p_s": 601300.0}
RAW = {"F": 0.25, "q_a": 100.0, "q_b": -60.0, "q_s": 3.6, "p_s": 5.0}
UNIT = {"F": "kN", "q_a": "L/min ANR", "q_b": "NL/min", "q_s": "m³/h ANR", "p_s": "bar(g)"}
#: Relative tolerance of a converted value against the hand conversion: one rounding of a
#: product and a quotient in float64 (a few 1e-16); 1e-12 leaves margin and fails on any wrong
#: factor (the smallest plausible mistake, 20 vs 0 degC ANR, is 7 %)
REL = 1e-12


def _check(m):
    for sig, want in HAND.items():
        assert m.signals[sig] == pytest.approx(np.full(N, want), rel=REL), sig
    assert set(HAND) <= set(m.measured_signals)


def test_the_hand_conversions_are_the_reference_density():
    assert RHO_REF == 1.185   # the density the conversions above were worked with
    assert HAND["q_a"] == pytest.approx(0.1 / 60 * RHO_REF, rel=REL)


def test_csv_with_units_in_brackets():
    head = "t[s],u[-]," + ",".join(f"{s}[{UNIT[s]}]" for s in HAND)
    rows = "".join(f"{0.01 * i:.2f},0," + ",".join(str(RAW[s]) for s in HAND) + "\n" for i in range(N))
    _check(read_csv(head + "\n" + rows))


@pytest.mark.parametrize("header, raw, want", [
    ("F[N]", 12.5, 12.5), ("F[daN]", 3.0, 30.0), ("F[lbf]", 1.0, 4.4482216152605),
    ("q_a[kg/s]", 0.002, 0.002), ("q_a[g/s]", 2.0, 0.002),
    ("q_a[l/min ANR]", 60.0, 1e-3 * RHO_REF),            # 60 L/min = 1 L/s = 1e-3 m^3/s
    ("q_b[Nl/min]", 60.0, 1e-3 * RHO_REF),
    ("q_s[m3/h ANR]", 36.0, 1e-2 * RHO_REF),              # 36 m^3/h = 0.01 m^3/s
    ("p_s[bar]", 7.0, 7e5), ("p_s[MPa]", 0.6, 6e5), ("p_s[psig]", 0.0, AMBIENT),
])
def test_each_unit(header, raw, want):
    text = f"t[s],{header}\n" + "".join(f"{0.01 * i:.2f},{raw}\n" for i in range(N))
    m = read_csv(text)
    (sig,) = m.measured_signals
    assert m.signals[sig] == pytest.approx(np.full(N, want), rel=REL)


def test_a_rig_header_mapped_with_sensor_objects():
    """No header names a signal: a load cell in volts at 50 N/V with a zero offset, a flow meter
    in L/min ANR and a supply gauge in bar(g), mapped as sensor objects."""
    text = "Zeit;Kanal 1;Kanal 2;Kanal 3;Kanal 4\n" + "".join(
        f"{10 * i};0;2.0;100;5\n" for i in range(N))
    cols = {"Zeit": "t[ms]", "Kanal 1": "u", "Kanal 2": {"signal": "F", "unit": "N", "gain": 50.0,
                                                           "offset": -4.0, "raw_unit": "V"},
            "Kanal 3": {"signal": "q_s", "unit": "L/min ANR"},
            "Kanal 4": {"signal": "p_s", "unit": "bar", "reference": "gauge"}}
    m = read_measurement(text.encode(), "rig.csv", columns=cols)
    assert m.signals["F"] == pytest.approx(np.full(N, 96.0), rel=REL)       # 50 N/V * 2 V - 4 N
    assert m.signals["q_s"] == pytest.approx(np.full(N, HAND["q_a"]), rel=REL)   # 100 L/min ANR
    assert m.signals["p_s"] == pytest.approx(np.full(N, HAND["p_s"]), rel=REL)


def test_mat_npz_and_tdms_files():
    from scipy.io import savemat
    t = np.arange(N) * 0.01
    cols = {s: np.full(N, RAW[s]) for s in HAND}
    buf = io.BytesIO()
    savemat(buf, {"t": t, **cols, "units": {s: UNIT[s].replace("³", "3") for s in HAND}})
    _check(read_measurement(buf.getvalue(), "rig.mat"))

    buf = io.BytesIO()
    np.savez(buf, **{"t[s]": t}, **{f"{s}[{UNIT[s]}]": cols[s] for s in HAND})
    _check(read_measurement(buf.getvalue(), "rig.npz"))

    from nptdms import ChannelObject, TdmsWriter
    buf = io.BytesIO()
    with TdmsWriter(buf) as w:
        w.write_segment([ChannelObject("rig", s, cols[s], properties={
            "unit_string": UNIT[s], "wf_increment": 0.01, "wf_start_offset": 0.0}) for s in HAND])
    _check(read_measurement(buf.getvalue(), "rig.tdms"))


def test_the_preview_offers_the_new_signals_with_their_units():
    text = "time,force,flow_a,supply_pressure\n" + "".join(f"{i},1,1,6\n" for i in range(N))
    pv = inspect_file(text.encode(), "rig.csv")
    assert pv["mapping"] == {"time": "t", "force": "F", "flow_a": "q_a", "supply_pressure": "p_s"}
    for sig, unit in (("F", "N"), ("q_a", "kg/s"), ("q_b", "kg/s"), ("q_s", "kg/s"), ("p_s", "Pa")):
        assert pv["signals"][sig]["unit"] == unit
    assert "L/min ANR" in pv["signals"]["q_s"]["accepted_units"]


@pytest.mark.parametrize("header, raw, words", [
    ("q_a[L/h]", 1.0, "unknown unit"),                 # not a unit accepted for a flow
    ("F[bar]", 1.0, "unknown unit"),                   # a pressure unit on a force
    ("p_s[bar]", -1.0, "not positive"),                # an absolute supply pressure below 0
])
def test_bad_units_and_values_name_the_column(header, raw, words):
    text = f"t[s],{header}\n" + "".join(f"{0.01 * i:.2f},{raw}\n" for i in range(N))
    with pytest.raises(MeasurementError) as exc:
        read_csv(text)
    assert exc.value.column == header and words in str(exc.value)
