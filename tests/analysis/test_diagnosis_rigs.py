"""Rigs as users meet them: every base parameter somewhat off, nothing declared.

Each case (:func:`pneucore.data.synthetic.rig_case`) starts from the catalogue
model, draws an error for every base parameter of
:data:`pneucore.data.synthetic.RIG_BASE_ERRORS` (friction levels and viscous
coefficients per direction 15-40 %, moving mass 5-20 %, heat coefficient
20-60 %, valve conductance 8-20 %, supply pressure 2-6 %), and records the
true rig through the paper's 12-bit acquisition with noise. The diagnosis
gets the catalogue model and the records, and nothing else. Each test
asserts the full set of findings of its case: which base parameters are
mis-set, which catalog effect is missing (exactly the hidden ones), and
whether what remains lies outside the catalog.

"Noise floor" is the Eq. 25 error of the true model on the same records: the
best any model can do. The full confusion table over more cases is printed by
``benchmarks/bench_diagnosis_confusion.py``.
"""
import functools
import json

import pytest

from api_conftest import db_path  # noqa: F401  (fixture)
from pneucore.analysis.compare import compare
from pneucore.analysis.diagnose import check_request, diagnose
from pneucore.data.experiment import as_experiments
from pneucore.analysis.history import refine
from pneucore.analysis.hypotheses import identifiable, offered
from pneucore.description.model import Model
from pneucore.description.paths import get_value

#: The valve edge groups as base-parameter paths (supply edges P-*, exhaust edges *-R)
GROUPS = {g: f"valve.ports.{pat}.C" for g, pat in {"supply": "P-*", "exhaust": "*-R"}.items()}
from pneucore.data.synthetic import RIG_CASES, rig_case
from pneucore.description.validation import FieldError

#: The recalibrated model must come within 20 % of the noise floor: ~8 base parameters against
#: ~5000 samples leave the fit a fraction of a percent above the truth's error; 20 % allows an
#: optimiser stopped by its budget, not a missing effect (those leave several times the floor)
FLOOR_FACTOR = 1.2
#: A recalibrated base parameter must come back within 10 % of the truth: identifiable
#: parameters are fitted to well under 1 % on these records (tests below print them); the
#: Coulomb levels, seen only in the few starts and stops of the free test, to a few percent
PARAM_RTOL = 0.10


@functools.lru_cache(maxsize=None)
def case(name):
    c = rig_case(name, **dict(RIG_CASES)[name])
    floor = compare(c.truth, c.experiments).overall
    return c, as_experiments(c.experiments), floor


@functools.lru_cache(maxsize=None)
def diagnosis(name):
    c, exps, _ = case(name)
    return diagnose(c.start, exps)


def describe(d):
    lines = [f"verdict={d.verdict!r}; {d.message}"]
    for r in d.ranking:
        lines.append(f"  {r['effect']}: err {r['error_after_overall']:.5f} dBIC {r['delta_bic']:.1f} "
                     f"excess {r['excess_drop']:.2f} sig {r['significant']} mat {r['material']}")
    lines.append(f"  remaining {d.remaining}")
    return "\n".join(lines)


def assert_recalibrated(c, d, rtol=PARAM_RTOL):
    """Every base error the diagnosis recalibrated comes back near the truth; the large ones all."""
    truth = Model.from_dict(c.truth)
    got = {r["path"]: r for r in d.recalibrate}
    for path, (v0, v1) in c.misset.items():
        if path.startswith("valve."):
            # a scale factor on the catalogue table; a scale of every edge is found as the
            # same scale of each edge group
            paths = [GROUPS[g] for g in GROUPS] if path == "valve.ports.*.C" else [path]
            want = v1
        else:
            paths = [path]
            want = get_value(truth, path)
        for p in paths:
            if p in got:
                assert got[p]["before"] == pytest.approx(v0, rel=1e-12)
                assert abs(got[p]["after"] - want) <= rtol * abs(want), (p, got[p], want)
                assert got[p]["unit"], p
    # the errors that matter most for these records are all found: valve conductance (of the
    # supply edges at least) and supply pressure (each >= 2 % off and seen in both experiments)
    for path in (GROUPS["supply"], "supply.pressure"):
        assert path in got, (path, describe(d))


