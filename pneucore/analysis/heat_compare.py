"""Heat models side by side: one scenario under every model, one measurement against every model.

:func:`simulate_heat_models` runs a scenario under each heat model of
:data:`pneucore.physics.heat.HEAT_MODELS` (the model's other heat parameters kept).
:func:`compare_heat_models` calibrates each heat model on its own parameters
(``HEAT_MODELS[name].fit_parameters``, optionally with
the gas-temperature sensor's time constant) against the same measurements
and tabulates pressure errors (paper Eq. 25) and gas-temperature errors (rms
[K] and Eq. 25) per model.

Transfer (:func:`transfer`): a heat model's parameters fitted on one record
(a vessel's filling) predict another (its discharge, or the held-out end of
the same record) without refitting. The fit weighs every sample by the
accuracy its measurement states for its signal (``meta.accuracy``), fixed in
advance, so that neither pressure nor temperature can take all the weight
(issue 22: a weighting by each series' own residual let the series the model
could fit take it).
"""
from __future__ import annotations

import math

import numpy as np

from pneucore.analysis.calibrate import Objective, calibrate
from pneucore.analysis.compare import replay, with_heat_model
from pneucore.data.experiment import as_experiments
from pneucore.physics.heat import HEAT_MODELS, HEAT_PARAMETERS
from pneucore.analysis.metrics import eq25_error
from pneucore.description.model import Model
from pneucore.simulate import simulate
from pneucore.description.paths import ParameterSpec, set_values, unit_of
from pneucore.description.validation import FieldError

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
            params[f"heat.{p}"] = {"min": spec.min, "max": min(spec.max, FIT_CAP), "value": v}
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


#: Largest heat parameter a fit here may reach (the registry's bounds otherwise): h at
#: 1e3 W/(m^2 K), forced convection of a fast jet at its strongest, and no sensor slower
#: than 1e3 s
FIT_CAP = 1e3
#: Bounds of the parameters a transfer fit may move (fitted in logarithm: multipliers, a
#: coefficient and a time constant are scale quantities, so the registry's lower bound of 0
#: becomes a floor): a multiplier from 1e-3 of its correlation, h from 0.01 W/(m^2 K), a
#: sensor's time constant from 0.01 s (a bare fine-wire couple); the upper bounds are the
#: registry's (:data:`HEAT_PARAMETERS`) up to :data:`FIT_CAP`
TRANSFER_BOUNDS = {p: (floor, min(HEAT_PARAMETERS[p].max, FIT_CAP)) for p, floor in (
    ("natural_multiplier", 1e-3), ("jet_multiplier", 1e-3), ("coefficient", 1e-2),
    ("sensor_time_constant", 1e-2))}
#: A fitted value within this distance of a bound in logarithm (1 %) ran to it [-]
AT_BOUND_LOG = 0.01


