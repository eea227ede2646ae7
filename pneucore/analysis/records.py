"""The records of one analysis, prepared once and read by every stage.

A diagnosis follows the same experiments through a dozen stages and a hundred fits: the base
hypotheses' sensitivities, the null fit, the score pass, the joint refits, the evidence, the
held-out and per-experiment fits, the findings. Each used to derive what it needed from the
experiments again: the weights of each measured signal (its noise level, or the accuracy the
record states), the finest sample period, and, on long records, the window of their first
seconds that a fit starts on (cut anew by every fit, each cut experiment estimating its
noise and initial state anew). :class:`Records` holds them once:

- ``sigma``: the standard deviation each signal's residual is divided by
  (:func:`pneucore.analysis.calibrate.signal_sigmas`), one dict per experiment;
- ``sample_period``: the finest sample period of the records [s];
- :meth:`Records.window`: the records cut to their first seconds
  (:func:`pneucore.analysis.calibrate.window`), cut once per length and itself a
  :class:`Records`;
- :meth:`Records.subset`: some of the experiments (one fitted alone, the others when one is
  left out), with their weights as found for the whole;
- :meth:`Records.replayed`: the experiments replayed on a model, kept for the next stage that
  asks for the same model (the replay cache, shared by the records, their windows and subsets).

It is a list of the experiments (every function that takes a list of experiments takes it);
:class:`pneucore.analysis.calibrate.Objective` starts from its weights (a copy: a fit
reweights its own) and replays through its cache, :func:`pneucore.analysis.calibrate.window`
answers from its windows, and :func:`pneucore.analysis.diagnosis.stages.sample_period` reads
its period. A plain slice is a plain list again and derives its own; a record with a block of
samples masked (:func:`pneucore.analysis.diagnosis.evidence.masked`) is a new record with
weights of its own.

**The replay cache.** A diagnosis fits the same records from a hundred starting points; a
finite-difference column whose step meets a bound, a refit that starts where another ended,
and a stage that replays a model another stage fitted ask for a model that was simulated
already (4-7 % of the replays of a foreign case's diagnosis, measured). A replay is a pure
function of the model and the record, so the one kept serves (the compiled core is
deterministic: the same floats in, the same floats out). Keys are the model's plain form (as the
record reads it, below), found in 0.04 ms against 0.5-50 ms a replay; the cache holds at most :data:`REPLAY_CACHE_SAMPLES`
samples of replays, the oldest dropped first. Replays are read, never changed, by those who get
them (as the two an objective keeps of its last evaluations always were); an objective that
adds a sensor's gain to the simulated signals replays without the cache.

**What a record reads of a model.** The key of a record's replay is the model as that record
reads it (:func:`replay_key`): with the load and supply pressure the experiment declares in
place of the model's (:meth:`pneucore.data.experiment.Experiment.model_for`), and, on a record
whose piston is locked, without the piston's dynamics (:data:`LOCKED_UNREAD`: the friction
coefficients, the moving mass, the load), which the core reads only for the piston's
acceleration and its static limits, never in the locked mode. Two models that differ there
replay such a record alike to the last bit, so a finite-difference column in a friction
coefficient or the mass replays the free records alone: on the circuit rig measured apart
(``benchmarks/bench_diagnosis_confusion.py --apart``: a 1 s locked hold beside 1 s of free
pulses, 11-13 parameters fitted) 16-21 % of a round's replays, the locked hold's, which cost a
third of a free record's.
"""
from __future__ import annotations

import json
import threading
from collections import OrderedDict

import numpy as np

#: Samples of replays the cache keeps, over all its entries [-]: a replay keeps its measured
#: and simulated signals, the time and the command (about ten 8-byte numbers a sample), so
#: 400,000 samples are about 32 MB, 2 % of one diagnosis's memory estimate at the API's cost
#: limit (9,700 B a sample over 200,000 samples, docs/guides/memory.md); two 1 s records at
#: 1 kHz keep about 200 models, a 120 s record a few
REPLAY_CACHE_SAMPLES = 400_000


