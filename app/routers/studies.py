"""Robustness studies: sweeps and Monte Carlo on the local pool or a Dask cluster, as jobs.

Runs stream into the service's SQLite file; an interrupted study (server
restarted, worker killed) resumes without recomputing finished runs.
"""
import uuid

from fastapi import APIRouter, Request

from pneucore.study import Study, connect_scheduler, list_studies, study_results, study_status
from pneucore.study import delete_study, run_study
from pneucore.validation import FieldError

from ..deps import JobsDep, LimitsDep, not_found, parse_model, parse_scenario
from ..responses import JSON
from ..schemas import StudyRequest

router = APIRouter(prefix="/api/studies", tags=["studies"])


def _db(request: Request):
    return request.app.state.settings.db_path


def _exists(request, sid):
    return any(s["id"] == sid for s in list_studies(_db(request)))


def start_study(jobs, db_path, sid, study=None, scheduler=None, workers=None, time_limit=None):
    """Queue ``run_study`` as a job (used by POST, resume and the start-up recovery)."""
    def run(job):
        return run_study(study, store_path=db_path, scheduler=scheduler, workers=workers,
                         progress=job.report, study_id=sid)
    job = jobs.submit("study", run, time_limit=time_limit)
    job.study_id = sid
    return job


@router.post("", status_code=202, summary="Start a robustness study (a job); returns its id",
             response_class=JSON)
def create_study(req: StudyRequest, request: Request, jobs: JobsDep, limits: LimitsDep):
    model = parse_model(req.model)
    parse_scenario(req.scenario, model, limits)
    d = {"model": model.to_dict(), "scenario": req.scenario.plain(), "parameters": req.parameters,
         "samples": req.samples, "seed": req.seed, "metrics": req.metrics}
    study = Study.from_dict(d)
    if study.n_runs > limits.max_study_runs:
        raise FieldError("samples", f"{study.n_runs} runs exceed the API limit of {limits.max_study_runs}")
    if req.scheduler:
        client, owned, _ = connect_scheduler(req.scheduler, timeout=limits.scheduler_timeout)
        if owned:
            client.close()
    sid = uuid.uuid4().hex[:12]
    job = start_study(jobs, _db(request), sid, study, req.scheduler, req.workers,
                      limits.study_time_limit)
    return JSON({"id": sid, "job_id": job.id, "n_runs": study.n_runs, "status": "queued"})


@router.get("", summary="List stored studies")
def get_studies(request: Request):
    return list_studies(_db(request))


@router.get("/{study_id}", summary="Study progress: runs stored, failed, fraction, the job's state")
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
            response_class=JSON)
def get_results(study_id: str, request: Request, runs: bool = True):
    try:
        return JSON(study_results(_db(request), study_id, include_runs=runs))
    except KeyError:
        raise not_found("study", study_id) from None


@router.post("/{study_id}/resume", status_code=202, summary="Resume an interrupted study",
             response_class=JSON)
def resume_study(study_id: str, request: Request, jobs: JobsDep, limits: LimitsDep):
    if not _exists(request, study_id):
        raise not_found("study", study_id)
    job = start_study(jobs, _db(request), study_id, time_limit=limits.study_time_limit)
    return JSON({"id": study_id, "job_id": job.id, "status": "queued"})


@router.delete("/{study_id}", status_code=204, summary="Delete a study and its runs")
def remove_study(study_id: str, request: Request):
    if not delete_study(_db(request), study_id):
        raise not_found("study", study_id)
