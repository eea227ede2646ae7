"""POST /api/compare, /api/calibrate, /api/diagnose (synchronous; see /api/jobs for long work)."""
from fastapi import APIRouter, Request

from ..bodies import OffLoopRoute
from ..deps import LimitsDep, SettingsDep, StoreDep
from ..sync_pool import sync_slot
from ..responses import JSON, CSV_RESPONSES, csv_response, wants_csv
from ..schemas import (CalibrateRequest, CalibrateResponse, CompareRequest, CompareResponse,
                       DiagnoseRequest, DiagnoseResponse, RefineRequest, RefineResponse)
from ..services import (compare_csv, deadline_progress, run_calibrate, run_compare, run_diagnose,
                        run_refine)

router = APIRouter(prefix="/api", tags=["analysis"], route_class=OffLoopRoute)


@router.post("/compare", dependencies=[sync_slot("/api/jobs/compare")],
             summary="Model versus measurements: Eq. 25 errors, phases, worst windows",
             response_class=JSON, responses=CSV_RESPONSES, response_model=CompareResponse)
def compare_endpoint(req: CompareRequest, store: StoreDep, limits: LimitsDep, request: Request):
    progress = deadline_progress(limits, "comparison", "/api/jobs/compare")
    if wants_csv(request):
        return csv_response(compare_csv(req, store, limits, progress=progress), "comparison.csv")
    return JSON(run_compare(req, store, limits, progress=progress))


@router.post("/calibrate", dependencies=[sync_slot("/api/jobs/calibrate")],
             summary="Fit model parameters (least squares, with standard errors)",
             response_class=JSON, response_model=CalibrateResponse)
def calibrate_endpoint(req: CalibrateRequest, store: StoreDep, limits: LimitsDep):
    return JSON(run_calibrate(req, store, limits,
                              progress=deadline_progress(limits, "calibration", "/api/jobs/calibrate")))


@router.post("/diagnose", dependencies=[sync_slot("/api/jobs/diagnose")],
             summary="Rank the missing physical effects and name the verdict",
             response_class=JSON, response_model=DiagnoseResponse)
def diagnose_endpoint(req: DiagnoseRequest, store: StoreDep, limits: LimitsDep, settings: SettingsDep):
    return JSON(run_diagnose(req, store, limits, progress=deadline_progress(limits, "diagnosis", "/api/jobs/diagnose"),
                             settings=settings))


@router.post("/refine", dependencies=[sync_slot("/api/jobs/refine")],
             summary="Stepwise to the noise floor: diagnose, apply the findings, repeat",
             response_class=JSON, response_model=RefineResponse)
def refine_endpoint(req: RefineRequest, store: StoreDep, limits: LimitsDep, settings: SettingsDep):
    return JSON(run_refine(req, store, limits,
                           progress=deadline_progress(limits, "refinement", "/api/jobs/refine"),
                           settings=settings))
