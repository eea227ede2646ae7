"""Issue 41 item 4: the load checks reject families (load factor, buckling, each bore's own
cushion capacity), the ranking prefers margins, and the sizing's strokes are those of the
steady cycle with a tube on the ports."""
import pytest

from pneucore import simulate
from pneucore.description.validation import FieldError
from pneucore.sizing import Requirement, size
from pneucore.sizing.search import MARGIN

#: the issue's pick-and-place axis (2 kg, 150 mm, 0.35 s a stroke) with a 1 m tube on each port
TUBE_REQ = {"stroke": 0.15, "moving_mass": 2.0, "supply_pressure": 6e5, "extend_time": 0.35,
            "retract_time": 0.35, "tube_length": 1.0}
TUBE_CHOICES = {"bore": ["iso6432:16", "iso6432:20", "iso15552:32"], "valve": ["ckd-4ga:M4GA1"],
                "tube_inner_diameter": ["pu-tube:TU0425", "pu-tube:TU0604"]}


def test_with_a_1_m_tube_the_steady_cycle_runs_the_sizings_stroke_times():
    """Before, the steady cycle ran 0.9-1.6 % faster than the table here (1.8-3.1 % on the
    issue's case): the sizing's strokes started with both gases at the model's temperature,
    while in the running machine the exhausting chamber (its dead volume and the tube's) starts
    warmer, heated by its filling, so less air to push out."""
    ans = size(TUBE_REQ, TUBE_CHOICES, workers=1)
    designs = [d for d in ans["designs"] if d["feasible"]]
    assert len(designs) >= 4
    for d in designs:
        sc = d["steady_cycle"]
        assert sc["converged"] and d["stroke_starts"] is not None
        for k in ("extend", "retract"):
            # 0.2 %: STEADY_RTOL (0.1 %) plus the cycle's and the stroke's different sample
            # grids; the issue asks for 1 %
            assert sc["full_stroke_time"][k] == pytest.approx(d["metrics"][k]["full_stroke_time"],
                                                              rel=2e-3), (d["rank"], k)
        # the extension starts from the steady state the cycle reports: the state of the
        # settings of the pass before the last, within 0.5 K of the last's (the settings move
        # by the root's tolerance between passes)
        assert d["stroke_starts"]["extend"]["T_b"] == pytest.approx(sc["start"]["T_b"], abs=0.5)


def test_a_load_factor_above_the_limit_is_rejected_with_its_reason():
    req = {"stroke": 0.1, "moving_mass": 2.0, "load_force": 60.0, "supply_pressure": 6e5,
           "extend_time": 0.5, "retract_time": 0.5}
    ch = {"bore": ["iso6432:12", "iso6432:16", "iso6432:20"], "valve": ["ckd-4ga:M4GA1"]}
    ans = size(req, ch, workers=1)
    # theoretical outputs at 6 bar abs: 12 mm 56 N (load factor 1.07: too weak), 16 mm 100 N
    # (0.60: rejected), 20 mm 157 N (0.38: kept)
    assert [d["cylinder"]["name"] for d in ans["designs"]] == ["iso6432:20"]
    rej = {f["cylinder"]["name"]: f for f in ans["infeasible"]}
    assert rej["iso6432:16"]["reason"] == "load_factor"
    assert "load factor 0.598" in rej["iso6432:16"]["detail"]
    # a static duty (0.7, SMC) keeps it
    ans = size({**req, "max_load_factor": 0.7}, ch, workers=1)
    assert "iso6432:16" in [d["cylinder"]["name"] for d in ans["designs"]]


def test_the_ranking_puts_the_designs_with_a_margin_first():
    # 40 N on 16 mm is a load factor of 0.40 (20 % inside 0.5: no margin at MARGIN = 0.2 once
    # rounded up), on 20 mm 0.25: the 20 mm ranks first though it uses more air
    req = {"stroke": 0.1, "moving_mass": 2.0, "load_force": 42.0, "supply_pressure": 6e5,
           "extend_time": 0.5, "retract_time": 0.5}
    ans = size(req, {"bore": ["iso6432:16", "iso6432:20"], "valve": ["ckd-4ga:M4GA1"]},
               workers=1)
    first, second = ans["designs"]
    assert first["cylinder"]["name"] == "iso6432:20" and first["margins"]["ok"]
    assert not second["margins"]["ok"] and second["margins"]["load_factor"] < MARGIN
    assert second["air_per_cycle"] < first["air_per_cycle"]
    assert "ranked after the designs with a 20% margin" in second["why"]


#: tests/sizing/test_sizing_cushion.py's case: a 32 mm bore, 5 kg, 200 mm in 0.5 s meets its
#: ends at 4.5 - 6 J fully open; 20 mm cushions, a typed capacity of 0.2 J
CUSHION_REQ = {"stroke": 0.2, "moving_mass": 5.0, "load_force": 50.0, "supply_pressure": 7e5,
               "extend_time": 0.5, "retract_time": 0.5, "cushion_length": 0.02,
               "cushion_capacity": 0.2}


