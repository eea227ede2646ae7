"""POST /api/linearize: the actuator's state-space model at an operating point (issue 42,
item 5; :mod:`pneucore.control.linearize`). Closed-loop runs go through POST /api/simulate
with a scenario's ``controller``."""
from fastapi import APIRouter

from ..control_schemas import LinearizeRequest, LinearizeResponse
from ..responses import JSON
from ..services import controllers_answer, linearize_answer

router = APIRouter(prefix="/api", tags=["control"])


@router.post("/linearize", response_model=LinearizeResponse, response_class=JSON,
             summary="Linearise the actuator at an operating point (poles, natural frequency, A, B, C, D)")
def linearize_endpoint(req: LinearizeRequest):
    return JSON(linearize_answer(req))


@router.get("/controllers", response_class=JSON,
            summary="Controller kinds for a scenario's controller: gains (unit, default), valves")
def controllers_endpoint():
    return JSON(controllers_answer())
