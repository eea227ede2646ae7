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
