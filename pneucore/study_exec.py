"""Running a robustness study: batched tasks on a local process pool or a Dask cluster.

Each task receives the study's canonical JSON and a list of run indices,
regenerates those runs' parameter sets from the seed
(:meth:`pneucore.study_def.Study.values`), simulates them and returns one
row per run; nothing larger than the definition is shipped. The calling
process writes each finished batch into SQLite in one transaction
(``INSERT OR REPLACE`` keyed by run index), so:

* a killed Dask worker loses nothing: the scheduler reschedules its tasks
  and the client only writes what comes back;
* a killed local pool worker breaks the pool: it is restarted (at most
  :data:`MAX_POOL_RESTARTS` times per call) and the unfinished batches are
  resubmitted;
* a killed or interrupted caller leaves every finished batch stored:
  ``run_study(study_id=...)`` later computes only the missing run indices.
  A caller killed outright leaves the status ``running``; whoever restarts
  (e.g. a server at start-up) resumes such studies. Two calls must not run
  the same study id at the same time (nothing locks it; rows would only be
  written twice, identically).

The local pool *spawns* its workers (safe when the caller has threads, as
a web server does): the caller's ``__main__`` must be import-safe (guarded
by ``if __name__ == "__main__"``, or a package ``__main__``). Dask workers
need pneucore importable (installed, or on their ``sys.path``).
"""
from __future__ import annotations

import concurrent.futures as cf
import math
import multiprocessing
import os
import re
import socket
import time
import uuid
from concurrent.futures.process import BrokenProcessPool

from . import study_store as store
from .simulate import simulate
from .study_def import MAX_RUNS, Study
from .study_metrics import run_metrics
from .validation import FieldError

#: Environment variable naming a Dask scheduler address (used when ``scheduler`` is None)
ENV_SCHEDULER = "PNEUCORE_DASK_SCHEDULER"
#: Time allowed to reach the Dask scheduler (and for it to have a worker) [s]
SCHEDULER_TIMEOUT = 5.0
#: Largest automatic batch (runs per task)
MAX_AUTO_BATCH = 250
#: Local pool restarts allowed per call after a worker process died
MAX_POOL_RESTARTS = 3
#: Submissions of one batch allowed on Dask when the task itself errors (not a run failure)
MAX_TASK_ATTEMPTS = 3
_ID_RE = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")


class SchedulerError(FieldError):
    """The Dask scheduler cannot be used (unreachable, no workers, dask missing); path ``scheduler``."""


class StudyInterrupted(RuntimeError):
    """The study stopped before all runs were stored (resume with ``run_study(study_id=...)``)."""


# -- worker side ------------------------------------------------------------------------
_STUDIES = {}


def _study_for(text):
    """The parsed study of a definition text (kept per process: a worker parses it once)."""
    s = _STUDIES.get(text)
    if s is None:
        if len(_STUDIES) >= 4:
            _STUDIES.clear()
        s = Study.from_json(text)
        s.values()
        _STUDIES[text] = s
    return s


def run_batch(study_json, indices):
    """Simulate runs ``indices`` of a study (the task body, in a worker process).

    Returns
    -------
    rows : list of ``(index, params, metrics or None, error or None)``
        A run whose model is invalid or whose simulation fails records its
        error message (``"SimulationError: ..."``) and no metrics.
    """
    study = _study_for(study_json)
    names = study.metric_names
    rows = []
    for i in indices:
        i = int(i)
        params = study.run_values(i)
        try:
            res = simulate(study.run_model(i), study.scenario)
            rows.append((i, params, run_metrics(res, names), None))
        except Exception as exc:  # recorded per run; the batch goes on
            rows.append((i, params, None, f"{type(exc).__name__}: {exc}"))
    return rows


def _init_worker():
    import pneucore.simulate  # noqa: F401  (numba loads its on-disk cache at the first call)


# -- engines ------------------------------------------------------------------------------
class _InlineEngine:
    """``workers=0``: run the batches in the calling process, one at a time."""
    name = "inline (calling process)"
    n_slots = 1

    class _Task:
        def __init__(self, args):
            self.args, self.out, self.exc = args, None, None

    def submit(self, text, indices, key):
        return self._Task((text, indices))

    def wait_first(self, pending):
        task = next(iter(pending))
        try:
            task.out = run_batch(*task.args)
        except Exception as exc:
            task.exc = exc
        return [task]

    def result(self, task):
        if task.exc is not None:
            raise task.exc
        return task.out

    def retry(self, task, exc, attempts):
        return False

    def cancel(self, pending):
        pass

    def close(self):
        pass


