"""Datasets: POST (CSV upload, multipart or text/csv, or JSON), GET list, GET one, DELETE.

Every stored field is validated before the one transaction that stores it;
parsing and validation run in a worker thread, off the event loop. The shipped
sample datasets are read-only (DELETE answers 403).
"""
from typing import Optional

from fastapi import APIRouter, HTTPException, Request
from pydantic import ValidationError
from starlette.concurrency import run_in_threadpool

from ..bodies import RAW_FILE_TYPES, OffLoopRoute, read_file_upload
from ..request_memory import check_json
from ..deps import LimitsDep, StoreDep, not_found
from ..responses import JSON
from ..schemas import (CommandProposal, CommandProposalRequest, DatasetCreated, DatasetInfo,
                       DatasetJsonIn, DatasetWithData)
from ..services import DEFAULT_AMBIENT_PRESSURE, propose_dataset_command, store_json, store_upload
from ..store import ReadOnly

router = APIRouter(prefix="/api/datasets", tags=["datasets"], route_class=OffLoopRoute)


_AMBIENT_DOC = (f"The rig's ambient pressure, added to gauge pressures (bar(g), kPag...) [Pa]; "
                f"default {DEFAULT_AMBIENT_PRESSURE:g} Pa, the model's default ambient. Form field "
                "or query parameter")
_COLUMNS_DOC = ('Column mapping as a JSON object, e.g. {"Zeit": "t", "pA": "p_a[bar(g)]", '
                '"Kraft": null}: file column -> signal (a unit in brackets overrides the file\'s; '
                "null ignores the column). Form field or query parameter")

def _json_body_schema():
    """DatasetJsonIn's schema with its references into the OpenAPI components (MeasurementIn is
    there through ExperimentIn): a local '#/$defs/...' does not resolve inside an OpenAPI document."""
    schema = DatasetJsonIn.model_json_schema(ref_template="#/components/schemas/{model}")
    schema.pop("$defs", None)
    return schema


_UPLOAD_DOC = {
    "requestBody": {"content": {
        "multipart/form-data": {"schema": {"type": "object", "properties": {
            "file": {"type": "string", "format": "binary",
                     "description": "CSV (any delimiter, decimal comma, UTF-8/16 or latin-1, optional "
                                    "units row), NI TDMS or MATLAB .mat: t[s|ms], u[-|%], "
                                    "p_a[Pa|kPa|bar|bar(g)|psi(g)...], p_b, x[m|mm|in], v, "
                                    "T_a[K|degC], T_b, F[N|kN|daN|lbf] (rod force, outward), "
                                    "q_a, q_b, q_s[kg/s|g/s|L/min ANR|NL/min|m^3/h ANR] (mass "
                                    "flows, ANR at RHO_REF 1.185 kg/m^3), p_s[Pa|bar|bar(g)...] "
                                    "(supply), or aliases (Zeit, Time, p_A...)"},
            "ambient_pressure": {"type": "number", "description": _AMBIENT_DOC},
            "columns": {"type": "string", "description": _COLUMNS_DOC},
            "name": {"type": "string"}, "description": {"type": "string"},
            "locked": {"type": "boolean", "description": "Piston locked during the test [-]"},
            "x0": {"type": "number", "description": "Initial position [m]"},
            "scenario": {"type": "string", "description": "Scenario context as JSON text"}}}},
        "text/csv": {"schema": {"type": "string"}},
        "application/octet-stream": {"schema": {"type": "string", "format": "binary",
                                                "description": "A TDMS, .mat or CSV file"}},
        # components, not $defs: the document must resolve every reference it makes
        "application/json": {"schema": _json_body_schema()}}}}


@router.post("", status_code=201, summary="Store a measurement (CSV, TDMS or .mat upload, or JSON)",
             openapi_extra=_UPLOAD_DOC, response_model=DatasetCreated, response_model_by_alias=True)
async def create_dataset(request: Request, store: StoreDep, limits: LimitsDep):
    # the body is limited by app.bodies.BodyLimit while it is read (413 beyond the limit)
    ctype = request.headers.get("content-type", "")
    if ctype.startswith(("multipart/form-data",) + RAW_FILE_TYPES):
        data, filename, fields, multipart = await read_file_upload(request, limits.max_upload_bytes)
        name = fields.get("name") or ((filename or "upload").rsplit(".", 1)[0] if multipart else None)
        description = fields.get("description", "") if multipart else ""
        return await run_in_threadpool(store_upload, store, data, filename, fields, name, description,
                                       limits)
    body = await request.body()
    check_json(body, limits.max_request_memory)   # 413 before parsing, beyond the memory budget
    try:
        payload = await run_in_threadpool(DatasetJsonIn.model_validate_json, body)
    except ValidationError as exc:
        from fastapi.exceptions import RequestValidationError
        raise RequestValidationError([{**e, "loc": ("body",) + tuple(e["loc"])} for e in exc.errors()])
    return await run_in_threadpool(store_json, store, payload)


@router.get("", summary="List stored datasets (metadata only)", response_model=list[DatasetInfo])
def list_datasets(store: StoreDep):
    return store.list_datasets()


@router.get("/{dataset_id}", summary="One dataset with its samples", response_class=JSON,
            response_model=DatasetWithData)
def get_dataset(dataset_id: str, store: StoreDep):
    info = store.checked_dataset_info(dataset_id)   # a damaged row: 409 (app.store.DamagedRecord)
    if info is None:
        raise not_found("dataset", dataset_id)
    data = store.dataset_data(dataset_id)
    if data is None:   # deleted meanwhile
        raise not_found("dataset", dataset_id)
    return JSON({**info, "measurement": data})


@router.post("/{dataset_id}/propose-command", response_model=CommandProposal,
             summary="Propose a valve command from a stored record's pressure edges (to confirm)")
def propose_command_endpoint(dataset_id: str, store: StoreDep,
                             req: Optional[CommandProposalRequest] = None):
    out = propose_dataset_command(store, dataset_id, req or CommandProposalRequest())
    if out is None:
        raise not_found("dataset", dataset_id)
    return out


@router.delete("/{dataset_id}", status_code=204, summary="Delete a dataset")
def delete_dataset(dataset_id: str, store: StoreDep):
    try:
        deleted = store.delete_dataset(dataset_id)
    except ReadOnly as exc:
        raise HTTPException(403, str(exc)) from None
    if not deleted:
        raise not_found("dataset", dataset_id)
