"""The circuit panel and its ISO 1219-1 schematic (static/circuit.js, static/schematic.js) in a
real headless Chromium (issue 23, item 9): the schematic draws each component the model has and
nothing it lacks, follows the model as the user edits it (the circuit panel, the effect list, a
3/2 valve's chamber B), and a hostile name or kind in the model stays text. Fixtures of
tests/page/test_page.py (imported). No skipping: if Playwright or Chromium is missing the tests
fail loudly."""
from __future__ import annotations

import pytest

from test_page import server, browser, no_script_errors, page_errors, workbench_page  # noqa: F401

HOSTILE = '<img src=x onerror="window.__pwned=1">'
# a model with every drawn component (and one effect the schematic only names)
FULL_EFFECTS = {
    "tubing": {"length_a": 2.0, "diameter_a": 0.004, "length_b": 1.5, "diameter_b": 0.006},
    "meter_out_throttle": {"C_a": 3e-9, "b_a": 0.3, "C_b": 0.0, "b_b": 0.3},
    "meter_in_throttle": {"C_a": 0.0, "b_a": 0.3, "C_b": 2e-9, "b_b": 0.3},
    "exhaust_silencer": {"C": 1e-8, "b": 0.4},
    "return_spring": {"rate": 300.0, "preload": 20.0},
    "piston_leakage": {"conductance": 1e-11},
}


@pytest.fixture(scope="module")
def page(browser, server, page_errors):  # noqa: F811
    yield from workbench_page(browser, server, page_errors)


def _ids(page):
    """The ids of the schematic's symbol groups now on the page."""
    return set(page.evaluate("() => Array.from(document.querySelectorAll('#schematic svg g.schem-symbol')).map(g => g.id)"))


def _title(page, gid):
    return page.evaluate("(id) => document.getElementById(id).querySelector(':scope > title').textContent", gid)


def _load_preset(page, name):
    page.evaluate("setStatus('', 'info')")
    page.select_option("#model-preset", name)
    page.click("#btn-load-preset")
    page.wait_for_function("(n) => S.model && document.getElementById('status-msg').textContent.includes(n)", arg=name)


def _paste_model(page, model_js):
    """A model given as a JS expression over the current S.model, brought in through the
    model panel's "paste JSON" (checked by the service, then the page's model-change path)."""
    text = page.evaluate(f"() => {{ const m = JSON.parse(JSON.stringify(S.model)); {model_js}; return JSON.stringify(m); }}")
    if not page.evaluate("() => document.getElementById('model-io').open"):
        page.click("#model-io summary")
    page.fill("#model-json", text)
    page.evaluate("setStatus('', 'info')")
    page.click("#btn-model-json")
    page.wait_for_function("() => document.getElementById('status').classList.contains('ok')"
                           " || document.getElementById('status').classList.contains('error')")
    assert "loaded" in page.inner_text("#status-msg"), page.inner_text("#status")


def test_the_preset_is_a_4_2_valve_and_a_double_acting_cylinder(page):
    _load_preset(page, "paper-4way")
    svg = page.locator("#schematic svg")
    assert svg.get_attribute("data-valve") == "4/2"
    assert svg.get_attribute("data-cylinder") == "double-acting"
    ids = _ids(page)
    assert {"schem-cylinder", "schem-valve", "schem-supply", "schem-exhaust", "schem-line-a", "schem-line-b",
            "schem-angle"} <= ids
    # the paper's jack has no circuit component: none drawn
    assert not [i for i in ids if i.startswith(("schem-tube", "schem-meter", "schem-silencer", "schem-spring",
                                                 "schem-cushion", "schem-b-"))]
    assert "4/2 proportional directional control valve" in _title(page, "schem-valve")
    # the supply's pressure in the page's units (engineering by default: 7e5 Pa = 7 bar abs)
    assert "7 bar abs" in _title(page, "schem-supply")
    # a 4/2 valve: two boxes, four flow arrows (P-A and B-R actuated, P-B and A-R at rest)
    assert page.locator("#schem-valve rect").count() == 3      # two boxes and the solenoid
    # four arrows' shafts and the solenoid's diagonal, and the paper's valve is proportional (its
    # tables give C at five openings): two lines along the envelope and the solenoid's arrow
    assert page.locator("#schem-valve line").count() == 5 + 3
    assert svg.get_attribute("data-proportional") == "true"


