"""POST /api/friction/preview and the parameter units of GET /api/units: the page's friction map
and unit labels come from the service, computed by pneucore (one source for the law and the units).

The friction law is evaluated here independently, from the model's JSON coefficients through
the functions of :mod:`pneucore.physics.friction`, and compared with the endpoint, which reads the
coefficients from the core's parameter vector (every catalog effect applied).
"""
from __future__ import annotations

import copy
import re
from pathlib import Path

import pytest

from api_conftest import assert_field_error, client, db_path, model  # noqa: F401
from app.schemas import FRICTION_DEFAULT_VELOCITIES, FRICTION_MAX_PRESSURES, FRICTION_MAX_VELOCITIES
from pneucore.description.effects import EFFECTS
from pneucore.physics.friction import coulomb_level, sliding_friction, stribeck_factor, viscous_coefficient
from pneucore.description.paths import unit_of

ROOT = Path(__file__).resolve().parents[2]
URL = "/api/friction/preview"
BAR = 1e5
#: Velocities across both directions, the Stribeck region near rest and v = 0 itself [m/s]
VELOCITIES = [-0.4, -0.05, -0.003, -1e-4, 0.0, 1e-4, 0.003, 0.05, 0.4]
PRESSURES = [(1.013 * BAR, 1.013 * BAR), (6 * BAR, 2 * BAR), (2.5 * BAR, 7 * BAR)]
#: The endpoint evaluates the same float64 operations on the same coefficients: only the
#: order of the pressure-coefficient sums may differ (a few ulp) [-]
REL = 1e-12


def _asymmetric_model():
    """Pressure- and direction-dependent friction: every coefficient of Eq. 19-20 non-zero."""
    m = model()
    m["friction"] = {"extend": {"fc0": 12.0, "fc_a": 2e-6, "fc_b": -1e-6, "kv0": 40.0,
                                "kv_a": 3e-5, "kv_b": 1e-5},
                     "retract": {"fc0": 18.0, "fc_a": -1.5e-6, "fc_b": 3e-6, "kv0": 55.0,
                                 "kv_a": 1e-5, "kv_b": 2e-5}}
    return m


def _expected(m, p_a, p_b, v, ratio=1.0, v_s=0.01):
    """Eq. 18-20 from the model JSON through pneucore.physics.friction (None at rest)."""
    p_atm = m.get("ambient", {}).get("pressure", 101300.0)
    if v == 0.0:
        return None
    fs = m["friction"]["extend" if v > 0 else "retract"] or m["friction"]["extend"]
    fc = coulomb_level(fs["fc0"], fs["fc_a"], fs["fc_b"], p_a, p_b, p_atm)
    kv = viscous_coefficient(fs["kv0"], fs["kv_a"], fs["kv_b"], p_a, p_b, p_atm)
    return sliding_friction(v, 1.0 if v > 0 else -1.0, fc, kv, ratio, v_s)


def _post(c, m, pressures=PRESSURES, velocities=VELOCITIES):
    body = {"model": m, "pressures": [{"p_a": a, "p_b": b} for a, b in pressures]}
    if velocities is not None:
        body["velocities"] = velocities
    return c.post(URL, json=body)


def _check_curves(m, out, ratio=1.0, v_s=0.01):
    assert out["velocities"] == VELOCITIES
    assert len(out["curves"]) == len(PRESSURES)
    p_atm = m.get("ambient", {}).get("pressure", 101300.0)
    for (p_a, p_b), c in zip(PRESSURES, out["curves"]):
        assert (c["p_a"], c["p_b"]) == (p_a, p_b)
        for v, f in zip(VELOCITIES, c["force"]):
            want = _expected(m, p_a, p_b, v, ratio, v_s)
            if want is None:
                assert f is None   # at rest the piston sticks: no sliding force
            else:
                assert f == pytest.approx(want, rel=REL), (p_a, p_b, v)
                assert (f > 0) == (v > 0), "friction opposes the motion"
        for side, key in (("extend", "static_extend"), ("retract", "static_retract")):
            fs = m["friction"][side]
            fc = coulomb_level(fs["fc0"], fs["fc_a"], fs["fc_b"], p_a, p_b, p_atm)
            # the stick band: the breakaway force is the Coulomb level times the Stribeck ratio
            assert c[key] == pytest.approx(ratio * fc, rel=REL)
            assert c[f"coulomb_{side}"] == pytest.approx(fc, rel=REL)


