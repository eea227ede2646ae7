"""POST /api/compare, /api/calibrate, /api/diagnose (synchronous; see /api/jobs for long work)."""
from fastapi import APIRouter
from ..responses import JSON

from pneucore.calibrate import calibrate
from pneucore.compare import check_heat_models, compare
from pneucore.diagnose import check_request, diagnose
from pneucore.paths import parse_parameters

from ..bodies import OffLoopRoute
from ..deps import LimitsDep, StoreDep, parse_experiments, parse_model
from ..schemas import CalibrateRequest, CompareRequest, DiagnoseRequest
from ..services import deadline_progress

router = APIRouter(prefix="/api", tags=["analysis"], route_class=OffLoopRoute)


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


@router.post("/compare", summary="Model versus measurements: Eq. 25 errors, phases, worst windows",
             response_class=JSON)
def compare_endpoint(req: CompareRequest, store: StoreDep, limits: LimitsDep):
    return JSON(run_compare(req, store, limits, progress=_deadline(limits, "comparison", "compare")))


@router.post("/calibrate", summary="Fit model parameters (least squares, with standard errors)",
             response_class=JSON)
def calibrate_endpoint(req: CalibrateRequest, store: StoreDep, limits: LimitsDep):
    return JSON(run_calibrate(req, store, limits,
                              progress=_deadline(limits, "calibration", "calibrate")))


@router.post("/diagnose", summary="Rank the missing physical effects and name the verdict",
             response_class=JSON)
def diagnose_endpoint(req: DiagnoseRequest, store: StoreDep, limits: LimitsDep):
    return JSON(run_diagnose(req, store, limits, progress=_deadline(limits, "diagnosis", "diagnose")))


_deadline = deadline_progress     # the old name (app.services holds it)
