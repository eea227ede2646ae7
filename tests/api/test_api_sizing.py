"""POST /api/sizing and POST /api/jobs/sizing through the TestClient (issue 25's contract)."""
import pytest

from api_conftest import api, assert_field_error, client, db_path, wait_job  # noqa: F401

REQ = {"stroke": 0.2, "moving_mass": 5.0, "load_force": 50.0, "angle": 30.0,
       "supply_pressure": 7e5, "extend_time": 0.6, "retract_time": 0.6, "max_end_speed": 1.0}
CHOICES = {"bore": ["iso15552:32", "iso15552:40", "iso6432:20"], "valve": ["ckd-4ga"]}


def _body(**req):
    return {"requirement": {**REQ, **req}, "choices": CHOICES}


def test_sizing_answers_ranked_designs_whose_models_simulate(client):
    r = client.post("/api/sizing", json=_body())
    assert r.status_code == 200, r.text[:800]
    ans = r.json()
    assert ans["families"] == 9
    designs = ans["designs"]
    assert designs and all(d["feasible"] for d in designs)
    assert [d["rank"] for d in designs] == list(range(1, len(designs) + 1))
    assert len(designs) + len(ans["infeasible"]) == 9
    for d in designs:
        m = d["metrics"]
        assert m["units"]["full_stroke_time"] == "s" and m["units"]["air"] == "NL"
        # each direction meets its time (the meter-out root lands at or under it)
        assert m["extend"]["full_stroke_time"] <= REQ["extend_time"]
        assert m["retract"]["full_stroke_time"] <= REQ["retract_time"]
        assert m["extend"]["end_speed"] <= REQ["max_end_speed"]
        assert d["air_per_cycle"] == pytest.approx(m["extend"]["air"] + m["retract"]["air"])
        # the model is one the API accepts as it is
        s = client.post("/api/simulate", json={
            "model": d["model"], "scenario": {"duration": 0.2, "sample_period": 0.01,
                                              "command": [[0.0, 1.0]]}, "series": ["x"]})
        assert s.status_code == 200, s.text[:800]
    assert any("m g sin(angle)" in n for n in ans["notes"])


def test_a_requirement_no_series_meets_gets_reasons(client):
    r = client.post("/api/sizing", json=_body(extend_time=0.01, retract_time=0.01))
    assert r.status_code == 200, r.text[:800]
    ans = r.json()
    assert ans["reasons"] == {"too_slow": 9}
    assert ans["designs"] and not any(d["feasible"] for d in ans["designs"])
    assert all(i["reason"] == "too_slow" and i["detail"] for i in ans["infeasible"])


@pytest.mark.parametrize("change,field,unit", [
    ({"stroke": -0.2}, "requirement.stroke", "m"),
    ({"angle": 100.0}, "requirement.angle", "deg"),
    ({"supply_pressure": 9e4}, "requirement.supply_pressure", "Pa"),
    ({"max_end_speed": 0.0}, "requirement.max_end_speed", "m/s"),
])
def test_a_malformed_requirement_is_a_422_naming_the_field_and_unit(client, change, field, unit):
    r = client.post("/api/sizing", json=_body(**change))
    assert_field_error(r, field, msg_contains=f"(unit: {unit})")


def test_missing_fields_and_bad_choices_are_422s(client):
    body = _body()
    del body["requirement"]["extend_time"]
    assert_field_error(client.post("/api/sizing", json=body), "requirement.extend_time")
    body = _body()
    body["choices"] = {"bore": ["iso9999"]}
    assert_field_error(client.post("/api/sizing", json=body), "choices.bore[0]",
                       msg_contains="iso15552")
    body["choices"] = {"valve": [{"C": -1.0, "b": 0.3}]}
    assert_field_error(client.post("/api/sizing", json=body), "choices.valve[0].C")
    body["choices"] = {"valve": [{"qn": 0.0, "b": 0.3}]}
    assert_field_error(client.post("/api/sizing", json=body), "choices.valve[0].qn",
                       msg_contains="NL/min")
    body = _body()
    body["requirement"]["stroke_length"] = 1.0
    assert client.post("/api/sizing", json=body).status_code == 422


