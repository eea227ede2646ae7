"""The routers' dependencies (``Annotated[..., Depends()]``: the store, the jobs, the limits)
and the request parsing :mod:`app.services` builds on: pydantic input -> validated pneucore
objects (model, scenario, experiments) within the API's limits, a FieldError's path placed
under the request's field."""
from __future__ import annotations

from typing import Annotated

from fastapi import Depends, HTTPException, Request

from pneucore.data.experiment import as_experiments
from pneucore.description.model import Model, check_resolvable
from pneucore.description.scenario import Scenario
from pneucore.description.validation import FieldError

from .config import Limits, Settings
from .jobs import JobManager
from .store import Store


def get_store(request: Request) -> Store:
    return request.app.state.store


def get_jobs(request: Request) -> JobManager:
    return request.app.state.jobs


def get_limits(request: Request) -> Limits:
    return request.app.state.settings.limits


def get_settings(request: Request) -> Settings:
    return request.app.state.settings


StoreDep = Annotated[Store, Depends(get_store)]
JobsDep = Annotated[JobManager, Depends(get_jobs)]
LimitsDep = Annotated[Limits, Depends(get_limits)]
SettingsDep = Annotated[Settings, Depends(get_settings)]


class PrefixedFieldError(FieldError):
    """A pneucore FieldError whose path is placed under a request field (e.g. ``model.``)."""


def prefixed(exc: FieldError, prefix: str) -> FieldError:
    path = f"{prefix}.{exc.path}" if prefix and not exc.path.startswith(prefix + ".") and \
        exc.path != prefix else exc.path
    return PrefixedFieldError(path, exc.detail)


def parse_model(model_in, prefix="model") -> Model:
    """Pydantic model -> validated pneucore Model (FieldError paths prefixed)."""
    d = model_in.model_dump(exclude_none=True) if hasattr(model_in, "model_dump") else model_in
    try:
        return Model.from_dict(d)
    except FieldError as exc:
        raise prefixed(exc, prefix) from None


def parse_scenario(scen_in, model, limits: Limits, prefix="scenario") -> Scenario:
    """Pydantic scenario -> validated Scenario within the API limits."""
    d = scen_in.plain() if hasattr(scen_in, "plain") else dict(scen_in)
    try:
        scen = Scenario.from_dict(d, model)
    except FieldError as exc:
        raise prefixed(exc, prefix.rsplit(".", 1)[0] if prefix != "scenario" else "") from None
    check_scenario_limits(scen, limits, prefix)
    check_resolvable(model, scen.solver.rtol, scen.solver.max_step, "model.jack.moving_mass")
    return scen


def check_scenario_limits(scen, limits: Limits, prefix="scenario"):
    if scen.duration > limits.max_duration:
        raise FieldError(f"{prefix}.duration", f"{scen.duration:g} s exceeds the API limit of "
                                              f"{limits.max_duration:g} s")
    from pneucore.simulate import CYCLIC_MAX_CYCLES, output_samples
    if scen.start == "cyclic" and scen.duration * CYCLIC_MAX_CYCLES > limits.max_duration:
        # the cyclic steady state repeats the cycle up to CYCLIC_MAX_CYCLES times
        raise FieldError(f"{prefix}.start", f"a cyclic start repeats the {scen.duration:g} s cycle "
                                            f"up to {CYCLIC_MAX_CYCLES} times, beyond the API "
                                            f"limit of {limits.max_duration:g} s simulated; "
                                            f"shorten the cycle to "
                                            f"{limits.max_duration / CYCLIC_MAX_CYCLES:g} s [s]")
    n = output_samples(scen.duration, scen.sample_period)   # what the run would produce
    if n > limits.max_samples:
        raise FieldError(f"{prefix}.sample_period", f"{n} samples exceed the API limit of "
                                                   f"{limits.max_samples}")
    if len(scen.command) > limits.max_command_points:
        raise FieldError(f"{prefix}.command", f"{len(scen.command)} breakpoints exceed the API limit "
                                             f"of {limits.max_command_points}")
    scen.solver.max_steps = min(scen.solver.max_steps, limits.max_steps)


def parse_experiments(exps_in, model: Model, store: Store, limits: Limits):
    """Pydantic experiments -> pneucore Experiments (datasets resolved), within limits."""
    if len(exps_in) == 0:
        raise FieldError("experiments", "at least one experiment is required")
    if len(exps_in) > limits.max_experiments:
        raise FieldError("experiments", f"{len(exps_in)} experiments exceed the API limit of "
                                        f"{limits.max_experiments}")
    raw = []
    for i, e in enumerate(exps_in):
        d = e.model_dump(exclude_none=True) if hasattr(e, "model_dump") else dict(e)
        if d.get("dataset_id") is not None and d.get("scenario") is None:
            info = store.checked_dataset_info(d["dataset_id"])   # damaged: 409
            if info is not None:
                d["scenario"] = info["scenario"]
            if info is not None and not d.get("name"):
                d["name"] = info["name"]
        raw.append(d)
    exps = as_experiments(raw, model.ambient.pressure, datasets=store.measurement)
    from pneucore.data.measurement import MeasurementError
    total = sum(e.measurement.n for e in exps)
    if total > limits.max_analysis_samples:
        raise FieldError("experiments", f"{total} measured samples exceed the API limit of "
                                        f"{limits.max_analysis_samples}")
    seconds = 0.0
    for i, e in enumerate(exps):
        try:
            m = e.model_for(model)   # with this experiment's load and supply pressure
            scen = e.scenario_for(m)
        except FieldError as exc:
            raise prefixed(exc, f"experiments[{i}]") from None
        except MeasurementError as exc:
            exc.where = f"experiments[{i}].measurement"   # the handler places it in the request
            raise
        check_scenario_limits(scen, limits, f"experiments[{i}].scenario")
        check_resolvable(m, scen.solver.rtol, scen.solver.max_step, "model.jack.moving_mass")
        seconds += scen.duration
        if seconds > limits.max_analysis_seconds:
            raise FieldError("experiments", f"{seconds:g} s of records (simulated time over all "
                                            f"experiments) exceed the API limit of "
                                            f"{limits.max_analysis_seconds:g} s")
    return exps


def not_found(what, key):
    return HTTPException(status_code=404, detail=f"{what} {key!r} not found")
