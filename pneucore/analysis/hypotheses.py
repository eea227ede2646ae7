"""Mis-set base parameters as hypotheses, chosen from what the experiments can identify.

A model built from catalogue values has every base parameter somewhat off.
Before a missing physical effect can be named, the diagnosis must know what
recalibrating the base parameters alone explains. Which base parameters to
recalibrate is decided here, from the data, not by the user:

1. **Registry.** :data:`BASE_HYPOTHESES` lists the base parameters a test
   engineer actually gets wrong (friction level and viscous coefficient per
   direction, moving mass, heat coefficient, valve conductance of the supply
   and of the exhaust edges (``valve.ports.P-*.C``, ``valve.ports.*-R.C``),
   supply pressure, dead volumes, an undeclared load, an inclined jack's mounting
   angle), each with the relative error a catalogue value typically carries and fit
   bounds relative to the current value (an angle's in degrees: ``additive``).
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
   Collinearity is local: when the fit drives one of the confounding
   parameters to a bound, the confounded one is needed after all
   (:func:`freed_by_bounds`).
4. **Separating experiments.** For two hypotheses the records cannot tell
   apart, :func:`separating_experiments` simulates both on variations of the
   recorded tests (:func:`experiment_variants`) and names the one where their
   predictions differ most, against the noise.
5. **Residual analysis.** :func:`residual_signature` describes a remainder in
   words; :func:`calibrated_error` gives the error left once each signal's
   best transducer gain and offset are removed (what a catalog effect must
   explain beside a sensor calibration error).

A base parameter whose physics is a catalog effect of the same name
(``same_as_effect``: the base dead volumes and the ``dead_volume`` effect)
is left to that effect while the effect is a candidate, so that one physical
discrepancy is not offered twice.
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from pneucore.data.measurement import SIGNAL_UNITS, sensor_zero
from pneucore.physics.jack import ANGLE_MAX
from pneucore.description.paths import VALVE_GROUPS, ParameterSpec, get_value, set_values, unit_of
from pneucore.description.units import difference_shown

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
        Model path (:mod:`pneucore.description.paths`)
    label : str
        Human name, e.g. ``heat coefficient``
    typical : float
        Typical relative error of a catalogue value [-]
    lo, hi : float
        Fit bounds as multiples of the current value [-]
    span : float or callable
        Absolute half-range used when the current value is 0 (SI), or ``span(model)``
    applies : callable or None
        ``applies(model) -> bool``
    zero_typical : float
        Typical error as a fraction of ``span`` when the current value is 0 [-]
    same_as_effect : str or None
        Catalog effect carrying the same physics
    user_knows : callable or None
        ``user_knows(model) -> bool``: the user typically knows this value on ``model`` (a
        jack's load, an inclined jack's mounting angle); it is chosen after every other
        parameter and moves only when the data demand it
        (:data:`pneucore.analysis.diagnosis.rules.DEMAND_RULES`)
    separated_by : str
        The measurement that gives this value where the records cannot (said when it is held)
    additive : bool
        ``typical``, ``lo`` and ``hi`` are in the parameter's own unit, not relative to its
        value: a quantity for which 0 is no special value and an error is a difference, not
        a factor (a mounting angle: 5 deg off at 30 deg as at 60 deg)
    only_beside, not_beside : str or None
        Catalog effect beside which (a candidate, not yet in the model) this hypothesis is
        the only one offered for its physics, or is not offered: while the quadrant effect
        is a candidate, a friction level is recalibrated on both directions at once
        (``friction.*.fc0``), so that a level off by the same amount both ways is a
        recalibration before it is an effect, and the effect carries the difference alone
    """
    path: str
    label: str
    typical: float
    lo: float
    hi: float
    span: object = 0.0
    applies: Optional[Callable] = None
    same_as_effect: Optional[str] = None
    zero_typical: float = 0.1
    user_knows: Optional[Callable] = None
    separated_by: str = ""
    additive: bool = False
    only_beside: Optional[str] = None
    not_beside: Optional[str] = None


def _span(model, hyp):
    return hyp.span(model) if callable(hyp.span) else hyp.span


def _load_span(m):
    """Half-range of a load: half the jack's largest force, area A at supply above ambient [N]."""
    return 0.5 * m.jack.area_a * (m.supply.pressure - m.ambient.pressure)


def _user_sets(m):
    """A value its user sets up and knows: a jack's load (on a horizontal jack no weight acts
    along the rod, and on an inclined one the weight is the model's own, moving mass and
    mounting angle, :attr:`pneucore.description.model.Jack.gravity_force`, not part of the load) and
    its mounting angle (a machine frame's geometry)."""
    return True


def _inclined(m):
    """An inclined or vertical jack: the weight of the moving mass acts along the rod."""
    return m.jack.mounting_angle != 0.0


def _convective(m):
    return m.heat.model == "convective" and "heat_exchange" not in m.effects


