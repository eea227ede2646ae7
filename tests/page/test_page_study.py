"""Panel 6 of the page (robustness studies) driven like a user would, in a real headless Chromium.

The browser, the page and the error checks are the fixtures of ``tests/page/test_page.py``
(imported). The service fixture is this module's own: its database is seeded, before
the service starts, with a grid study stopped after its first batch (status
``interrupted``) so that the page's Resume button can be exercised.

Tests share one page and run in file order: the controls and their units, a 40-run
Monte Carlo on the Fig. 10 pulses shortened to 0.3 s (progress, histogram, scatter,
percentile table, sensitivity ranking checked against the API's own results), a
negative std refused next to its row, a scheduler address refused next to the
cluster input at once (requests name a configured cluster, never an address), the runs
downloadable as CSV, a grid checked before sending, resuming the interrupted
study, loading a previous study, then a screenshot of the panel in
``artifacts/study.png``.

No skipping: if Playwright or Chromium is missing the tests fail loudly.
"""
from __future__ import annotations

import json
import sys
import time
import urllib.request

import pytest
from service import running_service

from test_page import (ARTIFACTS, ROOT, _open, browser, click_and_wait_for_plot,  # noqa: F401
                       context, no_script_errors, page_errors, plot_data)

if str(ROOT) not in sys.path:  # pneucore seeds the database from this process
    sys.path.insert(0, str(ROOT))

SWEEP_ID = "sweep-interrupted"
#: the stroke metrics of the user's circuit (issue 23; SMC's definitions)
STROKE_METRICS = ("start_up_time", "full_stroke_time_extend", "full_stroke_time_retract",
                  "mean_speed", "max_speed", "end_speed_max", "air_per_cycle", "end_energy_max",
                  "energy_ratio_max")
METRICS = ("x_final", "x_max", "x_min", "t95", "overshoot", "settling_time", "p_a_max", "p_b_max",
           "T_max", "T_min", "stick_events", "air_consumption") + STROKE_METRICS
#: metric -> unit shown by the page (SI converted like the rest of the page)
SHOWN_UNITS = {"x_final": "mm", "t95": "s", "p_a_max": "bar abs", "T_max": "°C", "stick_events": "-",
               "air_consumption": "NL"}


def _seed_interrupted_study(db):
    """A 4 x 5 grid study stored in ``db``, stopped after its first batch of 5 runs."""
    from pneucore import model_preset, scenario_preset
    from pneucore.study import run_study

    scenario = scenario_preset("paper-fig10-pulses")
    scenario["duration"] = 0.3
    study = {"model": model_preset("paper-4way"), "scenario": scenario, "name": "interrupted sweep",
             "parameters": {"heat.coefficient": {"grid": [10, 25, 40, 60]},
                            "jack.moving_mass": {"grid": [1.5, 2, 2.5, 3, 3.5]}}}

    class Stop(Exception):
        pass

    def stop_after_first_batch(fraction, step):
        if fraction > 0:
            raise Stop(step)

    with pytest.raises(Stop):
        run_study(study, str(db), workers=0, batch_size=5, progress=stop_after_first_batch,
                  study_id=SWEEP_ID)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """The service on a free port, its database holding one interrupted study; yields its base URL."""
    tmp = tmp_path_factory.mktemp("study-page")
    db = tmp / "page.sqlite3"
    _seed_interrupted_study(db)
    with running_service(tmp, db) as url:
        yield url


@pytest.fixture(scope="module")
def state():
    """Values handed from one test to the next (the Monte Carlo study's id)."""
    return {}


@pytest.fixture(scope="module", autouse=True)
def si_units(page):
    """These tests type and read SI values (Pa): the page's unit system set to SI once (the
    study panel follows the chosen system: tests/page/test_page_designer.py)."""
    page.select_option("#unit-system", "si")
    page.wait_for_function("() => document.body.dataset.units === 'si'")


def get_json_runs(page, sid):
    """The stored study's per-run metrics, as the page holds them from the API."""
    return page.evaluate("S.study.res.runs.metrics")


