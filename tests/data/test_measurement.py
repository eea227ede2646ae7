"""Tests for pneucore.data.measurement."""

import io
import json
import math
import pickle
import re

import numpy as np
import pytest

import pneucore.data.measurement as meas
from pneucore.data.measurement import (
    MAX_SAMPLES,
    MIN_SAMPLES,
    SIGNAL_UNITS,
    SIGNALS,
    Measurement,
    MeasurementError,
    parse_header,
    read_csv,
)


# ----------------------------------------------------------------- helpers

def make_csv(columns, n=12, delimiter=",", overrides=None, comments=()):
    """CSV text with a regular time base plus `columns` {header: value or fn(i)}.

    `overrides` maps (header, row) -> cell text, row being 1-based.
    """
    overrides = overrides or {}
    headers = list(columns)
    lines = list(comments) + [delimiter.join(headers)]
    for i in range(n):
        cells = []
        for h in headers:
            v = columns[h]
            cell = v(i) if callable(v) else v
            cell = overrides.get((h, i + 1), cell)
            cells.append(str(cell))
        lines.append(delimiter.join(cells))
    return "\n".join(lines) + "\n"


def basic(**extra):
    cols = {"t": lambda i: f"{0.01 * i:.2f}", "u": 0, "p_a": 200000}
    cols.update(extra)
    return cols


def assert_points_at(exc, column, row):
    """The error carries and names the column and the data row."""
    err = exc.value
    assert err.column == column
    assert err.row == row
    msg = str(err)
    assert f"column {column!r}" in msg
    if row is None:
        assert "row" not in msg.split(":")[0]
    else:
        assert re.search(rf"\brow {row}\b", msg), msg


# ------------------------------------------------------------- constants

def test_signal_tables():
    assert SIGNALS == ("u", "p_a", "p_b", "x", "v", "T_a", "T_b", "F", "q_a", "q_b", "q_s", "p_s")
    assert SIGNAL_UNITS == {"u": "-", "p_a": "Pa", "p_b": "Pa", "x": "m",
                            "v": "m/s", "T_a": "K", "T_b": "K", "F": "N", "q_a": "kg/s",
                            "q_b": "kg/s", "q_s": "kg/s", "p_s": "Pa"}
    assert MIN_SAMPLES == 10
    assert MAX_SAMPLES == 2_000_000


# ------------------------------------------------------- unit conversions

# All conversions below are exact in binary floating point (integer products
# or a single correctly rounded division/addition), so they are compared with
# == and need no tolerance.
@pytest.mark.parametrize("header, value, expected", [
    ("p_a", 250000.0, 250000.0),
    ("p_a[Pa]", 250000.0, 250000.0),
    ("p_a[bar]", 1.0, 1e5),
    ("p_b[bar]", 6.0, 6e5),
    ("p_a[kPa]", 300.0, 300000.0),
    ("p_a[MPa]", 0.5, 500000.0),
    ("p_a[barg]", 2.0, 301300.0),
    ("p_a[kPag]", 100.0, 201300.0),
    ("p_a[MPag]", 1.0, 1101300.0),
    ("p_a[Pag]", 0.0, 101300.0),
    ("T_a[K]", 300.0, 300.0),
    ("T_a[degC]", 20.0, 293.15),
    ("T_b[C]", 20.0, 293.15),
    ("T_a[degF]", 68.0, 293.15),
    ("x[m]", 0.1, 0.1),
    ("x[mm]", 25.0, 0.025),
    ("x[cm]", 2.5, 0.025),
    ("x[um]", 250.0, 0.00025),
    ("v[m/s]", 0.3, 0.3),
    ("v[mm/s]", 300.0, 0.3),
    ("t[s]", 5.0, 5.0),
    ("t[ms]", 5.0, 0.005),
    ("u[-]", 0.25, 0.25),
    ("u[%]", 50.0, 0.5),
])
def test_parse_header_conversions(header, value, expected):
    signal, convert = parse_header(header)
    assert signal == header.split("[")[0]
    assert float(convert(value)) == expected


