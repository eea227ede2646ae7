"""POST /api/valve/convert: catalogue valve data to the model's C and b (issue 23, item 7),
against the catalogues' own figures and the ISO 6358 law written out here."""
import math

import pytest

from api_conftest import api, assert_field_error, client, db_path  # noqa: F401

DM3_S_BAR = 1e-8     # 1 dm^3/(s bar) in m^3/(s Pa), by the units' definitions


def test_a_flow_point_gives_smcs_worked_example(client):
    # SMC's VX datasheet example ("Flow-rate characteristics"): C = 2 dm^3/(s bar), b = 0.3
    # passes 420 dm^3/min (ANR) from 0.4 to 0.3 MPa gauge; the datasheet reads its chart to
    # 2 significant digits, hence 0.5 %
    r = client.post("/api/valve/convert", json={"flow_rate": 420e-3 / 60, "p1": 5e5, "p2": 4e5,
                                                "b": 0.3})
    assert r.status_code == 200, r.text
    ans = r.json()
    assert ans["conversion"] == "flow_rate" and ans["b"] == 0.3
    assert ans["C"] == pytest.approx(2 * DM3_S_BAR, rel=5e-3)
    assert ans["units"] == {"C": "m^3/(s Pa)", "b": "-"}


def test_a_nominal_flow_inverts_the_iso6358_law(client):
    # Qn of C = 1 dm^3/(s bar), b = 0.3 by the law (paper Eq. 4, m = 0.5, T = T0) at 7 bar abs
    # upstream and 6 bar downstream, ANR atmosphere 100 kPa; back to C within 1e-9 (floats)
    C, b, p1, p2 = DM3_S_BAR, 0.3, 7e5, 6e5
    qn = C * p1 * math.sqrt(1 - ((p2 / p1 - b) / (1 - b)) ** 2) * 60e3      # NL/min
    r = client.post("/api/valve/convert", json={"qn": qn, "b": b})
    assert r.status_code == 200, r.text
    assert r.json()["C"] == pytest.approx(C, rel=1e-9)


def test_an_effective_area_follows_the_catalogue_rule(client):
    # catalogues (JIS B 8390): S [mm^2] = 5.0 C [dm^3/(s bar)], a rounded factor: 1 %
    r = client.post("/api/valve/convert", json={"effective_area": 10e-6, "b": 0.4})
    assert r.status_code == 200, r.text
    assert r.json()["C"] == pytest.approx(2 * DM3_S_BAR, rel=0.01)


@pytest.mark.parametrize("body,field,part", [
    ({"qn": -5.0, "b": 0.3}, "body.qn", "NL/min"),
    ({"qn": 200.0}, "body.b", "required"),
    ({"qn": 200.0, "b": 1.5}, "body.b", "< 1"),
    ({"effective_area": 1e-5, "qn": 200.0, "b": 0.3}, "body", "exactly one"),
    ({"b": 0.3}, "body", "exactly one"),
    ({"qn": 200.0, "b": 0.3, "p1": 5e5}, "body.p1", "not read"),
    ({"flow_rate": 1e-3, "p1": 4e5, "p2": 5e5, "b": 0.3}, "body.p2", "below p1"),
    ({"flow_rate": 1e-3, "p2": 4e5, "b": 0.3}, "body.p1", "Pa"),
])
def test_bad_valve_data_is_a_422_naming_the_field(client, body, field, part):
    assert_field_error(client.post("/api/valve/convert", json=body), field, msg_contains=part)


def test_unknown_and_non_numeric_fields_are_422s(client):
    r = client.post("/api/valve/convert", json={"qn": "lots", "b": 0.3})
    assert r.status_code == 422 and "qn" in r.text
    r = client.post("/api/valve/convert", json={"cv": 1.0, "b": 0.3})
    assert r.status_code == 422 and "cv" in r.text
