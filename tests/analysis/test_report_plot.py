"""The report's inline plots: axes labelled on a 1-2-5 grid, a legend that holds its labels."""
import re

import numpy as np
import pytest

from pneucore.analysis.report import nice_ticks, svg_plot


@pytest.mark.parametrize("lo, hi", [(0.0, 1.25), (1.37, 6.2), (-3e-3, 7e-3), (2.0e5, 6.3e5),
                                    (0.0, 20.0), (-1.0, 1.0), (293.1, 297.9)])
def test_ticks_are_round_multiples_of_a_1_2_5_step(lo, hi):
    t = nice_ticks(lo, hi)
    assert t.size >= 2
    step = t[1] - t[0]
    mantissa = step / 10 ** np.floor(np.log10(step))
    # the step is 1, 2 or 5 times a power of ten (float rounding only: 1e-9 relative)
    assert min(abs(mantissa - m) for m in (1, 2, 5, 10)) < 1e-9
    assert np.allclose(np.diff(t), step, rtol=1e-9)
    assert t[0] >= lo - 1e-9 * abs(step) and t[-1] <= hi + 1e-9 * abs(step)
    # every tick is an integer multiple of the step: no 0.2083
    assert np.allclose(t / step, np.round(t / step), atol=1e-9)
    # and written short: %.6g of a tick has no float noise (0.30000000000000004)
    assert all(len(f"{v:.6g}") <= 8 for v in t)


def test_degenerate_range_gives_its_ends():
    assert nice_ticks(2.0, 2.0).tolist() == [2.0, 2.0]
    assert nice_ticks(float("nan"), 1.0).size == 2


def test_plot_ticks_come_from_the_grid_and_the_legend_fits_its_labels():
    t = np.linspace(0.0, 1.37, 200)
    long_label = "model after the refinement's third round"
    svg = svg_plot([(t, 2e5 + 3e5 * t, "measured"), (t, 2e5 + 2.9e5 * t, long_label)],
                   title="p_a", ylabel="p_a [Pa]")
    labels = re.findall(r'text-anchor="middle">([-0-9.e+]+)</text>', svg)
    assert labels and all(abs(float(v) / 0.2 - round(float(v) / 0.2)) < 1e-9 for v in labels)
    rect = re.search(r'<rect class="legend" x="([0-9.]+)" y="[0-9.]+" width="([0-9.]+)"', svg)
    width = float(rect.group(2))
    # 6.5 px a character at 11 px font is a generous width for sans-serif (about 6 px average)
    assert width >= 6.5 * len(long_label)
    # the legend is drawn after the lines, so no line hides it
    assert svg.index('class="legend"') > svg.rindex("<polyline")
    assert "third round" in svg
