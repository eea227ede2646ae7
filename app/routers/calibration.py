"""POST /api/calibrate/parameters: what can be fitted on a model, with the default bounds."""
from fastapi import APIRouter
from pydantic import Field

from pneucore.calibration_options import calibration_options

from ..deps import parse_model
from ..schemas import CalibrationOption, ModelIn, _Strict

router = APIRouter(prefix="/api/calibrate", tags=["analysis"])


class ParametersRequest(_Strict):
    model: ModelIn = Field(..., description="The model to fit")


@router.post("/parameters", response_model=list[CalibrationOption],
             summary="Parameters that can be fitted, with value, unit and default bounds")
def parameters(req: ParametersRequest):
    return calibration_options(parse_model(req.model))
