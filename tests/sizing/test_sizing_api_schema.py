"""One source for the sizing API's fields: the schemas read their defaults and descriptions
(with units) from pneucore.sizing's dataclasses, and the API's choices are its registries."""
import dataclasses
import re

import pytest

from app.sizing_schemas import ChoicesSpec, RequirementSpec, SizingRequest
from pneucore.sizing import REASONS, Choices, Requirement
from pneucore.description.docstrings import api_description, field_docs

PAIRS = [(RequirementSpec, Requirement), (ChoicesSpec, Choices)]


@pytest.mark.parametrize("schema,cls", PAIRS, ids=lambda x: x.__name__)
def test_every_dataclass_field_is_in_the_schema_with_its_docstring(schema, cls):
    names = [f.name for f in dataclasses.fields(cls)]
    assert set(schema.model_fields) == set(names)
    for name in names:
        info = schema.model_fields[name]
        assert info.description == api_description(cls, name)
        # every description ends in its unit
        assert re.search(r"\[[^\[\]]+\]$", field_docs(cls)[name]), (cls.__name__, name)


@pytest.mark.parametrize("schema,cls", PAIRS, ids=lambda x: x.__name__)
def test_the_schema_defaults_are_the_dataclass_defaults(schema, cls):
    lib = cls()
    for name, info in schema.model_fields.items():
        if info.is_required():
            assert name in Requirement.REQUIRED
            continue
        assert info.get_default(call_default_factory=True) == getattr(lib, name), name


def test_the_required_fields_are_the_library_ones():
    required = {n for n, i in RequirementSpec.model_fields.items() if i.is_required()}
    assert required == set(Requirement.REQUIRED)


def test_the_units_the_errors_state_are_the_docstring_units():
    assert Requirement.unit("stroke") == "m" and Requirement.unit("angle") == "deg"
    assert Requirement.unit("supply_pressure") == "Pa"
    assert Requirement.unit("max_end_speed") == "m/s"


def test_the_reasons_documented_are_the_registry():
    from app.sizing_schemas import InfeasibleOut
    desc = InfeasibleOut.model_fields["reason"].description
    for name, meaning in REASONS.items():
        assert f"{name}: {meaning}" in desc


def test_the_example_is_a_valid_request():
    ex = SizingRequest.model_json_schema()["examples"][0]
    req, choices = SizingRequest.model_validate(ex).plain()
    Requirement.from_dict(req)
    Choices.from_dict(choices)
