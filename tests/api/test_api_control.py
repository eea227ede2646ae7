"""POST /api/linearize and closed-loop POST /api/simulate (issue 42)."""
import math

from api_conftest import api, assert_field_error, client, db_path  # noqa: F401
from pneucore import model_preset


def test_linearize_answers_the_contract(client):
    r = client.post("/api/linearize", json={"model": model_preset("paper-4way"),
                                            "operating_point": {"x": 0.1}})
    assert r.status_code == 200, r.text
    ans = r.json()
    for k in ("natural_frequency", "damping", "poles", "A", "B", "C", "D", "states"):
        assert k in ans
    n = len(ans["states"])
    assert len(ans["A"]) == n and len(ans["B"]) == n and len(ans["C"][0]) == n
    assert ans["operating_point"]["x"] == 0.1
    assert ans["operating_point"]["p_a"] == ans["operating_point"]["p_b"]   # equilibrium
    assert 1.0 < ans["natural_frequency"] < 100.0


def test_linearize_outside_the_stroke_is_a_422_naming_the_field(client):
    r = client.post("/api/linearize", json={"model": model_preset("paper-4way"),
                                            "operating_point": {"x": 0.5}})
    assert_field_error(r, "operating_point.x")
    assert "[m]" in r.text or " m " in r.text
