"""The Control view of the page (static/control.js), in a real headless Chromium: the
controller select lists GET /api/controllers with a gain input per gain (units in the labels),
a closed loop runs on the model panel's model (position and reference plotted, metrics
tabled), and the linearisation reports the natural frequency; the sensors (typed in the page's
units, sent in SI) add the sensed position to the plot; a robustness study over uncertain
ranges shows a histogram of a metric over its runs with the share meeting a specification; a
tuning ranks gain sets and takes the best into the gain fields; a bad range or sensor value is
shown next to its field.

No skipping: if Playwright or Chromium is missing the tests fail loudly.
"""
from __future__ import annotations

import re

import pytest

from test_page import (server, _open, browser, context, no_script_errors,  # noqa: F401
                       page_errors, plot_data)

from pneucore.control.controllers import CONTROLLERS


@pytest.fixture(scope="module")
def page(context, server, page_errors):
    p = _open(context, server, page_errors, view="control")
    p.wait_for_function("() => document.querySelectorAll('#control-kind option').length > 0")
    yield p
    p.close()


def test_controllers_are_listed_with_their_gains(page):
    options = page.eval_on_selector_all("#control-kind option", "els => els.map(e => e.value)")
    assert set(CONTROLLERS) <= set(options)
    page.select_option("#control-kind", "pid")
    assert "[1/m]" in page.inner_text("label[for='control-gain-kp']")


def test_a_closed_loop_runs_and_its_metrics_show(page):
    # the paper's valve has a 15 % overlap: a proportional gain large enough to open it
    page.select_option("#control-kind", "sliding_mode")
    page.fill("#control-gain-lambda", "20")
    page.fill("#control-setpoint", "[[0, 0.1], [0.05, 0.12]]")
    page.click("#btn-control-run")
    page.wait_for_function("""() => document.getElementById('panel-control').dataset.ran
        || document.getElementById('status').classList.contains('error')""")
    assert page.get_attribute("#panel-control", "data-ran") == "1", page.inner_text("#status")
    names = [t["name"] for t in plot_data(page, "control-plot-x")]
    assert names == ["x_ref", "x"]
    assert "settling time" in page.inner_text("#control-table")


def test_linearisation_reports_the_natural_frequency(page):
    page.click("#btn-control-linearize")
    page.wait_for_function("() => document.getElementById('control-linear').textContent.length > 0")
    assert "natural frequency" in page.inner_text("#control-linear")


def _sliding(page):
    page.select_option("#control-kind", "sliding_mode")
    page.fill("#control-gain-lambda", "20")
    page.fill("#control-setpoint", "[[0, 100], [0.05, 120]]")   # mm (the engineering system)
    page.fill("#control-duration", "0.6")


def _wait(page, flag):
    page.wait_for_function(f"""() => document.getElementById('panel-control').dataset.{flag}
        || document.getElementById('status').classList.contains('error')""", timeout=300_000)
    assert page.get_attribute("#panel-control", f"data-{flag}") == "1", page.inner_text("#status")


def test_the_sensed_position_is_plotted_beside_the_true_one(page):
    assert "[mm]" in page.inner_text("label[for='control-sensor-position_resolution']")
    assert "[bar]" in page.inner_text("label[for='control-sensor-pressure_noise']")
    _sliding(page)
    page.fill("#control-sensor-position_resolution", "1")      # 1 mm: sent as 0.001 m
    page.evaluate("document.getElementById('panel-control').dataset.ran = ''")
    page.click("#btn-control-run")
    _wait(page, "ran")
    traces = {t["name"]: t for t in plot_data(page, "control-plot-x")}
    assert list(traces) == ["x_ref", "x", "x_sensed"]
    sensed = [v for v in traces["x_sensed"]["y"] if v is not None]
    # what the controller read: whole counts of 1 mm, shown in mm
    assert sensed and all(abs(v - round(v)) < 1e-6 for v in sensed), sensed[:10]
    assert len({round(v) for v in sensed}) > 1


def _metrics_table(page):
    """The metrics table: {row header: (text, value shown)}."""
    return {th: (th, td) for th, td in page.evaluate("""() => Array.from(
        document.querySelectorAll('#control-table tr')).map(tr => [tr.querySelector('th').textContent,
        tr.querySelector('td').textContent])""")}


def _unit_system(page, system):
    page.select_option("#unit-system", system)
    page.wait_for_function(f"() => document.body.dataset.units === '{system}'")