def get_json(server, path):
    with urllib.request.urlopen(server + path, timeout=10) as r:
        return json.load(r)


def set_row(page, i, path, kind, **values):
    """Parameter row ``i``: pick the path and the kind, then type the values (SI units)."""
    page.select_option(f"#sp-{i}-path", path)
    page.select_option(f"#sp-{i}-kind", kind)
    for key, v in values.items():
        page.fill(f"#sp-{i}-{key}", str(v))


def wait_for_study(page, timeout=120_000):
    """Wait until the followed study is done and its results are drawn (or the status shows an error)."""
    page.wait_for_function("""() => document.getElementById('study-progress').dataset.done === 'true'
        || document.getElementById('status').classList.contains('error')""", timeout=timeout)
    assert page.get_attribute("#study-progress", "data-done") == "true", page.inner_text("#status")
    study_id = page.get_attribute("#study-progress", "data-study")
    page.wait_for_function(f"""() => document.getElementById('study-results').dataset.studyId === '{study_id}'
        && /done/.test(document.getElementById('status').textContent)""")
    return study_id


def axis_titles(page, div_id):
    return page.evaluate("""(id) => { const l = document.getElementById(id).layout;
        return [l.xaxis.title.text, l.yaxis.title.text]; }""", div_id)


def table_rows(page):
    """The percentile table as {metric: [cells...]}."""
    return page.evaluate("""() => Object.fromEntries(Array.from(document.querySelectorAll('#study-table-data tbody tr'))
        .map(tr => [tr.dataset.metric, Array.from(tr.children).map(c => c.textContent.trim())]))""")


# --------------------------------------------------------------------------- tests
def test_panel_controls_have_units(page):
    assert page.locator("#panel-study .study-param").count() == 2       # a starting Monte Carlo
    page.click("#btn-study-add")
    assert page.locator("#panel-study .study-param").count() == 3
    # the unit follows the parameter: Pa for the supply, N s/m for kv0, a scale factor for the valve
    set_row(page, 2, "supply.pressure", "normal")
    assert page.inner_text("label[for='sp-2-std']") == "std [Pa]"
    assert "(optional)" in page.inner_text("label[for='sp-2-min']")
    assert page.input_value("#sp-2-mean") == "700000", "prefilled from the current model"
    set_row(page, 2, "friction.extend.kv0", "lognormal")
    assert page.inner_text("label[for='sp-2-median']") == "median [N s/m]"
    assert page.inner_text("label[for='sp-2-sigma']").startswith("sigma of ln x [-]")
    set_row(page, 2, "valve.ports.*.C", "grid")
    assert page.inner_text("label[for='sp-2-grid']").startswith("values [-]")
    assert "scale factor" in page.inner_text("#study-param-2")
    page.fill("#sp-2-grid", "0.8, 1, 1.2")
    # a path outside the list is typed; its unit is still known
    page.select_option("#sp-2-path", "__custom__")
    page.fill("#sp-2-custom", "jack.bore")
    page.press("#sp-2-custom", "Tab")
    assert page.inner_text("label[for='sp-2-grid']").startswith("values [m]")
    assert page.get_attribute("#study-param-2", "data-field") == "parameters.jack.bore"
    # every control of the panel is labelled, with a unit
    missing = page.evaluate("""() => Array.from(document.querySelectorAll('#panel-study input, #panel-study select'))
        .filter(e => !e.labels || e.labels.length === 0 ||
                     !Array.from(e.labels).some(l => /\\[[^\\]]+\\]/.test(l.textContent)))
        .map(e => e.id)""")
    assert missing == []
    page.click("#sp-2-remove")
    assert page.locator("#panel-study .study-param").count() == 2


