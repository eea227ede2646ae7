"""Where a diagnosis's independent pieces of work run: this machine's threads, or a Dask cluster.

A diagnosis opens one :class:`Runner` for its whole length (:func:`running`, a context
manager that also makes it the current one); its stages hand their independent pieces of
work (the sensitivity columns of the base hypotheses, the score pass's probes, the
candidates' joint refits, the per-experiment consistency fits) to :func:`pmap`, which runs
them on this machine's threads (:data:`pneucore.analysis.calibrate.THREADS`) or, when the
diagnosis was given a Dask cluster, one task each there, the large arguments common to every
piece (the model, the experiments) sent to the cluster once. The answer is the same either
way: the same arithmetic on the same pickled inputs, one BLAS thread on both sides
(:mod:`pneucore.analysis.blas_threads`).

While it waits on the cluster the runner calls the diagnosis's progress callback at least
every :data:`CLUSTER_HEARTBEAT` s (its time limit and cancellation hold; whatever the callback
raises cancels the tasks), and probes the cluster's health as a study does, on a connection of
its own (:func:`pneucore.study.execute.probe_scheduler`, every
:data:`pneucore.study.execute.PROBE_INTERVAL` s): a cluster with no worker, or whose scheduler
does not answer, for :data:`pneucore.study.execute.CLUSTER_GRACE` s is given up. Its tasks are
cancelled (within the scheduler timeout, even against a scheduler that stopped answering), and
the unfinished pieces and the rest of the diagnosis run on this machine, to the same answer;
the runner's :attr:`Runner.lost` says why (a diagnosis reports it, ``cluster["lost"]``). A
study stops there and is resumed later; a diagnosis has nothing stored to resume from, and
this machine can always finish it.

Nothing in a task calls :func:`pmap` on the cluster again: the current runner is a
:mod:`contextvars` variable of the diagnosis's own thread, which worker threads and processes
do not see.
"""
from __future__ import annotations

import contextvars
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager

from pneucore.analysis.blas_threads import single_threaded_blas

#: Longest wait for a task on a Dask cluster between two calls of the progress callback
#: (which stops the diagnosis past its time limit or once its client has gone) [s]
CLUSTER_HEARTBEAT = 1.0
#: Polling interval while waiting on a cluster's tasks [s]: a piece takes tens of
#: milliseconds to seconds, so 20 ms polling costs nothing
POLL = 0.02

_CURRENT = contextvars.ContextVar("pneucore_parallel_runner", default=None)


class ClusterLost(RuntimeError):
    """The Dask cluster had no worker, or its scheduler did not answer, for the grace time."""


def _threads():
    from pneucore.analysis import calibrate
    return calibrate.THREADS


@single_threaded_blas
def run_task(fn, *args):
    """``fn(*args)`` as a Dask task, with one BLAS thread (as on this machine's threads)."""
    return fn(*args)


class Runner:
    """Runs independent pieces of work here or on a Dask cluster (see the module docstring).

    Parameters
    ----------
    client : distributed.Client or None
        The cluster's client (None = this machine's threads only)
    address : str or None
        Its scheduler's address, probed for health on a connection of its own
    timeout : float
        Time allowed to reach the scheduler (a probe, a cancellation) [s]
    report : callable or None
        The diagnosis's ``progress(fraction, step)``, called while waiting on the cluster
    """

    def __init__(self, client=None, address=None, timeout=5.0, report=None):
        self.client, self.address, self.timeout = client, address, timeout
        self.report = report or (lambda f, s: None)
        self.lost = None
        self._fraction = 0.0
        self._probing = client is not None and isinstance(address, str)
        self._healthy = self._probed = time.monotonic()

    def probe_or_not(self):
        """Probe the scheduler's health during the work only if its address answers a probe
        now, as a study does for a ``Client`` handed over (an in-process cluster's address
        only its own event loop reaches)."""
        from pneucore.study.execute import SchedulerError, probe_scheduler
        try:
            probe_scheduler(self.address, self.timeout)
        except SchedulerError:
            self._probing = False
        self._healthy = self._probed = time.monotonic()

    @property
    def on_cluster(self):
        """Does work still go to the cluster? (a cluster given and not lost) [-]"""
        return self.client is not None and self.lost is None

    def describe(self):
        """``{"lost"}`` for a diagnosis's report (None, or why the cluster was given up), or
        None without a cluster. No address: a service's report must not show the address
        configured on its server."""
        if self.client is None:
            return None
        return {"lost": self.lost}

    def map(self, fn, items, shared=(), step="", fraction=None, local=None):
        """``[fn(*shared, item) for item in items]``, in parallel, in order.

        Parameters
        ----------
        fn : callable
            A module-level function (pickled by reference to a cluster) [-]
        items : iterable
            One piece of work each [-]
        shared : tuple
            Arguments common to every piece, sent to a cluster once [-]
        step : str
            What the pieces are, for the progress callback while waiting on a cluster [-]
        fraction : float or None
            Progress reported meanwhile (None = the last one reported) [-]
        local : callable or None
            ``local(item)``: the same piece run on this machine (with the caller's progress
            checks, say), used without a cluster and for what a lost cluster left undone
            (None = ``fn(*shared, item)``) [-]

        Returns
        -------
        results : list
            One per item, in their order [-]
        """
        items = list(items)
        if fraction is not None:
            self._fraction = fraction
        if not items:
            return []
        local = local or (lambda item: fn(*shared, item))
        if self.on_cluster:
            return self._on_cluster(fn, items, tuple(shared), step, local)
        return _local(local, items)

    # -- the cluster ---------------------------------------------------------------------
    def check(self):
        """Raise :class:`ClusterLost` once the cluster has had no worker, or its scheduler has
        not answered, for the studies' grace time (probed every ``PROBE_INTERVAL`` s)."""
        from pneucore.study import execute as X
        now = time.monotonic()
        if not self._probing or now - self._probed < X.PROBE_INTERVAL:
            return
        self._probed = now
        try:
            ok = int(X.probe_scheduler(self.address, self.timeout).get("n_workers") or 0) > 0
            why = "has no worker"
        except X.SchedulerError:
            ok, why = False, "does not answer"
        now = time.monotonic()
        if ok:
            self._healthy = now
        elif now - self._healthy > X.CLUSTER_GRACE:
            raise ClusterLost(f"the Dask cluster's scheduler {why} (for {now - self._healthy:.0f} s)")

    def _on_cluster(self, fn, items, shared, step, local):
        from concurrent.futures import CancelledError

        from distributed import KilledWorker
        client = self.client
        where = (step + " " if step else "") + "(on the Dask cluster)"
        futures, scattered, out = [], [], {}
        try:
            try:   # the shared arguments, once; bounded: the cluster may have died meanwhile
                scattered = client.scatter(list(shared), hash=False, timeout=self.timeout) \
                    if shared else []
            except Exception as exc:  # noqa: BLE001 - whatever the cause, the cluster is unusable
                raise ClusterLost(f"the Dask cluster did not take the work "
                                  f"({type(exc).__name__})") from None
            futures = [client.submit(run_task, fn, *scattered, item, pure=False) for item in items]
            pending = set(range(len(items)))
            while pending:
                self.report(self._fraction, where)
                end = time.monotonic() + CLUSTER_HEARTBEAT
                while time.monotonic() < end and not any(futures[i].done() for i in pending):
                    time.sleep(POLL)
                done = [i for i in pending if futures[i].done()]
                for i in done:
                    pending.discard(i)
                    try:
                        out[i] = futures[i].result()
                    except (KilledWorker, CancelledError) as exc:   # the cluster's doing
                        raise ClusterLost(f"the Dask cluster lost a task "
                                          f"({type(exc).__name__})") from None
                if not done:
                    self.check()
        except ClusterLost as exc:
            self.lost = str(exc)
            _bounded(lambda: client.cancel(futures), self.timeout)
            self.report(self._fraction, f"{exc}: the rest runs on this machine")
            rest = [i for i in range(len(items)) if i not in out]
            out.update(zip(rest, _local(local, [items[i] for i in rest])))
        except BaseException:
            _bounded(lambda: client.cancel(futures), self.timeout)
            raise
        finally:
            if self.lost is None:
                for f in futures + list(scattered):
                    f.release()
        return [out[i] for i in range(len(items))]


