"""POST /api/simulate with ``scenario.start: cyclic`` (issue 41 item 1): the run starts from the
cyclic steady state and says which; a bad ``start`` or too long a cycle is a 422 naming it."""
from api_conftest import assert_field_error, client, db_path, model, sim_body  # noqa: F401

CYCLE = {"duration": 1.0, "sample_period": 0.001, "command": [[0, 0], [0.01, 1], [0.5, -1]],
         "x0": 0.0}


def test_cyclic_start_is_reported_with_its_state(client):
    r = client.post("/api/simulate", json=sim_body(m=model(), s=dict(CYCLE, start="cyclic")))
    assert r.status_code == 200, r.text[:500]
    cyc = r.json()["stats"]["cyclic"]
    assert cyc["converged"]
    # the running machine's extension starts with chamber B at the supply (7 bar abs)
    assert abs(cyc["state"]["p_b"] - 7e5) < 1e3
    assert set(cyc["state"]) == {"p_a", "p_b", "T_a", "T_b", "x0", "v0"}
    given = client.post("/api/simulate", json=sim_body(m=model(), s=CYCLE)).json()
    assert "cyclic" not in given["stats"]
    ext = lambda d: d["stats"]["stroke"]["full_stroke_time_extend"]   # noqa: E731
    assert ext(r.json()) > 1.5 * ext(given)


def test_bad_start_and_too_long_a_cycle_are_422(client):
    r = client.post("/api/simulate", json=sim_body(m=model(), s=dict(CYCLE, start="steady")))
    assert_field_error(r, "scenario.start")
    r = client.post("/api/simulate", json=sim_body(m=model(), s=dict(CYCLE, duration=60.0,
                                                                      start="cyclic")))
    assert_field_error(r, "scenario.start", msg_contains=("cyclic",))
