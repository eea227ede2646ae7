"""The page says when a test was declared wrongly (issue 24, item 6): a hold test uploaded
without "locked" (its measured position never moves, the model's does) gets a hint next to
the comparison, in Chromium."""
from __future__ import annotations

import re

import numpy as np
import pytest

from pneucore.data.samples import load_sample
from test_page import TIMEOUT_MS, browser, page_errors, server, workbench_page  # noqa: F401


@pytest.fixture(scope="module")
def page(browser, server, page_errors):  # noqa: F811
    yield from workbench_page(browser, server, page_errors)


@pytest.fixture(scope="module")
def hold_file(tmp_path_factory):
    """The shipped hold test with a position channel at the lock (0.02 mm of noise)."""
    hold = next(e for e in load_sample("clean") if e["name"] == "locked-hold")
    m = hold["measurement"]
    x = 0.125 + 2e-5 * np.random.default_rng(5).standard_normal(m.n)
    lines = ["t[s],u[-],p_a[Pa],p_b[Pa],x[m]"]
    lines += [f"{t:.6f},{u:g},{pa:.2f},{pb:.2f},{xi:.7f}"
              for t, u, pa, pb, xi in zip(m.t, m.signals["u"], m.signals["p_a"], m.signals["p_b"], x)]
    path = tmp_path_factory.mktemp("hint") / "hold.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_hold_test_uploaded_as_free_gets_a_hint(page, hold_file):
    page.click("#upload-box summary")
    page.set_input_files("#upload-file", str(hold_file))
    page.wait_for_selector("#upload-mapping select[data-column='x[m]']")
    page.fill("#upload-name", "hold-declared-free")
    page.fill("#upload-x0", "125")
    page.click("#btn-upload")
    page.wait_for_function("() => /hold-declared-free stored/.test(document.getElementById('status-msg').textContent)")
    page.click("#btn-compare")
    hint = page.wait_for_selector(".context-hint[data-kind='declared_free_never_moves']", timeout=TIMEOUT_MS)
    text = hint.inner_text()
    assert re.search(r"stays within [\d.]+ mm", text) and "locked" in text, text
