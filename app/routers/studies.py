"""Robustness studies: sweeps and Monte Carlo on the local pool or a Dask cluster, as jobs.

Runs stream into the service's SQLite file; an interrupted study (server
restarted, worker killed) resumes without recomputing finished runs.
"""
from fastapi import APIRouter, HTTPException, Request
from fastapi.responses import StreamingResponse

from pneucore.progress import Cancelled
from pneucore.study import (Study, check_run_options, delete_study, list_studies, queue_study,
                            requeue_study, run_study, runs_csv, study_results, study_status)
from pneucore.spec.validation import FieldError

from ..bodies import OffLoopRoute
from ..config import STUDY_CLUSTERS
from ..deps import JobsDep, LimitsDep, not_found, parse_model, parse_scenario
from ..responses import JSON
from ..schemas import (ClusterInfo, StudyRequest, StudyResultsResponse, StudyStarted, StudyStatus)

router = APIRouter(prefix="/api/studies", tags=["studies"], route_class=OffLoopRoute)


def _db(request: Request):
    return request.app.state.settings.db_path


def _exists(request, sid):
    return any(s["id"] == sid for s in list_studies(_db(request)))


def configured_clusters(settings):
    """The cluster names a request may give, those of :data:`STUDY_CLUSTERS` configured here."""
    return [c for c in STUDY_CLUSTERS if c == "local" or (c == "dask" and settings.dask_scheduler)]


def cluster_address(settings, name=None):
    """The engine of cluster ``name`` for ``run_study``: ``"local"`` or the configured address.

    ``name`` None = the Dask cluster when one is configured, else the local pool. Any other
    name, an address above all, is refused (field ``scheduler``): the address comes from the
    server's configuration only, so no request makes the service connect anywhere.
    """
    names = configured_clusters(settings)
    if name is None:
        name = "dask" if "dask" in names else "local"
    if name not in names:
        shown = name if len(name) <= 64 else name[:61] + "..."
        raise FieldError("scheduler", f"unknown cluster {shown!r}: give one of {names} (a Dask "
                                      f"scheduler address is set on the server with "
                                      f"$PNEUCORE_DASK_SCHEDULER or --scheduler, never in a request)")
    return "local" if name == "local" else settings.dask_scheduler


def start_study(app_state, db_path, sid, scheduler=None, workers=None, time_limit=None):
    """Queue ``run_study`` for a stored study as a job (POST, resume, start-up recovery).

    ``scheduler`` is a cluster *name* (see :func:`cluster_address`; None = the default).
    A study deleted while it runs is stopped within a second and its runs removed; the
    time limit holds whether or not batches finish.
    """
    cancelled = app_state.cancelled_studies
    settings = app_state.settings
    address = cluster_address(settings, scheduler)
    limits = settings.limits

    def run(job):
        def progress(fraction, step):
            if sid in cancelled:
                raise Cancelled(f"study {sid} was deleted")
            job.report(fraction, step)
        try:
            return run_study(None, store_path=db_path, scheduler=address, workers=workers,
                             progress=progress, study_id=sid, time_limit=time_limit or limits.study_time_limit,
                             scheduler_timeout=limits.scheduler_timeout)
        finally:
            if sid in cancelled:
                delete_study(db_path, sid)
            elif app_state.jobs.stopping:
                # stopped by a shutdown: queued again, so the next start resumes it
                requeue_study(db_path, sid)
    try:
        job = app_state.jobs.submit("study", run, time_limit=time_limit)
    except RuntimeError as exc:
        raise HTTPException(429, str(exc)) from None
    job.study_id = sid
    return job


@router.post("", status_code=202, summary="Start a robustness study (a job); returns its id",
             response_class=JSON, response_model=StudyStarted)