#: The base parameters offered as hypotheses (one source: bounds and typical errors live here)
BASE_HYPOTHESES = {h.path: h for h in [
    # beside the quadrant effect (a candidate), a level is recalibrated on both directions at
    # once: a catalogue level off by the same factor both ways (the commonest catalogue error)
    # is a change the base parameters make, not a difference between the directions
    BaseHypothesis("friction.*.fc0", "Coulomb friction (both directions)", 0.3, 0.0, 5.0, 20.0,
                   only_beside="quadrant_friction"),
    BaseHypothesis("friction.extend.fc0", "Coulomb friction extending", 0.3, 0.0, 5.0, 20.0,
                   not_beside="quadrant_friction"),
    BaseHypothesis("friction.retract.fc0", "Coulomb friction retracting", 0.3, 0.0, 5.0, 20.0,
                   same_as_effect="quadrant_friction"),
    BaseHypothesis("friction.*.kv0", "viscous friction (both directions)", 0.3, 0.0, 5.0, 100.0,
                   only_beside="quadrant_friction"),
    BaseHypothesis("friction.extend.kv0", "viscous friction extending", 0.3, 0.0, 5.0, 100.0,
                   not_beside="quadrant_friction"),
    BaseHypothesis("friction.retract.kv0", "viscous friction retracting", 0.3, 0.0, 5.0, 100.0,
                   same_as_effect="quadrant_friction"),
    BaseHypothesis("jack.moving_mass", "moving mass", 0.15, 0.2, 5.0),
    BaseHypothesis("heat.coefficient", "heat coefficient", 0.5, 0.02, 10.0, applies=_convective),
    BaseHypothesis(f"valve.ports.{VALVE_GROUPS['supply']}.C", "valve conductance, supply edges (scale)",
                   0.15, 0.2, 5.0),
    BaseHypothesis(f"valve.ports.{VALVE_GROUPS['exhaust']}.C", "valve conductance, exhaust edges (scale)",
                   0.15, 0.2, 5.0),
    BaseHypothesis("supply.pressure", "supply pressure", 0.04, 0.7, 1.3),
    BaseHypothesis("jack.dead_volume_a", "dead volume A", 0.5, 0.05, 10.0,
                   same_as_effect="dead_volume"),
    BaseHypothesis("jack.dead_volume_b", "dead volume B", 0.5, 0.05, 10.0,
                   same_as_effect="dead_volume"),
    # a load the catalogue model leaves at 0 (a rod-end mass against gravity, a cable's drag):
    # fitted either sign within half the jack's force; typically small, 0.5 % of that range
    # (about 1 N on the paper's jack), below the typical error of a Coulomb level, so that a
    # mis-set friction is not taken for a load (a constant load is, while the piston moves,
    # a combination of the two Coulomb levels); its user knows it: it moves only when the
    # data demand it
    BaseHypothesis("jack.load_force", "load", 0.3, -5.0, 5.0, _load_span, zero_typical=0.005,
                   user_knows=_user_sets,
                   separated_by="no test of the moving jack separates them (while it moves, a "
                   "constant load shifts the two Coulomb levels, one up, one down); measure the "
                   "load at rest, with the chambers vented and a force gauge on the rod"),
    # the mounting angle of an inclined or vertical jack (a horizontal one is declared level,
    # and offered nothing): typically 5 deg off, an angle set by eye on a machine frame
    # (a spirit level or an inclinometer reads it to better than 1 deg); fitted anywhere in
    # the model's range; its user knows it: it moves only when the data demand it. Its weight
    # m g sin(angle) is a constant force along the rod, as a load is: the records never tell
    # the two apart, and while the piston moves they shift the two Coulomb levels
    BaseHypothesis("jack.mounting_angle", "mounting angle", 5.0, -ANGLE_MAX, ANGLE_MAX,
                   applies=_inclined, user_knows=_user_sets, additive=True,
                   separated_by="no test of this jack separates them (a wrong angle changes "
                   "the weight along the rod, m g sin(angle), a constant force as a load is, and "
                   "while the piston moves both shift the two Coulomb levels); measure the angle "
                   "with an inclinometer on the rod, or repeat a free test with a known mass "
                   "added to the rod: the weight along the rod changes by the mass times "
                   "g sin(angle), a load does not"),
]}


def label_of(path):
    """Human name of a base path (the path itself when it is not a registered hypothesis)."""
    h = BASE_HYPOTHESES.get(path)
    return h.label if h else path


def spec_for(model, hyp):
    """The :class:`ParameterSpec` that fits ``hyp`` from the current value of ``model``."""
    v = get_value(model, hyp.path)
    if hyp.additive:
        lo, hi = hyp.lo, hyp.hi
    elif v == 0.0:
        span = _span(model, hyp)
        lo, hi = -span if hyp.lo < 0 else 0.0, span
    else:
        lo, hi = sorted((v * hyp.lo, v * hyp.hi))
    return ParameterSpec(hyp.path, v, lo, hi, True, unit_of(hyp.path))


def typical_step(model, hyp):
    """One typical catalogue error of base parameter ``hyp`` at ``model``'s value, in its unit.

    ``hyp.typical`` itself for an additive parameter (an angle, a load); ``hyp.typical``
    times the value for a relative one; ``hyp.zero_typical`` of the parameter's span for
    a relative one whose value is 0.

    Parameters
    ----------
    model : Model
        The model whose value is read [-]
    hyp : BaseHypothesis
        The base parameter (:data:`BASE_HYPOTHESES`) [-]

    Returns
    -------
    step : float
        One typical error [the parameter's unit]
    """
    v = get_value(model, hyp.path)
    if hyp.additive:
        return hyp.typical
    return hyp.typical * abs(v) if v != 0.0 else hyp.zero_typical * _span(model, hyp)


def _signed_step(model, hyp):
    """The typical error as a move from the current value, into the fit's range (an angle of
    88 deg is moved down, not past the vertical)."""
    dv = typical_step(model, hyp)
    if hyp.additive and get_value(model, hyp.path) + dv > hyp.hi:
        return -dv
    return dv


#: Change of a recalibrated base parameter, in typical catalogue errors, beyond which it is
#: implausible as a catalogue error (a heat coefficient x10, a load of tens of newtons nobody
#: declared): 5 typical errors, where a Gaussian catalogue error has odds of 1 in 3.5 million;
#: counted on the logarithm of the factor for a nonzero value (a relative error is a factor,
#: ``ln(1 + typical)`` wide), on the span for a value of 0
IMPLAUSIBLE = 5.0


