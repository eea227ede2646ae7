"""The answers' forms (JSON by orjson with numpy arrays and NaN as null, CSV, NumPy .npz: the
client chooses with ``Accept``) and the documented error responses."""
from typing import Any

import orjson
from fastapi.responses import JSONResponse, Response
from pydantic import BaseModel, Field

from pneucore.data.npz import NPZ_MEDIA_TYPE


def dumps(content) -> bytes:
    """The API's JSON text of ``content`` (orjson: numpy arrays and scalars serialised, NaN
    and infinities as null, non-string keys as strings)."""
    return orjson.dumps(content, option=orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS)


class JSON(JSONResponse):
    """``application/json`` rendered by :func:`dumps`.

    A JSONResponse subclass so that the OpenAPI documents the route's response model."""
    media_type = "application/json"

    def render(self, content) -> bytes:
        return dumps(content)


class ErrorOut(BaseModel):
    """The body of every error response."""
    detail: Any = Field(..., description="What is wrong: a message, or for 422 a list of "
                                         "{loc, msg, type, field} naming each bad field")


_ERROR_TEXT = {
    400: "Malformed request: a Host this server does not answer to, a malformed multipart body, "
         "or a body that cannot be read",
    401: "A token is required (only when the server sets PNEUCORE_TOKEN): "
         "'Authorization: Bearer <token>'",
    403: "Refused: a cross-origin state-changing request, or a write to a read-only record "
         "(a shipped sample dataset)",
    404: "No such record",
    409: "A stored record the request uses is damaged (it no longer decodes; the message names it "
         "and the remedy: delete and store it again, a shipped sample is restored at the next start)",
    413: "The request body exceeds max_upload_bytes (GET /api/limits)",
    422: "Invalid input: each entry names the field (loc, field) and what is wrong (msg)",
    429: "Too many jobs queued or running (max_jobs), or synchronous analyses running and "
         "waiting (sync_workers, max_sync_queue; GET /api/limits); Retry-After says when to retry",
    503: "The server cannot serve now: its storage failed (a disk I/O error, a damaged or "
         "read-only database file; the cause is named, not the request's fault), the database "
         "stayed busy (Retry-After), or max_connections are in progress",
    507: "The server's disk is full: nothing can be stored (the cause is named); deletes still work",
    504: "The synchronous analysis exceeded request_time_limit (GET /api/limits); use /api/jobs",
}


#: The synchronous analyses admitted by :mod:`app.sync_pool` (429 when its queue is full)
SYNC_ANALYSES = ("/api/compare", "/api/calibrate", "/api/diagnose", "/api/refine",
                 "/api/reports/compare", "/api/reports/diagnose", "/api/heat-models/compare",
                 "/api/reports/sessions/{session_id}")


def document_errors(app, settings=None):
    """Add the error responses each operation can give to the app's OpenAPI document.

    Every operation can answer 400 (Host check) and 401 (token, when one is set);
    state-changing ones 403 (Origin check); those with a path parameter 404;
    those with a body 413 and 422; job-starting ones 429; the synchronous
    analyses 504; those that may store something 507 (a full disk). The document is built once, on first use.
    """
    build = app.openapi

    def openapi():
        if app.openapi_schema is None:
            doc = build()
            schemas = doc.setdefault("components", {}).setdefault("schemas", {})
            schemas["ErrorOut"] = ErrorOut.model_json_schema()
            for path, ops in doc.get("paths", {}).items():
                for method, op in ops.items():
                    _add_errors(path, method.upper(), op)
        return app.openapi_schema
    app.openapi = openapi


