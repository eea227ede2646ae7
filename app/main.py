"""Build the FastAPI app: routers, error handlers, the page and its local plotly.js.

Run with ``python -m app`` (or ``uvicorn app.main:app``; ``python -m app`` also selects
:data:`app.http_protocol.PROTOCOL`, one write per answer); the SQLite file is
``$PNEUCORE_DB`` (default ``./pneucore.sqlite3``).
"""
from __future__ import annotations

import gc
import importlib.util
import html
import logging
import os
import re
import sqlite3
import sys
import threading
from contextlib import asynccontextmanager
from pathlib import Path

import plotly
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse, RedirectResponse
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException as StarletteHTTPException

from pneucore.data.measurement import MeasurementError
from pneucore.simulate import SimulationError, start_warm_up
from pneucore.description.validation import FieldError

from . import docs_site
from .analysis_memory import MemoryBudget, MemoryBusy, limit_malloc_arenas
from .asgi import TrackedSend, send_json
from .bodies import BodyLimit
from .config import LOCAL_HOSTS, Settings
from .express_lane import SimulateExpressLane
from .jobs import JobManager, JobTimeout
from .responses import JSON, document_errors, dumps
from .routers import (analysis, calibration, datasets, effects, heat, jobs, presets, reports, sessions,
                      simulate, studies, units, uploads)
from .routers import friction
from .routers import models
from .routers import identify
from .routers import sizing
from .routers import valve
from .routers import control
from .schemas import NO_CONTROL, LimitsResponse, SampleInfo
from .security import Guard
from .store import DamagedRecord, ServerLock, Store, StoreUnavailable, disk_full, storage_fault
from .sync_pool import ClientGone, SyncPool

# the repository's static/ (a checkout or an editable install), else the copy a wheel
# installs as app/static (see pyproject.toml)
_REPO_STATIC = Path(__file__).resolve().parent.parent / "static"
STATIC_DIR = _REPO_STATIC if (_REPO_STATIC / "index.html").is_file() \
    else Path(__file__).resolve().parent / "static"
PLOTLY_JS = Path(plotly.__file__).parent / "package_data" / "plotly.min.js"
#: Swagger UI and ReDoc bundles shipped by the fastapi-offline package (served at /docs-assets)
DOCS_ASSETS = Path(importlib.util.find_spec("fastapi_offline").origin).parent / "static"


def _loc(path: str):
    out = ["body"]
    for part in path.split("."):
        m = re.fullmatch(r"([^\[\]]*)((?:\[\d+\])*)", part)
        if not m:
            out.append(part)
            continue
        if m.group(1):
            out.append(m.group(1))
        out += [int(i) for i in re.findall(r"\[(\d+)\]", m.group(2))]
    return out


#: Orders a start-up freeze against the shutdown's unfreeze (an app stopped before its core
#: was loaded must not freeze afterwards)
_FREEZE_LOCK = threading.Lock()


def _freeze_start_up_objects(warm_up_thread=None, stopped=None):
    """Once the simulator is loaded, leave the objects of the start-up (modules, the compiled
    core: about 190,000) out of the garbage collector's full collections: one of them scans
    every object in about 0.1 s, a pause of every request in progress (the p95 and the
    worst case of ``benchmarks/bench_api.py``). Objects created later are collected as before.

    Parameters
    ----------
    warm_up_thread : threading.Thread or None
        The warm-up (:func:`pneucore.simulate.start_warm_up`) to wait for
    stopped : threading.Event or None
        Set when the app has shut down: nothing is frozen then
    """
    if warm_up_thread is not None:
        warm_up_thread.join()
    with _FREEZE_LOCK:
        if stopped is None or not stopped.is_set():
            gc.freeze()


