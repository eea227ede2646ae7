"""Request bodies: one documented size limit, enforced while reading; JSON parsed off the event loop.

:class:`BodyLimit` (ASGI middleware) refuses a body larger than
``Limits.max_upload_bytes`` with 413: up front when ``Content-Length`` says so,
otherwise as soon as the bytes received pass the limit (a chunked body is never
buffered beyond it). :class:`OffLoopRoute` (the routers' ``route_class``) parses
a JSON body larger than :data:`LOOP_PARSE_BYTES` in a worker thread, so a large
request never blocks the event loop that serves every other client; a smaller
one is parsed on the loop (microseconds, less than the hop to a thread and back).
Pydantic's validation of the parsed object is C code and costs milliseconds even
at the size limit.
"""
from __future__ import annotations

import json
from contextlib import nullcontext

import orjson
from fastapi.routing import APIRoute
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException
from starlette.requests import Request

from .asgi import TrackedSend, send_json
from .analysis_memory import BODY, body_estimate, budget_of_request
from .request_memory import check_json, json_values


class BodyTooLarge(HTTPException):
    """413: the request body passed the size limit."""

    def __init__(self, limit, declared=None):
        what = f"request body of {declared} bytes" if declared is not None else "request body"
        super().__init__(413, f"{what} exceeds the limit of {limit} bytes (GET /api/limits: "
                              f"max_upload_bytes)")


def _json_413(limit, declared=None):
    return orjson.dumps({"detail": BodyTooLarge(limit, declared).detail})


class BodyLimit:
    """ASGI middleware: every request body is at most ``limit`` bytes, counted as it arrives."""

    def __init__(self, app, limit: int):
        self.app = app
        self.limit = int(limit)

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        limit = self.limit
        for k, v in scope.get("headers", ()):
            if k == b"content-length":
                v = v.decode("latin-1").strip()
                if v.isdigit() and int(v) > limit:
                    return await self._refuse(send, _json_413(limit, int(v)))
        received = 0

        async def limited_receive():
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise BodyTooLarge(limit)
            return message

        tracked = TrackedSend(send)
        try:
            await self.app(scope, limited_receive, tracked)
        except BodyTooLarge:
            if tracked.started:
                raise
            await self._refuse(send, _json_413(limit))

    @staticmethod
    async def _refuse(send, body):
        await send_json(send, 413, body, close=True)


async def read_multipart(request: Request, body: bytes, limit: int):
    """The form of a multipart ``body`` (already read under the size limit); a malformed one is a
    400 that says what is wrong.

    Parameters
    ----------
    request : Request
        The request (its headers carry the boundary)
    body : bytes
        The whole body
    limit : int
        Largest part [bytes]
    """
    from starlette.formparsers import MultiPartException, MultiPartParser

    async def stream():
        yield body
    try:
        return await MultiPartParser(request.headers, stream(), max_part_size=limit).parse()
    except MultiPartException as exc:
        raise HTTPException(400, f"malformed multipart/form-data body: {exc.message}") from None


#: Content types whose body is a file (the rest of an upload's fields in the query string)
RAW_FILE_TYPES = ("text/csv", "text/plain", "application/octet-stream", "application/x-npz")


async def read_file_upload(request: Request, limit: int):
    """The file of an upload: a multipart field ``file``, or the raw body of one of
    :data:`RAW_FILE_TYPES`. Returns ``(data, filename, fields, multipart)``: the file's bytes,
    its name (the query's ``filename`` for a raw body; None when not given), the other form
    fields over the query parameters, and whether it came as multipart.

    Parameters
    ----------
    request : Request
        The request (its body is limited by :class:`BodyLimit` while it is read)
    limit : int
        Largest multipart part [bytes]
    """
    from starlette.datastructures import UploadFile

    from pneucore.description.validation import FieldError
    body = await request.body()
    if request.headers.get("content-type", "").startswith("multipart/form-data"):
        form = await read_multipart(request, body, limit)
        upload = form.get("file")
        if not isinstance(upload, UploadFile):
            raise FieldError("file", "a file field named 'file' is required")
        fields = {**request.query_params,
                  **{k: v for k, v in form.items() if not isinstance(v, UploadFile)}}
        return await upload.read(), upload.filename, fields, True
    return body, request.query_params.get("filename"), dict(request.query_params), False


def parse_json(body: bytes):
    """JSON text -> Python objects (orjson; the standard parser for NaN/Infinity tokens,
    which then fail validation with the field's path rather than as a syntax error)."""
    try:
        return orjson.loads(body)
    except orjson.JSONDecodeError:
        return json.loads(body)   # raises json.JSONDecodeError: FastAPI's 422 json_invalid


#: Largest JSON body parsed on the event loop [bytes] (orjson: about 40 us at this size)
LOOP_PARSE_BYTES = 64 * 1024


class OffLoopRoute(APIRoute):
    """An APIRoute whose JSON body, when larger than :data:`LOOP_PARSE_BYTES`, is read
    and parsed in a worker thread.

    FastAPI reads ``await request.json()``; Starlette caches the parsed body on the
    request, so parsing it first in a thread leaves FastAPI nothing to do on the loop.
    """

    def get_route_handler(self):
        handler = super().get_route_handler()

        async def off_loop_handler(request: Request):
            # the analyses' memory budget for this request's work (an upload's decoding, a
            # synchronous analysis: app.analysis_memory.admitted); a job holds its own
            budget = getattr(request.app.state, "memory", None)
            with budget_of_request(budget):
                return await self._handle(handler, request, budget)
        return off_loop_handler

    async def _handle(self, handler, request, budget):
        ctype = request.headers.get("content-type", "")
        estimate = 0
        # only for a route whose body FastAPI parses: one that reads its body itself (an
        # upload) would hold the parsed objects beside its own, several times the body's size
        if self.body_field is not None and "json" in ctype.split(";", 1)[0]:
            body = await request.body()
            # refused before parsing when its values would exceed the memory budget (413)
            check_json(body, request.app.state.settings.limits.max_request_memory)
            if len(body) > LOOP_PARSE_BYTES:
                # a large body's parsed values are held on the analyses' budget until the
                # answer (503 when they do not fit now; a job adds them to its own estimate)
                estimate = body_estimate(json_values(body))
            with budget.hold(estimate, "request body") if budget is not None and estimate \
                    else nullcontext():
                if body:
                    try:
                        request._json = parse_json(body) if len(body) <= LOOP_PARSE_BYTES \
                            else await run_in_threadpool(parse_json, body)
                    except (ValueError, RecursionError):
                        pass   # FastAPI parses it again and reports the syntax error (422)
                token = BODY.set(estimate)
                try:
                    return await handler(request)
                finally:
                    try:
                        BODY.reset(token)
                    except ValueError:
                        pass
        return await handler(request)
