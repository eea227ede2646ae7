"""See where the model fails: ``compare(model, experiments)``.

For each experiment the model is replayed with the measured command and
compared with the measurement: the paper's Eq. 25 error per signal and
overall, the same error per phase (valve opens / closes / reverses as in
Table 2, and piston moving / stuck / at a stop), the worst time windows
described in words, and the residual series. ``heat_models=[...]`` runs the
same comparison under several heat models side by side (Fig. 8, Table 2).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pneucore.data.experiment import as_experiments
from pneucore.analysis.metrics import (command_phases, eq25_error, noise_sigma, ordered_labels,
                                       phase_errors, piston_phases, worst_windows)
from pneucore.analysis.phase_excess import describe, explain_residual
from pneucore.result import LazyResult, SummarisedResult, kept_columns
from pneucore.description.model import Model


@dataclass
class Replay:
    """One experiment replayed on a model: aligned measured and simulated signals.

    The phase labels are computed on first use: a fit replays an experiment
    hundreds of times and needs only the residuals.
    """
    experiment: object
    result: object
    t: np.ndarray
    measured: dict
    simulated: dict
    u: np.ndarray = field(default=None, repr=False)
    _cmd: np.ndarray = field(default=None, repr=False)
    _piston: np.ndarray = field(default=None, repr=False)

    @property
    def cmd_labels(self):
        """Valve phase of each sample (:func:`pneucore.analysis.metrics.command_phases`)."""
        if self._cmd is None:
            self._cmd = command_phases(self.t, self.u)
        return self._cmd

    @property
    def piston_labels(self):
        """Piston state of each sample (:func:`pneucore.analysis.metrics.piston_phases`)."""
        if self._piston is None:
            self._piston = piston_phases(self.result.mode)
        return self._piston

    @property
    def ok(self):
        return self.result.status == 0

    def keep_summary(self):
        """Drop what the summary no longer needs (:func:`summarise`): the phase labels are made,
        the result becomes a :class:`pneucore.result.SummarisedResult` (status, modes, events and
        the :data:`SUMMARY_SERIES`), and a simulated signal that is a column of the core's outputs
        becomes a copy of it, so that those outputs are freed. Values unchanged."""
        self.cmd_labels, self.piston_labels   # noqa: B018 - made while the modes are at hand
        self.drop_core_outputs()

    def drop_core_outputs(self):
        """Free the compiled core's outputs, keeping what a fit and a summary read of them: the
        result becomes a :class:`pneucore.result.SummarisedResult` (status, modes, events and the
        :data:`SUMMARY_SERIES`), and a simulated signal that is a column of those outputs a copy
        of it (a fit keeps its last replays, :data:`pneucore.analysis.calibrate.RECENT_REPLAYS`,
        and two fits run at once: their outputs made most of a diagnosis's peak). Values
        unchanged; the full result can no longer be built."""
        # a signal that is still a view is the core's column as observed (a sensor's gain or
        # offset, applied by a fit, makes a new array): its copy serves both
        copies = {s: v.copy() for s, v in self.simulated.items()
                  if isinstance(v, np.ndarray) and v.base is not None}
        self.result = summarised_result(self.result, SUMMARY_SERIES,
                                        {s: c for s, c in copies.items() if s in SUMMARY_SERIES})
        self.simulated = {s: copies.get(s, v) for s, v in self.simulated.items()}
        return self


#: Observed series a summarised replay keeps besides its compared signals: the regressors of
#: :func:`pneucore.analysis.hypotheses.residual_signature`, the one reader of a summarised
#: replay's simulation beyond its status, modes and events
SUMMARY_SERIES = ("x", "v", "p_a", "p_b")


def summarised_result(result, keep=SUMMARY_SERIES, given=None):
    """A replay's result as :class:`pneucore.result.SummarisedResult` (a lazy or full result);
    ``given``: copies of some of the ``keep`` series already made (name -> array)."""
    if hasattr(result, "summarised"):
        return result.summarised(keep, given)
    return SummarisedResult(result.status, result.message, result.mode, result.events,
                            kept_columns(result, keep, given))


def replay(model, experiment):
    """Simulate ``experiment`` on ``model`` and align the signals (no exception on solver failure)."""
    run = experiment.run(model)
    res = LazyResult(run)   # the full result built only when something reads it
    n = len(run.t_out)
    meas = {s: experiment.measurement.signals[s][:n] for s in experiment.signals}
    sim = {s: np.asarray(run.observed(s), float) for s in experiment.signals}
    u = experiment.command_samples[:n]
    return Replay(experiment, res, run.t_out, meas, sim, u)


#: A measured position whose spread (1st to 99th percentile) stays below this never moved [m]:
#: about eight steps of the paper's 12-bit acquisition over a 250 mm stroke (0.06 mm a step),
#: well above an LVDT's noise, far below any stroke a free test makes
STILL_SPREAD = 5e-4
#: A free replay moving farther than this [m] (ten times the above) contradicts a record that
#: never moved: the context declared is the likelier mistake, not the physics
MOVES_SPREAD = 5e-3


def _spread(x):
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if x.size < 2:
        return None
    lo, hi = np.percentile(x, [1.0, 99.0])
    return float(hi - lo)


def context_hints(replays):
    """Hints where the records contradict the context declared with them: a "free" test whose
    measured position never moves while the model's does (a locked test declared free), a
    "locked" test whose measured position moves.

    Parameters
    ----------
    replays : list of Replay
        The experiments replayed on the model [-]

    Returns
    -------
    hints : list of dict
        ``{"experiment", "kind", "message"}`` each; ``kind`` is ``declared_free_never_moves``
        or ``declared_locked_moves`` [-]
    """
    hints = []
    for rp in replays:
        exp = rp.experiment
        x_meas = exp.measurement.signals.get("x")
        meas = _spread(x_meas) if x_meas is not None else None
        if meas is None:
            continue
        locked = bool(exp.scenario.get("locked", False))
        sim = _spread(rp.simulated["x"]) if "x" in rp.simulated else None
        if not locked and meas < STILL_SPREAD and sim is not None and sim > MOVES_SPREAD:
            hints.append({"experiment": exp.name, "kind": "declared_free_never_moves", "message": (
                f"{exp.name}: the measured position stays within {1e3 * meas:.2g} mm over the "
                f"whole record while the model, told the piston is free, moves it by "
                f"{1e3 * sim:.3g} mm. If the piston was locked, declare it (scenario.locked = "
                "true, with its x0); the errors of this test say little about the model until then.")})
        elif locked and meas > 4 * STILL_SPREAD:
            hints.append({"experiment": exp.name, "kind": "declared_locked_moves", "message": (
                f"{exp.name}: declared locked, but the measured position moves by {1e3 * meas:.3g} "
                "mm. If the piston was free, declare it (scenario.locked = false, with its x0); a "
                "locked replay ignores the motion.")})
    return hints


def _overall(errors):
    vals = [e for e in errors.values() if e is not None and math.isfinite(e)]
    return float(math.sqrt(np.mean(np.square(vals)))) if vals else float("nan")


def _pooled(replays):
    sigs = {}
    for rp in replays:
        for s in rp.measured:
            sigs.setdefault(s, ([], []))
            sigs[s][0].append(rp.measured[s])
            sigs[s][1].append(rp.simulated[s])
    return {s: eq25_error(np.concatenate(m), np.concatenate(g)) for s, (m, g) in sigs.items()}


def _phase_table(replays, which):
    """Pooled Eq. 25 per phase label per signal: {label: {signal: err}}."""
    acc = {}
    for rp in replays:
        labels = rp.cmd_labels if which == "command" else (
            rp.piston_labels if which == "piston" else
            np.char.add(np.char.add(rp.cmd_labels.astype(str), ", "), rp.piston_labels.astype(str)))
        for lab in ordered_labels(labels):
            sel = labels == lab
            for s in rp.measured:
                d = acc.setdefault(str(lab), {}).setdefault(s, ([], []))
                d[0].append(rp.measured[s][sel])
                d[1].append(rp.simulated[s][sel])
    out = {}
    for lab, sigs in acc.items():
        row = {}
        for s, (m, g) in sigs.items():
            m, g = np.concatenate(m), np.concatenate(g)
            n = int(np.sum(np.isfinite(m) & np.isfinite(g)))
            if n:
                row[s] = eq25_error(m, g)
        if row:
            row["overall"] = _overall(row)
            out[lab] = row
    return out


def errors(model, experiments):
    """Eq. 25 errors per signal and overall only: ``(errors, overall)`` (cheaper than :func:`compare`)."""
    errs = _pooled([replay(model, e) for e in experiments])
    return errs, _overall(errs)


def _noise(rp, name, measured):
    """:func:`pneucore.analysis.metrics.noise_sigma` of a replay's measured series: the
    experiment's own, found once (:meth:`Experiment.noise`), when the replay holds the whole
    record [SI]."""
    full = rp.experiment.measurement.signals.get(name)
    if full is not None and full.shape == measured.shape and hasattr(rp.experiment, "noise"):
        return rp.experiment.noise(name)
    return noise_sigma(measured)


def noise_floor(replays):
    """Eq. 25 error that white measurement noise alone would give, per signal [-].

    Noise is estimated from each measurement's second differences
    (:func:`pneucore.analysis.metrics.noise_sigma`); the floor is
    ``sqrt(N sigma^2 / sum y^2)``.
    """
    acc = {}
    for rp in replays:
        for s, m in rp.measured.items():
            ok = np.isfinite(m)
            sig = _noise(rp, s, m)
            a = acc.setdefault(s, [0.0, 0.0])
            a[0] += ok.sum() * sig * sig
            a[1] += np.sum(m[ok] ** 2)
    return {s: float(math.sqrt(a[0] / a[1])) if a[1] > 0 else float("nan") for s, a in acc.items()}


#: The most signals a phase's message names (the worst first) [-]
EXPLAIN_AT_MOST = 4


def phase_explanations(replays):
    """Per phase (command and piston), why its error stands above the noise floor.

    Each experiment's residual of each signal within the phase is split into an offset, a drift
    and a lag (:func:`pneucore.analysis.phase_excess.explain_residual`), against the noise of
    that experiment's measured signal.

    Parameters
    ----------
    replays : list of Replay
        The experiments replayed on the model [-]

    Returns
    -------
    explanations : dict
        phase label -> ``{"worst_ratio"``: the largest residual RMS over noise sigma [-],
        ``"within_noise"``: bool, ``"noise_floor"``: the Eq. 25 error that the noise alone gives
        over this phase's samples, per signal and ``overall`` (RMS of the signals'), as
        :func:`noise_floor` for the whole record [-], ``"message"``: words, ``"signals"``: one
        dict per experiment and signal (``experiment``, ``signal`` and
        :func:`explain_residual`'s fields)``}``

        A phase whose signals are small (the ``initial`` phase: chambers near ambient pressure,
        the piston near 0) has an Eq. 25 noise floor above the whole record's, since Eq. 25
        divides by the signal's energy: its error is judged against its own floor.
    """
    acc = {}
    floors = {}
    for rp in replays:
        t = np.asarray(rp.t, float)
        for s in rp.measured:
            if s == "u":
                continue
            m = np.asarray(rp.measured[s], float)
            g = np.asarray(rp.simulated[s], float)
            sigma = _noise(rp, s, m)
            dg = np.gradient(g, t) if t.size > 1 else np.zeros_like(g)
            for labels in (rp.cmd_labels, rp.piston_labels):
                for lab in ordered_labels(labels):
                    sel = labels == lab
                    ok = sel & np.isfinite(m) & np.isfinite(g)
                    f = floors.setdefault(str(lab), {}).setdefault(s, [0.0, 0.0])
                    f[0] += ok.sum() * sigma * sigma
                    f[1] += float(np.sum(m[ok] ** 2))
                    e = explain_residual(t[sel], g[sel] - m[sel], sigma, derivative=dg[sel])
                    e = {"experiment": rp.experiment.name, "signal": s, **e}
                    e["message"] = describe(s, e)
                    acc.setdefault(str(lab), []).append(e)
    many = len(replays) > 1
    record = _overall(noise_floor(replays))
    out = {}
    for lab, items in acc.items():
        judged = [e for e in items if e["ratio"] is not None]
        judged.sort(key=lambda e: -e["ratio"])
        worst = judged[0]["ratio"] if judged else None
        above = [e for e in judged if e["cause"] != "noise"]
        floor = {s: math.sqrt(a / b) for s, a, b in ((s, *v) for s, v in floors[lab].items()) if b > 0}
        floor["overall"] = _overall(floor)
        if not judged:
            msg = f"{lab}: too few samples to judge"
        elif not above:
            msg = (f"{lab}: within the noise (at most {worst:.2g}x the noise in any signal); "
                   f"this phase's own noise floor is {100 * floor['overall']:.2g} % (Eq. 25 "
                   "over its samples)")
            if floor["overall"] > 1.5 * record:
                msg += (f", above the whole record's {100 * record:.2g} % since Eq. 25 divides "
                        "by this phase's smaller signals")
        else:
            msg = f"{lab}: " + "; ".join((f"{e['experiment']}, " if many else "") + e["message"]
                                         for e in above[:EXPLAIN_AT_MOST])
        out[lab] = {"worst_ratio": worst, "within_noise": bool(judged) and not above,
                    "noise_floor": floor, "message": msg, "signals": items}
    return out


@dataclass
class Comparison:
    """Result of :func:`compare` (all numbers plain; ``to_dict()`` is JSON-ready)."""
    errors: dict
    overall: float
    phases: dict
    piston_phases: dict
    combined_phases: dict
    windows: list
    experiments: list
    noise_floor: dict
    heat_models: dict = field(default_factory=dict)
    replays: list = field(default_factory=list, repr=False)
    hints: list = field(default_factory=list)
    _explanations: dict = field(default=None, repr=False)

    @property
    def phase_explanations(self):
        """:func:`phase_explanations` of the replays, made on first use (a fit's trial models
        need only the errors) [-]"""
        if self._explanations is None:
            self._explanations = phase_explanations(self.replays)
        return self._explanations

    def to_dict(self, residuals=True):
        d = {"errors": self.errors, "overall": self.overall, "phases": self.phases,
             "piston_phases": self.piston_phases, "combined_phases": self.combined_phases,
             "failure_windows": self.windows, "noise_floor": self.noise_floor,
             "experiments": [dict(e) for e in self.experiments], "hints": self.hints,
             "phase_explanations": self.phase_explanations}
        if not residuals:
            for e in d["experiments"]:
                e.pop("residuals", None)
                e.pop("simulated", None)
                e.pop("measured", None)
        if self.heat_models:
            d["heat_models"] = self.heat_models
        return plain_json(d)


def plain_json(obj):
    """``obj`` as plain JSON: numpy arrays and scalars as lists and Python numbers, NaN and
    infinities as None, keys as strings.

    Parameters
    ----------
    obj : object
        Nested dicts, lists, tuples, numpy arrays and scalars

    Returns
    -------
    plain : object
        The same structure with JSON types only

    Examples
    --------
    >>> plain_json({"e": np.array([0.5, np.nan]), 1: (np.int64(2), np.bool_(True))})
    {'e': [0.5, None], '1': [2, True]}
    """
    if isinstance(obj, dict):
        return {str(k): plain_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain_json(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [plain_json(v) for v in obj.tolist()]
    if isinstance(obj, (np.floating, float)):
        f = float(obj)
        return f if math.isfinite(f) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj




def summarise(replays, n_windows=5):
    """Build a :class:`Comparison` from replays (shared by compare, calibrate and diagnose)."""
    exps = []
    windows = []
    for rp in replays:
        # the core's outputs (every series of every replay) are not kept by the summary: the
        # peak of a diagnosis, whose calibrations' summaries each hold their replays
        rp.keep_summary()
    for rp in replays:
        errs = {s: eq25_error(rp.measured[s], rp.simulated[s]) for s in rp.measured}
        win = worst_windows(rp.t, rp.measured, rp.simulated, rp.cmd_labels, rp.piston_labels,
                            n_windows=n_windows, experiment=rp.experiment.name)
        windows += win
        exps.append({
            "name": rp.experiment.name, "dataset_id": rp.experiment.dataset_id,
            "command_source": rp.experiment.command_source,
            "errors": errs, "overall": _overall(errs),
            "status": rp.result.message,
            "phases": {s: phase_errors(rp.measured[s], rp.simulated[s], rp.cmd_labels)
                       for s in rp.measured},
            "t": rp.t, "residuals": {s: rp.simulated[s] - rp.measured[s] for s in rp.measured},
            "simulated": {s: rp.simulated[s] for s in rp.measured},
            "measured": {s: rp.measured[s] for s in rp.measured},
            # the text array, written as a list by to_dict (a list of str: 60 bytes a sample)
            "mode": rp.result.mode,
            "events": rp.result.events,
        })
        if rp.experiment.closed_loop is not None:   # a closed-loop record replayed open loop
            exps[-1]["closed_loop"] = rp.experiment.closed_loop
    windows.sort(key=lambda w: -w["energy"])
    errors = _pooled(replays)
    return Comparison(errors, _overall(errors), _phase_table(replays, "command"),
                      _phase_table(replays, "piston"), _phase_table(replays, "combined"),
                      windows[:n_windows], exps, noise_floor(replays), replays=replays,
                      hints=context_hints(replays))


#: The three heat models of the paper's Fig. 8 and Table 2
PAPER_HEAT_MODELS = ("convective", "adiabatic", "isothermal")


def with_heat_model(model, name):
    """A copy of ``model`` under heat model ``name``.

    A ``heat_exchange`` effect is removed; under ``convective`` its coefficient is
    kept, since it is the one the model actually uses.
    """
    m = model.copy()
    m.heat.model = name
    hx = m.effects.pop("heat_exchange", None)
    if hx is not None and name == "convective":
        m.heat.coefficient = hx["h"]
    return m


def check_heat_models(heat_models):
    """Validate the ``heat_models`` argument of :func:`compare`; returns the names."""
    from pneucore.physics.heat import HEAT_MODELS
    from pneucore.description.validation import FieldError
    if not heat_models:
        return ()
    if heat_models is True:
        return PAPER_HEAT_MODELS
    names = tuple(heat_models)
    for i, n in enumerate(names):
        if not isinstance(n, str) or n not in HEAT_MODELS:
            raise FieldError(f"heat_models[{i}]", f"unknown heat model {n!r}; expected one of "
                                                  f"{sorted(HEAT_MODELS)}")
    return names


def compare(model, experiments, heat_models=None, n_windows=5, datasets=None, progress=None):
    """Compare the model with measurements.

    Parameters
    ----------
    model : Model or dict
        The actuator model
    experiments : list
        :class:`pneucore.data.experiment.Experiment` objects or their JSON
    heat_models : list of str or True or None
        Also compare under these heat models
        (True = isothermal, adiabatic and convective), side by side
    n_windows : int
        Number of worst windows to describe
    progress : callable or None
        ``progress(fraction, step)``; may raise ``Cancelled``

    Returns
    -------
    comparison : Comparison
        Eq. 25 errors per signal, overall and per phase, worst windows,
        residual series, estimated noise floor, and ``heat_models`` when asked
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    names = check_heat_models(heat_models)
    exps = as_experiments(experiments, model.ambient.pressure, datasets)
    report = progress or (lambda f, s: None)
    total = len(exps) * (1 + len(names))
    rps = []
    for i, e in enumerate(exps):
        report(i / total, f"simulating {e.name}")
        rps.append(replay(model, e))
    comp = summarise(rps, n_windows)
    if names:
        for k, name in enumerate(names):
            report((len(exps) * (1 + k)) / total, f"heat model {name}")
            m = with_heat_model(model, name)
            c = summarise([replay(m, e) for e in exps], n_windows=0)
            comp.heat_models[name] = {"errors": c.errors, "overall": c.overall, "phases": c.phases}
    return comp