def test_the_metrics_table_and_the_linearisation_follow_the_unit_system(page):
    # the last run (a sliding-mode step, quantised pressures, the velocity filter sent) in the
    # engineering system: lengths in mm; in SI: in m, the values 1000x smaller; times in s in
    # both (no system converts a time), overshoot in %
    _sliding(page)
    page.fill("#control-sensor-pressure_resolution", "0.01")   # bar: sent as 1 kPa
    page.fill("#control-rate-filter", "0.004")
    page.evaluate("document.getElementById('panel-control').dataset.ran = ''")
    page.click("#btn-control-run")
    _wait(page, "ran")
    sent = page.evaluate("CTL.run.series.p_a_sensed.filter(v => v != null)")
    assert sent and all(abs(v / 1000 - round(v / 1000)) < 1e-6 for v in sent)   # whole kPa
    rows = {h.split(" [")[0]: (h, v) for h, v in _metrics_table(page).values()}
    assert rows["steady-state error"][0].endswith("[mm]")
    assert rows["RMS tracking error"][0].endswith("[mm]")
    assert rows["settling time (2 %)"][0].endswith("[s]") and rows["overshoot"][0].endswith("[%]")
    ctl = page.evaluate("CTL.run.stats.control")
    # shown to 4 significant digits: 1e-3 relative is their rounding
    assert float(rows["RMS tracking error"][1]) == pytest.approx(ctl["rms_error"] * 1e3, rel=1e-3)
    assert float(rows["rise time (10-90 %)"][1]) == pytest.approx(ctl["rise_time"], rel=1e-3)
    page.click("#btn-control-linearize")
    page.wait_for_function("() => document.getElementById('control-linear').textContent.length > 0")
    assert " mm, p_a = " in page.inner_text("#control-linear") and "bar abs" in page.inner_text("#control-linear")
    _unit_system(page, "si")
    try:
        rows = {h.split(" [")[0]: (h, v) for h, v in _metrics_table(page).values()}
        assert rows["steady-state error"][0].endswith("[m]")
        assert rows["hunting amplitude"][0].endswith("[m]")
        assert float(rows["RMS tracking error"][1]) == pytest.approx(ctl["rms_error"], rel=1e-3)
        assert float(rows["rise time (10-90 %)"][1]) == pytest.approx(ctl["rise_time"], rel=1e-3)
        text = page.inner_text("#control-linear")
        assert " m, p_a = " in text and " Pa" in text and "mm" not in text and "bar" not in text
        assert page.inner_text("label[for='control-sensor-pressure_resolution']").endswith("[Pa]")
    finally:
        _unit_system(page, "engineering")
        page.fill("#control-sensor-pressure_resolution", "0")
        page.fill("#control-rate-filter", "0.002")


def test_a_bad_sensor_value_is_shown_next_to_its_field(page):
    page.fill("#control-sensor-position_resolution", "0")
    page.fill("#control-sensor-position_noise", "-1")
    page.click("#btn-control-run")
    err = "#control-sensor-position_noise + .field-error"
    page.wait_for_function(f"() => document.querySelector('{err}').textContent.length > 0")
    assert page.get_attribute("#control-sensor-position_noise", "aria-invalid") == "true"
    page.fill("#control-sensor-position_noise", "0")


def test_a_bad_range_names_its_field(page):
    page.fill("#control-rob-mass-min", "3")
    page.fill("#control-rob-mass-max", "2")
    page.click("#btn-control-robust")
    text = page.inner_text("#control-rob-mass-min + .field-error")
    assert "Moving mass" in text and "min" in text
    assert page.get_attribute("#control-rob-mass-min", "aria-invalid") == "true"
    assert "parameters.jack.moving_mass" in page.inner_text("#status-errors")
    page.fill("#control-rob-mass-min", "1.5")


