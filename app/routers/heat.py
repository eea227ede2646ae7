"""GET /api/heat-models; POST /api/heat-models/simulate, /compare and /compare/job."""

import numpy as np
from fastapi import APIRouter, HTTPException

from pneucore.physics.heat import HEAT_MODELS
from pneucore.analysis.heat_compare import check_names, compare_heat_models, simulate_heat_models

from ..deps import JobsDep, LimitsDep, StoreDep, parse_experiments, parse_model, parse_scenario
from ..responses import JSON
from ..schemas import (HeatModelInfo, HeatModelsCompareRequest, HeatModelsCompareResponse,
                       HeatModelsResponse, HeatModelsSimulateRequest, JobResponse)
from ..services import deadline_progress, result_json

router = APIRouter(prefix="/api/heat-models", tags=["heat"])

#: Series returned per run when the request names none (what the page overlays)
HEAT_SERIES = ("t", "u", "p_a", "p_b", "T_a", "T_b", "heat_a", "heat_b", "x")


@router.get("", summary="The heat models with their parameters (name, unit, default, min, max)",
            response_model=list[HeatModelInfo])
def list_heat_models():
    return [m.to_dict() for m in HEAT_MODELS.values()]


@router.post("/simulate", summary="One scenario under every heat model (pressures, temperatures)",
             response_class=JSON, response_model=HeatModelsResponse)
def simulate_endpoint(req: HeatModelsSimulateRequest, limits: LimitsDep):
    model = parse_model(req.model)
    scen = parse_scenario(req.scenario, model, limits)
    check_names(req.heat_models)
    runs = simulate_heat_models(model, scen, req.heat_models)
    series = req.series if req.series is not None else [
        s for s in HEAT_SERIES if all(s in r.series for r in runs.values())]
    return JSON({"runs": {name: result_json(res, series) for name, res in runs.items()}})


def check_compare(req: HeatModelsCompareRequest, store, limits):
    """Everything the request can get wrong, checked before any work (422 with the field)."""
    model = parse_model(req.model)
    check_names(req.heat_models)
    return model, parse_experiments(req.experiments, model, store, limits)


def run_compare(req: HeatModelsCompareRequest, store, limits, progress=None):
    model, exps = check_compare(req, store, limits)
    rows = compare_heat_models(model, exps, req.heat_models, sensor=req.sensor,
                               max_nfev=min(max(req.max_nfev, 1), 200), progress=progress)
    meas = exps[0].measurement
    measured = {"t": np.ascontiguousarray(meas.t - meas.t[0], float),
                **{s: np.ascontiguousarray(meas.signals[s], float) for s in exps[0].signals}}
    return {"models": rows, "measured": measured, "experiment": exps[0].name}


@router.post("/compare", summary="One measurement against every heat model, each calibrated on "
                                 "its own parameters: pressure and temperature errors per model",
             response_class=JSON, response_model=HeatModelsCompareResponse)
def compare_endpoint(req: HeatModelsCompareRequest, store: StoreDep, limits: LimitsDep):
    return JSON(run_compare(req, store, limits, progress=deadline_progress(
        limits, "heat-model comparison", "/api/heat-models/compare/job")))


@router.post("/compare/job", status_code=202, response_model=JobResponse,
             summary="The same as a job (progress and result at GET /api/jobs/{id})")
def compare_job(req: HeatModelsCompareRequest, store: StoreDep, limits: LimitsDep, jobs: JobsDep):
    check_compare(req, store, limits)
    try:
        job = jobs.submit("heat-models", lambda job: run_compare(req, store, limits,
                                                                 progress=job.report))
    except RuntimeError as exc:
        raise HTTPException(429, str(exc)) from None
    return job.to_dict(with_result=False)
