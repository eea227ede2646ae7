"""A designer's study metrics (issue 41 item 7): the stroke-end kinetic energy and its ratio to
the cushion's capacity, as the stroke table gives them."""
import pytest

from pneucore import model_preset, simulate
from pneucore.study import run_study
from pneucore.study.metrics import METRICS

CYCLE = {"duration": 1.0, "sample_period": 0.001, "command": [[0, 0], [0.01, 1], [0.5, -1]],
         "x0": 0.0}


def test_end_energy_and_energy_ratio_are_study_metrics():
    assert METRICS["end_energy_max"].unit == "J" and METRICS["energy_ratio_max"].unit == "-"
    m = model_preset("paper-4way")
    m["effects"] = {"end_cushion": {"length_a": 0.02, "volume_a": 0.0, "C_a": 2e-9, "length_b": 0.02,
                                    "volume_b": 0.0, "C_b": 2e-9, "b": 0.3, "capacity": 0.5}}
    study = {"model": m, "scenario": CYCLE, "samples": 2, "seed": 1,
             "parameters": {"supply.pressure": {"distribution": "uniform", "min": 6e5, "max": 6e5 + 1.0}},
             "metrics": ["end_energy_max", "energy_ratio_max"]}
    runs = run_study(study, None, workers=0)["results"]["runs"]["metrics"]
    ref = simulate(dict(m, supply=dict(m["supply"], pressure=6e5)), CYCLE).stroke_metrics()
    ratio = max(s["energy_ratio"] for s in ref["strokes"] if s["energy_ratio"] is not None)
    for e, r in zip(runs["end_energy_max"], runs["energy_ratio_max"]):
        # 1 Pa of supply spread: the same strokes to 1e-4
        assert e == pytest.approx(ref["end_energy_max"], rel=1e-4)
        assert r == pytest.approx(ratio, rel=1e-4) and r == pytest.approx(e / 0.5, rel=1e-4)
