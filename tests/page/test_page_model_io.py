"""Models in and out on the page (issue 24, item 2): a catalogue model brought in as a JSON file
or pasted (or an export that holds one), named and described, refused with its field named when
it is wrong (the page's model left alone), and downloaded to be loaded back, in Chromium."""
from __future__ import annotations

import json

import pytest

from pneucore import model_preset
from test_page import TIMEOUT_MS, browser, page_errors, server, workbench_page  # noqa: F401


@pytest.fixture(scope="module")
def page(browser, server, page_errors):  # noqa: F811
    yield from workbench_page(browser, server, page_errors, accept_downloads=True)


def _catalogue_model():
    m = model_preset("paper-4way")
    m["name"] = "DSBC-50 rig"
    m["description"] = "Festo DSBC 50 mm, from its data sheet"
    m["jack"]["bore"] = 0.05
    m["jack"]["rod_a"] = m["jack"]["rod_b"] = 0.02
    return m


def test_a_model_file_replaces_the_model_and_its_name_shows(page, tmp_path):
    path = tmp_path / "catalogue.json"
    path.write_text(json.dumps({"model": _catalogue_model(), "versions": []}))   # an export holding one
    page.click("#model-io summary")
    page.set_input_files("#model-file", str(path))
    page.wait_for_function("() => /DSBC-50 rig loaded/.test(document.getElementById('status-msg').textContent)")
    assert page.input_value("#jack-bore") == "50"          # mm on the page
    assert page.input_value("#model-name-input") == "DSBC-50 rig"
    assert "Festo DSBC 50 mm" in page.inner_text("#model-name")


def test_a_wrong_model_names_its_field_and_changes_nothing(page):
    bad = _catalogue_model()
    bad["jack"]["bore"] = -0.05
    page.fill("#model-json", json.dumps(bad))
    page.click("#btn-model-json")
    page.wait_for_function("() => /refused/.test(document.getElementById('status-msg').textContent)")
    assert "model.jack.bore" in page.inner_text("#status-msg") or page.locator("#jack-bore.invalid").count() == 1
    assert page.input_value("#jack-bore") == "50"          # the page's model is left alone
    page.fill("#model-json", "{not json")
    page.click("#btn-model-json")
    page.wait_for_function("() => /not valid JSON/.test(document.getElementById('status-msg').textContent)")


def test_rename_download_and_load_back(page, tmp_path):
    page.fill("#model-name-input", "DSBC-50 rig, seals run in")
    page.dispatch_event("#model-name-input", "change")
    with page.expect_download() as dl:
        page.click("#btn-model-download")
    saved = tmp_path / "out.json"
    dl.value.save_as(saved)
    m = json.loads(saved.read_text())
    assert m["name"] == "DSBC-50 rig, seals run in" and m["jack"]["bore"] == pytest.approx(0.05)
    page.click("#btn-load-preset")   # back to the preset, then the download brings the rig back
    page.wait_for_function("() => document.getElementById('jack-bore').value === '32'")
    page.set_input_files("#model-file", str(saved))
    page.wait_for_function("() => document.getElementById('jack-bore').value === '50'", timeout=TIMEOUT_MS)
    assert page.input_value("#model-name-input") == "DSBC-50 rig, seals run in"


def test_a_comparison_made_with_another_model_says_so(page):
    """Issue 24, item 7: old comparison results left on screen after the model changed."""
    page.select_option("#dataset-select", "sample:piston-leak")
    page.click("#btn-compare")
    page.wait_for_selector("#error-table-data td[data-signal='overall']")
    assert page.locator("#compare-stale").count() == 0
    page.fill("#jack-moving_mass", "3.1")
    page.dispatch_event("#jack-moving_mass", "change")
    assert "The model changed since this comparison" in page.inner_text("#compare-stale")
    page.click("#btn-compare")
    page.wait_for_function("() => !document.getElementById('compare-stale')")