class _LocalEngine:
    """``concurrent.futures.ProcessPoolExecutor`` (spawned processes: safe with threads in the caller)."""

    def __init__(self, workers):
        self.workers = workers
        self.restarts = 0
        self.name = f"local process pool ({workers} worker{'s' if workers > 1 else ''})"
        self.n_slots = workers
        self._start()

    def _start(self):
        self.pool = cf.ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"),
                                           initializer=_init_worker)
        self.generation = getattr(self, "generation", -1) + 1

    def submit(self, text, indices, key):
        f = self.pool.submit(run_batch, text, indices)
        f.generation = self.generation
        return f

    def wait_first(self, pending):
        return cf.wait(list(pending), return_when=cf.FIRST_COMPLETED).done

    def result(self, f):
        return f.result()

    def retry(self, f, exc, attempts):
        if not isinstance(exc, BrokenProcessPool):
            return False
        if f.generation == self.generation:  # the current pool broke: start a new one
            if self.restarts >= MAX_POOL_RESTARTS:
                return False
            self.restarts += 1
            self.pool.shutdown(wait=False, cancel_futures=True)
            self._start()
        return True

    def cancel(self, pending):
        for f in pending:
            f.cancel()

    def close(self):
        self.pool.shutdown(wait=True, cancel_futures=True)


class _DaskEngine:
    """A ``dask.distributed.Client``: the scheduler places, retries and reschedules tasks."""

    def __init__(self, client, owned, address):
        self.client, self.owned = client, owned
        self._done = None  # distributed.as_completed over every submitted future
        info = client.scheduler_info()
        workers = info.get("workers", {})
        self.n_slots = max(1, sum(int(w.get("nthreads", 1)) for w in workers.values()))
        nw, nt = len(workers), self.n_slots
        self.name = (f"dask.distributed at {address} ({nw} worker{'s' if nw != 1 else ''}, "
                     f"{nt} thread{'s' if nt != 1 else ''})")

    def submit(self, text, indices, key):
        from distributed import as_completed
        f = self.client.submit(run_batch, text, indices, key=key, pure=False)
        if self._done is None:
            self._done = as_completed([f], loop=self.client.loop)
        else:
            self._done.add(f)
        return f

    def wait_first(self, pending):
        return [next(self._done)]

    def result(self, f):
        try:
            return f.result()
        finally:
            f.release()

    def retry(self, f, exc, attempts):
        return attempts < MAX_TASK_ATTEMPTS

    def cancel(self, pending):
        if pending:
            self.client.cancel(list(pending))

    def close(self):
        if self.owned:
            self.client.close()