def _unfreeze(stopped):
    """The shutdown's half of :func:`_freeze_start_up_objects`."""
    with _FREEZE_LOCK:
        stopped.set()
        gc.unfreeze()


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()
    limit_malloc_arenas()   # before the worker threads (app.analysis_memory.MALLOC_ARENAS)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        # compile (or load) the simulator in the background while the service starts
        warm = start_warm_up()
        stopped = threading.Event()
        threading.Thread(target=_freeze_start_up_objects, args=(warm, stopped), daemon=True,
                         name="pneucore-gc-freeze").start()
        # one server per database (DatabaseInUse: a second server stops before touching it)
        lock = ServerLock(settings.db_path).acquire()
        try:
            store = Store(settings.db_path)   # StoreUnavailable: a clear message (see main)
        except BaseException:
            lock.release()
            raise
        if settings.seed_samples:
            try:
                store.seed_samples()
            except (sqlite3.Error, OSError) as exc:
                if not disk_full(exc):
                    raise
                # a full disk: the service starts and reads; its writes answer 507 until freed
                print(f"pneucore: sample datasets not restored, the disk is full ({exc})")
        app.state.store = store
        # one budget for the synchronous analyses and the jobs (app.analysis_memory)
        app.state.memory = MemoryBudget(settings.limits.analysis_memory_budget)
        app.state.jobs = JobManager(workers=settings.limits.analysis_workers,
                                    max_jobs=settings.limits.max_jobs,
                                    time_limit=settings.limits.job_time_limit, store=store,
                                    memory=app.state.memory)
        app.state.cancelled_studies = set()
        app.state.sync_pool = SyncPool(settings.limits.sync_workers, settings.limits.max_sync_queue,
                                       settings.limits.request_time_limit)
        if settings.resume_studies:
            # studies left queued or running by a stopped server resume where they were
            from pneucore.study import list_studies
            for s in list_studies(settings.db_path):
                if s.get("status") in ("queued", "running"):
                    try:
                        studies.start_study(app.state, settings.db_path, s["id"],
                                            time_limit=settings.limits.study_time_limit)
                    except Exception as exc:  # a full queue must not stop the service
                        print(f"pneucore: study {s['id']} not resumed at start-up: {exc}")
        yield
        app.state.jobs.shutdown()
        store.close()
        lock.release()
        _unfreeze(stopped)

    app = FastAPI(title="pneucore", version="0.1.0", lifespan=lifespan, default_response_class=JSON,
                  docs_url=None, redoc_url=None,
                  description="Design and validation tool for pneumatic actuators (Maré, Geider & "
                              "Colin model): simulate, compare with measurements, diagnose the "
                              "missing physics, calibrate. SI units, absolute pressures. Errors "
                              "(Eq. 25) are fractions, not percent: 0.05 means 5 %.")
    app.state.settings = settings

    # the last added is outermost: the guard answers bad hosts, origins and tokens before a body is read
    app.add_middleware(CatchAll)   # innermost: an unexpected error is an ordinary 500 (see CatchAll)
    app.add_middleware(SimulateExpressLane)   # inside both: small simulations answered on the loop
    app.add_middleware(BodyLimit, limit=settings.limits.max_upload_bytes)
    app.add_middleware(Guard, allowed_hosts=settings.allowed_hosts, token=settings.token)

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException):
        headers = dict(exc.headers or {})
        if exc.status_code == 405:
            # every method of every route at this path, not only the first route's
            headers["Allow"] = ", ".join(_allowed_methods(request.app, request.scope))
        return JSONResponse(status_code=exc.status_code, content={"detail": exc.detail},
                            headers=headers or None)

    @app.exception_handler(FieldError)
    async def field_error(request: Request, exc: FieldError):
        return JSONResponse(status_code=422, content={"detail": [
            {"loc": _loc(exc.path), "msg": exc.detail, "type": "value_error", "field": exc.path}]})

    @app.exception_handler(MeasurementError)
    async def measurement_error(request: Request, exc: MeasurementError):
        where = getattr(exc, "where", "measurement")
        loc = _loc(where) + ([exc.column] if exc.column else []) + \
            ([exc.row] if exc.row is not None else [])
        return JSONResponse(status_code=422, content={"detail": [
            {"loc": loc, "msg": str(exc), "type": "measurement_error", "column": exc.column,
             "row": exc.row, "field": where + (f".{exc.column}" if exc.column else "")}]})

    @app.exception_handler(SimulationError)
    async def simulation_error(request: Request, exc: SimulationError):
        return JSONResponse(status_code=422, content={"detail": [
            {"loc": ["body", "scenario", "solver"], "msg": str(exc), "type": "simulation_error"}]})

    @app.exception_handler(ClientGone)
    async def client_gone(request: Request, exc: ClientGone):
        # nobody reads it: the status (nginx's 499, "client closed request") is for the access log
        return JSONResponse(status_code=499, content={"detail": str(exc)})

    @app.exception_handler(MemoryBusy)
    async def memory_busy(request: Request, exc: MemoryBusy):
        # the analyses running hold the memory budget: nothing started, to be tried again
        return JSONResponse(status_code=503, content=exc.body(),
                            headers={"Retry-After": str(exc.retry_after)})

    @app.exception_handler(JobTimeout)
    async def timeout_error(request: Request, exc: JobTimeout):
        return JSONResponse(status_code=504, content={"detail": str(exc)})

    @app.exception_handler(RequestValidationError)
    async def validation_error(request: Request, exc: RequestValidationError):
        errs = []
        for e in exc.errors():
            if e.get("type") == "string_pattern_mismatch" and (e.get("ctx") or {}).get("pattern") == NO_CONTROL:
                e = dict(e, msg="must not contain a control character (a tab, CR, LF, NUL, ...)")
            e = {k: v for k, v in e.items() if k in ("loc", "msg", "type")}
            field = ""
            for p in e["loc"][1:]:
                field += f"[{p}]" if isinstance(p, int) else (f".{p}" if field else str(p))
            e["field"] = field   # same notation as pneucore's paths: experiments[0].scenario.x0
            errs.append(e)
        return JSONResponse(status_code=422, content={"detail": errs})

    @app.exception_handler(ValueError)
    async def value_error(request: Request, exc: ValueError):
        return JSONResponse(status_code=422, content={"detail": [
            {"loc": ["body"], "msg": str(exc), "type": "value_error"}]})

    @app.exception_handler(DamagedRecord)
    async def damaged_record(request: Request, exc: DamagedRecord):
        # 409 Conflict: the record's stored state, not the request, is what fails (a 422 would
        # blame the request, a 500 the server's code); the message names the record and the remedy
        return JSONResponse(status_code=409, content={"detail": str(exc)})

    @app.exception_handler(sqlite3.Error)
    @app.exception_handler(OSError)
    async def storage_error(request: Request, exc: Exception):
        # an answer of its own, not the generic handler's (whose exception reaches the server,
        # which then resets the kept-alive connection)
        return storage_error_response(exc)

    @app.exception_handler(Exception)
    async def unexpected(request: Request, exc: Exception):
        return JSONResponse(status_code=500, content={"detail": f"internal error: {type(exc).__name__}: {exc}"})

    for r in (presets, effects, heat, simulate, calibration, analysis, reports, uploads, datasets, sessions,
              jobs, studies, units):
        app.include_router(r.router)
    app.include_router(friction.router)
    app.include_router(models.router)
    app.include_router(identify.router)
    app.include_router(identify.jobs_router)
    app.include_router(sizing.router)
    app.include_router(valve.router)
    app.include_router(control.router)

    @app.get("/api/limits", tags=["meta"], summary="The documented size and time limits",
             response_model=LimitsResponse)
    def limits():
        # the limits, and the deployment settings a client needs to know (README: shared server)
        return {**settings.limits.to_dict(), "allowed_hosts": list(settings.allowed_hosts),
                "token_required": settings.token is not None}

    @app.get("/api/samples", tags=["meta"], summary="Sample datasets shipped with the tool",
             response_model=list[SampleInfo])
    def samples():
        from pneucore.data.samples import list_samples
        return list_samples()

    @app.get("/", include_in_schema=False)
    def index():
        return FileResponse(STATIC_DIR / "index.html")

    # /docs and /redoc offline: their assets come from the installed fastapi-offline package
    @app.get("/docs", include_in_schema=False)
    def swagger_docs():
        # FastAPI's own page starts Swagger UI from an inline script, which the service's
        # Content-Security-Policy refuses: the same page with the start in static/swagger-init.js
        url = html.escape(app.openapi_url, quote=True)
        return HTMLResponse(
            '<!DOCTYPE html><html><head><meta charset="utf-8">'
            '<meta name="viewport" content="width=device-width, initial-scale=1.0">'
            '<link rel="stylesheet" href="/docs-assets/swagger-ui.css">'
            '<link rel="icon" href="/favicon.ico"><title>pneucore API</title></head>'
            f'<body><div id="swagger-ui" data-openapi="{url}"></div>'
            '<script src="/docs-assets/swagger-ui-bundle.js"></script>'
            '<script src="/static/swagger-init.js"></script></body></html>')

    # the documentation site, built by mkdocs, with a policy of its own (app.docs_site)
    @app.get("/docs-site", include_in_schema=False)
    def docs_site_root():
        return RedirectResponse(docs_site.PREFIX, status_code=307)

    @app.get("/docs-site/{path:path}", include_in_schema=False)
    def docs_site_page(path: str, request: Request):
        return docs_site.serve(settings.docs_site, path, request.url.path.endswith("/"))

    @app.get("/redoc", include_in_schema=False)
    def redoc_docs():
        from fastapi.openapi.docs import get_redoc_html
        return get_redoc_html(openapi_url=app.openapi_url, title="pneucore API",
                              redoc_js_url="/docs-assets/redoc.standalone.js",
                              redoc_favicon_url="/favicon.ico", with_google_fonts=False)

    @app.get("/favicon.ico", include_in_schema=False)
    def favicon():
        return FileResponse(STATIC_DIR / "favicon.svg", media_type="image/svg+xml")

    app.mount("/docs-assets", StaticFiles(directory=DOCS_ASSETS), name="docs-assets")

    @app.get("/static/plotly.min.js", include_in_schema=False)
    def plotly_js():
        return FileResponse(PLOTLY_JS, media_type="application/javascript")

    if STATIC_DIR.exists():
        app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")
    document_errors(app, settings)
    return app


