"""Heat models side by side: one scenario under every model, one measurement against every model.

:func:`simulate_heat_models` runs a scenario under each heat model of
:data:`pneucore.physics.heat.HEAT_MODELS` (the model's other heat parameters kept).
:func:`compare_heat_models` calibrates each heat model on its own parameters
(``HEAT_MODELS[name].fit_parameters``, optionally with
the gas-temperature sensor's time constant) against the same measurements
and tabulates pressure errors (paper Eq. 25) and gas-temperature errors (rms
[K] and Eq. 25) per model.
"""
from __future__ import annotations

import math

import numpy as np

from pneucore.analysis.calibrate import calibrate
from pneucore.analysis.compare import replay, with_heat_model
from pneucore.data.experiment import as_experiments
from pneucore.physics.heat import HEAT_MODELS, HEAT_PARAMETERS
from pneucore.analysis.metrics import eq25_error
from pneucore.spec.model import Model
from pneucore.simulate import simulate
from pneucore.spec.validation import FieldError

def check_names(names, path="heat_models"):
    """Validate a list of heat-model names (None = all, in registry order); returns a tuple."""
    if names is None:
        return tuple(HEAT_MODELS)
    if not isinstance(names, (list, tuple)) or not names:
        raise FieldError(path, f"give a non-empty list of heat models from {list(HEAT_MODELS)}")
    for i, n in enumerate(names):
        if not isinstance(n, str) or n not in HEAT_MODELS:
            raise FieldError(f"{path}[{i}]", f"unknown heat model {n!r}; expected one of "
                                             f"{list(HEAT_MODELS)}")
    return tuple(dict.fromkeys(names))


def simulate_heat_models(model, scenario, names=None):
    """One scenario under several heat models.

    Parameters
    ----------
    model : Model or dict
        The model (its other heat parameters are kept under every heat model)
    scenario : Scenario or dict
        The scenario
    names : list of str or None
        Heat models (None = every registered model)

    Returns
    -------
    runs : dict
        name -> :class:`pneucore.result.SimulationResult`
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    return {n: simulate(with_heat_model(model, n), scenario) for n in check_names(names)}


def _temperature_rms(rp):
    out = {}
    for s in ("T_a", "T_b"):
        if s in rp.measured:
            m, g = rp.measured[s], rp.simulated[s]
            ok = np.isfinite(m) & np.isfinite(g)
            out[s] = float(math.sqrt(np.mean((g[ok] - m[ok]) ** 2))) if ok.any() else None
    return out


def compare_heat_models(model, experiments, names=None, sensor=False, max_nfev=60,
                        datasets=None, progress=None):
    """Every heat model calibrated on its own parameters against the same measurements.

    Parameters
    ----------
    model : Model or dict
        The model (its heat section is the starting point of each calibration)
    experiments : list
        Experiments (objects or JSON) fitted jointly
    names : list of str or None
        Heat models (None = all)
    sensor : bool
        Also fit the gas-temperature sensor's time constant (``heat.sensor_time_constant``)
        for every non-isothermal model
    max_nfev : int
        Residual evaluations per calibration
    progress : callable or None
        ``progress(fraction, step)``

    Returns
    -------
    rows : list of dict
        Per model: ``name``, ``parameters`` (``{path: {value, stderr, unit}}``),
        ``errors`` (Eq. 25 per signal [-]), ``temperature_rms`` ([K] per measured
        temperature), ``model`` (the calibrated model JSON), ``t``, ``simulated``
        (the observed series at the measured samples, first experiment) and
        ``message`` of the optimiser
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    names = check_names(names)
    exps = as_experiments(experiments, model.ambient.pressure, datasets)
    report = progress or (lambda f, s: None)
    rows = []
    for k, name in enumerate(names):
        report(k / len(names), f"heat model {name}")
        m = with_heat_model(model, name)
        fit = list(HEAT_MODELS[name].fit_parameters)
        if sensor and "sensor_time_constant" in HEAT_MODELS[name].parameters:
            fit.append("sensor_time_constant")
        params = {}
        for p in fit:
            spec = HEAT_PARAMETERS[p]
            v = getattr(m.heat, p)
            if p == "sensor_time_constant" and v <= 0.0:
                v = 1.0   # start from a response time of a bare thermocouple's order [s]
            params[f"heat.{p}"] = {"min": spec.min, "max": min(spec.max, 1e3), "value": v}
        if params:
            cal = calibrate(m, exps, params, max_nfev=max_nfev)
            m_fit, values, message = cal.model, cal.values, cal.message
        else:
            m_fit, values, message = m, {}, "nothing to fit"
        rps = [replay(m_fit, e) for e in exps]
        errors = {}
        for s in rps[0].measured:
            meas = np.concatenate([rp.measured[s] for rp in rps if s in rp.measured])
            sim = np.concatenate([rp.simulated[s] for rp in rps if s in rp.measured])
            errors[s] = eq25_error(meas, sim)
        rows.append({"name": name, "description": HEAT_MODELS[name].description,
                     "parameters": values, "errors": errors,
                     "temperature_rms": _temperature_rms(rps[0]),
                     "model": m_fit.to_dict(), "message": message,
                     "t": np.ascontiguousarray(rps[0].t, float),
                     "simulated": {s: np.ascontiguousarray(v, float)
                                   for s, v in rps[0].simulated.items()}})
    report(1.0, "done")
    return rows


def table(rows):
    """The rows as a plain-text table: model, fitted parameters, p_a Eq. 25 [%], T_a rms [K]."""
    lines = [f"{'heat model':<22} {'p_a Eq.25':>10} {'T_a rms':>8}  fitted"]
    for r in rows:
        fitted = ", ".join(f"{k.split('.', 1)[1]} = {v['value']:.4g}" for k, v in r["parameters"].items())
        ep = r["errors"].get("p_a")
        eT = r["temperature_rms"].get("T_a")
        lines.append(f"{r['name']:<22} {100 * ep:>9.2f}% {eT if eT is not None else float('nan'):>7.2f}K  "
                     f"{fitted}")
    return "\n".join(lines)
