"""Running a robustness study: batched tasks on a local process pool or a Dask cluster.

Each task receives the study's canonical JSON and a list of run indices,
regenerates those runs' parameter sets from the seed
(:meth:`pneucore.study.definition.Study.values`), simulates them and returns the
batch column-wise (:class:`~pneucore.study.store.RunBlock`: a few numpy
arrays, so a batch of 250 runs pickles to ~30 kB and the client unpacks it
at memory speed); nothing larger than the definition is shipped to a
worker. The calling process writes each finished batch into SQLite in one
transaction (``INSERT OR REPLACE`` keyed by run index), so:

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

Nothing waits without a bound. The driver wakes at least every
:data:`HEARTBEAT` seconds even when no batch finishes: it calls ``progress``
again (so a caller's own time limit or cancellation holds), checks
``time_limit``, and on Dask checks the cluster with an independent probe
(:func:`probe_scheduler`): no worker, or no answering scheduler, for
:data:`CLUSTER_GRACE` seconds ends the call with :class:`StudyInterrupted`
and the stored status ``interrupted`` (resume later). Every connection to
a scheduler has an enforced time limit, even against a listener that
accepts and then stays silent.

The local pool starts its workers from a *forkserver* that has already
imported pneucore and loaded the compiled core (:mod:`pneucore.study._worker`):
the first worker of a process pays the imports and the cache load once,
every later worker is a fork of a warm process (tens of milliseconds). It is
safe when the caller has threads (a web server), and the caller's
``__main__`` is never re-imported. Each worker watches the process that
created the pool and exits when it dies (a ``kill -9`` of the server leaves
no orphan). Dask workers need pneucore importable (installed, or on their
``sys.path``).

Addresses: :func:`run_study` and :func:`connect_scheduler` take a scheduler
address from their caller, trusted code. A Dask client unpickles what the
scheduler sends, so a service must never take an address from a request:
the web service takes it from its own configuration only
(``$PNEUCORE_DASK_SCHEDULER`` or ``python -m app --scheduler``) and lets a
request name the configured cluster.
"""
from __future__ import annotations

import asyncio
import concurrent.futures as cf
import functools
import math
import os
import re
import threading
import time
import uuid
from concurrent.futures.process import BrokenProcessPool

import numpy as np

from pneucore.study import store
from pneucore.simulate import simulate
from pneucore.study.definition import MAX_RUNS, Study
from pneucore.study.metrics import run_metrics
from pneucore.description.validation import FieldError

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
#: Longest wait of the driver without checking time limit, cancellation and cluster health [s]
HEARTBEAT = 1.0
#: How long a Dask cluster may have no worker (or its scheduler not answer) before the study stops [s]
CLUSTER_GRACE = 10.0
#: Interval between two probes of a Dask cluster's health during a study [s]
PROBE_INTERVAL = 2.0
_ID_RE = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")


class SchedulerError(FieldError):
    """The Dask scheduler cannot be used (unreachable, no workers, dask missing); path ``scheduler``."""


class StudyInterrupted(RuntimeError):
    """The study stopped before all runs were stored (resume with ``run_study(study_id=...)``)."""


# -- worker side ------------------------------------------------------------------------
@functools.lru_cache(maxsize=4)
def _study_for(text):
    """The parsed study of a definition text, its values drawn (kept per process, the last
    four: a worker parses it once)."""
    s = Study.from_json(text)
    s.values()
    return s