def plausibility(model, path, after, at_bound=False):
    """Why a recalibrated value is implausible as a catalogue error, or ``""``.

    Parameters
    ----------
    model : Model
        The model the value was recalibrated from (the catalogue)
    path : str
        Base parameter path
    after : float
        The recalibrated value (SI; a scale factor for valve tables)
    at_bound : bool
        The fit left it at a bound

    Returns
    -------
    reason : str
        Empty when plausible
    """
    h = BASE_HYPOTHESES.get(path)
    against = against_direction(model, path, after) if h is not None else ""
    if against:
        return against
    if at_bound:
        return "at its fit bound: the data push it further than the fit allows"
    if h is None:
        return ""
    z = typical_errors(model, path, after)
    if z > IMPLAUSIBLE:
        if h.additive:
            return f"{z:.0f} times the typical error of {h.label} ({h.typical:g} {unit_of(path)})"
        return f"{z:.0f} times the typical catalogue error of {h.label}"
    return ""


def typical_errors(model, path, after):
    """How many typical catalogue errors base parameter ``path`` moves from ``model``'s value
    to ``after`` [-] (:data:`BASE_HYPOTHESES`; ``inf`` for a path that is none of them).

    A relative catalogue error is a factor: x 1/2.8 is as far from the catalogue as x 2.8, so
    it is counted on the logarithm of the factor (``ln(1 + typical)`` wide: a valve's
    conductance at 0.35 of its catalogue value is 7 typical errors of 15 %); an additive one
    (an angle) in its unit; a relative one from a value of 0 on its span."""
    h = BASE_HYPOTHESES.get(path)
    if h is None:
        return math.inf
    v = get_value(model, path)
    if h.additive:
        return abs(after - v) / h.typical
    if v != 0.0 and after / v > 0.0:
        return abs(math.log(after / v)) / math.log1p(h.typical)
    sg = typical_step(model, h)
    return abs(after - v) / sg if sg > 0 else 0.0


def against_direction(model, path, after):
    """Why a recalibrated value points against its declared direction, or ``""``.

    A declared load, mass or level that changes sign is not a catalogue error but a force
    pointing the other way: physically impossible whatever its size (issue 28). For the
    load, the declared direction is that of the whole load of Eq. 17 as declared: the
    user's ``load_force`` plus the weight along the rod (``m g sin(angle)``, towards
    x = 0 with the rod up); a recalibrated load that turns it around (gravity pointing up)
    is impossible, as is one that turns the user's own ``load_force`` around. A load of 0
    on a horizontal jack declares no direction: either sign may be fitted.

    Parameters
    ----------
    model : Model
        The model the value was recalibrated from (the declared values)
    path : str
        Parameter path
    after : float
        The recalibrated value (SI; a scale factor for valve tables)

    Returns
    -------
    reason : str
        Empty when it keeps the declared direction

    Examples
    --------
    A 1.47 kg mass on a vertical jack (rod up) weighs 14.4 N towards x = 0; a load of
    -51 N fitted beside it would lift it (issue 28):

    >>> from pneucore import Model, model_preset
    >>> m = Model.from_dict(model_preset("paper-4way"))
    >>> m.jack.moving_mass, m.jack.mounting_angle = 1.47, 90.0
    >>> against_direction(m, "jack.load_force", -51.0)
    'load against its declared direction: 14.4 N towards x = 0 declared (the weight along the rod), -36.6 N fitted'
    >>> against_direction(m, "jack.load_force", -10.0)
    ''

    An angle has no direction of its own: declared at 2 deg, fitted at -1 deg, it moved:

    >>> m.jack.mounting_angle = 2.0
    >>> against_direction(m, "jack.mounting_angle", -1.0)
    ''
    """
    h = BASE_HYPOTHESES.get(path)
    if h is not None and h.additive:
        # an angle has no direction of its own: 2 deg fitted at -1 deg is a move, not a reversal
        return ""
    v = get_value(model, path)
    label = label_of(path)
    if v != 0.0 and after / v < 0.0:
        return (f"{label} changed sign ({v:g} -> {after:.3g} {unit_of(path)}): against its declared "
                f"direction")
    if path == "jack.load_force":
        grav = model.jack.gravity_force
        declared, fitted = v + grav, after + grav
        if declared != 0.0 and fitted / declared < 0.0:
            what = ("the weight along the rod" if v == 0.0 else
                    "the load given" if grav == 0.0 else "the load given and the weight along the rod")
            return (f"load against its declared direction: {declared:.3g} N towards x = 0 declared "
                    f"({what}), {fitted:.3g} N fitted")
    return ""


def impossible(model, path, after):
    """Why a recalibrated base value is physically impossible, or ``""``: against its declared
    direction (:func:`against_direction`), or below 0 where the quantity cannot be (a mass, a
    friction level, a conductance, a volume, a heat coefficient, an absolute pressure: every
    registered hypothesis fitted as a positive multiple of its value, ``lo >= 0``). Such a
    value never goes into a proposed model, however well it fits (issue 28); one that is only
    implausible (:func:`plausibility`) may.

    Parameters
    ----------
    model : Model
        The model the value was recalibrated from (the declared values)
    path : str
        Base parameter path
    after : float
        The recalibrated value (SI; a scale factor for valve tables)

    Returns
    -------
    reason : str
        Empty when the value is physically possible

    Examples
    --------
    >>> from pneucore import Model, model_preset
    >>> m = Model.from_dict(model_preset("paper-4way"))
    >>> impossible(m, "jack.moving_mass", -0.29)
    'moving mass changed sign (2 -> -0.29 kg): against its declared direction'
    >>> impossible(m, "jack.moving_mass", 0.29)
    ''
    >>> m.friction.extend.kv0 = 0.0      # declared 0: a level may be fitted to 0, not below
    >>> impossible(m, "friction.extend.kv0", -1.0)
    'viscous friction extending below 0 (-1 N s/m): physically impossible'
    """
    against = against_direction(model, path, after)
    if against:
        return against
    h = BASE_HYPOTHESES.get(path)
    if h is not None and not h.additive and h.lo >= 0.0 and after < 0.0:
        return f"{h.label} below 0 ({after:.3g} {unit_of(path)}".rstrip() + "): physically impossible"
    return ""


