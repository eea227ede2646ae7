"""A rig's tests together on the page (issue 24, item 1): several stored datasets selected at
once, each with its own context (locked, x0, time offset) edited in the experiment table, and
compared and diagnosed together, in Chromium."""
from __future__ import annotations

import json

import pytest

from test_page import TIMEOUT_MS, browser, page_errors, server, workbench_page  # noqa: F401

HOLD, FREE = "sample-piston-leak-locked-hold", "sample-spool-lag-free-pulses"


@pytest.fixture(scope="module")
def page(browser, server, page_errors):  # noqa: F811
    yield from workbench_page(browser, server, page_errors)


def _last_body(page, path):
    return page.evaluate("(p) => window.__bodies && window.__bodies[p]", path)


def test_two_datasets_of_different_samples_are_compared_together(page):
    # record the request bodies the page sends (the experiments it asks for)
    page.evaluate("""() => { window.__bodies = {}; const f = window.fetch;
        window.fetch = (u, o) => { if (o && o.body && typeof o.body === 'string') window.__bodies[new URL(u, location).pathname] = JSON.parse(o.body); return f(u, o); }; }""")
    page.select_option("#dataset-select", [f"ds:{HOLD}", f"ds:{FREE}"])
    rows = page.locator("#experiment-set-table tbody tr")
    assert rows.count() == 2
    # both tests drawn at once in the Data view, before any comparison (one line style each)
    page.wait_for_function("() => !document.getElementById('dataset-plot').hidden && "
                           "(document.getElementById('dataset-plot').data || []).length > 0")
    names = page.evaluate("document.getElementById('dataset-plot').data.map(t => t.name)")
    assert any(n.startswith("piston-leak / locked-hold: p_a") for n in names), names
    assert any(n.startswith("spool-lag / free-pulses: x") for n in names), names
    assert page.is_checked("#experiment-set-table tr[data-index='0'] input[data-key='locked']")
    assert not page.is_checked("#experiment-set-table tr[data-index='1'] input[data-key='locked']")
    # the free test's start position, edited in mm, reaches the request in m
    page.fill("#experiment-set-table tr[data-index='1'] input[data-key='x0']", "50")
    page.dispatch_event("#experiment-set-table tr[data-index='1'] input[data-key='x0']", "change")
    page.click("#btn-compare")
    page.wait_for_selector("#error-table-data td[data-signal='overall']")
    body = _last_body(page, "/api/compare")
    assert [e["dataset_id"] for e in body["experiments"]] == [HOLD, FREE]
    assert body["experiments"][1]["scenario"]["x0"] == pytest.approx(0.05)
    assert body["experiments"][1]["scenario"]["locked"] is False
    table = page.inner_text("#error-table-data")
    assert "locked-hold" in table and "free-pulses" in table


def test_a_context_edit_changes_the_request_and_the_answer(page):
    """Declaring the free test locked is sent as such, and the page then hints that its
    position moves (the context check of the comparison)."""
    page.check("#experiment-set-table tr[data-index='1'] input[data-key='locked']")
    page.click("#btn-compare")
    page.wait_for_selector(".context-hint[data-kind='declared_locked_moves']", timeout=TIMEOUT_MS)
    body = _last_body(page, "/api/compare")
    assert body["experiments"][1]["scenario"]["locked"] is True
    page.uncheck("#experiment-set-table tr[data-index='1'] input[data-key='locked']")
