"""Refinement history: each model version with its errors, so the error is seen falling.

``refine(model, experiments)`` runs the loop the tool is built around:
compare, diagnose, add the named effect with its fitted parameters, and
again, until no catalog effect explains what remains.
"""
from __future__ import annotations

import copy
import math
import datetime as _dt
from dataclasses import dataclass, field

from pneucore.analysis.compare import compare
from pneucore.analysis.diagnose import check_request, diagnose
from pneucore.analysis import parallel as P
from pneucore.data.experiment import as_experiments
from pneucore.description.model import Model


@dataclass
class ModelVersion:
    """One step of the refinement.

    Parameters
    ----------
    version : int
        0 for the starting model
    label : str
        e.g. ``base`` or ``+ piston_leakage``
    model : dict
        Model JSON
    errors : dict
        Eq. 25 error per signal [-]
    overall : float
        RMS of the per-signal errors [-]
    added : str or None
        Effect added at this step
    params : dict
        Its fitted parameters (value, stderr, unit)
    note : str
        Free text (verdict message)
    created : str
        ISO 8601 time
    """
    version: int
    label: str
    model: dict
    errors: dict
    overall: float
    added: object = None
    params: dict = field(default_factory=dict)
    note: str = ""
    created: str = ""
    recalibrated: list = field(default_factory=list)

    def to_dict(self):
        return copy.deepcopy(self.__dict__)


class RefinementHistory:
    """The list of model versions of one refinement session."""

    def __init__(self, versions=None):
        self.versions = list(versions or [])

    def add(self, model, comparison, added=None, params=None, note="", recalibrated=None,
            label=None):
        """Record a model version with its comparison; returns the :class:`ModelVersion`.

        The first version is labelled ``base``; a later one ``+ <effect>`` when it adds an
        effect, ``recalibrated: <parameters>`` when it only corrects base parameters, and
        ``version <n>`` otherwise (a model edited by hand).

        Parameters
        ----------
        model : Model or dict
            The model of this version (a dict is validated)
        comparison : Comparison, tuple or None
            Its errors: a :class:`pneucore.analysis.compare.Comparison` (or any object with
            ``errors`` and ``overall``), the pair ``(errors, overall)`` of
            :func:`pneucore.analysis.compare.errors`, or None when there is nothing to compare
            with (no errors, overall None)
        added : str or None
            Effect added at this step
        params : dict or None
            Its fitted parameters
        note : str
            Free text
        recalibrated : list or None
            The mis-set base parameters corrected at this step
            (``[{path, label, before, after, stderr, unit}]``)
        label : str or None
            The version's label, in place of the one derived from the above
        """
        model = model if isinstance(model, Model) else Model.from_dict(model)
        if comparison is None:
            errors, overall = {}, None
        elif isinstance(comparison, tuple):
            errors, overall = comparison
        else:
            errors, overall = comparison.errors, comparison.overall
        if label:
            pass
        elif not self.versions:
            label = "base"
        elif added:
            label = f"+ {added}"
        elif recalibrated:
            label = "recalibrated: " + ", ".join(r.get("label", r["path"]) for r in recalibrated)
        else:
            label = f"version {len(self.versions)}"
        v = ModelVersion(len(self.versions), label,
                         model.to_dict(), dict(errors), overall, added,
                         params or {}, note, _dt.datetime.now(_dt.timezone.utc).isoformat(),
                         list(recalibrated or []))
        self.versions.append(v)
        return v

    @property
    def latest(self):
        return self.versions[-1] if self.versions else None

    def overall_errors(self):
        """``(labels, overall errors)`` for a chart of the error falling."""
        return [v.label for v in self.versions], [v.overall for v in self.versions]

    def to_dict(self):
        return {"versions": [v.to_dict() for v in self.versions]}

    @classmethod
    def from_dict(cls, d):
        return cls([ModelVersion(**v) for v in d.get("versions", [])])


def from_initial_state(experiments, found):
    """The experiments started from the initial state a diagnosis fitted.

    Parameters
    ----------
    experiments : list of Experiment
        The experiments the diagnosis ran on
    found : list of dict
        :attr:`pneucore.analysis.diagnose.Diagnosis.initial_state`:
        ``{experiment, path, after, ...}`` with ``path`` ``initial.p_a``, ``initial.p_b`` or
        ``initial.x0`` [Pa or m]

    Returns
    -------
    experiments : list of Experiment
        Copies of those with a fitted initial state, starting from it; the others as given
    """
    from pneucore.analysis.hypotheses import with_initial
    by_name = {}
    for r in found:
        by_name.setdefault(r["experiment"], {})[r["path"].split(".", 1)[1]] = r["after"]
    return [with_initial(e, by_name[e.name]) if e.name in by_name else e for e in experiments]


#: Relative rise of the Eq. 25 error above which a round's proposed model is not taken: none
#: (issue 39: refine never returns a model worse than its start on its own objective, the
#: overall error on the experiments as they stand; a proposal that raises it is said and left)
WORSE_TOLERANCE = 0.0


