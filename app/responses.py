"""Fast JSON responses: numpy arrays and NaN (as null) handled by orjson."""
import orjson
from fastapi.responses import Response


class JSON(Response):
    """``application/json`` rendered by orjson (numpy arrays serialised, NaN -> null)."""
    media_type = "application/json"

    def render(self, content) -> bytes:
        return orjson.dumps(content, option=orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS)
