"""Which experiment would separate two hypotheses the records cannot tell apart?"""
from pneucore import model_preset
from pneucore.analysis.hypotheses import SEPARATES, separating_experiments
from pneucore.data.experiment import as_experiments
from pneucore.data.synthetic import synthetic_experiments
from pneucore.description.model import Model


def _coulomb_in_pb_and_its_constant_twin():
    """3/2 valve: chamber B is held at a constant pressure, so a Coulomb term in p_b
    (friction.*.fc_b) is a constant offset of the Coulomb level (fc0): two models that
    predict the records identically."""
    a = Model.from_dict(model_preset("paper-3way"))
    b = a.copy()
    amb = a.ambient.pressure
    p_b = a.valve.b_chamber_pressure if a.valve.b_chamber_pressure is not None \
        else 0.5 * a.supply.pressure
    for side in ("extend", "retract"):
        fa, fb = getattr(a.friction, side), getattr(b.friction, side)
        fa.fc_b = 4e-5                      # 4e-5 N/Pa x ~2.5 bar gauge: ~10 N
        fb.fc_b = 0.0
        fb.fc0 = fa.fc0 + fa.fc_b * (p_b - amb)
    return a, b


def test_a_chamber_b_pressure_change_separates_coulomb_in_pb_from_a_constant():
    a, b = _coulomb_in_pb_and_its_constant_twin()
    exps = as_experiments(synthetic_experiments(a, seed=3))
    out = separating_experiments(a, b, exps)
    assert out, "some experiment must separate them"
    best = out[0]
    # the records cannot tell them apart: their predictions agree to far below one noise
    # standard deviation per sample (the models are the same function of time there)
    assert best["recorded"] < 1.0, out
    assert best["key"] == "chamber-b", out
    assert "chamber B" in best["experiment"]
    assert best["separation"] >= SEPARATES


def test_two_hypotheses_that_differ_on_the_records_need_no_new_experiment_to_be_offered():
    """Separation is judged against the records: when they already separate A and B, no
    variant is ten times better than them for a mild difference, and identical models give
    nothing at all."""
    a, _ = _coulomb_in_pb_and_its_constant_twin()
    exps = as_experiments(synthetic_experiments(a, seed=3))
    assert separating_experiments(a, a.copy(), exps) == []


def test_the_confounded_twin_predicts_the_records_alike_and_a_variant_tells_them_apart():
    """3/2 rig: the extending Coulomb level is not separable from the viscous coefficient and
    the supply edges' conductance on these records; its twin (moved by its typical error,
    the others compensating) predicts the records nearly alike, while a test with chamber B
    at another pressure separates the two."""
    from pneucore.analysis import hypotheses as H
    from pneucore.analysis.calibrate import Objective
    from pneucore.analysis.compare import replay
    from pneucore.data.synthetic import RIG_CASES, rig_case
    c = rig_case("base/paper-3way", **dict(RIG_CASES)["base/paper-3way"])
    m = Model.from_dict(c.start)
    exps = as_experiments(c.experiments)
    obj = Objective(m, exps, [])
    r0 = obj.weighted([replay(m, e) for e in exps])
    chosen, report, cols = H.identifiable(m, exps, obj, r0, H.offered(m), replay)
    entry = next(h for h in report if h["path"] == "friction.extend.fc0")
    assert entry["status"] == "not separable", report
    twin = H.confounded_twin(m, entry["path"], [h.path for h in chosen], cols)
    # the typical error alone moves the records by its sensitivity; the compensated twin
    # by a small fraction of it (the collinearity threshold leaves at most 10 % of the norm,
    # plus the curvature of a 30 % step)
    r_twin = obj.weighted([replay(twin, e) for e in exps]) - r0
    assert float(r_twin @ r_twin) ** 0.5 < 0.3 * entry["sensitivity"]
    out = separating_experiments(m, twin, exps)
    assert out and out[0]["separation"] >= SEPARATES, out
