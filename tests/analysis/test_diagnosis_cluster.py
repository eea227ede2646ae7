"""A diagnosis whose candidate refits run on a Dask cluster (issue 26): the same verdict and
the same fitted values as on this machine's threads, on the hidden-leak case of
tests/analysis/test_diagnosis_stages.py, with the model, the experiments and the null
pickled to worker processes of a LocalCluster (the study tests' fixture) and back."""
import time

import pytest

from dask_cluster import local_cluster

from pneucore.analysis.diagnose import diagnose
from pneucore.analysis.diagnosis import stages as S
from pneucore.analysis.history import refine
from pneucore.study import SchedulerError

from test_diagnosis_stages import _leak_case, _leak_stages, _quiet

#: Relative agreement of a fitted value computed on a Dask worker process with the same fit on
#: this process's threads: the same arithmetic from the same pickled inputs, with one BLAS
#: thread on both sides; only a different summation order in a library could move the last
#: digits (1e-9 is a million times above double round-off, far below any fit's tolerance)
SAME_RTOL = 1e-9


@pytest.fixture(scope="module")
def client():
    """A Client on a LocalCluster of two single-threaded worker processes (the tests' own)."""
    import distributed
    cluster = local_cluster(2)
    c = distributed.Client(cluster, set_as_default=False)
    yield c
    c.close()
    cluster.close()


def _values(cal):
    return {p: v["value"] for p, v in cal.values.items()}


def test_the_refits_on_the_cluster_are_those_of_the_threads(client):
    st = _leak_stages()
    model, exps, _ = _leak_case()
    calls = []
    remote = S.joint_refits(model, exps, st["null"], st["lead"], 30,
                            lambda f, s: calls.append((f, s)), client)
    assert list(remote) == list(st["refits"]) == list(st["lead"])   # the same order
    for name, cal in st["refits"].items():
        other = remote[name]
        assert set(_values(other)) == set(_values(cal))
        for p, v in _values(cal).items():
            assert _values(other)[p] == pytest.approx(v, rel=SAME_RTOL, abs=1e-300), (name, p)
        assert other.error_after.overall == pytest.approx(cal.error_after.overall, rel=SAME_RTOL)
    # the caller's progress callback ran while the tasks did (the time limit is checked there)
    assert calls and all("Dask cluster" in s for _, s in calls)


def test_a_diagnosis_on_the_cluster_names_the_same_effect_with_the_same_values(client):
    model, exps, _ = _leak_case()
    kw = dict(base_hypotheses=False, n_refit=3)   # the null held: the refits are the work
    local = diagnose(model, exps, **kw)
    remote = diagnose(model, exps, scheduler=client, **kw)
    assert remote.verdict == local.verdict == "piston_leakage"
    assert [r["effect"] for r in remote.ranking] == [r["effect"] for r in local.ranking]
    for a, b in zip(local.ranking, remote.ranking):
        for p, v in a["params"].items():
            for k in ("value", "stderr"):
                assert b["params"][p][k] == pytest.approx(v[k], rel=SAME_RTOL), (a["effect"], p, k)
        assert b["delta_bic"] == pytest.approx(a["delta_bic"], rel=SAME_RTOL)
    assert remote.message == local.message


def test_a_refinement_reaches_the_cluster_once_for_all_its_rounds(client):
    model, exps, _ = _leak_case()
    final_l, _, diags_l = refine(model, exps, max_rounds=1)
    final_r, _, diags_r = refine(model, exps, max_rounds=1, scheduler=client)
    assert [d.verdict for d in diags_r] == [d.verdict for d in diags_l]
    assert final_r.effects["piston_leakage"]["conductance"] == pytest.approx(
        final_l.effects["piston_leakage"]["conductance"], rel=SAME_RTOL)


def test_a_progress_callback_that_stops_cancels_the_cluster_refits(client):
    st = _leak_stages()
    model, exps, _ = _leak_case()

    class Stop(Exception):
        pass

    def stop(fraction, step):
        raise Stop(step)

    with pytest.raises(Stop, match="Dask cluster"):
        S.joint_refits(model, exps, st["null"], st["lead"], 30, stop, client)
    # nothing of this call is left on the cluster (cancelled and released)
    deadline = time.monotonic() + 10.0   # the scheduler forgets released tasks within ms; 10 s: a loaded machine
    while client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks)) and \
            time.monotonic() < deadline:
        time.sleep(0.1)
    assert client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks)) == 0


def test_an_unreachable_scheduler_is_a_clear_error_naming_it():
    model, exps, _ = _leak_case()
    # port 9 (discard) on localhost: nothing listens there
    with pytest.raises(SchedulerError) as err:
        diagnose(model, exps, base_hypotheses=False, scheduler="tcp://127.0.0.1:9",
                 scheduler_timeout=0.5)
    assert err.value.path == "scheduler"
