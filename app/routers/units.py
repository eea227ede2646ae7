"""GET /api/units: the page's display unit systems, the SI unit of every model and scenario field,
and of every model parameter path (:mod:`pneucore.description.paths`)."""
import re

from fastapi import APIRouter
from pydantic import BaseModel, Field

from .. import schemas
from ..services import display_units

router = APIRouter(prefix="/api", tags=["meta"])

_UNIT_RE = re.compile(r"\[([^\[\]]+)\]\s*$")


def _fields(cls, prefix, out):
    """Walk a request schema: the unit in brackets that ends each field's description."""
    for name, f in cls.model_fields.items():
        path = f"{prefix}.{name}"
        ann = f.annotation
        sub = next((a for a in getattr(ann, "__args__", (ann,)) if isinstance(a, type)
                    and issubclass(a, BaseModel)), None)
        if sub is not None:
            _fields(sub, path, out)
            continue
        m = _UNIT_RE.search(f.description or "")
        if m:
            out[path] = m.group(1)
    return out


class UnitsResponse(BaseModel):
    systems: dict = Field(..., description="Display systems: {name: {label, units: {SI unit: {unit, scale, offset}}}}; display = (SI - offset) / scale, offset 'gauge' = the model's ambient pressure")
    fields: dict[str, str] = Field(..., description="SI unit of each model and scenario field, from the schemas' descriptions")
    parameters: dict[str, str] = Field(..., description="SI unit of each model parameter path (calibration, studies, diagnosis: jack.bore, friction.extend.fc0, effects.<effect>.<parameter>, valve.ports.*.C for any edge), from pneucore.description.paths.unit_of")
    stroke: dict[str, dict] = Field(..., description="Unit and definition of each per-stroke metric of a simulation's stats.stroke.strokes: {name: {unit, description}}, from pneucore.analysis.strokes.STROKE_FIELDS (SMC's definitions)")


@router.get("/units", response_model=UnitsResponse, summary="Display unit systems and the SI unit of every field")
def units():
    fields = {}
    _fields(schemas.ModelIn, "model", fields)
    _fields(schemas.ScenarioIn, "scenario", fields)
    fields["upload.x0"] = "m"
    fields["upload.ambient_pressure"] = "Pa"
    tables = display_units()
    return {"systems": tables["systems"], "fields": fields, "parameters": tables["parameters"],
            "stroke": tables["stroke"]}
