"""The circuit's fields in the model (issue 23, issue 28 item 3): validation naming the field
and its unit, JSON round trips that leave earlier models' JSON unchanged, chamber-B modes."""
import math

import pytest

from pneucore import model_preset
from pneucore.description.model import Model
from pneucore.description.validation import FieldError


def _3way(**valve):
    d = model_preset("paper-3way")
    d["valve"].update(valve)
    return d


def test_presets_round_trip_without_the_new_fields():
    """A horizontal jack and a held chamber B write no new key: stored JSON is unchanged."""
    for name in ("paper-4way", "paper-3way"):
        d = Model.from_dict(model_preset(name)).to_dict()
        assert "mounting_angle" not in d["jack"]
        assert not {"b_chamber", "b_chamber_conductance", "b_chamber_critical_ratio"} & set(d["valve"])


def test_new_fields_round_trip():
    d = _3way(b_chamber="restriction", b_chamber_conductance=2e-9, b_chamber_critical_ratio=0.35,
              b_chamber_pressure=None)
    d["jack"]["mounting_angle"] = 45.0
    d["effects"] = {"return_spring": {"rate": 800.0, "preload": 25.0},
                    "exhaust_silencer": {"C": 1e-8, "b": 0.4}}
    m = Model.from_dict(d)
    out = m.to_dict()
    assert Model.from_dict(out).to_dict() == out
    assert out["jack"]["mounting_angle"] == 45.0 and out["valve"]["b_chamber"] == "restriction"
    assert m.copy().to_dict() == out


@pytest.mark.parametrize("angle", [90.0001, -91.0, 180.0])
def test_mounting_angle_outside_90_degrees_names_field_and_unit(angle):
    d = model_preset("paper-4way")
    d["jack"]["mounting_angle"] = angle
    with pytest.raises(FieldError) as e:
        Model.from_dict(d)
    assert e.value.path == "jack.mounting_angle" and "[deg]" in str(e.value)


def test_gravity_load_of_a_mounting_angle():
    """m g sin(a) added to the load: 2 kg at 30 degrees is 9.80665 N (g = 9.80665 m/s^2)."""
    d = model_preset("paper-4way")
    d["jack"].update(mounting_angle=30.0, load_force=5.0)
    j = Model.from_dict(d).jack
    assert j.total_load == pytest.approx(5.0 + 2.0 * 9.80665 * 0.5, rel=1e-12)
    d["jack"]["mounting_angle"] = 0.0
    assert Model.from_dict(d).jack.total_load == 5.0        # exactly the load when horizontal


@pytest.mark.parametrize("mode,expected", [("held", 3.5e5), ("vented", 1.013e5),
                                           ("closed", None)])
def test_chamber_b_pressure_by_mode(mode, expected):
    m = Model.from_dict(_3way(b_chamber=mode))
    assert m.b_chamber_pressure == expected
    assert m.valve.b_dynamic == (expected is None)


def test_restriction_is_a_constant_b_r_edge_over_the_opening_range():
    m = Model.from_dict(_3way(b_chamber="restriction", b_chamber_conductance=2e-9,
                              b_chamber_critical_ratio=0.35))
    ports = m.valve.core_ports()
    assert set(ports) == {"P-A", "A-R", "B-R"} and "B-R" not in m.valve.ports
    br = ports["B-R"]
    assert br.opening == [0.0, 1.0] and br.C == [2e-9, 2e-9] and br.b == [0.35, 0.35]


@pytest.mark.parametrize("valve,field,part", [
    ({"b_chamber": "bogus"}, "valve.b_chamber", "held"),
    ({"b_chamber": "restriction"}, "valve.b_chamber_conductance", "[m^3/(s Pa)]"),
    ({"b_chamber": "closed", "b_chamber_pressure": 2e5}, "valve.b_chamber_pressure", "[Pa]"),
    ({"b_chamber_conductance": 1e-9}, "valve.b_chamber_conductance", "restriction"),
    ({"b_chamber": "restriction", "b_chamber_conductance": 1e-9, "b_chamber_critical_ratio": 1.0},
     "valve.b_chamber_critical_ratio", "< 1"),
])
def test_bad_chamber_b_names_the_field(valve, field, part):
    with pytest.raises(FieldError) as e:
        Model.from_dict(_3way(**valve))
    assert e.value.path == field and part in str(e.value)


def test_chamber_b_modes_only_on_a_3_2_valve():
    d = model_preset("paper-4way")
    d["valve"]["b_chamber"] = "vented"
    with pytest.raises(FieldError) as e:
        Model.from_dict(d)
    assert e.value.path == "valve.b_chamber" and "3/2" in str(e.value)


@pytest.mark.parametrize("effect,params,field", [
    ("return_spring", {"rate": -1.0}, "effects.return_spring.rate"),
    ("return_spring", {"preload": math.inf}, "effects.return_spring.preload"),
    ("meter_out_throttle", {"C_a": 2e-6}, "effects.meter_out_throttle.C_a"),
    ("meter_in_throttle", {"b_b": 1.0}, "effects.meter_in_throttle.b_b"),
    ("exhaust_silencer", {"C": -1e-9}, "effects.exhaust_silencer.C"),
])
def test_bad_effect_parameters_name_field(effect, params, field):
    d = model_preset("paper-4way")
    d["effects"] = {effect: params}
    with pytest.raises(FieldError) as e:
        Model.from_dict(d)
    assert e.value.path == field


def test_a_throttle_on_a_port_the_valve_does_not_have():
    d = model_preset("paper-3way")
    d["effects"] = {"meter_out_throttle": {"C_a": 3e-9, "C_b": 3e-9}}
    with pytest.raises(FieldError) as e:
        Model.from_dict(d)
    assert e.value.path == "effects.meter_out_throttle.C_b" and "no port B" in str(e.value)
    d["effects"] = {"meter_out_throttle": {"C_a": 3e-9, "C_b": 0.0}}
    Model.from_dict(d)      # port A only: accepted


def test_candidates_on_a_3_2_valve_hold_port_b_off():
    """A diagnosis candidate built for a 3/2 valve never carries a line or a throttle on the port
    the valve does not drive (the API would refuse the model it proposes: issue 28's 3/2 rig)."""
    from pneucore import Model, model_preset
    from pneucore.description.effects import EFFECTS
    m3 = Model.from_dict(model_preset("paper-3way"))
    # a flow control's volume before the valve on port B too (physics.flow_control)
    for name, port_b in (("tubing", ("length_b",)), ("meter_out_throttle", ("C_b", "volume_b")),
                         ("meter_in_throttle", ("C_b", "volume_b"))):
        eff = EFFECTS[name]
        assert eff.unused_in(m3) == port_b
        vals = eff.probe_values(m3)
        assert all(vals[p] == eff.param(p).off for p in port_b)
        d = model_preset("paper-3way")
        d["effects"] = {name: vals}
        Model.from_dict(d)   # accepted as it is
        assert eff.unused_in(Model.from_dict(model_preset("paper-4way"))) == ()