def _local(fn, items):
    """``[fn(item) for item in items]`` on this machine's threads."""
    with ThreadPoolExecutor(_threads()) as pool:
        return list(pool.map(fn, items))


def _bounded(fn, timeout):
    """Call ``fn()`` in a daemon thread and wait at most ``timeout`` s (errors ignored)."""
    def quiet():
        try:
            fn()
        except Exception:  # noqa: BLE001 - a cancellation on a lost cluster may fail: moot
            pass
    t = threading.Thread(target=quiet, daemon=True, name="pneucore-cancel")
    t.start()
    t.join(timeout)


def current():
    """The runner of the diagnosis running in this thread, or None."""
    return _CURRENT.get()


def pmap(fn, items, shared=(), step="", fraction=None):
    """:meth:`Runner.map` on the current runner (:func:`running`), else on this machine's threads."""
    r = _CURRENT.get()
    if r is None:
        return _local(lambda item: fn(*shared, item), list(items))
    return r.map(fn, items, shared, step, fraction)


@contextmanager
def running(scheduler=None, timeout=None, report=None):
    """A :class:`Runner` for ``scheduler``, current in this thread until the block ends.

    ``scheduler`` is None (this machine's threads), a Dask scheduler address, a
    ``distributed.Client`` or a cluster object, as for a study, or an open :class:`Runner`
    (used as it is, and left open: several diagnoses on one cluster, which is reached and
    probed once, and once lost stays lost)
    (:func:`pneucore.study.execute.connect_scheduler`, whose ``SchedulerError`` names
    ``scheduler`` when it cannot be reached or has no worker); a service passes only the
    address configured on the server, never one from a request (a client unpickles what the
    scheduler sends). A client opened here is closed at the end within the timeout, even
    against a scheduler that stopped answering. ``timeout`` [s]: time to reach it (None = the
    studies' default).
    """
    if isinstance(scheduler, Runner):
        # an open runner handed over (a refinement's rounds share one): the same client, its
        # lost cluster still lost; this block's progress callback while it is current
        prev = scheduler.report
        if report is not None:
            scheduler.report = report
        token = _CURRENT.set(scheduler)
        try:
            yield scheduler
        finally:
            _CURRENT.reset(token)
            scheduler.report = prev
        return
    if scheduler is None:
        r = Runner(report=report)
        token = _CURRENT.set(r)
        try:
            yield r
        finally:
            _CURRENT.reset(token)
        return
    from pneucore.study.execute import SCHEDULER_TIMEOUT, connect_scheduler
    timeout = SCHEDULER_TIMEOUT if timeout is None else timeout
    client, owned, address = connect_scheduler(scheduler, timeout)
    r = Runner(client, address, timeout, report)
    if not owned:   # a Client handed over (an in-process cluster's address is not probed)
        r.probe_or_not()
    token = _CURRENT.set(r)
    try:
        yield r
    finally:
        _CURRENT.reset(token)
        if owned:   # closed within the timeout, even against a scheduler that stopped answering
            t = threading.Thread(target=lambda: client.close(timeout=timeout), daemon=True)
            t.start()
            t.join(timeout + 1.0)
