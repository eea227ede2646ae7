"""The control endpoints' work (issue 42): linearisation, and the closed-loop simulations that a
scenario with a ``controller`` asks POST /api/simulate for. Re-exported by :mod:`app.services`
(the routers take their work from there)."""
from __future__ import annotations

from pneucore.control.linearize import linearize, to_json
from pneucore.description.validation import FieldError

from .deps import parse_model, parse_scenario


def linearize_answer(req):
    """POST /api/linearize: the model checked, linearised at the operating point.

    Parameters
    ----------
    req : app.control_schemas.LinearizeRequest
        The request

    Returns
    -------
    out : dict
        :func:`pneucore.control.linearize.to_json` of the result
    """
    model = parse_model(req.model)
    op = req.operating_point
    freq = req.frequencies
    if freq is not None:
        bad = [i for i, f in enumerate(freq) if not (f == f and 0.0 < f < 1e7)]
        if bad:
            raise FieldError(f"frequencies[{bad[0]}]", "must be a finite frequency > 0 [Hz]")
    return to_json(linearize(model, op.x, op.p_a, op.p_b, op.u, freq))


#: The closed loop's series an answer carries by default, where the run has them
CLOSED_LOOP_SERIES = ("x_ref", "x_sensed", "v_est", "a_est", "p_a_sensed", "p_b_sensed")


def closed_loop_simulation(req, limits, max_steps=None, form="json"):
    """POST /api/simulate with a scenario's ``controller``: the closed loop
    (:func:`pneucore.control.closed_loop.simulate_closed_loop`), answered as an open-loop run
    is, with ``series.x_ref`` [m], what the controller read (``series.v_est`` [m/s],
    ``series.a_est`` [m/s^2], the estimated rates; ``series.x_sensed`` [m] where the model has
    a position sensor; ``series.p_a_sensed``, ``p_b_sensed`` [Pa] where its transducers have
    noise or a resolution) and ``stats.control``. An unstable loop is a 422 naming
    ``scenario.controller.gains``.

    Parameters
    ----------
    req : app.schemas.SimulateRequest
        The request
    limits : app.config.Limits
        The API's limits
    max_steps : int or None
        A step budget below the request's own (not used: the express lane never takes a
        closed loop)
    form : {"json", "npz"}
        The answer's form
    """
    from pneucore.control.closed_loop import ControlError, simulate_closed_loop
    from .services import result_json, result_npz

    if "command" in req.scenario.model_fields_set and req.scenario.command is not None:
        raise FieldError("scenario.command", "give either a command (open loop) or a "
                         "controller (closed loop), not both")
    model = parse_model(req.model)
    d = req.scenario.plain()
    controller = d.pop("controller")
    d.pop("command", None)
    scen = parse_scenario(d, model, limits)
    from .analysis_memory import admitted, check_alone, simulation_estimate
    from pneucore.simulate import output_samples
    samples = output_samples(scen.duration, scen.sample_period)
    estimate = simulation_estimate(samples)
    check_alone(estimate, limits.analysis_memory_budget, "scenario.duration",
                f"a closed-loop simulation of {scen.duration:g} s ({samples:,} output samples)")
    try:
        # held on the request's budget while it runs (503 when it does not fit now)
        with admitted(estimate, "closed-loop simulation"):
            res = simulate_closed_loop(model, scen, controller)
    except ControlError as exc:
        raise FieldError("scenario.controller.gains", str(exc)) from None
    series = req.series
    if series is None:
        from .services import DEFAULT_SERIES
        series = [s for s in DEFAULT_SERIES if s in res.series] + \
            [s for s in CLOSED_LOOP_SERIES if s in res.series]
    if form == "npz":
        return result_npz(res, series)
    return result_json(res, series)


def controllers_answer():
    """GET /api/controllers: each registered controller kind, its gains (unit, default) and
    the valve kinds it drives."""
    from pneucore.control.controllers import CONTROLLERS
    return {"controllers": [k.describe() for k in CONTROLLERS.values()]}


def check_control_study(req, limits, address="local"):
    """A closed-loop study or tuning request checked before its job starts (422 now): the
    study, its controller, its specification, and its scenario within the API's limits
    (duration, samples). ``address``: where its runs go (:func:`control_engine`'s
    ``scheduler``: ``"local"`` for the local process pool, else a cluster's address) [-].

    Returns
    -------
    estimate : int
        The job's memory estimate [bytes] (:func:`app.analysis_memory.control_estimate`: the
        local pool's processes each on one run, every run's row; a tuning's runs are its gain
        sets times the study's),
        a 422 naming ``study.samples`` when it alone exceeds ``limits.analysis_memory_budget``
    """
    import math

    from pneucore.control.robustness import check_specification, check_study
    from pneucore.simulate import output_samples

    from .analysis_memory import check_alone, control_estimate
    from .deps import check_scenario_limits
    study, _ = check_study(req.study)
    check_scenario_limits(study.scenario, limits, "study.scenario")
    check_specification(req.specification)
    samples = output_samples(study.scenario.duration, study.scenario.sample_period)
    gains = getattr(req, "gains", None) or {}
    runs = study.n_runs * math.prod(len(v) for v in gains.values())
    from pneucore.study.execute import default_workers
    # its runs go where a study's go (control_engine): the local pool's processes, or a cluster
    estimate = control_estimate(samples, runs, default_workers(), local=address == "local")
    check_alone(estimate, limits.analysis_memory_budget, "study.samples",
                f"{runs:,} closed-loop runs of {samples:,} samples")
    return estimate


def control_engine(settings):
    """Where a closed-loop study or tuning runs: the studies' engine (the configured Dask
    cluster, else the local process pool), with the studies' scheduler time limit."""
    from .services import cluster_address
    address = cluster_address(settings, None)
    return {"scheduler": address, "scheduler_timeout": settings.limits.scheduler_timeout}


def run_control_study(req, progress=None, engine=None):
    """The closed-loop study job's work (:func:`pneucore.control.robustness.closed_loop_study`)
    on the studies' engine; ``progress`` (the job's report) raising stops it."""
    from pneucore.control.robustness import closed_loop_study
    return closed_loop_study(req.study, progress, req.specification, engine)


def run_tune(req, progress=None, engine=None):
    """The tuning job's work (:func:`pneucore.control.robustness.tune_controller`) on the
    studies' engine."""
    from pneucore.control.robustness import tune_controller
    return tune_controller(req.study, dict(req.gains), req.objective, progress,
                           req.specification, engine)
