"""A finding lists everything it would change before it is applied (issue 24, item 4: "Apply"
had also moved Coulomb levels, supply, mass and valve C without listing them): every value the
candidate's model differs in, before and after, with its unit, on the card, in Chromium; the
list is the API's ``changes`` (pneucore.description.paths.model_changes), checked against the model."""
import pytest

from test_page import browser, context, page_errors, server  # noqa: F401


def test_each_card_lists_what_taking_it_changes(page):
    page.fill("#heat-coefficient", "15")
    page.dispatch_event("#heat-coefficient", "change")
    page.select_option("#dataset-select", "sample:piston-leak")
    page.click("#btn-diagnose")
    page.wait_for_function("() => document.getElementById('diag-progress').dataset.done === 'true'")
    card = page.locator("#card-piston_leakage")
    summary = card.locator("details.changes summary").inner_text()
    assert "changes" in summary
    card.locator("details.changes summary").click()
    paths = card.locator("details.changes tr[data-path]")
    listed = {paths.nth(i).get_attribute("data-path") for i in range(paths.count())}
    # the effect, its parameter and the recalibrated heat coefficient are all listed
    assert {"effects.piston_leakage", "effects.piston_leakage.conductance", "heat.coefficient"} <= listed
    row = card.locator("details.changes tr[data-path='heat.coefficient']").inner_text()
    assert "15" in row and "W/(m² K)" in row, row
