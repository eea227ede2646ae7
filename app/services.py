"""Helpers the routers share: a simulation result as the API's JSON, a request's time limit.

Routers import what they share from here, never from one another.
"""
from __future__ import annotations

import time

from pneucore.validation import FieldError

#: Series returned by default (everything the page plots)
DEFAULT_SERIES = ("t", "u", "p_a", "p_b", "T_a", "T_b", "m_a", "m_b", "x", "v", "a", "q_a", "q_b",
                  "friction", "mode", "u_eff", "p_supply", "q_supply", "net_force")


def result_json(res, series):
    """A :class:`~pneucore.result.SimulationResult` as the body of POST /api/simulate.

    Parameters
    ----------
    res : SimulationResult
        A completed simulation
    series : list of str or None
        Series to return (None = :data:`DEFAULT_SERIES`); an unknown name or an
        empty list is a :class:`~pneucore.validation.FieldError` on ``series``
    """
    names = [s for s in (series or DEFAULT_SERIES) if s in res.series]
    if series is not None and len(series) == 0:
        raise FieldError("series", "give at least one series name, or omit the field for the default set")
    if series:
        unknown = [s for s in series if s not in res.series]
        if unknown:
            raise FieldError("series", f"unknown series {unknown}; available: {sorted(res.series)}")
    return res.to_dict(series=names, arrays=True, inputs=False)


def deadline_progress(limits, what, job):
    """Progress callback that stops a synchronous analysis past the request time limit.

    Parameters
    ----------
    limits : app.config.Limits
        Its ``request_time_limit`` [s] applies
    what : str
        The analysis, in words, for the message
    job : str
        The job kind the message points to (``POST /api/jobs/<job>``)
    """
    from .jobs import JobTimeout
    t0 = time.time()

    def check(fraction, step):
        if time.time() - t0 > limits.request_time_limit:
            raise JobTimeout(f"the {what} exceeded the request time limit of "
                             f"{limits.request_time_limit:g} s (at step: {step}); use POST /api/jobs/{job}")
    return check