# -- checks before any work -----------------------------------------------------------------
def default_workers():
    """CPUs available to this process (the local pool's default size)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def connect_scheduler(scheduler, timeout=SCHEDULER_TIMEOUT):
    """A ``distributed.Client`` for ``scheduler`` (an address, a Client or a cluster object).

    Returns ``(client, owned, address)``; raises :class:`SchedulerError`
    (path ``scheduler``) within about ``timeout`` seconds if the scheduler
    cannot be reached or has no worker.
    """
    try:
        import distributed
    except ImportError:
        raise SchedulerError("scheduler", "a Dask scheduler needs dask.distributed: "
                                          "pip install dask distributed") from None
    if isinstance(scheduler, distributed.Client):
        return scheduler, False, getattr(scheduler.scheduler, "address", "client")
    if hasattr(scheduler, "scheduler_address"):  # a cluster object (LocalCluster, ...)
        scheduler = scheduler.scheduler_address
    if not isinstance(scheduler, str) or not scheduler.strip():
        raise SchedulerError("scheduler", f"must be a Dask scheduler address such as "
                                          f"tcp://host:8786, got {scheduler!r}")
    address = scheduler.strip()
    from distributed.comm.addressing import parse_address, parse_host_port
    try:
        scheme, loc = parse_address(address)
        if scheme in ("tcp", "tls"):
            host, port = parse_host_port(loc, 8786)
    except (ValueError, TypeError) as exc:
        raise SchedulerError("scheduler", f"malformed Dask scheduler address {address!r}: {exc}") from None
    if scheme in ("tcp", "tls"):
        try:  # fail fast (a refused connection returns at once) with a plain error
            socket.create_connection((host, port), timeout=timeout).close()
        except OSError as exc:
            raise SchedulerError("scheduler", f"cannot reach the Dask scheduler at {address} "
                                              f"within {timeout:g} s: {exc}") from None
    try:
        client = distributed.Client(address, timeout=timeout, set_as_default=False)
    except Exception as exc:
        raise SchedulerError("scheduler", f"cannot connect to the Dask scheduler at {address} "
                                          f"within {timeout:g} s: {exc}") from None
    try:
        client.wait_for_workers(1, timeout=timeout)
    except Exception:
        client.close()
        raise SchedulerError("scheduler", f"the Dask scheduler at {address} has no worker "
                                          f"(waited {timeout:g} s)") from None
    return client, True, address


def _check_options(workers, batch_size, study_id, scheduler):
    if workers is not None:
        if scheduler is not None:
            raise FieldError("workers", "sets the local pool's size; a Dask cluster has its own "
                                        "workers (leave workers unset with a scheduler)")
        if isinstance(workers, bool) or not isinstance(workers, int) or not 0 <= workers <= 1024:
            raise FieldError("workers", f"must be a whole number in [0, 1024] (0 = run in this "
                                        f"process), got {workers!r}")
    if batch_size is not None:
        if isinstance(batch_size, bool) or not isinstance(batch_size, int) \
                or not 1 <= batch_size <= MAX_RUNS:
            raise FieldError("batch_size", f"must be a whole number in [1, {MAX_RUNS}], got {batch_size!r}")
    if study_id is not None and (not isinstance(study_id, str) or not _ID_RE.match(study_id)):
        raise FieldError("study_id", "must be 1-64 characters among letters, digits, '_', '-' and '.'")


def _open_store(path):
    try:
        return store.connect(path)
    except Exception as exc:
        raise FieldError("store_path", f"cannot open the SQLite store {path!r}: {exc}") from None


def check_run_options(workers=None, batch_size=None, study_id=None, scheduler=None):
    """Check :func:`run_study`'s options without running anything (raises FieldError)."""
    _check_options(workers, batch_size, study_id, scheduler)


def queue_study(study, store_path, study_id=None):
    """Validate ``study`` and store it with status ``queued``; run it later with
    ``run_study(study_id=...)``. Returns the study id.

    Lets a service hand out an id that exists in the store at once, before the
    (possibly queued) work starts.
    """
    study = Study.from_dict(study)
    _check_options(None, None, study_id, None)
    sid = study_id or uuid.uuid4().hex[:12]
    db = _open_store(store_path)
    try:
        if store.get_study(db, sid) is not None:
            raise FieldError("study_id", f"study {sid!r} already exists in the store")
        store.create_study(db, sid, study.to_json(), status="queued")
    finally:
        db.close()
    return sid


