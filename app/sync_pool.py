"""A bounded pool for the synchronous analyses (compare, calibrate, diagnose, refine, reports).

Each request of these routes is admitted before its body's work takes a thread: at most
``Limits.sync_workers`` run at once, at most ``Limits.max_sync_queue`` more wait for one of
them (on the event loop, holding no thread), and any further one is answered 429 at once
with ``Retry-After``. The threads that answer every other request (reads, uploads) are
never all taken by analyses: 40 concurrent diagnoses used to fill the server's thread
pool, so that a plain ``GET /api/datasets/{id}`` waited about a minute behind them.
"""
from __future__ import annotations

import asyncio
from contextlib import asynccontextmanager

from fastapi import Depends, HTTPException, Request

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

    def __init__(self, workers, queue):
        self.workers = int(workers)
        self.queue = int(queue)
        self.admitted = 0   # running + waiting; changed only on the event loop
        self._slots = asyncio.Semaphore(self.workers)

    @asynccontextmanager
    async def slot(self, what):
        """An async context manager around one analysis; raises 429 when the queue is full."""
        if self.admitted >= self.workers + self.queue:
            raise HTTPException(429, (
                f"too many synchronous analyses: {self.workers} running and {self.queue} waiting "
                f"(GET /api/limits: sync_workers, max_sync_queue); try again in {RETRY_AFTER_S} s "
                f"or use POST {what}"), headers={"Retry-After": str(RETRY_AFTER_S)})
        self.admitted += 1
        try:
            async with self._slots:
                yield
        finally:
            self.admitted -= 1


def _admitted(what):
    async def admission(request: Request):
        async with request.app.state.sync_pool.slot(what):
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
