"""POST /api/linearize: the actuator's state-space model at an operating point (issue 42,
item 5; :mod:`pneucore.control.linearize`). Closed-loop runs go through POST /api/simulate
with a scenario's ``controller``."""
from fastapi import APIRouter, HTTPException, Request

from ..analysis_memory import job_estimate
from ..bodies import OffLoopRoute
from ..control_schemas import (ControllersResponse, ControlStudyRequest, LinearizeRequest,
                               LinearizeResponse, TuneRequest)
from ..deps import JobsDep, LimitsDep
from ..responses import JSON
from ..schemas import JobResponse
from ..services import (check_control_study, control_engine, controllers_answer,
                        linearize_answer, run_control_study, run_tune)

# a large body (a study's ensemble) counted on the memory budget (app.bodies.OffLoopRoute)
router = APIRouter(prefix="/api", tags=["control"], route_class=OffLoopRoute)


@router.post("/linearize", response_model=LinearizeResponse, response_class=JSON,
             summary="Linearise the actuator at an operating point (poles, natural frequency, A, B, C, D)")
def linearize_endpoint(req: LinearizeRequest):
    return JSON(linearize_answer(req))


@router.get("/controllers", response_class=JSON, response_model=ControllersResponse,
            summary="Controller kinds for a scenario's controller: gains (unit, default), valves")
def controllers_endpoint():
    return JSON(controllers_answer())


def _job(jobs, kind, fn, memory):
    """Queue ``fn``; ``memory``: its estimate [bytes] (:func:`app.services.check_control_study`),
    with the request body's, waited for in the queue."""
    try:
        return jobs.submit(kind, fn, memory=job_estimate(memory)).to_dict(with_result=False)
    except RuntimeError as exc:
        raise HTTPException(429, str(exc)) from None


def _control_job(kind, run, req, request, limits, jobs):
    """A closed-loop study or tuning checked now (422) and run as a job on the studies' engine
    with its memory estimate; ``run(req, report, engine)`` is its work."""
    engine = control_engine(request.app.state.settings)
    estimate = check_control_study(req, limits, engine["scheduler"])
    return _job(jobs, kind, lambda job: run(req, job.report, engine), estimate)


@router.post("/jobs/control-study", status_code=202, response_model=JobResponse,
             summary="Closed-loop robustness over a study's parameter sets, as a job on the study pool")
def control_study_job(req: ControlStudyRequest, request: Request, jobs: JobsDep, limits: LimitsDep):
    return _control_job("control-study", run_control_study, req, request, limits, jobs)


@router.post("/jobs/tune-controller", status_code=202, response_model=JobResponse,
             summary="Rank controller gains on their worst case over a study's ensemble, as a job on the study pool")
def tune_job(req: TuneRequest, request: Request, jobs: JobsDep, limits: LimitsDep):
    return _control_job("tune-controller", run_tune, req, request, limits, jobs)
