"""A real rig's record as it comes, on the page in Chromium (issue 28).

The record of tests/api/test_api_real_record.py (the paper's 3/2 jack lifting a load by
three pulses): no command column, the pressure in raw volts (gauge, 2 bar/V, -0.5 bar zero,
clipped at its zero), the position in mm. It goes in through the mapping table with its
sensor's gain and offset, is plotted at once with a command proposed from its pressure's
edges, compared and diagnosed with the mass declared known, and the diagnosis on screen
is exported as the report.
"""
from __future__ import annotations


import numpy as np
import pytest

from pneucore.data.synthetic import synthesize
from pneucore.description.model import Model
from pneucore.description.presets import model_preset
from pneucore.description.scenario import pulse_train
from test_page import browser, page_errors, server, wait_status, wide_context  # noqa: F401

PULSES = [(0.1, 1.0), (0.5, 1.0), (0.9, 1.0)]


@pytest.fixture(scope="module")
def context(browser):  # noqa: F811
    yield from wide_context(browser)


@pytest.fixture(scope="module")
def rig_file(tmp_path_factory):
    d = model_preset("paper-3way")
    d["jack"]["load_force"] = -30.0
    m = Model.from_dict(d)
    meas = synthesize(m, {"command": pulse_train(PULSES, 0.05), "duration": 1.3, "x0": 0.0,
                          "sample_period": 0.001}, signals=("p_a", "x"))
    bar_g = np.maximum(meas.signals["p_a"] - m.ambient.pressure, 0.0) / 1e5
    volts = (bar_g + 0.5) / 2.0
    lines = ["time_s,pressure_V,pos_mm"] + [f"{t:.4f},{v:.6f},{1e3 * x:.5f}"
                                           for t, v, x in zip(meas.t, volts, meas.signals["x"])]
    path = tmp_path_factory.mktemp("rig") / "vertical.csv"
    path.write_text("\n".join(lines))
    return path


def _wait_status(page, pattern):
    return wait_status(page, pattern)


def test_upload_volts_with_a_sensor_and_see_the_proposed_command(page, rig_file):
    page.select_option("#model-preset", "paper-3way")
    page.click("#btn-load-preset")
    _wait_status(page, "Model preset paper-3way loaded")
    page.click("#upload-box summary")
    page.set_input_files("#upload-file", str(rig_file))
    page.wait_for_selector("#upload-mapping select[data-column='pressure_V']")
    page.select_option("#upload-mapping select[data-column='pressure_V']", "p_a")
    sensor = "#upload-mapping [data-sensor-for='pressure_V'][data-key='{}']"
    page.fill(sensor.format("unit"), "bar")
    page.fill(sensor.format("gain"), "2")
    page.fill(sensor.format("offset"), "-0.5")
    page.select_option(sensor.format("reference"), "gauge")
    page.fill(sensor.format("raw_unit"), "V")
    page.select_option("#upload-mapping select[data-column='pos_mm']", "x")
    page.fill("#upload-mapping [data-sensor-for='pos_mm'][data-key='unit']", "mm")
    page.fill("#upload-name", "vertical")
    page.click("#btn-upload")
    _wait_status(page, "Dataset vertical stored")
    assert "2 barg per V, offset -0.5 barg" in page.inner_text("#upload-report")
    # plotted at once, with the command proposed from the pressure's edges drawn over it
    page.wait_for_selector("#dataset-command-box:not([hidden])")
    assert "proposed" in page.inner_text("#dataset-command-source")
    cmd = [[float(v) for v in line.split()] for line in page.input_value("#dataset-command").splitlines()]
    assert [u for _, u in cmd] == [0.0] + [1.0, 0.0] * 3
    for (t_open, _), (t_close, _), (t_true, _) in zip(cmd[1::2], cmd[2::2], PULSES):
        # within 2 samples (2 ms): the edges' smoothing window, see tests/data/test_command.py
        assert abs(t_open - t_true) <= 0.002 and abs(t_close - t_true - 0.05) <= 0.002
    names = page.evaluate("() => document.getElementById('dataset-plot').data.map((t) => t.name)")
    assert "p_a measured" in names and "x measured" in names and "u proposed" in names


def test_an_edited_command_is_the_one_compared(page):
    ta = page.locator("#dataset-command")
    ta.fill("0 0\n0.1 1\nbad line")
    ta.dispatch_event("change")
    assert "line 3" in page.inner_text(".field-error[data-error-for='experiments.command']")
    ta.fill("0 0\n0.1 1\n0.15 0\n0.5 1\n0.55 0\n0.9 1\n0.95 0")
    ta.dispatch_event("change")
    assert "entered on this page" in page.inner_text("#dataset-command-source")
    exps = page.evaluate("() => S.experiments")
    assert exps[0]["scenario"]["command"][1] == [0.1, 1]
    page.click("#btn-compare")
    _wait_status(page, "Comparison done")


def test_diagnose_with_a_known_mass_and_export_what_is_shown(page):
    page.fill("#diag-known", "jack.moving_mass, jack.load_force")
    page.click("#btn-diagnose")
    _wait_status(page, "Diagnosis done")
    shown = page.evaluate("() => S.diag.result")
    assert shown["known"] == ["jack.moving_mass", "jack.load_force"]
    assert shown["model"]["jack"]["moving_mass"] == page.evaluate("() => S.diag.model.jack.moving_mass")
    with page.expect_download() as dl:
        page.click("#btn-diag-report")
    html = open(dl.value.path(), encoding="utf-8").read()
    # the report prints the message on screen, verbatim (HTML-escaped like the page's own)
    first = shown["message"][:60].replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    assert first.replace("'", "&#x27;") in html or first in html
    assert "given with the experiment" in html      # the command's source, in the provenance
