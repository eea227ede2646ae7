"""The documentation site builds, warnings as errors, and is complete (issue 40, item 3).

``mkdocs build --strict`` (the CI's build: a broken link, a missing anchor, a page left out of
the nav or a docstring mkdocstrings cannot read fails it) into a temporary folder; then every
module of ``pneucore`` has its API reference page, the REST reference lists every operation of
the service's OpenAPI document, and every link of the README into ``docs/`` resolves to a page
of the site. Skipped only where MkDocs is not installed (``pip install -e ".[test]"`` installs
it).
"""
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("mkdocs")
pytest.importorskip("mkdocstrings")

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    out = tmp_path_factory.mktemp("site")
    t0 = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)
    elapsed = time.perf_counter() - t0
    assert run.returncode == 0, f"mkdocs build --strict failed:\n{run.stdout}\n{run.stderr}"
    print(f"mkdocs build --strict: {elapsed:.1f} s")
    return out


def _modules():
    names = []
    for path in sorted((ROOT / "pneucore").rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        names.append(".".join(parts))
    return names


def _page(site, md):
    """The built page of a Markdown source (``use_directory_urls``)."""
    md = md.removesuffix(".md")
    if md == "index" or md.endswith("/index"):
        return site / md.removesuffix("index") / "index.html"
    return site / md / "index.html"


def test_every_module_has_a_reference_page(site):
    modules = _modules()
    assert "pneucore.simulate" in modules and len(modules) > 50
    missing = [m for m in modules if not _page(site, f"reference/api/{m}.md").is_file()]
    assert not missing, f"modules without an API reference page: {missing}"
    # a page holds the module's documentation, not only its title
    page = _page(site, "reference/api/pneucore.description.model.md").read_text()
    assert "Jack" in page and "[m]" in page


def test_the_rest_reference_lists_every_operation(site):
    from app.main import app
    page = _page(site, "reference/rest.md").read_text()
    ops = [(m.upper(), p) for p, item in app.openapi()["paths"].items() for m in item
           if m in ("get", "post", "put", "patch", "delete")]
    assert len(ops) > 20
    missing = [f"{m} {p}" for m, p in ops if f"{m} {p}" not in page]
    assert not missing, f"operations missing from the REST reference: {missing}"
    assert (site / "reference" / "openapi.json").is_file()


def test_readme_links_into_docs_resolve(site):
    readme = (ROOT / "README.md").read_text()
    links = re.findall(r"\]\((docs/[^)#\s]+)(?:#[^)]*)?\)", readme)
    assert len(links) >= 10, links
    for link in links:
        target = ROOT / link
        assert target.exists(), f"README links to {link}, which does not exist"
        if link.endswith(".md"):
            built = _page(site, link.removeprefix("docs/"))
            assert built.is_file(), f"README links to {link}, which the site does not build"


def test_the_moved_readme_content_keeps_its_figures():
    """The README's sections moved to docs/ whole: a few of their figures, each with its
    machine or source beside it, are where the docs say they are."""
    bench = (ROOT / "docs" / "benchmarks.md").read_text()
    assert "Machine: AMD EPYC, 2 cores, Python 3.11.7" in bench
    validation = (ROOT / "docs" / "validation.md").read_text()
    assert "Thorncroft, Patton & Gordon" in validation and "| **natural_and_jet + sensor** |" in validation
    server = (ROOT / "docs" / "guides" / "server.md").read_text()
    assert "Memory per request" in server and "benchmarks/bench_request_memory.py" in server


def test_the_getting_started_example_prints_what_it_says():
    """The first Python example of the getting-started page runs, and prints the figures
    quoted under it (the ``# ...`` line after each ``print``)."""
    import contextlib
    import io
    text = (ROOT / "docs" / "getting-started.md").read_text()
    section = text[text.index("## A first simulation from Python"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    quoted = [ln[2:].strip() for ln in code.splitlines() if ln.startswith("# ")]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "getting-started.md", "exec"), {})
    assert out.getvalue().split("\n")[:-1] == quoted
