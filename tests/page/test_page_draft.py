"""Unsaved model edits survive a reload (static/draft.js, issue 24), in Chromium.

One tab at the 1366x768 of a laptop, with no session: the bore and the name typed in the
Model view come back after a reload with "Restored unsaved edits … Discard" in the nav, and
Discard brings the preset back. A draft in the tab's storage that is not JSON, or that the
service refuses, is never applied; a hostile name in an accepted one stays text. A stored
session named by the address wins over the draft, which is then only offered.
"""
from __future__ import annotations

import json
import urllib.request

import pytest

from test_page import (TIMEOUT_MS, _open, browser, no_script_errors, page_errors, server,  # noqa: F401
                       show_view, workspace_ready)

KEY = "pneucore.modelDraft"     # static/draft.js
PRESET_BORE_MM = "32"           # paper-4way (Table 1 of the paper)


@pytest.fixture(scope="module")
def page(browser, server, page_errors):  # noqa: F811
    ctx = browser.new_context(viewport={"width": 1366, "height": 768})
    p = _open(ctx, server, page_errors, view="model")
    workspace_ready(p)
    yield p
    p.close()
    ctx.close()


def _reload(p):
    p.reload()
    p.wait_for_function("() => document.body.dataset.ready === 'true'", timeout=TIMEOUT_MS)
    workspace_ready(p)


def _plant(p, value):
    """Put ``value`` (text) in the tab's draft slot as the page is left, after the page's own
    writes (on pagehide and on visibilitychange: they remove the slot when the model is the
    stored one), then reload."""
    p.evaluate("""([k, v]) => { const put = () => sessionStorage.setItem(k, v);
        addEventListener('pagehide', put); document.addEventListener('visibilitychange', put); }""", [KEY, value])
    _reload(p)


def _plant_model(p, model):
    _plant(p, json.dumps({"v": 1, "at": 1.7e12, "model": model}))


def _stored(p):
    return p.evaluate(f"sessionStorage.getItem({KEY!r})")


def _post(server, path, body):
    req = urllib.request.Request(server + path, data=json.dumps(body).encode(),
                                 headers={"content-type": "application/json"})
    with urllib.request.urlopen(req, timeout=60) as r:
        return json.load(r)


def test_typed_edits_come_back_after_a_reload_and_discard_brings_the_preset_back(page):
    assert page.input_value("#jack-bore") == PRESET_BORE_MM and not page.is_visible("#draft-bar")
    page.fill("#jack-bore", "40")
    page.fill("#model-name-input", "rig 7 <b>east</b>")    # typed, the field not left
    page.wait_for_function(f"() => (sessionStorage.getItem({KEY!r}) || '').includes('rig 7')")
    _reload(page)
    assert page.input_value("#jack-bore") == "40"
    assert page.evaluate("S.model.jack.bore") == pytest.approx(0.040, rel=1e-12)   # mm -> m, exact to float
    assert page.input_value("#model-name-input") == "rig 7 <b>east</b>"
    assert page.locator("#model-name b, #draft-bar b").count() == 0               # text, never HTML
    assert page.is_visible("#draft-bar")
    assert "Restored unsaved edits" in page.inner_text("#draft-msg")
    page.click("#btn-draft-discard")
    assert page.input_value("#jack-bore") == PRESET_BORE_MM
    assert page.evaluate("S.model.name") == "paper-4way"
    assert not page.is_visible("#draft-bar") and _stored(page) is None
    _reload(page)
    assert page.input_value("#jack-bore") == PRESET_BORE_MM and not page.is_visible("#draft-bar")


def test_a_draft_that_is_not_json_or_that_the_service_refuses_is_not_applied(page):
    _plant(page, '{"v": 1, "model": ')
    assert "could not be read" in page.inner_text("#draft-msg")
    assert page.input_value("#jack-bore") == PRESET_BORE_MM and _stored(page) is None
    # the shape of a draft, with a bore the service refuses (negative)
    model = page.evaluate("clone(S.model)")
    model["jack"]["bore"] = -0.04
    _plant_model(page, model)
    msg = page.inner_text("#draft-msg")
    assert "not restored" in msg and "bore" in msg, msg
    assert page.input_value("#jack-bore") == PRESET_BORE_MM
    page.click("#btn-draft-discard")
    assert _stored(page) is None


def test_a_hostile_name_in_an_accepted_draft_stays_text(page):
    model = page.evaluate("clone(S.model)")
    model["name"] = "<img src=x onerror=\"document.title='owned'\">"
    _plant_model(page, model)
    assert "Restored unsaved edits" in page.inner_text("#draft-msg")
    assert page.input_value("#model-name-input") == model["name"]
    assert page.locator("img[src=x]").count() == 0 and page.title() != "owned"
    page.click("#btn-draft-discard")


def test_a_session_named_by_the_address_wins_and_the_draft_is_only_offered(page, server):  # noqa: F811
    model = page.evaluate("clone(S.model)")
    model["jack"]["bore"] = 0.050
    sid = _post(server, "/api/sessions", {"name": "rig", "model": model,
                                          "experiments": [{"dataset_id": "sample-clean-locked-hold"}]})["id"]
    page.evaluate(f"location.hash = '#view=model&session={sid}'")
    page.wait_for_function(f"() => document.getElementById('session-id') && "
                           f"document.getElementById('session-id').textContent === {sid!r}")
    assert page.input_value("#jack-bore") == "50"
    page.fill("#jack-bore", "45")
    page.wait_for_function(f"() => (sessionStorage.getItem({KEY!r}) || '').includes('0.045')")
    _reload(page)                                        # the address still names the session
    assert page.inner_text("#session-id") == sid
    assert page.input_value("#jack-bore") == "50"        # the session's model, not the draft
    assert "not restored" in page.inner_text("#draft-msg") and page.is_visible("#btn-draft-restore")
    page.click("#btn-draft-restore")
    page.wait_for_function("() => document.getElementById('draft-msg').textContent.includes('Restored')")
    assert page.input_value("#jack-bore") == "45" and page.inner_text("#session-id") == sid
    # recording the edits as a version of the session leaves nothing unsaved
    show_view(page, "diagnose")
    page.click("#btn-record-version")
    page.wait_for_function("() => /Recorded/.test(document.getElementById('status-msg').textContent)")
    page.wait_for_function(f"() => sessionStorage.getItem({KEY!r}) === null")
    assert not page.is_visible("#draft-bar")
