"""The page under its Content-Security-Policy, with hostile stored text, and behind a token.

Real headless Chromium (Playwright) against uvicorn subprocesses. A CSP violation is
logged by Chromium as a console error, which fails these tests like any script error.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import urllib.error
import urllib.request

import pytest
from service import ROOT, free_port, running_service
from test_page import CHROMIUM_ARGS, CHROMIUM, TIMEOUT_MS  # noqa: F401  (same browser set-up)

HOSTILE = '<img src=x onerror="window.__pwned=1">'


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright
    pw = sync_playwright().start()
    b = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True)
    yield b
    b.close()
    pw.stop()


def _open(browser, url, errors):
    ctx = browser.new_context()
    page = ctx.new_page()
    page.set_default_timeout(TIMEOUT_MS)
    page.on("pageerror", lambda exc: errors.append(f"page error: {exc}"))
    page.on("console", lambda m: errors.append(f"console {m.type}: {m.text}")
            if m.type == "error" and "Failed to load resource" not in m.text else None)
    page.goto(url)
    page.wait_for_function("() => document.body.dataset.ready", timeout=TIMEOUT_MS)
    assert page.evaluate("document.body.dataset.ready") == "true", page.inner_text("#status")
    return ctx, page


def _post(url, path, body, ctype, headers=None):
    req = urllib.request.Request(url + path, data=body, method="POST",
                                 headers={"content-type": ctype, **(headers or {})})
    with urllib.request.urlopen(req, timeout=60) as r:
        return r.read()


def test_stored_text_is_shown_as_text_under_the_csp(browser, tmp_path):
    import json
    csv = "t[s],u[-],p_a[bar]\n" + "".join(f"{i * 0.001:.3f},{0 if i < 5 else 1},{1 + 0.01 * i:.2f}\n"
                                           for i in range(20))
    with running_service(tmp_path, tmp_path / "xss.sqlite3") as url:
        did = json.loads(_post(url, f"/api/datasets?name={urllib.request.quote(HOSTILE)}",
                               csv.encode(), "text/csv"))["id"]
        errors = []
        ctx, page = _open(browser, url + "/#view=data", errors)   # the workspace view with the picker
        page.select_option("#dataset-select", f"ds:{did}")
        page.wait_for_function("(n) => document.querySelector('#dataset-info').textContent.includes(n)",
                               arg=HOSTILE)
        assert page.evaluate("window.__pwned") is None
        assert page.locator("#dataset-info img").count() == 0
        assert HOSTILE in page.inner_text("#dataset-select")
        assert errors == [], errors
        ctx.close()


def test_page_works_behind_a_token(browser, tmp_path):
    """PNEUCORE_TOKEN set: the page, opened once as /?token=..., works on its cookie."""
    token = "tok-3f9a_Z"
    port = free_port()
    env = dict(os.environ, PNEUCORE_DB=str(tmp_path / "tok.sqlite3"), PNEUCORE_TOKEN=token,
               PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "uvicorn", "app.main:app", "--host", "127.0.0.1",
                             "--port", str(port), "--log-level", "warning"], cwd=ROOT, env=env,
                            start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}"
    try:
        t0 = time.monotonic()
        while True:   # up when it refuses us for want of the token; 90 s: a start-up bound
            try:
                urllib.request.urlopen(url + "/api/presets", timeout=2)
                pytest.fail("the service answered without its token")
            except urllib.error.HTTPError as e:
                assert e.code == 401
                break
            except OSError:
                assert time.monotonic() - t0 < 90 and proc.poll() is None, "service did not start"
                time.sleep(0.2)
        errors = []
        ctx, page = _open(browser, f"{url}/?token={token}", errors)
        # the token left the address bar; the workspace keeps its view there (#view=...)
        assert page.url.split("#")[0] == url + "/" and "token" not in page.url, page.url
        # the page's own API calls carry the cookie: the dataset picker was filled from the API
        assert page.locator("#dataset-select option").count() > 0
        assert errors == [], errors
        ctx.close()
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(10)
