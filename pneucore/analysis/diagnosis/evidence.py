"""The evidence of a refitted candidate beside the likelihood ratio: its share of the excess
over the noise floor, its fit with the next candidate, its agreement across experiments,
whether its strength is determined at all, and the words that explain it."""
from __future__ import annotations

import dataclasses
import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from pneucore.analysis import calibrate as _calibrate
from pneucore.analysis import hypotheses as H
from pneucore.analysis.calibrate import fit
from pneucore.analysis.compare import replay
from pneucore.analysis.diagnosis.rules import CONSISTENT_RTOL
from pneucore.analysis.parallel import pmap
from pneucore.data.measurement import Measurement
from pneucore.spec.effects import EFFECTS
from pneucore.spec.paths import ParameterSpec


def excess_drop(e0, e1, floor):
    """Share of the misfit in excess of the noise floor that a change removes [-].

    ``(e0^2 - e1^2) / (e0^2 - floor^2)`` on squared Eq. 25 errors (energies add); 0 when the
    error before is already at the floor.
    """
    if not (floor == floor) or e0 <= floor:
        return 0.0
    return float((e0 * e0 - e1 * e1) / (e0 * e0 - floor * floor))


def improvement(before, after):
    """Where the error fell: list of {signal, phase, before, after, drop} sorted by drop."""
    out = []
    for ph, row in before.phases.items():
        for s, e0 in row.items():
            if s == "overall":
                continue
            e1 = after.phases.get(ph, {}).get(s)
            if e0 is None or e1 is None:
                continue
            out.append({"signal": s, "phase": ph, "before": e0, "after": e1, "drop": e0 - e1})
    out.sort(key=lambda d: -d["drop"])
    return out


def explain(eff, cand, floor_overall):
    """The candidate's finding in words (where the error fell, its fitted parameters, LR, BIC)."""
    lands = cand["improvement"][:2]
    where = "; ".join(f"{d['signal']} while {d['phase']} ({100 * d['before']:.2f} % -> "
                      f"{100 * d['after']:.2f} %)" for d in lands if d["drop"] > 0) or "nowhere in particular"
    # the same standard error as the ranking's table (its 95 % interval is ci95 there)
    params = ", ".join(f"{k} = {v['value']:.3g} ± {v['stderr']:.2g} {v['unit']}"
                       for k, v in cand["params"].items())
    return (f"Adding {eff.name} ({eff.description}) lowers the overall error from "
            f"{100 * cand['error_before']:.2f} % to {100 * cand['error_after_overall']:.2f} %"
            f" (noise floor about {100 * floor_overall:.2f} %). The improvement lands on {where}. "
            f"This matches the effect's signature: {eff.signature}. Fitted (± standard error): {params}. "
            f"Likelihood-ratio p = {cand['p_value']:.2g}, delta BIC = {cand['delta_bic']:.1f}.")


def undetermined(cand):
    """Why a refitted candidate's strength is not determined, or ``""``.

    A strength parameter (one with an ``off`` value) at its fit bound, or whose standard
    error exceeds its distance from off, does not show the effect, whatever the fit's
    improvement: the improvement then comes from what the bound or the confounding lets
    the effect stand in for.
    """
    eff = EFFECTS[cand["effect"]]
    bound, vague, n = [], [], 0
    for p in eff.score_params:
        v = cand["params"].get(p)
        if v is None:
            continue
        n += 1
        off = eff.param(p).off
        if v.get("at_bound") and v["value"] != off:
            bound.append(f"{p} at its fit bound")
        elif not v["stderr"] < abs(v["value"] - off):
            vague.append(f"{p} = {v['value']:.3g} +- {v['stderr']:.2g} {v.get('unit', '')}".rstrip()
                         + " is not distinguishable from off")
    # one strength away from off is enough (the others may legitimately be off: one chamber's
    # leak); a strength held by its bound never is
    if bound or (n and len(vague) == n):
        return "; ".join(bound + vague)
    return ""