def test_every_component_of_the_model_is_drawn(page):
    _load_preset(page, "paper-4way")
    import json
    _paste_model(page, f"m.effects = {json.dumps(FULL_EFFECTS)}; m.jack.mounting_angle = 30")
    ids = _ids(page)
    assert {"schem-tube-a", "schem-tube-b", "schem-meter-out-a", "schem-meter-in-b", "schem-silencer",
            "schem-spring"} <= ids
    # a zero conductance is no flow control on that port
    assert "schem-meter-out-b" not in ids and "schem-meter-in-a" not in ids
    # the tube's label, in the page's units (mm): 2 m long, 4 mm bore on A
    assert "tube 2000 mm" in page.text_content("#schem-tube-a")
    assert "4 mm" in page.text_content("#schem-tube-a")
    assert "1500 mm" in page.text_content("#schem-tube-b") and "6 mm" in page.text_content("#schem-tube-b")
    assert "meter-out 0.3 dm³/(s bar)" in page.text_content("#schem-meter-out-a")   # 3e-9 m^3/(s Pa)
    assert "One-way flow control" in _title(page, "schem-meter-out-a")
    # the check valve lets air into the chamber for meter-out (its ball above the seat's apex:
    # the chamber is up) and out of it for meter-in
    ball_vs_apex = page.evaluate("""(id) => { const g = document.getElementById(id);
        return Number(g.querySelector('.schem-check-ball').getAttribute('cy'))
             - Number(g.querySelector('.schem-check-seat').dataset.apexY); }""", "schem-meter-out-a")
    assert ball_vs_apex < 0
    ball_vs_apex = page.evaluate("""(id) => { const g = document.getElementById(id);
        return Number(g.querySelector('.schem-check-ball').getAttribute('cy'))
             - Number(g.querySelector('.schem-check-seat').dataset.apexY); }""", "schem-meter-in-b")
    assert ball_vs_apex > 0
    assert "Silencer" in _title(page, "schem-silencer") and "0.4" in _title(page, "schem-silencer")
    assert "rate 300 N/m" in _title(page, "schem-spring")
    assert "Mounting angle 30 deg" in _title(page, "schem-angle")
    # an effect with no symbol is named, not dropped
    assert "piston_leakage" in page.text_content("#schem-others")
    # the circuit panel shows the same values (in its units) as the model holds
    assert page.input_value("#circ-tubing-length_a") == "2000"
    assert page.input_value("#circ-meter_in_throttle-C_b") == "0.2"
    assert page.input_value("#circ-meter_out_throttle-C_b") == "0"