def test_monte_carlo_study_runs_and_shows_results(page, server, state):
    click_and_wait_for_plot(page, "#btn-fig10")
    page.fill("#scn-duration", "0.3")
    set_row(page, 0, "friction.extend.fc0", "uniform", min=4, max=16)
    set_row(page, 1, "supply.pressure", "normal", mean="6e5", std="4e4", min="4.5e5", max="7.5e5")
    page.fill("#study-samples", "40")
    page.fill("#study-seed", "1")
    page.fill("#study-scheduler", "")
    assert "40 runs" in page.inner_text("#study-nruns")
    page.click("#btn-study-run")
    sid = wait_for_study(page)
    state["mc"] = sid

    # the progress bar completed: 40 of 40 runs stored
    assert page.evaluate("document.getElementById('study-progress').max") == 40
    assert page.evaluate("document.getElementById('study-progress').value") == 40
    assert page.inner_text("#study-progress-text") == "40/40"
    assert "40/40 runs stored" in page.inner_text("#study-summary")
    # the runs download as CSV from the summary's link: 40 rows, units in the headers
    href = page.get_attribute("#study-csv", "href")
    with urllib.request.urlopen(server + href) as r:
        lines = r.read().decode().splitlines()
    assert len(lines) == 41 and "supply.pressure [Pa]" in lines[0] and "t95 [s]" in lines[0]
    # ... and as a NumPy archive from the link beside it
    import io

    import numpy as np
    with urllib.request.urlopen(server + page.get_attribute("#study-npz", "href")) as r:
        z = np.load(io.BytesIO(r.read()))
    assert z["params"].shape[0] == 40 and "t95" in z["metric_names"].tolist()

    api = get_json(server, f"/api/studies/{sid}/results")
    assert api["stored"] == 40 and api["failed"] == 0
    assert api["definition"]["scenario"]["duration"] == 0.3

    # histogram of t95: the 40 values of the API, in seconds
    assert page.input_value("#study-metric") == "t95"
    hist = plot_data(page, "study-hist")
    assert len(hist) == 1 and len(hist[0]["x"]) == 40
    assert sorted(hist[0]["x"]) == pytest.approx(sorted(api["runs"]["metrics"]["t95"]))
    assert page.get_attribute("#study-hist", "data-count") == "40"
    assert axis_titles(page, "study-hist") == ["t95 [s]", "runs [-]"]

    # the ranking: both parameters, the method stated; a higher supply pressure extends faster
    ranking = page.inner_text("#study-ranking")
    assert "supply.pressure" in ranking and "friction.extend.fc0" in ranking
    assert page.get_attribute("#study-method", "data-method") == "prcc"
    assert "Method: partial rank correlation (PRCC)" in ranking and "Marino" in ranking
    order = page.evaluate("""() => Array.from(document.querySelectorAll('#study-ranking-data tbody tr'))
        .map(tr => tr.dataset.parameter)""")
    assert order == ["supply.pressure", "friction.extend.fc0"]
    prcc = float(page.inner_text("#study-ranking-data tbody tr:first-child td:nth-child(3)"))
    assert prcc < -0.5

    # the scatter: t95 against the top-ranked parameter (its unit on the axis), one point per run
    assert page.input_value("#study-xparam") == "supply.pressure"
    sc = plot_data(page, "study-scatter")[0]
    assert len(sc["x"]) == 40 and all(4.5e5 <= x <= 7.5e5 for x in sc["x"])
    assert axis_titles(page, "study-scatter") == ["supply.pressure [Pa]", "t95 [s]"]
    page.click("#study-ranking-data tr[data-parameter='friction.extend.fc0']")
    assert page.input_value("#study-xparam") == "friction.extend.fc0"
    sc = plot_data(page, "study-scatter")[0]
    assert len(sc["x"]) == 40 and all(4 <= x <= 16 for x in sc["x"])
    assert axis_titles(page, "study-scatter")[0] == "friction.extend.fc0 [N]"

    # the results in the engineering units (the parameters were typed in SI)
    page.select_option("#unit-system", "engineering")
    page.wait_for_function("() => document.body.dataset.units === 'engineering'")
    assert axis_titles(page, "study-scatter")[0] == "friction.extend.fc0 [N]"
    # the percentile table: every metric, its unit, 40 runs; the median matches the API
    rows = table_rows(page)
    assert list(rows) == list(METRICS)
    for name, unit in SHOWN_UNITS.items():
        assert rows[name][1] == unit, (name, rows[name])
    # 40 runs each; the stroke metrics are undefined for pulses that reach no end of stroke
    assert all(rows[m][-1] == "40" for m in METRICS if m not in STROKE_METRICS)
    heads = page.evaluate("Array.from(document.querySelectorAll('#study-table-data thead th')).map(t => t.textContent)")
    assert heads[5:10] == ["5 %", "25 %", "50 %", "75 %", "95 %"]
    assert float(rows["t95"][7]) == pytest.approx(api["metrics"]["t95"]["percentiles"]["50"], rel=1e-3)
    assert float(rows["p_a_max"][7]) == pytest.approx(api["metrics"]["p_a_max"]["percentiles"]["50"] / 1e5, rel=1e-3)

    # another metric: from the selector or from the table
    page.select_option("#study-metric", "p_a_max")
    assert axis_titles(page, "study-hist")[0] == "p_a_max [bar abs]"
    assert "p_a_max" in page.inner_text("#study-ranking")
    page.click("#study-table-data tr[data-metric='x_final'] th")
    assert page.input_value("#study-metric") == "x_final"
    assert axis_titles(page, "study-scatter")[1] == "x_final [mm]"

    # the list of stored studies shows it, done
    row = page.locator(f"#study-row-{sid}")
    assert row.get_attribute("data-status") == "done"
    assert "40/40" in row.inner_text()
    assert "status ok" in page.get_attribute("#status", "class")
    page.select_option("#unit-system", "si")      # the next tests type SI values again
    page.wait_for_function("() => document.body.dataset.units === 'si'")


