"""The Control view of the page (static/control.js), in a real headless Chromium: the
controller select lists GET /api/controllers with a gain input per gain (units in the labels),
a closed loop runs on the model panel's model (position and reference plotted, metrics
tabled), and the linearisation reports the natural frequency.

No skipping: if Playwright or Chromium is missing the tests fail loudly.
"""
from __future__ import annotations

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
