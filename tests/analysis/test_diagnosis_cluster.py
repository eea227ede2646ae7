"""A diagnosis whose candidate refits run on a Dask cluster (issue 26): the same verdict and
the same fitted values as on this machine's threads, on the hidden-leak case of
tests/analysis/test_diagnosis_stages.py, with the model, the experiments and the null
pickled to worker processes of a LocalCluster (the study tests' fixture) and back; so are
the sensitivities and the per-experiment consistency fits; a cluster lost midway is given up
as a study gives it up, and the diagnosis ends on this machine."""
import dataclasses
import functools
import time

import numpy as np
import pytest

from dask_cluster import local_cluster

from pneucore.analysis import parallel as P
from pneucore.analysis.diagnose import diagnose
from pneucore.analysis.diagnosis.evidence import consistency
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
    with P.running(client):
        remote = S.joint_refits(model, exps, st["null"], st["lead"], 30,
                                lambda f, s: calls.append((f, s)))
    assert list(remote) == list(st["refits"]) == list(st["lead"])   # the same order
    for name, cal in st["refits"].items():
        other = remote[name]
        assert set(_values(other)) == set(_values(cal))
        for p, v in _values(cal).items():
            assert _values(other)[p] == pytest.approx(v, rel=SAME_RTOL, abs=1e-300), (name, p)
        assert other.error_after.overall == pytest.approx(cal.error_after.overall, rel=SAME_RTOL)
    # the caller's progress callback ran while the tasks did (the time limit is checked there)
    assert calls and all("Dask cluster" in s for _, s in calls)


#: The null held: the refits are the work
SMALL = dict(base_hypotheses=False, n_refit=3)


@functools.lru_cache(maxsize=None)
def _local_small():
    """The leak case's diagnosis (:data:`SMALL`) on this machine's threads, the reference."""
    model, exps, _ = _leak_case()
    return diagnose(model, exps, **SMALL)


def test_a_diagnosis_on_the_cluster_names_the_same_effect_with_the_same_values(client):
    model, exps, _ = _leak_case()
    kw = SMALL
    local = _local_small()
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


def test_a_refinements_rounds_share_one_runner_and_a_lost_cluster_stays_lost(monkeypatch):
    """Every round of a refinement runs on the runner it opened (the cluster reached and probed
    once); a cluster lost in one round is not tried again by the next: its work runs here."""
    from pneucore.analysis import history
    model, exps, _ = _leak_case()
    seen = []

    def one_round(m, e, scheduler=None, **kw):
        seen.append((scheduler, scheduler.on_cluster, P.current()))
        if len(seen) == 1:
            scheduler.lost = "the Dask cluster's scheduler has no worker (for 10 s)"
        # a round that proposes the model as it is: the loop goes on to the next round
        return dataclasses.replace(_local_small(), model=m, verdict="piston_leakage",
                                   recalibrate=[], initial_state=[], dropped=[],
                                   remaining={}) if len(seen) == 1 else \
            dataclasses.replace(_local_small(), verdict=None, recalibrate=[],
                                initial_state=[])
    monkeypatch.setattr(history, "diagnose", one_round)
    # a runner on a "cluster" nothing can reach: were any work sent to it, it would fail
    runner = P.Runner(client=object(), address=None)
    history.refine(model, exps, max_rounds=3, scheduler=runner, validated=True)
    assert len(seen) == 2
    assert all(r is runner and cur is runner for r, _, cur in seen)
    assert [on for _, on, _ in seen] == [True, False]   # lost in round 1, not tried in round 2
    assert P.current() is None                          # nothing left current after it


def test_a_progress_callback_that_stops_cancels_the_cluster_refits(client):
    st = _leak_stages()
    model, exps, _ = _leak_case()

    class Stop(Exception):
        pass

    def stop(fraction, step):
        raise Stop(step)

    with pytest.raises(Stop, match="Dask cluster"), P.running(client):
        S.joint_refits(model, exps, st["null"], st["lead"], 30, stop)
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


# ------------------------------------------------------------------ the other pieces of work

def _recorder():
    steps = []
    return steps, lambda f, s: steps.append(s)


