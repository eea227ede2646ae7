"""The acceptance rules of a diagnosis: when is a refitted catalog effect named?

:data:`RULES` is the one list. A candidate is named when every rule passes, judged in
the order listed; a rule marked ``deferred`` costs refits (a pair refit, a fit per
experiment) and is judged only on a contender that passed every rule before it. The
verdict stage (:func:`pneucore.analysis.diagnosis.stages.verdict`) walks this list and
nothing else. The thresholds each rule reads are the module's constants.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

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
#: An error within this factor of the noise floor is at the floor (20 %: the scatter of the
#: floor's estimate from second differences on quantised records, measured 0.06-0.08 % on
#: the confusion table's base cases against a 0.06 % noise level)
AT_FLOOR = 1.2
#: Typical catalogue errors within which an effect that is only a difference of base
#: parameters (:attr:`pneucore.description.effects.Effect.base_change`: the quadrant effect) is a
#: recalibration of them, not the effect: one. Each catalogue value is somewhat off on its own
#: (a retract Coulomb level 17 % above the extend level, against a typical 30 % error of a
#: level, is a mis-set level); the effect is a difference no catalogue error reaches (x1.5)
BASE_CHANGE = 1.0
#: Held-out prediction is an alternative path to "significant" and "strong" (judged only on a
#: determined, material candidate that failed the effective-sample LR or BIC test)
HELD_OUT = True
#: Blocks in time each experiment is cut into for the held-out prediction: 4 leaves 3/4 of a
#: 30-point record (~22 points) to fit 1-3 parameters, and 4 folds to vote
HELD_OUT_FOLDS = 4
#: Folds on which the candidate must predict the held-out block better than the null: all
#: but one (a majority that one unlucky block cannot decide)
HELD_OUT_WINS = HELD_OUT_FOLDS - 1
#: Share of the null's held-out prediction energy (squared scaled error, all folds) the
#: candidate must remove: the same share as :data:`EXCESS_MATERIAL` asks of the fit itself
HELD_OUT_DROP = 0.2
# With two experiments or more, each is also left out in turn: the null and the candidate
# fitted on the others predict it (experiment_wins(n) of them, and the same HELD_OUT_DROP);
# either vote, blocks in time or experiments left out, shows a prediction


@dataclass(frozen=True)
class Rule:
    """One acceptance rule.

    Parameters
    ----------
    name : str
        Short name (the key of the candidate's ``rules`` record)
    reason : str
        Why the rule is there, in one line
    test : callable
        ``test(candidate, context) -> bool``; ``context`` is a :class:`Judging`
    deferred : bool
        The test costs refits: judged only once every rule before it passed
    """
    name: str
    reason: str
    test: Callable
    deferred: bool = False


@dataclass
class Judging:
    """What the rules read beside the candidate.

    Parameters
    ----------
    alpha : float
        Significance level before the Bonferroni split [-]
    n_tests : int
        Number of refitted candidates (the Bonferroni split)
    pair : callable
        ``pair(candidate) -> dict or None``: the candidate refitted with the next
        significant, material one (``excess_drop`` of the two together)
    consistency : callable
        ``consistency(candidate) -> dict``: its parameters fitted on each experiment alone
    held_out : callable
        ``held_out(candidate) -> dict``: its and the null's predictions of blocks held out of
        their fits (:func:`pneucore.analysis.diagnosis.evidence.held_out`); None: not judged
    """
    alpha: float
    n_tests: int
    pair: Callable = None
    consistency: Callable = None
    held_out: Callable = None


def _determined(c, ctx):
    return not c["undetermined"]


def _material(c, ctx):
    return c["relative_drop"] >= MATERIAL and c["excess_drop"] >= EXCESS_MATERIAL


def _predicts(c, ctx):
    """Held-out prediction (refits: judged once, only on a determined, material candidate)."""
    if not HELD_OUT or ctx.held_out is None or not (_determined(c, ctx) and _material(c, ctx)):
        return False
    if "held_out" not in c:
        c["held_out"] = ctx.held_out(c)
    h = c["held_out"]
    by = [what for what, vote in (("blocks in time", blocks_predict),
                                  ("experiments left out", experiments_predict)) if vote(h)]
    h["predicts_by"] = by
    h["predicts"] = bool(by)
    return h["predicts"]


def indistinct(c, best):
    """Can the records not tell candidate ``c`` from ``best``: its BIC within ``|DELTA_BIC|``
    of ``best``'s? Such a candidate, significant and material, is reported as an alternative
    to the verdict (:func:`pneucore.analysis.diagnosis.findings.findings`), so its held-out
    prediction is made even behind a named candidate."""
    return c["delta_bic"] - best["delta_bic"] < -DELTA_BIC


def complexity(name):
    """``(fitted parameters, parameters)`` of catalog effect ``name``: what a fit frees (the
    ``k`` of its BIC), then what it asserts about the rig (a line: length, bore, segments)."""
    from pneucore.description.effects import EFFECTS
    eff = EFFECTS[name]
    return len(eff.diagnosis_params), len(eff.parameters)


def simpler(c, named):
    """Does candidate ``c`` say less than ``named`` where the records cannot tell them apart
    (parsimony)? Its BIC within ``|DELTA_BIC|`` of ``named``'s, and it frees fewer
    parameters, or ``named`` becomes it in a limit of its own parameters
    (:attr:`pneucore.description.effects.Effect.reduces_to`: a line whose resistance the records do
    not see is a dead volume). The simpler one is named, the other an alternative."""
    from pneucore.description.effects import EFFECTS
    if c is named or abs(c["delta_bic"] - named["delta_bic"]) >= -DELTA_BIC:
        return False
    return (complexity(c["effect"])[0] < complexity(named["effect"])[0]
            or c["effect"] in EFFECTS[named["effect"]].reduces_to)


def unfitted_resemblances(name, score, refitted):
    """The effects named candidate ``name`` resembles
    (:attr:`pneucore.description.effects.Effect.resembles`) that the score pass ranked testable
    (``score``: its entries) but left out of the refits (``refitted``: their names). Before
    ``name`` is named they are fitted on the same records and every candidate is judged again:
    the score pass is linear at the probes' doses, where a valve's 5 ms switching delay
    explains more of a 2.5 m line's residual than the line's 1 m probe (both start each
    pressure change later; L / c is 7.3 ms), and it pushed the line out of the three refits.
    Only fitted do they differ (a pure shift of each command's edges against a line's slowed,
    attenuated rise), so only their fits can tell them apart. Asked only of a named candidate:
    a line in segments costs tens of seconds a refit."""
    from pneucore.description.effects import EFFECTS
    if name is None:
        return []
    testable = {s["effect"] for s in score if s["dof"] > 0}
    return [r for r in EFFECTS[name].resembles if r in testable and r not in refitted]


def blocks_predict(h):
    """The vote of the blocks in time of a held-out report
    (:func:`pneucore.analysis.diagnosis.evidence.held_out`)."""
    return bool(h["wins"] >= HELD_OUT_WINS and h["drop"] >= HELD_OUT_DROP)


def experiments_predict(h):
    """The vote of the experiments left out in turn of a held-out report (none: no vote)."""
    n = len(h.get("experiment_folds") or ())
    return bool(n >= 2 and h["experiment_wins"] >= experiment_wins(n)
                and h["experiment_drop"] >= HELD_OUT_DROP)


def experiment_wins(n):
    """Experiments left out that the candidate must predict better than the null, of ``n``:
    all but one (a majority that one unlucky record cannot decide) from 3 on, both of 2."""
    return n - 1 if n >= 3 else n


def _significant(c, ctx):
    return c["p_value"] < ctx.alpha / ctx.n_tests or _predicts(c, ctx)


def _strong(c, ctx):
    return c["delta_bic"] < DELTA_BIC or _predicts(c, ctx)


def _clears(c):
    """Most of what it removes, it removes from records it leaves at their noise floor."""
    cleared = sum(r["excess_share"] for r in c.get("experiments", ()) if r["cleared"])
    return c["excess_drop"] > 0 and cleared >= EXCESS_MAJOR * c["excess_drop"]


def _major(c, ctx):
    if c["excess_drop"] >= EXCESS_MAJOR or c["excess_drop_calibrated"] >= EXCESS_MAJOR:
        return True
    if _clears(c):
        return True
    c["with_next"] = ctx.pair(c)
    return bool(c["with_next"] and c["with_next"]["excess_drop"] >= EXCESS_MAJOR)


def _consistent(c, ctx):
    c["consistency"] = ctx.consistency(c)
    return bool(c["consistency"]["consistent"])


#: The acceptance rules, in the order they are judged (every one must pass)
RULES = (
    Rule("determined", "a strength at its fit bound, or within one standard error of off, or "
         "physically impossible, is no evidence of the effect", _determined),
    Rule("significant", "likelihood-ratio p-value below alpha / number of refitted candidates "
         "(counted on n / tau effective samples), or it predicts held-out data (below)",
         _significant),
    Rule("strong", f"delta BIC below {DELTA_BIC:g} (Kass & Raftery: very strong), or it "
         "predicts held-out data: a determined, material candidate refitted without each of "
         f"{HELD_OUT_FOLDS} blocks in time predicts the block better than the null on "
         f"{HELD_OUT_WINS} folds and removes {100 * HELD_OUT_DROP:g} % of the null's held-out "
         "error, or, fitted on all experiments but one, predicts the one left out better on "
         "all of them but one (both of two) and removes as much of the null's error there "
         "(smooth residuals make n / tau too few samples for the LR)", _strong),
    Rule("material", f"removes at least {100 * MATERIAL:g} % of the error and "
         f"{100 * EXCESS_MATERIAL:g} % of its excess over the noise floor", _material),
    Rule("major", f"removes at least {100 * EXCESS_MAJOR:g} % of the excess: alone, once the "
         "sensors' gains and offsets are removed, or with the next candidate (else a stand-in); "
         f"or at least {100 * EXCESS_MAJOR:g} % of what it removes lies in records it leaves at "
         "their noise floor (a short record that shows the effect beside a long one whose misfit "
         "no catalog effect reaches: what remains is outside the catalog, not this effect's)",
         _major, deferred=True),
    Rule("consistent", "its parameters fitted on each experiment alone agree (a stand-in takes "
         "whatever helps each)", _consistent, deferred=True),
)

#: The rules judged on every candidate before any is chosen (no refits)
CHEAP = tuple(r for r in RULES if not r.deferred)


def flags(c, ctx):
    """Judge the cheap rules on candidate ``c``; sets its ``significant``, ``strong`` and
    ``material`` fields (``significant`` includes ``determined``) and ``rules``."""
    c["rules"] = {r.name: bool(r.test(c, ctx)) for r in CHEAP}
    c["significant"] = c["rules"]["determined"] and c["rules"]["significant"]
    c["strong"] = c["rules"]["strong"]
    c["material"] = c["rules"]["material"]
    c["consistent"] = None
    c["named"] = False


def judge(c, ctx):
    """Is candidate ``c`` named? Every rule of :data:`RULES` in order, stopping at the first
    that fails; a deferred rule updates the candidate's fields (``material`` after ``major``,
    ``consistent`` after ``consistent``). Returns and sets ``named``; ``failed`` names the
    first rule that failed (None when named)."""
    c["failed"] = None
    for r in RULES:
        rec = c.setdefault("rules", {})
        if r.name not in rec:
            rec[r.name] = bool(r.test(c, ctx))
        ok = rec[r.name]
        if r.name == "major":
            c["material"] = ok
        elif r.name == "consistent":
            c["consistent"] = ok
        if not ok:
            c["failed"] = r.name
            break
    c["named"] = c["failed"] is None
    return c["named"]


# -- when a value the user knows may move ---------------------------------------------------

#: Part of a known value's sensitivity column orthogonal to the parameters fitted beside it
#: below which it is confounded with them: under 0.5, more than 3/4 of what it changes in
#: the records (its squared norm) is what they change together (|correlation| above 0.87),
#: so a freed value takes up whatever misfit their combination leaves (a load standing in
#: for a Coulomb level, or for an effect not yet named)
CONFOUNDED = 0.5


def _unconfounded(t, ctx):
    # collinearity is local (:func:`pneucore.analysis.hypotheses.freed_by_bounds`): where the
    # fit with the value held drove a parameter it is confounded with to a bound (a Coulomb
    # level at 0 standing in for 25 N of weight), their combination is cut off there
    return t["orthogonal"] >= CONFOUNDED or bool(t.get("at_bound"))


def _misfit(t, ctx):
    # with the known value held, the null already at the noise floor leaves the data nothing
    # to demand (an LR on 16,000 samples still finds a 0.03 N load "significant" there)
    return not t["error_held"] <= AT_FLOOR * t["floor"]


def _demand_material(t, ctx):
    # the share an effect must remove to be named (MATERIAL, EXCESS_MATERIAL): a known value
    # moves for a material part of the misfit, as an effect is named for one
    e0, e1, floor = t["error_held"], t["error_freed"], t["floor"]
    if not e0 > 0.0:
        return False
    excess = e0 - floor
    return (e0 - e1) / e0 >= MATERIAL and excess > 0.0 and (e0 - e1) / excess >= EXCESS_MATERIAL


def _possible(t, ctx):
    return not t.get("impossible")


def _lr_significant(t, ctx):
    return t["p_value"] < ctx.alpha


def _bic_strong(t, ctx):
    return t["delta_bic"] < DELTA_BIC


#: The rules a base parameter the user typically knows (a jack's load, an inclined jack's angle,
#: :attr:`pneucore.analysis.hypotheses.BaseHypothesis.user_knows`) must pass to move, in
#: order: the null is fitted with it held at the user's value; a deferred rule reads the
#: null refitted with it freed (``p_value``, ``delta_bic`` of freed against held)
DEMAND_RULES = (
    Rule("unconfounded", "what it changes is no combination of the parameters fitted beside "
         "it (a load against the two Coulomb levels), or the fit with it held drove one of them "
         "to a bound: otherwise the records cannot tell which moved", _unconfounded),
    Rule("misfit", f"with it held, the misfit is above the noise floor (more than {AT_FLOOR:g} "
         "times it): at the floor the data demand nothing", _misfit),
    Rule("possible", "freed, it keeps its declared direction (a load that would turn the "
         "declared load or the weight along the rod around is impossible, never significant)",
         _possible, deferred=True),
    Rule("significant", "likelihood-ratio p-value of it freed against it held below alpha "
         "(counted on n / tau effective samples)", _lr_significant, deferred=True),
    Rule("strong", f"delta BIC of it freed against it held below {DELTA_BIC:g}", _bic_strong,
         deferred=True),
    Rule("material", f"freed, it removes at least {100 * MATERIAL:g} % of the error and "
         f"{100 * EXCESS_MATERIAL:g} % of its excess over the noise floor (what an effect must "
         "remove to be named)", _demand_material, deferred=True),
)


def demanded(t, ctx, freed):
    """Do the data demand freeing a value the user knows? The rules of :data:`DEMAND_RULES`
    in order, stopping at the first that fails; ``freed(t)`` fills the fields the deferred
    rules read (a refit), called once before the first of them. Sets ``t["rules"]`` and
    ``t["failed"]`` (None when demanded)."""
    t["rules"], t["failed"] = {}, None
    for r in DEMAND_RULES:
        if r.deferred and "p_value" not in t:
            freed(t)
        t["rules"][r.name] = ok = bool(r.test(t, ctx))
        if not ok:
            t["failed"] = r.name
            break
    return t["failed"] is None
