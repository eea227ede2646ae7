"""POST /api/reports/compare and /api/reports/diagnose: a self-contained HTML report to download."""
from fastapi import APIRouter
from fastapi.responses import Response

from pneucore.analysis.compare import compare
from pneucore.analysis.diagnose import diagnose
from pneucore.spec.model import Model
from pneucore.analysis.report import comparison_report, diagnosis_report

from ..deps import LimitsDep, StoreDep
from ..schemas import CompareRequest, DiagnoseRequest
from ..services import check_compare, check_diagnose, deadline_progress

router = APIRouter(prefix="/api/reports", tags=["reports"])

_HTML = {200: {"content": {"text/html": {"schema": {
    "type": "string", "description": "One HTML file that opens offline: inline SVG plots, tables "
                                     "(errors in percent), the model as JSON, the data provenance"}}}}}


def _html(text, filename):
    return Response(text, media_type="text/html; charset=utf-8",
                    headers={"Content-Disposition": f'attachment; filename="{filename}"'})


def _provenance(store, exps):
    return [{"dataset_id": e.dataset_id, **(store.dataset_info(e.dataset_id) or {})}
            for e in exps if e.dataset_id]


@router.post("/compare", response_class=Response, responses=_HTML,
             summary="HTML report of a comparison (plots, errors, windows, model, provenance)")
def compare_report(req: CompareRequest, store: StoreDep, limits: LimitsDep):
    model, exps = check_compare(req, store, limits)
    c = compare(model, exps, progress=deadline_progress(limits, "comparison", "/api/jobs/compare"))
    return _html(comparison_report(model, c, _provenance(store, exps)), "comparison-report.html")


@router.post("/diagnose", response_class=Response, responses=_HTML,
             summary="HTML report of a diagnosis (verdict, ranking, residual tests, plots, model)")
def diagnose_report(req: DiagnoseRequest, store: StoreDep, limits: LimitsDep):
    model, exps = check_diagnose(req, store, limits)
    progress = deadline_progress(limits, "diagnosis", "/api/jobs/diagnose")
    d = diagnose(model, exps, candidates=req.candidates, uncertain=req.uncertain,
                 progress=progress, validated=True).to_dict()
    c = compare(model, exps)
    refined = None
    best = next((r for r in d.get("ranking", []) if r.get("effect") == d.get("verdict")), None)
    if best is not None and best.get("model"):
        refined = compare(Model.from_dict(best["model"]), exps)
    return _html(diagnosis_report(model, d, c, _provenance(store, exps), refined),
                 "diagnosis-report.html")