class ReplayCache:
    """Replays by (model, record), the oldest dropped past :data:`REPLAY_CACHE_SAMPLES`;
    safe for the fits' threads."""

    def __init__(self, limit=REPLAY_CACHE_SAMPLES):
        self.limit = int(limit)
        self._entries = OrderedDict()     # (model key, id(record)) -> (record, replay, samples)
        self._samples = 0
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0

    def get(self, key, experiment):
        with self._lock:
            hit = self._entries.get((key, id(experiment)))
            if hit is None or hit[0] is not experiment:   # an id reused by a new record
                self.misses += 1
                return None
            self._entries.move_to_end((key, id(experiment)))
            self.hits += 1
            return hit[1]

    def put(self, key, experiment, rp):
        n = int(np.asarray(rp.t).size)
        if n > self.limit:
            return
        with self._lock:
            k = (key, id(experiment))
            if k in self._entries:
                return
            self._entries[k] = (experiment, rp, n)
            self._samples += n
            while self._samples > self.limit:
                _, (_, _, m) = self._entries.popitem(last=False)
                self._samples -= m


#: What the compiled core never reads of a model on a record whose piston is locked (the
#: scenario's ``locked``: the core's mode ``MODE_LOCKED``, which no event leaves), as
#: ``{section of the model's plain form: its fields}``: the friction coefficients of each
#: direction, the moving mass and the load reach only the piston's acceleration (the sliding
#: modes) and the net force and static limits written beside the states
#: (:func:`pneucore.core.rhs.rhs`), never a state's derivative. A locked record's replay is
#: therefore the same, bit for bit, whatever they are (``tests/analysis/test_records.py``)
LOCKED_UNREAD = {"friction": ("extend", "retract"), "jack": ("moving_mass", "load_force")}
#: Signals a locked record's replay holds unchanged by :data:`LOCKED_UNREAD`: states, or the
#: chambers' pressures made of them (a rod force, say, is the net force: not among them)
LOCKED_SIGNALS = frozenset({"p_a", "p_b", "x", "v", "T_a", "T_b", "m_a", "m_b"})


def replay_key(model, experiment, plain=None, memo=None):
    """The plain form of ``model`` as ``experiment`` reads it, as one string (:func:`model_key`
    of :meth:`pneucore.data.experiment.Experiment.model_for`, the fields of
    :data:`LOCKED_UNREAD` left out on a locked record whose compared signals and kept series
    are all among :data:`LOCKED_SIGNALS`): equal for models whose replays of the record are
    equal; None where the model is not plain JSON [-].

    ``plain``: ``model.to_dict()`` already made, and ``memo`` a dict kept over the records of
    one replay of ``model`` (the records that read the model as it is share their two keys,
    each serialised once: a lumped model's replay costs 0.5 ms, its key 0.04 ms)."""
    m = experiment.model_for(model)
    locked = _locked_alike(experiment)
    shared = m is model
    if shared and memo is not None and locked in memo:
        return memo[locked]
    try:
        d = plain if shared and plain is not None else m.to_dict()
        if locked:
            d = dict(d)
            for section, fields in LOCKED_UNREAD.items():
                part = d.get(section)
                if isinstance(part, dict):
                    d[section] = {k: v for k, v in part.items() if k not in fields}
        key = json.dumps(d, sort_keys=True, allow_nan=True)
    except (TypeError, ValueError):
        key = None
    if shared and memo is not None:
        memo[locked] = key
    return key


def _locked_alike(experiment):
    """Whether ``experiment`` is a locked record whose replay :data:`LOCKED_UNREAD` leaves
    unchanged: locked, and every signal it compares and every series a summarised replay keeps
    (:data:`pneucore.analysis.compare.SUMMARY_SERIES`) among :data:`LOCKED_SIGNALS` [-]."""
    from pneucore.analysis.compare import SUMMARY_SERIES
    scenario = experiment.scenario
    locked = scenario.get("locked", False) if isinstance(scenario, dict) else \
        getattr(scenario, "locked", False)
    return bool(locked) and LOCKED_SIGNALS.issuperset(experiment.signals) and \
        LOCKED_SIGNALS.issuperset(SUMMARY_SERIES)


