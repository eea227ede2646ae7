"""POST /api/friction/preview: a model's friction force map, computed by the simulator's law."""
from fastapi import APIRouter

from ..bodies import OffLoopRoute
from ..responses import JSON
from ..schemas import FrictionPreviewRequest, FrictionPreviewResponse
from ..services import friction_map

router = APIRouter(prefix="/api/friction", tags=["model"], route_class=OffLoopRoute)


@router.post("/preview", response_class=JSON, response_model=FrictionPreviewResponse,
             summary="Friction force against piston velocity at given chamber pressures (paper "
                     "Fig. 4), from the model's friction law with its friction effects")
def preview(req: FrictionPreviewRequest):
    return JSON(friction_map(req))
