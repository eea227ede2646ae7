"""One source for each fact: the API's input schemas against the pneucore dataclasses.

Every ``*In`` schema of :mod:`app.schemas` either mirrors a pneucore object
(listed in MIRRORS) or is API-only (listed in API_ONLY); a new schema must be
placed in one of them. For every field a schema shares with its pneucore
object, the default must be the same and, where both descriptions state a
unit ``[...]``, the unit too.
"""
from __future__ import annotations

import inspect
import re

import pytest
from pydantic import BaseModel

from app import schemas
from app.config import Limits
from app.deps import parse_model, parse_scenario
from pneucore.physics.heat import HEAT_PARAMETERS
from pneucore.description.docstrings import api_description, field_docs
from pneucore.description.model import FrictionSet, Gas, Jack, Model, PortTable, Source, Valve
from pneucore.description.scenario import Initial, Scenario, Solver

# the pneucore object a schema mirrors (a default instance; required fields given)
MIRRORS = {
    "JackIn": Jack(),
    "PortTableIn": PortTable([0.0, 1.0], [0.0, 1e-8], [0.3, 0.3]),
    "ValveIn": Valve(),
    "SourceIn": Source(7e5),
    "HeatIn": Model().heat,
    "FrictionSetIn": FrictionSet(),
    "FrictionIn": Model().friction,
    "GasIn": Gas(),
    "ModelIn": Model(),
    "InitialIn": Initial(),
    "SolverIn": Solver(),
    "ScenarioIn": Scenario(),
}
# schemas of API requests with no pneucore dataclass behind them
API_ONLY = {"MeasurementIn", "ExperimentIn", "DatasetJsonIn"}

_UNIT = re.compile(r"\[([^\[\]]*)\]\s*$")


def _in_schemas():
    return sorted(n for n, c in vars(schemas).items()
                  if n.endswith("In") and inspect.isclass(c) and issubclass(c, BaseModel))


def _unit(text):
    m = _UNIT.search((text or "").strip())
    return None if m is None else m.group(1).replace(" ", "")


def _doc_units(obj):
    """``field -> unit`` from the numpydoc Parameters section of ``obj``'s class docstring."""
    return {name: _unit(text) for name, text in field_docs(type(obj)).items()}


def _plain(value):
    if isinstance(value, BaseModel):
        return value.model_dump(exclude_none=True)
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value


def _lib_plain(value):
    if hasattr(value, "to_dict"):
        return {k: v for k, v in value.to_dict().items() if v is not None}
    return value


def test_every_in_schema_is_classified():
    names = set(_in_schemas())
    assert names <= set(MIRRORS) | API_ONLY, \
        f"new input schemas {sorted(names - set(MIRRORS) - API_ONLY)}: add them to MIRRORS or API_ONLY"
    assert set(MIRRORS) <= names


def _mirrored_fields():
    for cls_name, obj in MIRRORS.items():
        cls = getattr(schemas, cls_name)
        for fname, info in cls.model_fields.items():
            if hasattr(obj, fname):
                yield pytest.param(cls_name, fname, id=f"{cls_name}.{fname}")


@pytest.mark.parametrize("cls_name,fname", list(_mirrored_fields()))
def test_schema_default_is_the_dataclass_default(cls_name, fname):
    obj = MIRRORS[cls_name]
    info = getattr(schemas, cls_name).model_fields[fname]
    if info.is_required():
        return            # no default to compare (ports, pressure, the tables)
    api = info.get_default(call_default_factory=True)
    lib = getattr(obj, fname)
    if cls_name == "HeatIn" and fname in HEAT_PARAMETERS and fname not in ("model", "coefficient"):
        # a parameter of another heat model: null = not given, its registry default applies
        # (a value would be refused for a model that has no such parameter)
        p = HEAT_PARAMETERS[fname]
        assert api is None and lib == p.default
        assert info.description == f"{p.description} [{p.unit}]"
        return
    if api is None and lib is not None:
        # null = "the library's default object": the nested schema's own defaults must equal it
        nested = [a for a in getattr(info.annotation, "__args__", ())
                  if inspect.isclass(a) and issubclass(a, BaseModel)]
        assert nested, f"{cls_name}.{fname}: null default where pneucore has {lib!r}"
        api = nested[0]()
    if isinstance(api, BaseModel) and _plain(api) != _lib_plain(lib):
        # a null inside means "as another field" (friction.retract = extend): what the library
        # builds from the schema's default is what counts
        assert type(lib).from_dict(_plain(api)) == lib, f"{cls_name}.{fname}: {api!r} vs {lib!r}"
        return
    assert _plain(api) == _lib_plain(lib), f"{cls_name}.{fname}: API {api!r} vs pneucore {lib!r}"


