"""The cushion needle as a setting the sizing solves (issue 25, item 3: "a stroke-end speed the
cushion can absorb").

A requirement with a cushion (``cushion_length`` [m], ``cushion_capacity`` [J]) gives every
design the model's ``end_cushion`` at both ends; where a stroke would meet its end with more
kinetic energy than the capacity, the needle of that end is solved (1-D root on ln C, no
meter-out throttle that way) for the impact energy to be at the capacity while the stroke
still meets its time. Checked here by hand-verifiable facts: the solved needle's design,
simulated anew, meets its end with the capacity's energy (and a needle a little more open
exceeds it); a smaller capacity needs a more closed needle and a longer stroke (the monotonic
trade of tests/physics/test_cushion.py); a capacity no needle can meet in the time gets the
reason ``cushion`` at the most closed needle the time allows. Where the meter-out throttle may
vary too, a throttle and a needle together are searched before that verdict: a capacity the
needle alone cannot meet in the time, a pair can; and a verdict ``cushion`` then says that no
pair meets both, which an independent probe of pairs confirms.
"""
import math

import pytest

from pneucore import simulate
from pneucore.sizing import Requirement, size
from pneucore.sizing.search import NEEDLE_XTOL, _stroke_scenario
from pneucore.description.validation import FieldError

REQ = {"stroke": 0.2, "moving_mass": 5.0, "load_force": 20.0, "angle": 0.0,
       "supply_pressure": 7e5, "extend_time": 0.5, "retract_time": 0.5, "cushion_length": 0.02}
#: a 32 mm bore on the smallest valve, no meter-out: fully open each stroke meets its end at
#: about 1.4 - 1.6 m/s, 4.5 - 6 J, in 0.19 - 0.22 s
CHOICES = {"bore": ["iso15552:32"], "valve": ["ckd-4ga:M4GA1"], "meter_out": False}
NEEDLE = {"extend": "C_b", "retract": "C_a"}


def _size(capacity, choices=CHOICES, **req):
    return size({**REQ, "cushion_capacity": capacity, **req}, choices, workers=1)


def _impact(design, direction, needle=None):
    """The design's stroke simulated anew (its own model, optionally another needle)."""
    model = {**design["model"], "effects": {k: dict(v) for k, v in
                                            design["model"]["effects"].items()}}
    if needle is not None:
        model["effects"]["end_cushion"][NEEDLE[direction]] = needle
    req = Requirement.from_dict({**REQ, "cushion_capacity": design["cushion"]["capacity"],
                                 **{f"{k}_time": t for k, t in design["required_times"].items()}})
    # from the state the sizing timed the stroke from: the design's steady cycle's
    starts = design["stroke_starts"]
    res = simulate(model, _stroke_scenario(req, direction, starts and starts[direction]))
    (s,) = [s for s in res.stroke_metrics()["strokes"] if s["direction"] == direction]
    return s


def test_the_solved_needle_leaves_the_capacity_at_the_impact():
    cap = 0.05
    ans = _size(cap)
    (d,) = ans["designs"]
    assert d["feasible"] and ans["units"]["settings.*_needle_C"] == "m^3/(s Pa)"
    for k in ("extend", "retract"):
        c = d["cushion"][k]
        assert c["needle_solved"] and d["settings"][f"{k}_needle_C"] == c["needle_C"]
        assert d["settings"][f"{k}_meter_out_C"] == 0.0      # the needle brakes, no throttle
        # the design's own model, simulated anew: its impact energy is the capacity's. The
        # root is on ln C within NEEDLE_XTOL and the needle kept is at most 2 tolerances on its
        # closed side; the energy goes about as C^7 there, so 1 - exp(-7 x 3 x 5e-4) = 1 %
        s = _impact(d, k)
        assert s["end_energy"] == pytest.approx(c["end_energy"], rel=1e-12)   # the same run
        assert 0.99 * cap <= s["end_energy"] <= cap
        assert s["cushion_capacity"] == cap and s["energy_ratio"] <= 1.0
        assert s["full_stroke_time"] <= REQ[f"{k}_time"]
        # it is the most open such needle: 4 tolerances more open (past the root, which is
        # within 3 of it) the impact exceeds the capacity
        assert _impact(d, k, c["needle_C"] * math.exp(4 * NEEDLE_XTOL))["end_energy"] > cap


