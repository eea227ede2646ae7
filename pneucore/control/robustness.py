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
case of a metric over the ensemble (an unstable or failed run counts as infinitely bad), or on
the share of runs meeting a specification (``{metric: largest |value|}``).

The runs go to the study's engines (:func:`pneucore.study.execute.map_runs`: the local process
pool on its warm forkserver, or the Dask cluster), in batches of run indices: each task gets the
study's canonical JSON and the gain sets, and run ``i`` is gain set ``i // n_runs`` on the
study's run ``i % n_runs`` (:func:`run_control_block`). Progress, time limit and cancellation
are the studies' (an exception raised by ``progress`` kills the pool's running processes).
"""
from __future__ import annotations

import functools
import itertools
import json
import math

import numpy as np

from pneucore.control.closed_loop import parse_controller, simulate_closed_loop
from pneucore.control.metrics import CONTROL_METRICS
from pneucore.description.validation import FieldError

#: Metrics of :func:`pneucore.control.metrics.control_metrics` a study records per run
STUDY_METRICS = tuple(CONTROL_METRICS)
#: Unit of each of :data:`STUDY_METRICS`
METRIC_UNITS = {k: unit for k, (unit, _) in CONTROL_METRICS.items()}
#: Most closed-loop runs of one tuning job (gain sets x ensemble)
MAX_TUNING_RUNS = 5000


def check_study(definition):
    """The closed-loop study checked (a FieldError naming the field), before any run: the
    :class:`pneucore.study.definition.Study` and the controller, checked against the nominal
    model."""
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


class ControlBlock:
    """A batch of closed-loop runs, as a pool worker returns it: run ``indices`` [-], their
    metrics (rows, :data:`STUDY_METRICS` columns, NaN where undefined or failed), whether each
    ran to its end stably, and each one's error (None, ``"unstable"`` or the failure)."""

    def __init__(self, indices, metrics, stable, errors):
        self.indices, self.metrics, self.stable, self.errors = indices, metrics, stable, errors

    def __len__(self):
        return len(self.indices)


@functools.lru_cache(maxsize=4)
def _payload(text):
    """The parsed task payload, its study's values drawn (kept per process, the last four: a
    worker parses it once)."""
    from pneucore.study.definition import Study
    d = json.loads(text)
    got = (Study.from_dict(d["study"]), d["controllers"])
    got[0].values()
    return got


