"""The model panel's friction map and parameter units come from the service, in a real Chromium.

The browser, the page and the error checks are the fixtures of ``tests/page/test_page.py``
(imported), with this module's own service. The friction map drawn by the page must be the
answer of POST /api/friction/preview for the page's model (the page computes no friction law),
redrawn when a coefficient changes; the friction rows and the study parameters are labelled
with the units GET /api/units serves (the page holds no unit table).

No skipping: if Playwright or Chromium is missing the tests fail loudly.
"""
from __future__ import annotations

import json
import urllib.request

import pytest

from test_page import server, browser, context, no_script_errors, page_errors, plot_data  # noqa: F401

BAR = 1e5


def _preview(server, model, pairs):
    body = json.dumps({"model": model, "pressures": [{"p_a": a * BAR, "p_b": b * BAR} for a, b in pairs]})
    req = urllib.request.Request(server + "/api/friction/preview", data=body.encode(),
                                 headers={"content-type": "application/json"}, method="POST")
    with urllib.request.urlopen(req, timeout=30) as r:
        return json.loads(r.read())


def _drawn_equals_service(page, server):
    """Each trace of the page's map is the service's curve, with the stick band at v = 0."""
    model = page.evaluate("() => S.model")
    pairs = [(1.013, 1.013), (3, 3), (5, 5), (7, 2)]   # the input's default "1.013, 3, 5, 7/2"
    ref = _preview(server, model, pairs)
    traces = plot_data(page, "friction-plot")
    assert len(traces) == len(pairs)
    for t, c in zip(traces, ref["curves"]):
        want_x, want_y = [], []
        for v, f in zip(ref["velocities"], c["force"]):
            if f is None:
                want_x += [0, 0]
                want_y += [-c["static_retract"], c["static_extend"]]
            else:
                want_x.append(v * 1e3)      # drawn in the page's velocity unit: mm/s (engineering)
                want_y.append(f)
        assert t["x"] == pytest.approx(want_x, rel=1e-12)
        assert t["y"] == pytest.approx(want_y, rel=1e-12)   # the same JSON numbers, drawn as sent
    return ref


def test_friction_map_is_the_services_answer(page, server):
    ref = _drawn_equals_service(page, server)
    assert ref["curves"][0]["static_extend"] > 0


def test_friction_map_follows_a_coefficient_and_the_stribeck_effect(page, server):
    page.evaluate("() => { window.__frictionY = JSON.stringify(Array.from(document.getElementById('friction-plot').data[0].y)); }")
    page.fill("#fric-extend-fc0", "25")   # an input event, as typing gives
    page.wait_for_function("""() => { const d = document.getElementById('friction-plot').data;
        return d && JSON.stringify(Array.from(d[0].y)) !== window.__frictionY; }""")
    ref = _drawn_equals_service(page, server)
    assert ref["curves"][0]["coulomb_extend"] == pytest.approx(25.0, rel=0.5)  # fc0 plus pressure terms
    # the Stribeck effect, which the page's old copy of the law ignored: the breakaway rises
    page.select_option("#effect-add-select", "stribeck_friction")
    top_of_band = """() => { const d = document.getElementById('friction-plot').data[0];
        return Array.from(d.y)[Array.from(d.x).lastIndexOf(0)]; }"""   # the static limit, +x
    plain = page.evaluate(top_of_band)
    page.click("#btn-add-effect")
    page.wait_for_function(f"() => ({top_of_band})() > 1.4 * {plain}")   # default ratio 1.5
    ref = _drawn_equals_service(page, server)
    assert ref["stribeck_ratio"] == 1.5
    page.click("#remove-stribeck_friction")
    page.wait_for_function(f"() => ({top_of_band})() === {plain}")


def test_a_refused_pressure_is_shown_next_to_the_input(page):
    page.fill("#friction-pressures", "0")
    slot = "#friction-pressures ~ .field-error"
    page.wait_for_function(f"() => /pressures\\[0\\]\\.p_a/.test(document.querySelector('{slot}').textContent)")
    page.fill("#friction-pressures", "1.013, 3, 5, 7/2")
    page.wait_for_function(f"() => document.querySelector('{slot}').textContent === ''")


def test_units_come_from_the_service(page, server):
    with urllib.request.urlopen(server + "/api/units", timeout=30) as r:
        params = json.loads(r.read())["parameters"]
    rows = page.evaluate("""() => Array.from(document.querySelectorAll('#friction-rows th'))
        .map(th => th.textContent)""")
    for key, text in zip(("fc0", "fc_a", "fc_b", "kv0", "kv_a", "kv_b"), rows):
        assert text.endswith(f"[{params['friction.extend.' + key]}]"), (key, text)
    for path in ("jack.bore", "friction.retract.kv_b", "effects.sensor_lag.time_constant",
                 "heat.wall_mass", "valve.ports.*.C"):
        assert page.evaluate("(p) => paramUnit(p)", path) == params[path], path
    assert page.evaluate("() => paramUnit('valve.ports.P-A.b')") == params["valve.ports.*.b"]
    assert page.evaluate("() => paramUnit('no.such.path')") == ""