def test_a_tube_outside_the_tubing_effects_bounds_is_a_422_not_a_failed_family(client):
    # a line of 60 m (the tubing effect takes 50 m) and a 60 mm bore tube (it takes 50 mm):
    # refused up front naming the field, on both routes (no job is started), also when no
    # tube_length makes the tube choices count
    assert_field_error(client.post("/api/sizing", json=_body(tube_length=60.0)),
                       "requirement.tube_length", msg_contains="(unit: m)")
    for req in ({"tube_length": 1.0}, {}):
        body = _body(**req)
        body["choices"] = {**CHOICES, "tube_inner_diameter": [0.004, 0.06]}
        for route in ("/api/sizing", "/api/jobs/sizing"):
            assert_field_error(client.post(route, json=body), "choices.tube_inner_diameter[1]",
                               msg_contains="<= 0.05")


def test_a_run_longer_than_max_duration_is_refused(tmp_path):
    with api(tmp_path / "s.sqlite3", max_duration=1.0) as c:
        # 0.6 s a direction is simulated for 1.8 s: above the 1 s limit
        assert_field_error(c.post("/api/sizing", json=_body()), "requirement.extend_time",
                           msg_contains="max_duration")


def test_sizing_as_a_job_reports_progress_and_the_same_answer(client):
    r = client.post("/api/jobs/sizing", json=_body())
    assert r.status_code == 202, r.text[:800]
    job, seen = wait_job(client, r.json()["id"])
    assert job["status"] == "done", job
    assert job["kind"] == "sizing"
    sync = client.post("/api/sizing", json=_body()).json()
    # the same search: the same designs in the same order, the same metrics (deterministic)
    assert [d["model"] for d in job["result"]["designs"]] == [d["model"] for d in sync["designs"]]
    assert job["result"]["designs"][0]["air_per_cycle"] == sync["designs"][0]["air_per_cycle"]
    # bad input is a 422 at once, not a failed job
    body = _body(stroke=0.0)
    assert_field_error(client.post("/api/jobs/sizing", json=body), "requirement.stroke")


def test_sizing_is_documented(client):
    spec = client.get("/openapi.json").json()
    op = spec["paths"]["/api/sizing"]["post"]
    assert "$ref" in op["responses"]["200"]["content"]["application/json"]["schema"]
    assert "429" in op["responses"]
    props = spec["components"]["schemas"]["RequirementSpec"]["properties"]
    assert props["stroke"]["description"].endswith("[m]")
    assert props["angle"]["description"].endswith("[deg]")
    ex = spec["components"]["schemas"]["SizingRequest"]["examples"][0]
    assert client.post("/api/sizing", json=ex).status_code == 200


def test_sizings_beyond_the_sync_queue_are_429_naming_the_job_route(db_path, monkeypatch):
    """Four sizings at once on 1 worker and a queue of 1 (the bounded pool of the other
    synchronous analyses, app.sync_pool): one runs, one waits, two are 429 naming
    /api/jobs/sizing; every slot is given back."""
    import threading
    import time
    from concurrent.futures import ThreadPoolExecutor

    from app.routers import sizing
    release, running = threading.Event(), threading.Semaphore(0)

    def held(*a, **k):   # a sizing that lasts until the test lets it go
        running.release()
        assert release.wait(120)
        return {"held": True}
    monkeypatch.setattr(sizing, "run_sizing", held)
    with api(db_path, sync_workers=1, max_sync_queue=1) as c, ThreadPoolExecutor(4) as ex:
        calls = [ex.submit(c.post, "/api/sizing", json=_body()) for _ in range(4)]
        assert running.acquire(timeout=120)   # one runs (a bound on a hang)
        t0 = time.monotonic()
        refused = []
        while len(refused) < 2:
            refused = [f.result() for f in calls if f.done()]
            assert time.monotonic() - t0 < 60, [r.status_code for r in refused]
            time.sleep(0.01)
        release.set()
        answers = [f.result(timeout=120) for f in calls]
        assert c.app.state.sync_pool.admitted == 0
    assert all(r.status_code == 429 and "/api/jobs/sizing" in r.json()["detail"] for r in refused)
    assert sorted(r.status_code for r in answers) == [200] * 2 + [429] * 2


