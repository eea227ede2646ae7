"""The control endpoints' work (issue 42): linearisation, and the closed-loop simulations that a
scenario with a ``controller`` asks POST /api/simulate for. Re-exported by :mod:`app.services`
(the routers take their work from there)."""
from __future__ import annotations

from pneucore.control.linearize import linearize, to_json
from pneucore.spec.validation import FieldError

from .deps import parse_model


def linearize_answer(req):
    """POST /api/linearize: the model checked, linearised at the operating point.

    Parameters
    ----------
    req : app.control_schemas.LinearizeRequest
        The request

    Returns
    -------
    out : dict
        :func:`pneucore.control.linearize.to_json` of the result
    """
    model = parse_model(req.model)
    op = req.operating_point
    freq = req.frequencies
    if freq is not None:
        bad = [i for i, f in enumerate(freq) if not (f == f and 0.0 < f < 1e7)]
        if bad:
            raise FieldError(f"frequencies[{bad[0]}]", "must be a finite frequency > 0 [Hz]")
    return to_json(linearize(model, op.x, op.p_a, op.p_b, op.u, freq))
