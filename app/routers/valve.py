"""POST /api/valve/convert: valve data as catalogues give them (nominal flow Qn, effective
area, one flow point) converted to the model's sonic conductance C and critical ratio b
(:mod:`pneucore.spec.valve_data`; issue 23, item 7)."""
from typing import Optional

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field, create_model

from pneucore.spec.valve_data import CONVERSIONS, FIELDS, convert_valve_data

router = APIRouter(prefix="/api", tags=["valve"])

#: The request: every field of the library's registry, its unit and description from there
ValveConvertRequest = create_model(
    "ValveConvertRequest", __config__=ConfigDict(extra="forbid"),
    **{name: (Optional[float], Field(default, description=f"{text}; "
                                     + ("required by " + ", ".join(
                                         c for c, conv in CONVERSIONS.items()
                                         if name in conv.fields) if default is None
                                        else f"default {default:g}") + f" [{u}]"))
       for name, (u, text, _, default) in FIELDS.items()})


class ValveConvertResponse(BaseModel):
    C: float = Field(..., description="Sonic conductance, as the model's valve edges take it "
                                      "(valve.ports.*.C) [m^3/(s Pa)]")
    b: float = Field(..., description="Critical pressure ratio (the catalogue's, as given) [-]")
    conversion: str = Field(..., description="The conversion used: "
                                             + ", ".join(sorted(CONVERSIONS)) + " [-]")
    source: str = Field(..., description="The law used and its source")
    units: dict[str, str] = Field(..., description="Unit of each number of the answer")


@router.post("/valve/convert", response_model=ValveConvertResponse,
             summary="Valve data as catalogues give them (Qn, effective area, a flow point) "
                     "to the model's C and b; exactly one of " + ", ".join(sorted(CONVERSIONS)))
def valve_convert(req: ValveConvertRequest):
    return convert_valve_data(req.model_dump(exclude_unset=True), path="body")
