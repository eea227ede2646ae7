"""POST /api/datasets/inspect: preview a rig file before storing it (the page's mapping step)."""
from fastapi import APIRouter, Request
from starlette.concurrency import run_in_threadpool
from starlette.datastructures import UploadFile

from pneucore.fileformats import inspect_file
from pneucore.validation import FieldError

from ..deps import LimitsDep
from ..schemas import FilePreview
from ..bodies import OffLoopRoute, read_multipart

router = APIRouter(prefix="/api/datasets", tags=["datasets"], route_class=OffLoopRoute)


@router.post("/inspect", response_model=FilePreview,
             summary="Preview a CSV, TDMS or .mat file: dialect, columns, units, a proposed mapping",
             openapi_extra={"requestBody": {"content": {
                 "multipart/form-data": {"schema": {"type": "object", "properties": {
                     "file": {"type": "string", "format": "binary"}}}},
                 "application/octet-stream": {"schema": {"type": "string", "format": "binary"}}}}})
async def inspect_upload(request: Request, limits: LimitsDep):
    # the body is limited by app.bodies.BodyLimit while it is read (413 beyond the limit)
    ctype = request.headers.get("content-type", "")
    body = await request.body()
    if ctype.startswith("multipart/form-data"):
        form = await read_multipart(request, body, limits.max_upload_bytes)
        upload = form.get("file")
        if not isinstance(upload, UploadFile):
            raise FieldError("file", "a file field named 'file' is required")
        data, filename = await upload.read(), upload.filename
    else:
        data, filename = body, request.query_params.get("filename")
    return await run_in_threadpool(inspect_file, data, filename)