def given_prior(v):
    """A fitted effect parameter's entry: the posterior standard error where a prior applied.

    ``stderr_data`` keeps the data's alone; ``ci95`` is the value +- 1.96 standard errors.
    """
    out = dict(v)
    if "stderr_prior" in out:
        out["stderr_data"] = out["stderr"]
        out["stderr"] = out.pop("stderr_prior")
    out["ci95"] = [out["value"] - 1.96 * out["stderr"], out["value"] + 1.96 * out["stderr"]]
    return out


def pair(model, exps, lead, ranking, refits, u_specs, e0, floor, max_nfev, report):
    """Candidate ``lead`` refitted together with the next significant one.

    Returns ``{"effect", "error_after_overall", "excess_drop"}`` or None when there is no
    second significant, material candidate.
    """
    nxt = [c for c in ranking if c is not lead and c["significant"] and c["material"]]
    if not nxt:
        return None
    a, b = lead["effect"], nxt[0]["effect"]
    report(0.95, f"refit: {a} with {b}")
    m = model.copy()
    specs = []
    for name in (a, b):
        eff = EFFECTS[name]
        vals = refits[name].model.effects[name]
        m.effects[name] = dict(vals)
        specs += [ParameterSpec(f"effects.{name}.{p}", vals[p], eff.param(p).min, eff.param(p).max,
                                True, eff.param(p).unit) for p in eff.diagnosis_params
                  if p not in eff.unused_in(model)]
    cal = fit(m, exps, specs + list(u_specs), max_nfev=max_nfev, compute_before=False,
              reweight=True, prior=H.prior_for(model, [s.path for s in u_specs]))
    e1 = cal.error_after.overall
    return {"effect": b, "error_after_overall": e1, "excess_drop": excess_drop(e0, e1, floor)}



def fit_alone(model, specs, max_nfev, e):
    """``specs`` fitted on experiment ``e`` alone from ``model`` (one fit of :func:`consistency`)."""
    return fit(model, [e], specs, max_nfev=max_nfev, compute_before=False)