def test_psi_conversion():
    _, convert = parse_header("p_a[psi]")
    # 1 psi = 0.45359237 kg * 9.80665 m/s^2 / (0.0254 m)^2 = 6894.757293168361 Pa;
    # rel 1e-12 leaves room for a few ulp of rounding in the product, nothing more.
    assert float(convert(1.0)) == pytest.approx(6894.757293168361, rel=1e-12)
    _, convert_g = parse_header("p_a[psig]")
    # same as above: only floating-point rounding of one product and one sum
    assert float(convert_g(10.0)) == pytest.approx(68947.57293168361 + 101300.0, rel=1e-12)


def test_gauge_uses_given_ambient_pressure():
    _, convert = parse_header("p_a[barg]", ambient_pressure=95000.0)
    assert float(convert(2.0)) == 295000.0  # exact: 2e5 + 95000 are integers
    m = read_csv(make_csv(basic(**{"p_b[barg]": 2})), ambient_pressure=95000.0)
    assert np.all(m["p_b"] == 295000.0)  # exact, as above


def test_parse_header_whitespace():
    assert parse_header("  p_a [ kPa ] ")[0] == "p_a"
    assert float(parse_header("  p_a [ kPa ] ")[1](1.0)) == 1000.0  # exact integer


def test_read_csv_converts_every_column():
    text = make_csv({
        "t[ms]": lambda i: 5 * i,
        "u[%]": 50,
        "p_a[bar]": 1,
        "p_b[barg]": 2,
        "x[mm]": 25,
        "v[mm/s]": 300,
        "T_a[degC]": 20,
        "T_b[degF]": 68,
    })
    m = read_csv(text)
    # Exact comparisons: each conversion is one correctly rounded operation
    # whose result is the nearest double to the decimal literal.
    assert m.t[1] == 0.005
    assert np.all(m["u"] == 0.5)
    assert np.all(m["p_a"] == 1e5)
    assert np.all(m["p_b"] == 301300.0)
    assert np.all(m["x"] == 0.025)
    assert np.all(m["v"] == 0.3)
    assert np.all(m["T_a"] == 293.15)
    assert np.all(m["T_b"] == 293.15)
    assert m.meta["columns"]["p_b"] == "p_b[barg]"
    for arr in [m.t, *m.signals.values()]:
        assert arr.dtype == np.float64


# ------------------------------------------------------------- reading

def test_irregular_sampling_is_accepted():
    times = [0.0, 0.001, 0.003, 0.0035, 0.01, 0.02, 0.021, 0.05, 0.1, 0.1001, 0.3]
    m = read_csv(make_csv(basic(t=lambda i: times[i]), n=len(times)))
    assert m.t.tolist() == times
    assert m.n == len(times)
    assert m.duration == 0.3  # exact: 0.3 - 0.0


def test_missing_cells_become_nan_and_none_in_to_dict():
    overrides = {("p_a", 2): "", ("p_a", 3): "NaN", ("p_a", 4): "nan", ("p_a", 5): "NA",
                 ("x", 7): "  "}
    m = read_csv(make_csv(basic(x=0.01), overrides=overrides))
    assert np.isnan(m["p_a"][1:5]).all()
    assert np.isfinite(m["p_a"][[0, 5, 6]]).all()
    assert np.isnan(m["x"][6])
    d = m.to_dict()
    assert d["p_a"][1:5] == [None, None, None, None]
    assert d["x"][6] is None
    json.dumps(d, allow_nan=False)  # plain JSON, no NaN tokens


def test_missing_u_is_held():
    overrides = {("u", 4): "", ("u", 5): "NA", ("u", 8): "nan"}
    m = read_csv(make_csv(basic(u=lambda i: i / 100), overrides=overrides))
    u = m["u"].tolist()
    assert u[3] == u[2] == 0.02
    assert u[4] == 0.02
    assert u[7] == u[6] == 0.06
    assert not np.isnan(m["u"]).any()


def test_semicolon_delimiter_whitespace_and_comments():
    text = (
        "# rig 3, jack DNC-32\n"
        "\n"
        " t [s] ; u ;  p_a[bar] \n"
        + "".join(f" {0.1 * i:.1f} ;  0.5 ; 2 \n" for i in range(10))
        + "# end of file\n"
    )
    m = read_csv(text)
    assert m.n == 10
    assert np.all(m["p_a"] == 2e5)  # exact integer product
    assert np.all(m["u"] == 0.5)


