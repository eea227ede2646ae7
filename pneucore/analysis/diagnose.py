"""What is mis-set, what is missing, what remains? ``diagnose(model, experiments)``.

0. **Base hypotheses.** With nothing declared, the base parameters the
   experiments can identify are chosen (:mod:`pneucore.analysis.hypotheses`:
   sensitivities, visibility, collinearity); ``uncertain`` overrides the
   choice. Parameters of effects already in the model are refitted too.
1. **Null model.** Those parameters refitted (the best recalibration), the
   fit reweighted by each series' own residual (concentrated likelihood).
2. **Score pass (cheap).** For every catalog effect the model lacks, the
   change of the outputs caused by a moderate dose of the effect (one
   simulation per strength parameter) gives a sensitivity matrix ``J``.
   The base parameters' sensitivities are projected out and the
   Lagrange-multiplier statistic ``LM = r^T J (J^T J)^-1 J^T r`` is formed on
   residuals scaled to unit variance; a strength that may only be positive
   is dropped when the data ask for a negative one (one-sided test).
3. **Joint refit (real).** The leading candidates are added and fitted with
   the base parameters the null found mis-set, from the model as given (the
   null's values are biased by what is missing); a base parameter the joint
   fit puts back at its catalogue value is held there. Each gets its Eq. 25
   error after, per signal and phase, the likelihood-ratio statistic with
   its chi-square p-value and the change of BIC, all counted with **one
   common effective sample size** ``n / tau`` (``tau`` of the best refit's
   residual, :mod:`pneucore.analysis.autocorrelation`), so that the ranking by ΔBIC is
   monotone in the evidence shown; the white-noise LR is reported as
   ``lr_statistic_white``.
4. **Verdict.** The best refit is named only if it is significant (LR
   p-value below ``alpha`` divided by the number of refits), strongly
   preferred (ΔBIC < -10), material (at least 5 % of the error, and at least
   half of the misfit in excess of the noise floor: alone, alone once each
   signal's best transducer gain and offset are removed from the residuals
   (:func:`pneucore.analysis.hypotheses.calibrated_error`), or together with
   the next candidate), and consistent across experiments (its parameters
   fitted on each experiment alone agree, :func:`consistency`). Candidates
   are judged in order of evidence: a stand-in that fails does not hide the
   next; the first that passes is named (and ranked first). Otherwise
   the verdict is ``None``: "no catalog effect explains the remaining
   residual".
5. **Findings.** ``recalibrate`` (mis-set base parameters, before/after),
   ``model`` (the next version), ``alternatives`` (what the data cannot tell
   apart from the verdict), ``remaining`` (error, noise floor, whether the
   remainder lies outside the catalog, and its signature in words), with
   Ljung-Box whiteness and command cross-correlation tests of the residual.
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from pneucore.analysis.blas_threads import single_threaded_blas
from pneucore.analysis.autocorrelation import effective_lr, residual_times, times_report
from pneucore.analysis import calibrate as _calibrate
from pneucore.analysis.calibrate import fit, information_criteria
from pneucore.analysis.compare import plain_json
from pneucore.analysis.compare import replay, summarise
from pneucore.spec.effects import EFFECTS
from pneucore.data.experiment import as_experiments
from pneucore.analysis.metrics import cross_correlation_test, ljung_box
from pneucore.spec.model import Model
from pneucore.analysis import hypotheses as H
from pneucore.analysis.engineering import impossible, in_words
from pneucore.spec.paths import ParameterSpec, get_value, model_changes, parse_parameters, set_values

#: Significance level of the likelihood-ratio test, before the Bonferroni split
ALPHA = 1e-3
#: BIC decrease required to name an effect (Kass & Raftery 1995: > 10 is "very strong")
DELTA_BIC = -10.0
#: Fraction of the overall Eq. 25 error an effect must remove to be material
MATERIAL = 0.05
#: Number of candidates refitted after the score pass
N_REFIT = 3
#: Share of the misfit in excess of the noise floor an effect must remove to be material
EXCESS_MATERIAL = 0.2
#: Relative difference of an effect parameter fitted on two experiments beyond which they
#: disagree: 50 %; a physical effect, refitted with 1-2 parameters on ~2000 samples per
#: experiment, comes back within a few percent (tests/analysis/test_diagnosis.py: within 20 % of the truth)
CONSISTENT_RTOL = 0.5
#: Share of that excess the named effect must remove, alone or with the next candidate (two
#: missing effects of similar size): a stand-in for something outside the catalog removes less
EXCESS_MAJOR = 0.5
#: Relative rise of the Eq. 25 error within which an effect already in the model may be dropped
#: (its strength indistinguishable from off): 1 %, the scatter of refits stopped by the
#: optimiser's budget; an effect whose removal costs more is still doing work
DROP_TOLERANCE = 0.01
#: Relative change below which a refitted base parameter is not reported as mis-set
RECAL_MIN = 0.02
#: An error within this factor of the noise floor is at the floor
AT_FLOOR = 1.2
#: Misfit above this factor of the floor, with a command-dependent residual, lies outside
OUTSIDE_FACTOR = 1.5
#: Share of the remaining residual a physical signal must explain for the remainder to count as
#: structure (:func:`pneucore.analysis.hypotheses.residual_signature`)
SIGNATURE_R2 = 0.5

NO_EFFECT = "no catalog effect explains the remaining residual"


def _unit_residuals(replays):
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


def _stack(replays, keys):
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


def _lm_statistic(r, J, one_sided):
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


def _project_out(J, Ju):
    if Ju is None or Ju.shape[1] == 0:
        return J
    Q, _ = np.linalg.qr(Ju)
    return J - Q @ (Q.T @ J)


def _with_effect(model, name, values):
    m = model.copy()
    m.effects[name] = dict(values)
    return m


@dataclass
class Diagnosis:
    """Result of :func:`diagnose`; ``to_dict()`` is plain JSON."""
    verdict: object
    message: str
    ranking: list
    score_pass: list
    error_before: object
    failure_windows: list
    residual_tests: dict
    noise_floor: dict
    base_model: Model
    uncertain: list
    refits: dict = field(default_factory=dict, repr=False)
    recalibrate: list = field(default_factory=list)
    refitted: list = field(default_factory=list)
    model: object = None
    alternatives: list = field(default_factory=list)
    remaining: dict = field(default_factory=dict)
    identifiability: list = field(default_factory=list)
    initial_state: list = field(default_factory=list)
    error_start: object = None
    dropped: list = field(default_factory=list)
    hints: list = field(default_factory=list)
    given: object = field(default=None, repr=False)
    known: list = field(default_factory=list)

    def best(self):
        return self.ranking[0] if self.ranking else None

    def to_dict(self):
        return plain_json({
            "verdict": self.verdict, "message": self.message,
            "ranking": [{k: v for k, v in r.items() if k != "model_obj"} for r in self.ranking],
            "score_pass": self.score_pass,
            "error_before": {"errors": self.error_before.errors,
                             "overall": self.error_before.overall,
                             "phases": self.error_before.phases},
            "failure_windows": self.failure_windows, "residual_tests": self.residual_tests,
            "noise_floor": self.noise_floor, "base_model": self.base_model.to_dict(),
            "uncertain": self.uncertain, "known": self.known,
            "recalibrate": self.recalibrate, "refitted": self.refitted,
            "model": self.model.to_dict() if self.model is not None else None,
            "changes": (model_changes(self.given, self.model) if self.model is not None
                        and self.given is not None else []),
            "alternatives": self.alternatives, "remaining": self.remaining,
            "identifiability": self.identifiability, "dropped": self.dropped,
            "initial_state": self.initial_state, "hints": self.hints,
            "error_start": ({"errors": self.error_start.errors, "overall": self.error_start.overall}
                            if self.error_start is not None else None),
        })


def residual_tests(replays, lags=20):
    """Whiteness (Ljung-Box) and command cross-correlation tests of each residual.

    ``structure_remains``: some residual is not white noise (either test
    rejects at p < 0.001). ``command_dependent``: some residual depends on
    the command (the cross-correlation test, which allows for coloured noise,
    rejects): the physics the command drives is incomplete. An autocorrelated
    residual without a significant dependence on the command is ambiguous:
    coloured measurement noise, or missing physics that acts slowly (a leak
    during a hold, heat exchange); the summary says so.
    """
    out = []
    dependent = False
    coloured = False
    for rp in replays:
        u = rp.experiment.command_samples[:len(rp.t)]
        for s in rp.measured:
            d = rp.measured[s] - rp.simulated[s]
            q, p = ljung_box(d, lags)
            c, pc = cross_correlation_test(d, u, lags)
            out.append({"experiment": rp.experiment.name, "signal": s, "ljung_box_q": q,
                        "ljung_box_p": p, "cross_corr_s": c, "cross_corr_p": pc})
            if pc == pc and pc < 1e-3:
                dependent = True
            if p == p and p < 1e-3:
                coloured = True
    if dependent:
        text = ("the residual depends on the command (cross-correlation test rejected at "
                "p < 0.001): some physics is still missing or mis-set")
    elif coloured:
        text = ("the residual is autocorrelated (Ljung-Box rejected at p < 0.001) without a "
                "significant dependence on the command: coloured measurement noise, or missing "
                "physics that acts slowly (a leak, heat exchange); a recording of the sensors at "
                "rest tells them apart")
    else:
        text = "the residual is consistent with white measurement noise"
    return {"tests": out, "structure_remains": dependent or coloured,
            "command_dependent": dependent, "summary": text}


def _improvement(before, after):
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


def _explain(eff, cand, floor_overall):
    lands = cand["improvement"][:2]
    where = "; ".join(f"{d['signal']} while {d['phase']} ({100 * d['before']:.2f} % -> "
                      f"{100 * d['after']:.2f} %)" for d in lands if d["drop"] > 0) or "nowhere in particular"
    # the same standard error as the ranking's table (its 95 % interval is ci95 there)
    params = ", ".join(f"{k} = {v['value']:.3g} ± {v['stderr']:.2g} {v['unit']}"
                       for k, v in cand["params"].items())
    txt = (f"Adding {eff.name} ({eff.description}) lowers the overall error from "
           f"{100 * cand['error_before']:.2f} % to {100 * cand['error_after_overall']:.2f} %"
           f" (noise floor about {100 * floor_overall:.2f} %). The improvement lands on {where}. "
           f"This matches the effect's signature: {eff.signature}. Fitted (± standard error): {params}. "
           f"Likelihood-ratio p = {cand['p_value']:.2g}, delta BIC = {cand['delta_bic']:.1f}.")
    return txt


def _candidate_names(model, candidates):
    """The effects a diagnosis considers: ``candidates``, or every catalog effect not in the model."""
    return [n for n in EFFECTS if n not in model.effects] if candidates is None else list(candidates)


def _check_paths(model, paths, where):
    """Each of ``paths`` must be a writable model parameter; the error names ``where[i]``."""
    from pneucore.spec.validation import FieldError
    for i, p in enumerate(paths):
        if not isinstance(p, str):
            raise FieldError(f"{where}[{i}]", f"{p!r} is not a parameter path")
        try:
            (spec,) = parse_parameters(model, [p])
            # the path must also be writable and read back (a property such as jack.area_a,
            # or an attribute of a number such as supply.pressure.real, is not a parameter)
            trial = set_values(model, {p: spec.value})
            if get_value(trial, p) != spec.value:
                raise ValueError("does not read back what was written")
        except FieldError as exc:
            raise FieldError(f"{where}[{i}]", f"{p!r}: {exc.detail}") from None
        except Exception as exc:  # noqa: BLE001 - any failure means: not a model parameter
            raise FieldError(f"{where}[{i}]", f"{p!r} is not a fittable model parameter "
                                              f"({exc})") from None


def check_request(model, candidates=None, uncertain=(), known=()):
    """Validate ``candidates``, ``uncertain`` and ``known`` before any work; returns the
    candidate names. A path both uncertain and known is refused (naming it)."""
    from pneucore.spec.validation import FieldError
    if candidates is None:
        names = _candidate_names(model, None)
    else:
        names = list(candidates)
        for i, n in enumerate(names):
            if not isinstance(n, str) or n not in EFFECTS:
                raise FieldError(f"candidates[{i}]", f"unknown effect {n!r}; the catalog has "
                                                     f"{sorted(EFFECTS)}")
    paths = list(uncertain) if isinstance(uncertain, (list, tuple)) else list(dict(uncertain))
    _check_paths(model, paths, "uncertain")
    known = list(known or ())
    _check_paths(model, known, "known")
    for i, p in enumerate(paths):
        if p in known:
            raise FieldError(f"uncertain[{i}]", f"{p!r} is declared known: a known value is never "
                                                "fitted (drop it from uncertain or from known)")
    return names


@single_threaded_blas
def diagnose(model, experiments, candidates=None, uncertain=(), n_refit=N_REFIT, alpha=ALPHA,
             datasets=None, progress=None, max_nfev=30, refit_existing=True, base_hypotheses=True,
             validated=False, known=()):
    """Which base parameters are mis-set, which catalog effect is missing, what remains.

    Parameters
    ----------
    model : Model or dict
        Current model
    experiments : list
        Experiments (objects or JSON)
    candidates : list of str or None
        Effects to consider (None = every applicable catalog effect)
    uncertain : list of str or dict
        Base parameter paths refitted under the null and with
        every candidate (e.g. ``["heat.coefficient"]``); given, it overrides the automatic
        choice of ``base_hypotheses``
    n_refit : int
        Number of leading candidates refitted
    alpha : float
        Significance level (split over the refits)
    progress : callable or None
        ``progress(fraction, step)`` for long runs
    refit_existing : bool
        Also treat the parameters of catalog effects already in the model
        as uncertain: they were fitted on a model that lacked what is sought now, so they are
        refitted jointly (otherwise their bias makes a spurious extra effect look useful)
    base_hypotheses : bool
        With no ``uncertain`` given, choose the base parameters to
        recalibrate from what the experiments identify (:mod:`pneucore.analysis.hypotheses`)
    validated : bool
        ``candidates``, ``uncertain`` and ``known`` were already checked on this model by
        :func:`check_request` (the API does so at its boundary, before any work): they are
        not checked again
    known : list of str
        Parameter paths whose values the user declared (a weighed mass, a load from
        gravity): never fitted, never offered as a base hypothesis; where the data would
        need one far off, ``remaining["known_disagree"]`` and the message say so

    Returns
    -------
    diagnosis : Diagnosis
        ``verdict`` (effect name or None), ``recalibrate`` (mis-set base
        parameters), ``model`` (the next model version), ``alternatives``, ``remaining``,
        ``ranking`` of refitted candidates, ``score_pass`` of all candidates, errors, windows
        and residual tests
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    exps = as_experiments(experiments, model.ambient.pressure, datasets)
    report = progress or (lambda f, s: None)

    # -- candidates --------------------------------------------------------------
    names = _candidate_names(model, candidates) if validated else \
        check_request(model, candidates, uncertain, known)
    known = tuple(known or ())
    cands = []
    skipped = []
    for n in names:
        if n in model.effects:
            skipped.append({"effect": n, "reason": "already in the model"})
            continue
        ok, why = EFFECTS[n].applicable(model)
        if not ok:
            skipped.append({"effect": n, "reason": why})
            continue
        cands.append(n)

    # -- the model as given ----------------------------------------------------------
    from pneucore.analysis.calibrate import Objective
    report(0.01, "simulating the model as given")
    rps_start = [replay(model, e) for e in exps]
    comp_start = summarise(rps_start)

    # -- which base parameters can the experiments identify? -------------------------
    unc = {p: {} for p in uncertain} if isinstance(uncertain, (list, tuple)) else dict(uncertain)
    identifiability = []
    id_cols = {}
    initial_state = []
    auto = not unc and base_hypotheses
    if auto:
        # the initial state a record does not give, where the record identifies it: the rest
        # of the diagnosis replays the experiments from it
        report(0.015, "initial state")
        exps, initial_state, init_report = H.fit_initial_state(model, exps, replay)
        identifiability += [{**h, "label": f"{h['path']} of {h['experiment']}",
                             "sensitivity": None} for h in init_report]
        rps_id = [replay(model, e) for e in exps] if initial_state else rps_start
        obj_s = Objective(model, exps, [])
        chosen, base_report, id_cols = H.identifiable(
            model, exps, obj_s, obj_s.weighted(rps_id), H.offered(model, cands, exclude=known),
            replay)
        identifiability = base_report + identifiability
        auto_specs = [H.spec_for(model, h) for h in chosen]
    else:
        auto_specs = []
    # -- null model: uncertain base parameters refitted ----------------------------
    report(0.02, "fitting the base model")
    if refit_existing:
        for name in model.effects:
            for p in EFFECTS[name].diagnosis_params:
                if f"effects.{name}.{p}" not in known:
                    unc.setdefault(f"effects.{name}.{p}", {})
    u_specs = auto_specs + (parse_parameters(model, unc) if unc else [])
    base_paths = [s.path for s in u_specs if not s.path.startswith("effects.")]
    u_specs_start = list(u_specs)
    # the catalogue prior on the base parameters: a direction the data do not resolve stays
    # where the user put it (the least change), :func:`pneucore.analysis.hypotheses.prior_for`
    prior = H.prior_for(model, base_paths)
    if u_specs:
        null_fit = fit(model, exps, u_specs, max_nfev=max_nfev, progress=report, span=(0.02, 0.05),
                       step="fitting the base model", reweight=True, prior=prior)
        # a hypothesis confounded in the small with parameters the fit drove to a bound (a
        # load taken up by a Coulomb level that cannot go below 0) is needed after all
        freed = H.freed_by_bounds(identifiability, null_fit.values) if auto else []
        if freed:
            report(0.04, "refitting the base model with " + ", ".join(H.label_of(p) for p in freed))
            auto_specs = auto_specs + [H.spec_for(model, H.BASE_HYPOTHESES[p]) for p in freed]
            u_specs = auto_specs + (parse_parameters(model, unc) if unc else [])
            base_paths = [s.path for s in u_specs if not s.path.startswith("effects.")]
            u_specs_start = list(u_specs)
            prior = H.prior_for(model, base_paths)
            null_fit = fit(model, exps, u_specs, max_nfev=max_nfev, compute_before=False,
                           reweight=True, prior=prior)
        base = null_fit.model
        u_specs = [ParameterSpec(s.path, null_fit.values[s.path]["value"], s.min, s.max, s.vary, s.unit)
                   for s in u_specs]
        # the fit's end point is already simulated: its comparison is the null's
        comp0 = null_fit.error_after
        rps0 = comp0.replays
    else:
        null_fit = None
        base = model
        rps0 = rps_start
        comp0 = comp_start
    from pneucore.analysis.calibrate import Objective
    obj0 = Objective(base, exps, [])
    rss0 = obj0.rss(rps0)
    m2ll0, _, _, n_all = information_criteria(rss0, len(u_specs))
    r0, keys = _unit_residuals(rps0)
    y0 = _stack(rps0, keys)

    # sensitivities of the uncertain parameters (to project out)
    Ju = None
    if u_specs:
        def ucol(s):
            # around the null model (a valve scale reads 1 there, whatever the fit found)
            v = get_value(base, s.path)
            h = 1e-3 * (abs(v) or (s.max - s.min) / 100)
            mp = set_values(base, {s.path: v + h})
            return (_stack([replay(mp, e) for e in exps], keys) - y0) / h

        with ThreadPoolExecutor(_calibrate.THREADS) as pool:
            Ju = np.column_stack(list(pool.map(ucol, u_specs)))

    # -- score pass ------------------------------------------------------------------
    score = []

    def probe(name):
        eff = EFFECTS[name]
        sp = eff.score_params
        vals_off = eff.probe_values(model)
        for p in sp:
            vals_off[p] = eff.param(p).off
        cols, one_sided = [], []
        for p in sp:
            v = dict(vals_off)
            v[p] = eff.probe_values(model)[p]
            mp = _with_effect(base, name, v)
            yp = _stack([replay(mp, e) for e in exps], keys)
            cols.append(yp - y0)
            par = eff.param(p)
            one_sided.append(par.off is not None and par.min >= par.off
                             and v[p] > par.off)
        J = _project_out(np.column_stack(cols), Ju)
        lm, used = _lm_statistic(r0, J, one_sided)
        dof = max(len(used), 1)
        p_lm = float(stats.chi2.sf(lm, dof)) if used else 1.0
        return {"effect": name, "lm": lm, "dof": len(used), "p_value": p_lm,
                "score_params": list(sp)}

    with ThreadPoolExecutor(_calibrate.THREADS) as pool:
        for k, res in enumerate(pool.map(probe, cands)):
            score.append(res)
            report(0.05 + 0.35 * (k + 1) / max(len(cands), 1), f"score test: {res['effect']}")
    score.sort(key=lambda d: (-d["lm"] if d["dof"] else 0.0))
    for i, s in enumerate(score):
        s["rank"] = i + 1

    # -- refit leading candidates ------------------------------------------------------
    lead = [s["effect"] for s in score if s["dof"] > 0][:n_refit]
    floor = comp0.noise_floor
    floor_overall = float(math.sqrt(np.mean(np.square([v for v in floor.values() if v == v])))) \
        if floor else float("nan")
    refits = {}

    def refit(name):
        eff = EFFECTS[name]
        start = eff.probe_values(model)
        # from the model as given: the null's values are biased by what is missing
        m = _with_effect(model, name, start)
        specs = [ParameterSpec(f"effects.{name}.{p}", start[p], eff.param(p).min, eff.param(p).max,
                               True, eff.param(p).unit) for p in eff.diagnosis_params
                 if p not in eff.unused_in(model)]
        specs += u_specs_start
        # the refit checks the time limit at each evaluation (progress stays at its level)
        cal = fit(m, exps, specs, max_nfev=max_nfev, compute_before=False,
                  progress=lambda f, s: report(0.4, f"refit: {name}"), reweight=True, prior=prior)
        # base parameters the joint fit leaves at their catalogue values (within RECAL_MIN) are
        # not mis-set: hold them there and refit the rest from this point, so that they do not
        # blur the effect's parameters (kept unless the fit gets materially worse)
        auto_paths = {q.path for q in auto_specs}
        back = {q["path"] for q in _recalibration(model, cal, sorted(auto_paths))[1]
                if abs(q["after"] - q["before"]) <= RECAL_MIN * max(abs(q["before"]), 1e-300)}
        if back:
            m2 = _with_effect(model, name, {**start, **cal.model.effects[name]})
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
                       prior=H.prior_for(model, [q.path for q in specs2], scale))
            # kept unless materially worse (2 % of the residual energy: 1 % of the Eq. 25 error)
            if sum(r for _, _, r, _ in cal2.rss_after) <= 1.02 * sum(r for _, _, r, _ in cal.rss_after):
                cal = cal2
        return name, cal

    done = 0
    with ThreadPoolExecutor(_calibrate.THREADS) as pool:
        for name, cal in pool.map(refit, lead):
            refits[name] = cal
            done += 1
            report(0.4 + 0.55 * done / max(len(lead), 1), f"refit: {name}")

    # one common effective sample size for every comparison: the autocorrelation times of the
    # residual of the most complete model fitted (the best refit, else the null); counted per
    # candidate, a worse fit would get a longer tau, fewer samples, and a milder penalty
    if refits:
        ref = min(refits.values(), key=lambda c: sum(r for _, _, r, _ in c.rss_after))
        taus = ref.residual_times
    else:
        taus = null_fit.residual_times if null_fit is not None else residual_times(rps0)
    # the null's error once each signal's best transducer gain and offset are removed: what a
    # catalog effect must explain when a sensor calibration error is also present
    e0_cal = H.calibrated_error(rps0)[0]
    ranking = []
    for name, cal in refits.items():
        eff = EFFECTS[name]
        k_eff = len(eff.diagnosis_params)
        lr_eff, n_eff = effective_lr(rss0, cal.rss_after, taus)
        lr = max(lr_eff, 0.0)
        p = float(stats.chi2.sf(lr, k_eff))
        d_bic = -lr_eff + k_eff * math.log(max(n_eff, 1.0))
        d_aic = -lr_eff + 2 * k_eff
        params = {p_: v for p_, v in cal.values.items() if p_.startswith(f"effects.{name}.")}
        # an effect's parameter given the user's values along what the records do not resolve
        # (the catalogue prior; a quadrant level beside an undeclared load and the extend level)
        params = {k.split(".")[-1]: _given_prior(v) for k, v in params.items()}
        e0, e1 = comp0.overall, cal.error_after.overall
        cand = {"effect": name, "error_before": e0, "error_after": cal.error_after.errors,
                "error_after_overall": e1,
                "error_after_phases": cal.error_after.phases,
                "relative_drop": (e0 - e1) / e0 if e0 else 0.0,
                "excess_drop": _excess_drop(e0, e1, floor_overall),
                "excess_drop_calibrated": _excess_drop(
                    e0_cal, H.calibrated_error(cal.error_after.replays)[0], floor_overall),
                "lr_statistic": lr, "p_value": p, "delta_bic": d_bic, "delta_aic": d_aic,
                "lr_statistic_white": max(m2ll0 - cal.neg2_loglik, 0.0),
                "effective_samples": n_eff, "n_samples": n_all,
                "autocorrelation_time": times_report(taus),
                "params": params,
                "uncertain_params": {k: v for k, v in cal.values.items() if not k.startswith("effects.")},
                "improvement": _improvement(comp0, cal.error_after),
                "fit_success": cal.success, "fit_message": cal.message,
                "description": eff.description, "signature": eff.signature,
                "reference": eff.reference, "model_obj": cal.model}
        cand["explanation"] = _explain(eff, cand, floor_overall)
        cand["model"] = cal.model.to_dict()
        ranking.append(cand)
    # same null, same effective samples: delta BIC is monotone in the evidence shown
    ranking.sort(key=lambda c: c["delta_bic"])

    verdict = None
    message = NO_EFFECT
    n_tests = max(len(ranking), 1)
    for c in ranking:
        # physical plausibility: a strength at its fit bound, or not distinguishable from off by
        # its own standard error, is no evidence of the effect however much the fit improves
        c["undetermined"] = _undetermined(c) or impossible(
            c["effect"], (c["model"].get("effects") or {}).get(c["effect"]) or c["params"], model)
        c["significant"] = c["p_value"] < alpha / n_tests and not c["undetermined"]
        c["strong"] = c["delta_bic"] < DELTA_BIC
        c["material"] = c["relative_drop"] >= MATERIAL and c["excess_drop"] >= EXCESS_MATERIAL
        c["consistent"] = None
        c["named"] = False
    if ranking:
        # candidates are judged in evidence order; one that fails (a stand-in: it explains too
        # little of the excess, or its parameters disagree between experiments) does not hide
        # the next, which is judged on its own evidence (each test at alpha / number of refits)
        # and, if it passes, named and ranked first
        contenders = [c for c in ranking if c["significant"] and c["strong"]] or ranking[:1]
        for b in contenders:
            _judge(b, model, exps, ranking, refits, u_specs_start, comp0.overall, floor_overall,
                   max_nfev, report)
            if b["named"]:
                break
        named = [c for c in contenders if c["named"]]
        if named:
            b = named[0]
            ranking.remove(b)
            ranking.insert(0, b)
            verdict = b["effect"]
            message = (f"{b['effect']}: {b['description']}. Error {100 * b['error_before']:.2f} % -> "
                       f"{100 * b['error_after_overall']:.2f} %.")
        else:
            b = ranking[0]
            why = []
            if b["undetermined"]:
                why.append(f"best candidate {b['effect']} is not determined by these records "
                           f"({b['undetermined']})")
            elif not b["significant"]:
                why.append(f"best candidate {b['effect']} not significant (p = {b['p_value']:.2g})")
            if not b["strong"]:
                why.append(f"delta BIC {b['delta_bic']:.1f} not below {DELTA_BIC:g}")
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
            message = NO_EFFECT + " (" + "; ".join(why) + ")"
    tests = residual_tests(rps0)
    if verdict is not None:
        chosen = refits[verdict]
        best_rps = chosen.error_after.replays
        tests["after_verdict"] = residual_tests(best_rps)
    else:
        chosen = null_fit
        best_rps = rps0
    final_tests = tests.get("after_verdict", tests)

    # -- mis-set base parameters, the next model, alternatives, what remains --------------
    recal, refitted = _recalibration(model, chosen, base_paths)
    next_model = chosen.model.copy() if chosen is not None else model.copy()
    # an effect named in an earlier round leaves the model only when the data say so: its
    # refitted strength is indistinguishable from off *and* the model without it fits as well
    err_chosen = chosen.error_after.overall if chosen is not None else comp0.overall
    dropped, kept = [], []
    for name in _redundant(model, chosen, verdict):
        trial = next_model.copy()
        trial.effects.pop(name, None)
        e_trial = summarise([replay(trial, e) for e in exps]).overall
        if e_trial <= (1.0 + DROP_TOLERANCE) * err_chosen:
            next_model = trial
            dropped.append(name)
        else:
            kept.append((name, e_trial))
    report(0.97, "which experiment would separate what the records cannot")
    alternatives = _alternatives(ranking, verdict, refits, exps)
    moved = {r["path"] for r in recal}
    for h in identifiability:
        if h["status"] == "not separable":
            alt = {"path": h["path"], "label": h["label"], "kind": "base",
                   "with": h.get("with", []),
                   "note": f"{h['label']} cannot be told apart from "
                           f"{', '.join(H.label_of(w) for w in h.get('with', []))} "
                           f"by these experiments: only their combination is fitted"}
            # the split matters once its partners were found mis-set: say what would separate
            if moved & set(h.get("with", [])):
                twin = H.confounded_twin(model, h["path"], [q.path for q in auto_specs], id_cols)
                if twin is not None:
                    alt["separating"] = H.separating_experiments(model, twin, exps)
                    alt["note"] += _separating_words(alt["separating"])
            alternatives.append(alt)
    err_final = chosen.error_after.overall if chosen is not None else comp0.overall
    remaining = _remaining(err_final, floor_overall, final_tests, best_rps, verdict)
    if remaining.get("outside_catalog"):
        # a remainder a sensor's zero or gain accounts for: a finding about the rig's sensors,
        # fitted jointly with the base parameters (what the sensor error made them take up)
        report(0.98, "sensor offsets and gains")
        sensed = _sensor_refit(model, exps, verdict, refits, u_specs_start, prior,
                               (best_rps, rps_start), err_final, floor_overall, max_nfev)
        if sensed is not None:
            cal_s, remaining["sensor"], remaining["sensor_fit"] = sensed
            recal, refitted = _recalibration(model, cal_s, base_paths)
            next_model = cal_s.model.copy()
            for name in dropped:
                next_model.effects.pop(name, None)
    if known:
        m_final = chosen.model if chosen is not None else model
        remaining["known_disagree"] = H.known_disagreements(
            m_final, exps, known, best_rps, Objective(m_final, exps, []))
    message = _message(message, recal, remaining, verdict, initial_state)
    for name in dropped:
        message += (f" Dropped {name}: its refitted strength is indistinguishable from off and "
                    f"the model without it fits as well (error {100 * err_chosen:.2f} %).")
    for name, e_trial in kept:
        message += (f" Kept {name}: its strength is poorly determined by these records, but "
                    f"without it the error rises from {100 * err_chosen:.2f} % to "
                    f"{100 * e_trial:.2f} %.")
    if auto and not any(h["status"] == "identifiable" for h in identifiability
                        if "experiment" not in h):
        remaining["identifies_no_base"] = True
        remaining["identifies_nothing"] = not lead
        message += (" These experiments identify none of the base parameters (none of "
                    f"{', '.join(h['label'] for h in identifiability)} changes the recorded signals "
                    "measurably): record the chamber pressures during valve moves, and a free test "
                    "for friction and mass.")
    given = model.to_dict()
    for r in ranking:   # what taking each candidate would change, listed before it is taken
        if r.get("model"):
            r["changes"] = model_changes(given, r["model"])
            words = in_words(r["effect"], (r["model"].get("effects") or {}).get(r["effect"])
                             or r.get("params"), model)
            if words:   # where it acts and how big, in the units it is checked by
                r["in_words"] = words
                r["explanation"] = r.get("explanation", "") + f" In engineering terms: {words}."
                if r["effect"] == verdict:
                    message += f" In engineering terms: {words}."
    for hint in comp_start.hints:   # the records contradict their declared context
        message += " Check the context: " + hint["message"]
    report(1.0, "done")
    return Diagnosis(verdict, message, ranking, score + [{"effect": s["effect"], "skipped": s["reason"]}
                                                          for s in skipped],
                     comp0, comp0.windows, tests, floor, base, [s.path for s in u_specs], refits,
                     recalibrate=recal, refitted=refitted, model=next_model,
                     alternatives=alternatives, remaining=remaining,
                     identifiability=identifiability, error_start=comp_start, dropped=dropped,
                     initial_state=initial_state, hints=comp_start.hints, given=given,
                     known=list(known))