def model_key(model):
    """The plain form of ``model`` as one string: equal for models that simulate alike; None
    where it holds something that is not plain JSON (such a model is not cached: a repr may
    elide an array's middle, and two models would share a key) [-]."""
    try:
        return json.dumps(model.to_dict(), sort_keys=True, allow_nan=True)
    except (TypeError, ValueError):
        return None


class Records(list):
    """The experiments of one analysis with what every stage reads of them, prepared once.

    Parameters
    ----------
    experiments : iterable of Experiment
        Prepared experiments (:func:`pneucore.data.experiment.as_experiments`) [-]
    """

    def __init__(self, experiments, cache=None):
        super().__init__(experiments)
        self._sigma = None
        self._period = None
        self._windows = {}
        self._cache = cache if cache is not None else ReplayCache()

    @property
    def sigma(self):
        """``[{signal: sigma [SI unit of the signal]}]``, one per experiment: the weights of a
        fit on these records (:func:`pneucore.analysis.calibrate.signal_sigmas`), found once.
        Callers that change weights copy them first."""
        if self._sigma is None:
            from pneucore.analysis.calibrate import signal_sigmas
            self._sigma = [signal_sigmas(e) for e in self]
        return self._sigma

    @property
    def sample_period(self):
        """The finest sample period of the records (their median spacing) [s]; 0 when no
        record has two samples."""
        if self._period is None:
            dts = [float(np.median(np.diff(e.times))) for e in self if e.times.size > 1]
            self._period = min(dts) if dts else 0.0
        return self._period

    def window(self, seconds):
        """The records cut to their first ``seconds`` in all [s] (:func:`pneucore.analysis.
        calibrate.window`), as :class:`Records`, or None when they hold no more; cut once."""
        if seconds not in self._windows:
            from pneucore.analysis.calibrate import cut_window
            short = cut_window(list(self), seconds)
            self._windows[seconds] = None if short is None else Records(short, self._cache)
        return self._windows[seconds]

    def subset(self, indices):
        """The experiments at ``indices`` as :class:`Records`, with their weights as found for
        these records and the same replay cache [-]."""
        indices = [int(i) for i in indices]
        out = Records([self[i] for i in indices], self._cache)
        if self._sigma is not None:
            out._sigma = [self._sigma[i] for i in indices]
        return out

    def replayed(self, model):
        """Each experiment replayed on ``model`` (:func:`pneucore.analysis.compare.replay`,
        the core's outputs dropped), taken from the cache where the same model was replayed on
        the same record already [-]. The replays are to be read, not changed."""
        from pneucore.analysis.compare import replay
        out = []
        try:
            plain = model.to_dict()
        except (TypeError, ValueError):
            plain = None
        memo = {}
        for e in self:
            # the model as this record reads it: a locked record shares its replay with the
            # models that differ only in what it never reads
            key = replay_key(model, e, plain, memo)
            rp = None if key is None else self._cache.get(key, e)
            if rp is None:
                rp = replay(model, e).drop_core_outputs()
                if key is not None:
                    self._cache.put(key, e, rp)
            out.append(rp)
        return out

    @property
    def cache(self):
        """The replay cache these records share with their windows and subsets."""
        return self._cache

    def __getstate__(self):
        # sent to a Dask worker: the experiments and their weights; the windows are cut again
        # there if needed (each holds a copy of every cut record), the replays made again
        return {"_sigma": self._sigma, "_period": self._period, "_windows": {}}

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._cache = ReplayCache()

    def __reduce_ex__(self, protocol):
        return (Records, (list(self),), self.__getstate__())


def prepared(experiments):
    """``experiments`` as :class:`Records` (itself when it is one already)."""
    return experiments if isinstance(experiments, Records) else Records(experiments)
