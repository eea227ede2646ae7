"""POST /api/datasets/inspect: preview a rig file before storing it (the page's mapping step)."""
from fastapi import APIRouter, Request
from starlette.datastructures import UploadFile

from pneucore.fileformats import inspect_file
from pneucore.validation import FieldError

from ..deps import LimitsDep
from ..schemas import FilePreview
from .datasets import _read_limited

router = APIRouter(prefix="/api/datasets", tags=["datasets"])


@router.post("/inspect", response_model=FilePreview,
             summary="Preview a CSV, TDMS or .mat file: dialect, columns, units, a proposed mapping",
             openapi_extra={"requestBody": {"content": {
                 "multipart/form-data": {"schema": {"type": "object", "properties": {
                     "file": {"type": "string", "format": "binary"}}}},
                 "application/octet-stream": {"schema": {"type": "string", "format": "binary"}}}}})
async def inspect_upload(request: Request, limits: LimitsDep):
    ctype = request.headers.get("content-type", "")
    if ctype.startswith("multipart/form-data"):
        form = await request.form(max_part_size=limits.max_upload_bytes)
        upload = form.get("file")
        if not isinstance(upload, UploadFile):
            raise FieldError("file", "a file field named 'file' is required")
        data, filename = await upload.read(), upload.filename
        if len(data) > limits.max_upload_bytes:
            raise FieldError("file", f"exceeds the upload limit of {limits.max_upload_bytes} bytes")
    else:
        data, filename = await _read_limited(request, limits.max_upload_bytes), \
            request.query_params.get("filename")
    return inspect_file(data, filename)