#: A joint sensor refit is kept when it removes at least this share of the misfit in excess of
#: the noise floor (the rule a named effect must meet, :data:`EXCESS_MAJOR`)
SENSOR_EXCESS = EXCESS_MAJOR


def _sensor_refit(model, exps, verdict, refits, u_specs, prior, replays, err, floor, max_nfev):
    """The base parameters (and the verdict's effect) refitted with the sensor offsets and gains
    the residual asks for (:func:`pneucore.analysis.hypotheses.sensor_findings`), from the model
    as given; ``(calibration, findings, summary)`` when it removes at least
    :data:`SENSOR_EXCESS` of the misfit in excess of the floor, else None. ``replays``: the
    fitted model's and the model's as given, each screened (a recalibration may have taken up
    part of a sensor's error: a load for a pressure offset)."""
    fields = {}
    for rps in replays:
        for f in H.sensor_findings(rps, model.ambient.pressure, H.SENSOR_SCREEN):
            fields.setdefault(f["signal"], set()).update(
                {"offset": ("offset",), "gain": ("gain",)}.get(f["kind"], ("offset", "gain")))
    if not fields:
        return None
    specs = []
    for sig, fs in fields.items():
        specs += _calibrate.sensor_specs(exps, [sig], [f for f in ("offset", "gain") if f in fs])
    m0 = model
    if verdict is not None:
        eff = EFFECTS[verdict]
        start = refits[verdict].model.effects[verdict]
        m0 = _with_effect(model, verdict, start)
        specs += [ParameterSpec(f"effects.{verdict}.{p}", start[p], eff.param(p).min, eff.param(p).max,
                                True, eff.param(p).unit) for p in eff.diagnosis_params
                  if p not in eff.unused_in(model)]
    cal = fit(m0, exps, list(u_specs) + specs, max_nfev=max_nfev, compute_before=False,
              reweight=True, prior=prior)
    e1 = cal.error_after.overall
    if not _excess_drop(err, e1, floor) >= SENSOR_EXCESS:
        return None
    out = []
    for sp in specs:
        if not sp.path.startswith(_calibrate.SENSOR_PREFIX):
            continue
        sig, what = _calibrate.sensor_path(sp.path)
        v = cal.values[sp.path]
        if not abs(v["value"]) > 3.0 * v["stderr"]:
            continue   # not told apart from a right sensor (3 standard errors)
        unit, k = H.SENSOR_WORDS.get(sig, ("", 1.0))
        if what == "offset":
            words = (f"sensor {sig} reads {abs(v['value']) * k:.3g} {unit} "
                     f"{'more' if v['value'] > 0 else 'less'} than the model (its zero; "
                     f"± {v['stderr'] * k:.2g} {unit})")
        else:
            words = f"sensor {sig}'s gain is {100 * v['value']:+.3g} % off (± {100 * v['stderr']:.2g} %)"
        out.append({"path": sp.path, "signal": sig, "field": what, "value": v["value"],
                    "stderr": v["stderr"], "unit": v["unit"], "at_bound": v["at_bound"],
                    "description": words})
    if not out:
        return None
    summary = {"error": e1, "error_without": err,
               "description": "; ".join(f["description"] for f in out) + (
                   f": fitted with the base parameters, the error falls from {100 * err:.2f} % to "
                   f"{100 * e1:.2f} % (noise floor {100 * floor:.2f} %). A sensor finding, not "
                   "physics: correct the sensor, or give its offset and gain in the upload's "
                   "column mapping")}
    return cal, out, summary


