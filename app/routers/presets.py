"""GET /api/presets, /api/presets/{name}: model and scenario presets as plain JSON."""
from typing import Any

from fastapi import APIRouter

from ..deps import not_found
from ..schemas import PresetList
from ..services import preset, preset_list

router = APIRouter(prefix="/api/presets", tags=["presets"])


@router.get("", summary="List the model and scenario presets", response_model=PresetList)
def list_presets():
    return preset_list()


@router.get("/{name}", summary="A preset's JSON (model or scenario)", response_model=dict[str, Any],
            response_description="A ModelIn or a ScenarioIn, SI units, absolute pressures")
def get_preset(name: str):
    out = preset(name)
    if out is None:
        raise not_found("preset", name)
    return out
