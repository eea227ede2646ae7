"""POST /api/datasets/inspect: preview a rig file before storing it (the page's mapping step)."""
from fastapi import APIRouter, Request
from starlette.concurrency import run_in_threadpool

from ..bodies import OffLoopRoute, read_file_upload
from ..deps import LimitsDep
from ..schemas import FilePreview
from ..services import inspect_rig_file

router = APIRouter(prefix="/api/datasets", tags=["datasets"], route_class=OffLoopRoute)


@router.post("/inspect", response_model=FilePreview,
             summary="Preview a CSV, TDMS or .mat file: dialect, columns, units, a proposed mapping",
             openapi_extra={"requestBody": {"content": {
                 "multipart/form-data": {"schema": {"type": "object", "properties": {
                     "file": {"type": "string", "format": "binary"}}}},
                 "application/octet-stream": {"schema": {"type": "string", "format": "binary"}}}}})
async def inspect_upload(request: Request, limits: LimitsDep):
    data, filename, _, _ = await read_file_upload(request, limits.max_upload_bytes)
    return await run_in_threadpool(inspect_rig_file, data, filename, limits)
