"""Fast JSON responses: numpy arrays and NaN (as null) handled by orjson."""
import orjson
from fastapi.responses import JSONResponse, Response


class JSON(JSONResponse):
    """``application/json`` rendered by orjson (numpy arrays serialised, NaN -> null).

    A JSONResponse subclass so that the OpenAPI documents the route's response model."""
    media_type = "application/json"

    def render(self, content) -> bytes:
        return orjson.dumps(content, option=orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS)


def wants_csv(request) -> bool:
    """The client asked for CSV (``Accept: text/csv``) rather than JSON."""
    return "text/csv" in request.headers.get("accept", "").lower()


def csv_response(text: str, filename: str) -> Response:
    """A CSV download (see :mod:`pneucore.export` for the format)."""
    return Response(text, media_type="text/csv; charset=utf-8",
                    headers={"Content-Disposition": f'attachment; filename="{filename}"'})


#: OpenAPI entry of the CSV alternative of a 200 response
CSV_RESPONSES = {200: {"content": {"text/csv": {"schema": {
    "type": "string",
    "description": "With `Accept: text/csv`: a first line `# pneucore ...`, a header with units "
                   "in brackets (t[s], p_a[Pa], x[m]...), one row per sample, absolute pressures; "
                   "POST /api/datasets reads it back unchanged"}}}}}