def _undetermined(cand):
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


def _given_prior(v):
    """A fitted effect parameter's entry: the posterior standard error where a prior applied.

    ``stderr_data`` keeps the data's alone; ``ci95`` is the value +- 1.96 standard errors.
    """
    out = dict(v)
    if "stderr_prior" in out:
        out["stderr_data"] = out["stderr"]
        out["stderr"] = out.pop("stderr_prior")
    out["ci95"] = [out["value"] - 1.96 * out["stderr"], out["value"] + 1.96 * out["stderr"]]
    return out


def _judge(b, model, exps, ranking, refits, u_specs, e0, floor, max_nfev, report):
    """Decide whether candidate ``b`` is named: significant, strong, major, consistent.

    Its share of the excess must be major (:data:`EXCESS_MAJOR`): alone; or alone once
    each signal's best transducer gain and offset are removed from the residuals
    (``excess_drop_calibrated``: a sensor calibration error, the commonest truth outside
    the catalog, inflates the excess that no catalog effect can remove, and a real effect
    beside it still removes most of the rest, while a stand-in for it removes nothing of
    the rest); or together with the next significant, material candidate (two missing
    effects of similar size). Otherwise it is a stand-in for something else. Sets
    ``material``, ``with_next``, ``consistency``, ``consistent`` and ``named`` on ``b``.
    """
    if b["significant"] and b["strong"] and b["material"] and b["excess_drop"] < EXCESS_MAJOR \
            and b["excess_drop_calibrated"] < EXCESS_MAJOR:
        b["with_next"] = _pair(model, exps, b, ranking, refits, u_specs, e0, floor, max_nfev,
                               report)
        b["material"] = bool(b["with_next"] and b["with_next"]["excess_drop"] >= EXCESS_MAJOR)
    if b["significant"] and b["strong"] and b["material"]:
        report(0.96, f"consistency across experiments: {b['effect']}")
        b["consistency"] = consistency(refits[b["effect"]], exps, b["effect"], max_nfev)
        b["consistent"] = b["consistency"]["consistent"]
    b["named"] = bool(b["significant"] and b["strong"] and b["material"] and b["consistent"])
    return b["named"]


