"""POST /api/simulate and /api/simulate/heat-models.

The work (the request checked, the run, the answer) is :func:`app.services.simulation`'s;
this router runs it in a worker thread and answers in JSON, CSV (``Accept: text/csv``) or
as a NumPy archive (``Accept: application/x-npz``). A long run never blocks the event loop
that serves every other client.

Small runs rarely get here: :mod:`app.express_lane` answers them on the event loop before
the routing. What reaches this route is what the lane does not take (a CSV answer, a
large run, a core still to compile) or could not answer (an error, reported here with
the field's name, or a run past the lane's step budget, run here again with the
request's whole budget).
"""
from fastapi import APIRouter, Request
from starlette.concurrency import run_in_threadpool

from ..bodies import OffLoopRoute
from ..deps import LimitsDep
from ..responses import JSON, SIMULATION_RESPONSES, answer_form, csv_response, npz_response
from ..schemas import HeatModelsRequest, HeatModelsResponse, SimulateRequest, SimulateResponse
# simulate: the run handed to the service (named here, so where each run happens can be watched)
from ..services import simulate, simulate_under_heat_models, simulation, simulation_csv

router = APIRouter(prefix="/api/simulate", tags=["simulate"], route_class=OffLoopRoute)


def _answer(req: SimulateRequest, form: str, limits, memory=None):
    # the run's memory estimate held on the analyses' budget (app.analysis_memory)
    out = simulation(req, limits, run=simulate, form=form, memory=memory)
    if form == "csv":
        return csv_response(simulation_csv(out), "simulation.csv")
    if form == "npz":
        return npz_response(out, "simulation.npz")
    return JSON(out)


@router.post("", response_model=SimulateResponse, summary="Simulate a model on a scenario",
             response_class=JSON, responses=SIMULATION_RESPONSES)
async def simulate_endpoint(req: SimulateRequest, request: Request):
    # the limits are read here rather than through ``LimitsDep``: a plain (sync)
    # dependency costs a hop through the thread pool on every request
    form = answer_form(request.headers.get("accept", ""), offered=("json", "csv", "npz"))
    return await run_in_threadpool(_answer, req, form, request.app.state.settings.limits,
                                   getattr(request.app.state, "memory", None))


@router.post("/heat-models", summary="One scenario under several heat models (paper Fig. 8, 11)",
             response_class=JSON, response_model=HeatModelsResponse)
def heat_models_endpoint(req: HeatModelsRequest, limits: LimitsDep, request: Request):
    return JSON(simulate_under_heat_models(req, limits, getattr(request.app.state, "memory", None)))
