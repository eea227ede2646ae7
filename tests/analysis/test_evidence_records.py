"""Evidence record by record (issue 22): where an effect removes the misfit in excess of the
noise floor, experiment by experiment (:func:`pneucore.analysis.diagnosis.evidence.experiment_excess`),
and which records' estimates the consistency rule compares
(:func:`pneucore.analysis.diagnosis.evidence.not_compared`).

The long record that needed it (a 1 s hold with a hidden leak beside a 20 s cyclic record whose
position drifts) costs a minute to diagnose: it is a case of the confusion table
(``benchmarks/bench_diagnosis_confusion.py --cases 'long/*'``), not a test here.
"""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from pneucore import Model, model_preset
from pneucore.analysis.compare import noise_floor
from pneucore.analysis.diagnosis import evidence as V
from pneucore.analysis.diagnosis.rules import AT_FLOOR, EXCESS_MATERIAL
from pneucore.analysis.metrics import eq25_error

#: Noise of the synthetic pressure records [Pa] (the paper's transducers: a few hundred Pa)
SIGMA = 300.0


def _record(name, n, seed):
    """A smooth pressure record [Pa abs] and its measurement with white noise ``SIGMA``."""
    t = np.arange(n) * 1e-3
    y = 4e5 + 1.5e5 * np.sin(2 * np.pi * t / (n * 1e-3))
    m = y + np.random.default_rng(seed).normal(0.0, SIGMA, n)
    exp = SimpleNamespace(name=name, measurement=SimpleNamespace(signals={"p_a": m}))
    return t, y, m, exp


def _replay(exp, t, m, sim):
    return SimpleNamespace(experiment=exp, t=t, measured={"p_a": m}, simulated={"p_a": sim})


@pytest.fixture(scope="module")
def hold_and_cyclic():
    """A short record the candidate explains to the noise (a 0.5 % drift the null leaves) and a
    long one whose 0.3 % offset neither explains (null and candidate replays)."""
    t1, y1, m1, e1 = _record("hold", 1000, 1)
    t2, y2, m2, e2 = _record("cyclic", 20000, 2)
    null = [_replay(e1, t1, m1, y1 + 2e3 * t1 / t1[-1]), _replay(e2, t2, m2, y2 + 1.2e3)]
    cand = [_replay(e1, t1, m1, y1), _replay(e2, t2, m2, y2 + 1.21e3)]
    return null, cand


def _pooled(replays):
    """The pooled overall Eq. 25 error of the replays (one signal here) [-]."""
    m = np.concatenate([r.measured["p_a"] for r in replays])
    g = np.concatenate([r.simulated["p_a"] for r in replays])
    return eq25_error(m, g)


def test_the_records_shares_add_up_to_the_pooled_share_of_the_excess(hold_and_cyclic):
    null, cand = hold_and_cyclic
    rows = V.experiment_excess(null, cand)
    floor = noise_floor(null)["p_a"]
    pooled = V.excess_drop(_pooled(null), _pooled(cand), floor)
    # the pooled squared error and floor are sums of one term per record: exact to round-off
    assert sum(r["excess_share"] for r in rows) == pytest.approx(pooled, rel=1e-9)
    # the short record carries most of what is removed, the long one gives a little back
    assert rows[0]["excess_share"] > pooled > 0 > rows[1]["excess_share"]


def test_a_record_is_cleared_when_the_candidate_brings_it_to_its_floor(hold_and_cyclic):
    null, cand = hold_and_cyclic
    hold, cyclic = V.experiment_excess(null, cand)
    assert hold["experiment"] == "hold" and cyclic["experiment"] == "cyclic"
    # the hold's own errors: far above its floor before, at it after (pure noise left; the
    # floor is estimated from second differences: within a few % of SIGMA on 1000 samples)
    assert hold["error_before"] > 3 * hold["noise_floor"]
    assert hold["error_after"] <= AT_FLOOR * hold["noise_floor"] and hold["cleared"]
    assert hold["excess_drop"] > 0.99
    assert not cyclic["cleared"] and cyclic["excess_drop"] < 0
    # each record's own error is its Eq. 25 error alone
    assert hold["error_after"] == pytest.approx(eq25_error(cand[0].measured["p_a"],
                                                           cand[0].simulated["p_a"]), rel=1e-12)


def test_a_replay_that_stopped_early_clears_nothing(hold_and_cyclic):
    null, cand = hold_and_cyclic
    r = cand[0]
    short = SimpleNamespace(experiment=r.experiment, t=r.t[:500], measured={"p_a": r.measured["p_a"][:500]},
                            simulated={"p_a": r.simulated["p_a"][:500]})
    assert not V.experiment_excess(null, [short, cand[1]])[0]["cleared"]


def test_records_the_effect_explains_nothing_of_beside_one_it_clears_are_not_compared():
    rows = [{"experiment": "hold", "cleared": True, "excess_drop": 1.0, "error_before": 0.03,
             "error_after": 0.0007, "noise_floor": 0.0007},
            {"experiment": "cyclic", "cleared": False, "excess_drop": -0.18,
             "error_before": 0.0059, "error_after": 0.0064, "noise_floor": 0.0006},
            {"experiment": "pulses", "cleared": False, "excess_drop": EXCESS_MATERIAL,
             "error_before": 0.01, "error_after": 0.009, "noise_floor": 0.0006}]
    skip = V.not_compared(rows)
    # the cyclic record: the effect removes none of its excess; the pulses keep their say
    # (the effect removes a material share of theirs)
    assert list(skip) == ["cyclic"] and "-18 %" in skip["cyclic"]
    # no record cleared: every record is compared, as before
    rows[0]["cleared"] = False
    assert V.not_compared(rows) == {}


def test_consistency_leaves_out_the_records_it_is_told_to():
    m = Model.from_dict(model_preset("paper-4way"))
    m.effects["piston_leakage"] = {"conductance": 1.5e-10}
    exps = [SimpleNamespace(name=n, scenario={"locked": k}) for n, k in (("hold", True),
                                                                           ("cyclic", False))]
    why = {"hold": "a", "cyclic": "b"}
    out = V.consistency(SimpleNamespace(model=m), exps, "piston_leakage", skip=why)
    # nothing fitted, nothing compared, and the report says which were left out and why
    assert out["consistent"] and out["per_experiment"] == {} and out["not_compared"] == why


def test_the_floor_term_matches_the_pooled_floor(hold_and_cyclic):
    """The pooled floor of the null's records is the root of the sum of the records' floor
    terms (:func:`pneucore.analysis.compare.noise_floor`'s own definition, split)."""
    null, _ = hold_and_cyclic
    pooled = noise_floor(null)["p_a"]
    den = sum(float(np.sum(r.measured["p_a"] ** 2)) for r in null)
    terms = sum(noise_floor([r])["p_a"] ** 2 * float(np.sum(r.measured["p_a"] ** 2)) / den
                for r in null)
    assert math.sqrt(terms) == pytest.approx(pooled, rel=1e-12)
