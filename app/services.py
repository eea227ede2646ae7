"""The services: the one place in ``app/`` that calls pneucore's simulation and analysis.

The routers (``app/routers/``) parse a request (the pydantic schemas of :mod:`app.schemas`),
call a function of this module and shape the HTTP answer (JSON or CSV, status codes); they
import nothing from pneucore and nothing from one another (tests/test_layering.py). What
is here turns a request into pneucore's objects (through :mod:`app.deps`: the model, the
scenario and the experiments validated once, within the API's limits), runs the work and
returns plain data. Errors are pneucore's own (a :class:`~pneucore.description.validation.FieldError`
is a 422 naming the field, see :mod:`app.main`) or those of this module,
:class:`QueueFull` (429) and :class:`PastBudget` (the event loop's step budget ran out).

One module, in sections by resource (simulation, analyses, heat models, reports, the
model catalog, datasets, sessions, studies): the analyses are shared by the synchronous
endpoints, the jobs and the reports.
"""
from __future__ import annotations

import json
import time
from contextlib import nullcontext
from types import SimpleNamespace

import numpy as np

from pneucore.analysis.calibrate import calibrate, check_parameters
from pneucore.analysis.calibration_options import calibration_options
from pneucore.analysis.compare import check_heat_models, compare, errors as model_errors, with_heat_model
from pneucore.analysis.diagnose import check_request, diagnose
from pneucore.analysis.heat_compare import check_names, compare_heat_models, simulate_heat_models
from pneucore.core.integrator import ERR_MAX_STEPS, integrate  # noqa: F401 (read by the express lane)
from pneucore.data.experiment import closed_loop_replays
from pneucore.data.fileformats import inspect_file, read_measurement
from pneucore.data.measurement import DEFAULT_AMBIENT_PRESSURE, Measurement, MeasurementError
from pneucore.data.npz import simulation_npz
from pneucore.physics.flow import FLOW_LAWS
from pneucore.physics.friction import FRICTION_LAWS
from pneucore.physics.heat import HEAT_MODELS
from pneucore.progress import Cancelled
from pneucore.simulate import SimulationError, simulate
from pneucore.description.effects import EFFECTS
from pneucore.description.model import Model
from pneucore.description.provenance import bench_known
from pneucore.description.presets import MODEL_PRESETS, SCENARIO_PRESETS, model_preset, scenario_preset
from pneucore.description.scenario import Scenario
from pneucore.description.units import unit_systems
from pneucore.description.validation import FieldError, choice, finite_json, mapping, number
from pneucore.description.valve_data import convert_valve_data
from pneucore.analysis.strokes import STROKE_FIELDS
from pneucore.study import (Study, check_run_options, delete_study, list_studies, queue_study,
                            requeue_study, run_study, runs_csv, runs_npz, set_study_status,
                            study_results, study_status)

from .analysis_memory import (admitted, analysis_estimate, check_alone, identify_estimate,
                              job_estimate, samples_estimate, seconds_of, study_estimate)
from .config import STUDY_CLUSTERS, Limits
from .control_service import (check_control_study, closed_loop_simulation, control_engine,  # noqa: F401
                              controllers_answer, linearize_answer, run_control_study, run_tune)  # (issue 42)
from .deps import parse_experiments, parse_model, parse_scenario
from .request_memory import check_file
from .responses import dumps
from .schemas import (FRICTION_DEFAULT_VELOCITIES, CalibrateRequest, CompareRequest, DiagnoseRequest,
                      DiagnoseReportRequest,
                      ExperimentIn, RefineRequest)

# Besides the services, the routers and the express lane read four of the names imported
# above: ``integrate`` and ``EFFECTS``, the facts the lane's choice of the event loop rests on
# (is the core compiled in this process; does an effect bring compiled terms, so a core of
# its own), ``simulate``, which the lane and the simulate router hand to :func:`simulation`,
# and ``DEFAULT_AMBIENT_PRESSURE``, which the upload form documents.


class QueueFull(Exception):
    """The job queue is full: the work is refused now (429); no job was started."""


class PastBudget(Exception):
    """A run stopped at the step budget it was given below the request's own (the event
    loop's): it is to be run again, from the start, with the request's whole budget."""


