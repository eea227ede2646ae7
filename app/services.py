"""What the routers share: a simulation result as the API's JSON, a request's time limit, and
the analyses (compare, calibrate, diagnose) checked up front and run, for the synchronous
endpoints, the jobs and the reports alike.

Routers import what they share from here, never from one another.
"""
from __future__ import annotations

import time

from pneucore.analysis.calibrate import calibrate
from pneucore.analysis.compare import check_heat_models, compare
from pneucore.analysis.diagnose import check_request, diagnose
from pneucore.spec.paths import parse_parameters
from pneucore.spec.validation import FieldError

from .deps import parse_experiments, parse_model
from .schemas import CalibrateRequest, CompareRequest, DiagnoseRequest, RefineRequest

#: Series returned by default (everything the page plots)
DEFAULT_SERIES = ("t", "u", "p_a", "p_b", "T_a", "T_b", "m_a", "m_b", "x", "v", "a", "q_a", "q_b",
                  "friction", "mode", "u_eff", "p_supply", "q_supply", "net_force")


def result_json(res, series):
    """A :class:`~pneucore.result.SimulationResult` as the body of POST /api/simulate.

    Parameters
    ----------
    res : SimulationResult
        A completed simulation
    series : list of str or None
        Series to return (None = :data:`DEFAULT_SERIES`); an unknown name or an
        empty list is a :class:`~pneucore.spec.validation.FieldError` on ``series``
    """
    names = [s for s in (series or DEFAULT_SERIES) if s in res.series]
    if series is not None and len(series) == 0:
        raise FieldError("series", "give at least one series name, or omit the field for the default set")
    if series:
        unknown = [s for s in series if s not in res.series]
        if unknown:
            raise FieldError("series", f"unknown series {unknown}; available: {sorted(res.series)}")
    return res.to_dict(series=names, arrays=True, inputs=False)


def deadline_progress(limits, what, job_path):
    """Progress callback that stops a synchronous analysis past the request time limit.

    Parameters
    ----------
    limits : app.config.Limits
        Its ``request_time_limit`` [s] applies
    what : str
        The analysis, in words, for the message
    job_path : str
        Where the same work runs as a job, for the message (``/api/jobs/diagnose``)
    """
    from .jobs import JobTimeout
    t0 = time.time()

    def check(fraction, step):
        if time.time() - t0 > limits.request_time_limit:
            raise JobTimeout(f"the {what} exceeded the request time limit of "
                             f"{limits.request_time_limit:g} s (at step: {step}); use POST {job_path}")
    return check


def check_compare(req: CompareRequest, store, limits):
    """Everything a compare request can get wrong, checked before any work."""
    model = parse_model(req.model)
    check_heat_models(req.heat_models)
    return model, parse_experiments(req.experiments, model, store, limits)


def check_calibrate(req: CalibrateRequest, store, limits):
    model = parse_model(req.model)
    params = {k: v.model_dump(exclude_none=True) for k, v in req.parameters.items()}
    parse_parameters(model, params)
    return model, parse_experiments(req.experiments, model, store, limits), params


def check_diagnose(req: DiagnoseRequest, store, limits):
    model = parse_model(req.model)
    check_request(model, req.candidates, req.uncertain)
    return model, parse_experiments(req.experiments, model, store, limits)


def run_compare(req: CompareRequest, store, limits, progress=None, checked=None):
    """The comparison; ``checked``: what :func:`check_compare` returned for ``req`` (a job
    checked at submission), else it is checked here."""
    model, exps = checked or check_compare(req, store, limits)
    return compare(model, exps, heat_models=req.heat_models,
                   progress=progress).to_dict(residuals=req.residuals)


def run_calibrate(req: CalibrateRequest, store, limits, progress=None, checked=None):
    """The calibration; ``checked`` as for :func:`run_compare` (from :func:`check_calibrate`)."""
    model, exps, params = checked or check_calibrate(req, store, limits)
    return calibrate(model, exps, params, max_nfev=min(max(req.max_nfev, 1), 200),
                     progress=progress).summary()


