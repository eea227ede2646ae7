"""POST /api/simulate and /api/simulate/heat-models.

The work (the request checked, the run, the result as JSON) is
:func:`app.services.simulation`'s; this router chooses where it runs and answers
in JSON or CSV.

A small simulation (the paper's cases: a few hundred solver steps, about a
millisecond of work) asked while no other request is in progress is answered
directly on the event loop: a hop through the thread pool and back costs more
than the work (server CPU per request 1.3 against 1.7 ms). Everything else runs
in a worker thread: a long run never blocks the loop that serves every other
client, and while other requests are in progress the solver (compiled without
the GIL) runs beside the loop's work on the second core, where one loop thread
would serve them one after the other on one core (and, on a shared machine, get
one thread's share of the CPU):

* a run is tried on the loop only when it is the only request in progress
  (:func:`app.http_protocol.requests_in_progress`: uvicorn's count; 0 under the
  tests' client), the core is already compiled (never a compilation on the loop),
  the model adds no user terms and names no law registered at run time (a specialised
  core may still need compiling), the
  answer is JSON (not the CSV text, slower to write), and the scenario asks for at
  most :data:`LOOP_MAX_SAMPLES` output samples and :data:`LOOP_MAX_COMMAND_POINTS`
  breakpoints;
* on the loop the solver gets a budget of :data:`LOOP_MAX_STEPS` steps (a few
  milliseconds at most); a run that needs more stops there and is run again, from
  the start and with the request's whole budget, in a worker thread.
"""
from fastapi import APIRouter, Request
from starlette.concurrency import run_in_threadpool

from ..bodies import OffLoopRoute
from ..deps import LimitsDep
from ..http_protocol import requests_in_progress
from ..responses import JSON, CSV_RESPONSES, csv_response, wants_csv
from ..schemas import HeatModelsRequest, HeatModelsResponse, SimulateRequest, SimulateResponse
# integrate and EFFECTS: what the choice of the loop reads; simulate: the run handed to the service
from ..services import (EFFECTS, PastBudget, integrate, names_runtime_law, simulate,
                        simulate_under_heat_models, simulation, simulation_csv)

router = APIRouter(prefix="/api/simulate", tags=["simulate"], route_class=OffLoopRoute)

#: Largest run answered on the event loop: output samples [-] (the answer's size and the
#: result's building and encoding grow with them: about 0.3 ms per 1,000 samples)
LOOP_MAX_SAMPLES = 5_001
#: ... command breakpoints [-] (validating a scenario grows with them)
LOOP_MAX_COMMAND_POINTS = 1_000
#: ... solver steps, accepted and rejected [-]: 2-5 us each for the base core, so at most a few
#: milliseconds on the loop (the paper's cases take 100-200 steps)
LOOP_MAX_STEPS = 1_000


def _loop_candidate(req: SimulateRequest, request: Request = None) -> bool:
    """Whether the request may be tried on the event loop (see the module's notes)."""
    if request is not None and wants_csv(request):   # the CSV text: ~15 ms per 1,000 samples
        return False
    if not integrate.overloads:   # not compiled (or loaded from the cache) yet in this process
        return False
    if any(EFFECTS[n].terms is not None for n in (req.model.effects or {}) if n in EFFECTS):
        return False
    if names_runtime_law(req.model):   # a law registered at run time: its core may need compiling
        return False
    s = req.scenario
    if s.sample_period is None or s.duration is None or s.sample_period <= 0:
        return False
    return s.duration / s.sample_period < LOOP_MAX_SAMPLES - 1 and \
        len(s.command or ()) <= LOOP_MAX_COMMAND_POINTS


def _answer(req: SimulateRequest, request: Request, limits, on_loop=False):
    out = simulation(req, limits, LOOP_MAX_STEPS if on_loop else None, run=simulate)
    if wants_csv(request):
        return csv_response(simulation_csv(out), "simulation.csv")
    return JSON(out)


@router.post("", response_model=SimulateResponse, summary="Simulate a model on a scenario",
             response_class=JSON, responses=CSV_RESPONSES)
async def simulate_endpoint(req: SimulateRequest, request: Request):
    # the limits are read here rather than through ``LimitsDep``: a plain (sync)
    # dependency costs a hop through the thread pool on every request
    limits = request.app.state.settings.limits
    if requests_in_progress() <= 1 and _loop_candidate(req, request):
        try:
            return _answer(req, request, limits, on_loop=True)
        except PastBudget:
            pass
    return await run_in_threadpool(_answer, req, request, limits)


@router.post("/heat-models", summary="One scenario under several heat models (paper Fig. 8, 11)",
             response_class=JSON, response_model=HeatModelsResponse)
def heat_models_endpoint(req: HeatModelsRequest, limits: LimitsDep):
    return JSON(simulate_under_heat_models(req, limits))