def test_agrees_with_the_pneucore_law_in_both_directions(client):
    m = _asymmetric_model()
    r = _post(client, m)
    assert r.status_code == 200, r.text[:500]
    out = r.json()
    assert out["law"] == "coulomb_viscous" and out["stribeck_ratio"] == 1.0
    _check_curves(m, out)
    # the quadrant effect: the same speed costs more retracting than extending here
    c = out["curves"][0]
    assert -c["force"][0] > c["force"][-1]
    # and the pressure effect: the curves differ with the chamber pressures
    assert out["curves"][1]["force"][-1] != out["curves"][2]["force"][-1]


def test_a_registered_friction_law_is_what_the_preview_draws(client):
    """The map comes from the model's law in the registry, not from a copy of Eq. 18: a law
    registered as three times the built-in force (and static limit) draws three times the
    curves of the built-in law."""
    from numba import njit

    from pneucore.physics.friction import (breakaway_friction, register_friction_law,
                                           unregister_friction_law)

    @njit
    def triple_force(v, direction, fc, kv, ratio, v_s):
        return 3.0 * sliding_friction(v, direction, fc, kv, ratio, v_s)

    @njit
    def triple_static(fc, ratio, v_s):
        return 3.0 * breakaway_friction(fc, ratio, v_s)

    m = _asymmetric_model()
    base = _post(client, m).json()
    register_friction_law("test_preview_triple", triple_force, triple_static, "3 x Eq. 18 (test)")
    try:
        m3 = copy.deepcopy(m)
        m3["friction"]["law"] = "test_preview_triple"
        r = _post(client, m3)
    finally:
        unregister_friction_law("test_preview_triple")
    assert r.status_code == 200, r.text[:500]
    out = r.json()
    assert out["law"] == "test_preview_triple"
    for c0, c3 in zip(base["curves"], out["curves"]):
        for f0, f3 in zip(c0["force"], c3["force"]):
            assert (f0 is None and f3 is None) or f3 == pytest.approx(3.0 * f0, rel=REL)
        assert c3["static_extend"] == pytest.approx(3.0 * c0["static_extend"], rel=REL)
        assert c3["static_retract"] == pytest.approx(3.0 * c0["static_retract"], rel=REL)
        assert c3["coulomb_extend"] == pytest.approx(c0["coulomb_extend"], rel=REL)


def test_stribeck_effect_raises_the_breakaway(client):
    m = _asymmetric_model()
    m["effects"] = {"stribeck_friction": {"static_ratio": 2.0, "stribeck_velocity": 0.005}}
    out = _post(client, m).json()
    assert out["stribeck_ratio"] == 2.0 and out["stribeck_velocity"] == 0.005
    _check_curves(m, out, ratio=2.0, v_s=0.005)
    # near rest the force approaches twice the Coulomb level, far from it the plain law
    c = out["curves"][0]
    i_slow, i_fast = VELOCITIES.index(1e-4), VELOCITIES.index(0.4)
    fc = c["coulomb_extend"]
    assert c["force"][i_slow] == pytest.approx(c["viscous_extend"] * 1e-4
                                               + fc * stribeck_factor(1e-4, 2.0, 0.005), rel=REL)
    assert c["force"][i_slow] > 1.9 * fc     # factor 1 + exp(-(0.02)^2) ~ 2
    assert c["static_extend"] == pytest.approx(2.0 * fc, rel=REL)
    assert c["force"][i_fast] == pytest.approx(c["viscous_extend"] * 0.4 + fc, rel=REL)