def test_read_from_path_and_file_like(tmp_path):
    text = make_csv(basic())
    path = tmp_path / "step_run_07.csv"
    path.write_text("\ufeff" + text, encoding="utf-8")  # Excel-style BOM
    m = read_csv(path)
    assert m.name == "step_run_07"
    assert m.meta["source"] == str(path)
    assert read_csv(str(path), name="custom").name == "custom"
    assert read_csv(io.StringIO(text)).n == 12
    assert read_csv(io.BytesIO(text.encode())).n == 12
    assert read_csv(text).name == ""


def test_trailing_delimiter_is_tolerated():
    text = "t,u,x,\n" + "".join(f"{i},0,0.1,\n" for i in range(10))
    assert read_csv(text).measured_signals == ("x",)


# ------------------------------------------------------- dict round trip

def test_from_dict_to_dict_round_trip():
    d = {"t": [0.1 * i for i in range(10)],
         "u": [0.0] * 5 + [1.0] * 5,
         "p_a": [2e5, None, 3e5, 3e5, 3e5, 4e5, 4e5, None, 5e5, 5e5],
         "x": [0.0, 0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09],
         "name": "run1"}
    m = Measurement.from_dict(d)
    assert np.isnan(m["p_a"][1])
    out = m.to_dict()
    assert out == d
    back = Measurement.from_dict(json.loads(json.dumps(out)))
    assert back.name == "run1"
    np.testing.assert_array_equal(back.t, m.t)
    assert back.signals.keys() == m.signals.keys()
    for k in m.signals:
        np.testing.assert_array_equal(back[k], m[k])  # NaN == NaN here


def test_from_dict_units_and_gauge():
    d = {"t[ms]": list(range(0, 100, 10)), "u[%]": [100] * 10,
         "p_a[barg]": [2] * 9 + [None], "T_a[degC]": [20] * 10}
    m = Measurement.from_dict(d, ambient_pressure=100000.0)
    assert m.t[1] == 0.01  # exact: 10 / 1000 correctly rounded
    assert np.all(m["u"] == 1.0)
    assert m["p_a"][0] == 300000.0  # exact integers
    assert np.isnan(m["p_a"][9])
    assert m["T_a"][0] == 293.15  # exact: 20 + 273.15 rounds to the literal
    assert set(m.to_dict()) == {"t", "u", "p_a", "T_a"}


def test_from_dict_length_mismatch():
    d = {"t": list(range(10)), "u": [0] * 10, "x": [0] * 9}
    with pytest.raises(MeasurementError, match="9 values") as exc:
        Measurement.from_dict(d)
    assert exc.value.column == "x"


def test_from_dict_non_numeric_names_key_and_index():
    d = {"t": list(range(10)), "u": [0] * 10, "p_b[kPa]": [200] * 6 + ["abc"] + [200] * 3}
    with pytest.raises(MeasurementError, match="'abc' is not a number") as exc:
        Measurement.from_dict(d)
    assert_points_at(exc, "p_b[kPa]", 7)


# ---------------------------------------------------------- properties

def test_properties_getitem_and_slice():
    # p_b is only measured during the first 3 samples
    m = read_csv(make_csv(basic(x=0.02, p_b=lambda i: 3e5 if i < 3 else ""), n=30))
    assert m.n == 30
    assert m.duration == 0.29  # exact: 0.29 - 0.0
    assert m.measured_signals == ("p_a", "p_b", "x")
    assert m["t"] is m.t
    assert "p_b" in m and "T_a" not in m
    with pytest.raises(KeyError, match="T_a"):
        m["T_a"]
    s = m.slice(0.05, 0.2)
    assert s.t[0] == 0.05 and s.t[-1] == 0.2
    assert s.n == 16
    assert s.measured_signals == ("p_a", "x")  # p_b kept, but all NaN in the window
    assert np.isnan(s["p_b"]).all()
    s.signals["x"][0] = -1.0
    assert m["x"][5] == 0.02  # slice copies data
    with pytest.raises(MeasurementError, match="holds 3 samples"):
        m.slice(0.0, 0.02)