# ------------------------------------------------------------------------------ simulation
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
        empty list is a :class:`~pneucore.description.validation.FieldError` on ``series``
    """
    return res.to_dict(series=series_names(res, series), arrays=True, inputs=False)


def result_npz(res, series):
    """A :class:`~pneucore.result.SimulationResult` as the ``.npz`` answer of POST
    /api/simulate (``Accept: application/x-npz``): the series of :func:`result_json`, one
    member each, and its other fields in ``meta.json`` (:mod:`pneucore.data.npz`)."""
    return simulation_npz(res, series_names(res, series), dumps=dumps)


def series_names(res, series):
    """The series an answer carries: ``series`` checked against the result's, or
    :data:`DEFAULT_SERIES` (those the result has) when None; an unknown name or an empty
    list is a :class:`~pneucore.description.validation.FieldError` on ``series``."""
    if series is not None and len(series) == 0:
        raise FieldError("series", "give at least one series name, or omit the field for the default set")
    if series:
        unknown = [s for s in series if s not in res.series]
        if unknown:
            raise FieldError("series", f"unknown series {unknown}; available: {sorted(res.series)}")
    return [s for s in (series or DEFAULT_SERIES) if s in res.series]


def names_runtime_law(model_in):
    """Whether a model names a flow or friction law registered at run time (or an unknown one).

    Such a model runs on a core compiled in memory on its first use (about 10 s): never
    on the event loop.

    Parameters
    ----------
    model_in : app.schemas.ModelIn
        The request's model, before validation

    Returns
    -------
    runtime : bool
        True unless both laws are built into the cached core
    """
    flow = FLOW_LAWS.get(model_in.valve.flow_law)
    friction = FRICTION_LAWS.get(model_in.friction.law)
    return not (flow is not None and flow.builtin and friction is not None and friction.builtin)


def simulation(req, limits, max_steps=None, run=simulate, form="json", memory=None):
    """POST /api/simulate: the request checked, simulated, and the result as the API's JSON.

    Parameters
    ----------
    req : app.schemas.SimulateRequest
        The request (model, scenario, series)
    limits : app.config.Limits
        The API's limits (duration, samples, breakpoints, solver steps)
    max_steps : int or None
        A step budget [-] below the request's own (the event loop's), or None for the
        request's budget; a run that exhausts it where the request allows more raises
        :class:`PastBudget` (and is to be run again without it)
    run : callable
        The simulation, ``run(model, scenario)`` (:func:`pneucore.simulate.simulate`; the
        simulate router hands over the one it names, so where each run happens can be watched)
    form : {"json", "npz"}
        The answer's form: the dict :func:`result_json` (rendered by
        :class:`app.responses.JSON`, or as CSV), or the bytes of :func:`result_npz`
    memory : app.analysis_memory.MemoryBudget or None
        The budget its estimate (output samples, :data:`app.analysis_memory.BYTES_PER_SAMPLE`)
        is held on while it runs (503 when it does not fit now); None: not counted (the
        event loop's small runs). An estimate over the whole budget is a 422 naming
        ``scenario.duration`` either way

    Returns
    -------
    out : dict or bytes
        The body of the answer
    """
    if getattr(req.scenario, "controller", None) is not None:   # closed loop (issue 42)
        return closed_loop_simulation(req, limits, max_steps, form)
    model = parse_model(req.model)
    scen = parse_scenario(req.scenario, model, limits)
    with _simulation_held(scen, limits, memory):
        return _simulated(req, model, scen, max_steps, run, form)


def _simulation_held(scen, limits, memory, runs=1):
    """Context manager: the estimate of ``runs`` simulations of ``scen`` (its output samples,
    :data:`app.analysis_memory.BYTES_PER_SAMPLE`) held on ``memory`` (503 when it does not fit
    now; None: not counted); a 422 naming ``scenario.duration`` when it alone exceeds the
    budget."""
    from pneucore.simulate import output_samples
    samples = output_samples(scen.duration, scen.sample_period)
    estimate = samples_estimate("simulate", samples, runs)
    what = f"{runs} simulations" if runs > 1 else "a simulation"
    check_alone(estimate, limits.analysis_memory_budget, "scenario.duration",
                f"{what} of {scen.duration:g} s ({samples:,} output samples)")
    return nullcontext() if memory is None else memory.hold(estimate, "simulation")


def _simulated(req, model, scen, max_steps, run, form):
    """:func:`simulation`'s run and answer, its estimate held."""
    budget = scen.solver.max_steps
    if max_steps is not None:
        scen.solver.max_steps = min(budget, max_steps)
    try:
        res = run(model, scen)
    except SimulationError as exc:
        if max_steps is not None and budget > max_steps and exc.result is not None \
                and exc.result.status == ERR_MAX_STEPS:
            raise PastBudget from None
        raise
    return result_npz(res, req.series) if form == "npz" else result_json(res, req.series)


def simulation_csv(out):
    """The CSV text of a simulation's answer (:func:`simulation`'s ``out``)."""
    from pneucore.data.export import simulation_csv as as_csv
    return as_csv(out)


def simulate_under_heat_models(req, limits, memory=None):
    """POST /api/simulate/heat-models: one scenario under each requested heat model.

    Returns ``{"runs": {heat model: result JSON}}``; an unknown heat model is a FieldError
    on ``heat_models``, found before any run. ``memory``: as for :func:`simulation` (every
    run's estimate held: their answers are kept together).
    """
    model = parse_model(req.model)
    scen = parse_scenario(req.scenario, model, limits)
    names = check_heat_models(req.heat_models)
    with _simulation_held(scen, limits, memory, max(len(names), 1)):
        return {"runs": {name: result_json(simulate(with_heat_model(model, name), scen), req.series)
                         for name in names}}


# ------------------------------------------------------------------------------ analyses
def deadline_progress(limits, what, job_path):
    """Progress callback that stops a synchronous analysis past the request time limit, or
    once its client has gone.

    The time counts from the request's admission to :mod:`app.sync_pool` (the time it waited
    in the queue included); the callback raises :class:`app.sync_pool.ClientGone` once the
    client has closed its connection (nothing would read the answer).

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
    from .sync_pool import CURRENT, ClientGone
    ticket = CURRENT.get()   # the request's, set by the pool's admission; None outside it
    t0 = ticket.admitted if ticket is not None else time.monotonic()
    waited = ticket.waited() if ticket is not None else 0.0

    def check(fraction, step):
        if ticket is not None and ticket.gone.is_set():
            raise ClientGone(f"the client of the {what} left (at step: {step}); stopped")
        if time.monotonic() - t0 > limits.request_time_limit:
            raise JobTimeout(f"the {what} exceeded the request time limit of "
                             f"{limits.request_time_limit:g} s (at step: {step}; {waited:.1f} s of "
                             f"it waiting for a worker); use POST {job_path}")
    return check


#: What each analysis is called in the memory messages, by its kind in
#: :data:`app.analysis_memory.BYTES_PER_SAMPLE`
_ANALYSIS_WORDS = {"compare": "comparison", "calibrate": "calibration", "diagnose": "diagnosis",
                   "refine": "refinement", "heat": "heat-model comparison"}


def memory_estimate(kind, exps, limits, models=1):
    """The memory estimate of an analysis of ``kind`` on ``exps`` [bytes]
    (:func:`app.analysis_memory.analysis_estimate`); a 422 naming ``experiments`` when it alone
    exceeds ``limits.analysis_memory_budget``. A job passes it to
    :meth:`app.jobs.JobManager.submit`, which waits until it fits."""
    estimate = analysis_estimate(kind, exps, models)
    check_alone(estimate, limits.analysis_memory_budget, "experiments",
                f"a {_ANALYSIS_WORDS[kind]} of {seconds_of(exps)}")
    return estimate


def _held(kind, exps, limits, models=1):
    """Context manager: the analysis's estimate held on the synchronous request's budget while
    it runs (:func:`app.analysis_memory.admitted`: 503 when it does not fit now); nothing held
    in a job, whose manager held it before the start."""
    return admitted(memory_estimate(kind, exps, limits, models), _ANALYSIS_WORDS[kind])


def check_compare(req: CompareRequest, store, limits):
    """Everything a compare request can get wrong, checked before any work."""
    model = parse_model(req.model)
    check_heat_models(req.heat_models)
    return model, parse_experiments(req.experiments, model, store, limits)


def fit_known(req, model, listed=()):
    """What a fit request holds: ``(known, held)``.

    ``known`` is the request's ``known`` plus, unless ``bench_known`` is false, every path the
    model's ``provenance`` says was identified on a bench (a flow bench, a friction bench:
    :func:`pneucore.description.provenance.bench_known`) and that is a parameter of this model;
    ``held`` are those bench paths that the request lists to be fitted (``listed``: a
    calibration's varied parameters, a diagnosis's ``uncertain``): they are held at their bench
    value, and the answer names them (``bench_held``). ``bench_known: false`` fits them like any
    other value.
    """
    known = list(req.known)
    if not req.bench_known:
        return known, []
    for p in bench_known(model):
        if p in known:
            continue
        try:
            check_request(model, [], (), [p])   # a bench path this model has (edge, effect)
        except FieldError:
            continue
        known.append(p)
    held = [p for p in known if p not in req.known and p in listed]
    return known, held


def check_calibrate(req: CalibrateRequest, store, limits):
    model = parse_model(req.model)
    params = {k: v.model_dump(exclude_none=True) for k, v in req.parameters.items()}
    exps = parse_experiments(req.experiments, model, store, limits)
    check_parameters(model, exps, params)   # model paths and sensors.<signal>.offset / .gain
    known, held = fit_known(req, model, [k for k, p in params.items() if p.get("vary", True)])
    for path in held:   # bench-identified: held at the bench's value
        params[path] = {**{k: v for k, v in params[path].items() if k != "value"}, "vary": False}
    check_request(model, [], (), known)
    for path, p in params.items():
        if path in known and p.get("vary", True):
            raise FieldError(f"parameters.{path}", "declared known (in known): a known value is never "
                                                   "fitted; drop it from parameters or from known")
    return model, exps, params


def _uncertain_known(req, model):
    """A diagnosis's or refinement's ``(uncertain, known, held)`` after :func:`fit_known`:
    the bench paths listed in ``uncertain`` leave it, held."""
    known, held = fit_known(req, model, req.uncertain)
    return [p for p in req.uncertain if p not in held], known, held


def diagnosis_scheduler(req, settings):
    """The Dask scheduler address a diagnosis or refinement runs its candidate refits on, from
    the request's cluster *name* (:func:`cluster_address`, the studies' resolution: an address
    or an unconfigured name is a 422 naming ``scheduler``); None = this machine. ``settings``
    None = no cluster configured."""
    address = cluster_address(settings if settings is not None else _NO_CLUSTER,
                              getattr(req, "scheduler", None))
    return None if address == "local" else address


def check_diagnose(req: DiagnoseRequest, store, limits, settings=None):
    diagnosis_scheduler(req, settings)
    model = parse_model(req.model)
    uncertain, known, _ = _uncertain_known(req, model)
    check_request(model, req.candidates, uncertain, known)
    return model, parse_experiments(req.experiments, model, store, limits)


def run_compare(req: CompareRequest, store, limits, progress=None, checked=None):
    """The comparison; ``checked``: what :func:`check_compare` returned for ``req`` (a job
    checked at submission), else it is checked here."""
    model, exps = checked or check_compare(req, store, limits)
    # under heat models too: each of their comparisons is dropped but for its errors once
    # summarised, so two at most are alive at once
    with _held("compare", exps, limits, 2 if check_heat_models(req.heat_models) else 1):
        return compare(model, exps, heat_models=req.heat_models,
                       progress=progress).to_dict(residuals=req.residuals)


def run_calibrate(req: CalibrateRequest, store, limits, progress=None, checked=None):
    """The calibration; ``checked`` as for :func:`run_compare` (from :func:`check_calibrate`)."""
    model, exps, params = checked or check_calibrate(req, store, limits)
    with _held("calibrate", exps, limits):
        return _calibrated(req, model, exps, params, progress)


def _calibrated(req, model, exps, params, progress):
    """:func:`run_calibrate`'s work, its estimate held."""
    known, held = fit_known(req, model, [k for k, p in req.parameters.items() if p.vary])
    cal = calibrate(model, exps, params, max_nfev=req.max_nfev, progress=progress)
    out = cal.summary()
    out["bench_held"] = held
    if known:
        # the declared values, held: where the data would move one far, a finding says so
        from pneucore.analysis import hypotheses as H
        from pneucore.analysis.calibrate import Objective
        from pneucore.analysis.compare import replay
        out["known_disagree"] = H.known_disagreements(
            cal.model, exps, known, [replay(cal.model, e) for e in exps],
            Objective(cal.model, exps, []))
    return out


