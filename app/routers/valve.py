"""POST /api/valve/convert: valve data as catalogues give them (nominal flow Qn, effective
area, Cv, Kv, one flow point) converted to the model's sonic conductance C and critical ratio b
(issue 23, item 7; :mod:`pneucore.description.valve_data`)."""
from fastapi import APIRouter

from ..bodies import OffLoopRoute
from ..services import catalogue_valve, convert_valve
from ..valve_schemas import (CATALOGUE_SUMMARY, SUMMARY, CatalogueValveRequest,
                             CatalogueValveResponse, ValveConvertRequest, ValveConvertResponse)

router = APIRouter(prefix="/api", tags=["valve"], route_class=OffLoopRoute)


@router.post("/valve/convert", response_model=ValveConvertResponse, summary=SUMMARY)
def valve_convert(req: ValveConvertRequest):
    return convert_valve(req)


@router.post("/valve/catalogue", response_model=CatalogueValveResponse, summary=CATALOGUE_SUMMARY)
def valve_catalogue(req: CatalogueValveRequest):
    return catalogue_valve(req)
