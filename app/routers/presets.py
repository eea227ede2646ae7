"""GET /api/presets, /api/presets/{name}: model and scenario presets as plain JSON."""
from typing import Any

from fastapi import APIRouter

from pneucore.spec.presets import MODEL_PRESETS, SCENARIO_PRESETS, model_preset, scenario_preset

from ..deps import not_found
from ..schemas import PresetList

router = APIRouter(prefix="/api/presets", tags=["presets"])


@router.get("", summary="List the model and scenario presets", response_model=PresetList)
def list_presets():
    return {"models": [{"name": k, "description": v.get("description", "")} for k, v in MODEL_PRESETS.items()],
            "scenarios": [{"name": k, "description": v.get("description", "")}
                          for k, v in SCENARIO_PRESETS.items()]}


@router.get("/{name}", summary="A preset's JSON (model or scenario)", response_model=dict[str, Any],
            response_description="A ModelIn or a ScenarioIn, SI units, absolute pressures")
def get_preset(name: str):
    if name in MODEL_PRESETS:
        return model_preset(name)
    if name in SCENARIO_PRESETS:
        return scenario_preset(name)
    raise not_found("preset", name)
