"""Robustness studies: sweeps and Monte Carlo on the local pool or a Dask cluster, as jobs.

Runs stream into the service's SQLite file; an interrupted study (server
restarted, worker killed) resumes without recomputing finished runs. The work is
in :mod:`app.services` (queue_new_study, start_study, ...); ``start_study`` is named
here too, for :mod:`app.main`'s start-up recovery.
"""
from fastapi import APIRouter, HTTPException, Request
from fastapi.responses import Response, StreamingResponse

from ..bodies import OffLoopRoute
from ..deps import JobsDep, LimitsDep, not_found
from ..responses import JSON, NPZ_MEDIA_TYPE, npz_response
from ..schemas import ClusterInfo, StudyRequest, StudyResultsResponse, StudyStarted, StudyStatus
from ..services import (QueueFull, discard_study, list_stored_studies, queue_new_study, start_study,
                        study_clusters, study_exists, study_progress, study_runs_csv, study_runs_npz,
                        study_state_from_job, study_summary)

router = APIRouter(prefix="/api/studies", tags=["studies"], route_class=OffLoopRoute)


def _db(request: Request):
    return request.app.state.settings.db_path


@router.post("", status_code=202, summary="Start a robustness study (a job); returns its id",
             response_class=JSON, response_model=StudyStarted)
def create_study(req: StudyRequest, request: Request, limits: LimitsDep):
    try:
        started = queue_new_study(req, request.app.state, limits)
    except QueueFull as exc:
        raise HTTPException(429, str(exc)) from None
    return JSON(started, status_code=202)


@router.get("/clusters", summary="Where studies can run: the cluster names a request may give",
            response_model=list[ClusterInfo], response_model_exclude_unset=True)
def get_clusters(request: Request, limits: LimitsDep):
    return study_clusters(request.app.state.settings, limits)


@router.get("", summary="List stored studies", response_model=list[StudyStatus], response_model_exclude_unset=True)
def get_studies(request: Request, jobs: JobsDep):
    return [study_state_from_job(s, jobs.latest_for_study(s["id"]), _db(request))
            for s in list_stored_studies(_db(request))]


@router.get("/{study_id}", summary="Study progress: runs stored, failed, fraction, the job's state",
            response_model=StudyStatus, response_model_exclude_unset=True)
def get_study(study_id: str, request: Request, jobs: JobsDep):
    # the job first, then the study's row: a study job writes the row's status before its own
    # (pneucore.study.execute, then app.jobs), so a job read as done has a row that reads done;
    # read the other way round, a poll between the two writes saw the row still running and
    # the job done ("... no job of this server runs it", a page test failing under load)
    job = jobs.latest_for_study(study_id)
    job_state = job.to_dict(with_result=False) if job is not None else None
    st = study_progress(_db(request), study_id)
    if st is None:
        raise not_found("study", study_id)
    if job is not None:
        study_state_from_job(st, job, _db(request))
        st["job"] = job_state
    return st


@router.get("/{study_id}/results", summary="Distributions, percentiles, sensitivity ranking, raw runs",
            response_class=JSON, response_model=StudyResultsResponse)
def get_results(study_id: str, request: Request, runs: bool = True):
    out = study_summary(_db(request), study_id, include_runs=runs)
    if out is None:
        raise not_found("study", study_id)
    return JSON(out)


@router.get("/{study_id}/runs.csv", summary="Every stored run as CSV: parameters and metrics, "
                                             "units in the headers (SI)",
            response_class=StreamingResponse,
            responses={200: {"content": {"text/csv": {}}, "description": "CSV text"}})
def get_runs_csv(study_id: str, request: Request):
    chunks = study_runs_csv(_db(request), study_id)
    if chunks is None:
        raise not_found("study", study_id)
    return StreamingResponse(chunks, media_type="text/csv; charset=utf-8",
                             headers={"Content-Disposition": f'attachment; filename="study-{_safe_name(study_id)}-runs.csv"'})


def _safe_name(study_id):
    """A study id as a file name: letters, digits, ``-_.`` (64 at most)."""
    return "".join(c for c in study_id if c.isalnum() or c in "-_.")[:64] or "study"


@router.get("/{study_id}/runs.npz", summary="Every stored run as a NumPy .npz archive: parameter "
                                             "and metric matrices, their names and units (SI)",
            response_class=Response,
            responses={200: {"content": {NPZ_MEDIA_TYPE: {"schema": {"type": "string", "format": "binary"}}},
                             "description": "run_index (n), params (n x k) with param_paths and "
                                            "param_units, metrics (n x m) with metric_names and "
                                            "metric_units (NaN: undefined or failed), failed_index "
                                            "and failed_error; numpy.load reads it, no pickle"}})
def get_runs_npz(study_id: str, request: Request):
    data = study_runs_npz(_db(request), study_id)
    if data is None:
        raise not_found("study", study_id)
    return npz_response(data, f"study-{_safe_name(study_id)}-runs.npz")


@router.post("/{study_id}/resume", status_code=202, summary="Resume an interrupted study",
             response_class=JSON, response_model=StudyStarted)
def resume_study(study_id: str, request: Request, jobs: JobsDep, limits: LimitsDep):
    if not study_exists(_db(request), study_id):
        raise not_found("study", study_id)
    job = jobs.latest_for_study(study_id)
    if job is not None and job.status in ("queued", "running"):
        raise HTTPException(409, f"study {study_id} is already {job.status} (job {job.id})")
    try:
        job = start_study(request.app.state, _db(request), study_id, time_limit=limits.study_time_limit)
    except QueueFull as exc:
        raise HTTPException(429, str(exc)) from None
    return JSON({"id": study_id, "job_id": job.id, "status": "queued"}, status_code=202)


@router.delete("/{study_id}", status_code=204, summary="Delete a study and its runs (stops it if running)")
def remove_study(study_id: str, request: Request, jobs: JobsDep):
    if not study_exists(_db(request), study_id):
        raise not_found("study", study_id)
    job = jobs.latest_for_study(study_id)
    discard_study(request.app.state, _db(request), study_id,
                  running=job is not None and job.status in ("queued", "running"))
