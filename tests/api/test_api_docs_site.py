"""The documentation site served at /docs-site/ (issue 40, item 3; :mod:`app.docs_site`).

A built site's pages come with a Content-Security-Policy of their own that allows exactly
their inline scripts by hash (the page's policy refuses inline scripts, which the readthedocs
theme needs); nothing outside the built folder is ever served, whatever the encoding of a
``..``; an unbuilt site is a 404 that says how to build it; /docs is as it was.
"""
from __future__ import annotations

import base64
import hashlib
import os

import pytest
from fastapi.testclient import TestClient

from app.config import Limits, Settings
from app.docs_site import resolve, script_hashes
from app.main import create_app
from app.security import CSP

SCRIPTS = ('var base_url = "..";', '\n  jQuery(function () { SphinxRtdTheme.Navigation.enable(true); });\n')
PAGE = ("<!DOCTYPE html><html><head><script src=\"js/theme.js\"></script>"
        f"<script>{SCRIPTS[0]}</script></head><body style=\"margin: 0\">site page"
        f"<script type=\"text/javascript\">{SCRIPTS[1]}</script></body></html>")
SECRET = "the server's secret"


@pytest.fixture
def site(tmp_path):
    """A small built site (two pages, a style sheet) beside a file that must never be served."""
    root = tmp_path / "site"
    (root / "guides" / "memory").mkdir(parents=True)
    (root / "css").mkdir()
    (root / "index.html").write_text(PAGE)
    (root / "guides" / "memory" / "index.html").write_text(PAGE.replace("site page", "memory"))
    (root / "css" / "theme.css").write_text("body { color: black }")
    (tmp_path / "secret.txt").write_text(SECRET)
    os.symlink(tmp_path / "secret.txt", root / "link.txt")
    return root


def _client(tmp_path, site_dir):
    app = create_app(Settings(db_path=str(tmp_path / "api.sqlite3"), limits=Limits(),
                              docs_site=str(site_dir)))
    return TestClient(app, base_url="http://127.0.0.1", raise_server_exceptions=False)


def _sha(text):
    return "'sha256-" + base64.b64encode(hashlib.sha256(text.encode()).digest()).decode() + "'"


def test_a_page_has_a_policy_allowing_its_inline_scripts_by_hash_and_nothing_inline(tmp_path, site):
    with _client(tmp_path, site) as c:
        r = c.get("/docs-site/")
        sub = c.get("/docs-site/guides/memory/")
    assert r.status_code == 200 and "site page" in r.text
    policies = r.headers.get_list("content-security-policy")
    assert len(policies) == 1, policies   # its own alone: a second would be enforced besides
    script_src = [d for d in policies[0].split(";") if d.strip().startswith("script-src")][0]
    assert script_src.split()[1:] == ["'self'", _sha(SCRIPTS[0]), _sha(SCRIPTS[1])]
    assert "unsafe-inline" not in script_src and "unsafe-eval" not in policies[0]
    assert "frame-ancestors 'none'" in policies[0] and "object-src 'none'" in policies[0]
    assert r.headers["x-content-type-options"] == "nosniff"
    assert sub.status_code == 200 and "memory" in sub.text


def test_the_hashes_follow_the_file_as_it_is_when_served(tmp_path, site):
    with _client(tmp_path, site) as c:
        first = c.get("/docs-site/").headers["content-security-policy"]
        (site / "index.html").write_text(PAGE.replace(SCRIPTS[0], 'var base_url = ".";'))
        second = c.get("/docs-site/").headers["content-security-policy"]
    assert _sha(SCRIPTS[0]) in first and _sha('var base_url = ".";') in second
    assert _sha(SCRIPTS[0]) not in second


def test_assets_and_folders(tmp_path, site):
    with _client(tmp_path, site) as c:
        css = c.get("/docs-site/css/theme.css")
        folder = c.get("/docs-site/guides/memory", follow_redirects=False)
        bare = c.get("/docs-site", follow_redirects=False)
        missing = c.get("/docs-site/nowhere.html")
    assert css.status_code == 200 and css.headers["content-type"].startswith("text/css")
    assert css.headers["content-security-policy"] == CSP   # not a page: the service's own
    # a folder's page only under its slash, so that the site's relative links resolve
    assert folder.status_code == 307 and folder.headers["location"] == "/docs-site/guides/memory/"
    assert bare.status_code == 307 and bare.headers["location"] == "/docs-site/"
    assert missing.status_code == 404


@pytest.mark.parametrize("path", [
    "/docs-site/..%2Fsecret.txt", "/docs-site/%2e%2e/secret.txt", "/docs-site/%2E%2E%2Fsecret.txt",
    "/docs-site/guides/..%2F..%2F..%2Fsecret.txt", "/docs-site/%252e%252e%252fsecret.txt",
    "/docs-site/..%5Csecret.txt", "/docs-site/%2Ftmp%2Fsecret.txt", "/docs-site//etc/passwd",
    "/docs-site/link.txt", "/docs-site/css/%00theme.css", "/docs-site/%2e/index.html"])
def test_nothing_outside_the_built_site_is_served(tmp_path, site, path):
    with _client(tmp_path, site) as c:
        r = c.get(path, follow_redirects=False)
    assert r.status_code == 404, (path, r.status_code)
    assert SECRET not in r.text


def test_the_resolution_refuses_every_way_out(tmp_path, site):
    for path in ("../secret.txt", "guides/../../secret.txt", "..", "/../secret.txt",
                 "..\\secret.txt", "%2e%2e/secret.txt", "link.txt", "a\x00b"):
        target = resolve(site, path)
        assert target is None or site.resolve() in target.parents, path
    assert resolve(site, "guides/memory/index.html") == (site / "guides/memory/index.html").resolve()


def test_an_unbuilt_site_is_404_saying_how_to_build_it(tmp_path):
    with _client(tmp_path, tmp_path / "not-built") as c:
        r = c.get("/docs-site/")
        docs = c.get("/docs")
    assert r.status_code == 404 and "mkdocs build" in r.json()["detail"]
    # the API's docs as they were: the service's policy, Swagger UI started from a file
    assert docs.status_code == 200 and docs.headers["content-security-policy"] == CSP
    assert "/static/swagger-init.js" in docs.text


def test_the_page_header_links_the_site(tmp_path, site):
    with _client(tmp_path, site) as c:
        page = c.get("/").text
    header = page[page.index("<header"):page.index("</header>")]
    assert 'href="/docs-site/"' in header and 'href="/docs"' in header


def test_script_hashes_are_those_of_the_inline_scripts_only():
    html = b'<script src="a.js"></script><script>x=1</script><SCRIPT >x=1</SCRIPT><script>y</script>'
    assert script_hashes(html) == [_sha("x=1"), _sha("y")]
