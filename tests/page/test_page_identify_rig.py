"""The friction step of the page (static/identify.js; issue 29) reads the real rig's files as they
come, in a real headless Chromium: two files of ``shared/data/friction-bench`` (E. Zillen, TU Delft
2021, CC0: no header, ms, raw volts beside engineering units, no p_b column, the logger's time
jump) through the step's own file input -> POST /api/identify/friction/records -> identified on
the page, chamber B's coefficients shown as not determined, the same floats as the Python call on
the same files. A malformed file is named with its line next to the input.

Skipped when the data are not beside the checkout (shared/), as tests/identify/test_friction_rig.py.
"""
from __future__ import annotations

from pathlib import Path

import pytest

from pneucore.identify import identify_friction, read_bench_file
from pneucore.description.model import Model
from test_page import (_open, browser, no_script_errors, page_errors, server,  # noqa: F401
                       wait_status)

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "friction-bench"
FILES = ("O-ring_1bar.csv", "O-ring_7bar.csv")

pytestmark = pytest.mark.skipif(not (DATA / FILES[0]).exists(),
                                reason=f"friction-bench data not found at {DATA} (shared/ beside the checkout)")


@pytest.fixture(scope="module")
def page(browser, server, page_errors):  # noqa: F811
    ctx = browser.new_context(viewport={"width": 1600, "height": 1000})
    p = _open(ctx, server, page_errors)
    p.wait_for_function("() => document.getElementById('panel-identify').dataset.ready === 'true'")
    yield p
    ctx.close()


def _wait_status(page, pattern):
    return wait_status(page, pattern)


def test_the_rigs_files_as_they_come_are_read_and_identified(page):
    # the jack of the rig: a 25 mm bore (the data's README), the page's model otherwise
    page.evaluate("""() => { S.model.jack.bore = 0.025; S.model.jack.rod_a = 0; S.model.effects = {}; renderModel(); }""")
    page.set_input_files("#id-fric-rig-files", [str(DATA / f) for f in FILES])
    page.click("#btn-id-fric-rig")
    _wait_status(page, "2 rig file\\(s\\) read and chosen to fit on")
    warnings = page.eval_on_selector_all("#id-fric-rig-warnings li", "ls => ls.map(l => l.textContent)")
    assert any("no p_b column: chamber B is taken at ambient" in w for w in warnings), warnings
    assert any(w.startswith("O-ring_7bar: 8720 samples") for w in warnings), warnings
    chosen = page.eval_on_selector_all("#id-fric-fit option:checked", "os => os.map(o => o.textContent)")
    assert chosen == ["O-ring_1bar (rig file: t, x, p_a, p_b, F)", "O-ring_7bar (rig file: t, x, p_a, p_b, F)"]
    page.click("#btn-id-friction")
    _wait_status(page, "Friction identified")
    rows = {r[0]: r for r in page.eval_on_selector_all(
        "#id-fric-values tbody tr", "rs => rs.map(r => [...r.cells].map(c => c.textContent))")}
    for side in ("extend", "retract"):
        for key in ("fc_b", "kv_b"):
            name, value, unit, status = rows[f"friction.{side}.{key}"]
            assert value.endswith("(held)") and status.startswith("not determined: chamber B's gauge pressure"), rows[name]
        assert rows[f"friction.{side}.fc0"][3] != "" and "±" in rows[f"friction.{side}.fc0"][1]
    # the page's answer is the Python call's on the same files, to the last bit
    model, p_atm, got = page.evaluate("[S.model, pAtm(), IDF.friction.parameters]")
    ref = identify_friction(Model.from_dict(model), [read_bench_file(DATA / f, p_atm) for f in FILES])
    for name, p in ref.parameters.items():
        assert got[name]["value"] == p["value"] and got[name]["status"] == p["status"], name
    print(f"\npage, O-ring fitted on 1 and 7 bar: extend fc0 {got['friction.extend.fc0']['value']:.3f} "
          f"± {got['friction.extend.fc0']['se']:.3f} N, retract fc0 {got['friction.retract.fc0']['value']:.3f} "
          f"± {got['friction.retract.fc0']['se']:.3f} N")


def test_a_malformed_rig_file_is_named_with_its_line(page, tmp_path):
    lines = (DATA / FILES[0]).read_text().splitlines()[:60]
    lines[41] = lines[41].rsplit(None, 1)[0]                    # a row that lost its force
    bad = tmp_path / "cut.csv"
    bad.write_text("\n".join(lines) + "\n")
    page.set_input_files("#id-fric-rig-files", str(bad))
    page.click("#btn-id-fric-rig")
    err = page.locator(".field-error[data-error-for='identify.friction.rig']")
    err.wait_for()
    assert "cut.csv, line 42" in err.inner_text() and "6 values, the layout has 7" in err.inner_text()
    # a layout the service refuses lands next to the columns
    page.fill("#id-fric-rig-columns", "t[ms], x[furlong], p_a, F")
    page.click("#btn-id-fric-rig")
    cerr = page.locator(".field-error[data-error-for='identify.friction.columns']")
    cerr.wait_for()
    assert "unknown unit" in cerr.inner_text()
    page.fill("#id-fric-rig-columns", "")