def test_the_sensitivities_on_the_cluster_are_those_of_the_threads(client):
    """The base hypotheses' sensitivity columns and the score pass (its probes' LM statistics)
    computed as Dask tasks equal those of this machine's threads."""
    model, exps, _ = _leak_case()
    st = _leak_stages()
    rps = st["rps"]
    here = S.base_hypotheses(model, exps, st["cands"], [], (), True, rps, _quiet)
    # the null's own sensitivities need fitted base parameters: the chosen ones, at the model
    null = dataclasses.replace(st["null"], specs=list(here.auto_specs))
    Ju = S.uncertain_sensitivities(exps, null)
    steps, rec = _recorder()
    with P.running(client, report=rec):
        there = S.base_hypotheses(model, exps, st["cands"], [], (), True, rps, _quiet)
        score = S.candidate_scores(model, exps, st["null"], st["cands"], _quiet)
        Ju_there = S.uncertain_sensitivities(exps, null)
    assert any("base hypotheses (on the Dask cluster)" in s for s in steps)   # it went there
    assert any("score test (on the Dask cluster)" in s for s in steps)
    assert any("base parameters (on the Dask cluster)" in s for s in steps)
    assert Ju.shape == Ju_there.shape and Ju.shape[1] == len(here.auto_specs) >= 1
    assert np.allclose(Ju_there, Ju, rtol=SAME_RTOL, atol=0.0)
    assert set(there.id_cols) == set(here.id_cols) and here.id_cols
    for p, col in here.id_cols.items():
        assert np.allclose(there.id_cols[p], col, rtol=SAME_RTOL, atol=0.0), p
    assert [h.path for h in there.auto_specs] == [h.path for h in here.auto_specs]
    assert [s["effect"] for s in score] == [s["effect"] for s in st["score"]]
    for a, b in zip(st["score"], score):
        assert b["lm"] == pytest.approx(a["lm"], rel=SAME_RTOL, abs=1e-300), a["effect"]


def test_the_consistency_fits_on_the_cluster_are_those_of_the_threads(client):
    """Each experiment's fit of :func:`consistency` run as a Dask task gives the values and
    standard errors of the same fit on this machine's threads."""
    st = _leak_stages()
    model, exps, _ = _leak_case()
    name = st["verdict"]
    here = consistency(st["refits"][name], exps, name, 30)
    steps, rec = _recorder()
    with P.running(client, report=rec):
        there = consistency(st["refits"][name], exps, name, 30)
    assert any("consistency across experiments" in s and "Dask cluster" in s for s in steps)
    assert there["consistent"] == here["consistent"]
    assert set(there["per_experiment"]) == set(here["per_experiment"])
    assert sum(len(v) for v in here["per_experiment"].values()) >= 2   # estimates compared below
    for e, est in here["per_experiment"].items():
        assert set(there["per_experiment"][e]) == set(est)
        for p, v in est.items():
            for k in ("value", "stderr"):
                assert there["per_experiment"][e][p][k] == pytest.approx(v[k], rel=SAME_RTOL), (e, p, k)


def test_the_held_out_folds_on_the_cluster_are_those_of_the_threads(client):
    """The held-out folds (blocks in time, and experiments left out when they run) as Dask
    tasks: the same held-out energies as on this machine's threads."""
    st = _leak_stages()
    model, exps, _ = _leak_case()
    name = st["verdict"]
    here = S.held_out_evidence(model, exps, st["null"], name, st["refits"][name], 30)
    steps, rec = _recorder()
    with P.running(client, report=rec):
        there = S.held_out_evidence(model, exps, st["null"], name, st["refits"][name], 30)
    assert any("held-out blocks (on the Dask cluster)" in s for s in steps)
    assert there["used"] == here["used"]
    for key in ("folds", "experiment_folds"):
        assert len(there[key]) == len(here[key])
        for a, b in zip(here[key], there[key]):
            for k in ("null", "candidate"):
                assert b[k] == pytest.approx(a[k], rel=SAME_RTOL), (key, k)
    assert here["folds"]


# ------------------------------------------------------------------ a cluster lost midway

