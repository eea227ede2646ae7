"""Fast JSON responses (numpy arrays and NaN as null, by orjson) and the documented error responses."""
from typing import Any

import orjson
from fastapi.responses import JSONResponse, Response
from pydantic import BaseModel, Field


class JSON(JSONResponse):
    """``application/json`` rendered by orjson (numpy arrays serialised, NaN -> null).

    A JSONResponse subclass so that the OpenAPI documents the route's response model."""
    media_type = "application/json"

    def render(self, content) -> bytes:
        return orjson.dumps(content, option=orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS)


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
    413: "The request body exceeds max_upload_bytes (GET /api/limits)",
    422: "Invalid input: each entry names the field (loc, field) and what is wrong (msg)",
    429: "Too many jobs queued or running (max_jobs, GET /api/limits)",
    504: "The synchronous analysis exceeded request_time_limit (GET /api/limits); use /api/jobs",
}


def document_errors(app, settings=None):
    """Add the error responses each operation can give to the app's OpenAPI document.

    Every operation can answer 400 (Host check) and 401 (token, when one is set);
    state-changing ones 403 (Origin check); those with a path parameter 404;
    those with a body 413 and 422; job-starting ones 429; the synchronous
    analyses 504. The document is built once, on first use.
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
    codes = [400, 401]
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
    if path in ("/api/compare", "/api/calibrate", "/api/diagnose"):
        codes.append(504)
    responses = op.setdefault("responses", {})
    for code in codes:
        responses.setdefault(str(code), {
            "description": _ERROR_TEXT[code],
            "content": {"application/json": {"schema": {"$ref": "#/components/schemas/ErrorOut"}}}})


def wants_csv(request) -> bool:
    """The client asked for CSV (``Accept: text/csv``) rather than JSON."""
    return "text/csv" in request.headers.get("accept", "").lower()


def csv_response(text: str, filename: str) -> Response:
    """A CSV download (see :mod:`pneucore.data.export` for the format)."""
    return Response(text, media_type="text/csv; charset=utf-8",
                    headers={"Content-Disposition": f'attachment; filename="{filename}"'})


#: OpenAPI entry of the CSV alternative of a 200 response
CSV_RESPONSES = {200: {"content": {"text/csv": {"schema": {
    "type": "string",
    "description": "With `Accept: text/csv`: a first line `# pneucore ...`, a header with units "
                   "in brackets (t[s], p_a[Pa], x[m]...), one row per sample, absolute pressures; "
                   "POST /api/datasets reads it back unchanged"}}}}}