def run_block(study_json, indices):
    """Simulate runs ``indices`` of a study (the task body, in a worker process).

    Returns
    -------
    block : RunBlock
        Parameters and metrics column-wise; a run whose model is invalid or
        whose simulation fails records its error message
        (``"SimulationError: ..."``) and NaN metrics.
    """
    study = _study_for(study_json)
    names = study.metric_names
    idx = np.asarray([int(i) for i in indices], dtype=np.int64)
    P = np.asarray(study.values())[idx] if len(idx) else np.empty((0, len(study.paths)))
    M = np.full((len(idx), len(names)), np.nan)
    errors = []
    for j, i in enumerate(idx.tolist()):
        try:
            if study.controller is not None:
                M[j], error = _closed_loop_run(study, i, names)
                errors.append(error)
                continue
            res = simulate(study.run_model(i), study.scenario)
            m = run_metrics(res, names)
            M[j] = [np.nan if m[k] is None else m[k] for k in names]
            errors.append(None)
        except Exception as exc:  # recorded per run; the batch goes on
            errors.append(f"{type(exc).__name__}: {exc}")
    return store.RunBlock(idx, np.array(P, dtype=float).reshape(len(idx), len(study.paths)), M, errors)


def _closed_loop_run(study, i, names):
    """Run ``i`` of a closed-loop study (:func:`pneucore.control.closed_loop.simulate_closed_loop`
    on the run's model): its metrics (``names``, NaN where undefined) and its error (None; an
    unstable loop or a run stopped early raises :class:`pneucore.control.closed_loop.ControlError`,
    recorded by the caller as ``"ControlError: ..."`` with NaN metrics, like any failed run)."""
    from pneucore.control.closed_loop import simulate_closed_loop

    c = simulate_closed_loop(study.run_model(i), study.scenario, study.controller).stats["control"]
    return [np.nan if c.get(k) is None else float(c[k]) for k in names], None


def run_batch(study_json, indices):
    """Simulate runs ``indices`` of a study, one row per run.

    Returns
    -------
    rows : list of ``(index, params, metrics or None, error or None)``
        ``params`` = ``{path: value}``, ``metrics`` = ``{name: value or None}``;
        a failed run has no metrics and its error message.
    """
    study = _study_for(study_json)
    b = run_block(study_json, indices)
    rows = []
    for j, i in enumerate(b.indices.tolist()):
        params = {p: float(v) for p, v in zip(study.paths, b.params[j])}
        metrics = None if b.errors[j] is not None else \
            {k: store.clean(v) for k, v in zip(study.metric_names, b.metrics[j])}
        rows.append((i, params, metrics, b.errors[j]))
    return rows


# -- engines ------------------------------------------------------------------------------
class _InlineEngine:
    """``workers=0``: run the batches in the calling process, one at a time."""
    name = "inline (calling process)"
    n_slots = 1

    def __init__(self, task=None):
        self.task = task or run_block

    class _Task:
        def __init__(self, args):
            self.args, self.out, self.exc = args, None, None

    def submit(self, text, indices, key):
        return self._Task((text, indices))

    def wait_first(self, pending, timeout):
        task = next(iter(pending))
        try:
            task.out = self.task(*task.args)
        except Exception as exc:
            task.exc = exc
        return [task]

    def result(self, task):
        if task.exc is not None:
            raise task.exc
        return task.out

    def retry(self, task, exc, attempts):
        return False

    def check(self):
        pass

    def cancel(self, pending):
        pass

    def close(self):
        pass


class _LocalEngine:
    """``concurrent.futures.ProcessPoolExecutor`` on a warm forkserver (see the module docstring)."""

    def __init__(self, workers, task=None):
        self.workers = workers
        self.task = task or run_block
        self.restarts = 0
        self.name = f"local process pool ({workers} worker{'s' if workers > 1 else ''})"
        self.n_slots = workers
        self._start()

    def _start(self):
        from pneucore.study import _worker as _study_worker
        self.pool = cf.ProcessPoolExecutor(self.workers, mp_context=_study_worker.context(),
                                           initializer=_study_worker.init_worker,
                                           initargs=(os.getpid(),))
        self.generation = getattr(self, "generation", -1) + 1

    def submit(self, text, indices, key):
        f = self.pool.submit(self.task, text, indices)
        f.generation = self.generation
        return f

    def wait_first(self, pending, timeout):
        return cf.wait(list(pending), timeout=timeout, return_when=cf.FIRST_COMPLETED).done

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

    def check(self):
        pass

    def cancel(self, pending):
        """Stop at once: queued batches are dropped and the running ones' processes killed."""
        for f in pending:
            f.cancel()
        procs = list((getattr(self.pool, "_processes", None) or {}).values())
        self.pool.shutdown(wait=False, cancel_futures=True)
        for p in procs:
            try:
                p.kill()
            except Exception:  # already gone
                pass

    def close(self):
        self.pool.shutdown(wait=True, cancel_futures=True)