def first_against_direction(model, values):
    """The first of ``values`` (``{path: value or {"value": ...}}``, fitted base parameters)
    that points against its declared direction (:func:`against_direction`), in words, or
    ``""``; paths that are no registered base hypothesis are skipped."""
    for p, v in (values or {}).items():
        if p not in BASE_HYPOTHESES:
            continue
        why = against_direction(model, p, v["value"] if isinstance(v, dict) else v)
        if why:
            return why
    return ""


def prior_for(model, paths, scale=None):
    """The catalogue prior of the base hypotheses among ``paths``: least change from ``model``.

    A base parameter the experiments cannot resolve (a load against the two
    Coulomb levels while the piston moves, a per-direction friction level against
    the quadrant effect) is otherwise set by whatever the optimiser's path gives;
    with this prior it stays at the user's value, and moves only as far as the data
    demand. The prior of each registered hypothesis is Gaussian, centred on the
    value in ``model``, of standard deviation the typical catalogue error
    (:attr:`BaseHypothesis.typical`, or ``zero_typical * span`` for a value of 0:
    about 1 N for the load of the paper's jack).

    Parameters
    ----------
    model : Model
        The user's model (its values are the prior's centres)
    paths : iterable of str
        The fitted paths; those that are no registered hypothesis get no prior
    scale : dict or None
        ``{path: f}`` for valve scale factors fitted around a model whose tables were
        already multiplied by ``f`` (their centre is then ``1 / f``)

    Returns
    -------
    prior : dict
        ``{path: (centre, sigma)}`` (SI; valve scale factors [-])
    """
    out = {}
    for p in paths:
        h = BASE_HYPOTHESES.get(p)
        if h is None:
            continue
        c = get_value(model, p)
        sg = typical_step(model, h)
        if scale and p in scale:
            c, sg = c / scale[p], sg / scale[p]
        if sg > 0:
            out[p] = (c, sg)
    return out


def user_known(model, hyps):
    """The paths of ``hyps`` whose values the user typically knows on ``model``
    (:attr:`BaseHypothesis.user_knows`): held at the user's value until the data demand them."""
    return [h.path for h in hyps if h.user_knows is not None and h.user_knows(model)]


def offered(model, candidates=(), exclude=()):
    """Base hypotheses that apply to ``model`` (and are not carried by a candidate effect);
    ``exclude``: paths never offered (the values the user declared known)."""
    out = []
    for h in BASE_HYPOTHESES.values():
        if h.path in exclude:
            continue
        if h.applies is not None and not h.applies(model):
            continue
        # one physical discrepancy is not offered twice: the effect (a candidate, or already in
        # the model) carries it; offered beside the effect, the base parameter and the effect's
        # strength are confounded, and the effect is dropped as "indistinguishable from off"
        if h.same_as_effect and (h.same_as_effect in candidates
                                 or h.same_as_effect in model.effects):
            continue
        # a level of both directions is offered beside its effect (a candidate not yet in the
        # model) instead of the one direction's: the effect then carries the difference alone
        beside = (h.only_beside or h.not_beside)
        if beside:
            candidate = beside in candidates and beside not in model.effects
            if candidate != bool(h.only_beside):
                continue
        if get_value(model, h.path) == 0.0 and not _span(model, h):
            continue
        out.append(h)
    return out



def sensitivity_column(model, objective, r0, replay, h):
    """``(h, dv, column)``: hypothesis ``h`` moved by its step ``dv`` on ``model``, the change
    of ``objective``'s weighted residual from ``r0`` on its experiments (one column of
    :func:`identifiable`; the objective holds the experiments, sent to a cluster once)."""
    dv = _signed_step(model, h)
    mp = set_values(model, {h.path: get_value(model, h.path) + dv})
    return h, dv, objective.weighted([replay(mp, e) for e in objective.experiments]) - r0


