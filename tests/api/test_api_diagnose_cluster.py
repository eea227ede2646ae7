"""POST /api/diagnose, /api/refine, their jobs and reports with ``scheduler`` (issue 26): the
candidate refits run on the Dask cluster configured on the server when the request names it
("dask"), with the same answer as on this machine ("local"); an address, or a name not
configured here, is a 422 naming ``scheduler`` (a request never gives an address)."""
import time

import pytest
from fastapi.testclient import TestClient

from api_conftest import LEAK_IDS, api, assert_field_error, model
from app.config import Limits, Settings
from app.main import create_app
from dask_cluster import local_cluster

#: Relative agreement of a value fitted on a Dask worker with the same fit on this machine:
#: the same arithmetic from the same inputs (tests/analysis/test_diagnosis_cluster.py's SAME_RTOL)
SAME_RTOL = 1e-9

#: a bound on a hung job under a loaded machine, not a speed claim
WAIT_S = 300.0

PATHS = ("/api/diagnose", "/api/jobs/diagnose", "/api/refine", "/api/jobs/refine",
         "/api/reports/diagnose", "/api/reports/refine")


def _body(**extra):
    return {"model": model(), "experiments": [{"dataset_id": i} for i in LEAK_IDS], **extra}


@pytest.mark.parametrize("scheduler", ["tcp://127.0.0.1:9", "127.0.0.1:8786", "dask", "elsewhere"])
def test_an_address_or_an_unconfigured_cluster_is_refused_naming_scheduler(tmp_path, scheduler):
    with api(tmp_path / "a.sqlite3") as c:   # no Dask cluster configured
        for path in PATHS:
            r = c.post(path, json=_body(scheduler=scheduler))
            assert_field_error(r, "scheduler", msg_contains="'local'")
        # nothing was queued by the refused job requests
        assert c.app.state.jobs.active() == 0


def test_an_address_is_refused_even_where_a_cluster_is_configured(tmp_path):
    settings = Settings(db_path=str(tmp_path / "b.sqlite3"), limits=Limits(),
                        dask_scheduler="tcp://127.0.0.1:9")
    with TestClient(create_app(settings), base_url="http://127.0.0.1") as c:
        for path in PATHS:
            r = c.post(path, json=_body(scheduler="tcp://127.0.0.1:9"))
            assert_field_error(r, "scheduler")


def test_a_diagnosis_on_the_configured_cluster_answers_as_the_local_one(tmp_path):
    cluster = local_cluster(2)
    try:
        settings = Settings(db_path=str(tmp_path / "c.sqlite3"), limits=Limits(),
                            dask_scheduler=cluster.scheduler_address)
        with TestClient(create_app(settings), base_url="http://127.0.0.1") as c:
            # two candidates and a given uncertain path: a small diagnosis, two refits
            small = dict(candidates=["piston_leakage", "sensor_lag"], uncertain=["heat.coefficient"])
            here = c.post("/api/diagnose", json=_body(scheduler="local", **small))
            there = c.post("/api/diagnose", json=_body(scheduler="dask", **small))
            assert here.status_code == there.status_code == 200, (here.text[:400], there.text[:400])
            a, b = here.json(), there.json()
            assert a["verdict"] == b["verdict"] == "piston_leakage"
            # where it ran, without the server's address: the cluster, never lost here
            assert b["cluster"] == {"lost": None} and a.get("cluster") is None
            assert [r["effect"] for r in a["ranking"]] == [r["effect"] for r in b["ranking"]]
            for ra, rb in zip(a["ranking"], b["ranking"]):
                for p, v in ra["params"].items():
                    assert rb["params"][p]["value"] == pytest.approx(v["value"], rel=SAME_RTOL)
                assert rb["delta_bic"] == pytest.approx(ra["delta_bic"], rel=SAME_RTOL)
            # the same as a job on the cluster (the job runs where its request named)
            r = c.post("/api/jobs/diagnose", json=_body(scheduler="dask", **small))
            assert r.status_code == 202, r.text
            t0 = time.monotonic()
            while (job := c.get(f"/api/jobs/{r.json()['id']}").json())["status"] in ("queued", "running"):
                assert time.monotonic() - t0 < WAIT_S, job
                time.sleep(0.2)
            assert job["status"] == "done", job["error"]
            assert job["result"]["verdict"] == "piston_leakage"
            for p, v in a["ranking"][0]["params"].items():
                assert job["result"]["ranking"][0]["params"][p]["value"] == pytest.approx(
                    v["value"], rel=SAME_RTOL)
    finally:
        cluster.close()
