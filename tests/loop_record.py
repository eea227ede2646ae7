"""A synthetic record shaped like issue 39's real one (shared by the loop tests).

A vertical 25 mm jack (rod up, ``mounting_angle`` 90 deg) lifting 1.47 kg by short pulses of a
3/2 valve, chamber B vented; recorded as the rig writes it: no command column, chamber A's
pressure in raw volts (gauge, :data:`GAIN_BAR_PER_V` bar/V), the position in mm, 1 kHz. The
valve switches :data:`SWITCH_DELAY` after its command: the record's pressure turns at
``command + SWITCH_DELAY`` (the truth is simulated with those instants), which is where a
proposed command's edges must lie (within two samples) for a model without switching time.
"""
from __future__ import annotations

import functools

import numpy as np

from pneucore.data.measurement import Measurement
from pneucore.data.synthetic import synthesize
from pneucore.description.model import Model
from pneucore.description.presets import model_preset

#: Sensor gain [bar/V] of the gauge pressure transducer
GAIN_BAR_PER_V = 2.0
#: The valve's switching time after its command [s]: 4 ms, "a few milliseconds"
SWITCH_DELAY = 0.004
#: Commanded pulses ``(t_open, width)`` [s]: short pulses, each lifting the load a little
COMMANDED = [(0.2, 0.020), (1.3, 0.030), (2.6, 0.025), (3.8, 0.035)]
#: Record length [s]
DURATION = 4.6
#: Sample period [s]
DT = 0.001


def truth_dict():
    """The true jack (JSON): 25 mm bore, 10 mm rod, 100 mm stroke, 1.47 kg, vertical, B vented,
    4.8 bar gauge supply."""
    d = model_preset("paper-3way")
    d["name"] = "vertical-25mm"
    d["jack"].update({"bore": 0.025, "rod_a": 0.010, "rod_b": 0.010, "stroke": 0.1,
                      "dead_volume_a": 4e-6, "dead_volume_b": 4e-6, "moving_mass": 1.47,
                      "mounting_angle": 90.0})
    d["valve"]["b_chamber"] = "vented"
    d["supply"]["pressure"] = 101300.0 + 4.8e5
    # a small valve (1 mm nozzle): the chamber fills in tens of ms
    for port in d["valve"]["ports"].values():
        port["C"] = [0.4 * c for c in port["C"]]
    return d


def effective_edges():
    """The instants the valve really switched ``[[t_open, t_close], ...]`` [s] (sample times)."""
    return [[round(t + SWITCH_DELAY, 6), round(t + w + SWITCH_DELAY, 6)] for t, w in COMMANDED]


@functools.lru_cache(maxsize=None)
def _measurement():
    m = Model.from_dict(truth_dict())
    cmd = [[0.0, 0.0]]
    for a, b in effective_edges():
        cmd += [[a, 1.0], [b, 0.0]]
    meas = synthesize(m, {"command": cmd, "duration": DURATION, "x0": 0.0, "sample_period": DT},
                      signals=("p_a", "x"), seed=3)
    return meas


def record():
    """The record as SI :class:`Measurement` without ``u`` (a fresh copy)."""
    meas = _measurement()
    sig = {k: v.copy() for k, v in meas.signals.items() if k != "u"}
    return Measurement(meas.t.copy(), sig, name="vertical-25mm").validate()


def record_csv():
    """The record as the rig writes it: ``time_s, pA_V`` (gauge volts), ``pos_mm``; the time
    column as ``n * dt`` (its last sample a rounding past the duration)."""
    meas = _measurement()
    amb = 101300.0
    volts = np.maximum(meas.signals["p_a"] - amb, 0.0) / 1e5 / GAIN_BAR_PER_V
    t = np.arange(meas.t.size) * DT
    rows = [f"{float(a)!r},{v:.6f},{x * 1e3:.5f}" for a, v, x in zip(t, volts, meas.signals["x"])]
    return "time_s,pA_V,pos_mm\n" + "\n".join(rows) + "\n"


#: The upload mapping of :func:`record_csv`
MAPPING = {"time_s": "t",
           "pA_V": {"signal": "p_a", "unit": "bar", "gain": GAIN_BAR_PER_V, "offset": 0.0,
                    "reference": "gauge", "raw_unit": "V"},
           "pos_mm": "x[mm]"}
