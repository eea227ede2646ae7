"""A bounded pool for the synchronous analyses (compare, calibrate, diagnose, refine, reports).

Each request of these routes is admitted before its body's work takes a thread: at most
``Limits.sync_workers`` run at once, at most ``Limits.max_sync_queue`` more wait for one of
them (on the event loop, holding no thread), and any further one is answered 429 at once
with ``Retry-After``. The threads that answer every other request (reads, uploads) are
never all taken by analyses: 40 concurrent diagnoses used to fill the server's thread
pool, so that a plain ``GET /api/datasets/{id}`` waited about a minute behind them.

Work whose client went away is not done: a waiting request whose client closed its
connection leaves the queue without starting, and a running one is told at its next
progress callback (:func:`app.services.deadline_progress`), which raises
:class:`ClientGone` (a :class:`pneucore.progress.Cancelled`: the analysis stops at once).
The request's time limit (``Limits.request_time_limit``) counts from its admission, the
time it waited in the queue included: a request that waited past it is answered 504
without starting.
"""
from __future__ import annotations

import asyncio
import contextvars
import threading
import time
from contextlib import asynccontextmanager

from fastapi import Depends, HTTPException, Request

from pneucore.progress import Cancelled

from .analysis_memory import budget_of_request


class ClientGone(Cancelled):
    """The client of a synchronous analysis closed its connection: the work stops (the
    answer, 499 as nginx names it, reaches no one but the access log)."""


class Ticket:
    """One admitted analysis: when it was admitted and whether its client is gone.

    Parameters
    ----------
    admitted : float
        ``time.monotonic()`` at admission [s]
    """

    def __init__(self, admitted):
        self.admitted = admitted
        self.started = None            # time.monotonic() when it got a worker [s]
        self.gone = threading.Event()  # set on the event loop, read by the worker thread

    def waited(self):
        """Time spent in the queue [s]."""
        return (self.started if self.started is not None else time.monotonic()) - self.admitted


#: The ticket of the analysis this context (the request's task, then its worker thread, which
#: gets a copy of the task's context) runs; None outside the pool
CURRENT = contextvars.ContextVar("pneucore_sync_ticket", default=None)


async def _disconnected(receive):
    """Return once the client has closed its connection. Called after the body is read (FastAPI
    reads it before a route's dependencies run): what ``receive`` gives then is the disconnect."""
    while (await receive())["type"] != "http.disconnect":
        pass


#: Seconds a client refused for a full queue is told to wait before it tries again
#: (``Retry-After``): about two diagnoses of a typical size (1-2 s each) ahead of it
RETRY_AFTER_S = 5


class SyncPool:
    """Admission of the synchronous analyses: ``workers`` at once, ``queue`` more waiting.

    Created on the event loop that serves the app (its lifespan).

    Parameters
    ----------
    workers : int
        Analyses run at once [-]
    queue : int
        Analyses admitted to wait for a free worker [-]; beyond, 429
    """

    def __init__(self, workers, queue, time_limit=None):
        self.workers = int(workers)
        self.queue = int(queue)
        self.time_limit = time_limit
        self.admitted = 0   # running + waiting; changed only on the event loop
        self._slots = asyncio.Semaphore(self.workers)

    @asynccontextmanager
    async def slot(self, what, receive=None):
        """An async context manager around one analysis, giving its :class:`Ticket`; raises 429
        when the queue is full, :class:`ClientGone` when the client leaves while it waits, and
        a 504 (:class:`app.jobs.JobTimeout`) when it waits past ``time_limit``.

        Parameters
        ----------
        what : str
            The path of the same work as a job, named in the 429
        receive : callable or None
            The request's ASGI ``receive`` (its body already read), watched for the client's
            disconnect; None: not watched
        """
        if self.admitted >= self.workers + self.queue:
            raise HTTPException(429, (
                f"too many synchronous analyses: {self.workers} running and {self.queue} waiting "
                f"(GET /api/limits: sync_workers, max_sync_queue); try again in {RETRY_AFTER_S} s "
                f"or use POST {what}"), headers={"Retry-After": str(RETRY_AFTER_S)})
        ticket = Ticket(time.monotonic())
        self.admitted += 1
        acquire = watcher = None
        owned = False   # whether this request holds a worker's slot
        try:
            acquire = asyncio.ensure_future(self._slots.acquire())
            if receive is not None:
                watcher = asyncio.ensure_future(_disconnected(receive))
            waits = {acquire} if watcher is None else {acquire, watcher}
            await asyncio.wait(waits, timeout=self.time_limit, return_when=asyncio.FIRST_COMPLETED)
            owned = acquire.done() and not acquire.cancelled()
            if watcher is not None and watcher.done() and not watcher.cancelled() \
                    and watcher.exception() is None:
                ticket.gone.set()
            if ticket.gone.is_set():
                raise ClientGone(f"the client left while its analysis waited "
                                 f"{ticket.waited():.1f} s for a worker; it never started")
            if not owned:
                from .jobs import JobTimeout
                raise JobTimeout(f"the analysis waited {ticket.waited():.0f} s for a worker, past "
                                 f"the request time limit of {self.time_limit:g} s "
                                 f"(GET /api/limits: request_time_limit, sync_workers); it never "
                                 f"started; use POST {what}")
            ticket.started = time.monotonic()
            if watcher is not None:   # the client leaving from now on: told at the next progress
                watcher.add_done_callback(
                    lambda t: t.cancelled() or t.exception() is not None or ticket.gone.set())
            token = CURRENT.set(ticket)
            try:
                yield ticket
            finally:
                try:
                    CURRENT.reset(token)
                except ValueError:   # exited in another context: the request's task ends anyway
                    pass
        finally:
            if watcher is not None:
                watcher.cancel()
            if owned:
                self._slots.release()
            elif acquire is not None and not acquire.cancel() and not acquire.cancelled():
                self._slots.release()   # granted meanwhile (a cancelled wait gives it back itself)
            self.admitted -= 1


def _admitted(what):
    async def admission(request: Request):
        async with request.app.state.sync_pool.slot(what, request.receive):
            # the analysis holds its memory estimate once its records are read (in its worker
            # thread, which gets a copy of this context: app.analysis_memory.admitted)
            with budget_of_request(getattr(request.app.state, "memory", None)):
                yield
    return admission


def sync_slot(what):
    """The route dependency that admits one analysis to the pool.

    Parameters
    ----------
    what : str
        The path of the same work as a job (``/api/jobs/diagnose``), named in the 429
    """
    return Depends(_admitted(what))
