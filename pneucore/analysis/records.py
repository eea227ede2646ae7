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
  :class:`Records`.

It is a list of the experiments (every function that takes a list of experiments takes it);
:class:`pneucore.analysis.calibrate.Objective` starts from its weights (a copy: a fit
reweights its own), :func:`pneucore.analysis.calibrate.window` answers from its cache, and
:func:`pneucore.analysis.diagnosis.stages.sample_period` reads its period. A slice or a
subset (one experiment fitted alone, a fold with a block held out) is a plain list again and
derives its own.
"""
from __future__ import annotations

import numpy as np


class Records(list):
    """The experiments of one analysis with what every stage reads of them, prepared once.

    Parameters
    ----------
    experiments : iterable of Experiment
        Prepared experiments (:func:`pneucore.data.experiment.as_experiments`) [-]
    """

    def __init__(self, experiments):
        super().__init__(experiments)
        self._sigma = None
        self._period = None
        self._windows = {}

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
            self._windows[seconds] = None if short is None else Records(short)
        return self._windows[seconds]

    def __getstate__(self):
        # sent to a Dask worker: the experiments and their weights; the windows are cut again
        # there if needed (each holds a copy of every cut record)
        return {"_sigma": self._sigma, "_period": self._period, "_windows": {}}

    def __setstate__(self, state):
        self.__dict__.update(state)

    def __reduce_ex__(self, protocol):
        return (Records, (list(self),), self.__getstate__())


def prepared(experiments):
    """``experiments`` as :class:`Records` (itself when it is one already)."""
    return experiments if isinstance(experiments, Records) else Records(experiments)
