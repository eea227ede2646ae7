"""The records of one analysis prepared once (issue 43, structure): weights, sample period and
the long records' window derived once and read by every stage, with the same values the
stages derived each for itself."""
import pickle

import numpy as np
import pytest

from pneucore import model_preset
from pneucore.analysis import calibrate as C
from pneucore.analysis.diagnosis import stages as S
from pneucore.analysis.records import Records, prepared
from pneucore.data.synthetic import synthetic_experiments
from pneucore.description.model import Model


@pytest.fixture(scope="module")
def exps():
    return synthetic_experiments(Model.from_dict(model_preset("paper-4way")), seed=3)


def test_the_records_hold_what_each_stage_derived_for_itself(exps):
    from pneucore.data.experiment import as_experiments
    plain = as_experiments(exps)
    rec = Records(plain)
    assert list(rec) == plain and prepared(rec) is rec
    # the same weights as an objective on the plain list derives, and the same period
    assert rec.sigma == C.Objective(None, plain, []).sigma
    assert S.sample_period(rec) == S.sample_period(plain) > 0.0
    # an objective starts from a copy: a fit's reweighting leaves the records' weights alone
    obj = C.Objective(None, rec, [])
    assert obj.sigma == rec.sigma and obj.sigma is not rec.sigma
    obj.sigma[0][next(iter(obj.sigma[0]))] *= 10.0
    assert rec.sigma == C.Objective(None, plain, []).sigma


def test_a_long_records_window_is_cut_once_and_is_the_same_cut(exps):
    from pneucore.data.experiment import as_experiments
    plain = as_experiments(exps)
    rec = Records(plain)
    total = sum(C._duration(e) for e in plain)
    seconds = 0.5 * total   # short enough that every record is cut
    w1, w2 = C.window(rec, seconds), C.window(rec, seconds)
    assert isinstance(w1, Records) and w1 is w2
    again = C.window(plain, seconds)
    assert [e.times.size for e in w1] == [e.times.size for e in again]
    for a, b in zip(w1, again):
        for s in a.signals:
            np.testing.assert_array_equal(a.measurement.signals[s], b.measurement.signals[s])
    assert C.window(rec, 2 * total) is None


def test_the_records_travel_to_a_worker_without_their_windows(exps):
    from pneucore.data.experiment import as_experiments
    rec = Records(as_experiments(exps))
    rec.sigma, C.window(rec, 0.5)
    back = pickle.loads(pickle.dumps(rec))
    assert isinstance(back, Records) and len(back) == len(rec)
    assert back.sigma == rec.sigma and back._windows == {}


def test_a_model_replayed_again_comes_from_the_cache_with_the_same_values(exps):
    from pneucore.analysis.compare import replay
    from pneucore.data.experiment import as_experiments
    rec = Records(as_experiments(exps))
    model = Model.from_dict(model_preset("paper-4way"))
    first = rec.replayed(model)
    assert rec.cache.misses == len(rec) and rec.cache.hits == 0
    # the same model built anew (equal plain form) is a hit, the very replays come back
    again = rec.replayed(Model.from_dict(model_preset("paper-4way")))
    assert rec.cache.hits == len(rec) and all(a is b for a, b in zip(first, again))
    # and they are what a replay without the cache gives, to the last bit (the core is
    # deterministic: equality, no tolerance)
    for rp, e in zip(first, rec):
        fresh = replay(model, e)
        for s in rp.simulated:
            np.testing.assert_array_equal(rp.simulated[s], fresh.simulated[s])
    # another model is another entry; a window and a subset share the cache
    other = model.copy()
    other.heat.coefficient *= 1.5
    rec.replayed(other)
    assert rec.cache.misses == 2 * len(rec)
    sub = rec.subset([1])
    assert sub.cache is rec.cache and sub.replayed(model)[0] is first[1]
    assert sub.sigma == [rec.sigma[1]]


def test_the_cache_keeps_a_bounded_number_of_samples():
    from types import SimpleNamespace
    from pneucore.analysis.records import ReplayCache
    cache = ReplayCache(limit=250)
    e = object()
    for k in range(5):
        cache.put(str(k), e, SimpleNamespace(t=np.zeros(100)))
    # two of 100 samples fit under 250: the oldest three were dropped, the newest kept
    assert cache.get("0", e) is None and cache.get("2", e) is None
    assert cache.get("3", e) is not None and cache.get("4", e) is not None
    # a replay longer than the whole limit is not kept at all
    cache.put("big", e, SimpleNamespace(t=np.zeros(300)))
    assert cache.get("big", e) is None
    # a record with the same id but not the same object is a miss
    assert cache.get("4", object()) is None