def test_a_tube_typed_into_the_circuit_panel_changes_the_schematic(page):
    _load_preset(page, "paper-4way")
    assert "schem-tube-a" not in _ids(page)
    assert page.is_disabled("#circ-tubing-diameter_a")   # a bore alone is no tube
    before = page.inner_html("#schematic")
    page.fill("#circ-tubing-length_a", "1500")       # mm (engineering units)
    tube = page.evaluate("() => S.model.effects.tubing")
    # added with port B off, A's bore at its catalog default; the effect list shows it
    assert tube["length_a"] == pytest.approx(1.5) and tube["length_b"] == 0.0
    assert page.locator("#effect-tubing").count() == 1
    assert page.input_value("#eff-tubing-length_a") == "1500"   # the effect list in mm too
    ids = _ids(page)
    assert "schem-tube-a" in ids and "schem-tube-b" not in ids
    assert page.inner_html("#schematic") != before
    assert page.is_enabled("#circ-tubing-diameter_a")
    assert "1500 mm" in page.text_content("#schem-tube-a")
    # a new bore redraws the label
    page.fill("#circ-tubing-diameter_a", "6")
    assert page.evaluate("() => S.model.effects.tubing.diameter_a") == pytest.approx(0.006)
    assert "6 mm" in page.text_content("#schem-tube-a")
    # the line's segments (a catalog parameter of both ports): shown at its default, 1 (lumped)
    assert page.is_enabled("#circ-tubing-segments")
    assert page.input_value("#circ-tubing-segments") == "1"
    page.fill("#circ-tubing-segments", "6")
    assert page.evaluate("() => S.model.effects.tubing.segments") == 6
    # the model is one the service takes (the effect as the catalog defines it)
    assert page.evaluate("async () => { await api('POST', '/api/calibrate/parameters', {model: S.model}); return true; }")
    # emptied, the port is off again: every port off removes the effect and its symbol
    page.fill("#circ-tubing-length_a", "")
    assert page.evaluate("() => 'tubing' in S.model.effects") is False
    assert page.locator("#effect-tubing").count() == 0
    assert "schem-tube-a" not in _ids(page)


def test_an_effect_added_from_the_effect_list_is_drawn(page):
    _load_preset(page, "paper-4way")
    page.select_option("#effect-add-select", "meter_out_throttle")
    page.click("#btn-add-effect")
    ids = _ids(page)
    assert {"schem-meter-out-a", "schem-meter-out-b"} <= ids    # the catalog default: both ports
    assert page.input_value("#circ-meter_out_throttle-C_a") == "0.3"
    # an edit in the effect list redraws the schematic and the circuit field
    page.fill("#eff-meter_out_throttle-C_b", "0")
    assert "schem-meter-out-b" not in _ids(page)
    assert page.input_value("#circ-meter_out_throttle-C_b") == "0"


def test_a_3_2_valve_with_a_spring_return_single_acting_cylinder(page):
    _load_preset(page, "paper-3way")
    page.select_option("#valve-b_chamber", "vented")
    page.fill("#circ-return_spring-rate", "400")
    svg = page.locator("#schematic svg")
    assert svg.get_attribute("data-valve") == "3/2"
    assert svg.get_attribute("data-cylinder") == "single-acting"
    ids = _ids(page)
    assert {"schem-spring", "schem-b-vent", "schem-line-a"} <= ids
    assert "schem-line-b" not in ids                  # chamber B is not on the valve
    assert "3/2 directional control valve" in _title(page, "schem-valve")
    # the paper's 3/2 valve switches (its tables are a step over 1 % of the travel): no marking
    assert svg.get_attribute("data-proportional") == "false" and "schem-proportional" not in ids
    assert "Single-acting cylinder" in _title(page, "schem-cylinder")
    assert page.evaluate("() => S.model.effects.return_spring") == {"rate": 400.0, "preload": 0.0}
    # a 3/2 valve: two flow arrows and two blocked ports (P at rest, R actuated)
    assert page.locator("#schem-valve line").count() == 2 + 4 + 1   # arrows, the blocked ports' Ts, the solenoid's diagonal
    # chamber B closed: an air spring, double-acting again, the port plugged
    page.select_option("#valve-b_chamber", "closed")
    assert svg.get_attribute("data-cylinder") == "double-acting"
    assert "schem-b-closed" in _ids(page) and "schem-b-vent" not in _ids(page)


