"""A stored session is opened from the Stored panel (issue 24, item 1): its last model, its
experiments (two datasets of different samples, one with an edited context) and its history come
back on the page, in Chromium."""
from __future__ import annotations

import pytest

from test_page import browser, page_errors, server, workbench_page  # noqa: F401


@pytest.fixture(scope="module")
def page(browser, server, page_errors):  # noqa: F811
    yield from workbench_page(browser, server, page_errors)


def test_a_stored_session_opens_with_its_model_experiments_and_history(page):
    sid = page.evaluate("""async () => {
        const m = await api('GET', '/api/presets/paper-4way');
        m.name = 'rig B, second try'; m.jack.moving_mass = 2.6;
        const s = await api('POST', '/api/sessions', { name: 'rig B', model: m, experiments: [
            { dataset_id: 'sample-piston-leak-locked-hold' },
            { dataset_id: 'sample-spool-lag-free-pulses', scenario: { locked: false, x0: 0.06 } }] });
        return s.id; }""")
    page.click("#stored-box summary")
    row = page.locator(f"#stored-lists ul[data-kind=sessions] li[data-id='{sid}']")
    row.wait_for()
    row.locator("button.stored-open").click()
    page.wait_for_function("(id) => /Opened session/.test(document.getElementById('status-msg').textContent)", arg=sid)
    assert page.input_value("#model-name-input") == "rig B, second try"
    assert page.input_value("#jack-moving_mass") == "2.6"
    assert page.inner_text("#session-id") == sid
    assert page.locator("#experiment-set-table tbody tr").count() == 2
    # the second experiment's stored context (x0 = 60 mm) is the one shown and sent
    assert page.input_value("#experiment-set-table tr[data-index='1'] input[data-key='x0']") == "60"
    assert page.evaluate("localStorage.getItem('pneucore.session')") == sid   # a reload reopens it


def test_two_versions_are_compared_in_the_history(page):
    """The history table's diff button lists what changed from the previous version."""
    sid = page.evaluate("S.session.id")
    page.evaluate("""async (sid) => {
        const m = JSON.parse(JSON.stringify(S.model)); m.heat.coefficient = 31.5;
        const s = await api('POST', `/api/sessions/${sid}/versions`, { model: m, added: null, params: {} });
        setSession(s); }""", sid)
    page.click("#history-table button.version-diff")
    page.wait_for_selector("#version-diff tr[data-path='heat.coefficient']")
    assert "31.5" in page.inner_text("#version-diff tr[data-path='heat.coefficient']")


def test_the_session_goes_on_when_the_data_change(page):
    """Issue 24: changing the experiments does not start a new session (and a new version 0):
    the next comparison adds a version on the new data, marked in the history."""
    sid = page.evaluate("S.session.id")
    n = page.evaluate("S.session.versions.length")
    page.select_option("#dataset-select", "sample:piston-leak")
    page.click("#btn-compare")
    page.wait_for_function("(n) => S.session && S.session.versions.length === n + 1", arg=n)
    assert page.evaluate("S.session.id") == sid
    last = page.locator("#history-table tbody tr").last
    assert last.locator(".data-changed").count() == 1
    assert "piston-leak" in last.locator(".data-changed").get_attribute("title")
    shapes = page.evaluate("document.getElementById('history-plot').layout.shapes || []")
    assert any(s.get("x0") == n - 0.5 for s in shapes)
    # "New session" still starts a fresh one, version 0 on the current data
    page.click("#btn-new-session")
    page.wait_for_function("(sid) => S.session && S.session.id !== sid", arg=sid)
    assert page.evaluate("S.session.versions.length") == 1
