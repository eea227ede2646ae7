"""``compare(model, experiments)`` on synthetic measurements whose truth is known.

Data: :func:`pneucore.data.synthetic.synthetic_experiments` (locked hold test and
Fig. 10 free pulse test; 1 s at 1 kHz; 12-bit converters on 0-10 bar and
0-250 mm; Gaussian noise 300 Pa on the pressures, 50 um on x, i.e. ~1.2 and
~0.8 LSB).
"""
import copy
import functools
import json
import math
import re

import numpy as np
import pytest

from pneucore import model_preset
from pneucore.analysis.compare import compare
from pneucore.data.synthetic import synthetic_experiments

#: The true model's Eq. 25 error is its measurement noise, so it must equal the estimated noise
#: floor up to the estimate's error. The floor comes from a median of ~1000 second differences
#: (sampling error of a few %); the true model's residual also carries the estimate of the
#: initial pressures (from the first samples), worth up to ~15 % on a pressure. 25 % covers
#: both; a model error of the size the diagnosis looks for is several times the floor.
FLOOR_RTOL = 0.25

PISTON_WORDS = ("piston moving", "piston extending", "piston retracting", "piston stuck",
                "piston at a stop", "piston locked")
PHASE_WORDS = ("initial", "valve opens", "valve closes", "valve reverses")


@functools.lru_cache(maxsize=None)
def clean_data(seed=0):
    """paper-4way (convective, h = 25) as the truth, no hidden effect."""
    return synthetic_experiments(model_preset("paper-4way"), seed=seed)


def experiment_json(exp):
    """An experiment as it would arrive over an API: plain JSON, NaN as null."""
    d = {"name": exp["name"], "scenario": dict(exp["scenario"]),
         "measurement": exp["measurement"].to_dict()}
    return json.loads(json.dumps(d, allow_nan=False))


# ----------------------------------------------------------------- perfect model