def test_command_breakpoints_on_step():
    m = read_csv(make_csv(basic(u=lambda i: 0 if i < 5 else 0.8), n=12))
    assert m.command_breakpoints() == [[0.0, 0.0], [0.05, 0.8]]
    const = read_csv(make_csv(basic(u=0.3)))
    assert const.command_breakpoints() == [[0.0, 0.3]]
    pulse = Measurement.from_dict({"t": list(range(10)), "u": [0, 0, 1, 1, None, -1, -1, 0, 0, 0],
                                   "x": [0] * 10})
    assert pulse.command_breakpoints() == [[0.0, 0.0], [2.0, 1.0], [5.0, -1.0], [7.0, 0.0]]


# ---------------------------------------------------------- error paths

def test_error_decreasing_time():
    k = 6
    cols = basic(**{"t[s]": lambda i: f"{0.1 * i:.1f}"})
    del cols["t"]
    text = make_csv(cols, overrides={("t[s]", k): "0.3"})
    with pytest.raises(MeasurementError, match="not strictly increasing") as exc:
        read_csv(text)
    assert_points_at(exc, "t[s]", k)


def test_error_repeated_time():
    with pytest.raises(MeasurementError, match="not strictly increasing") as exc:
        read_csv(make_csv(basic(), overrides={("t", 4): "0.02"}))
    assert_points_at(exc, "t", 4)


def test_error_missing_time():
    with pytest.raises(MeasurementError, match="time is missing") as exc:
        read_csv(make_csv(basic(), overrides={("t", 3): ""}))
    assert_points_at(exc, "t", 3)


def test_error_non_numeric_cell():
    cols = {"t": lambda i: i, "u": 0, "p_a[bar]": 2}
    with pytest.raises(MeasurementError) as exc:
        read_csv(make_csv(cols, n=20, overrides={("p_a[bar]", 17): "abc"}))
    assert str(exc.value) == "column 'p_a[bar]', row 17 (line 18): 'abc' is not a number"
    assert_points_at(exc, "p_a[bar]", 17)
    assert exc.value.line == 18


def test_error_row_numbers_skip_comment_lines():
    text = make_csv(basic(), overrides={("p_a", 3): "x1"}, comments=["# a", "# b"])
    with pytest.raises(MeasurementError) as exc:
        read_csv(text)
    assert_points_at(exc, "p_a", 3)
    assert exc.value.line == 6  # 2 comments + header + 3rd data row


def test_error_decimal_comma_hint():
    text = make_csv(basic(), delimiter=";", overrides={("p_a", 2): "2,5"})
    with pytest.raises(MeasurementError, match="decimal comma") as exc:
        read_csv(text)
    assert_points_at(exc, "p_a", 2)


def test_error_unknown_column():
    with pytest.raises(MeasurementError) as exc:
        read_csv(make_csv(basic(pressure=1)))
    assert_points_at(exc, "pressure", None)
    for known in ("t", "u", "p_a", "p_b", "x", "v", "T_a", "T_b"):
        assert known in str(exc.value)
    with pytest.raises(MeasurementError, match="did you mean 'p_a'") as exc:
        parse_header("P_a[bar]")
    assert exc.value.column == "P_a[bar]"


def test_error_unknown_unit():
    with pytest.raises(MeasurementError) as exc:
        read_csv(make_csv(basic(**{"x[furlong]": 1})))
    assert_points_at(exc, "x[furlong]", None)
    assert "'furlong'" in str(exc.value)
    for unit in ("m", "mm", "cm", "um"):
        assert unit in str(exc.value)
    with pytest.raises(MeasurementError, match="barg") as exc:
        parse_header("p_a[atm]")
    # a pressure unit is not accepted for a temperature column
    with pytest.raises(MeasurementError, match="degC") as exc:
        parse_header("T_a[bar]")
    assert exc.value.column == "T_a[bar]"


def test_error_all_missing_signal():
    with pytest.raises(MeasurementError, match="entirely missing") as exc:
        read_csv(make_csv(basic(**{"p_b[bar]": ""})))
    assert_points_at(exc, "p_b[bar]", None)


