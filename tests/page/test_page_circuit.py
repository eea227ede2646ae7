"""The circuit on the page (issues 23 and 28): the mounting angle and the chamber-B modes of a
3/2 valve are fields of the model panel, their errors land next to them, a closed or
restricted chamber B simulates as a gas volume, and the stroke metrics of a run with full
strokes are shown next to the plots. Fixtures of tests/page/test_page.py (imported)."""
from __future__ import annotations

import pytest

from test_page import (server, _open, browser, context, no_script_errors, page_errors,  # noqa: F401
                       click_and_wait_for_plot, plot_data, _numbers)


@pytest.fixture(scope="module")
def page(context, server, page_errors):
    p = _open(context, server, page_errors)
    yield p
    p.close()


def test_angle_outside_90_degrees_is_reported_next_to_its_field(page):
    click_and_wait_for_plot(page, "#btn-fig10")
    page.fill("#jack-mounting_angle", "91")
    page.click("#btn-simulate")
    err = page.locator(".field-error[data-error-for='model.jack.mounting_angle']")
    err.wait_for()
    assert "[deg]" in err.inner_text()
    page.fill("#jack-mounting_angle", "0")
    click_and_wait_for_plot(page, "#btn-simulate")


def test_chamber_b_restriction_on_a_3_2_valve(page):
    click_and_wait_for_plot(page, "#btn-fig9")        # the 3/2 preset, chamber B held
    held = set(_numbers(plot_data(page, "plot-pressure")[1]["y"]))
    page.select_option("#valve-b_chamber", "restriction")
    page.click("#btn-simulate")
    err = page.locator(".field-error[data-error-for='model.valve.b_chamber_conductance']")
    err.wait_for()
    assert "m^3/(s Pa)" in err.inner_text()
    page.fill("#valve-b_chamber_conductance", "0.2")     # dm^3/(s bar)
    click_and_wait_for_plot(page, "#btn-simulate")
    assert page.evaluate("() => S.model.valve.b_chamber_conductance") == pytest.approx(2e-9)
    assert page.locator(".field-error[data-error-for]").count() == 0
    # chamber B is now a gas volume: its pressure moves (it was one constant value when held)
    assert len(held) == 1
    series = page.evaluate("() => S.sim.series.p_b")
    assert len(set(series)) > 10


def test_stroke_metrics_next_to_the_plots(page):
    """A full extension then a full retraction: the summary next to the plots gives the full
    stroke times, the stroke end speed and the air per cycle, as the API's stats.stroke."""
    click_and_wait_for_plot(page, "#btn-fig10")
    page.fill("#scn-command", "0, 0\n0.05, 1\n0.5, -1")
    click_and_wait_for_plot(page, "#btn-simulate")
    text = page.inner_text("#sim-summary")
    sm = page.evaluate("() => S.sim.stats.stroke")
    assert sm["full_stroke_time_extend"] is not None and sm["air_per_cycle_NL"] is not None
    assert f"full stroke extending {sm['full_stroke_time_extend']:.3g} s" in text
    assert "air per cycle" in text and "stroke end speed" in text