def refine(model, experiments, max_rounds=4, uncertain=(), history=None, progress=None,
           validated=False, known=(), scheduler=None, scheduler_timeout=None):
    """Stepwise to the noise floor: diagnose, apply the findings, repeat.

    Each round recalibrates the base parameters the experiments identify and
    adds the best catalog effect when one explains what recalibration does
    not (both refitted jointly; an effect added earlier whose strength has
    become indistinguishable from zero is dropped, see
    :func:`pneucore.analysis.diagnose.diagnose`). The loop stops when the error is at
    the noise floor, when nothing material remains to name, or after
    ``max_rounds`` effects.

    Parameters
    ----------
    model : Model or dict
        Starting model
    experiments : list
        Experiments
    max_rounds : int
        Most effects to add
    uncertain : list
        Base parameter paths refitted along; given, they replace the automatic
        choice (see :func:`pneucore.analysis.diagnose.diagnose`)
    history : RefinementHistory or None
        Continue an existing history
    known : list of str
        Parameter paths the user declared (never fitted in any round: the final model holds
        them as given; see :func:`pneucore.analysis.diagnose.diagnose`)
    validated : bool
        ``uncertain`` and ``known`` were already checked on ``model`` by
        :func:`pneucore.analysis.diagnose.check_request` (the API does at its boundary); otherwise
        it is checked once here, before the first round, and not again in each round
    scheduler : str, distributed.Client, cluster or None
        Where each round's candidate refits run (see
        :func:`pneucore.analysis.diagnose.diagnose`); reached once for all the rounds
    scheduler_timeout : float or None
        Time to reach the scheduler (None = the studies' default) [s]

    Returns
    -------
    model : Model
        The refined model
    history : RefinementHistory
        One version per step, with errors; a step that only
        recalibrates is labelled ``recalibrated: ...``
    diagnoses : list
        The diagnosis of each round (the last one has verdict None unless
        ``max_rounds`` was reached or the floor was reached)
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    if not validated:
        check_request(model, None, uncertain, known)
    exps = as_experiments(experiments, model.ambient.pressure)
    history = history or RefinementHistory()
    if not history.versions:
        history.add(model, compare(model, exps))
    # one runner for every round: the cluster reached and probed once, and, once lost, not
    # tried again by the next round
    with P.running(scheduler, scheduler_timeout, progress) as runner:
        diagnoses = []
        dropped_in = {}        # effect -> round in which the data dropped it
        for k in range(max_rounds):
            d = diagnose(model, exps, uncertain=uncertain, progress=progress, validated=True,
                         known=known, scheduler=runner)
            diagnoses.append(d)
            # the current version on the experiments as they stand: what a proposal must beat
            comp_prev = compare(model, exps)
            new_exps = exps
            if d.initial_state:
                # the records imply an initial state their context does not declare (a rig left
                # pressurised): later rounds, and this version's errors, start from it, if it
                # does not raise the error (it is part of the round's proposal)
                new_exps = from_initial_state(exps, d.initial_state)
            # a round that names nothing and moves no parameter ends the loop as it stands;
            # one that moves a parameter (base, or of an effect already in the model) is taken
            # first when it does not raise the error, and then ends it (verdict None, below)
            moved = list(d.recalibrate) + list(getattr(d, "recalibrate_effects", []) or [])
            if d.verdict is None and not moved:
                if d.initial_state:
                    comp_init = compare(model, new_exps)
                    if _worse(comp_init, comp_prev):
                        d.message += _not_applied(comp_init, comp_prev, "initial state")
                        break
                    exps = new_exps
                    history.add(model, comp_init, note=d.message,
                                label="initial state: " + ", ".join(r.get("label", r["path"])
                                                                    for r in d.initial_state))
                break
            if d.verdict in dropped_in:
                d.message += (f" {d.verdict} is added back: round {dropped_in[d.verdict]} dropped it "
                              f"as indistinguishable from off, these records ask for it again.")
            for name in d.dropped:
                dropped_in[name] = k + 1
            comp_new = compare(d.model, new_exps)
            if _worse(comp_new, comp_prev):
                # never a version worse than the one before: the round's proposal is not taken
                d.message += _not_applied(comp_new, comp_prev, "proposed model")
                break
            exps = new_exps
            model = d.model.copy()
            params = d.ranking[0]["params"] if d.verdict else {}
            history.add(model, comp_new, d.verdict, params, d.message, moved)
            if d.verdict is None or d.remaining.get("at_floor"):
                break
    return model, history, diagnoses


def _worse(comp_new, comp_prev):
    """Whether a proposal's comparison is worse than the current version's (a proposal whose
    error cannot be computed is worse than one whose error can)."""
    a, b = comp_new.overall, comp_prev.overall
    if a is None or not math.isfinite(a):
        return b is not None and math.isfinite(b)
    return b is not None and math.isfinite(b) and a > (1.0 + WORSE_TOLERANCE) * b


def _not_applied(comp_new, comp_prev, what):
    a = "not computable" if comp_new.overall is None else f"{100 * comp_new.overall:.2f} %"
    return (f" Not applied: the {what}'s overall error ({a}) is above the current version's "
            f"({100 * comp_prev.overall:.2f} %) on the same experiments; refine keeps the better.")


def refinement_answer(final, history, diagnoses):
    """The answer of a refinement as plain JSON (POST /api/refine and ``pneucore refine``).

    Parameters
    ----------
    final : Model
        The refined model :func:`refine` returns [-]
    history : RefinementHistory
        Its versions [-]
    diagnoses : list of Diagnosis
        Each round's diagnosis [-]

    Returns
    -------
    answer : dict
        ``model`` (the refined model), ``versions``, ``diagnoses``, ``message`` (the last
        round's) and ``at_floor`` [-]
    """
    last = diagnoses[-1] if diagnoses else None
    return {"model": final.to_dict(), "versions": history.to_dict()["versions"],
            "diagnoses": [d.to_dict() for d in diagnoses],
            "message": last.message if last is not None else "",
            "at_floor": bool(last is not None and last.remaining.get("at_floor"))}
