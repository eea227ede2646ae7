"""POST /api/compare, /api/calibrate, /api/diagnose (synchronous; see /api/jobs for long work)."""
from fastapi import APIRouter
from ..responses import JSON

from pneucore.calibrate import calibrate
from pneucore.compare import compare
from pneucore.diagnose import diagnose

from ..deps import LimitsDep, StoreDep, parse_experiments, parse_model
from ..schemas import CalibrateRequest, CompareRequest, DiagnoseRequest

router = APIRouter(prefix="/api", tags=["analysis"])


def run_compare(req: CompareRequest, store, limits):
    model = parse_model(req.model)
    exps = parse_experiments(req.experiments, model, store, limits)
    return compare(model, exps, heat_models=req.heat_models).to_dict(residuals=req.residuals)


def run_calibrate(req: CalibrateRequest, store, limits):
    model = parse_model(req.model)
    exps = parse_experiments(req.experiments, model, store, limits)
    params = {k: v.model_dump(exclude_none=True) for k, v in req.parameters.items()}
    return calibrate(model, exps, params, max_nfev=min(max(req.max_nfev, 1), 200)).summary()


def run_diagnose(req: DiagnoseRequest, store, limits, progress=None):
    model = parse_model(req.model)
    exps = parse_experiments(req.experiments, model, store, limits)
    return diagnose(model, exps, candidates=req.candidates, uncertain=req.uncertain,
                    progress=progress).to_dict()


@router.post("/compare", summary="Model versus measurements: Eq. 25 errors, phases, worst windows",
             response_class=JSON)
def compare_endpoint(req: CompareRequest, store: StoreDep, limits: LimitsDep):
    return JSON(run_compare(req, store, limits))


@router.post("/calibrate", summary="Fit model parameters (least squares, with standard errors)",
             response_class=JSON)
def calibrate_endpoint(req: CalibrateRequest, store: StoreDep, limits: LimitsDep):
    return JSON(run_calibrate(req, store, limits))


@router.post("/diagnose", summary="Rank the missing physical effects and name the verdict",
             response_class=JSON)
def diagnose_endpoint(req: DiagnoseRequest, store: StoreDep, limits: LimitsDep):
    import time
    from ..jobs import JobTimeout
    t0 = time.time()

    def deadline(fraction, step):
        if time.time() - t0 > limits.request_time_limit:
            raise JobTimeout(f"the diagnosis exceeded the request time limit of "
                             f"{limits.request_time_limit:g} s (at step: {step}); use POST /api/jobs/diagnose")
    return JSON(run_diagnose(req, store, limits, progress=deadline))
