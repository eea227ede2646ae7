"""The README's loop figures are what the code prints (issue 24, item 9: they had drifted:
heat coefficient 37.5 against 35.3, 0.711 against 0.714 %, p and delta BIC).

Every figure-bearing fragment quoted in the README's loop section (curl walk-through, Python
loop, shell loop) must occur in what the code prints on the same sample today; a change that
moves a figure fails here until the README is updated with it."""
import re
from pathlib import Path

import pytest

from pneucore import model_preset
from pneucore.analysis.compare import compare
from pneucore.analysis.diagnose import diagnose
from pneucore.analysis.history import refine
from pneucore.data.samples import load_sample

README = Path(__file__).resolve().parent.parent / "README.md"

#: Fragments of the loop's text that carry figures
FIGURES = [
    r"Error [\d.]+ % -> [\d.]+ %",
    r"lowers the overall error from [\d.]+ % to [\d.]+ %",
    r"heat coefficient [\d.]+ -> [\d.]+ W/\(m\^2 K\)",
    r"Coulomb friction extending [\d.]+ -> [\d.]+ N",
    r"\([\d.]+ % -> [\d.]+ %\)",
    r"time_constant = [\d.e-]+ ± [\d.e-]+ s",
    r"Likelihood-ratio p = [\d.e+-]+, delta BIC = -?[\d.]+",
    r"noise floor \([\d.]+ %\)",
    r"^(?:base|\+ \w+) [\d.]+ %",
    r"^version \d+: \S.*?[\d.]+ %",
    r"\{'p_a': [\d.]+, 'p_b': [\d.]+, 'x': [\d.]+\} [\d.]+",
]


def _loop_section():
    text = README.read_text()
    start = text.index("## The loop: compare, diagnose, add, the error falls")
    end = text.index("## What is inside")
    # the quoted output: comment lines, with the comment marks and continuation indents removed
    lines = [re.sub(r"^\s*#\s*", "", ln) for ln in text[start:end].splitlines()
             if ln.lstrip().startswith("#") and not ln.startswith("##")]
    return lines


@pytest.fixture(scope="module")
def printed():
    """What the code prints on the README's sample, in the README's formats."""
    model, exps = model_preset("paper-4way"), load_sample("leak-and-lag")
    out = []
    c = compare(model, exps)
    out.append(f"{ {k: round(v, 4) for k, v in c.errors.items()} } {round(c.overall, 4)}")
    d1 = diagnose(model, exps)
    out += [d1.message, d1.ranking[0]["explanation"]]
    d2 = diagnose(d1.model, exps)
    out.append(d2.message)
    _, history, diagnoses = refine(model_preset("paper-4way"), exps)
    for v in history.versions:
        out.append(f"{v.label} {100 * v.overall:.3f} %")
        out.append(f"version {v.version}: {v.label:<40s} {100 * v.overall:.3g} %")
    out += [d.message for d in diagnoses]
    return out


def test_every_figure_the_readme_quotes_is_printed_by_the_code(printed):
    lines = _loop_section()
    # a fragment broken over two comment lines is read as one line
    joined = " ".join(lines)
    found = []
    for pattern in FIGURES:
        anchored = pattern.startswith("^")
        for src in (lines if anchored else [joined]):
            found += [m.group(0) for m in re.finditer(pattern, src, flags=re.M)]
    assert len(found) >= 12, f"the README's loop section lost its figures: {found}"
    norm = [re.sub(r"\s+", " ", p) for p in printed]
    missing = [f for f in found
               if not any(re.sub(r"\s+", " ", f) in p for p in norm)]
    assert not missing, ("README figures that the code no longer prints (update the README's "
                         f"loop section): {missing}\ncode prints:\n" + "\n".join(printed))