def _bounded(fn, timeout):
    """Call ``fn()`` in a daemon thread and wait at most ``timeout`` s (errors and overruns ignored)."""
    t = threading.Thread(target=lambda: _quiet(fn), daemon=True, name="pneucore-bounded")
    t.start()
    t.join(timeout)


def _quiet(fn):
    try:
        fn()
    except Exception:
        pass


class _DaskEngine:
    """A ``dask.distributed.Client``: the scheduler places, retries and reschedules tasks."""

    def __init__(self, client, owned, address, timeout, task=None):
        self.client, self.owned, self.address, self.timeout = client, owned, address, timeout
        self.task = task or run_block
        self._done = None  # distributed.as_completed over every submitted future
        self.probing = True
        try:
            info = probe_scheduler(address, timeout)
        except SchedulerError:
            if owned:
                raise
            # a Client handed over by the caller (e.g. an in-process cluster, whose inproc://
            # address only its own event loop reaches): ask through it; no independent probes
            self.probing = False
            sched = client.scheduler_info()
            ws = sched.get("workers", {})
            info = {"n_workers": len(ws), "total_threads": sum(int(w.get("nthreads", 1)) for w in ws.values())}
        self.n_slots = max(1, int(info.get("total_threads") or 1))
        nw, nt = int(info.get("n_workers") or 0), self.n_slots
        self.name = (f"dask.distributed at {address} ({nw} worker{'s' if nw != 1 else ''}, "
                     f"{nt} thread{'s' if nt != 1 else ''})")
        self._healthy = self._probed = time.monotonic()

    def submit(self, text, indices, key):
        from distributed import as_completed
        f = self.client.submit(self.task, text, indices, key=key, pure=False)
        if self._done is None:
            self._done = as_completed([f], loop=self.client.loop)
        else:
            self._done.add(f)
        return f

    def wait_first(self, pending, timeout):
        end = time.monotonic() + timeout
        while not self._done.has_ready():
            left = end - time.monotonic()
            if left <= 0:
                return []
            with self._done.thread_condition:
                self._done.thread_condition.wait(timeout=min(0.1, left))
        return self._done.next_batch(block=False)

    def result(self, f):
        try:
            return f.result(timeout=self.timeout)
        finally:
            _quiet(f.release)

    def retry(self, f, exc, attempts):
        return attempts < MAX_TASK_ATTEMPTS and self.client.status == "running"

    def check(self):
        """Raise StudyInterrupted after CLUSTER_GRACE s without a worker or an answering scheduler."""
        now = time.monotonic()
        if not self.probing or now - self._probed < PROBE_INTERVAL:
            return
        self._probed = now
        try:
            ok = int(probe_scheduler(self.address, self.timeout).get("n_workers") or 0) > 0
            why = "has no worker"
        except SchedulerError:
            ok, why = False, "does not answer"
        if ok:
            self._healthy = now
        elif now - self._healthy > CLUSTER_GRACE:
            raise StudyInterrupted(f"the Dask scheduler at {self.address} {why} "
                                   f"(for {now - self._healthy:.0f} s)")

    def cancel(self, pending):
        if pending:
            _bounded(lambda: self.client.cancel(list(pending)), self.timeout)

    def close(self):
        if self.owned:
            _bounded(lambda: self.client.close(timeout=self.timeout), self.timeout + 1.0)


