"""POST /api/reports/compare, /api/reports/diagnose, /api/reports/refine and
/api/reports/sessions/{id}: a self-contained HTML report to download."""
from fastapi import APIRouter, Path
from fastapi.responses import Response

from ..bodies import OffLoopRoute
from ..deps import LimitsDep, SettingsDep, StoreDep, not_found
from ..sync_pool import sync_slot
from ..schemas import CompareRequest, DiagnoseReportRequest, RefineRequest
from ..services import (comparison_report, deadline_progress, diagnosis_report, refinement_report,
                        session_report)

router = APIRouter(prefix="/api/reports", tags=["reports"], route_class=OffLoopRoute)

_HTML = {200: {"content": {"text/html": {"schema": {
    "type": "string", "description": "One HTML file that opens offline: inline SVG plots, tables "
                                     "(errors in percent), the model as JSON, the data provenance"}}}}}


def _html(text, filename):
    return Response(text, media_type="text/html; charset=utf-8",
                    headers={"Content-Disposition": f'attachment; filename="{filename}"'})


@router.post("/compare", dependencies=[sync_slot("/api/jobs/compare")],
             response_class=Response, responses=_HTML,
             summary="HTML report of a comparison (plots, errors, windows, model, provenance)")
def compare_report(req: CompareRequest, store: StoreDep, limits: LimitsDep):
    progress = deadline_progress(limits, "comparison", "/api/jobs/compare")
    return _html(comparison_report(req, store, limits, progress=progress), "comparison-report.html")


@router.post("/diagnose", dependencies=[sync_slot("/api/jobs/diagnose")],
             response_class=Response, responses=_HTML,
             summary="HTML report of a diagnosis (verdict, ranking, residual tests, plots, model)")
def diagnose_report(req: DiagnoseReportRequest, store: StoreDep, limits: LimitsDep,
                    settings: SettingsDep):
    progress = deadline_progress(limits, "diagnosis", "/api/jobs/diagnose")
    return _html(diagnosis_report(req, store, limits, progress=progress, settings=settings),
                 "diagnosis-report.html")


@router.post("/refine", dependencies=[sync_slot("/api/jobs/refine")],
             response_class=Response, responses=_HTML,
             summary="HTML report of a whole refinement (every version and round, the refined "
                     "model against the data, the model)")
def refine_report(req: RefineRequest, store: StoreDep, limits: LimitsDep, settings: SettingsDep):
    progress = deadline_progress(limits, "refinement", "/api/jobs/refine")
    return _html(refinement_report(req, store, limits, progress=progress, settings=settings),
                 "refinement-report.html")



@router.post("/sessions/{session_id}", dependencies=[sync_slot("/api/jobs/compare")],
             response_class=Response, responses=_HTML,
             summary="HTML report of a stored refinement session as recorded (every version with its "
                     "errors and the values it changed, the last model against the data, the model)")
def report_session(store: StoreDep, limits: LimitsDep,
                   session_id: str = Path(..., max_length=64, pattern=r"^[A-Za-z0-9_-]+$",
                                          description="A stored session's id (GET /api/sessions) [-]")):
    progress = deadline_progress(limits, "comparison", "/api/jobs/compare")
    text = session_report(session_id, store, limits, progress=progress)
    if text is None:
        raise not_found("session", session_id)
    return _html(text, "session-report.html")