@pytest.mark.parametrize("signal", ["p_a", "p_b", "x"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_perfect_model_sits_at_the_noise_floor(seed, signal):
    c = compare(model_preset("paper-4way"), clean_data(seed))
    assert set(c.errors) == {"p_a", "p_b", "x"}
    e, floor = c.errors[signal], c.noise_floor[signal]
    assert math.isfinite(e) and math.isfinite(floor) and floor > 0
    assert e == pytest.approx(floor, rel=FLOOR_RTOL), (signal, e, floor, c.noise_floor)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_perfect_model_overall_error_sits_at_the_overall_floor(seed):
    c = compare(model_preset("paper-4way"), clean_data(seed))
    floor_overall = math.sqrt(np.mean(np.square(list(c.noise_floor.values()))))
    assert c.overall == pytest.approx(floor_overall, rel=FLOOR_RTOL), (c.errors, c.noise_floor)


def test_model_error_rises_clearly_above_the_floor():
    """10 % heavier piston, 50 % more extension friction: several times the true model's error."""
    exps = clean_data(0)
    right = compare(model_preset("paper-4way"), exps).overall
    wrong = model_preset("paper-4way")
    wrong["jack"]["moving_mass"] *= 1.1
    wrong["friction"]["extend"]["fc0"] *= 1.5
    assert compare(wrong, exps).overall > 3.0 * right


def test_overall_is_the_rms_of_the_signal_errors():
    c = compare(model_preset("paper-4way"), clean_data(0))
    assert c.overall == pytest.approx(math.sqrt(np.mean(np.square(list(c.errors.values())))),
                                      rel=1e-12)


# ----------------------------------------------------------------- heat models (Fig. 8, Table 2)

def test_heat_models_side_by_side_rank_convective_first():
    """Data from a convective truth: convective beats adiabatic and isothermal on the pressures."""
    truth = model_preset("paper-4way")
    exps = clean_data(0)
    c = compare(truth, exps, heat_models=True)
    assert set(c.heat_models) == {"convective", "adiabatic", "isothermal"}
    hm = c.heat_models
    for s in ("p_a", "p_b"):
        assert hm["convective"]["errors"][s] < hm["adiabatic"]["errors"][s], (s, hm)
        assert hm["convective"]["errors"][s] < hm["isothermal"]["errors"][s], (s, hm)
    assert hm["convective"]["overall"] < min(hm["adiabatic"]["overall"], hm["isothermal"]["overall"])
    # the model is convective already: its own column equals the main comparison exactly
    assert hm["convective"]["errors"] == c.errors
    for name in hm:
        assert "valve opens" in hm[name]["phases"] and "valve closes" in hm[name]["phases"]
    json.dumps(c.to_dict(residuals=False), allow_nan=False)


def test_heat_models_list_runs_only_those():
    c = compare(model_preset("paper-4way"), clean_data(0), heat_models=["adiabatic"])
    assert set(c.heat_models) == {"adiabatic"}
    assert "heat_models" in c.to_dict(residuals=False)
    assert compare(model_preset("paper-4way"), clean_data(0)).heat_models == {}


def test_convective_column_uses_the_heat_exchange_effects_coefficient():
    """An adiabatic model that got convection from the ``heat_exchange`` effect (what
    ``apply_diagnosis`` produces) is the same physics as the convective heat model with that h:
    its ``convective`` column must be its own error, not that of the unused
    ``heat.coefficient`` left in the base."""
    truth = model_preset("paper-4way")
    truth["heat"] = {"model": "convective", "coefficient": 40.0}
    exps = synthetic_experiments(truth, seed=0)
    m = model_preset("paper-4way")
    m["heat"] = {"model": "adiabatic", "coefficient": 25.0}   # coefficient unused while adiabatic
    m["effects"] = {"heat_exchange": {"h": 40.0}}
    c = compare(m, exps, heat_models=True)
    # same physics, same data: the model's own error (at the noise floor) and its convective
    # column agree to round-off (1e-6 leaves room for solver step differences only)
    assert c.heat_models["convective"]["overall"] == pytest.approx(c.overall, rel=1e-6), \
        {"model": c.overall, **{k: v["overall"] for k, v in c.heat_models.items()}}


# ----------------------------------------------------------------- phases and windows

def test_command_and_piston_phases():
    c = compare(model_preset("paper-4way"), clean_data(0))
    assert "valve opens" in c.phases and "valve closes" in c.phases
    for lab, row in c.phases.items():
        assert lab in PHASE_WORDS
        assert "overall" in row
        for s, e in row.items():
            assert math.isfinite(e) and e >= 0.0, (lab, s)
    # locked hold test -> piston locked; free pulses -> moving and stuck
    assert {"piston locked", "piston moving", "piston stuck"} <= set(c.piston_phases)
    for lab in c.piston_phases:
        assert lab in PISTON_WORDS
    # the locked experiment measures no x, so the locked phase has pressures only
    assert "x" not in c.piston_phases["piston locked"]


def test_worst_windows_are_described_in_words():
    """A mis-set model (heavier piston, more extension friction) fails in describable windows."""
    m = model_preset("paper-4way")
    m["jack"]["moving_mass"] = 4.0
    m["friction"]["extend"]["fc0"] = 20.0
    exps = clean_data(0)
    c = compare(m, exps, n_windows=5)
    assert len(c.windows) == 5
    energies = [w["energy"] for w in c.windows]
    assert energies == sorted(energies, reverse=True)
    names = {e["name"] for e in exps}
    for w in c.windows:
        desc = w["description"]
        assert w["signal"] in ("p_a", "p_b", "x")
        assert w["experiment"] in names and desc.startswith(w["experiment"] + ": ")
        assert w["signal"] in desc
        assert 0.0 <= w["t_start"] < w["t_end"] <= 1.0
        # the time span as written, with its unit
        assert f"{w['t_start']:.3f}-{w['t_end']:.3f} s" in desc
        assert w["phase"] in PHASE_WORDS and w["phase"] in desc
        assert any(p in desc for p in PISTON_WORDS), desc
        if w["signal"] in ("p_a", "p_b"):
            ch = "A" if w["signal"] == "p_a" else "B"
            assert re.search(rf"chamber {ch} (compressing|expanding|steady)", desc), desc
        assert 0.0 < w["share"] <= 1.0


# ----------------------------------------------------------------- residual series, JSON input

def test_residual_series_cover_the_measurement():
    exps = clean_data(0)
    c = compare(model_preset("paper-4way"), exps)
    by_name = {e["name"]: e for e in exps}
    assert [e["name"] for e in c.experiments] == [e["name"] for e in exps]
    for e in c.experiments:
        meas = by_name[e["name"]]["measurement"]
        assert len(e["t"]) == meas.n
        for s, r in e["residuals"].items():
            assert len(r) == meas.n, (e["name"], s)
            # residual = simulated - measured
            assert np.allclose(np.asarray(e["simulated"][s]) - meas.signals[s], r, equal_nan=True)
    d = c.to_dict()
    json.dumps(d, allow_nan=False)
    for e in d["experiments"]:
        assert {"name", "errors", "residuals", "t"} <= set(e)
    assert "residuals" not in c.to_dict(residuals=False)["experiments"][0]


def test_json_experiments_with_null_samples():
    exps = clean_data(0)
    ref = compare(model_preset("paper-4way"), exps)
    missing = [0, 3, 100, 101, 102, 500, 1000]
    js = []
    for e in exps:
        d = experiment_json(e)
        for s in ("p_a", "p_b", "x"):
            if s in d["measurement"]:
                for i in missing:
                    d["measurement"][s][i] = None
        js.append(json.loads(json.dumps(d)))
    c = compare(model_preset("paper-4way"), js)
    for s, e in c.errors.items():
        assert math.isfinite(e)
        # 7 of 1001 samples dropped per series: the error barely moves
        assert e == pytest.approx(ref.errors[s], rel=0.05), s
    for e in c.experiments:
        for s, r in e["residuals"].items():
            r = np.asarray(r, float)
            assert r.shape == (1001,)
            assert np.isnan(r[missing]).all(), (e["name"], s)
            assert np.isfinite(np.delete(r, missing)).all(), (e["name"], s)
    json.dumps(c.to_dict(), allow_nan=False)   # missing samples come out as null


def test_command_outside_the_valve_range_names_column_u_and_row():
    d = experiment_json(clean_data(0)[0])
    d["measurement"]["u"][42] = 1.5                  # data row 43
    with pytest.raises(ValueError) as exc:
        compare(model_preset("paper-4way"), [d])
    msg = str(exc.value)
    assert "'u'" in msg and "row 43" in msg, msg


def test_command_outside_a_3way_valves_range_names_column_u_and_row():
    """A 4/2 record (u down to -0.8) replayed on the 3/2 valve (range [0, 1])."""
    d = experiment_json(clean_data(0)[0])
    u = np.asarray(d["measurement"]["u"], float)
    row = int(np.flatnonzero(u < 0)[0]) + 1          # 1-based data row
    with pytest.raises(ValueError) as exc:
        compare(model_preset("paper-3way"), [d])
    msg = str(exc.value)
    assert "'u'" in msg and f"row {row}" in msg and "3/2" in msg, msg
    assert getattr(exc.value, "column", None) == "u"
    assert getattr(exc.value, "row", None) == row


def test_out_of_range_command_message_shows_the_plain_number():
    """The value is quoted as the user wrote it (1.5), not as a numpy repr (np.float64(1.5))."""
    d = experiment_json(clean_data(0)[0])
    d["measurement"]["u"][42] = 1.5
    with pytest.raises(ValueError) as exc:
        compare(model_preset("paper-4way"), [d])
    msg = str(exc.value)
    assert "1.5" in msg and "np." not in msg, msg


def test_experiment_objects_are_not_modified():
    exps = clean_data(0)
    before = [copy.deepcopy(e["measurement"].to_dict()) for e in exps]
    compare(model_preset("paper-4way"), exps, heat_models=True)
    assert [e["measurement"].to_dict() for e in exps] == before
