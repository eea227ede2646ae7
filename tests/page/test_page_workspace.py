"""The page as a workspace of views (static/workspace.js), at the 1366x768 of a laptop.

Driven in Chromium with the fixtures of tests/page/test_page.py (imported), its own service.
In file order: the nav shows one view at a time, by mouse and by keyboard, with the view in
the address; the Diagnose view holds the residual plot and the findings in one screen;
a reload reopens the view and the session; a shared link with the session id opens it in a
browser that never saw it; an unknown or hostile address gives a status message, never HTML.
Screenshots of every view go to artifacts/workspace-<view>.png for review.
"""
from __future__ import annotations

import pytest

from test_page import (ARTIFACTS, TIMEOUT_MS, _open, browser, page_errors, server,  # noqa: F401
                       show_view, workspace_ready)

WIDTH, HEIGHT = 1366, 768
VIEWS = ["model", "simulate", "data", "identify", "compare", "diagnose", "heat", "studies", "sizing",
         "control"]
# the panel each view must show, and one it must not
SHOWN = {"model": "#panel-model", "simulate": "#panel-plots", "data": "#dataset-select",
         "identify": "#panel-identify", "compare": "#btn-compare", "diagnose": "#btn-diagnose",
         "heat": "#panel-heat", "studies": "#panel-study", "sizing": "#panel-sizing",
         "control": "#panel-control"}


@pytest.fixture(scope="module")
def ctx(browser):  # noqa: F811
    c = browser.new_context(viewport={"width": WIDTH, "height": HEIGHT})
    yield c
    c.close()


@pytest.fixture(scope="module")
def page(ctx, server, page_errors):  # noqa: F811
    p = _open(ctx, server, page_errors, view=None)
    yield p
    p.close()


@pytest.fixture(autouse=True)
def no_script_errors(page_errors):  # noqa: F811
    n = len(page_errors)
    yield
    assert page_errors[n:] == [], page_errors[n:]


def view_of(page):
    return page.evaluate("document.body.dataset.view")


def test_one_view_at_a_time_from_the_nav_with_the_view_in_the_address(page):
    assert view_of(page) == "model"          # no view in the address, none used before: the model
    for view in VIEWS:
        show_view(page, view)
        assert view_of(page) == view
        assert f"view={view}" in page.evaluate("location.hash")
        assert page.get_attribute(f"#workspace-nav a[data-view='{view}']", "aria-current") == "page"
        assert page.locator("#workspace-nav a[aria-current]").count() == 1
        assert page.is_visible(SHOWN[view]), view
        for other, sel in SHOWN.items():
            if other != view and not (view, other) in {("data", "compare"), ("compare", "data")}:
                assert not page.is_visible(sel), (view, other)
        ARTIFACTS.mkdir(exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / f"workspace-{view}.png"))


def test_the_keyboard_moves_along_the_steps_and_opens_one(page):
    show_view(page, "model")
    page.focus("#workspace-nav a[data-view='model']")
    page.keyboard.press("ArrowDown")
    page.keyboard.press("ArrowDown")
    assert page.evaluate("document.activeElement.dataset.view") == "data"
    page.keyboard.press("Enter")
    assert view_of(page) == "data"
    page.keyboard.press("End")
    assert page.evaluate("document.activeElement.dataset.view") == "all"
    # an address typed or followed in the same tab switches too
    page.evaluate("location.hash = '#view=heat'")
    page.wait_for_function("() => document.body.dataset.shown === 'heat'")
    assert page.is_visible("#panel-heat") and not page.is_visible("#panel-model")


def test_diagnose_view_shows_the_residual_plot_beside_the_findings(page):
    show_view(page, "data")
    page.select_option("#dataset-select", "sample:piston-leak")
    show_view(page, "diagnose")
    page.click("#btn-diagnose")
    page.wait_for_function("() => document.getElementById('diag-progress').dataset.done === 'true'",
                           timeout=4 * TIMEOUT_MS)
    page.evaluate("window.scrollTo(0, 0)")
    page.screenshot(path=str(ARTIFACTS / "workspace-diagnose.png"))
    boxes = page.evaluate("""() => Object.fromEntries(['residual-plot', 'diag-verdict', 'diag-cards']
        .map(id => { const r = document.getElementById(id).getBoundingClientRect();
                     return [id, {top: r.top, bottom: r.bottom, left: r.left, right: r.right, h: r.height}]; }))""")
    first = page.evaluate("""() => { const r = document.querySelector('#diag-cards .card').getBoundingClientRect();
        return {top: r.top, bottom: r.bottom, left: r.left, right: r.right}; }""")
    res, verdict = boxes["residual-plot"], boxes["diag-verdict"]
    # wholly in the first screen, without scrolling: the residual plot and the verdict
    for name, b in (("residual plot", res), ("verdict", verdict)):
        assert b["top"] >= 0 and b["bottom"] <= HEIGHT and b["right"] <= WIDTH, (name, b)
    # the top ranked finding's card starts in the first screen with at least its title line (40 px:
    # one 14 px heading line with the card's padding) seen; its evidence table may run below
    assert 0 <= first["top"] < HEIGHT - 40, first
    # beside, not under: the plot and the findings side by side
    assert res["left"] >= verdict["right"] - 1, (res, verdict)
    # the plot drawn in the slot at its width (resized when shown), with the residual traces
    width = page.evaluate("document.getElementById('residual-plot')._fullLayout.width")
    assert abs(width - (res["right"] - res["left"])) <= 2, (width, res)   # 2 px: borders/rounding
    assert page.evaluate("(document.getElementById('residual-plot').data || []).length") > 0
    # the comparison view gets its residual plot back under the comparison plot
    show_view(page, "compare")
    assert page.evaluate("document.getElementById('residual-block').parentElement.id") == "residual-home"
    page.screenshot(path=str(ARTIFACTS / "workspace-compare.png"))


