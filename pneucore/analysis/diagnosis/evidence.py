"""The evidence of a refitted candidate beside the likelihood ratio: its share of the excess
over the noise floor, its fit with the next candidate, its agreement across experiments,
whether its strength is determined at all, and the words that explain it."""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from pneucore.analysis import hypotheses as H
from pneucore.analysis.calibrate import fit
from pneucore.analysis.compare import noise_floor, replay
from pneucore.analysis.diagnosis.rules import AT_FLOOR, CONSISTENT_RTOL, EXCESS_MATERIAL
from pneucore.analysis.metrics import eq25_error
from pneucore.analysis.parallel import pmap
from pneucore.analysis.records import Records
from pneucore.data.measurement import Measurement
from pneucore.description.effects import EFFECTS
from pneucore.description.paths import ParameterSpec


def excess_drop(e0, e1, floor):
    """Share of the misfit in excess of the noise floor that a change removes [-].

    ``(e0^2 - e1^2) / (e0^2 - floor^2)`` on squared Eq. 25 errors (energies add); 0 when the
    error before is already at the floor.
    """
    if not (floor == floor) or e0 <= floor:
        return 0.0
    return float((e0 * e0 - e1 * e1) / (e0 * e0 - floor * floor))


def own_error(rp):
    """Overall Eq. 25 error of one replay alone: the root mean square of its signals' [-]."""
    vals = [eq25_error(rp.measured[s], rp.simulated[s]) for s in rp.measured]
    vals = [v for v in vals if v == v]
    return float(math.sqrt(np.mean(np.square(vals)))) if vals else float("nan")