def test_negative_std_is_reported_next_to_its_row(page, server):
    n_before = len(get_json(server, "/api/studies"))
    page.fill("#sp-1-std", "-4e4")
    page.click("#btn-study-run")
    err = page.locator(".field-error[data-error-for='parameters.supply.pressure.std']")
    err.wait_for()
    assert "> 0" in err.inner_text()
    # in the std's own field, inside the supply.pressure row; the input is flagged
    placed = page.evaluate("""() => {
        const e = document.querySelector(".field-error[data-error-for='parameters.supply.pressure.std']");
        return [document.getElementById('study-param-1').contains(e),
                document.getElementById('sp-1-std').closest('.field').contains(e),
                document.getElementById('study-param-0').contains(e)]; }""")
    assert placed == [True, True, False]
    assert page.get_attribute("#sp-1-std", "aria-invalid") == "true"
    assert "error" in page.get_attribute("#status", "class")
    assert "parameters.supply.pressure.std" in page.inner_text("#status-errors")
    assert len(get_json(server, "/api/studies")) == n_before, "a refused study must not be stored"
    page.fill("#sp-1-std", "4e4")
    assert err.count() == 0
    assert page.get_attribute("#sp-1-std", "aria-invalid") is None


def test_scheduler_address_is_refused_next_to_its_input(page):
    page.fill("#study-scheduler", "tcp://127.0.0.1:1")
    t0 = time.monotonic()
    page.click("#btn-study-run")
    err = page.locator(".field-error[data-error-for='scheduler']")
    err.wait_for(timeout=20_000)
    elapsed = time.monotonic() - t0
    # no connection is even tried: the refusal is immediate (15 s bounds a loaded machine)
    assert elapsed < 15, f"the refusal took {elapsed:.1f} s"
    assert "unknown cluster" in err.inner_text() and "'local'" in err.inner_text()
    assert page.evaluate("""() => document.getElementById('study-scheduler').closest('.field')
        .contains(document.querySelector(".field-error[data-error-for='scheduler']"))""")
    assert page.get_attribute("#study-scheduler", "aria-invalid") == "true"
    assert page.locator("#study-param-rows .field-error:not(:empty)").count() == 0
    page.fill("#study-scheduler", "")
    assert err.count() == 0


