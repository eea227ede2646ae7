"""What is mis-set, what is missing, what remains? ``diagnose(model, experiments)``.

:func:`diagnose` runs a pipeline of named stages, each a function of
:mod:`pneucore.analysis.diagnosis.stages`; the acceptance rules of step 4 are one list,
:data:`pneucore.analysis.diagnosis.rules.RULES`; the findings of step 5 are
:mod:`pneucore.analysis.diagnosis.findings`.

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
   the next candidate, or most of what it removes lies in records it leaves at
   their noise floor: ``ranking[i]["experiments"]``, a short record that shows
   the effect beside a long one whose misfit no catalog effect reaches), and
   consistent across experiments (its parameters fitted on each experiment alone
   agree, :func:`consistency`; beside a record it clears, one it explains nothing
   of is not compared). A base parameter the refit turns against its declared
   direction (a load lifting a vertical jack's mass) makes the candidate
   impossible. Where the LR or
   BIC test fails on a determined, material candidate (a sparse record whose
   smooth misspecified residual leaves few effective samples), it is significant
   and strong when it predicts data it was not fitted on: refitted, as the null
   is, without each of ``HELD_OUT_FOLDS`` blocks in time, it predicts the
   held-out blocks better, or, with two experiments or more, fitted on all but
   one it predicts the one left out better
   (:func:`pneucore.analysis.diagnosis.evidence.held_out`,
   ``ranking[i]["held_out"]``, whose ``used`` names the folds). Candidates
   are judged in order of evidence: a stand-in that fails does not hide the
   next; the first that passes is named (and ranked first), and those after it are
   flagged without their held-out prediction, which can no longer change the verdict
   (``ranking[i]["held_out_not_run"]`` says so). Otherwise
   the verdict is ``None``: "no catalog effect explains the remaining
   residual".
4b. **A recalibration that is a symptom.** With no verdict, a base parameter
   the null left at a fit bound or beyond ``IMPLAUSIBLE`` typical catalogue errors
   (:func:`pneucore.analysis.hypotheses.plausibility`) is held at its catalogue
   value (those at a bound first, then all) and steps 1-4 run again against that
   null; an effect named there that fits at least as well as the implausible
   recalibration is the verdict (the other implausible values beside it stay at
   the catalogue in the next model), else the recalibration stands and is called
   implausible (``remaining["held_at_catalogue"]``). A value that is physically
   impossible (:func:`pneucore.analysis.hypotheses.impossible`: a load against its
   declared direction, a negative mass) never stands: it is held at the declared value
   first, the rest refitted and steps 1-4 run against that null, which replaces the
   recalibration (``remaining["held_impossible"]``, and the message says why).
5. **Findings.** ``recalibrate`` (mis-set base parameters, before/after;
   ``recalibrate_effects`` the same of the effects already in the model),
   ``model`` (the next version), ``alternatives`` (what the data cannot tell
   apart from the verdict), ``remaining`` (error, noise floor, whether the
   remainder lies outside the catalog, and its signature in words), with
   Ljung-Box whiteness and command cross-correlation tests of the residual.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from pneucore.analysis import parallel as P
from pneucore.analysis.blas_threads import single_threaded_blas
from pneucore.analysis.compare import plain_json, replay, summarise
from pneucore.analysis.records import Records, prepared
from pneucore.analysis.diagnosis import rules as R
from pneucore.analysis.diagnosis import stages as S
from pneucore.analysis.diagnosis.circuits import restricted_paths
from pneucore.analysis.diagnosis.evidence import consistency, excess_drop as _excess_drop  # noqa: F401
from pneucore.analysis.diagnosis.evidence import undetermined as _undetermined  # noqa: F401
from pneucore.analysis.diagnosis.findings import (AT_FLOOR, DROP_TOLERANCE, OUTSIDE_FACTOR,  # noqa: F401
                                                  SIGNATURE_R2, findings, residual_tests)
from pneucore.analysis.diagnosis.rules import (ALPHA, CONSISTENT_RTOL, DELTA_BIC,  # noqa: F401
                                               EXCESS_MAJOR, EXCESS_MATERIAL, MATERIAL, N_REFIT,
                                               RULES)
from pneucore.analysis.diagnosis.stages import NO_EFFECT, RECAL_MIN  # noqa: F401
from pneucore.analysis.shown import card_badges, flag_changes
from pneucore.data.experiment import as_experiments
from pneucore.description.effects import EFFECTS
from pneucore.description.model import Model
from pneucore.description.paths import get_value, model_changes, parse_parameters, set_values


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
    cluster: object = None
    #: the significance level the candidates were judged at (over their number) [-]
    alpha: float = ALPHA
    #: parameters of the effects already in the model that the data moved, each ``path``,
    #: ``label``, ``before``, ``after``, ``stderr``, ``unit`` (the answer's model carries them)
    recalibrate_effects: list = field(default_factory=list)

    def best(self):
        return self.ranking[0] if self.ranking else None

    def _given_model(self):
        g = self.given
        return g if isinstance(g, Model) else Model.from_dict(g)

    def to_dict(self):
        return plain_json({
            "verdict": self.verdict, "message": self.message,
            "ranking": [dict({k: v for k, v in r.items() if k != "model_obj"},
                             badges=card_badges(r, self.alpha / max(len(self.ranking), 1),
                                                DELTA_BIC))
                        for r in self.ranking],
            "score_pass": self.score_pass,
            "error_before": {"errors": self.error_before.errors,
                             "overall": self.error_before.overall,
                             "phases": self.error_before.phases},
            "failure_windows": self.failure_windows, "residual_tests": self.residual_tests,
            "noise_floor": self.noise_floor, "base_model": self.base_model.to_dict(),
            "uncertain": self.uncertain, "known": self.known,
            "recalibrate": self.recalibrate, "refitted": self.refitted,
            "recalibrate_effects": self.recalibrate_effects,
            "model": self.model.to_dict() if self.model is not None else None,
            "changes": (flag_changes(self._given_model(), model_changes(self.given, self.model),
                                     self.known)
                        if self.model is not None and self.given is not None else []),
            # what "Apply the recalibration" changes: every value the base model moves, each
            # flagged where impossible or implausible (issue 39: 2 announced, 7 changed)
            "recalibration_changes": (
                flag_changes(self._given_model(), model_changes(self.given, self.base_model),
                             self.known) if self.given is not None else []),
            "alternatives": self.alternatives, "remaining": self.remaining,
            "identifiability": self.identifiability, "dropped": self.dropped,
            "initial_state": self.initial_state, "hints": self.hints,
            "error_start": ({"errors": self.error_start.errors, "overall": self.error_start.overall}
                            if self.error_start is not None else None),
            "cluster": self.cluster,
        })


def _candidate_names(model, candidates):
    """The effects a diagnosis considers: ``candidates``, or every catalog effect not in the model."""
    return [n for n in EFFECTS if n not in model.effects] if candidates is None else list(candidates)


def _check_paths(model, paths, where):
    """Each of ``paths`` must be a writable model parameter; the error names ``where[i]``."""
    from pneucore.description.validation import FieldError
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
    from pneucore.description.validation import FieldError
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
             validated=False, known=(), scheduler=None, scheduler_timeout=None):
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
    scheduler : str, distributed.Client, cluster or None
        Where the independent pieces of work run (the base hypotheses' and the score pass's
        sensitivities, the candidates' joint refits, the per-experiment consistency fits):
        None = this machine's threads; a Dask scheduler address, ``Client`` or cluster
        object = one task each on that cluster (the same answer, to round-off;
        :mod:`pneucore.analysis.parallel`), or an open :class:`pneucore.analysis.parallel.Runner`
        (a refinement's rounds share one). A cluster that loses every worker or stops
        answering is given up after the studies' grace time and the rest runs here
        (``cluster["lost"]`` says why). A service passes only the address configured on the
        server, never one from a request
    scheduler_timeout : float or None
        Time to reach the scheduler (None = the studies' default) [s]

    Returns
    -------
    diagnosis : Diagnosis
        ``verdict`` (effect name or None), ``recalibrate`` (mis-set base
        parameters), ``model`` (the next model version), ``alternatives``, ``remaining``,
        ``ranking`` of refitted candidates, ``score_pass`` of all candidates, errors, windows
        and residual tests
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    # the records prepared once (weights, sample period, windows), read by every stage
    exps = Records(as_experiments(experiments, model.ambient.pressure, datasets))
    report = progress or (lambda f, s: None)

    names = _candidate_names(model, candidates) if validated else \
        check_request(model, candidates, uncertain, known)
    with P.running(scheduler, scheduler_timeout, report) as runner:
        known = tuple(known or ())
        cands, skipped = S.candidate_effects(model, names, uncertain)

        report(0.01, "simulating the model as given")
        rps_start = [replay(model, e) for e in exps]
        comp_start = summarise(rps_start)

        hyp = S.base_hypotheses(model, exps, cands, uncertain, known, base_hypotheses, rps_start,
                                report)
        exps = prepared(hyp.exps)
        report(0.02, "fitting the base model")
        unc = S.uncertain_paths(model, hyp, known, refit_existing)
        # a value the user typically knows (a jack's load, an inclined jack's angle) is held at
        # the user's value, and freed only where the data demand it
        # (one confounded in the small is not chosen, and is freed where a fit drives the
        # parameters it is confounded with to a bound, as any other)
        null = S.null_fit(model, exps, hyp, unc, comp_start, rps_start, max_nfev, report,
                          held=S.known_chosen(hyp))
        null = S.demand(model, exps, hyp, unc, null, comp_start, rps_start, max_nfev, report, alpha)

        def weigh(null):
            score = S.candidate_scores(model, exps, null, cands, report)
            # a null at or below the noise floor leaves no excess for an effect to remove: no
            # candidate can pass the rule "material" (evidence.excess_drop is 0 there), so none
            # is refitted (a line in segments refitted on such a null took 140 of a round's 143 s)
            lead = S.leading(score, n_refit) if not S.at_noise_floor(null) else []
            refits = S.joint_refits(model, exps, null, lead, max_nfev, report,
                                    {c["effect"]: c.get("form", {}) for c in score})
            ranking = S.evidence(null, refits, skipped)
            named = S.verdict(model, exps, ranking, refits, null, alpha, max_nfev, report)
            # an effect the named one resembles and the score pass left out is fitted on the
            # same records before any is named (a switching delay against a line's L / c)
            more = R.unfitted_resemblances(named[0], score, refits)
            if more:
                refits.update(S.joint_refits(model, exps, null, more, max_nfev, report,
                                             {c["effect"]: c.get("form", {}) for c in score}))
                lead = lead + more
                ranking = S.evidence(null, refits, skipped)
                named = S.verdict(model, exps, ranking, refits, null, alpha, max_nfev, report)
            return (score, lead, refits, ranking) + named

        weighed = weigh(null)
        # a recalibration at a bound, or far beyond a catalogue error, is a symptom: the catalog
        # effects are weighed again against a null with it held at the catalogue value
        odd = S.implausible(model, null) if weighed[4] is None else []
        # a physically impossible value (a load against its declared direction) is no model to
        # propose: held at the declared value, the rest refitted and the effects weighed again
        # against that null, which stands in for the recalibration from here on
        impossible = None
        null_i, hold_i = S.hold_impossible(model, exps, hyp, unc, null, odd, comp_start,
                                           rps_start, max_nfev, report)
        if hold_i:
            e_with = null.error
            null, weighed = null_i, weigh(null_i)
            hyp.held |= {o["path"] for o in hold_i}
            for entry in hyp.identifiability:
                why = next((o["reason"] for o in hold_i if o["path"] == entry["path"]), None)
                if why:
                    entry["status"] = "held"
                    entry["note"] = "held at the declared value, the value fitted is impossible: " + why
            impossible = {"parameters": hold_i, "verdict": weighed[4], "error_held": null.error,
                          "error_with_impossible": e_with,
                          "description": S.impossible_words(hold_i, null.error, e_with)}
            odd = S.implausible(model, null) if weighed[4] is None else []
        held = None
        for hold in S.holdings(odd):
            report(0.5, "weighing the effects with " + ", ".join(o["label"] for o in hold)
                   + " held at the catalogue value")
            null_h = S.null_fit(model, exps, hyp, unc, comp_start, rps_start, max_nfev, report,
                                held={o["path"] for o in hold} | hyp.held)
            weighed_h = weigh(null_h)
            e_held = (weighed_h[2][weighed_h[4]].error_after.overall if weighed_h[4] is not None
                      else null_h.error)
            taken = S.takes_over(weighed_h, null)
            held = {"parameters": hold, "verdict": weighed_h[4], "error_held": e_held,
                    "error_recalibrated": null.error, "taken": taken,
                    "description": S.held_words(odd, hold, weighed_h[4] if taken else None,
                                                e_held, null.error)}
            if taken:
                null, weighed = null_h, weighed_h
                break
        score, lead, refits, ranking, verdict, message = weighed
        # an effect that is only a difference of base parameters within a catalogue error of
        # the user's values (a retract level 17 % above the extend level) is a recalibration
        folded = S.as_recalibration(model, verdict, refits, null)
        if folded is not None:
            null, words = folded
            for c in ranking:
                if c["effect"] == verdict:
                    c["as_recalibration"] = words
            verdict, message = None, NO_EFFECT + " (" + words + ")"
        f = findings(model, exps, verdict, message, ranking, refits, null, hyp, comp_start,
                     rps_start, known, lead, max_nfev, report)
        # a valve path passing far less than the catalogue: the components that could do it
        # and the test that separates them (never a leak or a line the records cannot see)
        paths = restricted_paths(f.recalibrate)
        if paths:
            f.remaining["restricted_paths"] = paths
            f.message += " " + " ".join(p["description"][0].upper() + p["description"][1:] + "."
                                        for p in paths)
        # a value the user knows, moved on the data's demand: what it cannot be told from
        words = S.demanded_words(model, hyp, f.recalibrate, f.refitted)
        if words:
            f.message += " " + words
        if impossible is not None:
            f.remaining["held_impossible"] = impossible
            f.message += " " + impossible["description"] + "."
        if held is not None:
            S.attach_held(f, held, odd, hold, model, null)
        report(1.0, "done")
        named = next((c for c in ranking if c["effect"] == verdict), None) if verdict else None
        if named is not None:
            # the verdict's own card warns (a rising error, a fit that did not converge): the
            # message says it beside the verdict, as the card's badges do (issue 39)
            warn = [b["why"] for b in card_badges(named, alpha / max(len(ranking), 1), DELTA_BIC)
                    if b["kind"] == "warning"]
            if warn:
                f.message += f" Caution on {verdict}: {'; '.join(warn)}."
        return Diagnosis(verdict, f.message, ranking,
                         score + [{"effect": e, "skipped": why} for e, why in
                                  {s["effect"]: s["reason"] for s in skipped}.items()],
                         null.comp, null.comp.windows, f.tests, null.comp.noise_floor, null.base,
                         [s.path for s in null.specs], refits,
                         recalibrate=f.recalibrate, refitted=f.refitted, model=f.model,
                         alternatives=f.alternatives, remaining=f.remaining,
                         identifiability=hyp.identifiability, error_start=comp_start,
                         dropped=f.dropped, initial_state=hyp.initial_state, hints=comp_start.hints,
                         given=model.to_dict(), known=list(known), cluster=runner.describe(),
                         alpha=alpha, recalibrate_effects=f.recalibrate_effects)


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
