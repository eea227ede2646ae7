"""POST /api/simulate and /api/simulate/heat-models."""
from fastapi import APIRouter, Request

from ..responses import JSON, CSV_RESPONSES, csv_response, wants_csv

from pneucore.analysis.compare import check_heat_models, with_heat_model
from pneucore.simulate import simulate

from ..bodies import OffLoopRoute
from ..deps import LimitsDep, parse_model, parse_scenario
from ..schemas import HeatModelsRequest, HeatModelsResponse, SimulateRequest, SimulateResponse
from ..services import result_json

router = APIRouter(prefix="/api/simulate", tags=["simulate"], route_class=OffLoopRoute)

@router.post("", response_model=SimulateResponse, summary="Simulate a model on a scenario",
             response_class=JSON, responses=CSV_RESPONSES)
def simulate_endpoint(req: SimulateRequest, request: Request):
    # the limits are read here rather than through ``LimitsDep``: a plain (sync)
    # dependency costs a hop through the thread pool on every request
    model = parse_model(req.model)
    scen = parse_scenario(req.scenario, model, request.app.state.settings.limits)
    res = simulate(model, scen)
    out = result_json(res, req.series)
    if wants_csv(request):
        from pneucore.data.export import simulation_csv
        return csv_response(simulation_csv(out), "simulation.csv")
    return JSON(out)


@router.post("/heat-models", summary="One scenario under several heat models (paper Fig. 8, 11)",
             response_class=JSON, response_model=HeatModelsResponse)
def heat_models_endpoint(req: HeatModelsRequest, limits: LimitsDep):
    model = parse_model(req.model)
    scen = parse_scenario(req.scenario, model, limits)
    out = {name: result_json(simulate(with_heat_model(model, name), scen), req.series)
           for name in check_heat_models(req.heat_models)}
    return JSON({"runs": out})