def test_a_smaller_capacity_needs_a_more_closed_needle_and_a_longer_stroke():
    caps = (0.2, 0.05, 0.01)
    designs = [_size(cap)["designs"][0] for cap in caps]
    for k in ("extend", "retract"):
        needles = [d["cushion"][k]["needle_C"] for d in designs]
        times = [d["metrics"][k]["full_stroke_time"] for d in designs]
        speeds = [d["metrics"][k]["end_speed"] for d in designs]
        assert all(b < a for a, b in zip(needles, needles[1:])), needles
        assert all(b > a for a, b in zip(times, times[1:])), times
        assert all(b < a for a, b in zip(speeds, speeds[1:])), speeds
        # each at its capacity: m v^2 / 2 within 1 % under it (as above)
        for d, cap in zip(designs, caps):
            assert 0.99 * cap <= 0.5 * REQ["moving_mass"] * d["metrics"][k]["end_speed"] ** 2 <= cap


def test_a_capacity_no_needle_meets_in_the_time_gets_the_reason():
    ans = _size(0.01, extend_time=0.3, retract_time=0.3)
    (fail,) = ans["infeasible"]
    assert fail["reason"] == "cushion" and fail["direction"] == "extend"
    assert "needle closed as far as the time allows" in ans["reason_meanings"]["cushion"]
    assert "as far as 0.3 s allows" in fail["detail"] and "capacity 0.01 J" in fail["detail"]
    (d,) = ans["designs"]
    c = d["cushion"]["extend"]
    assert not d["feasible"] and c["energy_ratio"] > 1.0
    # the needle shown is closed as far as the time allows: the stroke takes the 0.3 s, to the
    # root's tolerance (5e-4 on ln C moves the time by far less than 1 %)
    t = d["metrics"]["extend"]["full_stroke_time"]
    assert 0.99 * 0.3 <= t <= 0.3
    # and the energy there is the one the detail gives
    assert f"{c['end_energy']:.3g} J" in fail["detail"]


#: the meter-out throttle may vary as well as the needle
WITH_THROTTLE = {**CHOICES, "meter_out": True}


def test_a_throttle_and_needle_together_meet_what_the_needle_alone_cannot():
    """0.3 s each way, 0.1 J: the needle alone, closed as far as 0.3 s allows, leaves 0.185 J
    at the stroke end (extending); with the throttle free, a pair meets both."""
    alone = _size(0.1, extend_time=0.3, retract_time=0.3)
    assert [f["reason"] for f in alone["infeasible"]] == ["cushion"]
    ans = _size(0.1, WITH_THROTTLE, extend_time=0.3, retract_time=0.3)
    (d,) = ans["designs"]
    assert d["feasible"] and not ans["infeasible"]
    c = d["cushion"]["extend"]
    assert c["needle_solved"] and d["settings"]["extend_meter_out_C"] > 0.0
    for k in ("extend", "retract"):
        # the design's own model, simulated anew: the same run as the answer's metrics, within
        # the time and the capacity
        s = _impact(d, k)
        assert s["end_energy"] == pytest.approx(d["cushion"][k]["end_energy"], rel=1e-12)
        assert s["end_energy"] <= 0.1 and s["full_stroke_time"] <= 0.3


def test_a_cushion_verdict_with_the_throttle_free_means_no_pair_meets_both():
    """0.21 s to extend (0.187 s fully open), 0.01 J: no pair meets both. The design shown is the
    pair of least energy the search found, within the time; a probe of pairs the search need
    not have tried (throttles from the valve's exhaust conductance to 4 times it, needles from
    1 to 16 times 1e-9) finds none within the capacity in the time either."""
    ans = _size(0.01, WITH_THROTTLE, extend_time=0.21, retract_time=0.5)
    (fail,) = ans["infeasible"]
    assert fail["reason"] == "cushion" and fail["direction"] == "extend"
    assert "meter-out throttle and needle pairs searched" in fail["detail"]
    (d,) = ans["designs"]
    c = d["cushion"]["extend"]
    assert not d["feasible"] and c["energy_ratio"] > 1.0
    assert f"{c['end_energy']:.3g} J" in fail["detail"]
    assert d["metrics"]["extend"]["full_stroke_time"] <= 0.21
    probe = {**d, "model": {**d["model"], "effects": {k: dict(v) for k, v in
                                                      d["model"]["effects"].items()}}}
    c_edge = d["valve"]["C_exhaust"]
    in_time = 0
    for throttle in (c_edge, 2 * c_edge, 4 * c_edge):
        probe["model"]["effects"]["meter_out_throttle"]["C_b"] = throttle
        for needle in (1e-9, 2e-9, 4e-9, 8e-9, 16e-9):
            s = _impact(probe, "extend", needle)
            if s["full_stroke_time"] is not None and s["full_stroke_time"] <= 0.21:
                in_time += 1
                assert s["end_energy"] > 0.01, (throttle, needle, s)
    assert in_time >= 3      # the probe is not vacuous: five of its pairs meet the time