def identifiable(model, experiments, objective, r0, hyps, replay, visible=VISIBLE,
                 collinear=COLLINEAR, last=()):
    """Choose the base hypotheses the experiments can identify.

    Parameters
    ----------
    model : Model
        The model around which sensitivities are taken
    experiments : list
        Prepared experiments
    objective : pneucore.analysis.calibrate.Objective
        Gives noise-weighted residuals (built on ``experiments``)
    r0 : ndarray
        Its weighted residual at ``model``
    hyps : list of BaseHypothesis
        Offered hypotheses
    replay : callable
        ``replay(model, experiment)``
    visible, collinear : float
        See :data:`VISIBLE`, :data:`COLLINEAR`
    last : iterable of str
        Paths judged after every other (a value the user typically knows, a jack's load:
        the parameters it is confounded with are chosen first, and it is
        ``not separable`` from them where only their combination is seen)

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
    # one simulation per hypothesis and experiment, in the fit's worker threads (the compiled
    # integrator runs outside the GIL), or one task each on the diagnosis's Dask cluster
    from pneucore.analysis.parallel import pmap
    if [id(e) for e in experiments] != [id(e) for e in objective.experiments]:
        raise ValueError("identifiable: the objective must be built on the experiments")
    for h, dv, col in pmap(sensitivity_column, hyps, (model, objective, r0, replay),
                           "sensitivities of the base hypotheses"):
        cols[h.path] = col / dv
        norms[h.path] = float(col @ col)
        steps[h.path] = abs(dv)
    last = set(last)
    order = sorted(hyps, key=lambda h: (h.path in last, -norms[h.path]))
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


def freed_by_bounds(report, values, tol=1e-3):
    """Hypotheses reported ``not separable`` whose confounders a fit drove to a bound.

    Collinearity is judged on sensitivities at the starting point: a column
    that is (nearly) a combination of chosen ones can be fitted through them,
    as long as the combination stays inside their bounds. When a fit ends with
    one of those parameters at its bound (within ``tol`` of its range), the
    combination was cut off and the confounded hypothesis carries what they
    cannot (a load of 40 N taken for Coulomb levels of +40 N and -40 N: the
    retracting level stops at 0). Such entries are marked ``identifiable`` in
    ``report`` (with a ``note``) and returned.

    Parameters
    ----------
    report : list of dict
        The identifiability report of :func:`identifiable` (edited in place)
    values : dict
        ``Calibration.values`` of the fit with the chosen hypotheses
    tol : float
        Distance to a bound, as a fraction of the range [-]

    Returns
    -------
    paths : list of str
    """
    out = []
    for h in report:
        if h.get("status") != "not separable":
            continue
        hit = []
        for p in h.get("with", []):
            v = values.get(p)
            if v is None or "min" not in v:
                continue
            rng = v["max"] - v["min"]
            if min(abs(v["value"] - v["min"]), abs(v["max"] - v["value"])) <= tol * rng:
                hit.append(p)
        if hit:
            h["status"] = "identifiable"
            h["note"] = (f"confounded with {', '.join(label_of(p) for p in h['with'])} in the "
                         f"small, but the fit drove {', '.join(label_of(p) for p in hit)} to a bound")
            out.append(h["path"])
    return out


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


#: Units in which a sensor finding is worded (SI -> unit, factor), per signal
SENSOR_WORDS = {s: difference_shown(SIGNAL_UNITS[s]) for s in ("p_a", "p_b", "x", "v", "T_a", "T_b")}
#: A sensor correction is named when it removes at least this share of the signal's misfit
#: energy in excess of nothing (its Eq. 25 error squared): half, the rule an effect must meet
SENSOR_SHARE = 0.5
#: Share a sensor correction must remove to be tried in a joint refit (a screen: the refit
#: decides, and a recalibration may have taken up part of the sensor's error)
SENSOR_SCREEN = 0.2


def sensor_findings(replays, ambient=0.0, share=None):
    """Sensor offsets and gains the residuals ask for, per signal: findings about the rig's
    sensors, not about the physics.

    For each signal, the residual (measured - simulated, pooled over the experiments) is
    fitted by an offset alone, a gain alone (about ``ambient`` for pressures: a gauge
    sensor's gain acts on the pressure above ambient) and both (least squares). The
    simplest correction that comes within 10 % of both's residual energy, and removes at
    least :data:`SENSOR_SHARE` of the signal's misfit, is reported.

    Parameters
    ----------
    replays : iterable of Replay
        Replayed experiments
    ambient : float
        Ambient pressure, the zero of a pressure sensor's gain [Pa]
    share : float or None
        Share of the misfit a correction must remove; None: :data:`SENSOR_SHARE` [-]

    Returns
    -------
    findings : list of dict
        ``signal``, ``kind`` (``offset``, ``gain`` or ``gain and offset``), ``offset``
        (signal's SI unit), ``gain`` (relative, [-]), ``error_before`` and ``error_after``
        (Eq. 25 [-]) and ``description`` in words
    """
    acc = {}
    for rp in replays:
        for s in rp.measured:
            m, g = np.asarray(rp.measured[s], float), np.asarray(rp.simulated[s], float)
            n = min(m.shape[0], g.shape[0])
            ok = np.isfinite(m[:n]) & np.isfinite(g[:n])
            a = acc.setdefault(s, ([], []))
            a[0].append(m[:n][ok])
            a[1].append(g[:n][ok])
    out = []
    for s, (ms, gs) in acc.items():
        m, g = np.concatenate(ms), np.concatenate(gs)
        den = float(m @ m)
        if m.size < 3 or den <= 0.0:
            continue
        zero = sensor_zero(s, ambient)
        d = m - g
        e0 = float(d @ d)
        if e0 <= 0.0:
            continue
        cols = {"offset": np.ones_like(g)[:, None], "gain": (g - zero)[:, None],
                "gain and offset": np.column_stack([np.ones_like(g), g - zero])}
        fits = {}
        for kind, A in cols.items():
            coef, *_ = np.linalg.lstsq(A, d, rcond=None)
            r = d - A @ coef
            fits[kind] = (float(r @ r), coef)
        best_e = fits["gain and offset"][0]
        kind = next(k for k in ("offset", "gain", "gain and offset")
                    if fits[k][0] <= 1.1 * best_e + 1e-300)
        e1, coef = fits[kind]
        if e1 > (1.0 - (SENSOR_SHARE if share is None else share)) * e0:
            continue
        off = float(coef[0]) if kind != "gain" else 0.0
        gain = float(coef[-1]) if kind != "offset" else 0.0
        unit, f = SENSOR_WORDS.get(s, ("", 1.0))
        words = []
        if kind != "gain":
            words.append(f"reads {abs(off) * f:.3g} {unit} {'more' if off > 0 else 'less'} than "
                         "simulated (the sensor's zero)")
        if kind != "offset":
            words.append(f"a gain {100 * gain:+.2g} % off")
        out.append({"signal": s, "kind": kind, "offset": off, "gain": gain,
                    "error_before": math.sqrt(e0 / den), "error_after": math.sqrt(e1 / den),
                    "description": f"sensor {s}: " + " and ".join(words) + (
                        f"; corrected, the error of {s} falls from {100 * math.sqrt(e0 / den):.2f} % "
                        f"to {100 * math.sqrt(e1 / den):.2f} %: a sensor finding, not physics (give it "
                        "as the column's offset or gain in the upload's mapping)")})
    return out


#: A declared (known) value is said to disagree with the data when a fit of it alone would move
#: it by more than this many typical catalogue errors (or 10 % of it for a parameter with no
#: registered typical error) ...
KNOWN_FAR = 3.0
#: ... and remove at least this share of the residual energy
KNOWN_SHARE = 0.05


def known_disagreements(model, experiments, known, replays, objective):
    """Declared values the data disagree with: findings, never moved.

    For each known parameter, one Gauss-Newton step of it alone on the weighted residual
    of ``replays`` (one finite-difference simulation per experiment) gives where the data
    would put it and how much of the residual energy that would remove (to first order).
    A step beyond :data:`KNOWN_FAR` typical errors that removes at least
    :data:`KNOWN_SHARE` of the residual is reported: "the data disagree with the declared
    moving mass".

    Parameters
    ----------
    model : Model
        The model the replays ran (the known values as declared)
    experiments : list of Experiment
        The experiments
    known : iterable of str
        Declared parameter paths
    replays : list of Replay
        ``replay(model, e)`` for each experiment
    objective : Objective
        Weighting of the residuals (:class:`pneucore.analysis.calibrate.Objective`)

    Returns
    -------
    findings : list of dict
        ``path``, ``label``, ``declared``, ``data_suggest`` (SI; a scale for valve
        tables), ``unit``, ``residual_share`` [-] and ``description``
    """
    from pneucore.analysis.compare import replay as _replay
    r = objective.weighted(replays)
    rr = float(r @ r)
    out = []
    for path in known:
        try:
            v = get_value(model, path)
        except Exception:   # noqa: BLE001 - a path that no longer reads (an effect dropped)
            continue
        h = BASE_HYPOTHESES.get(path)
        step = typical_step(model, h) if h is not None else 0.1 * abs(v)
        if not step > 0 or not rr > 0:
            continue
        dv = 0.1 * step
        try:
            mp = set_values(model, {path: v + dv})
            rh = objective.weighted([_replay(mp, e) for e in experiments])
        except Exception:   # noqa: BLE001 - a value the model refuses: no finding
            continue
        if rh.shape != r.shape:
            continue
        J = (rh - r) / dv
        jj = float(J @ J)
        if not jj > 0:
            continue
        delta = -float(J @ r) / jj
        share = float(J @ r) ** 2 / jj / rr
        if abs(delta) > KNOWN_FAR * step and share >= KNOWN_SHARE:
            from pneucore.analysis.shown import value_flag
            label = label_of(path)
            unit = unit_of(path)
            # a value the field cannot hold (an angle beyond +-90 deg) said as such (issue 39)
            sev, why = value_flag(model, path, v + delta)
            flag = f", {sev}: {why}" if sev == "impossible" else ""
            out.append({"path": path, "label": label, "declared": v, "data_suggest": v + delta,
                        "unit": unit, "residual_share": share, "flag": sev,
                        "description": (
                            f"the data disagree with the declared {label} ({v:.3g} {unit}): "
                            f"fitted alone it would move to about {v + delta:.3g} {unit}{flag} "
                            f"(removing {100 * share:.0f} % of the residual, to first order); "
                            "it is held as declared: check the value, or what the model lacks")})
    return out


# ------------------------------------------------------------------ which experiment separates

#: Separation (noise-weighted chi-square between two hypotheses' predictions) a suggested
#: experiment must reach: the same 10-sigma level as :data:`VISIBLE`
SEPARATES = VISIBLE


def experiment_variants(model, experiment):
    """Experiments one could record next: variations of a recorded one, each described in words.

    Each changes one condition that the hypotheses may depend on differently:
    the piston locked or free (friction, mass and load act only on a moving
    piston), the supply pressure (anything proportional to a pressure), chamber
    B's pressure on a 3/2 valve (constant in the records, so that a term in
    ``p_b`` looks like a constant), the other end of the stroke (dead volumes
    against chamber volumes), a known added load (a force against a pressure-
    or velocity-dependent term).

    Returns
    -------
    variants : list of tuple
        ``(key, words, model, scenario dict)``
    """
    m0 = experiment.model_for(model)
    scen = experiment.scenario_for(m0).to_dict()
    amb = m0.ambient.pressure
    ps = m0.supply.pressure
    stroke = m0.jack.stroke
    name = experiment.name or "recorded"
    out = []
    locked = bool(scen.get("locked"))
    s = dict(scen, locked=not locked)
    out.append(("free" if locked else "locked",
                f"the {name} test with the piston {'free' if locked else 'locked'}", m0, s))
    m = m0.copy()
    m.supply.pressure = amb + 0.6 * (ps - amb)
    out.append(("supply", f"the {name} test at 60 % of the supply pressure (gauge)", m, dict(scen)))
    if m0.valve.kind == "3/2" and m0.valve.b_chamber == "held":
        bcp = m0.valve.b_chamber_pressure if m0.valve.b_chamber_pressure is not None else 0.5 * ps
        m = m0.copy()
        m.valve.b_chamber_pressure = amb + 0.5 * (bcp - amb)
        out.append(("chamber-b", f"the {name} test with chamber B held at half its gauge pressure",
                    m, dict(scen)))
    x0 = float(scen.get("x0", 0.0))
    s = dict(scen, x0=min(max(stroke - x0, 0.02 * stroke), 0.98 * stroke))
    out.append(("position", f"the {name} test from the other end of the stroke", m0, s))
    if not locked:
        m = m0.copy()
        m.jack.load_force = m0.jack.load_force + 0.1 * m0.jack.area_a * (ps - amb)
        out.append(("load", f"the {name} test with a known load of 10 % of the jack's force added",
                    m, dict(scen)))
    return out


def confounded_twin(model, path, chosen, columns):
    """``model`` moved along the direction the records cannot see: ``path`` by its typical
    error, the ``chosen`` parameters by the least-squares compensation of its sensitivity
    column (``columns`` from :func:`identifiable`, per unit); None when not computable.

    The two models predict the records alike (to the collinearity's residual): the pair
    to hand to :func:`separating_experiments`.
    """
    if path not in columns or path not in BASE_HYPOTHESES:
        return None
    use = [p for p in chosen if p in columns]
    if not use:
        return None
    dv = typical_step(model, BASE_HYPOTHESES[path])
    A = np.column_stack([columns[p] for p in use])
    coef, *_ = np.linalg.lstsq(A, columns[path], rcond=None)
    vals = {path: get_value(model, path) + dv}
    for p, c in zip(use, coef):
        vals[p] = get_value(model, p) - float(c) * dv
    try:
        return set_values(model, vals)
    except Exception:   # noqa: BLE001 - a compensation outside a parameter's domain
        return None


def separating_experiments(model_a, model_b, experiments, top=3):
    """Which experiment would tell hypothesis A from hypothesis B?

    Both hypotheses, each fitted to the records (or moved along the direction
    the records cannot see), predict every variant of every recorded
    experiment (:func:`experiment_variants`); the separation of a variant is
    ``sum ((y_a - y_b) / sigma)^2`` over the signals recorded, ``sigma`` each
    signal's noise in the record (discrimination design: Box and Hill,
    *Technometrics* 9, 1967). The recorded experiments' own separation is
    given for reference: small, since the records could not tell A from B.

    Parameters
    ----------
    model_a, model_b : Model
        The two hypotheses, as models
    experiments : list of Experiment
        The recorded experiments
    top : int
        Number of suggestions returned

    Returns
    -------
    suggestions : list of dict
        ``{key, experiment, separation, recorded}``, best first, only those whose
        separation reaches :data:`SEPARATES` and exceeds the recorded one tenfold
    """
    from pneucore.analysis.calibrate import THREADS, Objective
    from pneucore.analysis.compare import replay
    from pneucore.simulate import simulate

    def sep(ya, yb, sig):
        tot = 0.0
        for s, sd in sig.items():
            a, b = ya.get(s), yb.get(s)
            if a is None or b is None:
                continue
            n = min(a.shape[0], b.shape[0])
            d = (a[:n] - b[:n]) / sd
            d = d[np.isfinite(d)]
            tot += float(d @ d)
        return tot

    jobs = []
    for e in experiments:
        sig = Objective(model_a, [e], []).sigma[0]
        jobs.append((e, sig, None, None, None))
        for key, words, _m, scen in experiment_variants(model_a, e):
            jobs.append((e, sig, key, words, scen))

    def run(job):
        e, sig, key, words, scen = job
        if key is None:
            ys = [replay(m, e) for m in (model_a, model_b)]
            return job, sep(ys[0].simulated, ys[1].simulated, sig)
        ys = []
        for m in (model_a, model_b):
            # the same variation applied to each hypothesis
            mv = next(v[2] for v in experiment_variants(m, e) if v[0] == key)
            try:
                res = simulate(mv, scen, raise_on_error=False)
            except Exception:   # noqa: BLE001 - a variant the model rejects is not offered
                return job, None
            ys.append({s: np.asarray(res.observed(s), float) for s in sig})
        return job, sep(ys[0], ys[1], sig)

    with ThreadPoolExecutor(THREADS) as pool:
        results = list(pool.map(run, jobs))
    recorded = {j[0].name: v for j, v in results if j[2] is None}
    out = []
    for (e, _sig, key, words, _s), v in results:
        if key is None or v is None:
            continue
        ref = recorded.get(e.name) or 0.0
        if v >= SEPARATES and v >= 10.0 * ref:
            out.append({"key": key, "experiment": words, "separation": v, "recorded": ref})
    out.sort(key=lambda d: -d["separation"])
    return out[:top]


# ------------------------------------------------------------------ initial state

#: Initial-state quantities an experiment may start from, with units
INITIAL_UNITS = {"p_a": "Pa", "p_b": "Pa", "x0": "m"}


def initial_unknowns(model, experiment):
    """Initial values neither recorded nor given: what the replay has to assume.

    A chamber pressure that is not recorded starts at ambient pressure unless
    the scenario's ``initial`` gives it; a position neither recorded nor given
    (``x0``) starts at the scenario's default. A rig left pressurised, or a
    piston left elsewhere, starts from another state (not in equilibrium with
    what the replay assumes): these are hypotheses like the base parameters.

    Returns
    -------
    keys : list of str
        Among ``p_a``, ``p_b`` (not with a 3/2 valve) and ``x0``
    """
    sigs = experiment.measurement.signals
    ini = experiment.scenario.get("initial") or {}
    out = []
    for key in ("p_a", "p_b"):
        if key == "p_b" and model.b_chamber_pressure is not None:
            continue
        if key not in sigs and ini.get(key) is None:
            out.append(key)
    if "x" not in sigs and "x0" not in experiment.scenario:
        out.append("x0")
    return out


def with_initial(experiment, values):
    """A copy of ``experiment`` whose scenario starts from ``values`` (``p_a``, ``p_b``, ``x0``)."""
    import dataclasses
    scen = dict(experiment.scenario)
    ini = dict(scen.get("initial") or {})
    for k, v in values.items():
        if k == "x0":
            scen["x0"] = float(v)
        else:
            ini[k] = float(v)
    scen["initial"] = ini
    e = dataclasses.replace(experiment, scenario=scen)
    e._first_cache = experiment._first_cache       # the record's own estimates stay valid
    return e


def _initial_bounds(model, key):
    amb, ps = model.ambient.pressure, model.supply.pressure
    if key == "x0":
        return 0.0, model.jack.stroke, 0.1 * model.jack.stroke
    return 0.5 * amb, max(ps, amb) * 1.05, 0.1 * (ps - amb)


def fit_initial_state(model, experiments, replay, max_nfev=25, visible=VISIBLE):
    """Fit the initial state each experiment does not record, where its records identify it.

    For every experiment and every unknown of :func:`initial_unknowns`, the
    value the replay assumes is moved by a tenth of its range (supply above
    ambient, or the stroke); the noise-weighted change of the recorded signals
    must be visible (``|s|^2 >= visible``, as for the base parameters) in the
    samples before the command first changes: what the initial state alone
    drives (afterwards the valve's flows take over, and the base parameters,
    fitted later, matter more). The visible ones are fitted on those samples
    (bounded least squares from the best point of a coarse grid, since static
    friction makes the misfit flat near a resting state; the base parameters
    as given), and kept when they
    move by more than three standard errors and by more than 2 % of their
    range.

    Returns
    -------
    experiments : list
        The experiments, those with a fitted initial state replaced by copies
        starting from it (:func:`with_initial`)
    found : list of dict
        ``{experiment, path, label, before, after, stderr, unit}`` per kept value
    report : list of dict
        ``{experiment, path, status}`` per unknown (``identifiable`` / ``not visible``)
    """
    from scipy.optimize import least_squares

    from pneucore.analysis.calibrate import Objective
    out_exps, found, report = [], [], []
    for e in experiments:
        keys = initial_unknowns(model, e)
        if not keys:
            out_exps.append(e)
            continue
        m_e = e.model_for(model)
        scen = e.scenario_for(m_e)
        assumed = {k: (scen.x0 if k == "x0" else getattr(scen.initial, k)) for k in keys}
        for k in keys:
            if assumed[k] is None:
                assumed[k] = model.ambient.pressure
        obj = Objective(model, [e], [])
        # the record before the command first changes: what the initial state alone drives
        # (afterwards the valve's flows take over and the base parameters matter more)
        u = e.command_samples
        ch = np.flatnonzero(np.diff(u) != 0)
        n_quiet = int(ch[0]) + 1 if ch.size else u.shape[0]
        sig = obj.sigma[0]

        def weighted(ex):
            rp = replay(model, ex)
            parts = []
            for s_ in rp.measured:
                n = min(n_quiet, rp.simulated[s_].shape[0])
                d = (rp.simulated[s_][:n] - rp.measured[s_][:n]) / sig[s_]
                parts.append(np.where(np.isfinite(d), d, 0.0))
            return np.concatenate(parts) if parts else np.zeros(0)

        r0 = weighted(e)
        vis = []
        for k in keys:
            lo, hi, step = _initial_bounds(model, k)
            v1 = assumed[k] + step if assumed[k] + step <= hi else assumed[k] - step
            col = weighted(with_initial(e, {k: v1})) - r0
            ok = float(col @ col) >= visible
            report.append({"experiment": e.name, "path": f"initial.{k}",
                           "status": "identifiable" if ok else "not visible"})
            if ok:
                vis.append(k)
        if not vis or r0.shape[0] <= len(vis):
            out_exps.append(e)
            continue
        bounds = [_initial_bounds(model, k) for k in vis]
        scale = np.array([b[1] - b[0] for b in bounds])
        lo = np.array([b[0] for b in bounds]) / scale
        hi = np.array([b[1] for b in bounds]) / scale

        def fun(z):
            vals = dict(zip(vis, z * scale))
            return weighted(with_initial(e, vals))

        # a piston held by static friction makes the misfit flat around the assumed state
        # (a small change moves nothing): start from the best of a coarse grid over the
        # bounds (5 levels per unknown, the assumed state included)
        import itertools
        z_as = np.clip(np.array([assumed[k] for k in vis]) / scale, lo, hi)
        grid = [np.linspace(a, b, 5) for a, b in zip(lo, hi)]
        starts = [z_as] + [np.array(z) for z in itertools.product(*grid)]
        cost = [float(np.sum(fun(z) ** 2)) for z in starts]
        z0 = starts[int(np.argmin(cost))]
        sol = least_squares(fun, z0, bounds=(lo, hi), max_nfev=max_nfev, x_scale=1.0,
                            diff_step=1e-3)
        if float(sol.fun @ sol.fun) > cost[0]:
            out_exps.append(e)     # no better than what the replay assumes
            continue
        J = sol.jac
        n, k_ = sol.fun.shape[0], len(vis)
        s2 = float(sol.fun @ sol.fun) / max(n - k_, 1)
        try:
            cov = np.linalg.inv(J.T @ J) * s2
            se = np.sqrt(np.clip(np.diag(cov), 0, None)) * scale
        except np.linalg.LinAlgError:
            se = np.full(k_, np.inf)
        keep = {}
        for i, k in enumerate(vis):
            after = float(sol.x[i] * scale[i])
            d = abs(after - assumed[k])
            if d > 3.0 * se[i] and d > 0.02 * scale[i]:
                keep[k] = after
                found.append({"experiment": e.name, "path": f"initial.{k}",
                              "label": f"initial {'position' if k == 'x0' else 'pressure ' + k[-1].upper()}"
                                       f" of {e.name}",
                              "before": float(assumed[k]), "after": after, "stderr": float(se[i]),
                              "unit": INITIAL_UNITS[k]})
        out_exps.append(with_initial(e, keep) if keep else e)
    return out_exps, found, report
