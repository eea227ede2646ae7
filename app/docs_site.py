"""The documentation site (``mkdocs build``'s output) served offline at ``/docs-site/``.

The site's readthedocs theme starts its navigation and search from inline scripts (three
a page: the base URL, the page's data, the theme's start), which the page's
Content-Security-Policy (:data:`app.security.CSP`: no inline script) refuses. Each HTML page
of the site is answered with a policy of its own that allows exactly its inline scripts by
their SHA-256 hashes, computed from the file when it is served (:func:`page_policy`): no
``'unsafe-inline'`` for scripts; styles inline as the page's policy allows them (the theme's
``style`` attributes); everything else only from this server.

Files are served from the built folder only (:func:`resolve`): a path with a ``..`` or ``.``
segment, a backslash, a NUL, a ``%`` left after the URL's decoding (a doubly encoded
``%2e%2e``), or one that resolves (symbolic links followed) outside the folder is 404, as is
what is not a file. Where the site is not built the answer is 404 saying how to build it.

The folder: ``PNEUCORE_DOCS_SITE`` (``Settings.docs_site``), else ``site/`` beside the
package, where ``mkdocs build`` writes it (``mkdocs.yml``'s ``site_dir``).
"""
from __future__ import annotations

import base64
import hashlib
import mimetypes
import re
from pathlib import Path

from fastapi import HTTPException
from fastapi.responses import FileResponse, RedirectResponse, Response

#: Where the site is mounted [-]
PREFIX = "/docs-site/"
#: ``mkdocs build``'s output beside the package (mkdocs.yml: ``site_dir: site``)
DEFAULT_SITE = Path(__file__).resolve().parent.parent / "site"

#: An inline script: a ``<script>`` element without ``src``, its text
_INLINE_SCRIPT = re.compile(rb"<script\b(?![^>]*\bsrc\s*=)[^>]*>(.*?)</script\s*>", re.S | re.I)

#: The policy of a site page, ``{hashes}`` its inline scripts' (see the module docstring)
POLICY = ("default-src 'self'; script-src 'self'{hashes}; style-src 'self' 'unsafe-inline'; "
          "img-src 'self' data:; font-src 'self' data:; connect-src 'self'; worker-src 'self'; "
          "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'")

NOT_BUILT = ("the documentation site is not built here: build it with `pip install -e \".[docs]\"` "
             "and `mkdocs build` in the repository root (it writes site/), or set "
             "PNEUCORE_DOCS_SITE to the folder of a built site; the API's reference is at /docs")


def script_hashes(html: bytes):
    """The CSP sources of ``html``'s inline scripts: ``'sha256-<base64>'`` each, in order,
    without repeats [-]."""
    out = []
    for m in _INLINE_SCRIPT.finditer(html):
        h = "'sha256-" + base64.b64encode(hashlib.sha256(m.group(1)).digest()).decode() + "'"
        if h not in out:
            out.append(h)
    return out


def page_policy(html: bytes) -> str:
    """The Content-Security-Policy of a site page: :data:`POLICY` with its scripts' hashes."""
    return POLICY.format(hashes="".join(" " + h for h in script_hashes(html)))


def resolve(root: Path, path: str):
    """The file or folder of the built site at URL path ``path`` (already URL-decoded once),
    or None when it is not one inside ``root`` (see the module docstring)."""
    if any(c in path for c in ("\\", "\x00", "%")):
        return None
    parts = [p for p in path.split("/") if p != ""]
    if any(p in (".", "..") for p in parts):
        return None
    try:
        base = root.resolve(strict=True)
        target = base.joinpath(*parts).resolve(strict=True)
    except (OSError, RuntimeError, ValueError):
        return None
    if target != base and base not in target.parents:
        return None
    return target


def serve(site: str | None, path: str, slash: bool):
    """The answer of ``GET /docs-site/<path>``.

    Parameters
    ----------
    site : str or None
        The built site's folder (None: :data:`DEFAULT_SITE`)
    path : str
        The path below :data:`PREFIX`, URL-decoded [-]
    slash : bool
        Whether the URL ends with a slash (a folder's page is answered only there, so that
        the site's relative links resolve; else redirected) [-]
    """
    root = Path(site) if site else DEFAULT_SITE
    if not (root / "index.html").is_file():
        raise HTTPException(404, NOT_BUILT)
    target = resolve(root, path)
    if target is not None and target.is_dir():
        if not slash and path:
            clean = "/".join(p for p in path.split("/") if p)
            return RedirectResponse(PREFIX + clean + "/", status_code=307)
        target = target / "index.html"
    if target is None or not target.is_file():
        raise HTTPException(404, f"no page {path!r} in the documentation site")
    if target.suffix.lower() == ".html":
        data = target.read_bytes()
        return Response(data, media_type="text/html; charset=utf-8",
                        headers={"Content-Security-Policy": page_policy(data)})
    media = mimetypes.guess_type(target.name)[0] or "application/octet-stream"
    return FileResponse(target, media_type=media)