def run_diagnose(req: DiagnoseRequest, store, limits, progress=None, checked=None, settings=None):
    """The diagnosis; ``checked`` as for :func:`run_compare` (from :func:`check_diagnose`);
    ``settings``: the server's (its Dask cluster, :func:`diagnosis_scheduler`)."""
    model, exps = checked or check_diagnose(req, store, limits, settings)
    uncertain, known, held = _uncertain_known(req, model)
    with _held("diagnose", exps, limits):
        out = diagnose(model, exps, candidates=req.candidates, uncertain=uncertain,
                       progress=progress, validated=True, known=known,   # checked above
                       scheduler=diagnosis_scheduler(req, settings),
                       scheduler_timeout=limits.scheduler_timeout).to_dict()
    out["bench_held"] = held
    closed = closed_loop_replays(exps)
    if closed:
        out["closed_loop"] = closed
    return out


def check_refine(req: RefineRequest, store, limits, settings=None):
    """Everything a refine request can get wrong, checked before any work."""
    diagnosis_scheduler(req, settings)
    model = parse_model(req.model)
    uncertain, known, _ = _uncertain_known(req, model)
    check_request(model, None, uncertain, known)
    return model, parse_experiments(req.experiments, model, store, limits)


def run_refine(req: RefineRequest, store, limits, progress=None, checked=None, settings=None,
               memory_held=False):
    """:func:`pneucore.analysis.history.refine` on the request: the versions, each round's diagnosis and
    the refined model (plain JSON); ``checked`` as for :func:`run_compare` (from
    :func:`check_refine`); ``settings`` as for :func:`run_diagnose`; ``memory_held``: the
    caller holds the estimate already (the refinement's report)."""
    from pneucore.analysis.history import refine, refinement_answer
    model, exps = checked or check_refine(req, store, limits, settings)
    uncertain, known, _ = _uncertain_known(req, model)
    state = {"round": 0, "last": 0.0}

    def each_round(fraction, step):   # one progress over the rounds: a new round starts low again
        if fraction < state["last"]:
            state["round"] += 1
        state["last"] = fraction
        if progress is not None:
            progress((state["round"] + min(fraction, 1.0)) / req.max_rounds,
                     f"round {state['round'] + 1}: {step}")
    with nullcontext() if memory_held else _held("refine", exps, limits):
        final, history, diagnoses = refine(model, exps, max_rounds=req.max_rounds,
                                           uncertain=uncertain, progress=each_round,
                                           validated=True, known=known,   # check_refine checked it
                                           scheduler=diagnosis_scheduler(req, settings),
                                           scheduler_timeout=limits.scheduler_timeout)
        out = refinement_answer(final, history, diagnoses)
    closed = closed_loop_replays(exps)
    if closed and isinstance(out, dict):
        out["closed_loop"] = closed
    return out


def compare_csv(req: CompareRequest, store, limits, progress=None):
    """POST /api/compare answered as CSV: the comparison's series and errors as text."""
    from pneucore.data.export import comparison_csv
    model, exps = check_compare(req, store, limits)
    with _held("compare", exps, limits):
        return comparison_csv(compare(model, exps, progress=progress))


def calibration_parameters(req):
    """POST /api/calibrate/parameters: what can be fitted on the request's model, with value,
    unit and default bounds (:func:`pneucore.analysis.calibration_options.calibration_options`)."""
    return calibration_options(parse_model(req.model))


def model_diff(req):
    """POST /api/models/diff: :func:`pneucore.description.paths.model_changes` of two models, each
    validated first (a wrong one is a 422 naming ``before.<field>`` or ``after.<field>``)."""
    from pneucore.description.paths import model_changes
    return model_changes(parse_model(req.before, "before"), parse_model(req.after, "after"))


# ------------------------------------------------------------------------------ reports
def _provenance(store, exps):
    out = []
    for e in exps:
        if not e.dataset_id:
            continue
        meta = (store.dataset_data(e.dataset_id) or {}).get("meta") or {}
        out.append({"dataset_id": e.dataset_id, **(store.dataset_info(e.dataset_id) or {}),
                    "sensors": meta.get("sensors", []), "command_source": e.command_source})
    return out


def comparison_report(req: CompareRequest, store, limits, progress=None):
    """POST /api/reports/compare: the comparison as one self-contained HTML text."""
    from pneucore.analysis.report import comparison_report as html_report
    model, exps = check_compare(req, store, limits)
    with _held("compare", exps, limits):
        c = compare(model, exps, progress=progress)
        return html_report(model, c, _provenance(store, exps))


def _shown_param(v):
    """A fitted parameter of a diagnosis on screen, as the report prints it: a number or text,
    or the answer's ``{"value", "stderr", "unit"}`` (those three fields only, each of its type);
    None for anything else (left out)."""
    def number(x):
        return isinstance(x, (int, float)) and not isinstance(x, bool)
    if number(v) or isinstance(v, str):
        return v
    if isinstance(v, dict) and number(v.get("value")):
        out = {"value": v["value"]}
        if number(v.get("stderr")):
            out["stderr"] = v["stderr"]
        if isinstance(v.get("unit"), str):
            out["unit"] = v["unit"]
        return out
    return None


def diagnosis_report(req: DiagnoseReportRequest, store, limits, progress=None, settings=None):
    """POST /api/reports/diagnose: the diagnosis (with the comparisons of the model and of the
    verdict's refined model) as one self-contained HTML text; ``progress`` follows the
    diagnosis (run where ``req.scheduler`` names, as for :func:`run_diagnose`)."""
    model, exps = check_diagnose(req, store, limits, settings)
    # the diagnosis on screen only needs the two comparisons of the report: a diagnosis's
    # estimate bounds them too
    with _held("diagnose", exps, limits):
        return _diagnosis_report(req, model, exps, store, limits, progress, settings)


def _diagnosis_report(req, model, exps, store, limits, progress, settings):
    """:func:`diagnosis_report`'s work, its estimate held."""
    from pneucore.analysis.report import diagnosis_report_on
    shown = getattr(req, "diagnosis", None)
    if shown is not None:   # the diagnosis on screen, exported as it is
        d = shown.model_dump()
        if d.get("residual_tests") is not None and not isinstance(d["residual_tests"].get("summary"), str):
            d["residual_tests"] = None
        for r in d["ranking"]:
            for k in ("error_before", "error_after_overall", "lr_statistic", "p_value", "delta_bic"):
                if r.get(k) is None:
                    r[k] = float("nan")
            r["params"] = {str(k): q for k, q in ((k, _shown_param(v)) for k, v in r["params"].items())
                           if q is not None}
        best = next((r for r in d["ranking"] if r.get("effect") == d.get("verdict")), None)
        if best is not None and best.get("model"):
            parse_model(best["model"], "diagnosis.ranking.model")   # a 422 naming it, not a 500
    else:
        uncertain, known, _ = _uncertain_known(req, model)
        d = diagnose(model, exps, candidates=req.candidates, uncertain=uncertain,
                     progress=progress, validated=True, known=known,   # checked above
                     scheduler=diagnosis_scheduler(req, settings),
                     scheduler_timeout=limits.scheduler_timeout).to_dict()
    return diagnosis_report_on(model, exps, d, _provenance(store, exps))