class CatchAll:
    """ASGI middleware: an exception no handler answered becomes a 500 naming it, sent as an
    ordinary answer, and is logged with its traceback.

    Starlette's handler for ``Exception`` sends its 500 and then raises the exception again
    to the server, and uvicorn closes a connection whose application raised after answering:
    the client's kept-alive connection was reset after every 500. Here the exception ends
    with the answer, and the connection carries the client's next request. An exception
    after the answer has started (a stream broken midway) still reaches the server, which
    must close the connection: the answer is incomplete.
    """

    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        tracked = TrackedSend(send)
        try:
            await self.app(scope, receive, tracked)
        except Exception as exc:
            if tracked.started:
                raise
            logging.getLogger("uvicorn.error").error(
                "Exception in ASGI application (answered 500)", exc_info=exc)
            body = dumps({"detail": f"internal error: {type(exc).__name__}: {exc}"})
            await send_json(send, 500, body)


def storage_error_response(exc):
    """The answer to a database or file error raised by a route.

    A storage fault (:data:`app.store.STORAGE_FAULTS`) answers its status naming the cause and
    the remedy: a full disk (``SQLITE_FULL``, ``ENOSPC``) 507 Insufficient Storage; a database
    locked past the busy timeout 503 with ``Retry-After``; a disk that fails (``disk I/O
    error``), a damaged or read-only database file 503. Anything else is 500 naming it.

    Parameters
    ----------
    exc : sqlite3.Error or OSError
        The error

    Returns
    -------
    fastapi.responses.JSONResponse
    """
    cause = f"{type(exc).__module__}.{type(exc).__name__}: {exc}"
    fault = storage_fault(exc)
    if fault is None:
        return JSONResponse(status_code=500, content={"detail": f"internal error: {cause}"})
    name, _, status, remedy = fault
    busy = name in ("SQLITE_BUSY", "SQLITE_LOCKED")
    return JSONResponse(status_code=status, headers={"Retry-After": "5"} if busy else None,
                        content={"detail": f"{remedy} ({name}; {cause})"})