def _pair(model, exps, lead, ranking, refits, u_specs, e0, floor, max_nfev, report):
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
    return {"effect": b, "error_after_overall": e1, "excess_drop": _excess_drop(e0, e1, floor)}


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

    def one(e):
        # each experiment's fit is independent of the others': in parallel on the cores
        return fit(cal.model, [e], specs, max_nfev=max(max_nfev // 2, 8), compute_before=False)

    with ThreadPoolExecutor(_calibrate.THREADS) as pool:
        fits = list(pool.map(one, acting))
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


def _excess_drop(e0, e1, floor):
    """Share of the misfit in excess of the noise floor that a change removes [-].

    ``(e0^2 - e1^2) / (e0^2 - floor^2)`` on squared Eq. 25 errors (energies add); 0 when the
    error before is already at the floor.
    """
    if not (floor == floor) or e0 <= floor:
        return 0.0
    return float((e0 * e0 - e1 * e1) / (e0 * e0 - floor * floor))


def _recalibration(model, cal, paths):
    """``(recalibrate, refitted)``: base parameters moved materially by ``cal``, and all refitted.

    A parameter is mis-set when its fitted value differs from the model's by more than
    three standard errors *and* by more than :data:`RECAL_MIN` of its value: standard
    errors under a misspecified model are optimistic, so a statistically clear but
    practically nil change is not reported.
    """
    if cal is None:
        return [], []
    recal, refitted = [], []
    for p in paths:
        v = cal.values.get(p)
        if v is None:
            continue
        before = get_value(model, p)
        after = v["value"]
        se = v.get("stderr", 0.0)
        entry = {"path": p, "label": H.label_of(p), "before": before, "after": after,
                 "stderr": se, "unit": v.get("unit", "") or ("-" if p.startswith("valve.") else ""),
                 "at_bound": v.get("at_bound", False)}
        why = H.plausibility(model, p, after, entry["at_bound"])
        if why:
            entry["implausible"] = why
        refitted.append(entry)
        d = abs(after - before)
        if d > 3.0 * se and d > RECAL_MIN * max(abs(before), 1e-300):
            recal.append(entry)
    recal += _confounded_group(cal, refitted, recal)
    return recal, refitted


#: Correlation of two fitted parameters above which they form a confounded group
CONFOUNDED_CORR = 0.9


def _confounded_group(cal, refitted, recal):
    """Parameters that moved materially but only in a combination the data identify.

    Strongly correlated parameters (``|corr| > CONFOUNDED_CORR`` in the fit) each get a
    large standard error, so none passes the three-standard-error rule alone, while their
    joint change can be unmistakable (a load confounded with the two Coulomb levels). The
    group of the materially moved, correlated parameters is reported, each entry with
    ``confounded_with``, when its change along the combinations the data identify is
    beyond three standard errors (``sum_i (v_i^T dθ)^2 / λ_i > 9 k`` over the ``k``
    eigenpairs of the group's covariance with ``λ_i`` under 1 % of the largest); only the
    identified combinations are meaningful, not the split among the members.
    """
    done = {r["path"] for r in recal}
    moved = [r for r in refitted if r["path"] not in done
             and abs(r["after"] - r["before"]) > RECAL_MIN * max(abs(r["before"]), 1e-300)
             and r["stderr"] > 0]
    corr = getattr(cal, "correlations", None) or {}
    out = []
    for r in moved:
        if r["path"] in {q["path"] for q in out}:
            continue
        group = [r] + [q for q in refitted if q is not r and q["stderr"] > 0
                       and abs(corr.get(r["path"], {}).get(q["path"]) or 0.0) > CONFOUNDED_CORR]
        if len(group) < 2:
            continue
        dth = np.array([q["after"] - q["before"] for q in group])
        se = np.array([q["stderr"] for q in group])
        c = np.array([[1.0 if a is b else (corr.get(a["path"], {}).get(b["path"]) or 0.0)
                       for b in group] for a in group])
        # the combinations the data identify: eigen-directions of the group's covariance whose
        # variance is under 1 % of the worst one's (the near-null direction of the confounding,
        # along which the split between the members is arbitrary, is left out)
        cov = c * np.outer(se, se)
        try:
            lam, vec = np.linalg.eigh(cov)
        except np.linalg.LinAlgError:
            continue
        keep = lam < 1e-2 * lam.max()
        if not keep.any():
            continue
        proj = vec[:, keep].T @ dth
        m2 = float(np.sum(proj ** 2 / np.maximum(lam[keep], 1e-300)))
        if m2 > 9.0 * int(keep.sum()):
            paths = [q["path"] for q in group]
            for q in group:
                if q["path"] not in done:
                    q = dict(q)
                    q["confounded_with"] = [p for p in paths if p != q["path"]]
                    out.append(q)
                    done.add(q["path"])
    return out


def _redundant(model, cal, verdict):
    """Effects already in the model whose refitted strength is indistinguishable from off."""
    if cal is None:
        return []
    out = []
    for name in model.effects:
        if name == verdict:
            continue
        eff = EFFECTS[name]
        sp = eff.score_params
        if not sp:
            continue
        gone = True
        for p in sp:
            v = cal.values.get(f"effects.{name}.{p}")
            if v is None:
                gone = False
                break
            off = eff.param(p).off
            if abs(v["value"] - off) > max(2.0 * v.get("stderr", 0.0), 1e-300):
                gone = False
        if gone:
            out.append(name)
    return out


def _separating_words(suggestions):
    if not suggestions:
        return ("; no variation of the recorded tests (piston locked or free, supply pressure, "
                "position, load) would separate them")
    s = suggestions[0]
    return (f"; {s['experiment']} would separate them (their predictions would differ by "
            f"{math.sqrt(s['separation']):.0f} noise standard deviations in all, against "
            f"{math.sqrt(s['recorded']):.1f} in the records)")


def _alternatives(ranking, verdict, refits=None, exps=None):
    """Candidates the data cannot tell apart from the verdict (delta BIC within 10 of it).

    Each says which experiment would separate it from the verdict
    (:func:`pneucore.analysis.hypotheses.separating_experiments` on the two fitted models,
    ``separating``), falling back to the locked/free rule of the effects' catalog entries.
    """
    if verdict is None or not ranking:
        return []
    best = ranking[0]
    out = []
    for c in ranking[1:]:
        if c["significant"] and c["material"] and c["delta_bic"] - best["delta_bic"] < -DELTA_BIC:
            eff_b, eff_c = EFFECTS[best["effect"]], EFFECTS[c["effect"]]
            note = (f"{c['effect']} explains the data about as well as {best['effect']} "
                    f"(delta BIC {c['delta_bic']:.1f} against {best['delta_bic']:.1f})")
            alt = {"effect": c["effect"], "kind": "effect", "delta_bic": c["delta_bic"],
                   "error_after_overall": c["error_after_overall"]}
            if refits and exps and best["effect"] in refits and c["effect"] in refits:
                alt["separating"] = H.separating_experiments(
                    refits[best["effect"]].model, refits[c["effect"]].model, exps)
                note += _separating_words(alt["separating"])
            else:
                for kind in ("locked", "free"):
                    if (kind in eff_b.observable_in) != (kind in eff_c.observable_in):
                        note += f"; a {kind} test (only one of them acts there) would separate them"
            alt["note"] = note
            out.append(alt)
    return out


def _remaining(err, floor, tests, replays, verdict):
    """What neither recalibration nor a catalog effect explains."""
    at_floor = bool(floor == floor and err <= AT_FLOOR * floor)
    sig = H.residual_signature(replays) if not at_floor else {}
    # misfit well above the floor that either depends on the command or follows a physical
    # signal closely: structure, not coloured noise (which neither test would show)
    outside = bool(not at_floor and floor == floor and err > OUTSIDE_FACTOR * floor
                   and (tests.get("command_dependent") or sig.get("r2", 0.0) >= SIGNATURE_R2))
    out = {"error": err, "noise_floor": floor, "ratio": err / floor if floor else None,
           "at_floor": at_floor, "outside_catalog": outside, "residual": tests.get("summary", "")}
    if not at_floor:
        out["signature"] = sig
        if outside:
            out["description"] = ("misfit remains that neither recalibration nor a catalog effect "
                                  f"explains (error {100 * err:.2f} %, noise floor "
                                  f"{100 * floor:.2f} %): " + sig.get("description", ""))
        else:
            out["description"] = sig.get("description", "")
    else:
        out["description"] = f"the error ({100 * err:.2f} %) is at the noise floor ({100 * floor:.2f} %)"
    return out


def _fmt(v):
    return f"{v:.3g}"


def _message(message, recal, remaining, verdict, initial_state=()):
    parts = []
    if initial_state:
        parts.append("initial state not in the records: " + "; ".join(
            f"{r['label']} {_fmt(r['after'])} {r['unit']} (the replay assumed {_fmt(r['before'])})"
            for r in initial_state))
    if recal:
        parts.append("mis-set: " + "; ".join(
            f"{r['label']} {_fmt(r['before'])} -> {_fmt(r['after'])} {r['unit']}".rstrip()
            for r in recal))
        groups = []
        for r in recal:
            g = sorted([r["path"]] + r.get("confounded_with", []))
            if len(g) > 1 and g not in groups:
                groups.append(g)
        for g in groups:
            parts.append("these experiments identify " + ", ".join(H.label_of(p) for p in g)
                         + " only in combination (the split among them is not determined)")
    odd = [r for r in recal if r.get("implausible")]
    if odd:
        parts.append("implausible as catalogue errors: " + "; ".join(
            f"{r['label']} ({r['implausible']})" for r in odd)
            + ": a missing effect or a wrong declaration may stand behind "
            + ("it" if len(odd) == 1 else "them"))
    if remaining.get("outside_catalog"):
        parts.append("outside the catalog: " + remaining.get("description", ""))
        if remaining.get("sensor_fit"):
            parts.append(remaining["sensor_fit"]["description"])
    elif remaining.get("at_floor"):
        parts.append(remaining["description"])
    parts += [f["description"] for f in remaining.get("known_disagree", [])]
    parts = [q[:1].upper() + q[1:] for q in parts]
    return message + (" " + ". ".join(parts) + "." if parts else "")


def apply_diagnosis(model, diagnosis, effect=None):
    """The next model version: ``effect`` (default: the verdict) added with its fitted parameters.

    Parameters
    ----------
    model : Model or dict
        The model that was diagnosed
    diagnosis : Diagnosis
        Its diagnosis
    effect : str or None
        Which ranked effect to add (None = the verdict)

    Returns
    -------
    model : Model
        With the effect and any refitted uncertain parameters
    """
    name = effect or diagnosis.verdict
    if name is None:
        raise ValueError("the diagnosis named no effect; pass effect=<name> to add one anyway")
    for c in diagnosis.ranking:
        if c["effect"] == name:
            return c["model_obj"].copy()
    raise ValueError(f"effect {name!r} was not refitted by this diagnosis; refitted: "
                     f"{[c['effect'] for c in diagnosis.ranking]}")