def test_error_too_few_samples():
    with pytest.raises(MeasurementError) as exc:
        read_csv(make_csv(basic(), n=7))
    msg = str(exc.value)
    assert "7 data rows found" in msg and "10" in msg
    assert exc.value.column is None and exc.value.row is None


def test_error_too_many_samples(monkeypatch):
    monkeypatch.setattr(meas, "MAX_SAMPLES", 15)
    with pytest.raises(MeasurementError, match="MAX_SAMPLES = 15") as exc:
        read_csv(make_csv(basic(), n=20))
    assert exc.value.row == 16
    with pytest.raises(MeasurementError, match="too many samples"):
        Measurement.from_dict({"t": list(range(20)), "u": [0] * 20, "x": [0] * 20})


@pytest.mark.parametrize("cell", ["inf", "-inf", "Infinity"])
def test_error_infinite_value(cell):
    with pytest.raises(MeasurementError, match="infinite") as exc:
        read_csv(make_csv(basic(x=0.1), overrides={("x", 9): cell}))
    assert_points_at(exc, "x", 9)


def test_error_infinite_time():
    with pytest.raises(MeasurementError, match="infinite") as exc:
        read_csv(make_csv(basic(), overrides={("t", 12): "inf"}))
    assert_points_at(exc, "t", 12)


def test_error_negative_absolute_pressure():
    with pytest.raises(MeasurementError, match="not positive") as exc:
        read_csv(make_csv(basic(**{"p_b[barg]": 1}), overrides={("p_b[barg]", 5): "-1.5"}))
    assert_points_at(exc, "p_b[barg]", 5)
    with pytest.raises(MeasurementError, match="not positive") as exc:
        read_csv(make_csv(basic(), overrides={("p_a", 2): "-5"}))
    assert_points_at(exc, "p_a", 2)


def test_error_non_positive_temperature():
    with pytest.raises(MeasurementError, match="temperature") as exc:
        read_csv(make_csv(basic(**{"T_a[degC]": 20}),
                          overrides={("T_a[degC]", 3): "-300"}))
    assert_points_at(exc, "T_a[degC]", 3)


def test_error_leading_missing_u():
    with pytest.raises(MeasurementError, match="first command sample is missing") as exc:
        read_csv(make_csv({"t": lambda i: i, "u[%]": 10, "x": 0}, overrides={("u[%]", 1): ""}))
    assert_points_at(exc, "u[%]", 1)


def test_error_u_out_of_range():
    with pytest.raises(MeasurementError, match=r"u\[%\]") as exc:
        read_csv(make_csv(basic(u=lambda i: 0 if i < 3 else 50)))
    assert_points_at(exc, "u", 4)


def test_error_duplicate_column():
    with pytest.raises(MeasurementError, match="duplicate") as exc:
        read_csv(make_csv(basic(**{"x[mm]": 1, "x[m]": 0.001})))
    assert_points_at(exc, "x[m]", None)
    assert "'x[mm]'" in str(exc.value)
    with pytest.raises(MeasurementError, match="duplicate") as exc:
        read_csv(make_csv({"t": lambda i: i, "u": 0, "p_a[bar]": 2, "p_a[Pa]": 2e5}))
    assert "'p_a[bar]'" in str(exc.value) and "'p_a[Pa]'" in str(exc.value)


def test_error_required_column():
    cols = basic()
    del cols["t"]
    with pytest.raises(MeasurementError, match="required column") as exc:
        read_csv(make_csv(cols))
    assert_points_at(exc, "t", None)


def test_a_record_without_a_command_column_is_read():
    # rigs often log no command: the experiment's scenario gives it (issue 28)
    cols = basic()
    del cols["u"]
    m = read_csv(make_csv(cols))
    assert "u" not in m.signals and m.measured_signals
    assert m.command_breakpoints() == []


def test_error_no_measured_signal():
    with pytest.raises(MeasurementError, match="no measured signal"):
        read_csv(make_csv({"t": lambda i: i, "u": 0}))


def test_error_short_row():
    text = make_csv(basic())
    lines = text.splitlines()
    lines[4] = "0.03,0"  # data row 4 lacks the p_a cell
    with pytest.raises(MeasurementError, match="2 cells") as exc:
        read_csv("\n".join(lines) + "\n")
    assert_points_at(exc, "p_a", 4)


