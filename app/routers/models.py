"""POST /api/models/diff: what changes from one model to another, parameter by parameter."""
from fastapi import APIRouter

from ..bodies import OffLoopRoute
from ..schemas import ModelChange, ModelDiffRequest
from ..services import model_diff

router = APIRouter(prefix="/api/models", tags=["models"], route_class=OffLoopRoute)


@router.post("/diff", response_model=list[ModelChange],
             summary="Every value that differs between two models (two versions of a session, a "
                     "catalogue model and a fitted one), with units")
def diff(req: ModelDiffRequest):
    return model_diff(req)