# ----------------------------------------------------------------- base errors alone

def test_base_errors_alone_name_no_effect_and_recalibrate():
    c, exps, floor = case("base/paper-4way")
    d = diagnosis("base/paper-4way")
    assert d.verdict is None, describe(d)
    assert d.message.startswith("no catalog effect explains"), d.message
    assert "mis-set:" in d.message.lower()
    assert_recalibrated(c, d)
    # the recalibrated model is the next version, at the floor
    assert d.remaining["at_floor"] and not d.remaining["outside_catalog"], describe(d)
    assert compare(d.model, exps).overall <= FLOOR_FACTOR * floor, describe(d)
    out = json.loads(json.dumps(d.to_dict(), allow_nan=False))
    assert out["verdict"] is None
    for r in out["recalibrate"]:
        assert {"path", "before", "after", "stderr", "unit"} <= set(r)
    assert {"error", "noise_floor", "outside_catalog"} <= set(out["remaining"])
    assert out["model"]["effects"] == {}


def test_coloured_noise_and_base_errors_name_nothing():
    """Noise low-pass filtered at 20 ms: neither a stand-in effect nor 'outside the catalog'."""
    c, exps, floor = case("base/coloured-noise")
    d = diagnosis("base/coloured-noise")
    assert d.verdict is None, describe(d)
    assert not d.remaining["outside_catalog"], describe(d)
    assert_recalibrated(c, d)
    assert compare(d.model, exps).overall <= FLOOR_FACTOR * floor, describe(d)


def test_a_mis_set_exhaust_conductance_is_reported_as_such():
    """Only the exhaust edges' conductance is off (x0.7): that group is recalibrated, the
    supply edges are not, and no effect stands in for it."""
    c, exps, floor = case("base/exhaust-conductance")
    d = diagnosis("base/exhaust-conductance")
    assert d.verdict is None, describe(d)
    got = {r["path"]: r for r in d.recalibrate}
    # the scale of a conductance table is fitted to well under 1 % on these records
    assert got[GROUPS["exhaust"]]["after"] == pytest.approx(0.7, rel=0.02), describe(d)
    assert GROUPS["supply"] not in got, describe(d)
    assert d.remaining["at_floor"], describe(d)
    assert "exhaust edges" in d.message


def test_an_undeclared_load_is_reported_with_the_friction_it_is_confounded_with():
    """A 40 N load the catalogue model does not have. While the piston moves, a constant load
    is a combination of the two Coulomb levels (extending fc + L, retracting fc - L): the
    data identify the combination, the retracting level cannot go below 0, so the load is
    fitted and reported together with the Coulomb levels; no effect is named."""
    c, exps, floor = case("base/load")
    d = diagnosis("base/load")
    assert d.verdict is None, describe(d)
    got = {r["path"]: r for r in d.recalibrate}
    assert "jack.load_force" in got, describe(d)
    load = got["jack.load_force"]
    assert set(load["confounded_with"]) == {"friction.extend.fc0", "friction.retract.fc0"}
    # the identified combinations come back (truth: extending 8 + 40 N, retracting 10 - 40 N);
    # 1 N on ~50 N: the combination is fitted to a fraction of a newton on these records
    fe, fr = got["friction.extend.fc0"]["after"], got["friction.retract.fc0"]["after"]
    assert fe + load["after"] == pytest.approx(48.0, abs=1.0), describe(d)
    assert fr - load["after"] == pytest.approx(-30.0, abs=1.0), describe(d)
    # and the retracting level stays physical, so the load is at least 30 N
    assert fr >= 0.0 and load["after"] >= 30.0 - 1.0
    assert "only in combination" in d.message
    assert compare(d.model, exps).overall <= FLOOR_FACTOR * floor, describe(d)


