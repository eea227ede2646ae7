"""Every docstring example of pneucore runs: a broken ``>>>`` example fails the suite.

The modules are found by scanning the package's files for ``>>>``, so a new
module with examples joins without an edit here. One test per docstring
(module, class or function), named by its dotted name.
"""
from __future__ import annotations

import doctest
import importlib
import os

import pytest

import pneucore

PACKAGE_DIR = os.path.dirname(pneucore.__file__)
OPTIONS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE

#: Examples known to be out of date (xfail, not strict), by doctest name: none at present
STALE: dict = {}


def _modules_with_examples():
    names = []
    for root, dirs, files in os.walk(PACKAGE_DIR):
        dirs[:] = [d for d in dirs if not d.startswith((".", "__"))]
        for f in sorted(files):
            if not f.endswith(".py") or f == "__main__.py":
                continue
            path = os.path.join(root, f)
            with open(path, encoding="utf-8") as fh:
                if ">>>" not in fh.read():
                    continue
            rel = os.path.relpath(path, os.path.dirname(PACKAGE_DIR))[:-3]
            name = rel.replace(os.sep, ".")
            names.append(name[: -len(".__init__")] if name.endswith(".__init__") else name)
    return sorted(names)


def _docstring_tests():
    finder = doctest.DocTestFinder(exclude_empty=True)
    out = []
    for name in _modules_with_examples():
        module = importlib.import_module(name)
        for test in finder.find(module, name):
            if test.examples:
                marks = [pytest.mark.xfail(reason=STALE[test.name], strict=False)] \
                    if test.name in STALE else []
                out.append(pytest.param(test, id=test.name, marks=marks))
    return out


def test_the_scan_finds_the_modules_with_examples():
    mods = _modules_with_examples()
    # modules known to carry examples (the scan must see them, not only what is listed here)
    assert {"pneucore.physics.flow", "pneucore.physics.gas", "pneucore.description.scenario", "pneucore.study.metrics"} <= set(mods)
    assert len(_docstring_tests()) >= 15


@pytest.mark.parametrize("test", _docstring_tests())
def test_docstring_examples_run(test, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)          # an example that writes a file writes it here
    report = []
    runner = doctest.DocTestRunner(optionflags=OPTIONS)
    result = runner.run(test, out=report.append)
    assert result.failed == 0, "".join(report)