def test_error_bad_ambient_pressure():
    with pytest.raises(MeasurementError, match="ambient_pressure"):
        read_csv(make_csv(basic()), ambient_pressure=-1.0)


def test_error_is_value_error_and_picklable():
    err = MeasurementError("'abc' is not a number", column="p_a[bar]", row=17)
    assert isinstance(err, ValueError)
    assert str(err) == "column 'p_a[bar]', row 17: 'abc' is not a number"
    back = pickle.loads(pickle.dumps(err))
    assert (back.column, back.row, str(back)) == (err.column, err.row, str(err))
    assert str(MeasurementError("plain")) == "plain"


# ------------------------------------------------------- rig dialects (issue 11)

@pytest.mark.parametrize("spelling,signal,canonical", [
    ("bar(g)", "p_a", "barg"), ("barg", "p_a", "barg"), ("bar g", "p_a", "barg"),
    ("bar (gauge)", "p_b", "barg"), ("psi(g)", "p_a", "psig"), ("kPa", "p_a", "kPa"),
    ("KPA", "p_a", "kPa"), ("bar(a)", "p_a", "bar"), ("bar abs", "p_a", "bar"), ("mbar", "p_a", "mbar"),
    ("mm", "x", "mm"), ("in", "x", "in"), ("inch", "x", "in"), ("ms", "t", "ms"), ("%", "u", "%"),
    ("furlong", "x", None), ("bar(g)", "x", None)])
def test_unit_spellings(spelling, signal, canonical):
    assert meas.canonical_unit(spelling, signal) == canonical


def test_gauge_spellings_add_the_given_ambient():
    text = "t;u;p_a;p_b\ns;%;bar(g);psi g\n" + "".join(f"{i};0;1,5;10\n" for i in range(12))
    m = read_csv(text, ambient_pressure=95_000.0)
    assert m.signals["p_a"][0] == pytest.approx(1.5e5 + 95_000.0, rel=1e-15)
    assert m.signals["p_b"][0] == pytest.approx(10 * meas.PSI + 95_000.0, rel=1e-15)


@pytest.mark.parametrize("sep", [";", "\t", "|"])
def test_decimal_comma_detected_with_other_delimiters(sep):
    text = sep.join(["t", "u", "p_a[kPa]"]) + "\n" + "".join(
        sep.join([f"{0.01 * i:.2f}", "0", "250,5"]).replace("0.", "0,") + "\n" for i in range(12))
    m = read_csv(text)
    assert m.meta["import"]["decimal"] == "," and m.t[3] == pytest.approx(0.03)
    assert m.signals["p_a"][0] == pytest.approx(250_500.0)


def test_cr_only_lines_and_units_row_keep_row_numbers():
    text = "\r".join(["Zeit;Ventil;p_A", "ms;%;bar"] + [f"{i};0;{'x' if i == 4 else 2}" for i in range(12)])
    with pytest.raises(MeasurementError) as exc:
        read_csv(text)
    # data row 5 (the units row is not a data row), line 7 (header and units row counted)
    assert exc.value.row == 5 and exc.value.line == 7 and exc.value.column == "p_A"


@pytest.mark.parametrize("enc", ["utf-16", "utf-16-le", "utf-16-be", "utf-32", "cp1252", "utf-8-sig"])
def test_encodings_give_readable_names(enc):
    text = "# Prüfstand, 21 °C\nZeit [ms],Ventil [%],Druck A [bar g]\n" + "".join(f"{i},0,1\n" for i in range(12))
    m = read_csv(text.encode(enc))
    assert [c["column"] for c in m.meta["import"]["conversions"]] == ["Zeit [ms]", "Ventil [%]", "Druck A [bar g]"]


def test_mapping_and_aliases_are_reported():
    text = "Time,cmd,Kanal 3,Kraft\n" + "".join(f"{i * 0.01},0,{2e5},5\n" for i in range(12))
    m = read_csv(text, columns={"Kanal 3": "p_a[Pa]", "Kraft": None})
    how = {c["column"]: (c["signal"], c["how"]) for c in m.meta["import"]["conversions"]}
    assert how == {"Time": ("t", "alias"), "cmd": ("u", "alias"), "Kanal 3": ("p_a", "mapping")}
    assert m.meta["import"]["ignored_columns"] == ["Kraft"]
    with pytest.raises(MeasurementError, match="not in the file") as exc:
        read_csv(text, columns={"Druck": "p_a"})
    assert exc.value.column == "columns.Druck"


