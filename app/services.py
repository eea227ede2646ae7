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


def run_compare(req: CompareRequest, store, limits, progress=None):
    model, exps = check_compare(req, store, limits)
    return compare(model, exps, heat_models=req.heat_models,
                   progress=progress).to_dict(residuals=req.residuals)


def run_calibrate(req: CalibrateRequest, store, limits, progress=None):
    model, exps, params = check_calibrate(req, store, limits)
    return calibrate(model, exps, params, max_nfev=min(max(req.max_nfev, 1), 200),
                     progress=progress).summary()


def run_diagnose(req: DiagnoseRequest, store, limits, progress=None):
    model, exps = check_diagnose(req, store, limits)
    return diagnose(model, exps, candidates=req.candidates, uncertain=req.uncertain,
                    progress=progress).to_dict()


def check_refine(req: RefineRequest, store, limits):
    """Everything a refine request can get wrong, checked before any work."""
    model = parse_model(req.model)
    check_request(model, None, req.uncertain)
    return model, parse_experiments(req.experiments, model, store, limits)


def run_refine(req: RefineRequest, store, limits, progress=None):
    """:func:`pneucore.analysis.history.refine` on the request: the versions, each round's diagnosis and
    the refined model (plain JSON)."""
    from pneucore.analysis.history import refine
    model, exps = check_refine(req, store, limits)
    state = {"round": 0, "last": 0.0}

    def each_round(fraction, step):   # one progress over the rounds: a new round starts low again
        if fraction < state["last"]:
            state["round"] += 1
        state["last"] = fraction
        if progress is not None:
            progress((state["round"] + min(fraction, 1.0)) / req.max_rounds,
                     f"round {state['round'] + 1}: {step}")
    final, history, diagnoses = refine(model, exps, max_rounds=req.max_rounds,
                                       uncertain=req.uncertain, progress=each_round)
    last = diagnoses[-1] if diagnoses else None
    return {"model": final.to_dict(), "versions": history.to_dict()["versions"],
            "diagnoses": [d.to_dict() for d in diagnoses],
            "message": last.message if last is not None else "",
            "at_floor": bool(last is not None and last.remaining.get("at_floor"))}
