"""Schemas of POST /api/valve/convert: the request and the answer, from the library's registry
(:mod:`pneucore.description.valve_data`)."""
from typing import Optional

from pydantic import BaseModel, ConfigDict, Field, create_model

from typing import Any

from pneucore.description.valve_data import CATALOGUE_FIELDS, CATALOGUE_VALVES, C_UNIT, CONVERSIONS, FIELDS


def _description(name, text, unit, default):
    readers = ", ".join(c for c, conv in CONVERSIONS.items() if name in conv.fields)
    need = f"required by {readers}" if default is None else f"read by {readers}, default {default:g}"
    return f"{text}; {need} [{unit}]"


#: The request: every field of the library's registry, its unit and description from there
ValveConvertRequest = create_model(
    "ValveConvertRequest", __config__=ConfigDict(extra="forbid"),
    **{name: (Optional[float], Field(default, description=_description(name, text, u, default)))
       for name, (u, text, _, default) in FIELDS.items()})


class ValveConvertResponse(BaseModel):
    C: float = Field(..., description="Sonic conductance, as the model's valve edges take it "
                                      f"(valve.ports.*.C) [{C_UNIT}]")
    b: float = Field(..., description="Critical pressure ratio (the catalogue's, as given) [-]")
    conversion: str = Field(..., description="The conversion used: "
                                             + ", ".join(sorted(CONVERSIONS)) + " [-]")
    source: str = Field(..., description="The law used and its source")
    units: dict[str, str] = Field(..., description="Unit of each number of the answer")


#: The route's summary
SUMMARY = ("Valve data as catalogues give them (Qn, effective area, Cv, Kv, a flow point) to the "
           "model's C and b; exactly one of " + ", ".join(sorted(CONVERSIONS)))



class CatalogueValveRequest(BaseModel):
    """An on/off valve as its catalogue gives it (:func:`pneucore.description.valve_data.catalogue_valve`)."""
    model_config = ConfigDict(extra="forbid")
    function: str = Field(..., description=CATALOGUE_FIELDS["function"][1] + " [-]")
    supply: dict[str, Any] = Field(..., description=CATALOGUE_FIELDS["supply"][1])
    exhaust: Optional[dict[str, Any]] = Field(None, description=CATALOGUE_FIELDS["exhaust"][1])
    on_time: float = Field(0.0, description=CATALOGUE_FIELDS["on_time"][1] + " [s]")
    off_time: float = Field(0.0, description=CATALOGUE_FIELDS["off_time"][1] + " [s]")
    bistable: bool = Field(False, description=CATALOGUE_FIELDS["bistable"][1] + " [-]")


class CatalogueValveResponse(BaseModel):
    valve: dict[str, Any] = Field(..., description="The model's valve (model.valve): edge tables "
                                                   f"(C [{C_UNIT}], b [-] over the opening [-]), "
                                                   "on_time, off_time [s], rest_opening [-]")
    description: str = Field(..., description="The valve function in words")
    functions: dict[str, str] = Field(..., description="Every function offered, in words")


CATALOGUE_SUMMARY = ("An on/off valve from catalogue figures: function (" + ", ".join(CATALOGUE_VALVES)
                     + "), flow (C and b, Qn, Cv, Kv or effective area), switching times")
