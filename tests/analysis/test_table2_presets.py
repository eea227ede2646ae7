"""The locked-chamber presets against the paper's Table 2 (issue 22, item 8).

The paper's adiabatic and isothermal errors, with its convective model's error removed in
quadrature, are the distances its heat models keep from the convective one on its Figs. 6-7
tests. The presets ``paper-fig6-locked-max`` and ``paper-fig7-locked-min`` (run with
``paper-4way``) must keep the same distances within the issue's factor 1.5 in every cell above
the table's noise; their unprinted openings and timing were fitted for it
(``benchmarks/bench_table2_presets.py --fit``). Six short runs per check.
"""
import math

import pytest

from pneucore.analysis.heat_compare import (PAPER_TABLE2, locked_test_windows, table2_rows,
                                            table2_target)
from pneucore.description.presets import scenario_preset

#: The issue's criterion: a preset's distance within this factor of the table's, either way
FACTOR = 1.5


@pytest.fixture(scope="module")
def rows():
    return table2_rows("paper-4way")


def test_every_cell_above_the_noise_within_the_factor(rows):
    above = [r for r in rows if r["target"] is not None]
    # six cells: both models, valve opening at the largest volume and closing at both volumes
    assert len(above) == 6
    for r in above:
        assert 1 / FACTOR <= r["ratio"] <= FACTOR, r


def test_cells_below_the_noise_stay_under_the_triangle_bound(rows):
    below = [r for r in rows if r["target"] is None]
    assert {(r["move"], r["volume"]) for r in below} == {("opens", "min")}
    for r in below:
        # two errors of 0.94 % and 0.95 % against the same record: the models differ by <= 1.89 %
        assert r["distance"] <= r["bound"] == pytest.approx(1.89), r


def test_the_pattern_of_the_table(rows):
    """What Fig. 8's text says, on the presets: closing (expansion) the isothermal model is the
    nearer one and both move furthest at the largest volume; opening at the largest volume the
    two are as far as each other (the table's 2.82 / 2.82 %)."""
    d = {(r["move"], r["volume"], r["model"]): r["distance"] for r in rows}
    for vol in ("min", "max"):
        assert d[("closes", vol, "isothermal")] < d[("closes", vol, "adiabatic")]
    assert d[("closes", "max", "adiabatic")] > d[("closes", "min", "adiabatic")]
    # equal in the table; the fit matches each to 2 %, so 5 % apart at most
    assert d[("opens", "max", "adiabatic")] == pytest.approx(d[("opens", "max", "isothermal")], rel=0.05)


def test_the_criterion_rejects_the_earlier_presets():
    """The tests before the fit (full opening, exhaust at 0.55 s, 1 s records): nearly adiabatic
    gas, the adiabatic distances 4-5 times too small; the check would have failed."""
    old = {}
    for vol, name in (("max", "paper-fig6-locked-max"), ("min", "paper-fig7-locked-min")):
        sd = scenario_preset(name)
        sd.update(command=[[0.0, 0.0], [0.05, 1.0], [0.55, -1.0]], duration=1.0)
        old[vol] = sd
    off = [r for r in table2_rows("paper-4way", old) if not r["ok"]]
    assert {(r["move"], r["volume"], r["model"]) for r in off} >= {
        ("opens", "max", "adiabatic"), ("closes", "max", "adiabatic"), ("closes", "max", "isothermal")}


def test_targets_remove_the_convective_error_in_quadrature():
    t, bound = table2_target("closes", "max", "adiabatic")
    assert t == pytest.approx(math.sqrt(13.08 ** 2 - 2.01 ** 2)) and bound == pytest.approx(15.09)
    assert table2_target("opens", "min", "isothermal")[0] is None   # 0.94 % < 0.95 %: noise
    assert len(PAPER_TABLE2) == 4


def test_a_test_must_open_then_close():
    assert locked_test_windows({"command": [[0, 0], [0.05, 1.0], [0.5, 1.0], [2.0, -0.3]]}) == 2.0
    with pytest.raises(ValueError, match="two command changes"):
        locked_test_windows({"command": [[0, 0], [0.05, 1.0]]})
