"""The documentation site as the service serves it (issue 40, item 3), in Chromium.

The site is built by MkDocs (as ``tests/test_docs.py`` builds it) and served at ``/docs-site/``
with a Content-Security-Policy of its own that lists the hash of each inline script the
theme writes (``app/docs_site.py``). A policy that missed one would leave the theme's
navigation or search dead, with a CSP violation in the console: the pages are opened, the
navigation counted, a search run, and the console read.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from service import running_service
from test_page import browser  # noqa: F401

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def site_server(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("docs-site")
    site = tmp / "site"
    subprocess.run([sys.executable, "-m", "mkdocs", "build", "-q", "-d", str(site)], cwd=ROOT,
                   check=True, timeout=300)
    with running_service(tmp, tmp / "db.sqlite3", {"PNEUCORE_DOCS_SITE": str(site)}) as url:
        yield url


def test_the_served_site_runs_its_scripts_under_its_own_policy(browser, site_server):  # noqa: F811
    ctx = browser.new_context()
    page = ctx.new_page()
    problems = []
    page.on("console", lambda m: problems.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: problems.append(str(e)))
    try:
        for path, title in (("/docs-site/", "pneucore"),
                            ("/docs-site/guides/loop/", "Compare, diagnose, refine"),
                            ("/docs-site/reference/rest/", "REST reference")):
            r = page.goto(site_server + path)
            assert r.status == 200, path
            assert title in page.title()
            # the theme's navigation, written by its scripts: the whole site's table of contents
            assert page.locator(".wy-menu-vertical a").count() > 50, path
        # the search runs in the theme's web worker, on the index the build wrote
        page.goto(site_server + "/docs-site/search.html?q=leakage")
        results = page.locator("#mkdocs-search-results article")
        results.first.wait_for(timeout=20_000)
        assert results.count() >= 1
        assert problems == [], problems
    finally:
        ctx.close()