def test_friction_effects_act_as_in_the_simulation(client):
    """Catalog effects that rewrite the friction coefficients (their transforms) show in the map."""
    base = model()
    base["friction"] = {"extend": {"fc0": 12.0, "kv0": 40.0}, "retract": None}
    m = copy.deepcopy(base)
    pdf = {"fc_a": 4e-6, "fc_b": -1e-6, "kv_a": 2e-5, "kv_b": 0.0}
    quad = {"fc0": 5.0, "fc_a": 0.0, "fc_b": 1e-6, "kv0": 10.0, "kv_a": 0.0, "kv_b": 0.0}
    m["effects"] = {"pressure_dependent_friction": pdf, "quadrant_friction": quad}
    r = _post(client, m)
    assert r.status_code == 200, r.text[:500]
    # pressure dependence added to both directions, then retraction = extension + the offsets
    ext = {"fc0": 12.0, "kv0": 40.0, **pdf}
    summed = copy.deepcopy(base)
    summed["friction"] = {"extend": ext, "retract": {k: ext[k] + quad[k] for k in quad}}
    _check_curves(summed, r.json())
    plain = _post(client, base).json()["curves"][1]["force"]
    assert r.json()["curves"][1]["force"] != plain


def test_retract_null_uses_the_extension_set_and_default_grid(client):
    m = model()
    m["friction"] = {"extend": {"fc0": 9.0, "kv0": 30.0}, "retract": None}
    r = client.post(URL, json={"model": m, "pressures": [{"p_a": 3 * BAR, "p_b": 3 * BAR}]})
    assert r.status_code == 200, r.text[:500]
    out = r.json()
    assert out["velocities"] == list(FRICTION_DEFAULT_VELOCITIES)
    f = dict(zip(out["velocities"], out["curves"][0]["force"]))
    assert f[0.0] is None
    # the same set both ways: an odd function of the velocity
    assert f[0.5] == pytest.approx(30.0 * 0.5 + 9.0, rel=REL)
    assert f[-0.5] == pytest.approx(-f[0.5], rel=REL)
    assert out["curves"][0]["static_extend"] == out["curves"][0]["static_retract"] == 9.0


def test_the_response_documents_its_units(client):
    spec = client.get("/openapi.json").json()
    assert URL in spec["paths"]
    schemas = spec["components"]["schemas"]
    for name in ("FrictionPreviewRequest", "FrictionPressures", "FrictionCurve", "FrictionPreviewResponse"):
        for field, s in schemas[name]["properties"].items():
            if field != "model":
                assert re.search(r"\[[^\]]+\]\s*$", s.get("description", "")), (name, field)


@pytest.mark.parametrize("body, field", [
    ({"pressures": [{"p_a": 0.0, "p_b": 2e5}]}, "pressures[0].p_a"),
    ({"pressures": [{"p_a": 2e5, "p_b": -1.0}]}, "pressures[0].p_b"),
    ({"pressures": [{"p_a": 2e5, "p_b": 2e5}, {"p_a": 1e12, "p_b": 2e5}]}, "pressures[1].p_a"),
    ({"pressures": [{"p_a": 2e5}]}, "pressures[0].p_b"),
    ({"pressures": [{"p_a": 2e5, "p_b": 2e5, "p_c": 1.0}]}, "pressures[0].p_c"),
    ({"pressures": []}, "pressures"),
    ({"pressures": [{"p_a": 2e5, "p_b": 2e5}] * (FRICTION_MAX_PRESSURES + 1)}, "pressures"),
    ({"velocities": [0.1] * (FRICTION_MAX_VELOCITIES + 1)}, "velocities"),
    ({"velocities": []}, "velocities"),
    ({"velocities": [0.1, 1e6]}, "velocities[1]"),
    ({"velocities": ["fast"]}, "velocities[0]"),
    ({"model": None}, "model"),
])
def test_bad_input_is_a_422_naming_the_field(client, body, field):
    full = {"model": model(), "pressures": [{"p_a": 2e5, "p_b": 2e5}], **body}
    assert_field_error(client.post(URL, json=full), field)


