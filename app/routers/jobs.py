"""Long work as jobs: POST /api/jobs/{diagnose|calibrate|compare|refine} -> id; GET /api/jobs/{id}."""
from fastapi import APIRouter, HTTPException
from ..responses import JSON

from ..analysis_memory import job_estimate
from ..bodies import OffLoopRoute
from ..deps import JobsDep, LimitsDep, SettingsDep, StoreDep, not_found
from ..schemas import CalibrateRequest, CompareRequest, DiagnoseRequest, JobResponse, RefineRequest
from ..services import (check_calibrate, check_compare, check_diagnose, check_refine, memory_estimate,
                        run_calibrate, run_compare, run_diagnose, run_refine)
from ..sizing_schemas import SizingRequest
from ..sizing_service import check_sizing, run_sizing, sizing_memory

router = APIRouter(prefix="/api/jobs", tags=["jobs"], route_class=OffLoopRoute)


def _submit(jobs, kind, fn, memory=0):
    """Queue ``fn`` as a job of ``kind``; ``memory``: its estimate [bytes], waited for in the
    queue (:func:`app.services.memory_estimate`, a 422 now when it alone exceeds the budget)."""
    try:
        # the job keeps its parsed request: its body's estimate too (app.analysis_memory.BODY)
        job = jobs.submit(kind, fn, memory=job_estimate(memory) if memory else 0)
    except RuntimeError as exc:
        raise HTTPException(429, str(exc)) from None
    return job.to_dict(with_result=False)


@router.post("/diagnose", status_code=202, response_model=JobResponse, summary="Diagnose as a job")
def diagnose_job(req: DiagnoseRequest, store: StoreDep, limits: LimitsDep, jobs: JobsDep,
                 settings: SettingsDep):
    # validate up front so bad input is a 422 now, not a failed job later; the job runs on
    # what was checked (validated once), on the cluster the request names
    checked = check_diagnose(req, store, limits, settings)
    return _submit(jobs, "diagnose", lambda job: run_diagnose(req, store, limits, progress=job.report,
                                                              checked=checked, settings=settings),
                   memory_estimate("diagnose", checked[1], limits))


def _simple(kind, check, runner):
    """A job that validates its request up front, then runs ``runner`` reporting progress."""
    def endpoint(req, store, limits, jobs):
        checked = check(req, store, limits)
        estimate = memory_estimate(kind, checked[1], limits)
        return _submit(jobs, kind, lambda job: runner(req, store, limits, progress=job.report,
                                                      checked=checked), estimate)
    return endpoint


_calibrate = _simple("calibrate", check_calibrate, run_calibrate)
_compare = _simple("compare", check_compare, run_compare)


@router.post("/calibrate", status_code=202, response_model=JobResponse, summary="Calibrate as a job")
def calibrate_job(req: CalibrateRequest, store: StoreDep, limits: LimitsDep, jobs: JobsDep):
    return _calibrate(req, store, limits, jobs)


@router.post("/compare", status_code=202, response_model=JobResponse, summary="Compare as a job")
def compare_job(req: CompareRequest, store: StoreDep, limits: LimitsDep, jobs: JobsDep):
    return _compare(req, store, limits, jobs)


@router.post("/refine", status_code=202, response_model=JobResponse,
             summary="Refine to the noise floor as a job (the versions, each round's diagnosis)")
def refine_job(req: RefineRequest, store: StoreDep, limits: LimitsDep, jobs: JobsDep,
               settings: SettingsDep):
    checked = check_refine(req, store, limits, settings)
    return _submit(jobs, "refine", lambda job: run_refine(req, store, limits, progress=job.report,
                                                          checked=checked, settings=settings),
                   memory_estimate("refine", checked[1], limits))


@router.post("/sizing", status_code=202, response_model=JobResponse,
             summary="Size a drive as a job (progress per family; the result is POST /api/sizing's)")
def sizing_job(req: SizingRequest, limits: LimitsDep, jobs: JobsDep):
    checked = check_sizing(req, limits)
    return _submit(jobs, "sizing", lambda job: run_sizing(req, limits, progress=job.report,
                                                          checked=checked),
                   sizing_memory(checked, limits))


@router.get("/{job_id}", response_model=JobResponse, summary="Job progress and result",
            response_class=JSON)
def get_job(job_id: str, jobs: JobsDep):
    job = jobs.get(job_id)
    if job is None:
        raise not_found("job", job_id)
    return JSON(job.to_dict())
