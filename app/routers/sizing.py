"""POST /api/sizing: from a required motion to the circuits that meet it (synchronous; the
same as a job with progress: POST /api/jobs/sizing)."""
from fastapi import APIRouter

from ..bodies import OffLoopRoute
from ..deps import LimitsDep
from ..responses import JSON, ErrorOut
from ..services import deadline_progress
from ..sizing_schemas import SizingRequest, SizingResponse, SizingSeriesResponse
from ..sizing_service import run_sizing, sizing_series
from ..sync_pool import sync_slot

router = APIRouter(prefix="/api", tags=["sizing"], route_class=OffLoopRoute)

#: The answers of the bounded synchronous pool (app.sync_pool) and of the request time limit
_SYNC_ERRORS = {
    429: {"model": ErrorOut, "description": "Synchronous analyses running and waiting "
                                            "(sync_workers, max_sync_queue; GET /api/limits); "
                                            "Retry-After says when to retry, or use POST "
                                            "/api/jobs/sizing"},
    504: {"model": ErrorOut, "description": "The sizing exceeded request_time_limit "
                                            "(GET /api/limits); use POST /api/jobs/sizing"},
}


@router.post("/sizing", dependencies=[sync_slot("/api/jobs/sizing")],
             summary="Size a drive: cylinder, valve, tube and meter-out settings that meet a "
                     "required motion, ranked by air per cycle; why the others fail",
             response_class=JSON, response_model=SizingResponse, responses=_SYNC_ERRORS)
def sizing_endpoint(req: SizingRequest, limits: LimitsDep):
    return JSON(run_sizing(req, limits, progress=deadline_progress(limits, "sizing",
                                                                   "/api/jobs/sizing")))


@router.get("/sizing/series", response_model=SizingSeriesResponse, summary="The shipped cylinder, valve and tube series a sizing's "
                                      "choices may name (series or series:member)")
def sizing_series_endpoint():
    return sizing_series()
