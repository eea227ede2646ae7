"""POST /api/simulate's express lane: small simulations answered on the event loop,
without FastAPI's routing, dependency and response layers.

The pulse case of the paper takes about half a millisecond to simulate; FastAPI's
machinery around it (matching the route among forty, solving the dependencies,
validating the body through the route's field, wrapping the answer, five layers of
middleware on the way back) and a hop to a worker thread and back cost as much again.
:class:`SimulateExpressLane` is an ASGI middleware, inside the Host/Origin/token
:class:`~app.security.Guard` and the :class:`~app.bodies.BodyLimit`, that takes a
``POST /api/simulate`` which can be answered at once and answers it with the very
functions the route uses: the body parsed by :func:`app.bodies.parse_json` and
validated by the route's :class:`~app.schemas.SimulateRequest`, the run by
:func:`app.services.simulation`, the answer rendered by :func:`app.responses.dumps` or
as a NumPy archive. Everything else goes on, untouched, to the route, which answers
it in a worker thread:

* a request the lane does not take: a body that is not ``application/json``, larger
  than :data:`~app.bodies.LOOP_PARSE_BYTES` or of unknown length, a CSV answer (the
  text is slow to write: about 15 ms per 1,000 samples), or a run that is not a
  :func:`loop_candidate`;
* a request the lane took but could not answer: any error (malformed JSON, a field
  out of range, a failed simulation; the route gives the documented 422 with the
  field's name) or a run that needs more than :data:`LOOP_MAX_STEPS` solver steps
  (the route runs it again, from the start and with the request's whole budget). The
  body already read is handed on as it came.

Requests in the lane are served one after the other on the loop, each in a few
milliseconds at most (the step budget bounds it). With 20 clients on 2 cores this
costs less than threads do, because every stage but the solver holds the GIL and a hop
to a thread and back is paid on each request: answering small runs on the loop whatever
the number of requests in progress took the server's CPU from 2.0-2.75 to 1.35-1.6 ms a
request and the p50 from 26-38 to 23-25 ms, and the lane then to 1.1-1.15 ms and 19-20 ms
(``benchmarks/bench_api.py``, lean client).
"""
from __future__ import annotations

from . import bodies
from .bodies import LOOP_PARSE_BYTES
from .responses import NPZ_MEDIA_TYPE, answer_form, dumps
from .schemas import SimulateRequest
# integrate and EFFECTS: what the choice of the loop reads; simulate: the run handed to the service
from .services import EFFECTS, PastBudget, integrate, names_runtime_law, simulate, simulation

#: The path the lane serves
PATH = "/api/simulate"
#: Largest run answered on the event loop: output samples [-] (the answer's size and the
#: result's building and encoding grow with them: about 0.3 ms per 1,000 samples)
LOOP_MAX_SAMPLES = 5_001
#: ... command breakpoints [-] (validating a scenario grows with them)
LOOP_MAX_COMMAND_POINTS = 1_000
#: ... solver steps, accepted and rejected [-]: 2-5 us each for the base core, so at most a few
#: milliseconds on the loop (the paper's cases take 100-200 steps)
LOOP_MAX_STEPS = 1_000
#: Answer forms the lane writes (the CSV text goes to a thread)
LANE_FORMS = ("json", "npz")


def loop_candidate(req: SimulateRequest) -> bool:
    """Whether a checked request may be run on the event loop: the core is compiled
    (never a compilation on the loop), the model adds no user terms and names no law
    registered at run time (a specialised core may still need compiling), and the
    scenario asks for at most :data:`LOOP_MAX_SAMPLES` output samples and
    :data:`LOOP_MAX_COMMAND_POINTS` breakpoints."""
    if not integrate.overloads:   # not compiled (or loaded from the cache) yet in this process
        return False
    if getattr(req.scenario, "controller", None) is not None:   # closed loop: its own core
        return False
    if any(EFFECTS[n].terms is not None for n in (req.model.effects or {}) if n in EFFECTS):
        return False
    if names_runtime_law(req.model):   # a law registered at run time: its core may need compiling
        return False
    s = req.scenario
    if s.sample_period is None or s.duration is None or s.sample_period <= 0:
        return False
    return s.duration / s.sample_period < LOOP_MAX_SAMPLES - 1 and \
        len(s.command or ()) <= LOOP_MAX_COMMAND_POINTS


def _headers(scope):
    """Content type (media type only), content length (None if absent or not a number) and
    Accept of a request; of a header given twice, the first, as the route reads it
    (Starlette's ``request.headers.get``)."""
    found = {}
    for k, v in scope.get("headers", ()):
        if k in (b"content-type", b"content-length", b"accept") and k not in found:
            found[k] = v
    ctype = found.get(b"content-type", b"").decode("latin-1").split(";", 1)[0].strip().lower()
    length = found.get(b"content-length", b"").strip()
    length = int(length) if length.isdigit() and len(length) < 12 else None
    return ctype, length, found.get(b"accept", b"").decode("latin-1")


class SimulateExpressLane:
    """ASGI middleware: ``POST /api/simulate`` answered on the event loop when it can be
    (see the module's notes); every other request, and every one it cannot answer, goes
    on to the app it wraps."""

    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http" or scope["path"] != PATH or scope["method"] != "POST":
            return await self.app(scope, receive, send)
        ctype, length, accept = _headers(scope)
        form = answer_form(accept, offered=("json", "csv", "npz"))
        if ctype != "application/json" or length is None or length > LOOP_PARSE_BYTES \
                or form not in LANE_FORMS:
            return await self.app(scope, receive, send)
        chunks, message = [], None
        while True:
            message = await receive()
            if message["type"] != "http.request":   # the client left: the route sees it too
                return await self.app(scope, _replay(chunks, message, receive), send)
            chunks.append(message.get("body", b""))
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        answer = self._answer(scope, body, form)
        if answer is None:
            return await self.app(scope, _replay([body], None, receive), send)
        if form == "npz":
            headers = [(b"content-type", NPZ_MEDIA_TYPE.encode()),
                       (b"content-disposition", b'attachment; filename="simulation.npz"')]
        else:
            headers = [(b"content-type", b"application/json")]
        await send({"type": "http.response.start", "status": 200,
                    "headers": [(b"content-length", str(len(answer)).encode())] + headers})
        await send({"type": "http.response.body", "body": answer})

    @staticmethod
    def _answer(scope, body, form):
        """The answer's bytes, or None when the route is to answer."""
        try:
            req = SimulateRequest.model_validate(bodies.parse_json(body))
            if not loop_candidate(req):
                return None
            out = simulation(req, scope["app"].state.settings.limits, LOOP_MAX_STEPS,
                             run=simulate, form=form)
        except PastBudget:
            return None   # a longer run: redone in a worker thread with the request's budget
        except Exception:  # noqa: BLE001 - every error is the route's to report (422 naming the field)
            return None
        return out if form == "npz" else dumps(out)


def _replay(chunks, last, receive):
    """A ``receive`` that gives the body already read (then ``last``, when the client left
    while it was read), then what the server sends next."""
    pending = [{"type": "http.request", "body": b"".join(chunks), "more_body": False}]
    if last is not None:
        pending.append(last)

    async def replay():
        if pending:
            return pending.pop(0)
        return await receive()
    return replay