def test_a_rig_left_pressurised_is_reported_as_its_initial_state():
    """Position-only records of a rig whose chambers start at 2.5 and 4.5 bar (not declared:
    the replay assumes ambient): the initial state is fitted from the samples before the
    first command change, and nothing else is taken for it."""
    c, exps, floor = case("base/pressurised-start")
    d = diagnosis("base/pressurised-start")
    assert d.verdict is None and d.recalibrate == [], describe(d)
    got = {(r["experiment"], r["path"]): r for r in d.initial_state}
    assert set(got) == {("free-pulses", "initial.p_a"), ("free-pulses", "initial.p_b")}, got
    # the pressures come back within 0.1 bar: the quiet 0.18 s before the first pulse, the
    # piston moving under their difference, pins them to well under that (fitted: ~0.3 mbar)
    assert got[("free-pulses", "initial.p_a")]["after"] == pytest.approx(2.5e5, abs=1e4)
    assert got[("free-pulses", "initial.p_b")]["after"] == pytest.approx(4.5e5, abs=1e4)
    assert got[("free-pulses", "initial.p_a")]["unit"] == "Pa"
    assert d.remaining["at_floor"], describe(d)
    assert "initial state not in the records" in d.message.lower()


def test_refine_carries_a_fitted_initial_state_into_its_history():
    """The refine loop on the rig left pressurised: the history's last version is compared
    with the experiments started from the fitted initial state, so its error is at the noise
    floor (it stayed at ~110 % when the history replayed the experiments as declared)."""
    c, exps, _ = case("base/pressurised-start")
    model, history, diagnoses = refine(c.start, exps, max_rounds=2)
    assert diagnoses[0].initial_state, describe(diagnoses[0])
    # the noise floor the diagnosis estimates from the records (the case's own "truth replayed"
    # floor starts from ambient too, as declared, so it is no floor here)
    floor = diagnoses[0].remaining["noise_floor"]
    last = history.versions[-1]
    assert last.label.startswith("initial state:"), [v.label for v in history.versions]
    assert history.versions[0].overall > 10 * floor        # as declared: far off
    assert last.overall <= FLOOR_FACTOR * floor, (last.overall, floor)


def test_a_rig_started_at_ambient_reports_no_initial_state():
    """The same position-only records started at ambient, every base parameter off: the base
    errors are not taken for an initial state."""
    d = diagnosis("base/position-only")
    assert d.initial_state == [], d.initial_state
    assert any(h.get("path") == "initial.p_a" for h in d.identifiability)


# ----------------------------------------------------------------- base errors and an effect

@pytest.mark.parametrize("name", ["effect/piston_leakage", "effect/external_leakage/50mm"])
def test_effect_behind_base_errors_is_named_with_the_recalibration(name):
    c, exps, floor = case(name)
    d = diagnosis(name)
    (hidden,) = c.effects
    assert d.verdict == hidden, describe(d)
    assert d.ranking[0]["effect"] == hidden
    assert d.ranking[0]["consistent"] is True, d.ranking[0].get("consistency")
    assert d.alternatives == [] or all(a["kind"] == "base" for a in d.alternatives), d.alternatives
    assert d.recalibrate, describe(d)
    # the next model carries the effect and the recalibration, and is at the floor
    assert set(d.model.effects) == {hidden}
    assert compare(d.model, exps).overall <= FLOOR_FACTOR * floor, describe(d)
    assert not d.remaining["outside_catalog"]


