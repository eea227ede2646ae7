"""GET /api/effects: the effect catalog with parameters, units, bounds and descriptions."""
from fastapi import APIRouter

from pneucore.spec.effects import EFFECTS

from ..schemas import EffectInfo

router = APIRouter(prefix="/api/effects", tags=["effects"])


@router.get("", summary="The catalog of switchable physical effects", response_model=list[EffectInfo])
def list_effects():
    return [e.to_dict() for e in EFFECTS.values()]