# -- checks before any work -----------------------------------------------------------------
def default_workers():
    """CPUs available to this process (the local pool's default size, and its largest)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _parse_scheduler(address):
    """``(address, scheme)`` of a scheduler address string, or SchedulerError naming it."""
    if not isinstance(address, str) or not address.strip():
        raise SchedulerError("scheduler", f"must be a Dask scheduler address such as "
                                          f"tcp://host:8786, got {address!r}")
    address = address.strip()
    try:
        from distributed.comm.addressing import parse_address, parse_host_port
    except ImportError:
        raise SchedulerError("scheduler", "a Dask scheduler needs dask.distributed: "
                                          "pip install dask distributed") from None
    try:
        scheme, loc = parse_address(address)
        if scheme in ("tcp", "tls"):
            parse_host_port(loc, 8786)
    except (ValueError, TypeError) as exc:
        raise SchedulerError("scheduler", f"malformed Dask scheduler address {address!r}: {exc}") from None
    return address


def probe_scheduler(address, timeout=SCHEDULER_TIMEOUT):
    """Ask a Dask scheduler who it is, on a connection of its own, within ``timeout`` s.

    Returns
    -------
    identity : dict
        The scheduler's ``identity`` answer (``n_workers``, ``total_threads``, ...)

    Raises
    ------
    SchedulerError
        No answer within ``timeout`` (refused, unreachable, or a listener that
        accepts and stays silent: the whole exchange is bounded)
    """
    from distributed.comm import connect

    async def ask():
        comm = await connect(address, timeout=timeout)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    out = {}

    def run():
        try:
            out["value"] = asyncio.run(asyncio.wait_for(ask(), timeout))
        except BaseException as exc:  # reported below
            out["error"] = exc

    t = threading.Thread(target=run, daemon=True, name="pneucore-probe")
    t.start()
    t.join(timeout + 1.0)
    value = out.get("value")
    if not isinstance(value, dict):
        exc = out.get("error")
        why = f"{type(exc).__name__}: {exc}" if exc is not None else "no answer"
        if isinstance(exc, (TimeoutError, asyncio.TimeoutError)) or t.is_alive():
            why = "no answer"
        raise SchedulerError("scheduler", f"cannot reach the Dask scheduler at {address} "
                                          f"within {timeout:g} s ({why})")
    return value


def connect_scheduler(scheduler, timeout=SCHEDULER_TIMEOUT):
    """A ``distributed.Client`` for ``scheduler`` (an address, a Client or a cluster object).

    The address comes from the caller, never from a request of a service (a
    client unpickles what the scheduler sends).

    Returns ``(client, owned, address)``; raises :class:`SchedulerError`
    (path ``scheduler``) within about ``2 timeout`` seconds if the scheduler
    cannot be reached, does not answer, or has no worker.
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
    address = _parse_scheduler(scheduler)
    deadline = time.monotonic() + timeout
    while True:   # reachable, answering, and with a worker
        info = probe_scheduler(address, max(0.1, min(timeout, deadline - time.monotonic())))
        if int(info.get("n_workers") or 0) > 0:
            break
        if time.monotonic() > deadline:
            raise SchedulerError("scheduler", f"the Dask scheduler at {address} has no worker "
                                              f"(waited {timeout:g} s)")
        time.sleep(0.2)
    out = {}

    def make():
        try:
            out["client"] = distributed.Client(address, timeout=timeout, set_as_default=False)
        except BaseException as exc:
            out["error"] = exc

    t = threading.Thread(target=make, daemon=True, name="pneucore-connect")
    t.start()
    t.join(timeout + 1.0)
    if "client" not in out:
        if t.is_alive():   # close it if it ever connects
            threading.Thread(target=lambda: (t.join(), _quiet(lambda: out["client"].close())),
                             daemon=True).start()
        exc = out.get("error")
        raise SchedulerError("scheduler", f"cannot connect to the Dask scheduler at {address} "
                                          f"within {timeout:g} s" + (f": {exc}" if exc else ""))
    return out["client"], True, address


