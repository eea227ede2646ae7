"""``model_changes``: what a finding would change, listed before it is applied (issue 24)."""
from pneucore import model_preset
from pneucore.description.paths import model_changes, set_values
from pneucore.description.model import Model


def test_a_scaled_valve_table_is_one_scale_factor_and_units_are_named():
    a = model_preset("paper-4way")
    b = set_values(Model.from_dict(a), {"valve.ports.P-A.C": 0.8, "supply.pressure": 6.5e5})
    changes = {c["path"]: c for c in model_changes(a, b)}
    assert changes["valve.ports.P-A.C"]["kind"] == "scaled"
    assert abs(changes["valve.ports.P-A.C"]["after"] - 0.8) < 1e-9
    assert changes["supply.pressure"]["unit"] == "Pa"
    assert changes["supply.pressure"]["before"] == 7e5 and changes["supply.pressure"]["after"] == 6.5e5
    assert set(changes) == {"valve.ports.P-A.C", "supply.pressure"}   # nothing else moved


def test_no_change_no_entry_and_a_removed_effect_is_listed():
    a = model_preset("paper-4way")
    assert model_changes(a, model_preset("paper-4way")) == []
    a["effects"]["piston_leakage"] = {"conductance": 8e-11}
    gone = model_changes(a, model_preset("paper-4way"))
    assert gone[0] == {"path": "effects.piston_leakage", "before": "present", "after": None,
                       "unit": "", "kind": "removed"}