def test_end_cushions_and_unknown_shapes_in_the_drawing_function(page):
    """The end_cushion effect (issue 23 item 4) drawn from its expected shape, through the pure
    function; a shape it does not know is named and does not break the drawing."""
    res = page.evaluate("""() => {
        const ids = (svg) => Array.from(svg.querySelectorAll('g.schem-symbol')).map(g => g.id);
        const m = JSON.parse(JSON.stringify(S.model));
        m.effects = {end_cushion: {length_a: 0.015, volume_a: 2e-6, conductance_a: 1e-10,
                                   length_b: 0, volume_b: 0, conductance_b: 0}};
        const one = ids(drawSchematic(m));
        m.effects = {end_cushion: {length_a: 0.015, length_b: 0.02}};
        const two = ids(drawSchematic(m));
        m.effects = {end_cushion: {needle: 3}, tubing: 'not an object', future_effect: {x: 1}};
        const odd = drawSchematic(m);
        return {one, two, odd: ids(odd), others: odd.querySelector('#schem-others').textContent};
    }""")
    assert "schem-cushion-a" in res["one"] and "schem-cushion-b" not in res["one"]
    assert {"schem-cushion-a", "schem-cushion-b"} <= set(res["two"])
    assert not [i for i in res["odd"] if i.startswith(("schem-cushion", "schem-tube"))]
    assert "future_effect" in res["others"]


def test_a_flow_control_with_a_volume_is_drawn_at_the_cylinder_port(page):
    """A meter-out control with the volume between it and the valve (issue 43 item 5,
    physics.flow_control) is drawn between the cylinder and the tube, its volume named; one in
    series with the valve's edge stays between the tube and the valve."""
    _load_preset(page, "paper-4way")
    res = page.evaluate("""() => {
        const m = JSON.parse(JSON.stringify(S.model));
        m.effects = {tubing: {length_a: 2.0, diameter_a: 0.004, length_b: 2.0, diameter_b: 0.004},
                     meter_out_throttle: {C_a: 3e-9, b_a: 0.3, C_b: 3e-9, b_b: 0.3,
                                          volume_a: 1.5e-5, volume_b: 0}};
        const svg = drawSchematic(m);
        const y = (id) => Number(svg.querySelector('#' + id + ' line').getAttribute('y1'));
        const title = (id) => svg.querySelector('#' + id + ' > title').textContent;
        return {a: y('schem-meter-out-a') - y('schem-tube-a'), b: y('schem-meter-out-b') - y('schem-tube-b'),
                ta: title('schem-meter-out-a'), tb: title('schem-meter-out-b'),
                text: svg.querySelector('#schem-meter-out-a').textContent};
    }""")
    assert res["a"] < 0 < res["b"]           # A: above the tube (the cylinder's side); B: below
    assert "at the cylinder's port" in res["ta"] and "between it and the valve" in res["ta"]
    assert "in series with the valve's edge" in res["tb"]
    # loaded into the page, the labels in the page's units
    _paste_model(page, "m.effects = {meter_out_throttle: {C_a: 3e-9, b_a: 0.3, C_b: 0, b_b: 0.3, "
                       "volume_a: 1.5e-5, volume_b: 0}}")
    assert "V 15 cm³" in page.text_content("#schem-meter-out-a")          # 1.5e-5 m^3
    assert "15 cm³ between it and the valve" in _title(page, "schem-meter-out-a")


def test_hostile_text_in_the_model_never_becomes_markup(page):
    _load_preset(page, "paper-4way")
    res = page.evaluate("""(h) => {
        S.model.effects[h] = {x: 1};
        S.model.valve.kind = '<script>window.__pwned=2</script>' + h;
        S.model.description = h;
        renderEffects();                           // the page's model-change path
        const svg = document.querySelector('#schematic svg');
        return {markup: svg.querySelectorAll('img, script, foreignObject, iframe').length,
                others: svg.querySelector('#schem-others').textContent,
                valve: svg.getAttribute('data-valve'),
                pwned: window.__pwned === undefined ? null : window.__pwned};
    }""", HOSTILE)
    assert res["markup"] == 0
    assert HOSTILE in res["others"]               # shown as the text it is
    assert res["valve"].startswith("<script>")
    assert res["pwned"] is None
    assert "<img" in _title(page, "schem-valve")  # the unknown kind is named as text
    _load_preset(page, "paper-4way")