def session_report(session_id, store, limits, progress=None):
    """POST /api/reports/sessions/{session_id}: a refinement session as the user recorded it (every version
    with its errors and what it changed, the last version against the session's experiments)
    as one self-contained HTML text; None for an unknown session."""
    from pneucore.analysis.report import refinement_report as html_report
    from pneucore.description.paths import model_changes
    s = store.session(session_id)
    if s is None:
        return None
    # a damaged version (the store gives its model as None, the others stay usable) is listed
    # without its changes; the report compares the last readable model
    models = [None if v.get("model") is None else parse_model(v["model"], f"session.versions[{i}].model")
              for i, v in enumerate(s["versions"])]
    readable = [i for i, m in enumerate(models) if m is not None]
    if not readable:
        raise FieldError("session_id", f"session {session_id!r} has no readable version to report")
    versions = []
    for i, v in enumerate(s["versions"]):
        row = {k: v.get(k) for k in ("version", "label", "errors", "overall", "note")}
        row["changes"] = (model_changes(models[i - 1], models[i])
                          if i and models[i] is not None and models[i - 1] is not None else [])
        versions.append(row)
    last = readable[-1]
    try:
        exps_in = [ExperimentIn(**e) for e in s["experiments"]]
    except (TypeError, ValueError):
        raise FieldError("session_id", f"session {session_id!r} has unreadable experiments") from None
    if not exps_in:
        raise FieldError("session_id", f"session {session_id!r} has no experiments to compare with")
    exps = parse_experiments(exps_in, models[last], store, limits)
    with _held("compare", exps, limits):
        return _session_report(s, versions, models, last, exps, store, progress)


def _session_report(s, versions, models, last, exps, store, progress):
    """:func:`session_report`'s work, its estimate held."""
    from pneucore.analysis.report import refinement_report as html_report
    n = len(versions)
    answer = {"versions": versions, "diagnoses": [], "model": s["versions"][last]["model"],
              "message": f"Session {s['id']} “{s['name']}”: {n} version{'s' if n != 1 else ''}, each with "
                         "its errors on the experiments it was recorded on and the values it changed; "
                         "the last version is compared with the session's experiments below."}
    return html_report(answer, compare(models[last], exps, progress=progress), _provenance(store, exps),
                       title=f"Refinement session {s['name']}")


def refinement_report(req: RefineRequest, store, limits, progress=None, settings=None):
    """POST /api/reports/refine: the whole refinement (every version and round, the refined
    model against the data) as one self-contained HTML text; ``progress`` follows the loop."""
    from pneucore.analysis.report import refinement_report as html_report
    checked = check_refine(req, store, limits, settings)
    exps = checked[1]
    with _held("refine", exps, limits):
        answer = run_refine(req, store, limits, progress=progress, checked=checked,
                            settings=settings, memory_held=True)
        return html_report(answer, compare(Model.from_dict(answer["model"]), exps),
                           _provenance(store, exps))


# ------------------------------------------------------------------------------ heat models
#: Series returned per run when the request names none (what the page overlays)
HEAT_SERIES = ("t", "u", "p_a", "p_b", "T_a", "T_b", "heat_a", "heat_b", "x")


def heat_model_catalog():
    """GET /api/heat-models: every heat model with its parameters (name, unit, default, bounds)."""
    return [m.to_dict() for m in HEAT_MODELS.values()]


def simulate_every_heat_model(req, limits, memory=None):
    """POST /api/heat-models/simulate: one scenario under each requested heat model (all by
    default); the series default to those of :data:`HEAT_SERIES` every run has. ``memory``: as
    for :func:`simulate_under_heat_models`."""
    model = parse_model(req.model)
    scen = parse_scenario(req.scenario, model, limits)
    names = check_names(req.heat_models)
    with _simulation_held(scen, limits, memory, len(names)):
        runs = simulate_heat_models(model, scen, req.heat_models)
        series = req.series if req.series is not None else [
            s for s in HEAT_SERIES if all(s in r.series for r in runs.values())]
        return {"runs": {name: result_json(res, series) for name, res in runs.items()}}


def check_heat_compare(req, store, limits):
    """Everything a heat-model comparison can get wrong, checked before any work."""
    model = parse_model(req.model)
    check_names(req.heat_models)
    return model, parse_experiments(req.experiments, model, store, limits)


def heat_model_count(req):
    """Heat models a heat-model comparison calibrates (each one a calibration) [-]."""
    return len(check_names(req.heat_models))


def run_heat_compare(req, store, limits, progress=None, checked=None):
    """POST /api/heat-models/compare: each heat model calibrated on the measurement, the
    errors per model and the measured series; ``checked`` as for :func:`run_compare` (from
    :func:`check_heat_compare`)."""
    model, exps = checked or check_heat_compare(req, store, limits)
    with _held("heat", exps, limits, heat_model_count(req)):
        rows = compare_heat_models(model, exps, req.heat_models, sensor=req.sensor,
                                   max_nfev=req.max_nfev, progress=progress)
    meas = exps[0].measurement
    measured = {"t": np.ascontiguousarray(meas.t - meas.t[0], float),
                **{s: np.ascontiguousarray(meas.signals[s], float) for s in exps[0].signals}}
    return {"models": rows, "measured": measured, "experiment": exps[0].name}


# ------------------------------------------------------------------------------ model catalog
def effect_catalog():
    """GET /api/effects: the switchable effects with parameters, units, bounds, descriptions."""
    return [e.to_dict() for e in EFFECTS.values()]


def preset_list():
    """GET /api/presets: the model and scenario presets, by name with their descriptions."""
    return {"models": [{"name": k, "description": v.get("description", "")}
                       for k, v in MODEL_PRESETS.items()],
            "scenarios": [{"name": k, "description": v.get("description", "")}
                          for k, v in SCENARIO_PRESETS.items()]}


def preset(name):
    """A preset's JSON (a model or a scenario, SI units), or None for an unknown name."""
    if name in MODEL_PRESETS:
        return model_preset(name)
    if name in SCENARIO_PRESETS:
        return scenario_preset(name)
    return None


def friction_map(req):
    """POST /api/friction/preview: :func:`friction_preview` of the request's model, at its
    pressure pairs and velocities (the schema's default velocities when it gives none)."""
    model = parse_model(req.model)
    velocities = req.velocities if req.velocities is not None else FRICTION_DEFAULT_VELOCITIES
    return friction_preview(model, [(p.p_a, p.p_b) for p in req.pressures], velocities)


