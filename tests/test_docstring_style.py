"""Docstrings are numpydoc: a parameter's name and type on one line, its description (with
the ``[unit]``) indented on the next. The one-line form ``name : float  Description`` is
read by numpydoc (and Sphinx) as a type called "float  Description"."""
import os
import re

import pneucore

PKG = os.path.dirname(os.path.abspath(pneucore.__file__))
ONE_LINE = re.compile(r"^\s+\*{0,2}\w+(?:, \*{0,2}\w+)* : \S(?:.*?\S)?  +\S")


def test_no_one_line_parameter_entries():
    bad = []
    for root, dirs, files in os.walk(PKG):
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        for f in sorted(files):
            if f.endswith(".py"):
                path = os.path.join(root, f)
                with open(path, encoding="utf-8") as fh:
                    for i, line in enumerate(fh, 1):
                        if ONE_LINE.match(line):
                            bad.append(f"{os.path.relpath(path, PKG)}:{i}: {line.strip()}")
    assert not bad, "\n".join(bad)


def test_the_check_catches_the_old_form():
    assert ONE_LINE.match("    bore : float  Bore diameter [m]")
    assert not ONE_LINE.match("    bore : float")
    assert not ONE_LINE.match("        Bore diameter [m]")