def test_non_finite_numbers_are_refused(client):
    for text, field in (('{"p_a": NaN, "p_b": 2e5}', "pressures[0].p_a"),
                        ('{"p_a": 2e5, "p_b": Infinity}', "pressures[0].p_b")):
        import json
        body = '{"model": ' + json.dumps(model()) + ', "pressures": [' + text + ']}'
        r = client.post(URL, content=body, headers={"content-type": "application/json"})
        assert r.status_code == 422, r.text[:300]
        assert r.json()["detail"][0].get("field") == field


def test_a_bad_model_is_a_422_naming_the_model_field(client):
    assert_field_error(_post(client, model(**{"jack.rod_a": 0.04})), "model.jack.rod_a")
    m = model()
    m["friction"] = {"extend": {"fc0": 1.0}, "law": "no-such-law"}
    r = _post(client, m)
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "model.friction.law"


# ---------------------------------------------------------------------------- parameter units
def test_units_serve_every_parameter_path_from_pneucore(client):
    params = client.get("/api/units").json()["parameters"]
    # every path's unit is pneucore.description.paths.unit_of's, and none is missing
    assert params and all(params[p] == unit_of(p) and params[p] for p in params), \
        [p for p in params if params[p] != unit_of(p) or not params[p]]
    for path, unit in {"jack.bore": "m", "jack.wall_area_a": "m^2", "supply.pressure": "Pa",
                       "friction.retract.kv_a": "N s/(m Pa)", "friction.extend.fc0": "N",
                       "heat.coefficient": "W/(m^2 K)", "gas.gamma": "-",
                       "valve.ports.*.C": "-"}.items():
        assert params[path] == unit, path
    for name, e in EFFECTS.items():
        for p in e.parameters:
            assert params[f"effects.{name}.{p.name}"] == p.unit


# ---------------------------------------------------------------------------- no copies in the page
def _page_sources():
    return {p.name: p.read_text(encoding="utf-8") for p in sorted((ROOT / "static").glob("*.js"))}


def test_the_page_holds_no_copy_of_the_friction_law_or_the_unit_table():
    for name, text in _page_sources().items():
        assert not re.search(r"function\s+frictionForce|frictionForce\s*=", text), name
        # a friction law: the Coulomb level or the viscous term computed from the coefficients
        assert not re.search(r"\bfc0\b[^\n]*\bfc_a\b[^\n]*\*|Math\.sign\(v\)", text), name
        assert not re.search(r"PARAM_UNITS\s*=", text), name
        # a unit table: a parameter name mapped to a unit string ("kv_a: 'N s/(m Pa)'")
        assert not re.search(r"""\b(fc0|fc_a|kv0|kv_a|bore|moving_mass|gamma)\s*:\s*['"][^'"]*['"]""",
                             text), name
        assert "'N s/(m Pa)'" not in text and "'N/Pa'" not in text, name
    # the friction map is the model view's (static/model.js), the units request app.js's shared helper
    sources = _page_sources()
    assert "/api/friction/preview" in sources["model.js"] and "/api/units" in sources["app.js"]


def test_units_serve_the_stroke_metrics_of_pneucore(client):
    """GET /api/units ``stroke``: each per-stroke metric of ``stats.stroke.strokes`` with the
    unit and definition of pneucore.analysis.strokes.STROKE_FIELDS (the page's stroke table reads its
    columns from here), and every key a simulation's strokes carry has an entry."""
    from pneucore.analysis.strokes import STROKE_FIELDS
    stroke = client.get("/api/units").json()["stroke"]
    assert stroke == {k: {"unit": u, "description": d} for k, (u, d) in STROKE_FIELDS.items()}
    assert stroke["full_stroke_time"]["unit"] == "s" and stroke["end_speed"]["unit"] == "m/s"
    sim = client.post("/api/simulate", json={
        "model": model(),
        "scenario": {"duration": 0.8, "sample_period": 1e-3, "command": [[0, 0], [0.05, 1], [0.5, -1]]}})
    assert sim.status_code == 200, sim.text
    strokes = sim.json()["stats"]["stroke"]["strokes"]
    assert strokes and all(set(s) == set(stroke) for s in strokes)