def friction_preview(model, pressures, velocities):
    """The friction force map of ``model``, computed by the simulator's own friction law.

    The coefficients are read from the parameter vector the compiled core simulates with
    (:func:`pneucore.simulate.build_core`: every catalog effect's transform and packing
    applied, so ``pressure_dependent_friction``, ``quadrant_friction`` and
    ``stribeck_friction`` show as they act), and the force comes from the core's functions
    of :mod:`pneucore.physics.friction`: :func:`~pneucore.physics.friction.coulomb_level` (Eq. 20),
    :func:`~pneucore.physics.friction.viscous_coefficient` (Eq. 19) and the model's law
    from :data:`~pneucore.physics.friction.FRICTION_LAWS` (its ``force``, Eq. 18 with the
    breakaway factor for the built-in law, and its ``static`` limit), with
    the extension coefficients for ``v > 0`` and the retraction ones for ``v < 0``, as the
    right-hand side picks them by piston mode (:mod:`pneucore.core.rhs`).

    Parameters
    ----------
    model : pneucore.description.model.Model
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
    from pneucore.physics.friction import FRICTION_LAWS, coulomb_level, viscous_coefficient
    from pneucore.description.scenario import Scenario
    from pneucore.simulate import build_core

    prm = build_core(model, Scenario())["model"][0]
    law = FRICTION_LAWS[model.friction.law]       # the law the core dispatches to, by name
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
        force = [float(law.force(v, 1.0, fc_e, kv_e, ratio, v_s)) if v > 0.0 else
                 float(law.force(v, -1.0, fc_r, kv_r, ratio, v_s)) if v < 0.0 else None
                 for v in vs]
        # the static limits as the core's event probes compute them (aux static_limit_ext/_ret)
        curves.append({"p_a": p_a, "p_b": p_b, "force": force,
                       "static_extend": float(law.static(fc_e, ratio, v_s)),
                       "static_retract": float(law.static(fc_r, ratio, v_s)),
                       "coulomb_extend": fc_e, "coulomb_retract": fc_r,
                       "viscous_extend": kv_e, "viscous_retract": kv_r})
    return {"law": model.friction.law, "stribeck_ratio": ratio, "stribeck_velocity": v_s,
            "velocities": vs, "curves": curves}


def parameter_units():
    """The SI unit of every model parameter path, from :func:`pneucore.description.paths.unit_of`.

    The paths are those :mod:`pneucore.description.paths` can address on a model: the numeric fields of
    the model's sections (``jack.bore``, ``friction.retract.kv0``, ...), every heat-model
    parameter (``heat.<name>``), every catalog effect's parameters
    (``effects.<effect>.<parameter>``) and the valve scale factors under the edge ``*``
    (``valve.ports.*.C``; the same unit for any edge).

    Returns
    -------
    units : dict
        ``{path: unit}`` (``"-"`` for a dimensionless parameter; ``""`` where
        :mod:`pneucore.description.paths` knows none)
    """
    import dataclasses

    from pneucore.description.effects import EFFECTS
    from pneucore.physics.heat import HEAT_PARAMETERS
    from pneucore.description.model import Model
    from pneucore.description.paths import unit_of

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


def display_units():
    """The page's display unit systems and the SI unit of every model parameter path.

    Returns
    -------
    units : dict
        ``systems`` (:func:`pneucore.description.units.unit_systems`), ``parameters``
        (:func:`parameter_units`) and ``stroke``: the unit and definition of each per-stroke
        metric of a simulation's ``stats.stroke.strokes`` (:data:`pneucore.analysis.strokes.STROKE_FIELDS`)
    """
    stroke = {name: {"unit": unit, "description": text} for name, (unit, text) in STROKE_FIELDS.items()}
    return {"systems": unit_systems(), "parameters": parameter_units(), "stroke": stroke}


# ------------------------------------------------------------------------------ datasets
def _ambient(fields) -> float:
    raw = fields.get("ambient_pressure")
    if raw in (None, ""):
        return DEFAULT_AMBIENT_PRESSURE
    try:
        p = float(raw)
    except (TypeError, ValueError):
        raise FieldError("ambient_pressure", f"must be a number in Pa, got {raw!r}") from None
    if not (p > 0 and p < float("inf")):
        raise FieldError("ambient_pressure", f"must be a positive absolute pressure in Pa, got {raw!r}")
    return p


def _json_depth(obj, limit):
    """Whether a parsed JSON value nests deeper than ``limit`` levels (iterative: any depth)."""
    stack = [(obj, 1)]
    while stack:
        o, d = stack.pop()
        if isinstance(o, (dict, list)):
            if d > limit:
                return True
            stack.extend((v, d + 1) for v in (o.values() if isinstance(o, dict) else o))
    return False


def form_json(fields, key, limits):
    """The JSON value of a form field (an upload's ``columns``, ``scenario``), its length and
    depth checked first (``Limits.max_form_field_bytes``, ``Limits.max_json_depth``); None when
    not given. Any failure is a :class:`FieldError` naming the field (a 422, never a 500)."""
    raw = fields.get(key)
    if raw in (None, ""):
        return None
    if len(raw) > limits.max_form_field_bytes:
        raise FieldError(key, f"is {len(raw)} characters long; at most max_form_field_bytes = "
                              f"{limits.max_form_field_bytes} (GET /api/limits)")
    # nesting counted on the text before parsing: the parser recurses once a level
    depth = max_depth = 0
    for ch in raw:
        if ch in "[{":
            depth += 1
            max_depth = max(max_depth, depth)
        elif ch in "]}":
            depth -= 1
    if max_depth > limits.max_json_depth:
        raise FieldError(key, f"nests {max_depth} levels deep (counting brackets); at most "
                              f"max_json_depth = {limits.max_json_depth} (GET /api/limits)")
    try:
        value = json.loads(raw)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise FieldError(key, f"is not valid JSON ({exc})") from None
    if _json_depth(value, limits.max_json_depth):   # brackets inside strings miscounted above
        raise FieldError(key, f"nests deeper than max_json_depth = {limits.max_json_depth}")
    return value


def form_name(fields, key, limits, default=None, text=False):
    """A name (or, with ``text``, a description) from a form field: at most
    ``Limits.max_name_length`` characters (``Limits.max_text_length`` for a description) and no
    control character (CR, LF, NUL, tab...); a :class:`FieldError` naming the field otherwise."""
    value = fields.get(key)
    if value in (None, ""):
        return default
    most = limits.max_text_length if text else limits.max_name_length
    if len(value) > most:
        raise FieldError(key, f"is {len(value)} characters long; at most "
                              f"{'max_text_length' if text else 'max_name_length'} = {most}")
    if any(ord(c) < 32 or ord(c) == 127 for c in value):
        raise FieldError(key, "holds a control character (a tab, a line break...)")
    return value


def _columns(fields, limits):
    columns = form_json(fields, "columns", limits)
    if columns is None:
        return None
    if not isinstance(columns, dict):
        raise FieldError("columns", 'must be a JSON object such as {"Zeit": "t"}')
    return columns


def _context(fields, limits):
    """The scenario context of an upload (``scenario`` JSON text, ``locked``, ``x0``), validated."""
    scen = {}
    if fields.get("scenario"):
        scen = form_json(fields, "scenario", limits)
        if not isinstance(scen, dict):
            raise FieldError("scenario", "must be a JSON object")
    if fields.get("locked") not in (None, ""):
        scen["locked"] = str(fields["locked"]).lower() in ("1", "true", "yes", "on")
    if fields.get("x0") not in (None, ""):
        try:
            scen["x0"] = number(float(fields["x0"]), "x0", nonnegative=True)
        except ValueError as exc:
            if isinstance(exc, FieldError):
                raise
            raise FieldError("x0", f"must be a number, got {fields['x0']!r}") from None
    return check_context(scen)


def check_context(scen):
    """Validate a stored scenario context before anything is committed.

    Every given field is checked as a scenario field (types, finiteness, bounds,
    no unknown keys), so a stored dataset can always be read back and analysed;
    fields left out take their defaults when used (the command and duration the
    measurement's). Checks that need a model (``x0`` within the stroke, the
    command within the valve's range) come when the dataset is used.

    Returns the given fields as the check read them (numbers as floats: an integer of 30
    digits is stored as 1e+30, never as a number JSON writers refuse), nothing added.
    """
    mapping(scen, "scenario")
    checked = Scenario.from_dict(dict(scen), None).to_dict()

    def given(raw, read):
        if isinstance(raw, dict) and isinstance(read, dict):
            return {k: given(v, read.get(k)) for k, v in raw.items()}
        return read
    return given(dict(scen), checked)


def store_upload(store, data, filename, fields, name, description="", limits=None):
    """Read (CSV, TDMS or .mat), validate and store an uploaded file (the slow part: the
    router runs it in a worker thread).

    Parameters
    ----------
    store : app.store.Store
        Where the dataset goes
    data : bytes
        The file's content
    filename : str or None
        Its name (the format is told from the extension and the content)
    fields : dict
        The form's (or query's) other fields: ``ambient_pressure`` [Pa], ``columns`` (JSON
        text), ``scenario`` (JSON text), ``locked``, ``x0`` [m]
    name, description : str
        Labels
    limits : app.config.Limits or None
        The service's limits (``max_request_memory``, the names' and form fields' limits);
        None = the defaults

    Returns
    -------
    info : dict
        The stored dataset's metadata and ``import`` (how the file was read)
    """
    limits = limits or Limits()
    name = form_name({"name": name}, "name", limits)
    description = form_name({"description": description}, "description", limits, "", text=True)
    columns = _columns(fields, limits)
    decoded = check_file(data, filename, limits.max_request_memory)   # before anything is decoded
    # the decoded columns held on the analyses' memory budget while they are read (503 when
    # they do not fit now: app.analysis_memory.admitted)
    with admitted(decoded, "upload") if decoded else nullcontext():
        meas = read_measurement(data, filename, ambient_pressure=_ambient(fields), name=name,
                                columns=columns, memory_budget=limits.max_request_memory)
    scen = _context(fields, limits)
    info = store.add_dataset(meas, scen, name=name, description=description)
    return {**info, "import": meas.meta.get("import")}


def store_json(store, payload):
    """Validate and store a measurement given as JSON (:class:`app.schemas.DatasetJsonIn`);
    returns the stored dataset's metadata as :func:`store_upload` does."""
    try:
        # the validated lists as they are (model_dump would copy every one of them)
        meas = Measurement.from_dict({k: v for k, v in payload.measurement if v is not None},
                                     ambient_pressure=payload.ambient_pressure or DEFAULT_AMBIENT_PRESSURE)
    except MeasurementError as exc:
        raise FieldError("measurement", str(exc)) from None
    scen = check_context(payload.scenario)
    info = store.add_dataset(meas, scen, name=payload.name or meas.name,
                             description=payload.description)
    return {**info, "import": meas.meta.get("import")}


def propose_dataset_command(store, dataset_id, req):
    """POST /api/datasets/{id}/propose-command: a held valve command read from a stored record's
    pressure edges (:func:`pneucore.data.command.propose_command`), for the user to confirm;
    None for an unknown dataset."""
    from pneucore.data.command import propose_command
    data = store.dataset_data(dataset_id)
    if data is None:
        return None
    meas = Measurement.from_dict(data)
    try:
        out = propose_command(meas, req.signal, open_level=req.open_level,
                              closed_level=req.closed_level, min_rate=req.min_rate,
                              switching_time=req.switching_time)
    except ValueError as exc:
        raise FieldError("signal", str(exc)) from None
    from pneucore.data.command import propose_b_chamber
    return {**out, "has_command": "u" in meas.signals,
            "chamber_b": propose_b_chamber(meas, out["pulses"])}


def inspect_rig_file(data, filename, limits=None):
    """POST /api/datasets/inspect: a rig file's dialect, columns, units and a proposed mapping
    (:func:`pneucore.data.fileformats.inspect_file`), nothing stored; a TDMS or MATLAB file
    (read whole) within ``limits.max_request_memory`` (:func:`app.request_memory.check_file`)."""
    decoded = check_file(data, filename, (limits or Limits()).max_request_memory, preview=True)
    with admitted(decoded, "upload") if decoded else nullcontext():
        return inspect_file(data, filename)


# ------------------------------------------------------------------------------ sessions
def _session_errors(model, experiments, store, limits):
    """``(errors, overall)`` of ``model`` on the experiments; None without experiments."""
    if not experiments:
        return None
    return model_errors(model, parse_experiments(experiments, model, store, limits))


def new_session(req, store, limits):
    """Start a refinement session (version 0 = the request's model, with its errors on the
    experiments); returns the session's id."""
    model = parse_model(req.model)
    comparison = _session_errors(model, req.experiments, store, limits)
    exps = finite_json([e.model_dump(exclude_none=True) for e in req.experiments], "experiments")
    return store.create_session(req.name, exps, model, comparison)


def add_session_version(session_id, req, store, limits):
    """Add a model version to a session, its errors recomputed on the session's experiments;
    returns the session with every version, or None for an unknown session."""
    s = store.session(session_id)
    if s is None:
        return None
    model = parse_model(req.model)
    if req.added is not None:
        choice(req.added, EFFECTS, "added")
    params = finite_json(req.params, "params")
    if req.experiments is not None:
        exps = req.experiments
        new_set = finite_json([e.model_dump(exclude_none=True) for e in exps], "experiments")
    else:
        new_set = None
        try:
            exps = [ExperimentIn(**e) for e in s["experiments"]]
        except (TypeError, ValueError):
            raise FieldError("session", f"session {session_id!r} has unreadable experiments; "
                                        f"start a new session") from None
    store.add_version(session_id, model, _session_errors(model, exps, store, limits), req.added,
                      params, req.note, experiments=new_set)
    return store.session(session_id)


# ------------------------------------------------------------------------------ studies
#: Settings with no Dask cluster configured (a caller of the services without the server's)
_NO_CLUSTER = SimpleNamespace(dask_scheduler=None)


def configured_clusters(settings):
    """The cluster names a request may give, those of :data:`STUDY_CLUSTERS` configured here."""
    return [c for c in STUDY_CLUSTERS if c == "local" or (c == "dask" and settings.dask_scheduler)]


def study_clusters(settings, limits):
    """GET /api/studies/clusters: where studies can run, by the names a request may give."""
    out = [{"name": "local", "kind": "local process pool", "max_workers": limits.max_workers,
            "default": settings.dask_scheduler is None}]
    if settings.dask_scheduler:
        out.append({"name": "dask", "kind": "dask.distributed cluster configured on the server",
                    "default": True})
    return out


def cluster_address(settings, name=None):
    """The engine of cluster ``name`` for ``run_study``: ``"local"`` or the configured address.

    ``name`` None = the Dask cluster when one is configured, else the local pool. Any other
    name, an address above all, is refused (field ``scheduler``): the address comes from the
    server's configuration only, so no request makes the service connect anywhere.
    """
    names = configured_clusters(settings)
    if name is None:
        name = "dask" if "dask" in names else "local"
    if name not in names:
        shown = name if len(name) <= 64 else name[:61] + "..."
        raise FieldError("scheduler", f"unknown cluster {shown!r}: give one of {names} (a Dask "
                                      f"scheduler address is set on the server with "
                                      f"$PNEUCORE_DASK_SCHEDULER or --scheduler, never in a request)")
    return "local" if name == "local" else settings.dask_scheduler


def study_memory(scenario, address, workers, limits=None):
    """A study job's memory estimate [bytes] (:func:`app.analysis_memory.study_estimate`): the
    local pool's ``workers`` processes (None: the CPUs available) each simulating one run of
    ``scenario`` (a Scenario or its dict); a Dask cluster's runs are not this server's. A 422
    naming ``workers`` when it alone exceeds ``limits.analysis_memory_budget``."""
    from pneucore.simulate import output_samples
    from pneucore.study.execute import default_workers
    get = scenario.get if isinstance(scenario, dict) else lambda k, d=None: getattr(scenario, k, d)
    samples = output_samples(float(get("duration")), float(get("sample_period", 1e-3) or 1e-3))
    n = default_workers() if workers is None else int(workers)
    estimate = study_estimate(samples, n, local=address == "local")
    if limits is not None:
        check_alone(estimate, limits.analysis_memory_budget, "workers",
                    f"a study on {n} worker processes, runs of {samples:,} samples,")
    return estimate


def _stored_study_memory(db_path, sid, address, workers):
    """:func:`study_memory` of a stored study (a resume, the start-up recovery) [bytes]; the
    floor's estimate where its definition cannot be read (the study then fails and says why)."""
    import json

    from pneucore.study.store import connect, get_study
    try:
        db = connect(db_path)
        try:
            rec = get_study(db, sid)
        finally:
            db.close()
        return study_memory(json.loads(rec["definition"])["scenario"], address, workers)
    except Exception:   # noqa: BLE001 - a damaged record: run_study names what is wrong
        return study_estimate(1, 0)


def start_study(app_state, db_path, sid, scheduler=None, workers=None, time_limit=None,
                memory=None):
    """Queue ``run_study`` for a stored study as a job (POST, resume, start-up recovery).

    ``scheduler`` is a cluster *name* (see :func:`cluster_address`; None = the default).
    A study deleted while it runs is stopped within a second and its runs removed; the
    time limit holds whether or not batches finish. Raises :class:`QueueFull` when the
    job queue is full. ``memory``: the job's estimate [bytes] (:func:`study_memory`; None:
    computed from the stored study), waited for in the queue.
    """
    cancelled = app_state.cancelled_studies
    settings = app_state.settings
    address = cluster_address(settings, scheduler)
    limits = settings.limits

    def run(job):
        def progress(fraction, step):
            if sid in cancelled:
                raise Cancelled(f"study {sid} was deleted")
            job.report(fraction, step)
        try:
            return run_study(None, store_path=db_path, scheduler=address, workers=workers,
                             progress=progress, study_id=sid, time_limit=time_limit or limits.study_time_limit,
                             scheduler_timeout=limits.scheduler_timeout)
        except Exception:
            if sid not in cancelled and not app_state.jobs.stopping:
                # the study follows its job: a failure (a full disk among them) leaves it
                # resumable, never "running"; when even this cannot be written, the reads
                # say so from the job (study_state_from_job)
                _mark_interrupted(db_path, sid)
            raise
        finally:
            if sid in cancelled:
                delete_study(db_path, sid)
            elif app_state.jobs.stopping:
                # stopped by a shutdown: queued again, so the next start resumes it
                requeue_study(db_path, sid)
    if memory is None:
        memory = _stored_study_memory(db_path, sid, address, workers)
    try:
        job = app_state.jobs.submit("study", run, time_limit=time_limit, memory=memory)
    except RuntimeError as exc:   # JobManager.submit: the queue is full
        raise QueueFull(str(exc)) from None
    job.study_id = sid
    return job


def _mark_interrupted(db_path, sid):
    """Store the status ``interrupted`` for study ``sid``; False when it cannot be written."""
    try:
        set_study_status(db_path, sid, "interrupted")
        return True
    except Exception as exc:   # a full disk: the job's state answers until it can be written
        print(f"pneucore: study {sid} not marked interrupted: {type(exc).__name__}: {exc}")
        return False


def study_state_from_job(st, job, db_path):
    """A study's stored state ``st`` corrected by its latest job: a stored ``queued`` or
    ``running`` whose job has failed or stopped reads ``interrupted`` (and is stored so when
    it can be, e.g. once space is freed after a full disk).

    Parameters
    ----------
    st : dict
        The study's entry (its ``status`` is changed in place)
    job : app.jobs.Job or app.jobs.JobRecord or None
        Its latest job in this server
    db_path : str
        The store

    Returns
    -------
    dict
        ``st``
    """
    if job is not None and job.status in ("error", "interrupted") and \
            st.get("status") in ("queued", "running"):
        st["status"] = "interrupted"
        _mark_interrupted(db_path, st["id"])
    return st


def queue_new_study(req, app_state, limits):
    """POST /api/studies: check the study (model, scenario, parameters, runs, cluster,
    workers), store it and queue it as a job; returns ``{id, job_id, n_runs, status}``.
    Raises :class:`QueueFull` (before anything is stored) when the job queue is full."""
    model = parse_model(req.model)
    scenario = req.scenario.plain()
    controller = scenario.pop("controller", None)
    if controller is not None:
        # a closed-loop study (issue 42): every run is the loop on the run's model
        if "command" in req.scenario.model_fields_set and req.scenario.command is not None:
            raise FieldError("scenario.command", "give either a command (open loop) or a "
                             "controller (closed loop), not both")
        scenario.pop("command", None)
    parse_scenario(scenario, model, limits)
    if controller is not None:
        scenario["controller"] = controller
    # the validated Model itself: Study.from_dict takes it as it is (validated once, above)
    d = {"model": model, "scenario": scenario, "parameters": req.parameters,
         "samples": req.samples, "seed": req.seed, "metrics": req.metrics, "name": req.name}
    study = Study.from_dict(d)
    if study.n_runs > limits.max_study_runs:
        raise FieldError("samples", f"{study.n_runs} runs exceed the API limit of {limits.max_study_runs}")
    settings = app_state.settings
    address = cluster_address(settings, req.scheduler)
    if req.workers is not None and not (0 <= req.workers <= limits.max_workers):
        raise FieldError("workers", f"must be a whole number in [0, {limits.max_workers}] (max_workers "
                                    f"of GET /api/limits: the CPUs available), got {req.workers}")
    check_run_options(workers=req.workers, scheduler=None if address == "local" else address)
    # (the job keeps the study's id, not the parsed request: no body's estimate added)
    memory = study_memory(study.scenario, address, req.workers, limits)
    if app_state.jobs.active() >= app_state.jobs.max_jobs:
        raise QueueFull(f"too many jobs queued or running (limit {app_state.jobs.max_jobs})")
    sid = queue_study(study, settings.db_path)   # the id exists in the store from now on
    job = start_study(app_state, settings.db_path, sid, req.scheduler, req.workers,
                      limits.study_time_limit, memory)
    return {"id": sid, "job_id": job.id, "n_runs": study.n_runs, "status": "queued"}


def list_stored_studies(db_path):
    """Every stored study (id, name, created, status, runs)."""
    return list_studies(db_path)


def study_exists(db_path, sid):
    return any(s["id"] == sid for s in list_studies(db_path))


def study_progress(db_path, sid):
    """A study's progress (runs stored, failed, fraction), or None for an unknown study."""
    try:
        return study_status(db_path, sid)
    except KeyError:
        return None


def study_summary(db_path, sid, include_runs=True):
    """A study's distributions, percentiles, sensitivity ranking and (``include_runs``) raw
    runs, or None for an unknown study."""
    try:
        return study_results(db_path, sid, include_runs=include_runs)
    except KeyError:
        return None


def study_runs_csv(db_path, sid):
    """The stored runs of a study as CSV text chunks (an iterator), or None for an unknown
    study."""
    try:
        return runs_csv(db_path, sid)
    except KeyError:
        return None


def study_runs_npz(db_path, sid):
    """The stored runs of a study as a NumPy ``.npz`` archive (bytes), or None for an
    unknown study."""
    try:
        return runs_npz(db_path, sid)
    except KeyError:
        return None


def discard_study(app_state, db_path, sid, running):
    """Delete a study and its runs; ``running``: its job is queued or running, and is told to
    stop (within a second; the job removes what it stored meanwhile)."""
    if running:
        app_state.cancelled_studies.add(sid)
    delete_study(db_path, sid)


# ---------------------------------------------------------------------------- identification
# the step-by-step identification (issue 29): a valve flow bench and a friction bench
def check_identify_valve(req):
    """POST /api/identify/valve, validated: the bench points (pneucore's checks, 422 naming
    the point and field), the model when given and the edge against its valve."""
    from pneucore.identify.valve_bench import BenchPoint
    from pneucore.physics.flow import R_LAMINAR
    from pneucore.description.model import VALVE_KINDS

    model = parse_model(req.model) if req.model is not None else None
    u_range = model.valve.opening_range if model is not None else VALVE_KINDS["4/2"]["range"]
    r_lam = model.valve.laminar_ratio if model is not None else R_LAMINAR
    if model is not None and req.edge not in VALVE_KINDS[model.valve.kind]["ports"]:
        raise FieldError("edge", f"a {model.valve.kind} valve has no edge {req.edge!r} (its edges: "
                                 f"{', '.join(VALVE_KINDS[model.valve.kind]['ports'])})")
    points = [BenchPoint.from_dict(p.model_dump(), f"points[{i}]", u_range)
              for i, p in enumerate(req.points)]
    return {"model": model, "u_range": u_range, "laminar_ratio": r_lam, "points": points}


def identify_memory(kind, checked, limits=None):
    """An identification's memory estimate [bytes]
    (:func:`app.analysis_memory.identify_estimate`: a friction bench's records' samples, fitted
    and validated); a 422 naming ``experiments`` when it alone exceeds the budget."""
    limits = limits or Limits()
    samples = 0 if kind == "valve" else \
        sum(int(r.t.size) for r in list(checked["fit"]) + list(checked["validate"]))
    estimate = identify_estimate(kind, samples)
    check_alone(estimate, limits.analysis_memory_budget, "experiments",
                f"a {kind} identification of {samples:,} samples")
    return estimate


def run_identify_valve(req, progress=None, checked=None, limits=None):
    """The edge's C(u), b(u) tables (:func:`pneucore.identify.identify_valve`), with the model's
    valve table written when a model was given."""
    c = checked or check_identify_valve(req)
    # held on a synchronous request's budget (503 when it does not fit); a job held it before
    with admitted(identify_memory("valve", c, limits), "valve identification"):
        return _identify_valve(req, c, progress)


def _identify_valve(req, c, progress):
    from pneucore.identify import identify_valve

    res = identify_valve(c["points"], req.edge, u_range=c["u_range"], laminar_ratio=c["laminar_ratio"],
                         openings=req.openings, progress=progress)
    out = res.to_dict()
    out["table"] = res.port_table(c["u_range"]).to_dict()
    out["model"] = res.write_into(c["model"]).to_dict() if c["model"] is not None else None
    return out


def _bench_record(r, path, store):
    """A friction-bench record's fields, a ``dataset_id`` read from the store (its measurement
    in SI units, the rod force ``F`` among its signals)."""
    d = r.model_dump(exclude_none=True)
    did = d.pop("dataset_id", None)
    if did is None:
        return d
    meas = store.measurement(did) if store is not None else None
    if meas is None:
        raise FieldError(f"{path}.dataset_id", f"unknown dataset {did!r}")
    return {"name": d.get("name") or meas.name or did, "measurement": meas.to_dict()}


def check_identify_friction(req, store=None):
    """POST /api/identify/friction, validated: the model and every record (422 naming it); a
    record may be a stored dataset (``dataset_id``, read from ``store``)."""
    from pneucore.identify.friction_bench import FrictionRecord

    model = parse_model(req.model)
    fit = [FrictionRecord.from_dict(_bench_record(r, f"experiments[{i}]", store), f"experiments[{i}]")
           for i, r in enumerate(req.experiments)]
    val = [FrictionRecord.from_dict(_bench_record(r, f"validate[{i}]", store), f"validate[{i}]")
           for i, r in enumerate(req.validate_)]
    return {"model": model, "fit": fit, "validate": val}


def run_identify_friction(req, progress=None, checked=None, store=None, limits=None):
    """The model's friction law from the bench records
    (:func:`pneucore.identify.identify_friction`) and the rod force it predicts on the
    validation records (:func:`pneucore.identify.predict_rod_force`)."""
    c = checked or check_identify_friction(req, store)
    # held on a synchronous request's budget (503 when it does not fit); a job held it before
    with admitted(identify_memory("friction", c, limits), "friction identification"):
        return _identify_friction(req, c, progress)


def _identify_friction(req, c, progress):
    from pneucore.identify import identify_friction, predict_rod_force

    progress = progress or (lambda f, s: None)
    res = identify_friction(c["model"], c["fit"], extras=req.extras, stribeck=req.stribeck,
                            quadrant=req.quadrant, v_min=req.v_min, window=req.window,
                            progress=lambda f, s: progress(0.9 * f, s))
    extra = {k: res.parameters[k]["value"] for k in ("offset", "area_a", "area_b")
             if k in res.parameters and res.parameters[k]["identified"]}
    out = res.to_dict()
    out["validation"] = []
    for i, rec in enumerate(c["validate"]):
        progress(0.9 + 0.1 * i / max(len(c["validate"]), 1), f"validating on {rec.name or i}")
        out["validation"].append(predict_rod_force(res.model, rec, window=req.window, v_min=res.v_min,
                                                   **extra))
    return out


def read_friction_files(files, fields, limits):
    """POST /api/identify/friction/records: friction-bench files as the rig writes them (no
    header; the layout declared in ``columns``, the TU Delft rig's by default) read by
    :func:`pneucore.identify.read_bench_file`, the reader the CLI uses, into records that POST
    /api/identify/friction takes as they are.

    Parameters
    ----------
    files : list of tuple
        ``(filename, bytes)`` of each uploaded file [-]
    fields : dict
        The form's (or query's) other fields: ``columns`` (labels in file order, comma-separated
        or a JSON list), ``ambient_pressure`` [Pa]
    limits : Limits
        The documented limits (file count, rows, the memory budget of a file)
    """
    from pneucore.identify.friction_bench import RIG_COLUMNS, bench_columns, read_bench_file

    from .schemas_identify import MAX_FRICTION_RECORDS, MAX_RECORD_SAMPLES

    if not files:
        raise FieldError("file", "at least one bench file is required (multipart field 'file', once "
                                 "per file)")
    if len(files) > MAX_FRICTION_RECORDS:
        raise FieldError("file", f"{len(files)} files, at most {MAX_FRICTION_RECORDS} a request")
    p_atm = _ambient(fields)
    raw = fields.get("columns")
    if raw in (None, ""):
        columns, declared = list(RIG_COLUMNS), False
    else:
        if len(raw.encode()) > limits.max_form_field_bytes:
            raise FieldError("columns", f"longer than {limits.max_form_field_bytes} bytes")
        text = raw.strip()
        if text.startswith("["):
            try:
                columns = json.loads(text)
            except ValueError as exc:
                raise FieldError("columns", f"is not a JSON list: {exc}") from None
        else:
            columns = [c.strip() for c in text.split(",")]
        declared = True
    layout = bench_columns(columns, p_atm)
    records, summary = [], []
    for i, (filename, data) in enumerate(files):
        decoded = check_file(data, "bench.csv", limits.max_request_memory)   # 422 before decoding
        name = "".join(ch for ch in str(filename or f"file {i + 1}") if ch.isprintable())
        name = name.rsplit(".", 1)[0][:limits.max_name_length] or f"file {i + 1}"
        with admitted(decoded, "upload"):   # held on the analyses' budget while decoded
            rec = read_bench_file(data, p_atm, name, columns, field=f"file[{i}]",
                                  max_rows=MAX_RECORD_SAMPLES)
        records.append(rec.to_dict())
        summary.append({"name": name, "samples": int(rec.t.size), "duration": float(rec.t[-1] - rec.t[0]),
                        "p_a_median": float(np.median(rec.p_a)), "p_b_median": float(np.median(rec.p_b)),
                        "stroke": float(np.ptp(rec.x))})
    signals = {sig for _, sig, _, _ in layout}
    warnings = []
    if "p_b" not in signals:
        warnings.append(f"the files have no p_b column: chamber B is taken at ambient, p_b = "
                        f"{p_atm:g} Pa abs in every record; its pressure coefficients (fc_b, kv_b) "
                        f"cannot be identified from these records and keep the model's values")
    if not declared:
        warnings.append("read with the TU Delft friction bench's layout (no columns given): "
                        + ", ".join("-" if c is None else c for c in RIG_COLUMNS)
                        + "; x = -position (the position grows as the piston moves into the "
                          "pressurised chamber A)")
    return {"records": records, "files": summary, "columns": [None if c in (None, "", "-", "_") else c
                                                              for c in columns],
            "ambient_pressure": p_atm, "warnings": warnings}


def catalogue_valve(req):
    """POST /api/valve/catalogue: an on/off valve from catalogue figures (422 naming a bad field)."""
    from pneucore.description.valve_data import CATALOGUE_VALVES, catalogue_valve as build
    d = req.model_dump(exclude_none=True)
    valve = build(d, path="body")
    return {"valve": valve, "description": CATALOGUE_VALVES[d["function"]]["description"],
            "functions": {k: v["description"] for k, v in CATALOGUE_VALVES.items()}}


def convert_valve(req):
    """POST /api/valve/convert: catalogue valve data to C and b (a bad field: 422 naming it)."""
    return convert_valve_data(req.model_dump(exclude_unset=True), path="body")