def test_the_stroke_metrics_table_next_to_the_plots(page):
    """A full extension then a full retraction: a row per valve switching in the plots panel,
    each metric of stats.stroke.strokes in its column, in the page's units (speeds in mm/s in
    the engineering system), the columns and units as GET /api/units gives them."""
    _load_preset(page, "paper-4way")
    page.click("#btn-fig10")
    # Fig. 10 is also the page's first scenario, so its name alone does not say the load ended: the
    # button is disabled while it runs (a command typed before it ends would be overwritten)
    page.wait_for_function("() => S.scenario && S.scenario.name === 'paper-fig10-pulses'"
                           " && !document.getElementById('btn-fig10').disabled")
    page.fill("#scn-command", "0, 0\n0.05, 1\n0.5, -1")
    before = int(page.get_attribute("#panel-plots", "data-runs") or 0)
    page.click("#btn-simulate")
    page.wait_for_function(f"() => Number(document.getElementById('panel-plots').dataset.runs || 0) > {before}")
    strokes = page.evaluate("() => S.sim.stats.stroke.strokes")
    units = page.evaluate("() => S.units.stroke")
    table = page.locator("#stroke-table #stroke-metrics")
    assert table.locator("tbody tr").count() == len(strokes) >= 2
    heads = table.locator("thead th").all_inner_texts()
    assert len(heads) == len(units)
    assert "full stroke time [s]" in heads and "end speed [mm/s]" in heads and "air NL [NL]" in heads
    ext = next(i for i, s in enumerate(strokes) if s["direction"] == "extend")
    row = table.locator("tbody tr").nth(ext)
    assert row.get_attribute("data-direction") == "extend"
    cell = lambda m: row.locator(f"td[data-metric='{m}']").inner_text()  # noqa: E731
    # shown to 4 significant digits: the relative tolerance is half a unit of the 4th digit
    assert float(cell("full_stroke_time")) == pytest.approx(strokes[ext]["full_stroke_time"], rel=5e-4)
    assert float(cell("end_speed")) == pytest.approx(strokes[ext]["end_speed"] / 1e-3, rel=5e-4)   # m/s -> mm/s
    assert float(cell("air_NL")) == pytest.approx(strokes[ext]["air_NL"], rel=5e-4)


def _jack_angle(page, svg_js="document.querySelector('#schematic svg')"):
    """The angle [deg] the jack is drawn at on the page, counter-clockwise from the horizontal,
    from the rotation its group applies (the SVG's own transform matrix)."""
    return page.evaluate(f"""() => {{ const m = {svg_js}.querySelector('#schem-jack').transform.baseVal.consolidate().matrix;
        return Math.atan2(-m.b, m.a) * 180 / Math.PI; }}""")