# -- the driver ------------------------------------------------------------------------------
def run_study(study=None, store_path=None, scheduler=None, workers=None, batch_size=None,
              progress=None, study_id=None, scheduler_timeout=SCHEDULER_TIMEOUT):
    """Run (or resume) a robustness study; every finished batch is stored as it completes.

    Parameters
    ----------
    study : Study or dict or None  The definition (see :mod:`pneucore.study_def`); may be
        None when resuming a stored ``study_id``
    store_path : str or None  SQLite file (created if needed); None = in memory, and the
        results are returned under ``"results"``
    scheduler : str, distributed.Client, cluster or None  Dask scheduler address (e.g.
        ``tcp://10.0.0.5:8786``), an existing Client (left open) or a cluster object; None =
        ``$PNEUCORE_DASK_SCHEDULER`` if set (and ``workers`` is None), else the local
        process pool; ``"local"`` forces the local pool
    workers : int or None  Local pool size (default: the CPUs available; 0 = run in this
        process); not allowed with a scheduler
    batch_size : int or None  Runs per task (default: enough tasks for 4 per worker slot, at
        most 250 runs each)
    progress : callable or None  ``progress(fraction, step)`` after each stored batch (and
        once before the first); an exception raised there stops the study (status
        ``interrupted``; already stored batches are kept) and propagates
    study_id : str or None  Resume this stored study (only missing run indices are
        computed), or create a new study under this id; None = a new random id
    scheduler_timeout : float  Time allowed to reach the scheduler [s]

    Returns
    -------
    summary : dict  ``id``, ``status``, ``n_runs``, ``computed`` (runs simulated by this
        call), ``already_stored``, ``failed`` (stored runs with an error), ``batches``,
        ``batch_size``, ``engine``, ``wall_time`` [s], ``store_path``; plus ``results``
        (:func:`pneucore.study_results.study_results`) when ``store_path`` is None

    Raises
    ------
    FieldError  Bad definition or options, before any work (``SchedulerError`` for the scheduler)
    StudyInterrupted  Runs could not be completed (pool restarts exhausted, a task failing
        repeatedly); the stored runs remain and the study can be resumed
    """
    t0 = time.perf_counter()
    # ---- every check first: nothing is written before they pass
    if study is not None:
        study = Study.from_dict(study)
    if scheduler is None and workers is None:
        scheduler = os.environ.get(ENV_SCHEDULER) or None
    if isinstance(scheduler, str) and scheduler.strip().lower() == "local":
        scheduler = None
    _check_options(workers, batch_size, study_id, scheduler)
    if study is None and study_id is None:
        raise FieldError("study", "is required (or give the study_id of a stored study to resume)")
    path = store_path if store_path is not None else ":memory:"
    db = _open_store(path)
    try:
        existing = store.get_study(db, study_id) if study_id is not None else None
        if existing is not None:
            stored_study = Study.from_json(existing["definition"])
            if study is not None and study.to_json() != existing["definition"]:
                raise FieldError("study_id", f"study {study_id!r} exists in the store with a "
                                             f"different definition; use a new id")
            study = stored_study
        elif study is None:
            raise FieldError("study_id", f"no study {study_id!r} in the store {path!r}")
        text = study.to_json()
        client = None
        if scheduler is not None:
            client, owned, address = connect_scheduler(scheduler, scheduler_timeout)
            engine_factory = lambda: _DaskEngine(client, owned, address)  # noqa: E731
        else:
            n_workers = default_workers() if workers is None else workers
            engine_factory = (lambda: _LocalEngine(n_workers)) if n_workers > 0 else _InlineEngine
        # ---- work starts
        try:
            sid = study_id or uuid.uuid4().hex[:12]
            if existing is None:
                store.create_study(db, sid, text)
            else:
                store.set_status(db, sid, "running")
        except BaseException:
            if client is not None and owned:
                client.close()
            raise
        return _drive(db, sid, study, text, engine_factory, batch_size, progress, path, t0)
    finally:
        db.close()


def _drive(db, sid, study, text, engine_factory, batch_size, progress, path, t0):
    n = study.n_runs
    done = store.stored_indices(db, sid)
    missing = [i for i in range(n) if i not in done]
    report = progress or (lambda f, s: None)
    n_done = len(done)
    computed = 0
    engine = None
    pending = {}
    summary = {"id": sid, "n_runs": n, "already_stored": n_done, "store_path": path}
    status = "interrupted"
    try:
        engine = engine_factory()
        size = batch_size or max(1, min(MAX_AUTO_BATCH, math.ceil(len(missing) / (4 * engine.n_slots))))
        batches = [missing[k:k + size] for k in range(0, len(missing), size)]
        summary.update(engine=engine.name, batch_size=size, batches=len(batches))
        report(n_done / n, f"{n_done}/{n} runs stored; {len(missing)} to compute in "
                           f"{len(batches)} batches on {engine.name}")
        attempts = {}
        for k, b in enumerate(batches):
            pending[engine.submit(text, b, f"pneucore-study-{sid}-{k}-{uuid.uuid4().hex[:8]}")] = k
        while pending:
            for f in engine.wait_first(pending):
                k = pending.pop(f)
                try:
                    rows = engine.result(f)
                except Exception as exc:
                    attempts[k] = attempts.get(k, 1) + 1
                    if not engine.retry(f, exc, attempts[k] - 1):
                        raise StudyInterrupted(
                            f"batch of runs {batches[k][0]}-{batches[k][-1]} could not be computed "
                            f"({type(exc).__name__}: {exc}); {n_done}/{n} runs are stored, resume "
                            f"with study_id={sid!r}") from exc
                    key = f"pneucore-study-{sid}-{k}-{uuid.uuid4().hex[:8]}"
                    pending[engine.submit(text, batches[k], key)] = k
                    continue
                store.write_runs(db, sid, rows)
                n_done += len(rows)
                computed += len(rows)
                report(n_done / n, f"{n_done}/{n} runs stored")
        status = "done"
    finally:
        if engine is not None:
            if status != "done":
                engine.cancel(list(pending))
            engine.close()
        stored, failed = store.count_runs(db, sid)
        if stored >= n:
            status = "done"
        store.set_status(db, sid, status)
    summary.update(status=status, computed=computed, failed=failed,
                   wall_time=time.perf_counter() - t0)
    if path == ":memory:":
        from .study_results import results_from_db
        summary["results"] = results_from_db(db, sid)
    return summary