@pytest.mark.parametrize("failure", ["every worker gone", "scheduler dead"])
def test_a_cluster_lost_midway_is_given_up_and_the_diagnosis_ends_here(monkeypatch, failure):
    """As a study's (tests/study/test_study.py): with every Dask worker gone, or the scheduler
    itself dead, during the diagnosis's first tasks, the studies' probe gives the cluster up
    after their grace time; the diagnosis does not hang, finishes on this machine with the
    local answer, and says why (``cluster["lost"]``)."""
    from pneucore.study import execute as study_exec
    monkeypatch.setattr(study_exec, "CLUSTER_GRACE", 1.0)   # instead of 10 s: a faster test
    monkeypatch.setattr(study_exec, "PROBE_INTERVAL", 0.2)
    model, exps, _ = _leak_case()
    kw = SMALL
    local = _local_small()
    cluster = local_cluster(1)
    killed = []

    def progress(fraction, step):
        if "Dask cluster" in step and not killed:   # the first wait on the cluster's tasks
            killed.append(step)
            if failure == "every worker gone":
                cluster.scale(0)
            else:
                cluster.close()
    try:
        t0 = time.monotonic()
        d = diagnose(model, exps, scheduler=cluster.scheduler_address, scheduler_timeout=1.0,
                     progress=progress, **kw)
        assert time.monotonic() - t0 < 300.0   # a bound on a hang on a loaded machine, not a speed claim
    finally:
        cluster.close()
    assert killed
    # the probe finds no worker, or no answering scheduler; or the client first learns that
    # Dask cancelled the tasks (their inputs were on the retired worker; the connection to the
    # scheduler was lost): either is the cluster lost, and the message says which
    why = ("has no worker", "does not answer", "lost a task")
    lost = d.cluster["lost"]
    assert lost and any(w in lost for w in why), lost
    assert cluster.scheduler_address.split("://")[-1] not in lost   # no address in a report
    assert d.to_dict()["cluster"]["lost"] == d.cluster["lost"]
    assert d.verdict == local.verdict == "piston_leakage"
    for a, b in zip(local.ranking, d.ranking):
        assert a["effect"] == b["effect"]
        for p, v in a["params"].items():
            assert b["params"][p]["value"] == pytest.approx(v["value"], rel=SAME_RTOL), (a["effect"], p)


def test_the_health_probe_gives_up_a_scheduler_that_does_not_answer(monkeypatch):
    """The runner's probe (the studies' :func:`probe_scheduler` on a connection of its own):
    a scheduler that does not answer is tolerated for the grace time, then given up with a
    message naming it; a runner never probes more often than the studies' interval."""
    from pneucore.study import execute as study_exec
    monkeypatch.setattr(study_exec, "CLUSTER_GRACE", 0.3)   # instead of 10 s: a faster test
    monkeypatch.setattr(study_exec, "PROBE_INTERVAL", 0.0)
    # port 9 (discard) on localhost: nothing listens there
    r = P.Runner(client=object(), address="tcp://127.0.0.1:9", timeout=0.2)
    r.check()   # within the grace: no error yet
    time.sleep(0.4)
    with pytest.raises(P.ClusterLost, match="scheduler does not answer"):
        r.check()
    monkeypatch.setattr(study_exec, "PROBE_INTERVAL", 3600.0)
    r = P.Runner(client=object(), address="tcp://127.0.0.1:9", timeout=0.2)
    time.sleep(0.4)
    r.check()   # not probed again within the interval: nothing raised


def test_a_cluster_dead_before_the_work_is_handed_is_given_up_at_once():
    """A cluster that died between two batches of work (during a local stage): handing it the
    shared arguments is bounded by the scheduler timeout, not a hang; the batch runs here."""
    import operator

    import distributed
    cluster = local_cluster(1)
    c = distributed.Client(cluster, set_as_default=False)
    try:
        r = P.Runner(c, cluster.scheduler_address, timeout=1.0)
        assert r.map(operator.add, [1, 2], shared=(10,)) == [11, 12] and r.lost is None
        cluster.close()
        t0 = time.monotonic()
        assert r.map(operator.add, [1, 2], shared=(10,)) == [11, 12]
        assert time.monotonic() - t0 < 60.0   # a bound on a hang on a loaded machine, not a speed claim
        assert r.lost and not r.on_cluster
        assert r.map(operator.add, [3], shared=(10,)) == [13]   # no second try on a lost cluster
    finally:
        c.close(timeout=1.0)
        cluster.close()