def test_each_bore_takes_its_own_cushion_capacity():
    ch = {"bore": ["iso15552:32", "iso15552:40"], "valve": ["ckd-4ga:M4GA1"], "meter_out": False}
    # the user's table: the 32 mm cushion takes 0.05 J (the typed 0.2 J for the 40 mm); a
    # figure for the test, not a catalogue's
    req = {**CUSHION_REQ, "cushion_capacities": [{"bore": 0.032, "capacity": 0.05,
                                                  "series": "iso15552"}]}
    ans = size(req, ch, workers=1)
    by = {d["cylinder"]["name"]: d for d in ans["designs"]}
    assert set(by) == {"iso15552:32", "iso15552:40"}
    c32, c40 = by["iso15552:32"]["cushion"], by["iso15552:40"]["cushion"]
    assert c32["capacity"] == 0.05 and c32["capacity_source"] == "cushion_capacities[0]"
    assert by["iso15552:32"]["model"]["effects"]["end_cushion"]["capacity"] == 0.05
    assert c40["capacity"] == 0.2 and c40["capacity_source"] == "cushion_capacity"
    for k in ("extend", "retract"):
        # the needle is solved for each cylinder's own capacity: at it within the needle's
        # root tolerance (99 %: tests/sizing/test_sizing_cushion.py)
        assert 0.99 * 0.05 <= c32[k]["end_energy"] <= 0.05
        assert 0.99 * 0.2 <= c40[k]["end_energy"] <= 0.2
    # without the table the 32 mm takes the typed 0.2 J
    alone = size(CUSHION_REQ, {**ch, "bore": ["iso15552:32"]}, workers=1)["designs"][0]
    assert alone["cushion"]["capacity"] == 0.2
    assert alone["cushion"]["extend"]["end_energy"] > 0.05


def test_a_cushion_no_needle_brings_within_the_bores_capacity_is_rejected_naming_it():
    # 0.3 s allows no needle to bring 5 kg within 0.001 J on the 32 mm bore
    req = {**CUSHION_REQ, "extend_time": 0.3, "retract_time": 0.3,
           "cushion_capacities": [{"bore": 0.032, "capacity": 0.001}]}
    ans = size(req, {"bore": ["iso15552:32"], "valve": ["ckd-4ga:M4GA1"], "meter_out": False},
               workers=1)
    (f,) = ans["infeasible"]
    assert f["reason"] == "cushion" and "cushion capacity 0.001 J (cushion_capacities[0])" in f["detail"]


def test_a_series_less_entry_serves_every_series_and_a_series_entry_wins():
    r = Requirement.from_dict({**CUSHION_REQ, "cushion_capacity": 0.4, "cushion_capacities": [
        {"bore": 0.032, "capacity": 1.0}, {"bore": 0.032, "capacity": 2.0, "series": "iso15552"}]})
    assert r.capacity_for({"name": "iso15552:32", "bore": 0.032}) == (2.0, "cushion_capacities[1]")
    assert r.capacity_for({"name": "mine", "bore": 0.032}) == (1.0, "cushion_capacities[0]")
    assert r.capacity_for({"name": "iso15552:40", "bore": 0.04}) == (0.4, "cushion_capacity")


@pytest.mark.parametrize("table,path", [
    ([{"bore": -0.016, "capacity": 0.1}], "requirement.cushion_capacities[0].bore"),
    ([{"bore": 0.016}], "requirement.cushion_capacities[0].capacity"),
    ([{"bore": 0.016, "capacity": 0.1, "energy": 1}], "requirement.cushion_capacities[0].energy"),
    ([{"bore": 0.016, "capacity": 0.1}, {"bore": 0.016, "capacity": 0.2}],
     "requirement.cushion_capacities[1].bore"),
    ("0.1", "requirement.cushion_capacities"),
])
def test_a_bad_capacity_table_names_its_field(table, path):
    with pytest.raises(FieldError) as e:
        Requirement.from_dict({**CUSHION_REQ, "cushion_capacities": table})
    assert e.value.path == path


def test_a_capacity_table_needs_the_cushion_and_limits_are_bounded():
    req = {k: v for k, v in CUSHION_REQ.items() if not k.startswith("cushion")}
    with pytest.raises(FieldError) as e:
        Requirement.from_dict({**req, "cushion_capacities": [{"bore": 0.016, "capacity": 0.1}]})
    assert e.value.path == "requirement.cushion_capacities"
    for field, value in (("max_load_factor", 1.5), ("max_load_factor", 0.0),
                         ("min_buckling_safety", 0.5)):
        with pytest.raises(FieldError) as e:
            Requirement.from_dict({**req, field: value})
        assert e.value.path == f"requirement.{field}" and "(unit: -)" in str(e.value)