def test_refine_finds_two_effects_behind_base_errors_and_stops_at_the_floor():
    c, exps, floor = case("effect/leak+spool")
    model, hist, diags = refine(c.start, exps)
    assert set(model.effects) == set(c.effects), [d.message for d in diags]
    added = [v.added for v in hist.versions[1:] if v.added]
    assert set(added) == set(c.effects), [v.label for v in hist.versions]
    # the error falls version by version, to the floor
    errs = [v.overall for v in hist.versions]
    assert all(b < a for a, b in zip(errs, errs[1:])), errs
    assert errs[-1] <= FLOOR_FACTOR * floor, (errs, floor)
    assert diags[-1].remaining["at_floor"]
    assert hist.versions[1].recalibrated, "the first round corrects the mis-set base too"


# ----------------------------------------------------------------- outside the catalog

def test_transducer_offset_is_outside_the_catalog():
    """A 0.2 bar offset on the chamber-B transducer: no catalog effect, and said so."""
    c, exps, floor = case("outside/pressure-offset/50mm")
    d = diagnosis("outside/pressure-offset/50mm")
    assert d.verdict is None, describe(d)
    rem = d.remaining
    assert rem["outside_catalog"], describe(d)
    assert rem["error"] > 3 * rem["noise_floor"]
    sig = rem["signature"]
    # the remainder sits on p_b and is a constant: what an offset looks like
    assert sig["signal"] == "p_b" and sig["proportional_to"] == "1", sig
    assert "outside the catalog" in d.message.lower()
    # the words describe the fit returned (issue 22): the base fit before the sensor's zero was
    # found put a Coulomb level at its bound, the one returned holds a plausible value; no
    # value the message calls implausible is one the returned fit has plausible
    plausible = [r for r in d.refitted if not r.get("implausible")]
    for r in plausible:
        assert f"Implausible: {r['label']}" not in d.message, describe(d)
    held = rem.get("held_at_catalogue")
    if held and held.get("null_fit"):
        for o in held["null_fit"]["parameters"]:
            assert f"{o['after']:.3g} {o['unit']}" not in d.message, describe(d)


# ----------------------------------------------------------------- what the data can identify

def test_a_locked_test_cannot_identify_friction_or_mass():
    """The piston is locked: friction and moving mass have no effect, the heat coefficient has."""
    c, exps, _ = case("base/paper-4way")
    locked = [e for e in exps if e.scenario.get("locked")]
    model = Model.from_dict(c.start)
    from pneucore.analysis.calibrate import Objective
    from pneucore.analysis.compare import replay
    obj = Objective(model, locked, [])
    r0 = obj.weighted([replay(model, e) for e in locked])
    chosen, report, _ = identifiable(model, locked, obj, r0, offered(model), replay)
    status = {h["path"]: h["status"] for h in report}
    for p in ("friction.extend.fc0", "friction.retract.kv0", "jack.moving_mass", "jack.load_force"):
        assert status[p] == "not visible", status
    for p in ("heat.coefficient", "supply.pressure", GROUPS["supply"], GROUPS["exhaust"]):
        assert status[p] == "identifiable", status


# ----------------------------------------------------------------- bad input

@pytest.mark.parametrize("path", ["jack.area_a", "supply.pressure.real", "heat.bogus"])
def test_uncertain_that_is_not_a_parameter_is_refused_by_name(path):
    c, exps, _ = case("base/paper-4way")
    with pytest.raises(FieldError) as ei:
        check_request(Model.from_dict(c.start), None, ["heat.coefficient", path])
    assert ei.value.path == "uncertain[1]" and path in ei.value.detail


def test_api_refuses_a_property_or_attribute_path_with_422(db_path):  # noqa: F811
    from api_conftest import LEAK_IDS, api, assert_field_error, model
    with api(db_path) as c:
        for path in ("jack.area_a", "supply.pressure.real"):
            r = c.post("/api/diagnose", json={"model": model(), "uncertain": [path],
                                              "experiments": [{"dataset_id": i} for i in LEAK_IDS]})
            assert_field_error(r, "uncertain[0]", msg_contains=path)


