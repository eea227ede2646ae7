"""Background jobs for long work (diagnosis, calibration, studies): id, progress, result, time limit.

Analysis jobs and robustness studies run on separate thread pools
(:data:`POOLS`), so a diagnosis never waits behind studies. Every job is also a
record in the SQLite store (:class:`app.store.Store`, table ``jobs``): written
when queued, started and finished, and its progress at most every
:data:`PROGRESS_WRITE_S` seconds. A job that was queued or running when the
server died reads ``"interrupted"`` at the next start, with the progress and
step it had reached, instead of 404.
"""
from __future__ import annotations

import threading
import time
import traceback
import uuid
from concurrent.futures import ThreadPoolExecutor

from pneucore.progress import Cancelled

#: Seconds between two writes of a running job's progress to the store
PROGRESS_WRITE_S = 0.5

#: Job kinds with a pool of their own, and that pool's thread count (other kinds run on the
#: analysis pool). A study runs its own process pool; its thread only feeds and stores it.
POOLS = {"study": 2}

#: Seconds past its time limit after which the watchdog ends a job that has not stopped by
#: itself (work checks its limit at each progress report; this holds when none comes)
WATCHDOG_GRACE_S = 1.0

#: Job states; ``interrupted`` = the server stopped while the job was queued or running
STATUSES = ("queued", "running", "done", "error", "interrupted")


class JobTimeout(Cancelled):
    """The job ran past its wall-time limit."""


class ServerStopping(Cancelled):
    """The service is shutting down; running jobs stop at their next progress report."""


class Job:
    def __init__(self, kind, time_limit):
        self.id = uuid.uuid4().hex[:12]
        self.kind = kind
        self.status = "queued"
        self.progress = 0.0
        self.step = "queued"
        self.result = None
        self.error = None
        self.created = time.time()
        self.started = None
        self.finished = None
        self.time_limit = time_limit
        self.manager = None
        self._written = 0.0

    def report(self, fraction, step):
        """Progress callback handed to pneucore; also enforces the time limit and shutdown."""
        self.progress = float(max(self.progress, min(fraction, 1.0)))
        self.step = str(step)
        m = self.manager
        if m is not None and time.monotonic() - self._written > PROGRESS_WRITE_S:
            self._written = time.monotonic()
            m.record(self)
        if m is not None and m.stopping:
            raise ServerStopping(f"the service is stopping (the {self.kind} job was at: {step})")
        if self.started and time.time() - self.started > self.time_limit:
            raise JobTimeout(f"the {self.kind} job exceeded its time limit of {self.time_limit:g} s "
                             f"(at step: {step})")

    def to_dict(self, with_result=True):
        d = {"id": self.id, "kind": self.kind, "status": self.status, "progress": self.progress,
             "step": self.step, "error": self.error, "created": self.created,
             "started": self.started, "finished": self.finished}
        if with_result:
            d["result"] = self.result
        return d


class JobRecord:
    """A job read back from the store (finished long ago, or interrupted by a server stop)."""

    def __init__(self, d):
        self.__dict__.update(d)

    def to_dict(self, with_result=True):
        d = dict(self.__dict__)
        if not with_result:
            d.pop("result", None)
        return d