#: Methods probed for the 405 ``Allow`` header
_METHODS = ("GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS")


def _allowed_methods(app, scope):
    """The methods some route accepts at this path (for the 405 ``Allow`` header)."""
    from starlette.routing import Match
    allowed = []
    for method in _METHODS:
        probe = {**scope, "method": method}
        if any(route.matches(probe)[0] == Match.FULL for route in app.router.routes):
            allowed.append(method)
    return allowed


app = create_app()


def main():
    """Start the service: ``python -m app [--host H] [--port P]``."""
    import argparse

    import uvicorn
    p = argparse.ArgumentParser(description="pneucore web service")
    p.add_argument("--host", default=os.environ.get("PNEUCORE_HOST", "127.0.0.1"))
    p.add_argument("--port", type=int, default=int(os.environ.get("PNEUCORE_PORT", "8000")))
    p.add_argument("--scheduler", default=None, help="Dask scheduler address for studies, the cluster "
                   "requests name 'dask' (default $PNEUCORE_DASK_SCHEDULER; none = the local pool only)")
    a = p.parse_args()
    if a.scheduler:   # read by Settings when uvicorn imports app.main
        os.environ["PNEUCORE_DASK_SCHEDULER"] = a.scheduler
    settings = Settings()
    try:   # a database in use or that cannot be opened: a clear message, not a traceback
        ServerLock(settings.db_path).acquire()   # held until the process ends
        Store(settings.db_path).close()
    except StoreUnavailable as exc:
        sys.exit(f"pneucore: not started: {exc}")
    print(f"pneucore: open http://{a.host}:{a.port}/  (database {settings.db_path})")
    if a.host not in LOCAL_HOSTS and "PNEUCORE_ALLOWED_HOSTS" not in os.environ:
        print("pneucore: only the host names localhost, 127.0.0.1 and ::1 are answered; on a shared "
              "server set PNEUCORE_ALLOWED_HOSTS and PNEUCORE_TOKEN (README: Running on a shared server)")
    from .http_protocol import PROTOCOL   # one write per response (see app.http_protocol)
    lim = settings.limits
    # limits that hold without a reverse proxy (README: Running on a shared server): connections,
    # keep-alive; the head's size and time are the protocol's (app.http_protocol)
    uvicorn.run("app.main:app", host=a.host, port=a.port, workers=1, http=PROTOCOL,
                limit_concurrency=lim.max_connections, timeout_keep_alive=lim.keep_alive_timeout,
                h11_max_incomplete_event_size=lim.max_header_bytes)
