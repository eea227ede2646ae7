"""Background jobs for long work (diagnosis, calibration): id, progress, result, time limit."""
from __future__ import annotations

import threading
import time
import traceback
import uuid
from concurrent.futures import ThreadPoolExecutor


from pneucore.progress import Cancelled


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

    def report(self, fraction, step):
        """Progress callback handed to pneucore; also enforces the time limit and shutdown."""
        self.progress = float(max(self.progress, min(fraction, 1.0)))
        self.step = step
        if self.manager is not None and self.manager.stopping:
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


class JobManager:
    """Runs jobs on a small thread pool (the compiled core releases the GIL)."""

    def __init__(self, workers=1, max_jobs=16, time_limit=300.0):
        self.pool = ThreadPoolExecutor(workers, thread_name_prefix="pneucore-job")
        self.jobs = {}
        self.max_jobs = max_jobs
        self.time_limit = time_limit
        self.stopping = False
        self._lock = threading.Lock()

    def active(self):
        return sum(1 for j in self.jobs.values() if j.status in ("queued", "running"))

    #: Finished jobs kept for polling (the oldest are forgotten beyond this)
    KEEP_FINISHED = 200

    def _prune(self):
        done = [j for j in self.jobs.values() if j.status in ("done", "error")]
        for j in sorted(done, key=lambda j: j.finished or 0)[:max(0, len(done) - self.KEEP_FINISHED)]:
            del self.jobs[j.id]

    def submit(self, kind, fn, time_limit=None):
        """Queue ``fn(job)``; returns the job. Raises RuntimeError when the queue is full."""
        with self._lock:
            self._prune()
            if self.active() >= self.max_jobs:
                raise RuntimeError(f"too many jobs queued or running (limit {self.max_jobs})")
            job = Job(kind, time_limit or self.time_limit)
            job.manager = self
            self.jobs[job.id] = job

        def run():
            job.status = "running"
            job.started = time.time()
            job.step = "started"
            # the status is written last, so a poll never sees "done" without its result
            try:
                result = fn(job)
                job.result = result
                job.progress = 1.0
                job.step = "done"
                job.finished = time.time()
                job.status = "done"
            except Exception as exc:  # the job reports its error; the server keeps going
                job.error = str(exc) if not isinstance(exc, (KeyError,)) else repr(exc)
                job.trace = traceback.format_exc(limit=3)
                job.step = "failed"
                job.finished = time.time()
                job.status = "error"

        self.pool.submit(run)
        return job

    def get(self, jid):
        return self.jobs.get(jid)

    def latest_for_study(self, study_id):
        """The most recent job of a robustness study, if any."""
        js = [j for j in self.jobs.values() if getattr(j, "study_id", None) == study_id]
        return max(js, key=lambda j: j.created) if js else None

    def shutdown(self):
        """Stop: queued jobs are dropped, running ones stop at their next progress report."""
        self.stopping = True
        self.pool.shutdown(wait=True, cancel_futures=True)