def test_proportional_marking_silencer_and_the_cylinder_at_its_angle(page):
    """ISO 1219-1 as described in the sources named in static/schematic.js: a proportional
    valve's two lines along the envelope's long sides and its solenoid's arrow; the silencer a
    square at 45 deg on its port; the cylinder drawn at the mounting angle, inside the drawing."""
    _load_preset(page, "paper-4way")
    _paste_model(page, "m.effects = {exhaust_silencer: {C: 1e-8, b: 0.4}}; m.jack.mounting_angle = 30")
    svg = page.locator("#schematic svg")
    assert svg.get_attribute("data-proportional") == "true" and svg.get_attribute("data-angle") == "30"
    assert "proportional directional control valve" in _title(page, "schem-valve")
    geo = page.evaluate("""() => {
        const box = Array.from(document.querySelectorAll('#schem-valve > rect')).map(r => r.getBBox())
            .map(b => ({x: b.x, y: b.y, width: b.width, height: b.height}));
        const lines = Array.from(document.querySelectorAll('#schem-proportional .schem-proportional-line'))
            .map(l => ['x1', 'y1', 'x2', 'y2'].map(k => Number(l.getAttribute(k))));
        const body = document.querySelector('#schem-silencer .schem-silencer-body').getAttribute('d');
        const exhaust = document.querySelector('#schem-exhaust line');
        return {box, lines, body, exhaustX: Number(exhaust.getAttribute('x1')),
                exhaustEnd: Number(exhaust.getAttribute('y2')),
                arrow: document.querySelectorAll('#schem-proportional .schem-proportional-arrow').length};
    }""")
    top = min(b["y"] for b in geo["box"][:2])
    bottom = max(b["y"] + b["height"] for b in geo["box"][:2])
    left = min(b["x"] for b in geo["box"][:2])
    right = max(b["x"] + b["width"] for b in geo["box"][:2])
    assert len(geo["lines"]) == 2 and geo["arrow"] == 1
    for x1, y1, x2, y2 in geo["lines"]:
        assert y1 == y2 and (x1, x2) == (left, right)       # parallel to the long sides, as long
        assert y1 < top or y1 > bottom                      # outside the boxes, one each side
    assert {y1 < top for _, y1, _, _ in geo["lines"]} == {True, False}
    # the silencer: four vertices, the top one on the exhaust line's end, equal half-diagonals
    pts = [tuple(map(float, p.split(","))) for p in geo["body"].replace("M", "").replace("Z", "").split(" L")]
    assert len(pts) == 4
    assert pts[0] == (geo["exhaustX"], geo["exhaustEnd"])
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    assert max(xs) - min(xs) == max(ys) - min(ys)           # a square standing on a corner
    # the jack drawn at 30 deg (float round-off of the SVG matrix: 1e-6 deg), and the rotated
    # jack lies inside the drawing (its screen box inside the svg's)
    assert _jack_angle(page) == pytest.approx(30.0, abs=1e-6)
    inside = page.evaluate("""() => { const s = document.querySelector('#schematic svg').getBoundingClientRect();
        const j = document.querySelector('#schem-jack').getBoundingClientRect();
        return j.top >= s.top && j.bottom <= s.bottom && j.left >= s.left && j.right <= s.right; }""")
    assert inside
    assert "30°" in page.text_content("#schem-angle")
    # the ports stay joined to their working lines: a join per port, ending where the line starts
    assert page.locator("#schem-port-joins .schem-port-join").count() == 2
    # vertical, rod down, and back to horizontal
    for ang in (90, -90, 0):
        _paste_model(page, f"m.jack.mounting_angle = {ang}")
        assert _jack_angle(page) == pytest.approx(ang, abs=1e-6)
    _load_preset(page, "paper-4way")


def test_hostile_text_and_numbers_in_the_new_symbols_stay_text(page):
    res = page.evaluate("""(h) => {
        const m = JSON.parse(JSON.stringify(S.model));
        m.jack.mounting_angle = h;                        // not a number: drawn horizontal
        m.effects = {exhaust_silencer: {C: h, b: 0.4}, [h]: {x: 1}};
        m.valve.ports[h] = {opening: [0, 0.5, 1], C: [h, h, h], b: [0.3, 0.3, 0.3]};
        const svg = drawSchematic(m);
        document.body.appendChild(svg);
        const out = {markup: svg.querySelectorAll('img, script, foreignObject, iframe').length,
                     angle: svg.getAttribute('data-angle'), prop: svg.getAttribute('data-proportional'),
                     transform: svg.querySelector('#schem-jack').getAttribute('transform'),
                     others: svg.querySelector('#schem-others').textContent,
                     pwned: window.__pwned === undefined ? null : window.__pwned};
        svg.remove();
        return out;
    }""", HOSTILE)
    assert res["markup"] == 0 and res["pwned"] is None
    assert res["angle"] == "0" and "NaN" not in res["transform"]
    assert res["prop"] == "true"                          # a table of three openings, whatever its name
    assert HOSTILE in res["others"]
