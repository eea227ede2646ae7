"""GET /api/heat-models; POST /api/heat-models/simulate, /compare and /compare/job."""
from fastapi import APIRouter, HTTPException, Request

from ..bodies import OffLoopRoute
from ..analysis_memory import job_estimate
from ..deps import JobsDep, LimitsDep, StoreDep
from ..sync_pool import sync_slot
from ..responses import JSON
from ..schemas import (HeatModelInfo, HeatModelsCompareRequest, HeatModelsCompareResponse,
                       HeatModelsResponse, HeatModelsSimulateRequest, JobResponse)
from ..services import (check_heat_compare, deadline_progress, heat_model_catalog, heat_model_count,
                        memory_estimate, run_heat_compare, simulate_every_heat_model)

router = APIRouter(prefix="/api/heat-models", tags=["heat"], route_class=OffLoopRoute)


@router.get("", summary="The heat models with their parameters (name, unit, default, min, max)",
            response_model=list[HeatModelInfo])
def list_heat_models():
    return heat_model_catalog()


@router.post("/simulate", summary="One scenario under every heat model (pressures, temperatures)",
             response_class=JSON, response_model=HeatModelsResponse)
def simulate_endpoint(req: HeatModelsSimulateRequest, limits: LimitsDep, request: Request):
    return JSON(simulate_every_heat_model(req, limits, getattr(request.app.state, "memory", None)))


@router.post("/compare", dependencies=[sync_slot("/api/heat-models/compare/job")],
             summary="One measurement against every heat model, each calibrated on "
             "its own parameters: pressure and temperature errors per model",
             response_class=JSON, response_model=HeatModelsCompareResponse)
def compare_endpoint(req: HeatModelsCompareRequest, store: StoreDep, limits: LimitsDep):
    return JSON(run_heat_compare(req, store, limits, progress=deadline_progress(
        limits, "heat-model comparison", "/api/heat-models/compare/job")))


@router.post("/compare/job", status_code=202, response_model=JobResponse,
             summary="The same as a job (progress and result at GET /api/jobs/{id})")
def compare_job(req: HeatModelsCompareRequest, store: StoreDep, limits: LimitsDep, jobs: JobsDep):
    # checked now (bad input is a 422 now, not a failed job later); the job runs on what was checked
    checked = check_heat_compare(req, store, limits)
    estimate = memory_estimate("heat", checked[1], limits, heat_model_count(req))
    try:
        job = jobs.submit("heat-models", lambda job: run_heat_compare(req, store, limits,
                                                                      progress=job.report,
                                                                      checked=checked),
                          memory=job_estimate(estimate))   # with the request body's
    except RuntimeError as exc:
        raise HTTPException(429, str(exc)) from None
    return job.to_dict(with_result=False)