def max_workers():
    """Largest local pool: the CPUs this process may run on (``os.sched_getaffinity``) [-].

    More processes than CPUs only add memory (about 180 MB each) and contention.
    """
    return default_workers()


def _check_options(workers, batch_size, study_id, scheduler, time_limit=None):
    if workers is not None:
        if scheduler is not None:
            raise FieldError("workers", "sets the local pool's size; a Dask cluster has its own "
                                        "workers (leave workers unset with a scheduler)")
        top = max_workers()
        if isinstance(workers, bool) or not isinstance(workers, int) or not 0 <= workers <= top:
            raise FieldError("workers", f"must be a whole number in [0, {top}] (0 = run in this "
                                        f"process; {top} = the CPUs available), got {workers!r}")
    if batch_size is not None:
        if isinstance(batch_size, bool) or not isinstance(batch_size, int) \
                or not 1 <= batch_size <= MAX_RUNS:
            raise FieldError("batch_size", f"must be a whole number in [1, {MAX_RUNS}], got {batch_size!r}")
    if study_id is not None and (not isinstance(study_id, str) or not _ID_RE.match(study_id)):
        raise FieldError("study_id", "must be 1-64 characters among letters, digits, '_', '-' and '.'")
    if time_limit is not None and (isinstance(time_limit, bool) or not isinstance(time_limit, (int, float))
                                   or not time_limit > 0 or not math.isfinite(time_limit)):
        raise FieldError("time_limit", f"must be a positive number of seconds, got {time_limit!r}")


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
              progress=None, study_id=None, scheduler_timeout=SCHEDULER_TIMEOUT, time_limit=None):
    """Run (or resume) a robustness study; every finished batch is stored as it completes.

    Parameters
    ----------
    study : Study or dict or None
        The definition (see :mod:`pneucore.study.definition`); may be None when resuming a
        stored ``study_id``
    store_path : str or None
        SQLite file (created if needed); None = in memory, and the results are returned
        under ``"results"``
    scheduler : str, distributed.Client, cluster or None
        Dask scheduler address (e.g. ``tcp://10.0.0.5:8786``), an existing Client (left
        open) or a cluster object; None = ``$PNEUCORE_DASK_SCHEDULER`` if set (and
        ``workers`` is None), else the local process pool; ``"local"`` forces the local pool
    workers : int or None
        Local pool size (default and largest: the CPUs available, :func:`max_workers`;
        0 = run in this process); not allowed with a scheduler [-]
    batch_size : int or None
        Runs per task (default: enough tasks for 4 per worker slot, at most 250 runs
        each) [-]
    progress : callable or None
        ``progress(fraction, step)`` (fraction [-], step in words) after each stored
        batch, once before the first, and at least every :data:`HEARTBEAT` s while
        waiting; an exception raised there stops the study (status ``interrupted``;
        already stored batches are kept) and propagates
    study_id : str or None
        Resume this stored study (only missing run indices are computed), or create a new
        study under this id; None = a new random id
    scheduler_timeout : float
        Time allowed to reach the scheduler [s]
    time_limit : float or None
        Wall time allowed to this call [s]; past it the study stops
        with :class:`StudyInterrupted` (status ``interrupted``), whether or not batches finish

    Returns
    -------
    summary : dict
        ``id``, ``status``, ``n_runs``, ``computed`` (runs simulated by this
        call), ``already_stored``, ``failed`` (stored runs with an error), ``batches``,
        ``batch_size``, ``engine``, ``wall_time`` [s], ``store_path``; plus ``results``
        (:func:`pneucore.study.results.study_results`) when ``store_path`` is None

    Raises
    ------
    FieldError  Bad definition or options, before any work (``SchedulerError`` for the scheduler)
    StudyInterrupted  Runs could not be completed (pool restarts exhausted, a task failing
        repeatedly, the Dask cluster without worker or scheduler, the time limit); the stored
        runs remain and the study can be resumed
    """
    t0 = time.perf_counter()
    # ---- every check first: nothing is written before they pass
    if study is not None:
        study = Study.from_dict(study)
    if scheduler is None and workers is None:
        scheduler = os.environ.get(ENV_SCHEDULER) or None
    if isinstance(scheduler, str) and scheduler.strip().lower() == "local":
        scheduler = None
    _check_options(workers, batch_size, study_id, scheduler, time_limit)
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
        try:
            engine_factory, client, owned = _engines(scheduler, workers, scheduler_timeout)
        except SchedulerError:
            if existing is not None and existing["status"] != "done":
                store.set_status(db, study_id, "interrupted")   # resumable, not left queued
            raise
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
        return _drive(db, sid, study, text, engine_factory, batch_size, progress, path, t0,
                      time_limit)
    finally:
        db.close()