def test_a_valve_given_by_its_catalogue_qn(client):
    # the same valve as the converter answers for that Qn (POST /api/valve/convert): one law
    conv = client.post("/api/valve/convert", json={"qn": 600.0, "b": 0.3})
    assert conv.status_code == 200, conv.text[:800]
    body = {"requirement": REQ, "choices": {"bore": ["iso15552:32"],
                                            "valve": [{"qn": 600.0, "b": 0.3, "name": "cat"}]}}
    r = client.post("/api/sizing", json=body)
    assert r.status_code == 200, r.text[:800]
    designs = r.json()["designs"]
    assert designs and designs[0]["valve"]["name"] == "cat"
    # 1e-12: the same function on the same numbers, floating point only
    assert designs[0]["valve"]["C"] == pytest.approx(conv.json()["C"], rel=1e-12)
    assert designs[0]["valve"]["qn"] == pytest.approx(600.0, rel=1e-9)


def test_a_cycle_time_with_dwell_instead_of_the_two_times(client):
    req = {k: v for k, v in REQ.items() if k not in ("extend_time", "retract_time")}
    body = {"requirement": {**req, "cycle_time": 1.6, "dwell": 0.2},
            "choices": {"bore": ["iso15552:32"], "valve": ["ckd-4ga:M4GA1"]}}
    r = client.post("/api/sizing", json=body)
    assert r.status_code == 200, r.text[:800]
    (d,) = r.json()["designs"]
    # the shares fill the 1.2 s to move (cycle less two dwells; 1e-9: arithmetic only), and
    # each stroke meets its share
    assert sum(d["required_times"].values()) == pytest.approx(1.2, rel=1e-9)
    for k in ("extend", "retract"):
        assert d["metrics"][k]["full_stroke_time"] <= d["required_times"][k]
    body["requirement"]["extend_time"] = 0.6
    assert_field_error(client.post("/api/sizing", json=body), "requirement.extend_time",
                       msg_contains="not both")


def test_a_cushion_in_the_requirement_gets_its_needles_solved(client):
    """The cushion needle is a setting the answer shows: per end its conductance, the impact
    energy and the energy against the capacity (at most 1 in a feasible design)."""
    body = {"requirement": {"stroke": 0.2, "moving_mass": 5.0, "load_force": 20.0,
                            "supply_pressure": 7e5, "extend_time": 0.5, "retract_time": 0.5,
                            "cushion_length": 0.02, "cushion_capacity": 0.05},
            "choices": {"bore": ["iso15552:32"], "valve": ["ckd-4ga:M4GA1"], "meter_out": False}}
    r = client.post("/api/sizing", json=body)
    assert r.status_code == 200, r.text[:800]
    ans = r.json()
    (d,) = ans["designs"]
    assert d["feasible"] and ans["units"]["cushion.*.end_energy"] == "J"
    for k in ("extend", "retract"):
        c = d["cushion"][k]
        assert c["needle_solved"] and c["needle_C"] == d["settings"][f"{k}_needle_C"] > 0.0
        # at the capacity from below: 1 % (the root's tolerance, tests/sizing/test_sizing_cushion.py)
        assert 0.99 <= c["energy_ratio"] <= 1.0
    ec = d["model"]["effects"]["end_cushion"]
    assert (ec["C_b"], ec["C_a"]) == (d["settings"]["extend_needle_C"],
                                      d["settings"]["retract_needle_C"])


@pytest.mark.parametrize("change,field,unit", [
    ({"cushion_capacity": 0.1}, "requirement.cushion_length", "m"),
    # a cushion none of the chosen ISO cylinders has a capacity for
    ({"cushion_length": 0.02}, "requirement.cushion_capacity", "J"),
    ({"cushion_length": 0.02, "cushion_capacity": -1.0}, "requirement.cushion_capacity", "J"),
    ({"cushion_length": 0.15, "cushion_capacity": 0.1}, "requirement.cushion_length", "m"),
])
def test_a_bad_cushion_is_a_422_naming_the_field_and_unit(client, change, field, unit):
    r = client.post("/api/sizing", json=_body(**change))
    assert_field_error(r, field, msg_contains=f"(unit: {unit})")