def test_a_robustness_study_shows_a_histogram_and_the_share_meeting_the_spec(page):
    _sliding(page)
    page.fill("#control-rob-runs", "6")
    page.fill("#control-spec-settling", "0.4")
    page.fill("#control-spec-overshoot", "20")
    page.fill("#control-spec-band", "1")                       # mm
    page.fill("#control-rob-mass-min", "1.5")
    page.fill("#control-rob-mass-max", "2")
    requests = []
    page.on("request", lambda r: requests.append(r.post_data_json)
            if r.url.endswith("/api/jobs/control-study") else None)
    page.click("#btn-control-robust")
    _wait(page, "robust")
    (body,) = requests
    assert body["study"]["samples"] == 6
    assert body["specification"] == pytest.approx({"settling_time": 0.4, "overshoot": 0.2,
                                                   "steady_state_error": 0.001})
    params = body["study"]["parameters"]
    fr = page.evaluate("S.model.friction")
    ext, ret = fr["extend"]["fc0"], (fr.get("retract") or fr["extend"])["fc0"]
    if ext == ret:
        assert set(params) == {"friction.*.fc0", "jack.moving_mass"}
    else:   # the model's levels differ: each direction in its own range
        assert set(params) == {"friction.extend.fc0", "friction.retract.fc0", "jack.moving_mass"}
        assert params["friction.retract.fc0"]["max"] == pytest.approx(1.5 * ret)
        assert "differ" in page.inner_text("#control-rob-fc-note")
    fc = params.get("friction.*.fc0") or params["friction.extend.fc0"]
    assert (fc["min"], fc["max"]) == pytest.approx((0.5 * ext, 1.5 * ext))
    assert params["jack.moving_mass"] == {"distribution": "uniform", "min": 1.5, "max": 2}
    assert page.get_attribute("#control-rob-hist", "data-runs") == "6"
    n = int(page.get_attribute("#control-rob-hist", "data-count"))
    assert 0 < n <= 6
    traces = plot_data(page, "control-rob-hist")
    assert sum(len(t["x"]) for t in traces) == n
    shapes = page.evaluate("document.getElementById('control-rob-hist').layout.shapes")
    assert len(shapes) == 1 and shapes[0]["x0"] == pytest.approx(0.4)   # the bound, in s
    share = page.inner_text("#control-rob-share")
    m = re.search(r"(\d+) of 6 runs meet the specification", share)
    assert m, share
    assert float(page.get_attribute("#control-rob-share", "data-share")) == pytest.approx(int(m.group(1)) / 6)
    # another metric, in the page's length unit
    page.select_option("#control-rob-metric", "steady_state_error")
    assert "[mm]" in page.evaluate("document.getElementById('control-rob-hist').layout.xaxis.title.text")


def test_a_tuning_takes_the_best_gains_into_the_fields(page):
    _sliding(page)
    page.fill("#control-rob-runs", "3")
    page.fill("#control-tune-lambda", "8, 20")
    page.click("#btn-control-tune")
    _wait(page, "tuned")
    rows = page.eval_on_selector_all("#control-tune-ranked tbody tr",
                                     "trs => trs.map(tr => Array.from(tr.cells).map(c => c.textContent))")
    assert len(rows) == 2
    heads = page.eval_on_selector_all("#control-tune-ranked thead th", "ths => ths.map(t => t.textContent)")
    best_lambda = float(rows[0][heads.index("lambda [1/s]")])
    assert best_lambda in (8.0, 20.0)
    page.fill("#control-gain-lambda", "1")
    page.click("#btn-control-tune-use")
    assert float(page.input_value("#control-gain-lambda")) == best_lambda


def test_a_reload_shows_the_last_robustness_study_and_tuning_again(page, context, server,
                                                                   page_errors):
    """The robustness study and the tuning above ran as jobs; their answers stay on the server,
    and a page opened again on this browser (the same context: its localStorage) shows both,
    saying they are for what they were run on, without running them again."""
    kept = page.evaluate("[localStorage.getItem('pneucore.control.robust-job'),"
                         " localStorage.getItem('pneucore.control.tune-job')]")
    assert all(kept), kept                         # the two tests above each kept a job id
    posts = []
    again = _open(context, server, page_errors, view="control")
    again.on("request", lambda r: posts.append(r.url) if r.method == "POST" else None)
    try:
        again.wait_for_function("() => document.getElementById('panel-control').dataset.robust"
                                " && document.getElementById('panel-control').dataset.tuned")
        assert again.get_attribute("#control-rob-hist", "data-runs") == "6"
        assert len(again.eval_on_selector_all("#control-tune-ranked tbody tr", "t => t")) == 2
        for step in ("#control-rob-step", "#control-tune-step"):
            text = again.inner_text(step)
            assert "run on" in text and kept[0 if "rob" in step else 1] in text, text
        assert not [u for u in posts if "/api/jobs/" in u]      # shown, not run again
        # a job the server no longer holds is forgotten, never an error on the page
        again.evaluate("localStorage.setItem('pneucore.control.robust-job', 'no-such-job')")
    finally:
        again.close()
    third = _open(context, server, page_errors, view="control")
    try:
        third.wait_for_function("() => document.getElementById('panel-control').dataset.tuned")
        assert third.evaluate("localStorage.getItem('pneucore.control.robust-job')") is None
        assert third.get_attribute("#panel-control", "data-robust") is None
    finally:
        third.close()