def _engines(scheduler, workers, scheduler_timeout, task=None):
    """``(engine factory, client, owned)``: the Dask engine on ``scheduler`` (connected now),
    else the local pool of ``workers`` processes (None = the CPUs available; 0 = this
    process), each running ``task(text, indices)`` (default :func:`run_block`)."""
    if scheduler is not None:
        client, owned, address = connect_scheduler(scheduler, scheduler_timeout)
        return (lambda: _DaskEngine(client, owned, address, scheduler_timeout, task)), client, owned
    n_workers = default_workers() if workers is None else workers
    if n_workers > 0:
        return (lambda: _LocalEngine(n_workers, task)), None, False
    return (lambda: _InlineEngine(task)), None, False


def map_runs(task, text, n, on_block, scheduler=None, workers=None, batch_size=None,
             progress=None, time_limit=None, scheduler_timeout=SCHEDULER_TIMEOUT,
             what="runs"):
    """Run ``n`` indexed runs of a task on the study's engines (the local process pool on its
    warm forkserver, or a Dask cluster) without a store: the same batches, progress,
    heartbeat, time limit, retries and cancellation as :func:`run_study`. A closed-loop
    study and a controller tuning run this way (:mod:`pneucore.control.robustness`).

    Parameters
    ----------
    task : callable
        ``task(text, indices) -> block``, a module-level function (pickled by name) [-]
    text : str
        What every task receives (a JSON definition) [-]
    n : int
        Runs, indices ``0 .. n - 1`` [-]
    on_block : callable
        ``on_block(block)`` in the calling process, for each finished batch; ``len(block)``
        is its number of runs [-]
    scheduler, workers, batch_size, time_limit, scheduler_timeout
        As :func:`run_study` (the scheduler an address from trusted code only) [-, -, -, s, s]
    progress : callable or None
        ``progress(fraction, step)``; an exception raised there stops the work (the pool's
        running processes killed) and propagates [-]
    what : str
        What the runs are, for the progress text [-]

    Returns
    -------
    summary : dict
        ``engine``, ``batches``, ``batch_size``, ``wall_time`` [s]
    """
    t0 = time.perf_counter()
    if scheduler is None and workers is None:
        scheduler = os.environ.get(ENV_SCHEDULER) or None
    if isinstance(scheduler, str) and scheduler.strip().lower() == "local":
        scheduler = None
    _check_options(workers, batch_size, None, scheduler, time_limit)
    engine_factory, _, _ = _engines(scheduler, workers, scheduler_timeout, task)
    report = progress or (lambda f, s: None)
    deadline = None if time_limit is None else time.monotonic() + time_limit
    done = [0]
    pending = {}
    engine = None
    finished = False
    try:
        engine = engine_factory()
        size = batch_size or max(1, min(MAX_AUTO_BATCH, math.ceil(n / (4 * engine.n_slots))))
        batches = [list(range(k, min(n, k + size))) for k in range(0, n, size)]
        report(0.0, f"{n} {what} in {len(batches)} batches on {engine.name}")

        def keep(block):
            on_block(block)
            done[0] += len(block)
            report(done[0] / n, f"{done[0]}/{n} {what} done")

        _pump(engine, text, batches, pending, keep, lambda: done[0], n, report, deadline,
              time_limit, "start again", f"pneucore-runs-{uuid.uuid4().hex[:8]}", "done")
        finished = True
    finally:
        if engine is not None:
            if not finished:
                engine.cancel(list(pending))
            engine.close()
    return {"engine": engine.name, "batches": len(batches), "batch_size": size,
            "wall_time": time.perf_counter() - t0}


