"""A servo actuator for the control examples and tests: the paper's jack (Table 1) with a
critically lapped proportional 4/2 valve (no overlap: the flow gain is that of the opening
from u = 0, where the paper's valve has its 15 % overlap, Fig. 2) and, by default, no Coulomb
friction. Catalogue-typical conductance 1e-8 m^3/(s Pa) at full opening, as paper-4way."""
from __future__ import annotations

from pneucore.description.presets import model_preset

_C4 = 1.0e-8


def servo_model(coulomb=False, heat="isothermal"):
    """The servo actuator as a plain model dict.

    Parameters
    ----------
    coulomb : bool
        Keep paper-4way's Coulomb friction (8-10 N plus its pressure terms, Eq. 19-20); else
        only the viscous part [-]
    heat : str
        Heat model [-]

    Returns
    -------
    model : dict
        A model for :func:`pneucore.simulate` or the API
    """
    m = model_preset("paper-4way")
    m["name"] = "servo-4way"
    m["description"] = "paper jack, critically lapped proportional 4/2 valve"
    supply = {"opening": [0.0, 1.0], "C": [0.0, _C4], "b": [0.3, 0.3]}
    exhaust = {"opening": [-1.0, 0.0], "C": [_C4, 0.0], "b": [0.3, 0.3]}
    m["valve"]["ports"] = {"P-A": supply, "A-R": exhaust,
                           "P-B": {"opening": [-1.0, 0.0], "C": [_C4, 0.0], "b": [0.3, 0.3]},
                           "B-R": {"opening": [0.0, 1.0], "C": [0.0, _C4], "b": [0.3, 0.3]}}
    m["heat"] = {"model": heat}
    if not coulomb:
        for side in ("extend", "retract"):
            for k in ("fc0", "fc_a", "fc_b"):
                m["friction"][side][k] = 0.0
    return m