@pytest.mark.parametrize("value", ["yes", 1, "true"])
def test_meter_out_takes_a_json_boolean_only(client, value):
    """``choices.meter_out`` is true or false: a string or a number is refused naming the field
    (the Python library refuses them too; lax coercion once turned "yes" into true)."""
    body = {"requirement": REQ, "choices": {**CHOICES, "meter_out": value}}
    assert_field_error(client.post("/api/sizing", json=body), "choices.meter_out")


def test_the_sized_design_simulated_in_its_steady_cycle_on_a_1_m_tube_keeps_its_times(client):
    """The page's flow: size with a 1 m tube, take the design, simulate its steady cycle
    through POST /api/simulate: the same stroke times as the table (1.8-3.1 % faster before,
    the sizing's strokes starting with the gases at the model's temperature)."""
    req = {"stroke": 0.15, "moving_mass": 2.0, "load_force": 0.0, "supply_pressure": 6e5,
           "extend_time": 0.35, "retract_time": 0.35, "tube_length": 1.0}
    body = {"requirement": req, "choices": {"bore": ["iso6432:20", "iso15552:32"],
                                            "valve": ["ckd-4ga:M4GA1"],
                                            "tube_inner_diameter": ["pu-tube:TU0604"]}}
    r = client.post("/api/sizing", json=body)
    assert r.status_code == 200, r.text[:800]
    designs = [d for d in r.json()["designs"] if d["feasible"]]
    assert designs
    for d in designs:
        s = client.post("/api/simulate", json={"model": d["model"],
                                               "scenario": d["steady_cycle"]["scenario"]})
        assert s.status_code == 200, s.text[:800]
        stroke = s.json()["stats"]["stroke"]
        for k in ("extend", "retract"):
            # 1 %: the bound between the page's steady cycle and the sizing's table
            assert stroke[f"full_stroke_time_{k}"] == pytest.approx(
                d["metrics"][k]["full_stroke_time"], rel=0.01), (d["rank"], k)


@pytest.mark.parametrize("table,field", [
    ([{"bore": 0.0, "capacity": 0.1}], "requirement.cushion_capacities[0].bore"),
    ([{"bore": 0.032, "capacity": -1.0}], "requirement.cushion_capacities[0].capacity"),
])
def test_a_bad_cushion_capacity_entry_is_a_422_naming_it(client, table, field):
    r = client.post("/api/sizing", json=_body(cushion_length=0.02, cushion_capacity=0.2,
                                              cushion_capacities=table))
    assert_field_error(r, field)


def test_a_load_factor_limit_out_of_range_is_a_422_naming_it(client):
    assert_field_error(client.post("/api/sizing", json=_body(max_load_factor=2.0)),
                       "requirement.max_load_factor")


def test_the_series_route_lists_each_series_with_its_catalogue_energies(client):
    """GET /api/sizing/series: every shipped series a choice may name, with its source, and for
    the cylinder series whose catalogue gives them each member's cushion and bumper capacity
    [J] (the figures a sizing takes); null where the catalogue gives none."""
    r = client.get("/api/sizing/series")
    assert r.status_code == 200, r.text[:400]
    s = r.json()
    assert {"iso15552", "iso6432", "smc-cm2", "smc-ca2"} <= set(s["cylinders"])
    cm2 = s["cylinders"]["smc-cm2"]
    assert cm2["members"] == ["20", "25", "32", "40"]
    assert cm2["cushion_capacity"] == {"20": 0.54, "25": 0.78, "32": 1.27, "40": 2.35}
    assert cm2["bumper_capacity"] == {"20": 0.27, "25": 0.4, "32": 0.65, "40": 1.2}
    assert s["cylinders"]["smc-ca2"]["bumper_capacity"] is None
    assert s["cylinders"]["iso15552"]["cushion_capacity"] is None
    assert "SMC" in cm2["source"] and s["valves"]["ckd-4ga"]["members"][0] == "M4GA1"
    # each unit is in the schema's description
    props = client.get("/openapi.json").json()["components"]["schemas"]["SeriesOut"]["properties"]
    assert props["cushion_capacity"]["description"].endswith("[J]")