def run_diagnose(req: DiagnoseRequest, store, limits, progress=None, checked=None):
    """The diagnosis; ``checked`` as for :func:`run_compare` (from :func:`check_diagnose`)."""
    model, exps = checked or check_diagnose(req, store, limits)
    return diagnose(model, exps, candidates=req.candidates, uncertain=req.uncertain,
                    progress=progress, validated=True).to_dict()   # checked above


def check_refine(req: RefineRequest, store, limits):
    """Everything a refine request can get wrong, checked before any work."""
    model = parse_model(req.model)
    check_request(model, None, req.uncertain)
    return model, parse_experiments(req.experiments, model, store, limits)


def run_refine(req: RefineRequest, store, limits, progress=None, checked=None):
    """:func:`pneucore.analysis.history.refine` on the request: the versions, each round's diagnosis and
    the refined model (plain JSON); ``checked`` as for :func:`run_compare` (from
    :func:`check_refine`)."""
    from pneucore.analysis.history import refine
    model, exps = checked or check_refine(req, store, limits)
    state = {"round": 0, "last": 0.0}

    def each_round(fraction, step):   # one progress over the rounds: a new round starts low again
        if fraction < state["last"]:
            state["round"] += 1
        state["last"] = fraction
        if progress is not None:
            progress((state["round"] + min(fraction, 1.0)) / req.max_rounds,
                     f"round {state['round'] + 1}: {step}")
    final, history, diagnoses = refine(model, exps, max_rounds=req.max_rounds,
                                       uncertain=req.uncertain, progress=each_round,
                                       validated=True)   # check_refine checked it
    last = diagnoses[-1] if diagnoses else None
    return {"model": final.to_dict(), "versions": history.to_dict()["versions"],
            "diagnoses": [d.to_dict() for d in diagnoses],
            "message": last.message if last is not None else "",
            "at_floor": bool(last is not None and last.remaining.get("at_floor"))}