def test_exported_simulation_reads_back():
    from pneucore import model_preset, scenario_preset
    from pneucore.data.export import simulation_csv
    from pneucore.simulate import simulate
    res = simulate(model_preset("paper-3way"), scenario_preset("paper-fig9-switching"))
    m = read_csv(simulation_csv(res))
    for s in ("p_a", "x", "T_a"):
        # 10 significant digits written: relative rounding at most 5e-10
        np.testing.assert_allclose(m.signals[s], res.series[s], rtol=1e-9)
    assert "m_a[kg]" in m.meta["import"]["ignored_columns"]


# ------------------------------------------------------------------ sensors (issue 28, item 2)
def test_a_sensor_in_raw_volts_with_gain_offset_and_gauge_reference():
    # 1.5 V at 2 bar/V with a -0.5 bar zero is 2.5 bar gauge: 2.5e5 Pa + the rig's ambient
    text = make_csv({"t": lambda i: f"{0.01 * i:.2f}", "pV": 1.5, "pos": 10.0})
    m = read_csv(text, ambient_pressure=95000.0, columns={
        "pV": {"signal": "p_a", "unit": "bar", "gain": 2.0, "offset": -0.5, "reference": "gauge",
               "raw_unit": "V"},
        "pos": {"signal": "x", "unit": "mm", "offset": -3.0}})
    # exact in binary up to the last bit of 2.5e5 + 95000 and 7 mm / 1000
    np.testing.assert_allclose(m["p_a"], 345000.0, rtol=1e-15)
    np.testing.assert_allclose(m["x"], 0.007, rtol=1e-15)
    conv = {c["signal"]: c for c in m.meta["import"]["conversions"]}
    assert conv["p_a"] == {"column": "pV", "signal": "p_a", "from": "barg", "to": "Pa",
                           "ambient_pressure": 95000.0, "how": "mapping", "gain": 2.0,
                           "offset": -0.5, "raw_unit": "V"}
    assert conv["x"]["offset"] == -3.0 and conv["x"]["from"] == "mm"


def test_a_sensor_reference_overrides_the_units_gauge_mark():
    text = make_csv({"t": lambda i: f"{0.01 * i:.2f}", "p_a[barg]": 3.0})
    m = read_csv(text, columns={"p_a[barg]": {"signal": "p_a", "reference": "absolute"}})
    assert m["p_a"][0] == 3e5     # 3 bar absolute, no ambient added


@pytest.mark.parametrize("sensor, where", [
    ({"signal": "p_a", "gain": 0}, "columns.pV.gain"),
    ({"signal": "p_a", "offset": float("nan")}, "columns.pV.offset"),
    ({"signal": "p_a", "gain": True}, "columns.pV.gain"),
    ({"signal": "p_a", "bias": 1}, "columns.pV"),
    ({"signal": "T_a", "reference": "gauge"}, "columns.pV.reference"),
    ({"signal": "p_a", "raw_unit": "V" * 40}, "columns.pV.raw_unit"),
    ({"unit": "bar"}, "columns.pV.signal"),
])
def test_a_bad_sensor_names_its_field(sensor, where):
    text = make_csv({"t": lambda i: f"{0.01 * i:.2f}", "pV": 1.5})
    with pytest.raises(MeasurementError) as exc:
        read_csv(text, columns={"pV": sensor})
    assert exc.value.column == where


def test_messages_carry_numbers_not_numpy_reprs():
    # a pressure sensor at its zero read as absolute: 0 Pa is refused, written as a number
    with pytest.raises(MeasurementError) as exc:
        read_csv(make_csv(basic(p_a=0.0)))
    assert "absolute pressure 0 Pa is not positive" in str(exc.value)
    assert "np." not in str(exc.value)
    with pytest.raises(MeasurementError) as exc:
        read_csv(make_csv(basic(**{"T_a": -1.0})))
    assert "temperature -1 K" in str(exc.value) and "np." not in str(exc.value)