@pytest.mark.parametrize("cls_name,fname", list(_mirrored_fields()))
def test_schema_unit_is_the_dataclass_unit(cls_name, fname):
    lib_unit = _doc_units(MIRRORS[cls_name]).get(fname)
    api_unit = _unit(getattr(schemas, cls_name).model_fields[fname].description)
    if lib_unit is None or api_unit is None:
        return            # only one side states a unit
    assert api_unit == lib_unit, f"{cls_name}.{fname}: API [{api_unit}] vs pneucore [{lib_unit}]"


@pytest.mark.parametrize("cls_name,fname", list(_mirrored_fields()))
def test_schema_description_is_the_dataclass_docstring(cls_name, fname):
    """Descriptions live once, in the dataclass docstring: the schema's is derived from it
    (a registered heat parameter's comes from its registry entry, checked above)."""
    if cls_name == "HeatIn" and fname in HEAT_PARAMETERS and fname not in ("model", "coefficient"):
        return
    api = getattr(schemas, cls_name).model_fields[fname].description
    assert api == api_description(type(MIRRORS[cls_name]), fname)
    assert "None" not in api and "``" not in api and ":class:" not in api


def test_every_mirrored_dataclass_field_is_documented():
    missing = [f"{type(obj).__name__}.{f}" for obj in MIRRORS.values()
               for f in getattr(type(obj), "__dataclass_fields__", {})
               if f not in field_docs(type(obj))]
    assert not missing, missing


def test_the_unit_reader_reads_both_docstring_forms():
    # guards the test above against comparing nothing
    assert _doc_units(Solver())["max_step"] == "s"
    assert _doc_units(Jack())["dead_volume_a"] == "m^3"
    assert _doc_units(FrictionSet())["kv_b"] == "Ns/(mPa)"
    compared = sum(1 for p in _mirrored_fields()
                   if _doc_units(MIRRORS[p.values[0]]).get(p.values[1]) is not None)
    assert compared >= 20


def test_the_same_json_gives_the_same_scenario_through_the_api_and_the_library():
    """A request that gives part of the solver settings gets the library's defaults for the
    rest (the API once used max_step 0.02 s where the library uses 0.05 s)."""
    model_d = {"jack": {}, "valve": {"ports": {
        k: {"opening": [-1.0, 1.0], "C": [0.0, 1e-8], "b": [0.3, 0.3]}
        for k in ("P-A", "A-R", "P-B", "B-R")}}}
    for scen_d in ({}, {"solver": {"rtol": 1e-6}}, {"solver": {}, "x0": 0.1},
                   {"command": [[0.0, 0.5]], "locked": True}):
        model = parse_model(schemas.ModelIn(**model_d))
        api = parse_scenario(schemas.ScenarioIn(**scen_d), model, Limits(max_workers=1))
        lib = Scenario.from_dict(scen_d, Model.from_dict(model_d))
        api_d, lib_d = api.to_dict(), lib.to_dict()
        # the API's step budget is a Limit (app/config.py), not a default of its own
        assert api_d["solver"].pop("max_steps") == min(lib_d["solver"].pop("max_steps"),
                                                       Limits.max_steps)
        assert api_d == lib_d, scen_d


def test_the_api_choices_are_the_pneucore_registries():
    from typing import get_args

    from pneucore.description.model import VALVE_KINDS
    from pneucore.description.scenario import COMMAND_INTERPOLATIONS
    from pneucore.study.definition import DISTRIBUTIONS
    assert get_args(schemas.ValveIn.model_fields["kind"].annotation) == tuple(VALVE_KINDS)
    assert get_args(schemas.ScenarioIn.model_fields["command_interpolation"].annotation) \
        == tuple(COMMAND_INTERPOLATIONS)
    described = schemas.StudyRequest.model_fields["parameters"].description
    for name, dist in DISTRIBUTIONS.items():
        assert f"{name}: {', '.join(dist.required + dist.optional)}" in described