def friction_preview(model, pressures, velocities):
    """The friction force map of ``model``, computed by the simulator's own friction law.

    The coefficients are read from the parameter vector the compiled core simulates with
    (:func:`pneucore.simulate.build_core`: every catalog effect's transform and packing
    applied, so ``pressure_dependent_friction``, ``quadrant_friction`` and
    ``stribeck_friction`` show as they act), and the force comes from the core's functions
    of :mod:`pneucore.physics.friction`: :func:`~pneucore.physics.friction.coulomb_level` (Eq. 20),
    :func:`~pneucore.physics.friction.viscous_coefficient` (Eq. 19) and
    :func:`~pneucore.physics.friction.sliding_friction` (Eq. 18 with the breakaway factor), with
    the extension coefficients for ``v > 0`` and the retraction ones for ``v < 0``, as the
    right-hand side picks them by piston mode (:mod:`pneucore.core.rhs`).

    Parameters
    ----------
    model : pneucore.spec.model.Model
        A validated model
    pressures : list of (float, float)
        Chamber pressure pairs ``(p_a, p_b)``, absolute [Pa]
    velocities : list of float
        Piston velocities [m/s]

    Returns
    -------
    preview : dict
        ``law``, ``stribeck_ratio`` [-], ``stribeck_velocity`` [m/s], ``velocities`` [m/s]
        and per pressure pair a curve: ``force`` [N] (positive towards -x; None at v = 0,
        where the piston sticks), the static limits ``static_extend`` and
        ``static_retract`` [N] (magnitudes), ``coulomb_*`` [N] and ``viscous_*`` [N s/m]
    """
    from pneucore.core import layout as L
    from pneucore.physics.friction import coulomb_level, sliding_friction, viscous_coefficient
    from pneucore.spec.scenario import Scenario
    from pneucore.simulate import build_core

    prm = build_core(model, Scenario())["model"][0]
    p_atm = float(prm[L.P_ATM])
    ratio, v_s = float(prm[L.P_STRIBECK_RATIO]), float(prm[L.P_STRIBECK_V])
    fc_ext = (prm[L.P_FE_FC0], prm[L.P_FE_FCA], prm[L.P_FE_FCB])
    kv_ext = (prm[L.P_FE_KV0], prm[L.P_FE_KVA], prm[L.P_FE_KVB])
    fc_ret = (prm[L.P_FR_FC0], prm[L.P_FR_FCA], prm[L.P_FR_FCB])
    kv_ret = (prm[L.P_FR_KV0], prm[L.P_FR_KVA], prm[L.P_FR_KVB])
    vs = [float(v) for v in velocities]
    curves = []
    for p_a, p_b in pressures:
        p_a, p_b = float(p_a), float(p_b)
        fc_e = float(coulomb_level(*fc_ext, p_a, p_b, p_atm))
        fc_r = float(coulomb_level(*fc_ret, p_a, p_b, p_atm))
        kv_e = float(viscous_coefficient(*kv_ext, p_a, p_b, p_atm))
        kv_r = float(viscous_coefficient(*kv_ret, p_a, p_b, p_atm))
        force = [float(sliding_friction(v, 1.0, fc_e, kv_e, ratio, v_s)) if v > 0.0 else
                 float(sliding_friction(v, -1.0, fc_r, kv_r, ratio, v_s)) if v < 0.0 else None
                 for v in vs]
        # the static limits as the core's event probes compute them (aux static_limit_ext/_ret)
        curves.append({"p_a": p_a, "p_b": p_b, "force": force,
                       "static_extend": ratio * fc_e, "static_retract": ratio * fc_r,
                       "coulomb_extend": fc_e, "coulomb_retract": fc_r,
                       "viscous_extend": kv_e, "viscous_retract": kv_r})
    return {"law": model.friction.law, "stribeck_ratio": ratio, "stribeck_velocity": v_s,
            "velocities": vs, "curves": curves}


def parameter_units():
    """The SI unit of every model parameter path, from :func:`pneucore.spec.paths.unit_of`.

    The paths are those :mod:`pneucore.spec.paths` can address on a model: the numeric fields of
    the model's sections (``jack.bore``, ``friction.retract.kv0``, ...), every heat-model
    parameter (``heat.<name>``), every catalog effect's parameters
    (``effects.<effect>.<parameter>``) and the valve scale factors under the edge ``*``
    (``valve.ports.*.C``; the same unit for any edge).

    Returns
    -------
    units : dict
        ``{path: unit}`` (``"-"`` for a dimensionless parameter; ``""`` where
        :mod:`pneucore.spec.paths` knows none)
    """
    import dataclasses

    from pneucore.spec.effects import EFFECTS
    from pneucore.physics.heat import HEAT_PARAMETERS
    from pneucore.spec.model import Model
    from pneucore.spec.paths import unit_of

    model = Model()
    paths = []

    def walk(obj, prefix):
        for f in dataclasses.fields(obj):
            value = getattr(obj, f.name)
            if dataclasses.is_dataclass(value):
                walk(value, f"{prefix}.{f.name}")
            elif (isinstance(value, (int, float)) and not isinstance(value, bool)) or \
                    (value is None and unit_of(f"{prefix}.{f.name}")):   # optional: jack.wall_area_a
                paths.append(f"{prefix}.{f.name}")

    for section in ("jack", "supply", "ambient", "friction", "gas"):
        walk(getattr(model, section), section)
    paths += [f"heat.{name}" for name in HEAT_PARAMETERS]
    paths += [f"effects.{name}.{p.name}" for name, e in EFFECTS.items() for p in e.parameters]
    out = {path: unit_of(path) for path in paths}
    for key in ("C", "b"):
        out[f"valve.ports.*.{key}"] = unit_of(f"valve.ports.*.{key}")
    return out