def test_reload_reopens_the_view_and_the_session(page):
    show_view(page, "diagnose")
    sid = page.inner_text("#session-id")
    assert f"session={sid}" in page.evaluate("location.hash")
    assert page.get_attribute("#workspace-link", "href") == f"#view=diagnose&session={sid}"
    page.reload()
    workspace_ready(page)
    assert view_of(page) == "diagnose"
    assert page.inner_text("#session-id") == sid
    assert page.is_visible("#residual-plot")


def test_a_shared_link_opens_the_session_in_another_browser(browser, server, page, page_errors):  # noqa: F811
    sid = page.inner_text("#session-id")
    other = browser.new_context(viewport={"width": WIDTH, "height": HEIGHT})   # no stored session
    try:
        p = other.new_page()
        p.goto(f"{server}/#view=compare&session={sid}")
        workspace_ready(p)
        assert p.evaluate("document.body.dataset.view") == "compare"
        assert p.inner_text("#session-id") == sid
        assert p.input_value("#dataset-select") == "sample:piston-leak"
        assert "Opened from the link" in p.inner_text("#status")
    finally:
        other.close()


@pytest.mark.parametrize("hash_, says", [
    ("#view=diagnose&session=0123456789abcdef0123456789abcdef", "could not be opened"),
    ('#view=<img src=x onerror="document.title=1">&session=<b>x</b>', "names no view"),
])
def test_an_unknown_or_hostile_link_says_so_as_text(browser, server, hash_, says):  # noqa: F811
    errors = []
    other = browser.new_context(viewport={"width": WIDTH, "height": HEIGHT})
    try:
        p = other.new_page()
        p.on("pageerror", lambda exc: errors.append(str(exc)))
        p.goto(f"{server}/{hash_}")
        workspace_ready(p)
        p.wait_for_function(f"() => document.getElementById('status-msg').textContent.includes({says!r})")
        assert p.evaluate("document.body.dataset.ready") == "true"
        assert p.locator("#status img, #status b").count() == 0       # shown as text, never parsed
        assert p.evaluate("document.title") != "1"
        assert p.evaluate("document.body.dataset.view") in VIEWS
        assert errors == []
    finally:
        other.close()


def test_an_error_on_a_field_of_another_view_leads_there(browser, server):  # noqa: F811
    errors = []
    other = browser.new_context(viewport={"width": WIDTH, "height": HEIGHT})   # no session, no dataset chosen
    try:
        p = other.new_page()
        p.on("pageerror", lambda exc: errors.append(str(exc)))
        p.goto(f"{server}/#view=diagnose")
        workspace_ready(p)
        p.click("#btn-diagnose")
        link = p.locator("#status-errors li.link", has_text="experiments")
        link.wait_for()
        assert not p.is_visible("#dataset-select")        # the field is in the Data view
        link.click()
        assert p.evaluate("document.body.dataset.view") == "data"
        assert p.is_visible("#dataset-select")
        assert "view=data" in p.evaluate("location.hash")
        assert errors == []
    finally:
        other.close()


def test_using_a_sized_design_shows_the_model_it_went_into(page):
    """Last: it replaces the page's model."""
    show_view(page, "sizing")
    page.wait_for_function("() => document.getElementById('panel-sizing').dataset.ready === 'true'")
    page.fill("#sz-bore", "iso15552:32")
    page.fill("#sz-valve", "ckd-4ga")
    page.click("#btn-size")
    page.wait_for_function("() => document.getElementById('panel-sizing').dataset.sized")
    assert not page.is_visible("#jack-bore")
    page.click("#btn-size-use")
    page.wait_for_function("() => document.body.dataset.shown === 'model'")
    assert page.is_visible("#jack-bore")
    assert page.input_value("#model-name-input").startswith("sizing: ")
