"""Valve edge groups as parameter paths (supply edges ``P-*``, exhaust edges ``*-R``)."""
import pytest

from pneucore import model_preset
from pneucore.description.model import Model
from pneucore.description.paths import VALVE_GROUPS, get_value, parse_parameters, set_values
from pneucore.description.validation import FieldError


@pytest.mark.parametrize("kind, group, edges", [
    ("paper-4way", "supply", {"P-A", "P-B"}), ("paper-4way", "exhaust", {"A-R", "B-R"}),
    ("paper-3way", "supply", {"P-A"}), ("paper-3way", "exhaust", {"A-R"})])
def test_a_group_path_scales_exactly_its_edges(kind, group, edges):
    m = Model.from_dict(model_preset(kind))
    path = f"valve.ports.{VALVE_GROUPS[group]}.C"
    assert get_value(m, path) == 1.0
    (spec,) = parse_parameters(m, [path])
    assert spec.unit == "-" and spec.min < 1.0 < spec.max
    m2 = set_values(m, {path: 0.7})
    for e, port in m.valve.ports.items():
        want = [0.7 * c for c in port.C] if e in edges else port.C
        assert m2.valve.ports[e].C == pytest.approx(want, rel=1e-15), e


def test_a_pattern_matching_no_edge_is_refused_by_name():
    m = Model.from_dict(model_preset("paper-4way"))
    with pytest.raises(FieldError) as ei:
        get_value(m, "valve.ports.X-*.C")
    assert "X-*" in ei.value.detail and "P-A" in ei.value.detail
