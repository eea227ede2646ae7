"""The heat-model parts of the page (static/heat.js), driven in a real headless Chromium.

The browser, the page and the error checks are the fixtures of ``tests/page/test_page.py``
(imported), with this module's own service. In file order: the model panel lists every heat
model of the API with an input per parameter (units in the labels), one scenario is run under
every heat model (pressures and temperatures overlaid), one sample measurement is compared
with every heat model, each calibrated on its own parameters (the table), and switching back
to the fixed coefficient drops the other model's fields so that a simulation is accepted.

No skipping: if Playwright or Chromium is missing the tests fail loudly.
"""
from __future__ import annotations

import pytest

from test_page import (server, _open, browser, click_and_wait_for_plot, context, no_script_errors,  # noqa: F401
                       page_errors, plot_data)

from pneucore.physics.heat import HEAT_MODELS


@pytest.fixture(scope="module")
def page(context, server, page_errors):
    p = _open(context, server, page_errors)
    p.wait_for_function("() => document.getElementById('panel-heat').dataset.ready === 'true'")
    yield p
    p.close()


def test_heat_select_lists_every_model_with_its_parameters(page):
    options = page.eval_on_selector_all("#heat-model option", "els => els.map(e => e.value)")
    assert options == list(HEAT_MODELS)
    page.select_option("#heat-model", "natural_and_jet")
    for p in HEAT_MODELS["natural_and_jet"].parameters:
        label = page.inner_text(f"label[for='heat-{p}']")
        assert "[" in label and "]" in label, label
    assert page.input_value("#heat-jet_multiplier") == "1"
    assert page.is_hidden("#heat-coefficient")   # not a parameter of this model
    page.fill("#heat-jet_multiplier", "0.5")
    page.dispatch_event("#heat-jet_multiplier", "input")
    assert page.evaluate("S.model.heat.jet_multiplier") == 0.5


def test_one_scenario_under_every_heat_model(page):
    page.click("#btn-fig10")
    page.wait_for_function("() => document.getElementById('scn-command').value.length > 0")
    page.click("#btn-heat-all")
    page.wait_for_function("""() => document.getElementById('panel-heat').dataset.simulated
        || document.getElementById('status').classList.contains('error')""")
    assert page.get_attribute("#panel-heat", "data-simulated") == str(len(HEAT_MODELS)), \
        page.inner_text("#status")
    names = [t["name"] for t in plot_data(page, "heat-plot-temperature")]
    assert {f"{m} T_a" for m in HEAT_MODELS} <= set(names)
    temps = {t["name"]: max(v for v in t["y"] if isinstance(v, (int, float)))
             for t in plot_data(page, "heat-plot-temperature")}
    # adiabatic compression heats the gas most; the isothermal gas stays at ambient
    assert temps["adiabatic T_a"] > temps["convective T_a"] > temps["isothermal T_a"]


def test_measurement_against_every_heat_model(page):
    page.select_option("#dataset-select", "sample:piston-leak")
    page.click("#btn-heat-compare")
    page.wait_for_function("""() => document.getElementById('panel-heat').dataset.compared
        || document.getElementById('status').classList.contains('error')""", timeout=120_000)
    assert page.get_attribute("#panel-heat", "data-compared") == str(len(HEAT_MODELS)), \
        page.inner_text("#status")
    rows = page.eval_on_selector_all("#heat-table tbody tr", "els => els.map(e => e.dataset.model)")
    assert rows == list(HEAT_MODELS)
    assert "coefficient =" in page.inner_text("#heat-table tr[data-model='convective']")
    names = {t["name"] for t in plot_data(page, "heat-plot-pressure")}
    assert "measured p_a" in names and "convective p_a" in names


def test_back_to_the_fixed_coefficient_simulates(page):
    page.select_option("#heat-model", "convective")
    assert page.locator("#heat-jet_multiplier").count() == 0
    assert page.is_visible("#heat-coefficient")
    assert "jet_multiplier" not in page.evaluate("Object.keys(S.model.heat)")
    click_and_wait_for_plot(page, "#btn-simulate")
    assert not page.evaluate("document.getElementById('status').classList.contains('error')")