def fit_heat(model, experiments, parameters, t_max=None, max_nfev=200):
    """Fit heat parameters on records, every sample weighted by its signal's stated accuracy.

    Least squares (``scipy.optimize.least_squares``, trust region, bounded) on the
    calibration's weighted residuals (:class:`pneucore.analysis.calibrate.Objective`:
    ``(simulated - measured) / sigma``, sigma the accuracy the measurement's metadata
    states, ``meta.accuracy``, else the record's own noise), with the parameters in
    logarithm (:data:`TRANSFER_BOUNDS`). A stated accuracy is fixed in advance, so neither
    pressure nor temperature can take all the weight (issue 22: a weighting by each
    series' own residual let the series the model could fit take it).

    Parameters
    ----------
    model : Model or dict
        Starting model (its heat section names the heat model)
    experiments : list
        Experiments (objects or JSON) fitted jointly
    parameters : list of str
        Heat parameters fitted (names in :data:`TRANSFER_BOUNDS`)
    t_max : float or None
        Fit only the samples up to this time [s] (the rest held out)
    max_nfev : int
        Residual evaluations

    Returns
    -------
    model : Model
        The fitted model
    values : dict
        ``{name: value}`` of the fitted parameters (heat parameter units)
    """
    from scipy.optimize import least_squares
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    exps = as_experiments(experiments, model.ambient.pressure)
    if t_max is not None:
        exps = [e.cut(t_max) for e in exps]
    lo = np.log([TRANSFER_BOUNDS[p][0] for p in parameters])
    hi = np.log([TRANSFER_BOUNDS[p][1] for p in parameters])
    x0 = np.clip(np.log([max(getattr(model.heat, p), 1e-2) for p in parameters]), lo + 1e-9,
                 hi - 1e-9)
    paths = [f"heat.{p}" for p in parameters]
    obj = Objective(model, exps, [ParameterSpec(q, float(math.exp(v)), float(math.exp(a)),
                                                float(math.exp(b)), True, unit_of(q))
                                  for q, v, a, b in zip(paths, x0, lo, hi)])
    sol = least_squares(lambda x: obj.residuals(np.exp(x)), x0, bounds=(lo, hi), x_scale=1.0,
                        diff_step=1e-3, max_nfev=max_nfev)
    values = {p: float(math.exp(v)) for p, v in zip(parameters, sol.x)}
    return set_values(model, {f"heat.{p}": v for p, v in values.items()}), values


