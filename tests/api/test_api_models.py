"""POST /api/models/diff (issue 24: a diff of two model versions)."""
from api_conftest import assert_field_error, client, db_path, model  # noqa: F401


def test_diff_lists_what_changed_with_units(client):  # noqa: F811
    a, b = model(), model()
    b["heat"]["coefficient"] = 35.0
    b["jack"]["moving_mass"] = 2.4
    b["effects"] = {"piston_leakage": {"conductance": 8e-11}}
    r = client.post("/api/models/diff", json={"before": a, "after": b})
    assert r.status_code == 200, r.text
    got = {c["path"]: c for c in r.json()}
    assert got["heat.coefficient"]["before"] == 25.0 and got["heat.coefficient"]["after"] == 35.0
    assert got["heat.coefficient"]["unit"] == "W/(m^2 K)"
    assert got["jack.moving_mass"]["unit"] == "kg"
    assert got["effects.piston_leakage"]["kind"] == "added"
    assert client.post("/api/models/diff", json={"before": a, "after": a}).json() == []


def test_a_wrong_model_is_a_422_naming_which(client):  # noqa: F811
    bad = model()
    bad["jack"]["bore"] = -1.0
    assert_field_error(client.post("/api/models/diff", json={"before": model(), "after": bad}),
                       "after.jack.bore")