def run_control_block(text, indices):
    """The task body of a closed-loop study or tuning (in a pool or Dask worker): run ``i``
    is gain set ``i // n_runs`` on the study's run ``i % n_runs``.

    Parameters
    ----------
    text : str
        ``{"study": the study's canonical definition, "controllers": [spec, ...]}`` (JSON)
    indices : list of int
        Runs [-]

    Returns
    -------
    block : ControlBlock
    """
    study, controllers = _payload(text)
    rows, errors, stable = [], [], []
    for i in indices:
        controller = controllers[i // study.n_runs]
        try:
            res = simulate_closed_loop(study.run_model(i % study.n_runs), study.scenario,
                                       controller, raise_on_error=False)
            c = res.stats["control"]
            ok = c["stable"] and res.status == 0
            rows.append([np.nan if c[k] is None else float(c[k]) for k in STUDY_METRICS])
            errors.append(None if ok else (res.message if res.status else "unstable"))
            stable.append(ok)
        except Exception as exc:          # a run's model or simulation failed: recorded
            rows.append([np.nan] * len(STUDY_METRICS))
            errors.append(f"{type(exc).__name__}: {exc}")
            stable.append(False)
    M = np.array(rows, float).reshape(len(rows), len(STUDY_METRICS))
    return ControlBlock(list(indices), M, stable, errors)


def _runs(study, controllers, progress=None, engine=None):
    """Every gain set of ``controllers`` on every run of ``study``, on the study's engines
    (:func:`pneucore.study.execute.map_runs`): per gain set, the metrics matrix, the errors
    and the stable flags."""
    from pneucore.study.execute import map_runs

    n = study.n_runs * len(controllers)
    text = json.dumps({"study": json.loads(study.to_json()), "controllers": controllers},
                      sort_keys=True, allow_nan=False)
    M = np.full((n, len(STUDY_METRICS)), np.nan)
    errors = [None] * n
    stable = [False] * n

    def keep(block):
        for j, i in enumerate(block.indices):
            M[i] = block.metrics[j]
            errors[i] = block.errors[j]
            stable[i] = block.stable[j]

    e = dict(engine or {})
    map_runs(run_control_block, text, n, keep, progress=progress,
             what="closed-loop runs", **e)
    r = study.n_runs
    return [(M[s * r:(s + 1) * r], errors[s * r:(s + 1) * r], stable[s * r:(s + 1) * r])
            for s in range(len(controllers))]


def check_specification(spec, path="specification"):
    """A specification ``{metric: largest |value|}`` checked: metrics of
    :data:`STUDY_METRICS`, bounds finite and >= 0 in the metric's unit; None passes."""
    if spec is None:
        return None
    if not isinstance(spec, dict) or not spec:
        raise FieldError(path, "must be {metric: largest |value|}, e.g. {\"settling_time\": "
                               "0.5 [s], \"overshoot\": 0.1 [-]}")
    out = {}
    for k, v in spec.items():
        if k not in STUDY_METRICS:
            raise FieldError(f"{path}.{k}", f"unknown metric; one of {list(STUDY_METRICS)}")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                or v < 0:
            raise FieldError(f"{path}.{k}", f"must be a finite bound >= 0 "
                                            f"[{METRIC_UNITS[k]}], got {v!r}")
        out[k] = float(v)
    return out


def _meets(M, stable, spec):
    """Per run: stable, and every metric of ``spec`` defined and within its bound."""
    if spec is None:
        return None
    ok = np.array(stable, bool)
    for k, bound in spec.items():
        col = M[:, STUDY_METRICS.index(k)]
        ok &= np.isfinite(col) & (np.abs(np.where(np.isfinite(col), col, 0.0)) <= bound)
    return ok.tolist()


def _summary(M, stable, meets=None):
    out = {"runs": len(stable), "stable_fraction": float(np.mean(stable)) if stable else 0.0}
    if meets is not None:
        out["meets_fraction"] = float(np.mean(meets)) if meets else 0.0
    for j, k in enumerate(STUDY_METRICS):
        col = M[:, j][np.isfinite(M[:, j])]
        out[k] = None if col.size == 0 else {
            "min": float(col.min()), "median": float(np.median(col)), "max": float(col.max()),
            "worst_abs": float(np.abs(col).max())}
    return out


def closed_loop_study(definition, progress=None, specification=None, engine=None):
    """Run a closed-loop study (see the module) on the study's engines.

    Parameters
    ----------
    definition : dict
        The study with ``scenario.controller``
    progress : callable or None
        ``progress(fraction, step)``; an exception raised there stops the runs (the pool's
        processes killed) and propagates
    specification : dict or None
        ``{metric: largest |value|}`` in the metric's unit (:data:`METRIC_UNITS`), e.g.
        ``{"settling_time": 0.5, "overshoot": 0.1}``: a run meets it when it is stable and
        each listed metric is defined and within its bound
    engine : dict or None
        :func:`pneucore.study.execute.map_runs`'s ``workers``, ``scheduler``,
        ``batch_size``, ``time_limit`` [s], ``scheduler_timeout`` [s]; None = the local
        pool on every CPU (or ``$PNEUCORE_DASK_SCHEDULER``)

    Returns
    -------
    out : dict
        ``paths``, ``values`` (per run), ``metrics`` (names), ``units``, ``rows`` (per run,
        None where undefined), ``errors`` (per run: None, ``"unstable"`` or the failure),
        ``meets`` (per run, with a specification), ``summary`` (per metric
        min/median/max/worst |value|, the stable fraction and the fraction meeting the
        specification)
    """
    spec = check_specification(specification)
    study, controller = check_study(definition)
    ((M, errors, stable),) = _runs(study, [controller], progress, engine)
    meets = _meets(M, stable, spec)
    out = {"paths": list(study.paths), "values": np.asarray(study.values()).tolist(),
           "metrics": list(STUDY_METRICS), "units": dict(METRIC_UNITS),
           "rows": [[None if not math.isfinite(v) else v for v in r] for r in M.tolist()],
           "errors": errors, "summary": _summary(M, stable, meets)}
    if spec is not None:
        out["specification"] = spec
        out["meets"] = meets
    return out


def tune_controller(definition, gains, objective="rms_error", progress=None,
                    specification=None, engine=None):
    """Rank the gain sets of a grid on the worst case of ``objective`` over a study's ensemble,
    every run of every set on the study's engines at once.

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
    specification : dict or None
        As :func:`closed_loop_study`: with one, the sets meeting it on the most runs rank
        first (all of them: the set meets it over the whole ensemble), then the worst
        objective
    engine : dict or None
        As :func:`closed_loop_study`

    Returns
    -------
    out : dict
        ``best`` (gains, worst objective, and the fraction meeting the specification),
        ``candidates`` (every gain set with its worst objective, stable fraction and
        summary), ``objective``
    """
    if objective not in STUDY_METRICS:
        raise FieldError("objective", f"unknown metric {objective!r}; one of {list(STUDY_METRICS)}")
    if not isinstance(gains, dict) or not gains:
        raise FieldError("gains", "give {gain name: [values, ...]} to search")
    for k, vals in gains.items():
        if not isinstance(vals, list) or not vals:
            raise FieldError(f"gains.{k}", "must be a non-empty list of values")
    spec = check_specification(specification)
    study, controller = _split(definition)
    names = sorted(gains)
    sets = list(itertools.product(*(gains[k] for k in names)))
    if len(sets) * study.n_runs > MAX_TUNING_RUNS:
        raise FieldError("gains", f"{len(sets)} gain sets x {study.n_runs} runs = "
                                  f"{len(sets) * study.n_runs}; the limit is {MAX_TUNING_RUNS}")
    ctls = []
    for values in sets:
        ctl = dict(controller, gains=dict(controller.get("gains", {}), **dict(zip(names, values))))
        # each set's gains checked before any run: a bad value is the request's field
        parse_controller(ctl, study.model, study.scenario.duration,
                         path="scenario.controller")
        ctls.append(ctl)
    j = STUDY_METRICS.index(objective)
    cands = []
    for ctl, (M, errors, stable) in zip(ctls, _runs(study, ctls, progress, engine)):
        col = M[:, j]
        worst = math.inf if (not all(stable) or not np.all(np.isfinite(col))) \
            else float(np.abs(col).max())
        meets = _meets(M, stable, spec)
        cands.append({"gains": ctl["gains"], "worst": worst,
                      "stable_fraction": float(np.mean(stable)),
                      "summary": _summary(M, stable, meets)})
    if spec is None:
        best = min(cands, key=lambda c: c["worst"])
    else:
        best = min(cands, key=lambda c: (-c["summary"]["meets_fraction"], c["worst"]))
    for c in cands:
        if not math.isfinite(c["worst"]):
            c["worst"] = None
    out = {"objective": objective, "best": {"gains": best["gains"], "worst": best["worst"]},
           "candidates": cands}
    if spec is not None:
        out["specification"] = spec
        out["best"]["meets_fraction"] = best["summary"]["meets_fraction"]
    return out