def test_an_experiment_that_moves_nothing_is_said_to_identify_no_base_parameter():
    """Valve closed throughout, piston locked: no base parameter changes a signal."""
    from pneucore import model_preset
    from pneucore.data.synthetic import synthesize
    m = model_preset("paper-4way")
    scen = {"duration": 0.3, "sample_period": 0.001, "command": [[0.0, 0.0]], "locked": True,
            "x0": 0.125, "initial": {"p_a": 3e5, "p_b": 3e5}}
    meas = synthesize(m, scen, ("p_a", "p_b"), seed=3, name="closed")
    d = diagnose(m, [{"name": "closed", "scenario": {"locked": True, "x0": 0.125},
                      "measurement": meas}])
    assert d.verdict is None and d.recalibrate == []
    assert d.remaining.get("identifies_no_base") is True, describe(d)
    assert "identify none of the base parameters" in d.message


def test_effect_beside_a_transducer_gain_error_is_named_and_the_rest_is_outside():
    """5 % gain on the p_a transducer and a piston leak: the leak is named, the gain is not
    taken for a stand-in effect, and what remains is said to lie outside the catalog."""
    c, exps, floor = case("outside/pressure-gain+leak")
    d = diagnosis("outside/pressure-gain+leak")
    assert d.verdict == "piston_leakage", describe(d)
    assert d.ranking[0]["effect"] == "piston_leakage"
    # the leak removes most of what a transducer correction leaves; the stand-ins do not
    assert d.ranking[0]["excess_drop_calibrated"] >= 0.5, describe(d)
    assert d.remaining["outside_catalog"], describe(d)


def test_calibrated_error_recovers_a_transducer_gain_and_offset():
    """A record read through a wrong transducer, replayed on the true model: the gain and
    offset come back and the corrected error falls to the noise's."""
    import numpy as np
    from pneucore.analysis.compare import replay
    from pneucore.analysis.hypotheses import calibrated_error
    c, exps, _ = case("base/paper-4way")
    truth = Model.from_dict(c.truth)
    rps = [replay(truth, e) for e in exps]
    e_plain, per_plain = calibrated_error(rps)
    for rp in rps:
        rp.measured["p_a"] = 2e4 + 1.05 * rp.measured["p_a"]
    e_gain, per = calibrated_error(rps)
    # least squares on ~2000 samples with 300 Pa noise: gain to ~1e-4, offset to ~100 Pa
    assert per["p_a"]["gain"] == pytest.approx(0.05, abs=2e-3)
    assert per["p_a"]["offset"] == pytest.approx(2e4, abs=2e3)
    # the corrected error is the plain one's (noise), within a few percent (the gain scales it)
    assert e_gain == pytest.approx(e_plain, rel=0.1)
    assert np.isfinite(e_gain)


# ------------------------------------------------------------ a line the model lumps by default

def test_a_tube_simulated_in_finite_volumes_is_named_tubing_with_its_length():
    """2.5 m of 4 mm tube on each port, simulated as a line in 8 finite volumes (its delay
    L / c = 7.3 ms, two samples and more at 1 kHz), base parameters off, nothing declared:
    the lumped line alone (no delay) was beaten by a 7.5 ms sensor lag and a dead volume;
    tried in segments too (Effect.forms), ``tubing`` is named with its length."""
    name = "effect/circuit/tubing/finite-volume"
    c, exps, floor = case(name)
    d = diagnosis(name)
    assert d.verdict == "tubing", describe(d)
    fitted = d.model.effects["tubing"]
    # the issue asks the length within 10 % where the data identify it; here it comes back
    # within 0.1 % (the fitted form resolves the delay to a sample)
    for sfx in ("a", "b"):
        assert fitted[f"length_{sfx}"] == pytest.approx(2.5, rel=PARAM_RTOL)
    assert fitted["segments"] > 1
    assert compare(d.model, exps).overall <= FLOOR_FACTOR * floor, describe(d)
