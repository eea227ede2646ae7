"""What a diagnosis card shows beside its figures: badges that never contradict them (issue 39).

A candidate's rules (:mod:`pneucore.analysis.diagnosis.rules`) may pass on another road than
the figures the card shows: "significant" and "strong" are also given by held-out prediction
while the card shows the likelihood-ratio p-value and delta BIC, and a fit can lower its
weighted objective while the overall error (Eq. 25) it shows rises. :func:`card_badges` is the
one function that turns a ranked candidate into its badges, each one checked against the
figures on the card: the overall error before and after, the p-value, delta BIC and the fit's
convergence.
"""
from __future__ import annotations

import math

#: Badge names, in the order shown
ORDER = ("significant", "predicts held-out data", "strong", "material", "raises the error",
         "fit did not converge")


def _finite(x):
    return isinstance(x, (int, float)) and math.isfinite(x)


def card_badges(c, alpha, delta_bic):
    """The badges a ranked candidate shows, each consistent with the card's figures.

    Parameters
    ----------
    c : dict
        A ranking entry of a diagnosis (``error_before``, ``error_after_overall``,
        ``p_value``, ``delta_bic``, ``significant``, ``strong``, ``material``,
        ``fit_success``, ``held_out``) [-]
    alpha : float
        The p-value a candidate must be below to be significant (the diagnosis's alpha over
        the number of refitted candidates) [-]
    delta_bic : float
        The delta BIC a candidate must be below to be strong [-]

    Returns
    -------
    badges : list of dict
        ``{"name", "kind" ("evidence" or "warning"), "why"}`` in :data:`ORDER` [-]
    """
    e0, e1 = c.get("error_before"), c.get("error_after_overall")
    lowers = _finite(e0) and _finite(e1) and e1 < e0
    raises = _finite(e0) and _finite(e1) and e1 > e0
    converged = c.get("fit_success", True) is not False
    ok = lowers and converged
    p, bic = c.get("p_value"), c.get("delta_bic")
    held = c.get("held_out") or {}
    out = []
    if ok and c.get("significant") and _finite(p) and p < alpha:
        out.append({"name": "significant", "kind": "evidence",
                    "why": f"likelihood-ratio p = {p:.2g} below {alpha:.2g}"})
    if ok and held.get("predicts"):
        out.append({"name": "predicts held-out data", "kind": "evidence",
                    "why": "refitted without them, it predicts the " +
                           " and the ".join(held.get("predicts_by") or ["held-out data"]) +
                           " better than the model without it"})
    if ok and c.get("strong") and _finite(bic) and bic < delta_bic:
        out.append({"name": "strong", "kind": "evidence",
                    "why": f"delta BIC {bic:.1f} below {delta_bic:g}"})
    if lowers and c.get("material"):
        out.append({"name": "material", "kind": "evidence",
                    "why": f"overall error {100 * e0:.2f} % -> {100 * e1:.2f} %"})
    if raises:
        out.append({"name": "raises the error", "kind": "warning",
                    "why": f"overall error {100 * e0:.2f} % -> {100 * e1:.2f} %: no evidence "
                           "badge beside a rise"})
    if not converged:
        out.append({"name": "fit did not converge", "kind": "warning",
                    "why": str(c.get("fit_message") or "the optimiser stopped before converging")})
    return out


def change_words(before, after):
    """"lowers the overall error from A to B" as the figures have it (raises, leaves)."""
    verb = "lowers" if after < before else ("raises" if after > before else "leaves")
    if verb == "leaves":
        return f"leaves the overall error at {100 * before:.2f} %"
    return f"{verb} the overall error from {100 * before:.2f} % to {100 * after:.2f} %"


#: A dead volume above this many times its chamber's swept volume (piston area x stroke) is
#: flagged implausible [-]: 3, beyond the longest hose a rig puts between valve and jack
#: (tens of cm^3 on a 50 cm^3 chamber); issue 39 saw 556-999 cm^3 fitted on a 51 cm^3 one
DEAD_VOLUME_FACTOR = 3.0


def value_flag(model, path, value):
    """Why a value proposed for ``path`` is impossible or implausible, or ``(None, "")``.

    One check for every value a finding shows or applies (issue 39): physically impossible
    (against its declared direction, below 0 where it cannot be:
    :func:`pneucore.analysis.hypotheses.impossible`), outside its field's range (an angle
    beyond +-90 deg), implausible as a catalogue error
    (:func:`pneucore.analysis.hypotheses.plausibility`), or a dead volume several times its
    chamber (:data:`DEAD_VOLUME_FACTOR`).

    Parameters
    ----------
    model : Model
        The model as given (the declared values) [-]
    path : str
        Parameter path [-]
    value : float
        The value proposed, SI [unit of the path]

    Returns
    -------
    flag : tuple
        ``(severity, reason)``: severity ``"impossible"``, ``"implausible"`` or None [-]
    """
    from pneucore.analysis.hypotheses import impossible, plausibility
    from pneucore.physics.jack import ANGLE_MAX
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        return None, ""
    try:
        why = impossible(model, path, value)
    except Exception:   # noqa: BLE001 - a path the hypotheses do not read: no verdict from them
        why = ""
    if why:
        return "impossible", why
    if path == "jack.mounting_angle" and abs(value) > ANGLE_MAX:
        return "impossible", (f"mounting angle {value:.3g} deg outside the field's range "
                              f"(+-{ANGLE_MAX:g} deg)")
    j = model.jack
    for side, area in (("a", j.area_a), ("b", j.area_b)):
        if path == f"jack.dead_volume_{side}":
            swept = area * j.stroke
            if swept > 0 and value > DEAD_VOLUME_FACTOR * swept:
                return "implausible", (f"dead volume {1e6 * value:.3g} cm^3 on a "
                                       f"{1e6 * swept:.3g} cm^3 chamber {side.upper()} "
                                       f"(more than {DEAD_VOLUME_FACTOR:g} times it)")
    try:
        why = plausibility(model, path, value)
    except Exception:   # noqa: BLE001 - as above
        why = ""
    if why:
        return "implausible", why
    return None, ""


def flag_changes(model, changes, known=()):
    """``changes`` (:func:`pneucore.description.paths.model_changes`) each with ``flag`` (severity or
    None), ``why`` and ``known`` (a value the user declared known moves) added: what the page
    lists before "Apply", value by value.

    Parameters
    ----------
    model : Model
        The model as given [-]
    changes : list of dict
        The changes a finding would make [-]
    known : list of str
        Paths declared known [-]

    Returns
    -------
    changes : list of dict
        New dicts, in the same order [-]
    """
    out = []
    for c in changes:
        c = dict(c)
        sev, why = (value_flag(model, c["path"], c["after"]) if c.get("kind") == "changed"
                    else (None, ""))
        if c["path"] in known:
            sev, why = "known", f"declared known: {why}" if why else "declared known"
        c["flag"], c["why"] = sev, why
        out.append(c)
    return out
