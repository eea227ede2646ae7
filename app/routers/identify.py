"""POST /api/identify/valve and /api/identify/friction: the step-by-step identification on
benches (paper section 2), and the same as jobs (POST /api/jobs/identify/...)."""
from fastapi import APIRouter, HTTPException, Request
from starlette.concurrency import run_in_threadpool

from ..analysis_memory import job_estimate
from ..bodies import RAW_FILE_TYPES, OffLoopRoute, read_multipart
from ..deps import JobsDep, LimitsDep, StoreDep
from ..responses import JSON
from ..schemas import JobResponse
from ..schemas_identify import (RECORDS_UPLOAD_DOC, FrictionIdentifyRequest, FrictionIdentifyResponse,
                                FrictionRecordsResponse, ValveIdentifyRequest, ValveIdentifyResponse)
from ..services import (FieldError, check_identify_friction, check_identify_valve, identify_memory,
                        read_friction_files,
                        run_identify_friction, run_identify_valve)

# long records are large bodies: parsed off the event loop (app.bodies.OffLoopRoute)
router = APIRouter(prefix="/api/identify", tags=["identify"], route_class=OffLoopRoute)
jobs_router = APIRouter(prefix="/api/jobs/identify", tags=["jobs"], route_class=OffLoopRoute)


@router.post("/valve", response_class=JSON, response_model=ValveIdentifyResponse,
             summary="A valve edge's C(u), b(u) tables from flow-bench points (ISO 6358, paper Eq. 4-5, "
                     "Fig. 2): standard errors, null band, residuals, the model's table")
def identify_valve(req: ValveIdentifyRequest, limits: LimitsDep):
    return JSON(run_identify_valve(req, limits=limits))


@router.post("/friction", response_class=JSON, response_model=FrictionIdentifyResponse,
             summary="The friction law (Eq. 18-20) from friction-bench records by the force balance "
                     "(Eq. 17), validated on records not fitted on (paper Fig. 4)")
def identify_friction(req: FrictionIdentifyRequest, store: StoreDep, limits: LimitsDep):
    return JSON(run_identify_friction(req, store=store, limits=limits))


@router.post("/friction/records", response_class=JSON, response_model=FrictionRecordsResponse,
             openapi_extra=RECORDS_UPLOAD_DOC,
             summary="Friction-bench files as the rig writes them (no header, declared columns and "
                     "units) read into records that POST /api/identify/friction takes")
async def friction_records(request: Request, limits: LimitsDep):
    from starlette.datastructures import UploadFile
    # the body is limited by app.bodies.BodyLimit while it is read (413 beyond the limit)
    ctype = request.headers.get("content-type", "")
    body = await request.body()
    fields = dict(request.query_params)
    if ctype.startswith("multipart/form-data"):
        form = await read_multipart(request, body, limits.max_upload_bytes)
        files = [(f.filename, await f.read()) for f in form.getlist("file") if isinstance(f, UploadFile)]
        if len(files) != len(form.getlist("file")):
            raise FieldError("file", "must be a file part (a text field named 'file' was sent)")
        fields.update({k: v for k, v in form.multi_items() if k != "file" and isinstance(v, str)})
    elif ctype.startswith(RAW_FILE_TYPES):
        files = [(fields.get("filename") or "file 1", body)] if body else []
    else:
        raise FieldError("file", "send the bench files as multipart/form-data (field 'file', once per "
                                 "file) or one file as a text/plain body")
    return JSON(await run_in_threadpool(read_friction_files, files, fields, limits))


def _submit(jobs, kind, fn, memory):
    """Queue ``fn``; ``memory``: its estimate [bytes] (:func:`app.services.identify_memory`),
    with the request body's, waited for in the queue."""
    try:
        job = jobs.submit(kind, fn, memory=job_estimate(memory))
    except RuntimeError as exc:
        raise HTTPException(429, str(exc)) from None
    return job.to_dict(with_result=False)


@jobs_router.post("/valve", status_code=202, response_model=JobResponse,
                  summary="The valve bench as a job (progress and result at GET /api/jobs/{id})")
def identify_valve_job(req: ValveIdentifyRequest, jobs: JobsDep, limits: LimitsDep):
    checked = check_identify_valve(req)      # bad input is a 422 now, not a failed job later
    return _submit(jobs, "identify-valve",
                   lambda job: run_identify_valve(req, progress=job.report, checked=checked),
                   identify_memory("valve", checked, limits))


@jobs_router.post("/friction", status_code=202, response_model=JobResponse,
                  summary="The friction bench as a job (progress and result at GET /api/jobs/{id})")
def identify_friction_job(req: FrictionIdentifyRequest, jobs: JobsDep, store: StoreDep,
                          limits: LimitsDep):
    checked = check_identify_friction(req, store)
    return _submit(jobs, "identify-friction",
                   lambda job: run_identify_friction(req, progress=job.report, checked=checked),
                   identify_memory("friction", checked, limits))
