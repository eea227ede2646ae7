"""POST /api/friction/preview: a model's friction force map, computed by the simulator's law."""
from fastapi import APIRouter

from ..deps import parse_model
from ..responses import JSON
from ..schemas import FRICTION_DEFAULT_VELOCITIES, FrictionPreviewRequest, FrictionPreviewResponse
from ..services import friction_preview

router = APIRouter(prefix="/api/friction", tags=["model"])


@router.post("/preview", response_class=JSON, response_model=FrictionPreviewResponse,
             summary="Friction force against piston velocity at given chamber pressures (paper "
                     "Fig. 4), from the model's friction law with its friction effects")
def preview(req: FrictionPreviewRequest):
    model = parse_model(req.model)
    velocities = req.velocities if req.velocities is not None else FRICTION_DEFAULT_VELOCITIES
    return JSON(friction_preview(model, [(p.p_a, p.p_b) for p in req.pressures], velocities))
