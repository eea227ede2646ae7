"""What HTTP alone costs for an answer of a given size: an ASGI app that does no work.

``benchmarks/bench_api.py`` starts it under the same uvicorn set-up as the API (one
worker, the HTTP protocol ``python -m app`` runs, the same event loop) and sends it the
same request with the same clients. It reads the whole body, then answers with bytes
loaded once at start-up: the API's own answer to that request (JSON, or ``.npz`` when the
``Accept`` header names it), so the server, the kernel and the client move exactly the
bytes the API does. The round trip it measures is the floor under the API's: what is
left above it is the endpoint's own work (parsing, simulating, writing the answer) and
whatever the application's layers add.

The answers' files are named by two environment variables, :data:`ENV_JSON` and
:data:`ENV_NPZ`; ``GET`` of any path answers ``ok`` (the readiness check).
"""
from __future__ import annotations

import os

#: Environment variables naming the files of the JSON and the ``.npz`` answer
ENV_JSON, ENV_NPZ = "PNEUCORE_BENCH_JSON", "PNEUCORE_BENCH_NPZ"


def _load(var):
    path = os.environ.get(var)
    if not path:
        return b"{}"
    with open(path, "rb") as fh:
        return fh.read()


_ANSWERS = {b"application/json": _load(ENV_JSON), b"application/x-npz": _load(ENV_NPZ)}


async def app(scope, receive, send):
    """ASGI app: a POST's body read in full and answered with the stored bytes of its form."""
    if scope["type"] != "http":   # lifespan: nothing to start or stop
        message = await receive()
        if message["type"] == "lifespan.startup":
            await send({"type": "lifespan.startup.complete"})
            message = await receive()
        if message["type"] == "lifespan.shutdown":
            await send({"type": "lifespan.shutdown.complete"})
        return
    while (await receive()).get("more_body", False):
        pass
    if scope["method"] != "POST":
        body, ctype = b"ok", b"text/plain"
    else:
        accept = next((v for k, v in scope["headers"] if k == b"accept"), b"")
        ctype = b"application/x-npz" if b"x-npz" in accept else b"application/json"
        body = _ANSWERS[ctype]
    await send({"type": "http.response.start", "status": 200,
                "headers": [(b"content-length", str(len(body)).encode()), (b"content-type", ctype)]})
    await send({"type": "http.response.body", "body": body})