def record_errors(model, experiment, t_min=None, t_max=None):
    """Pressure error (paper Eq. 25 [-]) and gas-temperature rms [K] of a model on a record.

    Parameters
    ----------
    model : Model or dict
        The model
    experiment : Experiment or dict
        The record
    t_min, t_max : float or None
        Only the samples in this time window [s]

    Returns
    -------
    errors : dict
        ``p`` [-] and ``T`` [K] (None where the record has no such samples)
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    rp = replay(model, as_experiments([experiment], model.ambient.pressure)[0])
    out = {}
    for s, key in (("p_a", "p"), ("T_a", "T")):
        if s not in rp.measured:
            out[key] = None
            continue
        m, g = np.asarray(rp.measured[s], float), np.asarray(rp.simulated[s], float)
        ok = np.isfinite(m)
        if t_min is not None:
            ok &= rp.t >= t_min
        if t_max is not None:
            ok &= rp.t <= t_max
        if not ok.any():
            out[key] = None
        elif key == "p":
            out[key] = eq25_error(m[ok], g[ok])
        else:
            out[key] = float(math.sqrt(np.mean((g[ok] - m[ok]) ** 2)))
    return out


def transfer(model, fit_on, predict, parameters, t_split=None, name=None):
    """Fit heat parameters on one record, then predict another (or the held-out rest) unrefitted.

    Parameters
    ----------
    model : Model or dict
        Starting model (its heat section names the heat model and holds the wall, inlet, ...)
    fit_on : Experiment or dict
        The record fitted (a filling)
    predict : Experiment or dict or None
        The record predicted (a discharge); None with ``t_split``: the rest of ``fit_on``
    parameters : list of str
        Heat parameters fitted
    t_split : float or None
        Fit ``fit_on`` up to this time [s] only; with ``predict`` None, predict after it
    name : str or None
        Row label (default: the heat model's name)

    Returns
    -------
    row : dict
        ``name``, ``values`` (fitted), ``at_bound`` (fitted parameters that ran to a bound of
        :data:`TRANSFER_BOUNDS`: a symptom, not a measurement), ``fit`` and ``predicted``
        errors (:func:`record_errors`), ``model`` (the fitted model)
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    fitted, values = fit_heat(model, [fit_on], parameters, t_max=t_split)
    fit_err = record_errors(fitted, fit_on, t_max=t_split)
    if predict is None:
        pred = record_errors(fitted, fit_on, t_min=t_split)
    else:
        pred = record_errors(fitted, predict)
    at_bound = [p for p, v in values.items()
                if any(abs(math.log(v / b)) < AT_BOUND_LOG for b in TRANSFER_BOUNDS[p])]
    return {"name": name or model.heat.model, "values": values, "at_bound": at_bound,
            "fit": fit_err, "predicted": pred, "model": fitted}


def transfer_table(rows, fit_label="fitted on", predict_label="predicted"):
    """Rows of :func:`transfer` as plain text: fitted values, p Eq. 25 [%] and T rms [K] of both."""
    def pct(v):
        return f"{100 * v:6.2f} %" if v is not None else "     - "

    def kel(v):
        return f"{v:6.2f} K" if v is not None else "     - "

    lines = [f"{'model':<34} {fit_label + ' p':>10} {'T':>8}   {predict_label + ' p':>12} {'T':>8}"
             f"   fitted"]
    for r in rows:
        vals = ", ".join(f"{k} = {v:.3g}" for k, v in r["values"].items())
        lines.append(f"{r['name']:<34} {pct(r['fit']['p']):>10} {kel(r['fit']['T']):>8}   "
                     f"{pct(r['predicted']['p']):>12} {kel(r['predicted']['T']):>8}   {vals}")
    return "\n".join(lines)


# ----------------------------------------------------------------------------- paper Table 2
#: The paper's Table 2 (Maré, Geider & Colin): Eq. 25 pressure error [%] of its convective
#: ("actual"), adiabatic and isothermal models against the locked-chamber measurements of
#: Figs. 6-7, per valve move (``opens``: the chamber filled, ``closes``: exhausted) and chamber
#: volume (``min``: piston at x = 0, ``max``: at full stroke)
PAPER_TABLE2 = {
    ("opens", "min"): {"convective": 0.95, "adiabatic": 0.94, "isothermal": 0.94},
    ("opens", "max"): {"convective": 1.22, "adiabatic": 2.82, "isothermal": 2.82},
    ("closes", "min"): {"convective": 1.14, "adiabatic": 6.10, "isothermal": 4.64},
    ("closes", "max"): {"convective": 2.01, "adiabatic": 13.08, "isothermal": 8.87},
}
#: The scenario preset of each chamber volume of Table 2 (run with ``paper-4way``)
TABLE2_TESTS = {"max": "paper-fig6-locked-max", "min": "paper-fig7-locked-min"}
#: The valve moves of Table 2, in the order a locked test makes them
TABLE2_MOVES = ("opens", "closes")


def locked_test_windows(scenario):
    """Split a locked-chamber test at its last command change: ``opens`` before, ``closes`` from it.

    Parameters
    ----------
    scenario : Scenario or dict
        A test whose command opens the valve, then moves it once more (exhausts the chamber)

    Returns
    -------
    t_close : float
        Time of the last command change [s]
    """
    cmd = scenario.command if not isinstance(scenario, dict) else scenario["command"]
    changes = [t for (t, u), (_, u_prev) in zip(cmd[1:], cmd[:-1]) if u != u_prev]
    if len(changes) < 2:
        raise ValueError("a Table 2 test opens the valve, then closes it: two command changes")
    return float(changes[-1])


def heat_model_distances(model, scenario, names=("adiabatic", "isothermal")):
    """Eq. 25 distance of each heat model from the convective one, per valve move of a locked test.

    The convective run is the reference (the paper's ``P_s``), each other model's run the
    ``P_g`` of Eq. 25, on chamber A's absolute pressure, over the ``opens`` samples
    (before the test's last command change) and the ``closes`` samples (from it on).

    Parameters
    ----------
    model : Model or dict
        The model (its heat model is replaced; its coefficient is the convective one)
    scenario : Scenario or dict
        A locked-chamber test (:func:`locked_test_windows`)
    names : tuple of str
        Heat models compared with the convective one

    Returns
    -------
    distances : dict
        move -> heat model name -> distance [%]
    """
    runs = simulate_heat_models(model, scenario, ("convective",) + tuple(names))
    t_close = locked_test_windows(scenario)
    t = np.asarray(runs["convective"].t)
    ref = np.asarray(runs["convective"].p_a)
    out = {}
    # half a sample of slack: the change lands on a sample, which belongs to the new move
    for move, keep in (("opens", t < t_close - 1e-9), ("closes", t >= t_close - 1e-9)):
        out[move] = {n: 100.0 * eq25_error(ref[keep], np.asarray(runs[n].p_a)[keep]) for n in names}
    return out


def table2_target(move, volume, name):
    """What Table 2 says a heat model's distance from the convective one is, and whether it says it.

    The table's errors are against measurements; the convective model's own error is the
    table's noise level. Removing it in quadrature (``sqrt(e_model^2 - e_conv^2)``) gives the
    distance between the two models the table implies when the two errors are independent.
    A cell whose model error does not exceed the convective one is below the noise: the table
    then says only that the distance is at most ``e_model + e_conv`` (the triangle inequality
    on two errors against the same data).

    Parameters
    ----------
    move : str
        ``opens`` or ``closes``
    volume : str
        ``min`` or ``max``
    name : str
        ``adiabatic`` or ``isothermal``

    Returns
    -------
    target : float or None
        The distance [%]; None below the noise
    bound : float
        The largest distance the table allows [%]
    """
    row = PAPER_TABLE2[(move, volume)]
    e, c = row[name], row["convective"]
    return (math.sqrt(e * e - c * c) if e > c else None), e + c


def table2_rows(model="paper-4way", scenarios=None, factor=1.5):
    """The paper's Table 2 against the presets' heat-model distances, per cell.

    Parameters
    ----------
    model : str, Model or dict
        The model (a preset name, by default ``paper-4way``)
    scenarios : dict or None
        volume (``min``/``max``) -> scenario; None = the presets of :data:`TABLE2_TESTS`
    factor : float
        Agreement asked of a cell above the noise [-]

    Returns
    -------
    rows : list of dict
        ``move``, ``volume``, ``model`` (adiabatic / isothermal), ``paper`` (the table's errors
        [%]), ``target`` [%] or None, ``bound`` [%], ``distance`` [%], ``ratio`` (distance /
        target, or None) and ``ok``
    """
    from pneucore.description.presets import model_preset, scenario_preset
    if isinstance(model, str):
        model = model_preset(model)
    scenarios = scenarios or {v: scenario_preset(n) for v, n in TABLE2_TESTS.items()}
    rows = []
    for volume in ("min", "max"):
        dist = heat_model_distances(model, scenarios[volume])
        for move in TABLE2_MOVES:
            for name in ("adiabatic", "isothermal"):
                target, bound = table2_target(move, volume, name)
                d = dist[move][name]
                ratio = d / target if target is not None else None
                ok = (1.0 / factor <= ratio <= factor) if ratio is not None else d <= bound
                rows.append({"move": move, "volume": volume, "model": name,
                             "paper": dict(PAPER_TABLE2[(move, volume)]), "target": target,
                             "bound": bound, "distance": d, "ratio": ratio, "ok": ok})
    return rows


def table2_text(rows):
    """The rows of :func:`table2_rows` as a plain-text table."""
    lines = [f"{'valve':<7}{'volume':<7}{'model':<11}{'paper e/e_conv':>15}{'paper dist.':>12}"
             f"{'preset dist.':>13}{'ratio':>7}  verdict"]
    for r in rows:
        tgt = f"{r['target']:.2f}%" if r["target"] is not None else f"<={r['bound']:.2f}%"
        ratio = f"{r['ratio']:.2f}" if r["ratio"] is not None else "-"
        verdict = ("ok" if r["ok"] else "OFF") + ("" if r["target"] is not None else " (below noise)")
        lines.append(f"{r['move']:<7}{r['volume']:<7}{r['model']:<11}"
                     f"{r['paper'][r['model']]:>8.2f}/{r['paper']['convective']:<5.2f}{tgt:>12}"
                     f"{r['distance']:>12.2f}%{ratio:>7}  {verdict}")
    return "\n".join(lines)
