"""The stages of a diagnosis, each a function of what the stages before it found.

:func:`pneucore.analysis.diagnose.diagnose` runs them in this order:

1. :func:`candidate_effects` - the catalog effects worth testing on this model;
2. :func:`base_hypotheses` - the base parameters the experiments identify (and the
   initial state a record does not give);
3. :func:`null_fit` - those parameters refitted: the null model, a :class:`Null`;
4. :func:`candidate_scores` - the cheap score (Lagrange-multiplier) test of every candidate;
5. :func:`joint_refits` - the leading candidates fitted with the base parameters;
6. :func:`evidence` - LR, BIC, error drops of each refit against the null: the ranking;
7. :func:`verdict` - the rules of :mod:`pneucore.analysis.diagnosis.rules` on the ranking;
8. :func:`pneucore.analysis.diagnosis.findings.findings` - what is mis-set, the next model,
   alternatives, what remains.
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from pneucore.analysis import calibrate as _calibrate
from pneucore.analysis import hypotheses as H
from pneucore.analysis import parallel as P
from pneucore.analysis.autocorrelation import effective_lr, residual_times, times_report
from pneucore.analysis.calibrate import Objective, fit, information_criteria
from pneucore.analysis.compare import replay
from pneucore.analysis.records import prepared
from pneucore.analysis.diagnosis import rules as R
from pneucore.analysis.diagnosis.evidence import (consistency, excess_drop, experiment_excess,
                                                  given_prior, held_out, improvement, explain,
                                                  not_compared, pair, undetermined)
from pneucore.analysis.engineering import impossible
from pneucore.description.effects import EFFECTS
from pneucore.description.paths import ParameterSpec, get_value, parse_parameters, set_values, unit_of

#: Relative change below which a refitted base parameter is not reported as mis-set
RECAL_MIN = 0.02

NO_EFFECT = "no catalog effect explains the remaining residual"


def with_effect(model, name, values):
    """A copy of ``model`` with effect ``name`` set to ``values``."""
    m = model.copy()
    m.effects[name] = dict(values)
    return m


def unit_residuals(replays):
    """Residuals (measured - simulated) scaled to unit RMS per (experiment, signal), stacked."""
    parts, keys = [], []
    for rp in replays:
        for s in rp.measured:
            m = rp.experiment.measurement.signals[s]
            ok = np.isfinite(m)
            g = np.full(m.shape[0], np.nan)
            g[:rp.simulated[s].shape[0]] = rp.simulated[s]
            d = np.where(np.isfinite(g), m - g, 0.0)[ok]
            rms = math.sqrt(np.mean(d ** 2)) if d.size else 1.0
            parts.append(d / max(rms, 1e-300))
            keys.append((rp.experiment.name, s, ok, max(rms, 1e-300)))
    return np.concatenate(parts), keys


def stack(replays, keys):
    """Simulated outputs stacked in the order of ``keys``, scaled like the residuals."""
    parts = []
    by = {(rp.experiment.name, s): rp for rp in replays for s in rp.measured}
    for name, s, ok, rms in keys:
        rp = by[(name, s)]
        g = np.full(ok.shape[0], np.nan)
        g[:rp.simulated[s].shape[0]] = rp.simulated[s]
        g = g[ok]
        parts.append(np.where(np.isfinite(g), g, 0.0) / rms)
    return np.concatenate(parts)


def lm_statistic(r, J, one_sided):
    """LM statistic of residual ``r`` on columns ``J`` with a crude active set for one-sided strengths."""
    cols = list(range(J.shape[1]))
    for _ in range(J.shape[1] + 1):
        if not cols:
            return 0.0, []
        Jc = J[:, cols]
        coef, *_ = np.linalg.lstsq(Jc, r, rcond=None)
        bad = [c for c, b in zip(cols, coef) if one_sided[c] and b < 0]
        if not bad:
            fitted = Jc @ coef
            return float(fitted @ fitted), cols
        cols = [c for c in cols if c not in bad]
    return 0.0, []


def project_out(J, Ju):
    """``J`` with the column space of ``Ju`` projected out (``J`` itself when ``Ju`` is empty)."""
    if Ju is None or Ju.shape[1] == 0:
        return J
    Q, _ = np.linalg.qr(Ju)
    return J - Q @ (Q.T @ J)


# -- 1. candidates ------------------------------------------------------------------------

def candidate_effects(model, names, uncertain=()):
    """``(candidates, skipped)``: the effects of ``names`` not in the model and applicable to
    it; ``skipped`` lists the others with the reason. An effect whose physics the declared
    ``uncertain`` paths already fit (the quadrant effect beside both directions' friction
    levels declared uncertain: :attr:`pneucore.description.effects.Effect.ties`) is skipped too: fitted
    beside them it is the same freedom twice, and a model carrying both cannot be built."""
    unc = set(uncertain if isinstance(uncertain, (list, tuple)) else dict(uncertain))
    cands, skipped = [], []
    for n in names:
        if n in model.effects:
            skipped.append({"effect": n, "reason": "already in the model"})
            continue
        ok, why = EFFECTS[n].applicable(model)
        if not ok:
            skipped.append({"effect": n, "reason": why})
            continue
        twice = sorted({q for src, dst in EFFECTS[n].ties.items() if src in unc
                        for q in dst if q in unc})
        if twice:
            skipped.append({"effect": n, "reason": "the parameters declared uncertain already "
                            "fit what it adds (" + ", ".join(twice) + " beside "
                            + ", ".join(sorted(k for k in EFFECTS[n].ties if k in unc)) + ")"})
            continue
        cands.append(n)
    return cands, skipped


def buildable(cal, name):
    """Why candidate ``name``'s refit ``cal`` is no model a user could be given, or ``""``:
    its model must read back as the API reads a model (a candidate the diagnosis built is
    skipped with the reason, never answered as the user's error)."""
    from pneucore.description.model import Model
    from pneucore.description.validation import FieldError
    try:
        Model.from_dict(cal.model.to_dict())
    except (FieldError, ValueError) as exc:
        return f"cannot be built on this model: {getattr(exc, 'detail', exc)}"
    return ""


# -- 2. base hypotheses -------------------------------------------------------------------

@dataclass
class Hypotheses:
    """The base parameters a diagnosis refits, and how they were chosen.

    ``exps`` are the experiments replayed from the initial state found (``initial_state``);
    ``auto`` tells whether the choice was automatic; ``auto_specs`` the chosen parameters;
    ``unc`` the ``uncertain`` ones given by the caller; ``id_cols`` their sensitivities.
    """
    exps: list
    unc: dict
    auto: bool
    auto_specs: list = field(default_factory=list)
    identifiability: list = field(default_factory=list)
    id_cols: dict = field(default_factory=dict)
    initial_state: list = field(default_factory=list)
    user_known: list = field(default_factory=list)
    held: set = field(default_factory=set)
    carried: list = field(default_factory=list)


def base_hypotheses(model, exps, cands, uncertain, known, automatic, rps_start, report):
    """Which base parameters can the experiments identify? (and the initial state a record
    does not give, where the record identifies it: the rest of the diagnosis replays the
    experiments from it). With ``uncertain`` given, or ``automatic`` false, nothing is chosen.
    """
    unc = {p: {} for p in uncertain} if isinstance(uncertain, (list, tuple)) else dict(uncertain)
    hyp = Hypotheses(exps, unc, bool(not unc and automatic))
    if not hyp.auto:
        return hyp
    report(0.015, "initial state")
    hyp.exps, hyp.initial_state, init_report = H.fit_initial_state(model, exps, replay)
    hyp.identifiability += [{**h, "label": f"{h['path']} of {h['experiment']}",
                             "sensitivity": None} for h in init_report]
    rps_id = [replay(model, e) for e in hyp.exps] if hyp.initial_state else rps_start
    obj_s = Objective(model, hyp.exps, [])
    offered = H.offered(model, cands, exclude=known)
    # a value the user typically knows is judged last: what it changes is first given to the
    # parameters it may be confounded with
    hyp.user_known = H.user_known(model, offered)
    chosen, base_report, hyp.id_cols = H.identifiable(
        model, hyp.exps, obj_s, obj_s.weighted(rps_id), offered, replay, last=hyp.user_known)
    hyp.identifiability = base_report + hyp.identifiability
    hyp.auto_specs = [H.spec_for(model, h) for h in chosen]
    # what a candidate effect carries beside a level of both directions (the quadrant effect:
    # the retract level alone): a value the user knows is confounded with it too (a load
    # shifts the two Coulomb levels, one up and one down, as the quadrant difference does), so
    # that it is not freed to stand in for the effect (:func:`demand`)
    if hyp.user_known:
        beside = {h.only_beside for h in offered if h.only_beside}
        carried = [h for h in H.BASE_HYPOTHESES.values() if h.same_as_effect in beside
                   and h.path not in hyp.id_cols and (h.applies is None or h.applies(model))]
        r0 = obj_s.weighted(rps_id)
        for h in carried:
            _, dv, col = H.sensitivity_column(model, obj_s, r0, replay, h)
            hyp.id_cols[h.path] = col / dv
            hyp.carried.append(h.path)
    return hyp


# -- 3. null fit ---------------------------------------------------------------------------

@dataclass
class Null:
    """The null model (uncertain base parameters refitted) and what the later stages read.

    ``specs``: the fitted parameters at the null's values; ``specs_start``: the same from
    the model as given (the joint refits start there); ``prior``: the catalogue prior;
    ``comp``/``replays``/``rss``: its comparison, replays and residual sums;
    ``r``/``keys``/``y``: unit-scaled residual, its layout and the scaled outputs.
    """
    base: object
    fit: object
    specs: list
    specs_start: list
    auto_specs: list
    base_paths: list
    prior: dict
    comp: object
    replays: list
    rss: object
    m2ll: float
    n_all: int
    r: object
    keys: list
    y: object
    floor_overall: float

    @property
    def error(self):
        """Its overall Eq. 25 error [-]."""
        return self.comp.overall


def uncertain_paths(model, hyp, known, refit_existing):
    """The caller's uncertain paths, with the parameters of effects already in the model
    (``refit_existing``: fitted on a model that lacked what is sought now) unless known."""
    unc = dict(hyp.unc)
    if refit_existing:
        for name in model.effects:
            eff = EFFECTS[name]
            for p in eff.diagnosis_params + eff.refit_in(model.effects[name]):
                if f"effects.{name}.{p}" not in known:
                    unc.setdefault(f"effects.{name}.{p}", {})
    return unc


def null_fit(model, exps, hyp, unc, comp_start, rps_start, max_nfev, report, held=()):
    """The null model: the chosen base parameters and ``unc`` refitted, reweighted by each
    series' own residual, under the catalogue prior (a direction the data do not resolve
    stays where the user put it, :func:`pneucore.analysis.hypotheses.prior_for`).

    ``held``: base paths held at the model's values (not fitted) although chosen.
    """
    auto_specs = [s for s in hyp.auto_specs if s.path not in held]
    u_specs = auto_specs + (parse_parameters(model, unc) if unc else [])
    base_paths = [s.path for s in u_specs if not s.path.startswith("effects.")]
    u_specs_start = list(u_specs)
    prior = H.prior_for(model, base_paths)
    if u_specs:
        nf = fit(model, exps, u_specs, max_nfev=max_nfev, progress=report, span=(0.02, 0.05),
                 step="fitting the base model", reweight=True, prior=prior)
        # a hypothesis confounded in the small with parameters the fit drove to a bound (a
        # load taken up by a Coulomb level that cannot go below 0) is needed after all
        freed = [p for p in (H.freed_by_bounds(hyp.identifiability, nf.values) if hyp.auto else [])
                 if p not in held]
        if freed:
            report(0.04, "refitting the base model with " + ", ".join(H.label_of(p) for p in freed))
            auto_specs = auto_specs + [H.spec_for(model, H.BASE_HYPOTHESES[p]) for p in freed]
            u_specs = auto_specs + (parse_parameters(model, unc) if unc else [])
            base_paths = [s.path for s in u_specs if not s.path.startswith("effects.")]
            u_specs_start = list(u_specs)
            prior = H.prior_for(model, base_paths)
            nf = fit(model, exps, u_specs, max_nfev=max_nfev, compute_before=False,
                     reweight=True, prior=prior)
        base = nf.model
        u_specs = [ParameterSpec(s.path, nf.values[s.path]["value"], s.min, s.max, s.vary, s.unit)
                   for s in u_specs]
        # the fit's end point is already simulated: its comparison is the null's
        comp0 = nf.error_after
        rps0 = comp0.replays
    else:
        nf, base, rps0, comp0 = None, model, rps_start, comp_start
    rss0 = Objective(base, exps, []).rss(rps0)
    m2ll0, _, _, n_all = information_criteria(rss0, len(u_specs))
    r0, keys = unit_residuals(rps0)
    floor = comp0.noise_floor
    floor_overall = float(math.sqrt(np.mean(np.square([v for v in floor.values() if v == v])))) \
        if floor else float("nan")
    return Null(base, nf, u_specs, u_specs_start, auto_specs, base_paths, prior, comp0, rps0,
                rss0, m2ll0, n_all, r0, keys, stack(rps0, keys), floor_overall)


def orthogonal_part(cols, path, others):
    """``(fraction, with)``: the part of ``path``'s sensitivity column orthogonal to the
    columns of ``others`` (least squares), as a fraction of its norm [-], and the two of
    ``others`` carrying most of it."""
    use = [p for p in others if p in cols and p != path]
    c = cols.get(path)
    if c is None or not use or not np.linalg.norm(c):
        return 1.0, []
    A = np.column_stack([cols[p] for p in use])
    coef, *_ = np.linalg.lstsq(A, c, rcond=None)
    frac = float(np.linalg.norm(c - A @ coef) / np.linalg.norm(c))
    share = sorted(((abs(k) * np.linalg.norm(cols[p]), p) for k, p in zip(coef, use)),
                   reverse=True)
    return frac, [p for _, p in share[:2]]


def known_chosen(hyp):
    """The chosen paths whose values the user typically knows: held in the first null fit."""
    return {s.path for s in hyp.auto_specs if s.path in hyp.user_known}


def demand(model, exps, hyp, unc, null, comp_start, rps_start, max_nfev, report, alpha):
    """The values the user typically knows (a jack's load, an inclined jack's mounting angle),
    held at the user's value in ``null``, freed only where the data demand it
    (:data:`pneucore.analysis.diagnosis.rules.DEMAND_RULES`). Returns the null to go on with;
    each held value's identifiability entry gets status ``held``, what it is confounded
    with and the rules' record (``demand``).

    They are judged one at a time, the one whose typical error changes the records most
    first (its prior makes it the likelier culprit: a 5 deg error of an inclined jack's angle
    against 1 N of undeclared load); a value freed joins the fitted ones, so a second known
    value that changes what the first does (a load beside a freed angle: both a constant
    force along the rod) is confounded with it and held (:func:`demanded_words` says what a
    freed one cannot be told from)."""
    fitted = {s.path for s in null.auto_specs}
    sens = {h["path"]: h.get("sensitivity") or 0.0 for h in hyp.identifiability}
    waiting = sorted((p for p in known_chosen(hyp) if p not in fitted), key=lambda p: (-sens[p], p))
    freed_paths = []
    out = null
    for path in waiting:
        frac, with_ = orthogonal_part(hyp.id_cols, path,
                                      [p for p in fitted | set(freed_paths) | set(hyp.carried)
                                       if p in hyp.id_cols])
        vals = out.fit.values if out.fit is not None else {}
        t = {"path": path, "orthogonal": frac, "with": with_,
             "at_bound": [p for p in with_ if (vals.get(p) or {}).get("at_bound")],
             "error_held": out.error, "floor": out.floor_overall}

        def freed(t, path=path, ref=out):
            report(0.045, "refitting the base model with " + H.label_of(path) + " freed")
            trial = null_fit(model, exps, hyp, unc, comp_start, rps_start, max_nfev, report,
                             held=set(waiting) - set(freed_paths) - {path})
            taus = trial.fit.residual_times if trial.fit is not None else None
            lr, n_eff = effective_lr(ref.rss, trial.rss, taus)
            value = trial.fit.values[path]["value"] if trial.fit is not None else None
            t.update(p_value=float(stats.chi2.sf(max(lr, 0.0), 1)), lr_statistic=lr,
                     delta_bic=-lr + math.log(max(n_eff, 1.0)), trial=trial, value=value,
                     error_freed=trial.error,
                     impossible=H.against_direction(model, path, value) if value is not None
                     else "")

        ok = R.demanded(t, R.Judging(alpha, 1), freed)
        trial = t.pop("trial", None)
        entry = next(h for h in hyp.identifiability if h["path"] == path)
        entry["demand"] = t
        if ok:
            entry["note"] = "the data demand it: freed, it passes " + ", ".join(t["rules"])
            freed_paths.append(path)
            out = trial
        else:
            hyp.held.add(path)
            entry["status"] = "held"
            entry["with"] = with_
            why = next(r.reason for r in R.DEMAND_RULES if r.name == t["failed"])
            if t.get("impossible"):
                why += f": freed, {t['impossible']}"
            entry["note"] = (f"held at the value given ({get_value(model, path):.3g} "
                             f"{unit_of(path)}".rstrip() + f"): the data do not demand it, rule "
                             f"'{t['failed']}' fails ({why}; what it changes in the records is "
                             f"{100 * (1 - frac ** 2):.0f} % what "
                             f"{' and '.join(H.label_of(p) for p in with_)} change)")
    return out


#: A known value freed by the data (:func:`demand`, or a bound the fit drove its confounders
#: to) is reported as moved when it moved by half its typical error or more (the catalogue
#: prior's width: 2.5 deg of a mounting angle, about 0.4 N of the paper's load); less is the
#: fit's split among confounded parameters, not a finding
MOVED_KNOWN = 0.5


def _freed_how(h):
    """Why the data freed a known value (its identifiability entry ``h``), or ``""``."""
    d = h.get("demand")
    if d is not None:
        if d.get("failed") is not None:
            return ""
        if d.get("at_bound") and d.get("orthogonal", 1.0) < R.CONFOUNDED:
            return (f"the fit with it held drove {', '.join(H.label_of(p) for p in d['at_bound'])} "
                    f"to a bound, and the likelihood tests pass")
        return f"the data demand it (rules {', '.join(d['rules'])} pass)"
    if h.get("status") == "identifiable" and "bound" in h.get("note", ""):
        # freed by :func:`pneucore.analysis.hypotheses.freed_by_bounds`
        return "the fit " + h["note"].split("but the fit ", 1)[-1] + " without it"
    return ""


def demanded_words(model, hyp, recalibrate, refitted):
    """The values the user knows (:attr:`pneucore.analysis.hypotheses.BaseHypothesis.user_knows`)
    that the data moved, with what they cannot be told from and the measurement that would.

    A known value freed by the data (the rules of :func:`demand`, or a bound the fit drove
    its confounders to, :func:`pneucore.analysis.hypotheses.freed_by_bounds`) and moved by
    :data:`MOVED_KNOWN` typical errors or more is put in ``recalibrate`` (edited in place)
    when the three-standard-error rule left it out (confounded, its own standard error is
    large), with ``demand``: ``how`` it was freed, ``twins`` (the other known values that
    change what it changes: an angle and a load, both a constant force along the rod),
    ``with`` (the fitted parameters it is confounded with) and ``separated_by``.

    Returns
    -------
    words : str
        The sentences for the message (empty where no known value moved)
    """
    out = []
    moved = {r["path"]: r for r in recalibrate}
    fits = {r["path"]: r for r in refitted}
    # the one moved furthest, in typical errors, first
    order = sorted((p for p in hyp.user_known if p in fits), key=lambda p: -abs(
        fits[p]["after"] - fits[p]["before"]) / H.typical_step(model, H.BASE_HYPOTHESES[p]))
    for path in order:
        h = next((e for e in hyp.identifiability if e["path"] == path), None)
        r = moved.get(path) or next((e for e in refitted if e["path"] == path), None)
        how = _freed_how(h) if h is not None else ""
        if not how or r is None:
            continue
        hb = H.BASE_HYPOTHESES[path]
        if abs(r["after"] - r["before"]) < MOVED_KNOWN * H.typical_step(model, hb):
            continue
        twins = [q for q in hyp.user_known if q != path and q in hyp.id_cols and path in hyp.id_cols
                 and orthogonal_part(hyp.id_cols, path, [q])[0] < H.COLLINEAR]
        with_ = [p for p in (h.get("demand") or h).get("with", []) if p not in twins]
        r["demand"] = {"how": how, "twins": twins, "with": with_,
                       "separated_by": hb.separated_by}
        if path not in moved:
            recalibrate.append(r)
            moved[path] = r
        others = twins + with_
        out.append(f"{hb.label[:1].upper() + hb.label[1:]} {r['before']:.3g} -> {r['after']:.3g} "
                   f"{r['unit']}: a value given, moved because {how}; these experiments cannot "
                   f"tell it apart from {', '.join(H.label_of(p) for p in others) or 'nothing'}: "
                   f"{hb.separated_by}.")
    return " ".join(out)


def attach_held(f, held, odd, hold, model, null):
    """Put the catalogue hold's account (:func:`held_words`) into the findings ``f`` (edited).

    When the held fit was not taken, its words are made to describe the fit returned (a
    sensor fit may have followed the null: the implausible values may have gone); when it
    was taken, the recalibrated values beside the symptom are withheld from the next model
    (:func:`withheld`).

    Parameters
    ----------
    f : Findings
        The round's findings (message, remaining, model, recalibrate, refitted) [-]
    held : dict
        The hold's account (parameters, verdict, errors, taken, description) [-]
    odd : list of dict
        The implausible recalibrations of the null fit [-]
    hold : list of str
        The paths held at the catalogue value [-]
    model : Model
        The model diagnosed [-]
    null : Null
        The null fit returned [-]
    """
    f.remaining["held_at_catalogue"] = held
    if not held["taken"]:
        # the words describe the fit returned (a sensor fit may have followed the null)
        now = still_implausible(odd, f.refitted)
        if now != odd:
            held["null_fit"] = {"parameters": odd, "description": held["description"]}
            held["description"] = (held_words(now, hold, None, held["error_held"], null.error)
                                   if now else "")
            if not now:
                held["superseded"] = (
                    "the fit returned leaves " + ", ".join(o["label"] for o in odd)
                    + " where a catalogue error reaches: "
                    + "; ".join(f"{r['label']} {r['after']:.3g} {r['unit']}".rstrip()
                                for r in f.refitted if r["path"] in {o["path"] for o in odd}))
    if held["description"]:
        f.message += " " + held["description"] + "."
    if held["taken"]:
        f.model, back = withheld(model, f.model, f.recalibrate, {s.path for s in null.auto_specs})
        held["withheld"] = [r["path"] for r in back]
        if back:
            f.message += (" Not taken into the next model, the same symptom beside it: "
                          + "; ".join(f"{r['label']} stays at {r['before']:.3g} "
                                      f"{r['unit']}".rstrip() for r in back) + ".")


# -- 4. candidate scores ------------------------------------------------------------------

def uncertain_sensitivities(exps, null):
    """Sensitivities of the null's fitted parameters (columns), scaled like its residual."""
    if not null.specs:
        return None
    return np.column_stack(P.pmap(uncertain_column, null.specs, (exps, null.base, null.keys, null.y),
                                  "sensitivities of the base parameters"))


def uncertain_column(exps, base, keys, y0, s):
    """One column of :func:`uncertain_sensitivities`: parameter ``s`` (a spec) moved by 1e-3 of
    its value around the null model ``base`` (a valve scale reads 1 there, whatever the fit
    found), the outputs' change per unit, scaled like the residual."""
    v = get_value(base, s.path)
    h = 1e-3 * (abs(v) or (s.max - s.min) / 100)
    mp = set_values(base, {s.path: v + h})
    return (stack([replay(mp, e) for e in exps], keys) - y0) / h


def sample_period(exps):
    """The finest sample period of the experiments' records [s] (their median spacing; read
    from :class:`pneucore.analysis.records.Records`, where it was found once)."""
    return prepared(exps).sample_period


def probe(model, exps, null, Ju, name):
    """The score of candidate ``name`` (see :func:`candidate_scores`): ``{effect, lm, dof,
    p_value, score_params, form}``; ``Ju`` the base parameters' sensitivities (or None).
    An effect with several structural forms (:meth:`pneucore.description.effects.Effect.forms_for`:
    a line lumped or in segments) is probed in each, and scored by the form whose change
    explains most of the residual (``form``: its overrides, ``{}`` for the default)."""
    eff = EFFECTS[name]
    best = None
    for form in eff.forms_for(eff.probe_values(model), model, sample_period(exps)):
        res = _probe_form(model, exps, null, Ju, name, form)
        if best is None or res["lm"] > best["lm"]:
            best = res
    return best


def _probe_form(model, exps, null, Ju, name, form):
    """:func:`probe` in one form (``form``: overrides of the probe values)."""
    eff = EFFECTS[name]
    sp = eff.score_params
    dose = {**eff.probe_values(model), **form}
    vals_off = dict(dose)
    for p in sp:
        vals_off[p] = eff.param(p).off
    cols, one_sided = [], []
    for p in sp:
        v = dict(vals_off)
        v[p] = dose[p]
        mp = with_effect(null.base, name, v)
        yp = stack([replay(mp, e) for e in exps], null.keys)
        cols.append(yp - null.y)
        par = eff.param(p)
        one_sided.append(par.off is not None and par.min >= par.off
                         and v[p] > par.off)
    J = project_out(np.column_stack(cols), Ju)
    lm, used = lm_statistic(null.r, J, one_sided)
    dof = max(len(used), 1)
    p_lm = float(stats.chi2.sf(lm, dof)) if used else 1.0
    return {"effect": name, "lm": lm, "dof": len(used), "p_value": p_lm,
            "score_params": list(sp), "form": dict(form)}


def candidate_scores(model, exps, null, cands, report):
    """The score pass: for every candidate, the outputs' change under a moderate dose of the
    effect (one simulation per strength parameter), the base parameters' sensitivities
    projected out, and the LM statistic on the null's unit residual; a strength that may
    only be positive is dropped when the data ask for a negative one (one-sided test).
    Returns the candidates' scores, best first, each with its ``rank``."""
    Ju = uncertain_sensitivities(exps, null)
    score = []
    for k, res in enumerate(P.pmap(probe, cands, (model, exps, null, Ju), "score test", 0.05)):
        score.append(res)
        report(0.05 + 0.35 * (k + 1) / max(len(cands), 1), f"score test: {res['effect']}")
    score.sort(key=lambda d: (-d["lm"] if d["dof"] else 0.0))
    for i, s in enumerate(score):
        s["rank"] = i + 1
    return score


def at_noise_floor(null):
    """Is the null's error at or below its noise floor? (No excess left for an effect:
    :func:`pneucore.analysis.diagnosis.evidence.excess_drop` is 0 for every candidate.)"""
    return bool(null.floor_overall == null.floor_overall and null.error <= null.floor_overall)


def leading(score, n_refit):
    """The ``n_refit`` best-scored candidates with a testable strength."""
    return [s["effect"] for s in score if s["dof"] > 0][:n_refit]


# -- 5. joint refits ----------------------------------------------------------------------

def effect_specs(model, name, values, form=None, sample_period=0.0, held=()):
    """The fit parameters of effect ``name`` (its diagnosis parameters that act on ``model``,
    but those of ``held``: held where ``values`` has them) starting at ``values``, in
    structural form ``form`` (overrides; its bounds,
    :meth:`pneucore.description.effects.Effect.form_bounds`, for records sampled every
    ``sample_period`` [s])."""
    eff = EFFECTS[name]
    out = []
    for p in eff.diagnosis_params:
        if p in eff.unused_in(model) or p in held:
            continue
        lo, hi = eff.form_bounds(p, model, form, sample_period)
        v = min(max(values[p], lo), hi) if form else values[p]
        out.append(ParameterSpec(f"effects.{name}.{p}", v, lo, hi, True, eff.param(p).unit))
    return out


def moved_back(model, cal, paths):
    """Of ``paths``, those the fit ``cal`` left within :data:`RECAL_MIN` of the model's values."""
    out = set()
    for p in sorted(paths):
        v = cal.values.get(p)
        if v is None:
            continue
        before = get_value(model, p)
        if abs(v["value"] - before) <= RECAL_MIN * max(abs(before), 1e-300):
            out.add(p)
    return out


def _rss(cal):
    """Residual energy a calibration ends with (its experiments together)."""
    return sum(r for _, _, r, _ in cal.rss_after)


def joint_refit(model, exps, null, name, max_nfev, report, form=None):
    """Candidate ``name`` fitted with the null's base parameters, from the model as given
    (the null's values are biased by what is missing), in the structural form ``form``
    (overrides of its probe values, :meth:`pneucore.description.effects.Effect.forms_for`: a line
    lumped, or in segments where its delay spans more than a sample; the one the score pass
    preferred, :func:`probe`) and in its default form, or, with ``form`` None, in each form;
    the best kept. A form
    that at the fitted values calls for a finer one (a line found longer needs more cells to
    resolve its delay) is fitted once more in that one, from there, and the better of the two
    kept; one that calls for a coarser form (a line found shorter, or within a sample) is not:
    the finer form fitted is at least as accurate, and the default form is fitted beside it
    (on a 1 s hold + 60 s cyclic record that second fit, in 2 segments after 3, cost 43 s of
    the round's 118). On long records the forms are first compared on the window's fit, and
    only those within :data:`FORM_MARGIN` of the best are fitted on the full records
    (:func:`forms_on_window`)."""
    eff = EFFECTS[name]
    dt = sample_period(exps)
    probe_at = eff.probe_values(model)
    best = None
    # the default form always (a lumped line is cheap to fit, and a truth in it may score
    # better in another form at the probe's dose), the preferred one beside it; on long
    # records those the window's fits leave far behind are dropped there
    tried = eff.forms_for(probe_at, model, dt) if form is None else [{}] + ([form] if form else [])
    # on long records the forms are compared on the window first (:func:`forms_on_window`)
    pre = forms_on_window(model, exps, null, name, probe_at, tried, max_nfev, report, dt)
    if pre:
        tried = [f for f, _ in pre.values()]
    start = probe_at
    for f in tried:
        if f and best is not None and name in best.model.effects:
            # a structural refinement (a line in segments, resolving its delay) is fitted
            # where the default form shows the effect at all: a line that removes no material
            # part of the excess lumped does not in segments either, and each of its
            # simulations costs 50-100 times the lumped line's (a 1 s record: 30-77 ms against
            # 0.6 ms; 73 of the 77 s of a round on two 1 s records went to a stand-in line in
            # six segments); it starts from the default form's fit
            if excess_drop(null.error, best.error_after.overall, null.floor_overall) < R.EXCESS_MATERIAL:
                continue
            start = {**probe_at, **best.model.effects[name]}
        # a refinement started from a fit (of the default form, or of a coarser one below)
        # starts near its end: half the evaluations (a line in segments refitted from the
        # lumped fit ran 34-42 evaluations of 30-77 ms each, 20 s of a 23-40 s case)
        nfev = max(max_nfev // 2, 8) if f and start is not probe_at else max_nfev
        cal = _joint_refit_from(model, exps, null, name, {**start, **f}, nfev, report,
                                f, dt, prefit=pre[_form_key(f)][1] if pre else None)
        if f:
            fitted = dict(cal.model.effects[name])
            again = eff.forms_for(fitted, model, dt)[-1] or {k: probe_at[k] for k in f}
            if any(fitted.get(k) != v for k, v in again.items()) and \
                    eff.needs_refit_in(again, f):
                cal2 = _joint_refit_from(model, exps, null, name, {**fitted, **again},
                                         max(max_nfev // 2, 8), report, again, dt)
                cal = cal2 if _rss(cal2) <= _rss(cal) else cal
        if best is None or _rss(cal) < _rss(best):
            best = cal
    return best


#: Relative excess of residual energy on the records' window [-] beyond which a structural form
#: of a candidate is not fitted on the full records: its window's fit ends more than this above
#: the best form's. Within it both go on (the window may not tell them apart); the same 2 % of
#: the residual energy (1 % of the Eq. 25 error) that :func:`_joint_refit_from` calls materially
#: worse
FORM_MARGIN = 0.02


def forms_on_window(model, exps, null, name, start, forms, max_nfev, report, sample_period):
    """``{form: window's fit}`` of the structural forms worth fitting on the full records, or
    ``{}`` where the records are fitted whole (within :data:`calibrate.PREFIT_SECONDS
    <pneucore.analysis.calibrate.PREFIT_SECONDS>`) or there is one form.

    On long records every fit starts with a fit on the records' first seconds
    (:func:`pneucore.analysis.calibrate.window`); each form's is made here, and a form whose
    window's fit ends more than :data:`FORM_MARGIN` above the best form's residual energy is
    dropped before its fit on the full records (the forms have the same parameters: the
    comparison needs no penalty). The kept forms' fits go on from these window fits, so they
    end where they would have. On a 1 s hold + 60 s cyclic record the line in 3 segments,
    which the score pass preferred at the probe's dose, ended its window 1.67 times above the
    lumped line, and its fit on the full records (53 replays of 1 s each) was the round's
    largest cost; the lumped line won there too.

    Parameters
    ----------
    model : Model
        Model as given [-]
    exps : list of Experiment
        Prepared experiments [-]
    null : Null
        The null fit (base parameters, their start and prior) [-]
    name : str
        Candidate effect [-]
    start : dict
        The effect's starting values (its probe values; SI) [-]
    forms : list of dict
        The forms to compare (their overrides; ``{}`` the default) [-]
    max_nfev : int
        Evaluations of each fit [-]
    report : callable
        ``report(fraction, step)`` [-]
    sample_period : float
        The records' sample period [s]

    Returns
    -------
    kept : dict
        ``{form as a hashable key: (form, its window's fit)}`` in ``forms``' order; ``{}``
        when not compared (the window :func:`pneucore.analysis.calibrate.prefit_window`)
    """
    if len(forms) < 2 or _calibrate.window(exps) is None:
        return {}
    pre = {}
    for f in forms:
        m, specs, _ = _refit_setup(model, null, name, {**start, **f}, f, sample_period)
        # the window the form's fit would start from (the same for every form: the same
        # parameters)
        short = _calibrate.prefit_window(exps, len(specs))
        if short is None:
            return {}
        pre[_form_key(f)] = (f, _calibrate.window_fit(
            m, short, specs, max_nfev, lambda fr, s: report(0.4, f"refit: {name}"), reweight=True,
            prior=null.prior))
    best = min(_rss(c) for _, c in pre.values())
    return {k: (f, c) for k, (f, c) in pre.items() if _rss(c) <= (1.0 + FORM_MARGIN) * best}


def _form_key(form):
    """A structural form (its overrides) as a dictionary key."""
    return tuple(sorted(form.items()))


def _refit_setup(model, null, name, start, form, sample_period, held=()):
    """``(model, specs, start)`` of a joint refit: the effect at ``start`` (within its form's
    bounds) and its parameters free beside the null's base parameters (those of ``held``
    held at ``start``)."""
    specs = effect_specs(model, name, start, form, sample_period, held) + null.specs_start
    start = {**start, **{s.path.rsplit(".", 1)[1]: s.value for s in specs
                         if s.path.startswith(f"effects.{name}.")}}
    return with_effect(model, name, start), specs, start


def _joint_refit_from(model, exps, null, name, start, max_nfev, report, form=None,
                      sample_period=0.0, prefit=None, held=()):
    """:func:`joint_refit` in one form (``form``: its overrides, within its bounds for records
    sampled every ``sample_period`` [s]), the effect starting at ``start``. Base parameters the
    joint fit leaves at their catalogue values (within :data:`RECAL_MIN`) are not mis-set:
    they are held there and the rest refitted from this point, so that they do not blur the
    effect's parameters (kept unless the fit gets materially worse). ``prefit``: the fit's
    window already fitted (:func:`forms_on_window`); ``held``: parameters of the effect held at
    ``start`` (its smaller form, :func:`smaller_form`)."""
    m, specs, start = _refit_setup(model, null, name, start, form, sample_period, held)
    # the refit checks the time limit at each evaluation (progress stays at its level)
    cal = fit(m, exps, specs, max_nfev=max_nfev, compute_before=False,
              progress=lambda f, s: report(0.4, f"refit: {name}"), reweight=True, prior=null.prior,
              prefit=prefit)
    back = moved_back(model, cal, {q.path for q in null.auto_specs})
    if back:
        cal2 = _go_on(model, exps, name, start, cal, specs, max_nfev, back)
        # kept unless materially worse (2 % of the residual energy: 1 % of the Eq. 25 error)
        if _rss(cal2) <= 1.02 * _rss(cal):
            cal = cal2
    if out_of_evaluations(cal) and cal.tail_drop >= GOING_ON:
        # a fit its budget stopped while still gaining is continued once from where it
        # stopped, and kept where that is materially better (the same 2 % of the residual
        # energy): an effect in series
        # with a base parameter it is confounded with (a meter-out throttle with the exhaust
        # edges' scale) creeps along their valley, and the candidate that stopped short there
        # loses to one that converged in another form (a silencer, named over the meter-out
        # pair that made the records: 0.111 % against 0.099 %, the meter-out's fit continued
        # reaching 0.074 % at a floor of 0.070 %)
        cal2 = _go_on(model, exps, name, start, cal, specs, max_nfev)
        if _rss(cal2) < 0.98 * _rss(cal):
            cal = cal2
    return cal


#: Share of its residual energy a fit must have removed over the second half of its last pass
#: (:attr:`pneucore.analysis.calibrate.Calibration.tail_drop`) to be continued when its budget
#: stopped it [-]: 2 %, what a continuation must gain to be kept (materially better); a fit
#: gaining less than that at its end will not gain it in as many evaluations more (the
#: meter-out pair of the circuit rig, apart: 7.6 %, continued to the floor; the lines in
#: segments stopped on the foreign rigs: under 1e-5, not continued)
GOING_ON = 0.02


def out_of_evaluations(cal):
    """Did the fit ``cal`` stop at its budget of evaluations, not at convergence? [-]"""
    return bool(getattr(cal, "out_of_budget", False))


def _go_on(model, exps, name, start, cal, specs, max_nfev, back=()):
    """A joint refit continued from ``cal``'s end point (on long records straight to its
    polish), the base parameters of ``back`` held at the model's values: the valve scales
    restart at 1 on the table ``cal`` reached and are reported against the model as given
    (:func:`absolute_scales`), the prior still centred on the catalogue."""
    # a parameter the fit held (not among its values: moved back by an earlier pass) stays held
    back = set(back) | {q.path for q in specs if q.path not in cal.values}
    m2 = with_effect(model, name, {**start, **cal.model.effects[name]})
    vals = {q.path: cal.values[q.path]["value"] for q in specs
            if not q.path.startswith(f"effects.{name}.") and q.path not in back}
    m2 = set_values(m2, vals)
    specs2 = []
    for q in specs:
        if q.path in back:
            continue
        v = get_value(m2, q.path)
        if q.path.startswith("valve."):   # a scale factor: bounds relative to m2's table
            f = vals[q.path]
            specs2.append(ParameterSpec(q.path, 1.0, q.min / f, q.max / f, True, q.unit))
        else:
            specs2.append(ParameterSpec(q.path, v, q.min, q.max, True, q.unit))
    scale = {q: vals[q] for q in vals if q.startswith("valve.")}
    cal2 = fit(m2, exps, specs2, max_nfev=max_nfev, compute_before=False, reweight=True,
               prior=H.prior_for(model, [q.path for q in specs2], scale), warm=True)
    absolute_scales(cal2, scale)
    return cal2


def absolute_scales(cal, scale):
    """Report ``cal``'s valve scale factors against the model as given, in place: a fit started
    from a table already multiplied by ``f`` (``scale``: ``{path: f}``) found its factor
    relative to that table, so its value, initial value, bounds and standard errors are
    multiplied by ``f`` (the correlations are unchanged). Without it a refit that moved the
    exhaust conductance by -30 % in its first pass reported "1 -> 1.0001" and no mis-set valve
    while the next model carried the change."""
    for path, f in scale.items():
        v = cal.values.get(path)
        if v is None:
            continue
        for key in ("value", "initial", "min", "max", "stderr", "stderr_prior"):
            if isinstance(v.get(key), (int, float)) and not isinstance(v.get(key), bool):
                v[key] = v[key] * f


def remote_joint_refit(model, exps, null, max_nfev, forms, name):
    """:func:`joint_refit` as a Dask task (:func:`pneucore.analysis.parallel.pmap`): every
    argument and the result are plain picklable objects (the model, the experiments, the
    :class:`Null`, the calibration); the progress callback stays with the caller (the runner
    calls it while it waits)."""
    return joint_refit(model, exps, null, name, max_nfev, lambda f, s: None, forms.get(name))


def joint_refits(model, exps, null, lead, max_nfev, report, forms=None):
    """``{name: calibration}`` of :func:`joint_refit` for each leading candidate (in parallel):
    one Dask task each on the current diagnosis's cluster
    (:func:`pneucore.analysis.parallel.current`), else on this machine's threads; ``forms``:
    ``{name: form}`` the score pass preferred (:func:`probe`; a name absent: every form)."""
    forms = forms or {}
    runner = P.current()
    if runner is not None and runner.on_cluster and lead:
        prev = runner.report
        runner.report = report
        try:
            cals = runner.map(remote_joint_refit, lead, (model, exps, null, max_nfev, forms),
                              "refit: " + ", ".join(lead), 0.4,
                              local=lambda n: joint_refit(model, exps, null, n, max_nfev, report,
                                                          forms.get(n)))
        finally:
            runner.report = prev
        return dict(zip(lead, cals))
    refits = {}
    with ThreadPoolExecutor(_calibrate.THREADS) as pool:
        for done, (name, cal) in enumerate(pool.map(
                lambda n: (n, joint_refit(model, exps, null, n, max_nfev, report, forms.get(n))),
                lead), 1):
            refits[name] = cal
            report(0.4 + 0.55 * done / max(len(lead), 1), f"refit: {name}")
    return refits


# -- 6. evidence ----------------------------------------------------------------------------

def common_times(refits, null):
    """One common effective sample size for every comparison: the autocorrelation times of the
    residual of the most complete model fitted (the best refit, else the null); counted per
    candidate, a worse fit would get a longer tau, fewer samples, and a milder penalty."""
    if refits:
        ref = min(refits.values(), key=lambda c: sum(r for _, _, r, _ in c.rss_after))
        return ref.residual_times
    return null.fit.residual_times if null.fit is not None else residual_times(null.replays)


def prior_cost(values, prior):
    """``sum ((value - centre) / sigma)^2`` of the fitted base parameters under the catalogue
    prior (:func:`pneucore.analysis.hypotheses.prior_for`): the part of -2 ln(posterior) the
    fit paid to move them from the user's values [-]."""
    out = 0.0
    for path, (c, sg) in (prior or {}).items():
        v = values.get(path)
        if v is not None:
            out += ((v["value"] if isinstance(v, dict) else v) - c) ** 2 / sg ** 2
    return out


def candidate_evidence(name, cal, null, taus, e0_cal, held=()):
    """The evidence of one refit against the null: error drop, share of the excess over the
    floor (also once the sensors' gains and offsets are removed), LR with its p-value,
    delta BIC / AIC on the common effective samples, fitted parameters, explanation.

    The LR counts what each fit paid under the catalogue prior to move the base parameters
    (:func:`prior_cost`), the objective both fits minimised: a candidate that needs the
    valve's conductance at x1.75 to stand (a line whose resistance the records do not see,
    taken back by the valve) pays for it against one that leaves the catalogue as it is
    (least change). ``held``: parameters of the effect held off (its smaller form,
    :func:`smaller_form`), not counted in its ``k``."""
    eff = EFFECTS[name]
    k_eff = len([p for p in eff.diagnosis_params if p not in held])
    lr_eff, n_eff = effective_lr(null.rss, cal.rss_after, taus)
    cost_null = prior_cost(null.fit.values, null.prior) if null.fit is not None else 0.0
    cost = prior_cost(cal.values, null.prior)
    lr_eff += cost_null - cost
    lr = max(lr_eff, 0.0)
    p = float(stats.chi2.sf(lr, k_eff))
    params = {p_: v for p_, v in cal.values.items() if p_.startswith(f"effects.{name}.")}
    held_off = {p_: {"value": cal.model.effects[name][p_], "stderr": 0.0, "unit": eff.param(p_).unit,
                     "held": True} for p_ in held}
    # an effect's parameter given the user's values along what the records do not resolve
    # (the catalogue prior; a quadrant level beside an undeclared load and the extend level)
    params = {**{k.split(".")[-1]: given_prior(v) for k, v in params.items()}, **held_off}
    e0, e1 = null.comp.overall, cal.error_after.overall
    floor = null.floor_overall
    cand = {"effect": name, "error_before": e0, "error_after": cal.error_after.errors,
            "error_after_overall": e1,
            "error_after_phases": cal.error_after.phases,
            "relative_drop": (e0 - e1) / e0 if e0 else 0.0,
            "excess_drop": excess_drop(e0, e1, floor),
            "excess_drop_calibrated": excess_drop(
                e0_cal, H.calibrated_error(cal.error_after.replays)[0], floor),
            "lr_statistic": lr, "p_value": p, "delta_bic": -lr_eff + k_eff * math.log(max(n_eff, 1.0)),
            "delta_aic": -lr_eff + 2 * k_eff,
            "lr_statistic_white": max(null.m2ll - cal.neg2_loglik, 0.0),
            "effective_samples": n_eff, "n_samples": null.n_all,
            "prior_cost": cost, "prior_cost_null": cost_null,
            "autocorrelation_time": times_report(taus),
            "params": params,
            "uncertain_params": {k: v for k, v in cal.values.items() if not k.startswith("effects.")},
            "improvement": improvement(null.comp, cal.error_after),
            "experiments": experiment_excess(null.replays, cal.error_after.replays),
            "fit_success": cal.success, "fit_message": cal.message,
            "description": eff.description, "signature": eff.signature,
            "reference": eff.reference, "model_obj": cal.model}
    if held:
        cand["held_off"] = sorted(held)
    cand["explanation"] = explain(eff, cand, floor)
    cand["model"] = cal.model.to_dict()
    return cand


def evidence(null, refits, skipped=None):
    """The ranking: :func:`candidate_evidence` of every refit, by delta BIC (same null, same
    effective samples: delta BIC is monotone in the evidence shown). A refit whose model
    cannot be built (:func:`buildable`) leaves ``refits`` and joins ``skipped`` with why."""
    for name in list(refits):
        why = buildable(refits[name], name)
        if why:
            refits.pop(name)
            if skipped is not None:
                skipped.append({"effect": name, "reason": why})
    taus = common_times(refits, null)
    # the null's error once each signal's best transducer gain and offset are removed: what a
    # catalog effect must explain when a sensor calibration error is also present
    e0_cal = H.calibrated_error(null.replays)[0]
    ranking = [candidate_evidence(name, cal, null, taus, e0_cal) for name, cal in refits.items()]
    ranking.sort(key=lambda c: c["delta_bic"])
    return ranking


# -- 7. verdict ------------------------------------------------------------------------------

def verdict(model, exps, ranking, refits, null, alpha, max_nfev, report):
    """Judge the ranking by :data:`pneucore.analysis.diagnosis.rules.RULES`; ``(verdict,
    message)``. Candidates are judged in evidence order; one that fails (a stand-in: it
    explains too little of the excess, or its parameters disagree between experiments) does
    not hide the next, which is judged on its own evidence (each test at alpha / number of
    refits) and, if it passes, named and ranked first."""
    ctx = R.Judging(alpha, max(len(ranking), 1))
    flagged = set()

    def flag(c):
        if id(c) not in flagged:
            flagged.add(id(c))
            R.flags(c, ctx)

    def paired(c):
        # the pair reads the next significant, material candidate's flags: all are flagged
        # first, the held-out prediction included, as when every candidate was flagged at once
        for o in ranking:
            flag(o)
        return pair(model, exps, c, ranking, refits, null.specs_start, null.error,
                    null.floor_overall, max_nfev, report)
    ctx.pair = paired

    def consistent(c):
        report(0.96, f"consistency across experiments: {c['effect']}")
        return consistency(refits[c["effect"]], exps, c["effect"], max_nfev,
                           skip=not_compared(c.get("experiments", ())),
                           held=c.get("held_off", ()))
    ctx.consistency = consistent

    def predicts(c):
        report(0.96, f"held-out prediction: {c['effect']}")
        return held_out_evidence(model, exps, null, c["effect"], refits[c["effect"]], max_nfev,
                                 c.get("held_off", ()))
    ctx.held_out = predicts

    def smaller(c):
        # a candidate whose parameters disagree between experiments on some of them only:
        # those are a stand-in, the others may be physics; the effect is judged again with
        # them held off (:func:`smaller_form`), and named in that form if it passes
        held = smaller_held(c)
        if not held:
            return None
        name = c["effect"]
        full = refits[name]
        s, refits[name] = smaller_form(model, exps, null, c, held, refits, max_nfev, report)
        determine(s)
        flag(s)
        if R.judge(s, ctx):
            ranking[ranking.index(c)] = s
            return s
        refits[name] = full
        c["smaller_form"] = {"held_off": sorted(held), "failed": s["failed"]}
        return None
    if not ranking:
        if at_noise_floor(null):
            return None, (NO_EFFECT + f" (the base model's error, {100 * null.error:.3f} %, is at "
                          f"the noise floor, {100 * null.floor_overall:.3f} %: nothing is left "
                          "for an effect to explain)")
        return None, NO_EFFECT
    # judged in evidence order, each candidate flagged just before it is judged: the first
    # contender (significant and strong) that passes every rule is named, as if all were
    # flagged first; the candidates after it are flagged without the held-out prediction,
    # whose refits (32 of the 37 s of a round on ten 2 s tests, for a stand-in behind a named
    # leak) cannot change the verdict any more, unless the records cannot tell them from it
    # (an alternative, reported when significant: R.indistinct)
    named = None

    def determine(c):
        # physical plausibility: a strength at its fit bound, or not distinguishable from off by
        # its own standard error, is no evidence of the effect however much the fit improves
        # (and a base parameter refitted beside it that points against its declared direction:
        # a load turned around by the effect's fit, gravity pointing up, issue 28)
        c["undetermined"] = undetermined(c) or impossible(
            c["effect"], (c["model"].get("effects") or {}).get(c["effect"]) or c["params"],
            model) or H.first_against_direction(model, c["uncertain_params"])
    for c in ranking:
        determine(c)
    for c in ranking:
        if named is not None and id(c) not in flagged:
            ctx.held_out = predicts if R.indistinct(c, named) else None
            if ctx.held_out is None:
                c["held_out_not_run"] = (f"{named['effect']}, ahead of it, was named: its "
                                         "flags are its likelihood ratio's and its BIC's alone")
        flag(c)
        if named is None and c["significant"] and c["strong"]:
            if R.judge(c, ctx):
                named = c
            elif c["failed"] == "consistent":
                named = smaller(c)
    contenders = [c for c in ranking if c["significant"] and c["strong"]]
    if named is None and not contenders and R.judge(ranking[0], ctx):
        named = ranking[0]
    # parsimony: of candidates the records cannot tell apart (BIC within 10), the one that
    # says less about the rig is named, if it passes every rule; the other is an alternative
    if named is not None:
        for c in sorted((c for c in ranking if R.simpler(c, named)),
                        key=lambda c: (R.complexity(c["effect"]), c["delta_bic"])):
            ctx.held_out = predicts
            flag(c)
            if c["significant"] and c["strong"] and R.judge(c, ctx):
                c["simpler_than"] = named["effect"]
                named = c
                break
    if named is not None:
        ranking.remove(named)
        ranking.insert(0, named)
        simpler = (f" Named before {named['simpler_than']}, which the records cannot tell "
                   f"from it (BIC within {-R.DELTA_BIC:g}) and which says more about the rig."
                   if named.get("simpler_than") else "")
        if named.get("held_off"):
            simpler += (f" Named without {', '.join(named['held_off'])}: fitted on each "
                        f"experiment alone, {'it' if len(named['held_off']) == 1 else 'they'} "
                        f"disagreed ({named['stand_in']}), a stand-in for something else, and "
                        f"the effect without {'it' if len(named['held_off']) == 1 else 'them'} "
                        "passes every rule.")
        return named["effect"], (f"{named['effect']}: {named['description']}. Error "
                                 f"{100 * named['error_before']:.2f} % -> "
                                 f"{100 * named['error_after_overall']:.2f} %.{simpler}")
    return None, NO_EFFECT + " (" + "; ".join(why_not(ranking[0])) + ")"


def smaller_held(c):
    """The parameters candidate ``c`` is judged again without (held off): those whose
    estimates disagreed between experiments (:func:`consistency`), where some of its other
    strength parameters act and every one of them has an ``off`` value; ``()`` otherwise (all
    disagreed: the whole effect is a stand-in)."""
    eff = EFFECTS[c["effect"]]
    dis = set((c.get("consistency") or {}).get("disagree") or ())
    if not dis:
        return ()
    unused = set(eff.unused_in(c["model_obj"]))
    rest = [p for p in eff.score_params if p not in dis and p not in unused]
    if not rest or any(eff.param(p).off is None for p in dis):
        return ()
    return tuple(sorted(dis))


def smaller_form(model, exps, null, c, held, refits, max_nfev, report):
    """Candidate ``c`` (whose parameters ``held`` disagreed between experiments) refitted with
    them held off, from its fit: ``(candidate, calibration)``, the candidate's evidence on the
    same null and effective samples as the ranking's (:func:`candidate_evidence`, ``held`` not
    counted in its ``k``). A stand-in parameter takes whatever helps each record (a leak on
    B standing in for a retract level mis-set, beside a leak on A both records agree on); the
    effect without it is what the records may still show (least change: it claims less)."""
    name = c["effect"]
    eff = EFFECTS[name]
    cal = refits[name]
    form = {k: v for k, v in cal.model.effects[name].items() if k not in eff.diagnosis_params}
    start = {**cal.model.effects[name], **{p: eff.param(p).off for p in held}}
    report(0.96, f"refit: {name} without {', '.join(held)}")
    cal2 = _joint_refit_from(model, exps, null, name, start, max_nfev, report, form,
                             sample_period(exps), held=held)
    taus = common_times(refits, null)
    cand = candidate_evidence(name, cal2, null, taus, H.calibrated_error(null.replays)[0], held)
    cand["stand_in"] = c["consistency"]["summary"]
    return cand, cal2


def as_recalibration(model, verdict, refits, null):
    """The named effect as a recalibration, where it is one: ``(null, words)`` or None.

    An effect that is nothing but a difference of the model's own base parameters
    (:attr:`pneucore.description.effects.Effect.base_change`: the quadrant effect is the
    retract friction set minus the extend set) is, where the base values it amounts to lie
    within :data:`pneucore.analysis.diagnosis.rules.BASE_CHANGE` typical catalogue errors of
    the user's values (:func:`pneucore.analysis.hypotheses.typical_errors`), a change the base
    parameters make: a catalogue value mis-set on one side, not a missing effect. The returned
    null is the effect's refit with the effect folded into those base values (the same
    physics, so the same replays and error), its base paths extended by them."""
    import dataclasses
    if verdict is None or EFFECTS[verdict].base_change is None:
        return None
    eff = EFFECTS[verdict]
    cal = refits[verdict]
    params = cal.model.effects[verdict]
    change = eff.base_change(params, cal.model)
    if not change or any(H.typical_errors(model, p, v) > R.BASE_CHANGE for p, v in change.items()):
        return None
    m = set_values(cal.model, change)
    m.effects.pop(verdict, None)
    values = {k: v for k, v in cal.values.items() if not k.startswith(f"effects.{verdict}.")}
    for path, v in change.items():
        k = path.rsplit(".", 1)[1]
        se = (cal.values.get(f"effects.{verdict}.{k}") or {}).get("stderr", 0.0)
        values[path] = {"value": v, "stderr": se, "unit": unit_of(path), "at_bound": False}
    fit_b = dataclasses.replace(cal, model=m, values=values)
    paths = list(null.base_paths) + [p for p in change if p not in null.base_paths]
    comp = cal.error_after
    null_b = dataclasses.replace(null, base=m, fit=fit_b, base_paths=paths, comp=comp,
                                 replays=comp.replays)
    moved = "; ".join(f"{H.label_of(p)} {get_value(model, p):.3g} -> {v:.3g} {unit_of(p)}".rstrip()
                      + f" ({H.typical_errors(model, p, v):.1f} typical catalogue errors)"
                      for p, v in change.items())
    words = (f"{verdict} would remove the misfit (error {100 * null.error:.2f} % -> "
             f"{100 * comp.overall:.2f} %), but it is a difference of base parameters within "
             f"{R.BASE_CHANGE:g} typical catalogue error of the user's values ({moved}): a "
             "mis-set value, recalibrated, not a missing effect")
    return null_b, words


def fitted_specs(fitted, specs):
    """``specs`` restarted at ``fitted``'s values (a valve scale factor at 1 on its table)."""
    out = []
    for q in specs:
        if q.path.startswith("valve."):
            out.append(ParameterSpec(q.path, 1.0, q.min, q.max, True, q.unit))
        else:
            v = min(max(get_value(fitted, q.path), q.min), q.max)
            out.append(ParameterSpec(q.path, v, q.min, q.max, True, q.unit))
    return out


def held_out_evidence(model, exps, null, name, cal, max_nfev, held=()):
    """:func:`pneucore.analysis.diagnosis.evidence.held_out` of candidate ``name`` (its joint
    refit ``cal``; ``held``: its parameters held off) against the null, each refitted from its
    own fit without each block."""
    scales = {(e, s): rms for e, s, _, rms in null.keys}
    base = fitted_specs(null.base, null.specs_start)
    # the candidate in the form its refit kept (the values the diagnosis does not fit: a
    # line's segments), within that form's bounds
    eff = EFFECTS[name]
    form = {k: v for k, v in cal.model.effects[name].items() if k not in eff.diagnosis_params}
    dt = sample_period(exps)
    cand = effect_specs(model, name, cal.model.effects[name], form, dt, held) + fitted_specs(
        cal.model, null.specs_start)
    # the experiments left out in turn start where the null fit and the joint refit start:
    # the model as given, the effect at its probe dose in the form the refit kept
    start = {**eff.probe_values(model), **form, **{p: eff.param(p).off for p in held}}
    loeo = (model, list(null.specs_start), with_effect(model, name, start),
            effect_specs(model, name, start, form, dt, held) + list(null.specs_start))
    return held_out(null.base, base, cal.model, cand, exps, scales, null.prior,
                    R.HELD_OUT_FOLDS, max(max_nfev // 2, 8), loeo=loeo,
                    enough=R.blocks_predict)


def why_not(b):
    """Why the best candidate ``b`` is not named, in words."""
    why = []
    if b["undetermined"]:
        why.append(f"best candidate {b['effect']} is not determined by these records "
                   f"({b['undetermined']})")
    elif not b["significant"]:
        h = b.get("held_out")
        held = (f"; refitted without each of {h['n_folds']} blocks in time it predicts "
                f"{h['wins']} better than the null, removing {100 * h['drop']:.0f} % of its "
                "held-out error" if h else "")
        if h and h.get("experiment_folds"):
            held += (f"; fitted on the others, it predicts {h['experiment_wins']} of "
                     f"{len(h['experiment_folds'])} experiments left out better, removing "
                     f"{100 * h['experiment_drop']:.0f} % of the null's error on them")
        why.append(f"best candidate {b['effect']} not significant (p = {b['p_value']:.2g}"
                   f"{held})")
    if not b["strong"]:
        why.append(f"delta BIC {b['delta_bic']:.1f} not below {R.DELTA_BIC:g}")
    if b["material"] and b["significant"] and b["strong"] and not b["consistent"]:
        why.append(f"best candidate {b['effect']} fitted separately on each experiment "
                   f"gives parameters that disagree ({b['consistency']['summary']}): "
                   f"a stand-in, not a physical effect")
    if not b["material"] and b["relative_drop"] < 0:
        why.append(f"best candidate {b['effect']} raises the error by "
                   f"{-100 * b['relative_drop']:.1f} %")
    elif not b["material"]:
        why.append(f"best candidate {b['effect']} removes only {100 * b['relative_drop']:.1f} % of the error and "
                   f"{100 * b['excess_drop']:.0f} % of its excess over the noise floor")
    return why


# -- 3b. a recalibration that is a symptom ----------------------------------------------------

def implausible(model, null):
    """The base parameters the null fit chose itself (not the caller's) that it left at a fit
    bound or beyond :data:`pneucore.analysis.hypotheses.IMPLAUSIBLE` typical catalogue errors:
    ``[{path, label, before, after, unit, reason}]``. Such a value is a symptom: something
    the recalibration stands in for (an effect the base model lacks)."""
    if null.fit is None:
        return []
    out = []
    for s in null.auto_specs:
        v = null.fit.values.get(s.path)
        if v is None:
            continue
        before = get_value(model, s.path)
        why = H.plausibility(model, s.path, v["value"], v.get("at_bound", False))
        if why and abs(v["value"] - before) > RECAL_MIN * max(abs(before), 1e-300):
            out.append({"path": s.path, "label": H.label_of(s.path), "before": before,
                        "after": v["value"], "unit": v.get("unit", ""), "reason": why,
                        "impossible": bool(H.impossible(model, s.path, v["value"]))})
    return out


def hold_impossible(model, exps, hyp, unc, null, odd, comp_start, rps_start, max_nfev, report):
    """The null refitted with the physically impossible values among ``odd``
    (:func:`pneucore.analysis.hypotheses.impossible`: a load against its declared direction, a
    negative mass) held at the declared values, and again with any the refit turns impossible
    in their place, until none is left: ``(null, held)``, ``held`` the impossible values (as
    :func:`implausible` gives them); ``(null, [])`` when none is impossible. An impossible
    value is no model to propose, however well it fits (issue 28): the rest is refitted
    around the declared value."""
    hold = [o for o in odd if o.get("impossible")]
    if not hold:
        return null, []
    null_h = null
    # each pass holds at least one more parameter, so at most one pass per fitted one
    for _ in range(max(len(hyp.auto_specs), 1)):
        report(0.05, "refitting the base model with " + ", ".join(o["label"] for o in hold)
               + " held at the declared value (the value fitted is impossible)")
        null_h = null_fit(model, exps, hyp, unc, comp_start, rps_start, max_nfev, report,
                          held={o["path"] for o in hold} | hyp.held)
        paths = {o["path"] for o in hold}
        new = [o for o in implausible(model, null_h) if o["impossible"] and o["path"] not in paths]
        if not new:
            break
        hold = hold + new
    return null_h, hold


def impossible_words(hold, e_held, e_with):
    """The impossible values held at the declared values, in words: each before and as fitted,
    with its reason, and the error of the refit around them (``e_held``) against the fit with
    them (``e_with``)."""
    it = "it" if len(hold) == 1 else "them"
    return ("Held at the declared value, being physically impossible: "
            + "; ".join(f"{o['label']} stays at {o['before']:.3g} {o['unit']}".rstrip()
                        + f" (fitted {o['after']:.3g} {o['unit']}".rstrip() + f": {o['reason']})"
                        for o in hold)
            + f". The rest is refitted with {it} held (error {100 * e_held:.2f} % against "
            f"{100 * e_with:.2f} % with the impossible value{'s' if len(hold) > 1 else ''}): "
            f"something this model lacks (an undeclared force or effect) or a wrong declaration "
            f"stands behind {it}")


def takes_over(weighed, null):
    """Does a verdict found with the implausible parameters held at their catalogue values
    explain the records at least as well as the implausible recalibration (the null)?
    ``weighed``: ``(score, lead, refits, ranking, verdict, message)`` of that run."""
    verdict_h, refits_h = weighed[4], weighed[2]
    return verdict_h is not None and refits_h[verdict_h].error_after.overall <= null.error


def holdings(odd):
    """The sets of implausible parameters to hold, in turn: those at a fit bound (the data push
    them further than the fit allows: the plainest symptom) or against their declared
    direction alone, then every one."""
    out = []
    # (a value against its declared direction is as plain: impossible, whatever its size)
    bound = [o for o in odd if "bound" in o["reason"] or "declared direction" in o["reason"]]
    for hold in (bound, odd):
        if hold and hold not in out:
            out.append(hold)
    return out


def held_words(odd, hold, verdict_h, e_held, e_null):
    """The reweighing in words: the implausible values (``odd``), those held at the catalogue
    (``hold``), and what then."""
    def vals(group):
        return "; ".join(f"{o['label']} {o['before']:.3g} -> {o['after']:.3g} {o['unit']}".rstrip()
                         + f" ({o['reason']})" for o in group)
    it = "it" if len(hold) == 1 else "them"
    if verdict_h is not None:
        return (f"The recalibration {vals(hold)} was a stand-in: with {it} held at the catalogue "
                f"value, {verdict_h} explains the records better (error {100 * e_held:.2f} % "
                f"against {100 * e_null:.2f} % with the implausible value)")
    it = "it" if len(odd) == 1 else "them"
    return (f"Implausible: {vals(odd)}; with {it} held at the catalogue value no catalog effect "
            f"explains the records as well, so the recalibration stands, but a missing effect or "
            f"a wrong declaration may stand behind {it}")


def still_implausible(odd, refitted):
    """Of the implausible values ``odd`` the null fit found, those the fit a diagnosis returns
    (``refitted``: its entries, :func:`pneucore.analysis.diagnosis.findings.findings`) still
    has implausible, each with the returned value and reason: a later fit (the sensors' zeros
    fitted beside the base parameters) may put them back where a catalogue error reaches,
    and the message describes the model returned, not the fit before it."""
    final = {r["path"]: r for r in refitted}
    out = []
    for o in odd:
        r = final.get(o["path"])
        if r is None:
            out.append(o)
        elif r.get("implausible"):
            out.append({**o, "after": r["after"], "reason": r["implausible"]})
    return out


def withheld(model, next_model, recal, auto_paths):
    """The next model with the implausible recalibrations among ``auto_paths`` put back at
    ``model``'s values, and those entries: once an effect was found to stand behind one
    implausible value, the others left beside it are the same symptom, weighed again in the
    next round from the catalogue value, not taken as its new centre."""
    back = [r for r in recal if r.get("implausible") and r["path"] in auto_paths]
    if not back:
        return next_model, []
    # a valve path is a scale factor on the model's tables: 1 reads back whatever the fit
    # found, so its table is scaled back by before / after
    return set_values(next_model, {r["path"]: (r["before"] / r["after"] if r["path"].startswith("valve.")
                                              else get_value(model, r["path"])) for r in back}), back