def test_a_cushion_not_needed_stays_fully_open_and_brakes_nothing():
    """A capacity above the fully open impact: the needle stays open (ten times the exhaust
    conductance, so the edge sets every flow) and the strokes are those without a cushion."""
    plain = size({k: v for k, v in REQ.items() if k != "cushion_length"}, CHOICES, workers=1)
    ans = _size(100.0)
    d, p = ans["designs"][0], plain["designs"][0]
    for k in ("extend", "retract"):
        assert not d["cushion"][k]["needle_solved"]
        assert d["settings"][f"{k}_needle_C"] == d["cushion"]["needle_open_C"]
        # the same right-hand side (the needle's flow exceeds the edge's, min() keeps the
        # edge's): the same full-stroke time to the solver's rtol
        assert d["metrics"][k]["full_stroke_time"] == pytest.approx(
            p["metrics"][k]["full_stroke_time"], rel=1e-6)
    assert any("else its series' catalogue figure" in n and "smc-cm2" in n for n in ans["notes"])


@pytest.mark.parametrize("change,field,text", [
    ({"cushion_capacity": 0.1}, "requirement.cushion_length", "required with cushion_capacity (unit: m)"),
    ({"cushion_capacities": [{"bore": 0.032, "capacity": 0.1}]}, "requirement.cushion_capacities",
     "need the cushion"),
    ({"cushion_length": -0.02, "cushion_capacity": 0.1}, "requirement.cushion_length", "(unit: m)"),
    ({"cushion_length": 0.02, "cushion_capacity": 0.0}, "requirement.cushion_capacity", "(unit: J)"),
    ({"cushion_length": 0.15, "cushion_capacity": 0.1}, "requirement.cushion_length", "overlap"),
    ({"cushion_length": 0.02, "cushion_capacity": 1e9}, "requirement.cushion_capacity", "(unit: J)"),
])
def test_a_bad_cushion_names_the_field_and_its_unit(change, field, text):
    req = {k: v for k, v in REQ.items() if k != "cushion_length"}
    with pytest.raises(FieldError) as e:
        Requirement.from_dict({**req, **change})
    assert e.value.path == field
    assert text in e.value.detail and "unit:" in e.value.detail


def test_the_command_lines_table_shows_the_needles():
    from pneucore.cli import sizing_lines
    ans = _size(0.05)
    lines = sizing_lines(ans)
    assert "needle C ext/ret" in lines[1] and "E_end/capacity" in lines[1]
    c = ans["designs"][0]["cushion"]
    assert f"{c['extend']['needle_C']:.3g}/{c['retract']['needle_C']:.3g}" in lines[2]


def test_the_throttle_variable_round_trips_and_stays_within_the_effect():
    """``path_y`` and ``path_throttle`` are inverses (the meter-out root's change of variable);
    near y = 0 the throttle would exceed the ``meter_out_throttle`` effect's bound, which the
    model refuses: it is then none (the pair search probes up to y = 0 on every valve)."""
    from pneucore.sizing.search import path_throttle, path_y
    from pneucore.description.effects import EFFECTS
    c_edge = 3.8e-8
    for c in (1e-10, 3e-9, 4e-8, 5e-7):
        # round-off of expm1/log1p on numbers of order 1
        assert path_throttle(path_y(c, c_edge), c_edge) == pytest.approx(c, rel=1e-9)
    assert path_throttle(0.0, c_edge) == path_throttle(-1e-9, c_edge) == 0.0
    assert path_throttle(-1e-3, c_edge) < EFFECTS["meter_out_throttle"].param("C_a").max


def test_one_capacity_for_every_bore_is_said_and_a_table_is_counted():
    """The issue's designer: one capacity typed for every bore let a 16 mm cylinder rank first
    against a capacity its cushion does not have. With no table of each bore's own capacity the
    answer says so; with one it says how many it holds and what the other bores take."""
    from pneucore.sizing.search import model_notes
    one = model_notes(Requirement.from_dict({**REQ, "cushion_capacity": 0.4}))
    assert any("One cushion capacity (0.4 J) taken for every bore" in n for n in one)
    table = [{"series": "iso15552", "bore": 0.032, "capacity": 0.3},
             {"series": "iso15552", "bore": 0.04, "capacity": 0.5}]
    two = model_notes(Requirement.from_dict({**REQ, "cushion_capacity": 0.4,
                                             "cushion_capacities": table}))
    assert not any("One cushion capacity" in n for n in two)
    assert any("Cushion capacities of 2 series and bores" in n and "(0.4 J)" in n for n in two)
    # no cushion, no word of capacities
    none = model_notes(Requirement.from_dict({k: v for k, v in REQ.items() if k != "cushion_length"}))
    assert not any("apacit" in n for n in none)