def test_a_fit_through_the_cache_is_the_fit_without_it(exps):
    """The objective reads replays through the records' cache: the fit's values equal to the last
    digit those of the same fit on the plain list (no cache)."""
    from pneucore.data.experiment import as_experiments
    from pneucore.description.paths import ParameterSpec
    model = Model.from_dict(model_preset("paper-4way"))
    model.jack.moving_mass *= 1.2
    specs = [ParameterSpec("jack.moving_mass", model.jack.moving_mass, 0.1, 10.0, True, "kg")]
    plain = as_experiments(exps)
    a = C.fit(model, plain, specs, max_nfev=8, compute_before=False)
    rec = Records(as_experiments(exps))
    b = C.fit(model, rec, specs, max_nfev=8, compute_before=False)
    assert a.values == b.values
    assert rec.cache.hits > 0   # the end point, simulated again to summarise it, was a hit


def test_a_model_that_is_not_plain_json_is_replayed_without_the_cache(exps, monkeypatch):
    """A key from a repr could elide an array's middle and give two models one key: such a model
    is never cached (replayed each time)."""
    from pneucore.analysis import records as Rm
    from pneucore.data.experiment import as_experiments
    rec = Records(as_experiments(exps))
    model = Model.from_dict(model_preset("paper-4way"))
    plain = model.to_dict
    monkeypatch.setattr(type(model), "to_dict", lambda self: {**plain(), "odd": np.arange(3)})
    assert Rm.model_key(model) is None
    a, b = rec.replayed(model), rec.replayed(model)
    assert rec.cache.hits == 0 and rec.cache.misses == 0 and a[0] is not b[0]


def test_a_locked_record_shares_its_replay_with_models_that_differ_in_what_it_never_reads(exps):
    """A locked record's replay is the same to the last bit whatever the friction coefficients,
    the moving mass and the load (the core reads them only for a sliding piston): the cache
    hands the one replay to models differing there, and a free record is replayed anew."""
    from pneucore.analysis.compare import SUMMARY_SERIES, replay
    from pneucore.analysis.records import LOCKED_UNREAD, replay_key
    from pneucore.data.experiment import as_experiments
    from pneucore.description.paths import get_value, set_values
    rec = Records(as_experiments(exps))
    locked = [i for i, e in enumerate(rec) if e.scenario.get("locked")]
    free = [i for i, e in enumerate(rec) if not e.scenario.get("locked")]
    assert locked and free
    model = Model.from_dict(model_preset("paper-4way"))
    first = rec.replayed(model)
    # every field left out of a locked record's key, moved: each coefficient of each direction
    d = model.to_dict()
    paths = [f"{sec}.{f}.{k}" if isinstance(d[sec][f], dict) else f"{sec}.{f}"
             for sec, fields in LOCKED_UNREAD.items() for f in fields
             for k in (d[sec][f] if isinstance(d[sec][f], dict) else [None])]
    paths = [p.removesuffix(".None") for p in paths]
    assert "friction.extend.fc0" in paths and "jack.moving_mass" in paths
    other = set_values(model, {p: 1.3 * get_value(model, p) + 1.0 for p in paths})
    misses = rec.cache.misses
    again = rec.replayed(other)
    assert rec.cache.misses == misses + len(free)
    for i in locked:
        assert again[i] is first[i]
        # what a replay without the cache gives on the other model: the same, to the last bit
        # (the signals, the series a summary keeps, the modes and the events)
        fresh = replay(other, rec[i])
        for s in rec[i].signals:
            np.testing.assert_array_equal(first[i].simulated[s], fresh.simulated[s])
        for s in SUMMARY_SERIES:
            np.testing.assert_array_equal(first[i].result.observed(s), fresh.result.observed(s))
        assert list(first[i].result.mode) == list(fresh.result.mode)
        assert first[i].result.events == fresh.result.events
    for i in free:
        assert again[i] is not first[i]
        assert replay_key(model, rec[i]) != replay_key(other, rec[i])
    # anything else the locked record reads is another entry (the heat coefficient)
    hot = model.copy()
    hot.heat.coefficient *= 1.5
    assert all(replay_key(hot, rec[i]) != replay_key(model, rec[i]) for i in locked)
