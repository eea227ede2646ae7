"""Closed-loop studies kept in the study store like open-loop ones (issue 42, item 6): POST
/api/studies with a scenario naming the controller stores the study, runs every parameter set
as the closed loop on the run's model, and the study routes answer its runs with the loop's
metrics (rise_time, settling_time [s], overshoot [-], steady_state_error [m], ...) and units;
an unstable run is a failed run; a bad controller is a 422 before anything is stored."""
import csv
import io

import numpy as np
import pytest

from api_conftest import assert_field_error, db_path, wait_job  # noqa: F401
from test_api_studies import studies_api

from pneucore.control.closed_loop import simulate_closed_loop
from pneucore.control.models import servo_model

CTL = {"kind": "pid", "gains": {"kp": 15.0}, "setpoint": [[0, 0.1], [0.05, 0.11]]}
SCEN = {"duration": 0.5, "sample_period": 0.001, "x0": 0.1,
        "initial": {"p_a": 5.3e5, "p_b": 5.3e5}}


def body(gains=None, **extra):
    ctl = dict(CTL, gains=gains or CTL["gains"])
    d = {"model": servo_model(), "scenario": dict(SCEN, controller=ctl),
         "parameters": {"jack.moving_mass": {"grid": [1.0, 4.0]}}, "workers": 0}
    d.update(extra)
    return d


def test_a_closed_loop_study_is_stored_and_answers_the_loops_metrics(db_path):
    with studies_api(db_path) as c:
        r = c.post("/api/studies", json=body())
        assert r.status_code == 202, r.text
        p = r.json()
        job, _ = wait_job(c, p["job_id"])
        assert job["status"] == "done", job
        assert p["id"] in [s["id"] for s in c.get("/api/studies").json()]
        res = c.get(f"/api/studies/{p['id']}/results").json()
        assert res["stored"] == 2 and res["failed"] == 0
        # the stored definition keeps the controller; the metrics are the loop's, with units
        assert res["definition"]["scenario"]["controller"]["kind"] == "pid"
        m = res["metrics"]
        assert m["overshoot"]["unit"] == "-" and m["steady_state_error"]["unit"] == "m"
        assert m["rise_time"]["unit"] == "s" and "t95" not in m
        # each run is the closed loop on its model: the same figures as simulating it
        # directly (the same code on the same input: equal to rounding, 1e-12)
        runs = res["runs"]
        by_mass = {}
        for j, mass in enumerate(runs["params"]["jack.moving_mass"]):
            m = servo_model()
            m["jack"]["moving_mass"] = mass
            direct = simulate_closed_loop(m, dict(SCEN, controller=CTL)).stats["control"]
            by_mass[mass] = {k: runs["metrics"][k][j] for k in runs["metrics"]}
            for k in ("overshoot", "rise_time", "rms_error"):
                assert by_mass[mass][k] == pytest.approx(direct[k], rel=1e-12), (mass, k)
        # a heavier piston overshoots more under the same P gain
        assert by_mass[4.0]["overshoot"] > by_mass[1.0]["overshoot"]
        # the runs' CSV and NPZ carry the loop's units
        text = c.get(f"/api/studies/{p['id']}/runs.csv").text
        header = next(csv.reader(io.StringIO(text)))
        assert "overshoot [-]" in header and "steady_state_error [m]" in header
        npz = np.load(io.BytesIO(c.get(f"/api/studies/{p['id']}/runs.npz").content))
        names = list(npz["metric_names"])
        assert npz["metric_units"][names.index("overshoot")] == "-"


def test_an_unstable_run_is_a_failed_run_and_a_bad_controller_a_422(db_path):
    with studies_api(db_path) as c:
        # kp 1500 with a 5000 integral: the 4 kg piston slams between the end stops (the
        # unstable case of tests/control/test_closed_loop.py), stored as a failed run
        b = body(gains={"kp": 1500.0, "ki": 5000.0})
        b["scenario"]["controller"]["setpoint"] = [[0, 0.1], [0.05, 0.15]]
        b["scenario"]["duration"] = 1.0
        b["parameters"] = {"jack.moving_mass": {"grid": [4.0]}}
        p = c.post("/api/studies", json=b).json()
        job, _ = wait_job(c, p["job_id"])
        assert job["status"] == "done", job
        res = c.get(f"/api/studies/{p['id']}/results").json()
        assert res["failed"] == 1
        assert "unstable" in res["runs"]["error"][0]
        n_before = len(c.get("/api/studies").json())
        assert_field_error(c.post("/api/studies", json=body(gains={"kp": -1.0})),
                           "scenario.controller.gains.kp", msg_contains="[1/m]")
        bad = body()
        bad["metrics"] = ["t95"]          # an open-loop metric: not the loop's
        assert_field_error(c.post("/api/studies", json=bad), "metrics[0]")
        assert len(c.get("/api/studies").json()) == n_before      # nothing stored