def create_study(req: StudyRequest, request: Request, limits: LimitsDep):
    model = parse_model(req.model)
    parse_scenario(req.scenario, model, limits)
    # the validated Model itself: Study.from_dict takes it as it is (validated once, above)
    d = {"model": model, "scenario": req.scenario.plain(), "parameters": req.parameters,
         "samples": req.samples, "seed": req.seed, "metrics": req.metrics, "name": req.name}
    study = Study.from_dict(d)
    if study.n_runs > limits.max_study_runs:
        raise FieldError("samples", f"{study.n_runs} runs exceed the API limit of {limits.max_study_runs}")
    address = cluster_address(request.app.state.settings, req.scheduler)
    if req.workers is not None and not (0 <= req.workers <= limits.max_workers):
        raise FieldError("workers", f"must be a whole number in [0, {limits.max_workers}] (max_workers "
                                    f"of GET /api/limits: the CPUs available), got {req.workers}")
    check_run_options(workers=req.workers, scheduler=None if address == "local" else address)
    state = request.app.state
    if state.jobs.active() >= state.jobs.max_jobs:
        raise HTTPException(429, f"too many jobs queued or running (limit {state.jobs.max_jobs})")
    sid = queue_study(study, _db(request))   # the id exists in the store from now on
    job = start_study(state, _db(request), sid, req.scheduler, req.workers, limits.study_time_limit)
    return JSON({"id": sid, "job_id": job.id, "n_runs": study.n_runs, "status": "queued"},
                status_code=202)


@router.get("/clusters", summary="Where studies can run: the cluster names a request may give",
            response_model=list[ClusterInfo], response_model_exclude_unset=True)
def get_clusters(request: Request, limits: LimitsDep):
    settings = request.app.state.settings
    out = [{"name": "local", "kind": "local process pool", "max_workers": limits.max_workers,
            "default": settings.dask_scheduler is None}]
    if settings.dask_scheduler:
        out.append({"name": "dask", "kind": "dask.distributed cluster configured on the server",
                    "default": True})
    return out


@router.get("", summary="List stored studies", response_model=list[StudyStatus], response_model_exclude_unset=True)
def get_studies(request: Request):
    return list_studies(_db(request))


@router.get("/{study_id}", summary="Study progress: runs stored, failed, fraction, the job's state",
            response_model=StudyStatus, response_model_exclude_unset=True)
def get_study(study_id: str, request: Request, jobs: JobsDep):
    try:
        st = study_status(_db(request), study_id)
    except KeyError:
        raise not_found("study", study_id) from None
    job = jobs.latest_for_study(study_id)
    if job is not None:
        st["job"] = job.to_dict(with_result=False)
    return st


@router.get("/{study_id}/results", summary="Distributions, percentiles, sensitivity ranking, raw runs",
            response_class=JSON, response_model=StudyResultsResponse)
def get_results(study_id: str, request: Request, runs: bool = True):
    try:
        return JSON(study_results(_db(request), study_id, include_runs=runs))
    except KeyError:
        raise not_found("study", study_id) from None


@router.get("/{study_id}/runs.csv", summary="Every stored run as CSV: parameters and metrics, "
                                             "units in the headers (SI)",
            response_class=StreamingResponse,
            responses={200: {"content": {"text/csv": {}}, "description": "CSV text"}})
def get_runs_csv(study_id: str, request: Request):
    try:
        chunks = runs_csv(_db(request), study_id)
    except KeyError:
        raise not_found("study", study_id) from None
    safe = "".join(c for c in study_id if c.isalnum() or c in "-_.")[:64] or "study"
    return StreamingResponse(chunks, media_type="text/csv; charset=utf-8",
                             headers={"Content-Disposition": f'attachment; filename="study-{safe}-runs.csv"'})


@router.post("/{study_id}/resume", status_code=202, summary="Resume an interrupted study",
             response_class=JSON, response_model=StudyStarted)
def resume_study(study_id: str, request: Request, jobs: JobsDep, limits: LimitsDep):
    if not _exists(request, study_id):
        raise not_found("study", study_id)
    job = jobs.latest_for_study(study_id)
    if job is not None and job.status in ("queued", "running"):
        raise HTTPException(409, f"study {study_id} is already {job.status} (job {job.id})")
    job = start_study(request.app.state, _db(request), study_id, time_limit=limits.study_time_limit)
    return JSON({"id": study_id, "job_id": job.id, "status": "queued"}, status_code=202)


@router.delete("/{study_id}", status_code=204, summary="Delete a study and its runs (stops it if running)")
def remove_study(study_id: str, request: Request, jobs: JobsDep):
    if not _exists(request, study_id):
        raise not_found("study", study_id)
    job = jobs.latest_for_study(study_id)
    if job is not None and job.status in ("queued", "running"):
        request.app.state.cancelled_studies.add(study_id)
    delete_study(_db(request), study_id)
