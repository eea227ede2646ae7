"""The sizing work behind POST /api/sizing and POST /api/jobs/sizing (see :mod:`pneucore.sizing`).

Kept beside :mod:`app.services` (the routers take their other work from there): a request is
checked whole before any work (:func:`check_sizing`: a 422 naming the field and its unit),
then sized on the request's limits (:func:`run_sizing`).
"""
from __future__ import annotations

from pneucore.sizing import check, load_series, size
from pneucore.sizing.series import CYLINDER_ENERGIES
from pneucore.sizing.search import run_samples_bound
from pneucore.description.validation import FieldError

from .analysis_memory import admitted, check_alone, sizing_estimate
from .deps import prefixed


def check_sizing(req, limits):
    """Everything a sizing request can get wrong, checked before any work.

    Parameters
    ----------
    req : app.sizing_schemas.SizingRequest
        The request
    limits : app.config.Limits
        Its ``max_duration`` bounds each simulated run [s]

    Returns
    -------
    checked : tuple
        What :func:`pneucore.sizing.check` returns
    """
    requirement, choices = req.plain()
    try:
        return check(requirement, choices, max_duration=limits.max_duration)
    except FieldError as exc:
        # the paths pneucore names (requirement.stroke, choices.bore[2]) are the request's
        raise prefixed(exc, "") from None


def sizing_memory(checked, limits):
    """A sizing's memory estimate [bytes] (:func:`app.analysis_memory.sizing_estimate`:
    ``max_workers`` threads each simulating one run); a 422 naming ``requirement`` when it
    alone exceeds ``limits.analysis_memory_budget``."""
    samples = run_samples_bound(checked[0])
    estimate = sizing_estimate(samples, limits.max_workers)
    check_alone(estimate, limits.analysis_memory_budget, "requirement",
                f"a sizing on {limits.max_workers} threads, runs of up to {samples:,} samples,")
    return estimate


def run_sizing(req, limits, progress=None, checked=None):
    """Size the request's drive (the answer of :func:`pneucore.sizing.size`).

    Parameters
    ----------
    req : app.sizing_schemas.SizingRequest
        The request
    limits : app.config.Limits
        ``max_workers`` threads evaluate families at once
    progress : callable or None
        ``progress(fraction, step)``; may raise to stop
    checked : tuple or None
        What :func:`check_sizing` returned for this request
    """
    checked = checked if checked is not None else check_sizing(req, limits)
    requirement, choices = req.plain()
    # held on a synchronous request's budget (503 when it does not fit); a job held it before
    with admitted(sizing_memory(checked, limits), "sizing"):
        return size(requirement, choices, workers=limits.max_workers, progress=progress,
                    checked=checked)


def sizing_series():
    """GET /api/sizing/series: the shipped series a sizing's choices may name, each with its
    label, source and members (sizes in SI: bore and rod [m], C [m^3/(s Pa)], tube diameters
    [m])."""
    s = load_series()
    out = {kind: {name: {"label": v.get("label", ""), "source": v.get("source", ""),
                         "members": [m.get("name") for m in v.get("members", [])]}
                  for name, v in s[kind].items()}
           for kind in ("cylinders", "valves", "tubes")}
    # each cylinder member's catalogue energies where its series gives them [J]
    for name, v in s["cylinders"].items():
        for key, rec in CYLINDER_ENERGIES.items():
            figures = {m["name"]: m[key] for m in v["members"] if key in m}
            out["cylinders"][name][rec] = figures or None
    return out
