"""Synthetic measurements: the model with hidden effects, seen through imperfect sensors.

Used to test the diagnosis on data whose truth is known, and to make the
sample datasets. The acquisition imitates the paper's rig (Sect. 4): a
12-bit board on 0-10 bar pressure transducers and a 0-250 mm LVDT, plus
Gaussian noise.
"""
from __future__ import annotations

import copy
import math

import numpy as np

from .measurement import Measurement
from .model import Model
from .scenario import pulse_train
from .simulate import simulate

#: Sensor ranges of the paper's acquisition (0-10 bar transducers, 250 mm LVDT)
SENSOR_RANGES = {"p_a": (0.0, 10e5), "p_b": (0.0, 10e5), "x": (0.0, 0.25), "v": (-5.0, 5.0),
                 "T_a": (200.0, 500.0), "T_b": (200.0, 500.0)}
#: Default Gaussian noise standard deviations (SI units): ~1.2 LSB of the 12-bit board
DEFAULT_NOISE = {"p_a": 300.0, "p_b": 300.0, "x": 5e-5, "v": 1e-3, "T_a": 0.1, "T_b": 0.1}


def quantise(y, lo, hi, bits=12):
    """Quantise to a ``bits``-bit converter spanning ``[lo, hi]`` (clipped at the ends).

    Parameters
    ----------
    y : ndarray  Signal (SI)
    lo, hi : float  Converter range (SI)
    bits : int  Resolution [bit]

    Returns
    -------
    yq : ndarray  Quantised signal
    """
    step = (hi - lo) / (2 ** bits - 1)
    return lo + np.clip(np.round((np.asarray(y) - lo) / step), 0, 2 ** bits - 1) * step


def lsb(signal, bits=12):
    """Quantisation step of a signal's converter (SI units)."""
    lo, hi = SENSOR_RANGES[signal]
    return (hi - lo) / (2 ** bits - 1)


def colored_noise(rng, sigma, n, dt, corr_time):
    """Gaussian AR(1) noise with standard deviation ``sigma`` and correlation time ``corr_time``.

    ``e_k = phi e_{k-1} + sigma sqrt(1 - phi^2) w_k`` with ``phi = exp(-dt / corr_time)``,
    started in its stationary distribution: the sampled form of a first-order
    low-pass filtered white noise (a transducer's filter, slow drift).

    Parameters
    ----------
    rng : numpy Generator
    sigma : float  Standard deviation (signal units)
    n : int  Number of samples
    dt : float  Sample period [s]
    corr_time : float  Correlation time [s]; 0 gives white noise
    """
    w = rng.normal(0.0, 1.0, n)
    if corr_time <= 0.0 or n == 0:
        return sigma * w
    from scipy.signal import lfilter
    phi = math.exp(-dt / corr_time)
    w[1:] *= math.sqrt(1.0 - phi * phi)
    return sigma * lfilter([1.0], [1.0, -phi], w)


def synthesize(model, scenario, signals=("p_a", "p_b", "x"), noise=None, bits=12, seed=0,
               name="synthetic", noise_corr_time=0.0):
    """Simulate ``model`` and return what the rig's sensors would record.

    Parameters
    ----------
    model : Model or dict  The *true* actuator, hidden effects included
    scenario : dict  Scenario (command, duration, sampling, locked/x0)
    signals : tuple of str  Measured signals
    noise : dict or None  Gaussian noise standard deviation per signal (SI); None = DEFAULT_NOISE
    bits : int or None  Converter resolution; None = no quantisation
    seed : int  Random seed
    name : str  Measurement name
    noise_corr_time : float  Correlation time of the noise [s] (0 = white; see
        :func:`colored_noise`)

    Returns
    -------
    measurement : Measurement  With ``meta["truth"]`` holding the true model JSON
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    res = simulate(model, scenario)
    rng = np.random.default_rng(seed)
    noise = DEFAULT_NOISE if noise is None else noise
    sig = {"u": res.u.copy()}
    for s in signals:
        y = np.asarray(res.observed(s), float).copy()
        dt = float(res.t[1] - res.t[0]) if res.t.shape[0] > 1 else 0.0
        y = y + colored_noise(rng, noise.get(s, 0.0), y.shape[0], dt, noise_corr_time)
        if bits:
            lo, hi = SENSOR_RANGES[s]
            y = quantise(y, lo, hi, bits)
        sig[s] = y
    m = Measurement(res.t.copy(), sig, name=name, meta={"truth": model.to_dict(),
                                                        "scenario": copy.deepcopy(scenario)})
    return m.validate()


def diagnostic_scenarios(model):
    """Two experiments that expose most effects: a locked hold test and a free pulse test.

    * ``locked-hold``: piston locked mid-stroke; the valve opens (0.05 s),
      closes with the chambers sealed (0.30 s), reverses (0.55 s) and closes
      again (0.75 s): exposes heat exchange, leaks, null leakage, dead
      volume, supply drop, spool and sensor lags.
    * ``free-pulses``: the paper's Fig. 10 pulse train on a free piston:
      exposes friction effects as well.

    Parameters
    ----------
    model : Model  Used for the stroke and the valve kind

    Returns
    -------
    scenarios : dict  name -> scenario dict
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    stroke = model.jack.stroke
    if model.valve.kind == "3/2":
        hold = [[0.0, 0.0], [0.05, 1.0], [0.4, 0.0]]
        free = [[0.0, 0.0], [0.18, 1.0], [0.38, 0.0], [0.62, 1.0], [0.76, 0.0]]
        x_free = 0.0
    else:
        hold = [[0.0, 0.0], [0.05, 0.8], [0.30, 0.0], [0.55, -0.8], [0.75, 0.0]]
        free = pulse_train([(0.18, 0.7), (0.28, -0.7), (0.564, -0.7), (0.62, 0.7)], 0.04)
        x_free = 0.2 * stroke
    return {
        "locked-hold": {"duration": 1.0, "sample_period": 0.001, "command": hold,
                        "locked": True, "x0": 0.5 * stroke},
        "free-pulses": {"duration": 1.0, "sample_period": 0.001, "command": free,
                        "locked": False, "x0": x_free},
    }


def synthetic_experiments(true_model, signals=("p_a", "p_b", "x"), noise=None, bits=12, seed=0,
                          which=None, noise_corr_time=0.0):
    """Synthetic experiments (JSON-ready dicts) of the diagnostic scenarios on ``true_model``.

    Returns
    -------
    experiments : list of dict  ``{"name", "scenario": {"locked", "x0"}, "measurement"}``
    """
    true_model = Model.from_dict(true_model) if not isinstance(true_model, Model) else true_model
    out = []
    for k, (name, scen) in enumerate(diagnostic_scenarios(true_model).items()):
        if which is not None and name not in which:
            continue
        sigs = tuple(s for s in signals if not (scen["locked"] and s in ("x", "v")))
        meas = synthesize(true_model, scen, sigs, noise, bits, seed + k, name, noise_corr_time)
        out.append({"name": name, "scenario": {"locked": scen["locked"], "x0": scen["x0"]},
                    "measurement": meas})
    return out