def _drive(db, sid, study, text, engine_factory, batch_size, progress, path, t0, time_limit=None):
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
    deadline = None if time_limit is None else time.monotonic() + time_limit
    try:
        engine = engine_factory()
        size = batch_size or max(1, min(MAX_AUTO_BATCH, math.ceil(len(missing) / (4 * engine.n_slots))))
        batches = [missing[k:k + size] for k in range(0, len(missing), size)]
        summary.update(engine=engine.name, batch_size=size, batches=len(batches))
        report(n_done / n, f"{n_done}/{n} runs stored; {len(missing)} to compute in "
                           f"{len(batches)} batches on {engine.name}")

        def keep(block):
            nonlocal n_done, computed
            store.write_runs(db, sid, block)
            n_done += len(block)
            computed += len(block)
            report(n_done / n, f"{n_done}/{n} runs stored")

        _pump(engine, text, batches, pending, keep, lambda: n_done, n, report, deadline,
              time_limit, f"resume with study_id={sid!r}", f"pneucore-study-{sid}")
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
        from pneucore.study.results import results_from_db
        summary["results"] = results_from_db(db, sid)
    return summary


def _pump(engine, text, batches, pending, on_block, n_done, n, report, deadline, time_limit,
          resume, key_prefix, word="stored"):
    """Submit ``batches`` of run indices to ``engine`` (its task on ``text``), hand each
    finished block to ``on_block`` and keep the limits while waiting: ``report`` at least
    every :data:`HEARTBEAT` s (an exception there stops the work), the ``deadline``
    (``time.monotonic()``) and the engine's health; a failed batch is resubmitted as far as
    the engine allows. ``pending`` (future -> batch number) is filled as it goes, for the
    caller to cancel on the way out. ``n_done()`` counts the runs ``word`` (stored) of ``n``;
    ``resume`` says how to go on after an interruption."""
    attempts = {}
    for k, b in enumerate(batches):
        pending[engine.submit(text, b, f"{key_prefix}-{k}-{uuid.uuid4().hex[:8]}")] = k
    while pending:
        finished = engine.wait_first(pending, HEARTBEAT)
        if not finished:   # nothing finished within a heartbeat: limits still hold
            report(n_done() / n, f"{n_done()}/{n} runs {word}")
            if deadline is not None and time.monotonic() > deadline:
                raise StudyInterrupted(f"the study exceeded its time limit of {time_limit:g} s; "
                                       f"{n_done()}/{n} runs are {word}, {resume}")
            engine.check()
            continue
        for f in finished:
            k = pending.pop(f)
            try:
                block = engine.result(f)
            except Exception as exc:
                attempts[k] = attempts.get(k, 1) + 1
                if not engine.retry(f, exc, attempts[k] - 1):
                    raise StudyInterrupted(
                        f"batch of runs {batches[k][0]}-{batches[k][-1]} could not be computed "
                        f"({type(exc).__name__}: {exc}); {n_done()}/{n} runs are {word}, "
                        f"{resume}") from exc
                key = f"{key_prefix}-{k}-{uuid.uuid4().hex[:8]}"
                pending[engine.submit(text, batches[k], key)] = k
                continue
            on_block(block)
        if deadline is not None and pending and time.monotonic() > deadline:
            raise StudyInterrupted(f"the study exceeded its time limit of {time_limit:g} s; "
                                   f"{n_done()}/{n} runs are {word}, {resume}")