def _add_errors(path, method, op):
    codes = [400, 401, 503]
    unsafe = method in ("POST", "PUT", "PATCH", "DELETE")
    if unsafe:
        codes.append(403)
    if "{" in path:
        codes.append(404)
    if method in ("POST", "PUT", "PATCH"):
        codes += [413, 422]
    elif op.get("parameters"):
        codes.append(422)
    if unsafe and path.startswith(("/api/jobs", "/api/studies")):
        codes.append(429)
    if path in SYNC_ANALYSES:
        codes.append(429)
    if (method == "GET" and path.startswith(("/api/datasets/{", "/api/sessions/{"))) or \
            (method == "POST" and (path in SYNC_ANALYSES or path.startswith(("/api/jobs", "/api/sessions")))):
        codes.append(409)   # a stored dataset it reads is damaged
    if path in ("/api/compare", "/api/calibrate", "/api/diagnose"):
        codes.append(504)
    if method in ("POST", "PUT", "PATCH"):
        codes.append(507)
    responses = op.setdefault("responses", {})
    for code in codes:
        responses.setdefault(str(code), {
            "description": _ERROR_TEXT[code],
            "content": {"application/json": {"schema": {"$ref": "#/components/schemas/ErrorOut"}}}})


#: The answer forms an ``Accept`` header chooses between, by media type (JSON by default)
ANSWER_FORMS = {"application/json": "json", "text/csv": "csv", NPZ_MEDIA_TYPE: "npz"}


def answer_form(accept: str, offered=("json", "csv")) -> str:
    """The form of the answer an ``Accept`` header asks for: ``json``, ``csv`` or ``npz``.

    The offered form with the highest ``q`` wins (the first listed on a tie); a header
    naming none of them, or none at all, gets JSON.

    Parameters
    ----------
    accept : str
        The request's ``Accept`` header (``""`` when absent)
    offered : tuple of str
        The forms the endpoint answers in
    """
    best, best_q = "json", 0.0
    for item in accept.lower().split(",")[:32]:   # a bound on a hostile header
        media, *params = item.split(";")
        form = ANSWER_FORMS.get(media.strip())
        if form is None or form not in offered:
            continue
        q = 1.0
        for p in params:
            k, _, v = p.partition("=")
            if k.strip() == "q":
                try:
                    q = float(v)
                except ValueError:
                    q = 0.0
        if q > best_q and q == q:   # q == q: not NaN
            best, best_q = form, q
    return best


def wants_csv(request) -> bool:
    """The client asked for CSV (``Accept: text/csv``) rather than JSON."""
    return answer_form(request.headers.get("accept", "")) == "csv"


def csv_response(text: str, filename: str) -> Response:
    """A CSV download (see :mod:`pneucore.data.export` for the format)."""
    return Response(text, media_type="text/csv; charset=utf-8",
                    headers={"Content-Disposition": f'attachment; filename="{filename}"'})


def npz_response(data: bytes, filename: str) -> Response:
    """A NumPy ``.npz`` download (see :mod:`pneucore.data.npz` for the format)."""
    return Response(data, media_type=NPZ_MEDIA_TYPE,
                    headers={"Content-Disposition": f'attachment; filename="{filename}"'})


_CSV_CONTENT = {"text/csv": {"schema": {
    "type": "string",
    "description": "With `Accept: text/csv`: a first line `# pneucore ...`, a header with units "
                   "in brackets (t[s], p_a[Pa], x[m]...), one row per sample, absolute pressures; "
                   "POST /api/datasets reads it back unchanged"}}}
#: OpenAPI entry of the CSV alternative of a 200 response
CSV_RESPONSES = {200: {"content": _CSV_CONTENT}}
#: ... of the CSV and NumPy alternatives of a simulation's 200 response
SIMULATION_RESPONSES = {200: {"content": {**_CSV_CONTENT, NPZ_MEDIA_TYPE: {"schema": {
    "type": "string", "format": "binary",
    "description": "With `Accept: application/x-npz`: a NumPy .npz archive (numpy.load reads "
                   "it, no pickle) with one array per series in SI units (absolute pressures; "
                   "`mode` as text) and `meta.json`, the JSON answer's other fields (units, "
                   "events, stats, status, message). The same numbers as the JSON answer, "
                   "written without conversion to text"}}}}}
