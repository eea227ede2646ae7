"""Mis-set base parameters as hypotheses, chosen from what the experiments can identify.

A model built from catalogue values has every base parameter somewhat off.
Before a missing physical effect can be named, the diagnosis must know what
recalibrating the base parameters alone explains. Which base parameters to
recalibrate is decided here, from the data, not by the user:

1. **Registry.** :data:`BASE_HYPOTHESES` lists the base parameters a test
   engineer actually gets wrong (friction level and viscous coefficient per
   direction, moving mass, heat coefficient, valve conductance, supply
   pressure, dead volumes, load), each with the relative error a catalogue
   value typically carries and fit bounds relative to the current value.
2. **Sensitivity.** Each parameter is moved by its typical error and the
   change of every output, divided by the output's noise level, gives a
   column ``s_j`` of the sensitivity matrix (one simulation per parameter
   and experiment).
3. **Identifiability.** A parameter is considered when its typical error
   would be seen, ``|s_j|^2 >= VISIBLE`` (a chi-square increase far beyond
   any noise fluctuation), and is not a linear combination of parameters
   already chosen: the columns are taken greedily by decreasing ``|s_j|``
   (pivoted Gram-Schmidt); a column whose part orthogonal to the chosen ones
   keeps less than ``COLLINEAR`` of its norm is reported as not separable
   from them (``not_separable``), since its value can only be fitted in a
   fixed combination with theirs (Fisher information matrix close to
   singular; Bard, *Nonlinear Parameter Estimation*, 1974, Sect. 7-5).

A base parameter whose physics is a catalog effect of the same name
(``same_as_effect``: the base dead volumes and the ``dead_volume`` effect)
is left to that effect while the effect is a candidate, so that one physical
discrepancy is not offered twice.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from pneucore.spec.paths import ParameterSpec, get_value, set_values, unit_of

#: Sensitivity norm^2 (noise-weighted chi-square units) a typical error must produce to be
#: considered identifiable: 100 is a 10-sigma effect on the whole record
VISIBLE = 100.0
#: Part of a sensitivity column orthogonal to the parameters already chosen below which it
#: is not separable from them (|correlation| above 0.995)
COLLINEAR = 0.1


@dataclass(frozen=True)
class BaseHypothesis:
    """A base parameter the catalogue may have wrong.

    Parameters
    ----------
    path : str
        Model path (:mod:`pneucore.spec.paths`)
    label : str
        Human name, e.g. ``heat coefficient``
    typical : float
        Typical relative error of a catalogue value [-]
    lo, hi : float
        Fit bounds as multiples of the current value [-]
    span : float
        Absolute half-range used when the current value is 0 (SI)
    applies : callable or None
        ``applies(model) -> bool``
    same_as_effect : str or None
        Catalog effect carrying the same physics
    """
    path: str
    label: str
    typical: float
    lo: float
    hi: float
    span: float = 0.0
    applies: Optional[Callable] = None
    same_as_effect: Optional[str] = None


def _convective(m):
    return m.heat.model == "convective" and "heat_exchange" not in m.effects


#: The base parameters offered as hypotheses (one source: bounds and typical errors live here)
BASE_HYPOTHESES = {h.path: h for h in [
    BaseHypothesis("friction.extend.fc0", "Coulomb friction extending", 0.3, 0.0, 5.0, 20.0),
    BaseHypothesis("friction.retract.fc0", "Coulomb friction retracting", 0.3, 0.0, 5.0, 20.0,
                   same_as_effect="quadrant_friction"),
    BaseHypothesis("friction.extend.kv0", "viscous friction extending", 0.3, 0.0, 5.0, 100.0),
    BaseHypothesis("friction.retract.kv0", "viscous friction retracting", 0.3, 0.0, 5.0, 100.0,
                   same_as_effect="quadrant_friction"),
    BaseHypothesis("jack.moving_mass", "moving mass", 0.15, 0.2, 5.0),
    BaseHypothesis("heat.coefficient", "heat coefficient", 0.5, 0.02, 10.0, applies=_convective),
    BaseHypothesis("valve.ports.*.C", "valve conductance (scale)", 0.15, 0.2, 5.0),
    BaseHypothesis("supply.pressure", "supply pressure", 0.04, 0.7, 1.3),
    BaseHypothesis("jack.dead_volume_a", "dead volume A", 0.5, 0.05, 10.0,
                   same_as_effect="dead_volume"),
    BaseHypothesis("jack.dead_volume_b", "dead volume B", 0.5, 0.05, 10.0,
                   same_as_effect="dead_volume"),
]}


def label_of(path):
    """Human name of a base path (the path itself when it is not a registered hypothesis)."""
    h = BASE_HYPOTHESES.get(path)
    return h.label if h else path


def spec_for(model, hyp):
    """The :class:`ParameterSpec` that fits ``hyp`` from the current value of ``model``."""
    v = get_value(model, hyp.path)
    if v == 0.0:
        lo, hi = -hyp.span if hyp.lo < 0 else 0.0, hyp.span
    else:
        lo, hi = sorted((v * hyp.lo, v * hyp.hi))
    return ParameterSpec(hyp.path, v, lo, hi, True, unit_of(hyp.path))


def _step(model, hyp):
    v = get_value(model, hyp.path)
    return hyp.typical * abs(v) if v != 0.0 else 0.1 * hyp.span


def offered(model, candidates=(), exclude=()):
    """Base hypotheses that apply to ``model`` (and are not carried by a candidate effect)."""
    out = []
    for h in BASE_HYPOTHESES.values():
        if h.path in exclude:
            continue
        if h.applies is not None and not h.applies(model):
            continue
        if h.same_as_effect and h.same_as_effect in candidates:
            continue
        if get_value(model, h.path) == 0.0 and h.span == 0.0:
            continue
        out.append(h)
    return out


def identifiable(model, experiments, objective, r0, hyps, replay, visible=VISIBLE,
                 collinear=COLLINEAR):
    """Choose the base hypotheses the experiments can identify.

    Parameters
    ----------
    model : Model
        The model around which sensitivities are taken
    experiments : list
        Prepared experiments
    objective : pneucore.analysis.calibrate.Objective
        Gives noise-weighted residuals
    r0 : ndarray
        Its weighted residual at ``model``
    hyps : list of BaseHypothesis
        Offered hypotheses
    replay : callable
        ``replay(model, experiment)``
    visible, collinear : float
        See :data:`VISIBLE`, :data:`COLLINEAR`

    Returns
    -------
    chosen : list of BaseHypothesis
        Identifiable, separable, in order of sensitivity
    report : list of dict
        ``{path, label, sensitivity, status, with}`` per offered hypothesis;
        ``status`` is ``identifiable``, ``not visible`` or ``not separable`` (``with``: the
        chosen paths it is confounded with)
    columns : dict
        path -> sensitivity column per unit of the parameter [1/SI]
    """
    cols, norms, steps = {}, {}, {}
    for h in hyps:
        dv = _step(model, h)
        v0 = get_value(model, h.path)
        v1 = v0 + dv
        mp = set_values(model, {h.path: v1})
        rp = [replay(mp, e) for e in experiments]
        col = objective.weighted(rp) - r0
        cols[h.path] = col / dv
        norms[h.path] = float(col @ col)
        steps[h.path] = dv
    order = sorted(hyps, key=lambda h: -norms[h.path])
    chosen, report, basis = [], [], []
    for h in order:
        c = cols[h.path] * steps[h.path]
        nrm = math.sqrt(norms[h.path])
        entry = {"path": h.path, "label": h.label, "sensitivity": nrm}
        if norms[h.path] < visible:
            entry["status"] = "not visible"
        else:
            resid = c.copy()
            for q in basis:
                resid -= q * (q @ resid)
            frac = float(np.linalg.norm(resid)) / nrm if nrm > 0 else 0.0
            if frac < collinear:
                entry["status"] = "not separable"
                # the chosen parameters carrying most of this column
                w = [(abs(float(cols[k.path] @ c)) / (np.linalg.norm(cols[k.path]) + 1e-300), k.path)
                     for k in chosen]
                entry["with"] = [p for _, p in sorted(w, reverse=True)[:2]]
            else:
                entry["status"] = "identifiable"
                basis.append(resid / np.linalg.norm(resid))
                chosen.append(h)
        report.append(entry)
    return chosen, report, {p: cols[p] for p in cols}


# ------------------------------------------------------------------ residual signature

#: Regressors a residual is compared with, and how each is named in words
_REGRESSORS = {"x": "piston position", "v": "piston velocity", "p_a": "pressure in A",
               "p_b": "pressure in B", "t": "time", "1": "a constant (offset)"}


def residual_signature(replays):
    """Describe the largest remaining residual physically: signal, phase, proportional to what.

    The series with the largest share of the Eq. 25 error is taken; its
    residual (measured minus simulated) is compared with the simulated
    position, velocity, chamber pressures, time and a constant: the regressor
    explaining most of its energy (squared correlation through the origin)
    is named, with the phase where the residual energy concentrates.

    Returns
    -------
    signature : dict
        ``signal, experiment, phase, proportional_to, share, r2, description``
    """
    best = None
    for rp in replays:
        for s in rp.measured:
            m, g = rp.measured[s], rp.simulated[s]
            ok = np.isfinite(m) & np.isfinite(g)
            if not ok.any():
                continue
            d = np.where(ok, m - g, 0.0)
            e = float(np.sum(d * d) / max(np.sum(m[ok] ** 2), 1e-300))
            if best is None or e > best[0]:
                best = (e, rp, s, d, ok)
    if best is None:
        return {}
    _, rp, s, d, ok = best
    res = rp.result
    regs = {"1": np.ones_like(d), "t": rp.t}
    for k in ("x", "v", "p_a", "p_b"):
        try:
            y = np.asarray(res.observed(k), float)
        except Exception:   # a signal this model does not produce (p_b of a 3/2 valve)
            continue
        if y.shape == d.shape and np.all(np.isfinite(y[ok])) and np.ptp(y[ok]) > 0:
            regs[k] = y
    dd = d[ok]
    e_tot = float(dd @ dd) or 1e-300
    scores = {}
    for k, y in regs.items():
        yy = y[ok]
        den = float(yy @ yy)
        if den > 0:
            scores[k] = float(dd @ yy) ** 2 / den / e_tot
    # time and the constant both fit a drift: prefer the physical signal when within 5 %
    kbest = max(scores, key=lambda k: scores[k] + (0.05 if k in ("x", "v", "p_a", "p_b") else 0.0))
    labels = rp.cmd_labels
    phase_e = {}
    for lab in dict.fromkeys(labels.tolist()):
        sel = (labels == lab) & ok
        phase_e[lab] = float(np.sum(d[sel] ** 2))
    phase = max(phase_e, key=phase_e.get)
    share = phase_e[phase] / e_tot
    sign = "larger" if float(np.mean(dd)) > 0 else "smaller"
    desc = (f"{s} measured {sign} than simulated in {rp.experiment.name}, most of it while "
            f"{phase} ({100 * share:.0f} % of that residual), proportional to "
            f"{_REGRESSORS.get(kbest, kbest)} (explains {100 * scores[kbest]:.0f} % of it)")
    return {"signal": s, "experiment": rp.experiment.name, "phase": phase,
            "proportional_to": kbest, "r2": scores[kbest], "share": share, "description": desc}


def calibrated_error(replays):
    """Eq. 25 error left once each signal's best transducer gain and offset are removed.

    A transducer whose gain or offset is wrong records ``m = a + (1 + g) y``
    for the true signal ``y``: its residual against a simulation ``s`` close
    to ``y`` is, to first order, ``a + g s`` plus whatever the model lacks.
    Per signal (one transducer, pooled over the experiments), the residual
    ``m - s`` is regressed on ``[1, s]`` by least squares and the remainder
    gives the error (Eq. 25 of the paper on the corrected residual; overall:
    RMS over the signals, as :func:`pneucore.analysis.compare.summarise`).
    It is the misfit that a sensor calibration error, the commonest truth
    outside the catalog, cannot account for: what a catalog effect must
    explain.

    Parameters
    ----------
    replays : iterable of Replay
        Replayed experiments (:func:`pneucore.analysis.compare.replay`)

    Returns
    -------
    overall : float
        Error after the correction [-]
    per_signal : dict
        ``{signal: {"error", "offset", "gain"}}``: the error [-], the fitted offset
        (signal units, SI) and relative gain error [-] of each transducer
    """
    acc = {}
    for rp in replays:
        for s in rp.measured:
            m, g = np.asarray(rp.measured[s], float), np.asarray(rp.simulated[s], float)
            n = min(m.shape[0], g.shape[0])
            m, g = m[:n], g[:n]
            ok = np.isfinite(m) & np.isfinite(g)
            a = acc.setdefault(s, ([], []))
            a[0].append(m[ok])
            a[1].append(g[ok])
    out = {}
    for s, (ms, gs) in acc.items():
        m, g = np.concatenate(ms), np.concatenate(gs)
        den = float(m @ m)
        if m.size < 3 or den <= 0.0:
            continue
        A = np.column_stack([np.ones_like(g), g])
        coef, *_ = np.linalg.lstsq(A, m - g, rcond=None)
        d = m - g - A @ coef
        out[s] = {"error": math.sqrt(float(d @ d) / den), "offset": float(coef[0]),
                  "gain": float(coef[1])}
    if not out:
        return float("nan"), out
    return float(math.sqrt(np.mean([v["error"] ** 2 for v in out.values()]))), out