class JobManager:
    """Runs jobs on thread pools (the compiled core releases the GIL), one per kind in POOLS.

    Parameters
    ----------
    workers : int
        Threads of the analysis pool [-]
    max_jobs : int
        Queued or running jobs, all kinds together [-]
    time_limit : float
        Default wall-time limit of a job [s]
    store : app.store.Store or None
        Where job records are kept (None = memory only)
    memory : app.analysis_memory.MemoryBudget or None
        The analyses' memory budget, shared with the synchronous ones: a job given an estimate
        (:meth:`submit`'s ``memory``) waits in the queue until it fits (None = not counted)
    """

    def __init__(self, workers=1, max_jobs=16, time_limit=300.0, store=None, memory=None):
        self.memory = memory
        self.pool = ThreadPoolExecutor(workers, thread_name_prefix="pneucore-job")
        self.pools = {kind: ThreadPoolExecutor(n, thread_name_prefix=f"pneucore-{kind}")
                      for kind, n in POOLS.items()}
        self.jobs = {}
        self.max_jobs = max_jobs
        self.time_limit = time_limit
        self.store = store
        self.stopping = False
        self._lock = threading.Lock()
        self._stop = threading.Event()
        if store is not None:
            self._interrupt_stored()   # what a previous server left queued or running
        threading.Thread(target=self._watch, name="pneucore-job-watchdog", daemon=True).start()

    def _watch(self, period=0.25):
        """End every running job past its time limit (+ :data:`WATCHDOG_GRACE_S`), reported or not.

        The job's record says so at once and its thread's late result is dropped; the thread
        itself runs on until its work returns (a simulation is bounded by its step budget).
        """
        while not self._stop.wait(period):
            now = time.time()
            for job in list(self.jobs.values()):
                late = job.status == "running" and job.started is not None and \
                    now - job.started > job.time_limit + WATCHDOG_GRACE_S
                if late:
                    with self._lock:
                        if job.status != "running":
                            continue
                        job.error = (f"the {job.kind} job exceeded its time limit of "
                                     f"{job.time_limit:g} s (at step: {job.step})")
                        job.step = "timed out"
                        job.finished = now
                        job.status = "error"
                    self.record(job, result=True)

    def active(self):
        return sum(1 for j in self.jobs.values() if j.status in ("queued", "running"))

    #: Finished jobs kept in memory for polling (older ones are read from the store)
    KEEP_FINISHED = 200

    def _prune(self):
        done = [j for j in self.jobs.values() if j.status in ("done", "error")]
        for j in sorted(done, key=lambda j: j.finished or 0)[:max(0, len(done) - self.KEEP_FINISHED)]:
            del self.jobs[j.id]

    def record(self, job, result=False):
        """Write the job's state (and its result when ``result``) to the store."""
        if self.store is None:
            return
        try:
            self.store.save_job(job.to_dict(with_result=result))
        except Exception as exc:  # a record that cannot be written must not fail the job
            print(f"pneucore: job {job.id} record not written: {type(exc).__name__}: {exc}")

    def submit(self, kind, fn, time_limit=None, memory=0):
        """Queue ``fn(job)``; returns the job. Raises RuntimeError when the queue is full.

        ``memory``: the job's memory estimate [bytes] (:mod:`app.analysis_memory`), held on the
        manager's budget while it runs; the job stays ``queued``, its step saying it waits for
        memory, until the estimate fits, and a server stopping meanwhile ends it
        ``interrupted``. Its time limit counts from its start."""
        with self._lock:
            self._prune()
            if self.active() >= self.max_jobs:
                raise RuntimeError(f"too many jobs queued or running (limit {self.max_jobs})")
            job = Job(kind, time_limit or self.time_limit)
            job.manager = self
            self.jobs[job.id] = job
        self.record(job)

        def run():
            budget = self.memory if memory else None
            if budget is not None:
                def waiting(text):
                    job.step = text
                    self.record(job)
                if not budget.wait_for(memory, waiting, stop=lambda: self.stopping):
                    with self._lock:
                        job.error = f"the service stopped while the {kind} job waited for memory"
                        job.finished = time.time()
                        job.status = "interrupted"
                    self.record(job, result=True)
                    return
            try:
                work()
            finally:
                if budget is not None:
                    budget.release(memory)

        def work():
            job.status = "running"
            job.started = time.time()
            job.step = "started"
            self.record(job)
            # the status is written last, so a poll never sees "done" without its result
            try:
                result = fn(job)
                with self._lock:
                    if job.status != "running":   # ended by the watchdog: the late result is dropped
                        return
                    job.result = result
                    job.progress = 1.0
                    job.step = "done"
                    job.finished = time.time()
                    job.status = "done"
            except ServerStopping as exc:
                with self._lock:
                    if job.status != "running":
                        return
                    job.error = str(exc)
                    job.finished = time.time()
                    job.status = "interrupted"
            except Exception as exc:  # the job reports its error; the server keeps going
                with self._lock:
                    if job.status != "running":
                        return
                    job.error = str(exc) if not isinstance(exc, (KeyError,)) else repr(exc)
                    job.trace = traceback.format_exc(limit=3)
                    job.step = "failed"
                    job.finished = time.time()
                    job.status = "error"
            self.record(job, result=True)

        self.pools.get(kind, self.pool).submit(run)
        return job

    def get(self, jid):
        """The job (in memory), else its stored record as a dict, else None."""
        job = self.jobs.get(jid)
        if job is not None or self.store is None:
            return job
        rec = self.store.job(jid)
        return None if rec is None else JobRecord(rec)

    def latest_for_study(self, study_id):
        """The most recent job of a robustness study, if any."""
        js = [j for j in self.jobs.values() if getattr(j, "study_id", None) == study_id]
        return max(js, key=lambda j: j.created) if js else None

    def shutdown(self):
        """Stop: queued jobs are dropped, running ones stop at their next progress report."""
        self.stopping = True
        self._stop.set()
        for pool in (self.pool, *self.pools.values()):
            pool.shutdown(wait=False, cancel_futures=True)
        for pool in (self.pool, *self.pools.values()):
            pool.shutdown(wait=True)
        if self.store is not None:
            self._interrupt_stored()

    def _interrupt_stored(self):
        """Mark the stored jobs left queued or running as interrupted; a store that cannot be
        written (a full disk) is reported and the service goes on: those records are marked
        at the next start."""
        try:
            self.store.interrupt_jobs()
        except Exception as exc:
            print(f"pneucore: stored jobs not marked interrupted: {type(exc).__name__}: {exc}")
