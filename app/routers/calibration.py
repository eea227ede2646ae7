"""POST /api/calibrate/parameters: what can be fitted on a model, with the default bounds."""
from fastapi import APIRouter

from ..bodies import OffLoopRoute
from ..schemas import CalibrationOption, CalibrationParametersRequest
from ..services import calibration_parameters

router = APIRouter(prefix="/api/calibrate", tags=["analysis"], route_class=OffLoopRoute)


@router.post("/parameters", response_model=list[CalibrationOption],
             summary="Parameters that can be fitted, with value, unit and default bounds")
def parameters(req: CalibrationParametersRequest):
    return calibration_parameters(req)
