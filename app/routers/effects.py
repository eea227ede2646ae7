"""GET /api/effects: the effect catalog with parameters, units, bounds and descriptions."""
from fastapi import APIRouter

from ..schemas import EffectInfo
from ..services import effect_catalog

router = APIRouter(prefix="/api/effects", tags=["effects"])


@router.get("", summary="The catalog of switchable physical effects", response_model=list[EffectInfo])
def list_effects():
    return effect_catalog()