def test_grid_values_are_checked_before_sending(page):
    page.select_option("#sp-0-kind", "grid")
    page.fill("#sp-0-grid", "4, 8, x")
    page.click("#btn-study-run")
    err = page.locator("#study-param-0 .field-error:not(:empty)")
    assert '"x" is not a number' in err.first.inner_text()
    assert page.get_attribute("#sp-0-grid", "aria-invalid") == "true"
    page.fill("#sp-0-grid", "4, 8, 12")
    assert err.count() == 0
    assert "3 grid points × 40 samples = 120 runs" in page.inner_text("#study-nruns")
    set_row(page, 0, "friction.extend.fc0", "uniform", min=4, max=16)
    assert "40 runs" in page.inner_text("#study-nruns")


def test_resume_the_interrupted_study(page):
    row = page.locator(f"#study-row-{SWEEP_ID}")
    assert row.get_attribute("data-status") == "interrupted"
    assert "5/20" in row.inner_text()
    page.click(f"#study-resume-{SWEEP_ID}")
    assert wait_for_study(page) == SWEEP_ID
    assert page.inner_text("#study-progress-text") == "20/20"
    assert "interrupted sweep" in page.inner_text("#study-title")
    assert "full factorial" in page.inner_text("#study-summary")
    # a complete full factorial: the ranking is the variance decomposition, stated as such
    assert page.get_attribute("#study-method", "data-method") == "factorial_variance"
    ranking = page.inner_text("#study-ranking")
    assert "variance decomposition" in ranking and "S_Ti" in ranking
    assert "heat.coefficient" in ranking and "jack.moving_mass" in ranking
    assert len(plot_data(page, "study-hist")[0]["x"]) == 20
    assert page.locator(f"#study-row-{SWEEP_ID}").get_attribute("data-status") == "done"
    assert page.locator(f"#study-resume-{SWEEP_ID}").count() == 0


def test_load_a_previous_study(page, state):
    sid = state["mc"]
    page.click(f"#study-load-{sid}")
    page.wait_for_function(f"() => document.getElementById('study-results').dataset.studyId === '{sid}'")
    assert len(plot_data(page, "study-hist")[0]["x"]) == 40
    assert page.inner_text("#study-progress-text") == "40/40"   # the bar follows the study on screen
    assert page.get_attribute("#study-method", "data-method") == "prcc"
    assert "selected" in (page.get_attribute(f"#study-row-{sid}", "class") or "")
    # its form comes back: the two parameters as defined, samples and seed (issue 41 item 7)
    rows = page.evaluate("S.study.rows.map(r => [r.path, r.kind])")
    assert rows == [["friction.extend.fc0", "uniform"], ["supply.pressure", "normal"]]
    assert page.input_value("#sp-1-mean") == "600000" and page.input_value("#sp-1-std") == "40000"
    assert page.input_value("#study-samples") == "40" and page.input_value("#study-seed") == "1"
    # the share of runs meeting a requirement on the selected metric (t95), counted here from
    # the API's own values
    page.select_option("#study-metric", "t95")
    t95 = sorted(v for v in get_json_runs(page, sid)["t95"] if v is not None)
    limit = t95[len(t95) // 2]
    page.select_option("#study-req-op", "le")
    page.fill("#study-req-value", repr(limit))
    share = float(page.get_attribute("#study-req-share", "data-share"))
    assert share == pytest.approx(sum(v <= limit for v in t95) / 40, abs=1e-12)
    assert "of 40 runs" in page.inner_text("#study-req-share")
    # the percentile table fits its panel (it was cut off on the right)
    fits = page.evaluate("""() => { const t = document.getElementById('study-table-data');
        const p = document.getElementById('panel-study'); return t.getBoundingClientRect().right <= p.getBoundingClientRect().right + 1; }""")
    assert fits


def test_screenshot(page, page_errors):
    page.select_option("#study-metric", "t95")
    page.select_option("#study-xparam", "supply.pressure")
    ARTIFACTS.mkdir(exist_ok=True)
    box = page.evaluate("""() => { const r = document.getElementById('panel-study').getBoundingClientRect();
        return {x: r.left + window.scrollX, y: r.top + window.scrollY, width: r.width, height: r.height}; }""")
    page.screenshot(path=str(ARTIFACTS / "study.png"), full_page=True, clip=box)   # below the sticky header
    assert (ARTIFACTS / "study.png").stat().st_size > 50_000
    assert page_errors == [], page_errors