def experiment_excess(before, after):
    """Where a change removes the misfit in excess of the noise floor, experiment by experiment.

    The pooled Eq. 25 error of a signal is ``sqrt(sum_i SSE_i / sum_i D_i)`` over the
    experiments ``i`` (``D``: the sum of the measured squares), and the overall error the
    root mean square over the signals, so the squared overall error, and its noise floor,
    are sums of one term per experiment. A short record that shows an effect clearly (a
    1 s locked hold with a leak) carries little of that sum beside a long one whose misfit
    no catalog effect reaches (a free piston's position drifting over 20 cycles): the
    effect's share of the pooled excess is then small although it explains its own
    record down to the noise.

    Parameters
    ----------
    before : list of Replay
        The null model's replays of the experiments [-]
    after : list of Replay
        The candidate's replays of the same experiments, in the same order [-]

    Returns
    -------
    rows : list of dict
        Per experiment: ``experiment`` (name), ``error_before``, ``error_after`` and
        ``noise_floor`` (its own overall Eq. 25 errors) [-], ``excess_drop`` (the share of
        its own excess over its floor the change removes) [-], ``excess_share`` (the part
        of the pooled excess over the floor the change removes there; the rows sum to
        :func:`excess_drop` of the pooled errors) [-], ``cleared`` (it leaves that
        experiment at its floor, :data:`pneucore.analysis.diagnosis.rules.AT_FLOOR`,
        from above it) [-]
    """
    den, rows = {}, []
    for rp in before:
        for s, m in rp.experiment.measurement.signals.items():
            if s in rp.measured:
                ok = np.isfinite(m)
                den[s] = den.get(s, 0.0) + float(np.sum(m[ok] ** 2))
    n_sig = len(den)

    def energy(rp, fl):
        # this experiment's term of the pooled squared overall error, and of its floor (with
        # the floors ``fl`` of its signals; None: the error's term alone)
        e = f = 0.0
        for s in rp.measured:
            m = rp.experiment.measurement.signals[s]
            g = np.full(m.shape, np.nan)
            g[:rp.simulated[s].shape[0]] = rp.simulated[s][:m.shape[0]]
            ok = np.isfinite(m) & np.isfinite(g)
            if den.get(s, 0.0) > 0:
                e += float(np.sum((m[ok] - g[ok]) ** 2)) / den[s] / n_sig
                if fl is not None:
                    f += fl[s] ** 2 * float(np.sum(m[np.isfinite(m)] ** 2)) / den[s] / n_sig
        return e, f

    terms = []
    for r0, r1 in zip(before, after):
        fl = noise_floor([r0])   # the record's floors, found once for both replays' terms
        (e0, f), (e1, _) = energy(r0, fl), energy(r1, None)
        floor = float(math.sqrt(np.mean([v * v for v in fl.values()]))) if fl else float("nan")
        c0, c1 = own_error(r0), own_error(r1)
        whole = r1.t.shape[0] == r0.t.shape[0]   # the candidate's replay reached the end
        rows.append({"experiment": r0.experiment.name, "error_before": c0, "error_after": c1,
                     "noise_floor": floor, "excess_drop": excess_drop(c0, c1, floor),
                     "cleared": bool(whole and c0 > AT_FLOOR * floor and c1 <= AT_FLOOR * floor)})
        terms.append((e0, e1, f))
    excess = sum(e0 - f for e0, _, f in terms)
    for row, (e0, e1, _) in zip(rows, terms):
        row["excess_share"] = float((e0 - e1) / excess) if excess > 0 else 0.0
    return rows


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
    params = ", ".join(f"{k} = {v['value']:.3g} {v['unit']} (held off)" if v.get("held") else
                       f"{k} = {v['value']:.3g} ± {v['stderr']:.2g} {v['unit']}"
                       for k, v in cand["params"].items())
    from pneucore.analysis.shown import change_words
    return (f"Adding {eff.name} ({eff.description}) "
            f"{change_words(cand['error_before'], cand['error_after_overall'])}"
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
        if v is None or v.get("held"):   # held off in the effect's smaller form: not fitted
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
    """Candidate ``lead`` refitted together with the next significant one (each with the
    parameters its candidate holds off, ``held_off``, left off).

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
    for c in (lead, nxt[0]):
        name = c["effect"]
        eff = EFFECTS[name]
        vals = refits[name].model.effects[name]
        m.effects[name] = dict(vals)
        specs += [ParameterSpec(f"effects.{name}.{p}", vals[p], eff.param(p).min, eff.param(p).max,
                                True, eff.param(p).unit) for p in eff.diagnosis_params
                  if p not in eff.unused_in(model) and p not in c.get("held_off", ())]
    cal = fit(m, exps, specs + list(u_specs), max_nfev=max_nfev, compute_before=False,
              reweight=True, prior=H.prior_for(model, [s.path for s in u_specs]))
    e1 = cal.error_after.overall
    return {"effect": b, "error_after_overall": e1, "excess_drop": excess_drop(e0, e1, floor)}


def fit_alone(model, specs, max_nfev, e):
    """``specs`` fitted on experiment ``e`` alone from ``model`` (one fit of :func:`consistency`);
    ``e`` an experiment, or the records of it alone (:meth:`pneucore.analysis.records.Records.
    subset`: its weights and the replay cache as prepared for all of them)."""
    return fit(model, e if isinstance(e, list) else [e], specs, max_nfev=max_nfev,
               compute_before=False)


def consistency(cal, exps, name, max_nfev=30, skip=None, held=()):
    """Do the experiments agree on the effect's parameters? (a physical effect: yes)

    The effect's parameters are refitted on each experiment alone, the base
    parameters held at the joint fit. A physical effect has the same
    parameters in every experiment; a stand-in for a mis-set parameter or for
    something outside the catalog takes whatever value helps each experiment.
    Two estimates agree when they differ by less than :data:`CONSISTENT_RTOL`
    of the larger, or by less than three standard errors of the difference
    (each inflated by the square root of its residual's autocorrelation time).
    Experiments in which the effect does not act (``observable_in``) or whose
    estimate has a relative standard error above 1 are not compared, nor those of
    ``skip`` (:func:`not_compared`: records the effect explains nothing of, beside one it
    explains down to the noise). Parameters of ``held`` stay where ``cal`` has them (off, in
    an effect's smaller form).

    Returns
    -------
    report : dict
        ``consistent`` (True, or False when two estimates disagree), ``per_experiment``
        ``{experiment: {param: {value, stderr}}}``, ``not_compared`` ``{experiment: why}``,
        ``disagree`` (the parameters whose estimates disagree), ``summary``
    """
    skip = dict(skip or {})
    eff = EFFECTS[name]
    per = {}
    specs = [ParameterSpec(f"effects.{name}.{p}", cal.model.effects[name][p], eff.param(p).min,
                           eff.param(p).max, True, eff.param(p).unit)
             for p in eff.score_params if p not in held]
    acting = [e for e in exps if e.name not in skip
              and ("locked" if e.scenario.get("locked") else "free") in eff.observable_in]
    if not specs:
        acting = []

    # each experiment's fit is independent of the others': in parallel on the cores, or one
    # task each on the diagnosis's Dask cluster
    at = {id(e): i for i, e in enumerate(exps)}
    alone = ([exps.subset([at[id(e)]]) for e in acting] if isinstance(exps, Records)
             else acting)
    fits = pmap(fit_alone, alone, (cal.model, specs, max(max_nfev // 2, 8)),
                f"consistency across experiments: {name}")
    for e, c1 in zip(acting, fits):
        est = {}
        for sp in specs:
            v = c1.values[sp.path]
            if abs(v["value"]) > 0 and v["stderr"] < abs(v["value"]):
                est[sp.path.split(".")[-1]] = {"value": v["value"], "stderr": v["stderr"]}
        per[e.name] = est
    bad, disagree = [], set()
    names = list(per)
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            a, b = per[names[i]], per[names[j]]
            for p in sorted(set(a) & set(b)):
                va, vb = a[p]["value"], b[p]["value"]
                se = math.sqrt(a[p]["stderr"] ** 2 + b[p]["stderr"] ** 2)
                if abs(va - vb) > CONSISTENT_RTOL * max(abs(va), abs(vb)) and abs(va - vb) > 3 * se:
                    bad.append(f"{p} = {va:.3g} on {names[i]}, {vb:.3g} on {names[j]}")
                    disagree.add(p)
    return {"consistent": not bad, "per_experiment": per, "not_compared": skip,
            "disagree": sorted(disagree), "summary": "; ".join(bad) if bad else "the experiments agree"}


def not_compared(rows):
    """``{experiment: why}``: the records whose estimates of an effect's parameters say nothing
    of it, from the candidate's :func:`experiment_excess` ``rows``.

    Where the effect brings some record from above its noise floor down to it, a record of
    whose excess it removes less than :data:`EXCESS_MATERIAL` carries no evidence of its
    value: fitted there alone, the effect takes whatever value helps with the misfit that
    lies outside the catalog (a free piston's position drifting on a long record), the
    stand-in behaviour the comparison looks for in the effect itself. Where it clears no
    record, every record is compared.
    """
    if not any(r["cleared"] for r in rows):
        return {}
    return {r["experiment"]: (f"the effect removes {100 * r['excess_drop']:.0f} % of its excess "
                              f"over the noise floor (error {100 * r['error_before']:.2f} % -> "
                              f"{100 * r['error_after']:.2f} %, floor {100 * r['noise_floor']:.2f} "
                              "%), while it brings another record to its floor")
            for r in rows if not r["cleared"] and r["excess_drop"] < EXCESS_MATERIAL}




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
             max_nfev, loeo=None, enough=None):
    """Does the candidate predict data it was not fitted on better than the null?

    **Blocks in time.** Each experiment is cut into ``n_folds`` blocks in time; for each
    fold ``k`` the null's and the candidate's parameters are refitted (from their full
    fits, reweighted, under the same ``prior``) on every experiment with its ``k``-th block
    marked missing, and each model predicts the held-out blocks: the squared prediction
    errors, series scaled by ``scales``, are compared. A smooth misspecified residual or
    coloured noise inflates both models' held-out errors alike; it does not let an effect
    that only fits what it was fitted on predict what it was not.

    **Experiments left out** (``loeo`` given and at least two experiments): for each
    experiment, the null and the candidate are fitted on all the others, from the model as
    given (``loeo``: nothing of the left-out record enters, not even through a starting
    point), and predict it whole. A stand-in takes whatever helps the records it is fitted
    on; a physical effect fitted on some records predicts another.

    Parameters
    ----------
    null_model, cand_model : Model
        The null's and the candidate's full fits [-]
    null_specs, cand_specs : list of ParameterSpec
        Their parameters, starting at those fits [-]
    exps : list of Experiment
        The experiments [-]
    scales : dict
        ``{(experiment, signal): residual RMS}`` of the null (unit of the signal)
    prior : dict
        The catalogue prior of the base parameters [-]
    n_folds : int
        Blocks in time per experiment [-]
    max_nfev : int
        Evaluation budget of each block refit [-]
    loeo : tuple or None
        ``(null start model, null start specs, candidate start model, candidate start
        specs)``: the fits' starting points for the experiment folds (None: none) [-]
    enough : callable or None
        ``enough(report) -> bool``: the blocks in time already show what is asked; the
        experiments are then not left out (their refits spared, ``used`` says so) [-]

    Returns
    -------
    report : dict
        ``folds`` [{``null``, ``candidate``}] held-out energies of the blocks, ``wins``
        (blocks where the candidate predicts better), ``drop`` (1 - candidate's / null's
        held-out energy over all blocks) [-]; ``experiment_folds`` [{``experiment``,
        ``null``, ``candidate``}], ``experiment_wins``, ``experiment_drop`` likewise for the
        experiments left out (empty, 0 and 0 without them); ``used``: the folds in words
    """
    # each fold a piece of work of its own: on this machine's threads, or one task each on the
    # diagnosis's Dask cluster, the common arguments sent there once
    folds = pmap(block_fold, range(n_folds), (null_model, null_specs, cand_model, cand_specs, exps,
                                              scales, prior, n_folds, max_nfev),
                 "held-out blocks")
    out = {"folds": folds, "n_folds": n_folds}
    out["wins"], out["drop"] = _vote(folds)
    used = f"{n_folds} blocks in time of each of {len(exps)} experiment{'s' * (len(exps) != 1)}"
    efolds = []
    if loeo is None:
        used += "; no experiment left out"
    elif len(exps) < 2:
        used += "; no experiment left out (one experiment)"
    elif enough is not None and enough(out):
        used += "; no experiment left out (the blocks in time already show it)"
    else:
        efolds = pmap(experiment_fold, range(len(exps)),
                      (tuple(loeo), exps, scales, prior, max_nfev), "held-out experiments")
        used += (f"; each of the {len(efolds)} experiments left out in turn, fitted on the "
                 "others from the model as given")
    out["experiment_folds"] = efolds
    out["experiment_wins"], out["experiment_drop"] = _vote(efolds)
    out["used"] = used
    return out


def block_fold(null_model, null_specs, cand_model, cand_specs, exps, scales, prior, n_folds,
               max_nfev, k):
    """Fold ``k`` of :func:`held_out`'s blocks in time: ``{"null", "candidate"}`` held-out
    energies, each model refitted with the ``k``-th block of every experiment marked missing
    (a piece of work for :func:`pneucore.analysis.parallel.pmap`) [-]."""
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


def experiment_fold(loeo, exps, scales, prior, max_nfev, i):
    """Experiment ``i`` left out of :func:`held_out`'s fits: ``{"experiment", "null",
    "candidate"}``, each model fitted on the others from its start in ``loeo`` and predicting
    it whole (a piece of work for :func:`pneucore.analysis.parallel.pmap`) [-]."""
    held = exps[i]
    others = [j for j in range(len(exps)) if j != i]
    train = exps.subset(others) if isinstance(exps, Records) else [exps[j] for j in others]
    out = {"experiment": held.name}
    for key, m, specs in (("null",) + tuple(loeo[:2]), ("candidate",) + tuple(loeo[2:])):
        mk = m
        if specs:
            # from the model as given: the budget of a joint refit, which starts there too
            mk = fit(m, train, specs, max_nfev=2 * max_nfev, compute_before=False,
                     reweight=True, prior=prior).model
        out[key] = block_energy(mk, [held], {held.name: (0, held.measurement.t.size)}, scales)
    return out


def _vote(folds):
    """``(wins, drop)`` of held-out folds: where the candidate predicts better, and 1 - its
    held-out energy over the null's, over the folds whose replays finished [-]."""
    good = [f for f in folds if f["null"] == f["null"] and f["candidate"] == f["candidate"]]
    wins = sum(f["candidate"] < f["null"] for f in good)
    e0 = sum(f["null"] for f in good)
    e1 = sum(f["candidate"] for f in good)
    return wins, ((1.0 - e1 / e0) if good and e0 > 0 else 0.0)
