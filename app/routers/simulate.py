"""POST /api/simulate and /api/simulate/heat-models."""
from fastapi import APIRouter, Request

from ..responses import JSON, CSV_RESPONSES, csv_response, wants_csv

from pneucore.compare import check_heat_models, with_heat_model
from pneucore.simulate import simulate
from pneucore.validation import FieldError

from ..bodies import OffLoopRoute
from ..deps import LimitsDep, parse_model, parse_scenario
from ..schemas import HeatModelsRequest, HeatModelsResponse, SimulateRequest, SimulateResponse

router = APIRouter(prefix="/api/simulate", tags=["simulate"], route_class=OffLoopRoute)

#: Series returned by default (everything the page plots)
DEFAULT_SERIES = ("t", "u", "p_a", "p_b", "T_a", "T_b", "m_a", "m_b", "x", "v", "a", "q_a", "q_b",
                  "friction", "mode", "u_eff", "p_supply", "q_supply", "net_force")


def _result(res, series):
    names = [s for s in (series or DEFAULT_SERIES) if s in res.series]
    if series is not None and len(series) == 0:
        raise FieldError("series", "give at least one series name, or omit the field for the default set")
    if series:
        unknown = [s for s in series if s not in res.series]
        if unknown:
            raise FieldError("series", f"unknown series {unknown}; available: {sorted(res.series)}")
    return res.to_dict(series=names, arrays=True, inputs=False)


@router.post("", response_model=SimulateResponse, summary="Simulate a model on a scenario",
             response_class=JSON, responses=CSV_RESPONSES)
def simulate_endpoint(req: SimulateRequest, request: Request):
    # the limits are read here rather than through ``LimitsDep``: a plain (sync)
    # dependency costs a hop through the thread pool on every request
    model = parse_model(req.model)
    scen = parse_scenario(req.scenario, model, request.app.state.settings.limits)
    res = simulate(model, scen)
    out = _result(res, req.series)
    if wants_csv(request):
        from pneucore.export import simulation_csv
        return csv_response(simulation_csv(out), "simulation.csv")
    return JSON(out)


@router.post("/heat-models", summary="One scenario under several heat models (paper Fig. 8, 11)",
             response_class=JSON, response_model=HeatModelsResponse)
def heat_models_endpoint(req: HeatModelsRequest, limits: LimitsDep):
    model = parse_model(req.model)
    scen = parse_scenario(req.scenario, model, limits)
    out = {name: _result(simulate(with_heat_model(model, name), scen), req.series)
           for name in check_heat_models(req.heat_models)}
    return JSON({"runs": out})
