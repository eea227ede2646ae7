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
