"""Closed-loop robustness over a study's parameter sets, and controller tuning over that ensemble
(issue 42, items 6-7).

A closed-loop study is a robustness study (:mod:`pneucore.study.definition`: model, parameters
by path with grids or distributions, samples, seed) whose ``scenario`` carries a
``controller``; every run is a closed loop (:func:`pneucore.control.closed_loop.simulate_closed_loop`)
on that run's model, and its metrics are the loop's (``stats.control``)::

    {"model": ..., "scenario": {..., "controller": {"kind": "pid", ...}},
     "parameters": {"jack.moving_mass": {"grid": [1, 2, 4]},
                    "friction.extend.fc0": {"distribution": "uniform", "min": 0, "max": 20}},
     "samples": 10, "seed": 1}

:func:`tune_controller` runs it for each gain set of a grid and ranks the sets on the worst
case of a metric over the ensemble (an unstable or failed run counts as infinitely bad).
"""
from __future__ import annotations

import itertools
import math

import numpy as np

from pneucore.control.closed_loop import simulate_closed_loop
from pneucore.description.validation import FieldError

#: Metrics of :func:`pneucore.control.metrics.control_metrics` a study records per run
STUDY_METRICS = ("rise_time", "settling_time", "overshoot", "steady_state_error", "rms_error",
                 "hunting_amplitude", "hunting_frequency", "switchings", "air_per_move")
#: Most closed-loop runs of one tuning job (gain sets x ensemble)
MAX_TUNING_RUNS = 5000


def check_study(definition):
    """The closed-loop study checked (a FieldError naming the field), before any run: the
    :class:`pneucore.study.definition.Study` and the controller, checked against the nominal
    model."""
    from pneucore.control.closed_loop import parse_controller

    study, controller = _split(definition)
    parse_controller(controller, study.model, study.scenario.duration)
    return study, controller


def _split(definition):
    from pneucore.study.definition import Study

    if not isinstance(definition, dict) or not isinstance(definition.get("scenario"), dict):
        raise FieldError("scenario", "a closed-loop study's scenario is an object with a controller")
    scen = dict(definition["scenario"])
    controller = scen.pop("controller", None)
    if controller is None:
        raise FieldError("scenario.controller", "is required for a closed-loop study")
    d = dict(definition, scenario=scen)
    d.pop("metrics", None)
    return Study.from_dict(d), controller


def _runs(study, controller, progress=None, label=""):
    rows, errors, stable = [], [], []
    for i in range(study.n_runs):
        try:
            res = simulate_closed_loop(study.run_model(i), study.scenario, controller,
                                       raise_on_error=False)
            c = res.stats["control"]
            ok = c["stable"] and res.status == 0
            rows.append([np.nan if c[k] is None else float(c[k]) for k in STUDY_METRICS])
            errors.append(None if ok else (res.message if res.status else "unstable"))
            stable.append(ok)
        except FieldError:
            raise
        except Exception as exc:          # a run's model or simulation failed: recorded
            rows.append([np.nan] * len(STUDY_METRICS))
            errors.append(f"{type(exc).__name__}: {exc}")
            stable.append(False)
        if progress is not None:
            progress((i + 1) / study.n_runs, f"{label}run {i + 1} of {study.n_runs}")
    return np.array(rows).reshape(len(rows), len(STUDY_METRICS)), errors, stable


def _summary(M, stable):
    out = {"runs": len(stable), "stable_fraction": float(np.mean(stable)) if stable else 0.0}
    for j, k in enumerate(STUDY_METRICS):
        col = M[:, j][np.isfinite(M[:, j])]
        out[k] = None if col.size == 0 else {
            "min": float(col.min()), "median": float(np.median(col)), "max": float(col.max()),
            "worst_abs": float(np.abs(col).max())}
    return out


def closed_loop_study(definition, progress=None):
    """Run a closed-loop study (see the module).

    Parameters
    ----------
    definition : dict
        The study with ``scenario.controller``
    progress : callable or None
        ``progress(fraction, step)``

    Returns
    -------
    out : dict
        ``paths``, ``values`` (per run), ``metrics`` (names), ``rows`` (per run, None where
        undefined), ``errors`` (per run: None, ``"unstable"`` or the failure), ``summary``
        (per metric min/median/max/worst |value|, and the stable fraction)
    """
    study, controller = _split(definition)
    M, errors, stable = _runs(study, controller, progress)
    return {"paths": list(study.paths), "values": np.asarray(study.values()).tolist(),
            "metrics": list(STUDY_METRICS),
            "rows": [[None if not math.isfinite(v) else v for v in r] for r in M.tolist()],
            "errors": errors, "summary": _summary(M, stable)}


def tune_controller(definition, gains, objective="rms_error", progress=None):
    """Rank the gain sets of a grid on the worst case of ``objective`` over a study's ensemble.

    Parameters
    ----------
    definition : dict
        A closed-loop study (its controller's gains are the base the grid overrides)
    gains : dict
        ``{gain name: [values]}``: the full factorial is tried
    objective : str
        One of :data:`STUDY_METRICS`; the worst ``|value|`` over the ensemble is minimised
        (a run that is unstable, fails, or leaves it undefined counts as infinite)
    progress : callable or None
        ``progress(fraction, step)``

    Returns
    -------
    out : dict
        ``best`` (gains, worst objective), ``candidates`` (every gain set with its worst
        objective, stable fraction and summary), ``objective``
    """
    if objective not in STUDY_METRICS:
        raise FieldError("objective", f"unknown metric {objective!r}; one of {list(STUDY_METRICS)}")
    if not isinstance(gains, dict) or not gains:
        raise FieldError("gains", "give {gain name: [values, ...]} to search")
    for k, vals in gains.items():
        if not isinstance(vals, list) or not vals:
            raise FieldError(f"gains.{k}", "must be a non-empty list of values")
    study, controller = _split(definition)
    names = sorted(gains)
    sets = list(itertools.product(*(gains[k] for k in names)))
    if len(sets) * study.n_runs > MAX_TUNING_RUNS:
        raise FieldError("gains", f"{len(sets)} gain sets x {study.n_runs} runs = "
                                  f"{len(sets) * study.n_runs}; the limit is {MAX_TUNING_RUNS}")
    j = STUDY_METRICS.index(objective)
    cands = []
    for s, values in enumerate(sets):
        ctl = dict(controller, gains=dict(controller.get("gains", {}), **dict(zip(names, values))))

        def step(frac, text, s=s):
            if progress is not None:
                progress((s + frac) / len(sets), f"gain set {s + 1} of {len(sets)}: {text}")
        M, errors, stable = _runs(study, ctl, step)
        col = M[:, j]
        worst = math.inf if (not all(stable) or not np.all(np.isfinite(col))) \
            else float(np.abs(col).max())
        cands.append({"gains": ctl["gains"], "worst": worst,
                      "stable_fraction": float(np.mean(stable)), "summary": _summary(M, stable)})
    best = min(cands, key=lambda c: c["worst"])
    for c in cands:
        if not math.isfinite(c["worst"]):
            c["worst"] = None
    return {"objective": objective, "best": {"gains": best["gains"], "worst": best["worst"]},
            "candidates": cands}