def consistency(cal, exps, name, max_nfev=30):
    """Do the experiments agree on the effect's parameters? (a physical effect: yes)

    The effect's parameters are refitted on each experiment alone, the base
    parameters held at the joint fit. A physical effect has the same
    parameters in every experiment; a stand-in for a mis-set parameter or for
    something outside the catalog takes whatever value helps each experiment.
    Two estimates agree when they differ by less than :data:`CONSISTENT_RTOL`
    of the larger, or by less than three standard errors of the difference
    (each inflated by the square root of its residual's autocorrelation time).
    Experiments in which the effect does not act (``observable_in``) or whose
    estimate has a relative standard error above 1 are not compared.

    Returns
    -------
    report : dict
        ``consistent`` (True, or False when two estimates disagree), ``per_experiment``
        ``{experiment: {param: {value, stderr}}}``, ``summary``
    """
    eff = EFFECTS[name]
    per = {}
    specs = [ParameterSpec(f"effects.{name}.{p}", cal.model.effects[name][p], eff.param(p).min,
                           eff.param(p).max, True, eff.param(p).unit)
             for p in eff.score_params]
    acting = [e for e in exps
              if ("locked" if e.scenario.get("locked") else "free") in eff.observable_in]
    if not specs:
        acting = []

    # each experiment's fit is independent of the others': in parallel on the cores, or one
    # task each on the diagnosis's Dask cluster
    fits = pmap(fit_alone, acting, (cal.model, specs, max(max_nfev // 2, 8)),
                f"consistency across experiments: {name}")
    for e, c1 in zip(acting, fits):
        est = {}
        for sp in specs:
            v = c1.values[sp.path]
            if abs(v["value"]) > 0 and v["stderr"] < abs(v["value"]):
                est[sp.path.split(".")[-1]] = {"value": v["value"], "stderr": v["stderr"]}
        per[e.name] = est
    bad = []
    names = list(per)
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            a, b = per[names[i]], per[names[j]]
            for p in set(a) & set(b):
                va, vb = a[p]["value"], b[p]["value"]
                se = math.sqrt(a[p]["stderr"] ** 2 + b[p]["stderr"] ** 2)
                if abs(va - vb) > CONSISTENT_RTOL * max(abs(va), abs(vb)) and abs(va - vb) > 3 * se:
                    bad.append(f"{p} = {va:.3g} on {names[i]}, {vb:.3g} on {names[j]}")
    return {"consistent": not bad, "per_experiment": per,
            "summary": "; ".join(bad) if bad else "the experiments agree"}




# -- held-out prediction ----------------------------------------------------------------------

def masked(exp, k, n_folds):
    """A copy of experiment ``exp`` with its ``k``-th of ``n_folds`` blocks of samples in time
    marked missing (NaN in every compared signal); the scenario and the initial state are
    the full record's (read from its first samples, copied, not re-estimated)."""
    n = exp.measurement.t.size
    lo, hi = (k * n) // n_folds, ((k + 1) * n) // n_folds
    sig = {s: np.array(v, float) for s, v in exp.measurement.signals.items()}
    for s in exp.signals:
        sig[s][lo:hi] = np.nan
    meas = Measurement(exp.measurement.t, sig, exp.measurement.name, dict(exp.measurement.meta))
    out = dataclasses.replace(exp, measurement=meas)
    out._first_cache.update(exp._first_cache)
    return out, (lo, hi)


def block_energy(model, exps, blocks, scales):
    """Squared prediction error of ``model`` on the held-out ``blocks`` (``{experiment name:
    (lo, hi)}``), each series scaled by ``scales[(experiment, signal)]`` (the null's residual
    RMS): sum of squares [-], NaN where the replay failed."""
    total = 0.0
    for e in exps:
        lo, hi = blocks[e.name]
        rp = replay(model, e)
        for s in e.signals:
            m = e.measurement.signals[s][lo:hi]
            g = np.full(m.shape, np.nan)
            sim = rp.simulated[s][lo:hi]
            g[:sim.shape[0]] = sim
            ok = np.isfinite(m)
            if not np.all(np.isfinite(g[ok])):
                return float("nan")
            total += float(np.sum(((m[ok] - g[ok]) / scales[(e.name, s)]) ** 2))
    return total


def held_out(null_model, null_specs, cand_model, cand_specs, exps, scales, prior, n_folds,
             max_nfev):
    """Does the candidate predict data it was not fitted on better than the null?

    Each experiment is cut into ``n_folds`` blocks in time; for each fold ``k`` the null's
    and the candidate's parameters are refitted (from their full fits, reweighted, under the
    same ``prior``) on every experiment with its ``k``-th block marked missing, and each
    model predicts the held-out blocks: the squared prediction errors, series scaled by
    ``scales``, are compared. A smooth misspecified residual or coloured noise inflates
    both models' held-out errors alike; it does not let an effect that only fits what it
    was fitted on predict what it was not.

    Returns
    -------
    report : dict
        ``folds`` [{``null``, ``candidate``}] held-out energies, ``wins`` (folds where the
        candidate predicts better), ``drop`` (1 - candidate's / null's held-out energy over
        all folds) [-]
    """
    def one(k):
        cut = [masked(e, k, n_folds) for e in exps]
        train = [c for c, _ in cut]
        blocks = {e.name: b for e, (_, b) in zip(exps, cut)}
        out = {}
        for key, m, specs in (("null", null_model, null_specs), ("candidate", cand_model, cand_specs)):
            mk = m
            if specs:
                mk = fit(m, train, specs, max_nfev=max_nfev, compute_before=False, reweight=True,
                         prior=prior).model
            out[key] = block_energy(mk, exps, blocks, scales)
        return out

    with ThreadPoolExecutor(_calibrate.THREADS) as pool:
        folds = list(pool.map(one, range(n_folds)))
    good = [f for f in folds if f["null"] == f["null"] and f["candidate"] == f["candidate"]]
    wins = sum(f["candidate"] < f["null"] for f in good)
    e0 = sum(f["null"] for f in good)
    e1 = sum(f["candidate"] for f in good)
    return {"folds": folds, "n_folds": n_folds, "wins": wins,
            "drop": (1.0 - e1 / e0) if good and e0 > 0 else 0.0}
