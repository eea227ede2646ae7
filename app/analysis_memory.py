"""Admission of analyses by their memory estimate against a budget (issue 40, item 4).

One analysis at the API's cost limit (200 simulated seconds, 200,000 samples) held 1.5-1.7 GB
before its replays were slimmed, and the default workers let four run at once: more than a
small shared server has. Each analysis (compare, calibrate, diagnose, refine, the reports, the
heat-model comparison; synchronous or as a job) and each simulation routed to a worker thread
is estimated before it starts from what it will replay, :func:`analysis_estimate`: its samples
(simulated seconds times the sample rate, over every experiment) times the bytes a sample
takes at the analysis's peak, measured per kind by ``benchmarks/bench_long_records.py --memory
--memory-kinds ...`` (:data:`BYTES_PER_SAMPLE`). The estimates of the analyses running are
summed against ``Limits.analysis_memory_budget`` (``PNEUCORE_ANALYSIS_MEMORY``, default half
of the machine's memory, :func:`default_budget`):

- a synchronous request that does not fit now is answered **503** with ``Retry-After`` and a
  JSON body naming the budget, its estimate and what is held (:class:`MemoryBusy`);
- a job that does not fit waits in the queue (status ``queued``, its ``step`` saying it waits
  for memory and how much) until the running ones give theirs back, first come first
  served; a synchronous request is admitted only besides the first job waiting;
- a request whose own estimate exceeds the whole budget is refused at once, **422** naming
  ``experiments`` (or ``scenario.duration``), its seconds and samples and the budget.

Every estimate held is given back when its work ends: an answer, an error, a client gone,
a time limit. Simulations answered on the event loop (:mod:`app.express_lane`, at most 5,001
samples, one at a time) are not counted: a few MB.
"""
from __future__ import annotations

import collections
import contextvars
import math
import os
import threading
from contextlib import contextmanager

from pneucore.description.validation import FieldError

#: Peak memory of one analysis per replayed sample, by kind [bytes]: the largest of the
#: peaks measured up to the cost limit by ``benchmarks/bench_memory_estimate.py`` (resident
#: growth of a forked child running the analysis as the API does, 2 Jacobian threads; 2-core
#: AMD EPYC VM, load 3.5-7, Python 3.11, numpy 2.4.6, scipy 1.17.1) on a 1 s hold plus a
#: cyclic record of 60, 120 and 198.9 s at 1 kHz (61,002 / 121,002 / 199,902 samples, the
#: last the cost limit, ``Limits.max_analysis_seconds``), rounded up. Measured, bytes a sample:
#:
#: - compare 818 / 739 / 708;
#: - calibrate 1,404 / 1,381 / 1,303;
#: - diagnose 9,205 / 9,638 / 7,784 (not monotonic: the leading candidates, and so the fits
#:   of the round, change with the record; 5,800 was taken from records up to 61 s before
#:   and under-estimated a diagnosis at 61 and 121 s, ratios 0.95 and 0.90);
#: - refine 8,921 / 8,521 / 7,905 (its rounds one after the other);
#: - heat: one calibration per heat model compared, the calibrate figure each;
#: - simulate (output samples, the answer's JSON written): 866 on 20 s, 1,115 on 100 s
#:   (``bench_long_records.py --memory --memory-kinds simulate``).
#:
#: What a sample costs at a diagnosis's peak is mostly the least-squares algebra (Jacobians
#: of samples x signals x fitted parameters and their SVD), so the compared signals (2-6) are
#: in the figure rather than a term of their own. The table is in docs/guides/memory.md.
BYTES_PER_SAMPLE = {
    "compare": 850,
    "calibrate": 1_450,
    "diagnose": 9_700,
    "refine": 9_700,
    "heat": 1_450,      # per heat model compared (each is one calibration)
    "simulate": 1_200,  # per output sample: the core's outputs, the series and the answer
}
#: Factor on the measured figures [-]: what a busy server takes beyond one analysis's own
#: peak. Four diagnoses of 1 s + 20 s in one server took 121 MB each
#: (``benchmarks/bench_analysis_budget.py --budget 0``: 485 MB, 2 malloc arenas), 1.46 times
#: one's traced peak alone. The per-sample figures are measured up to the cost limit, so the
#: factor no longer covers an extrapolation: a diagnosis at the cost limit (200,000 samples)
#: is estimated 200,000 x 9,700 x 1.5 = 2.91 GB (one of 199,902 samples measured 1.56 GB alone)
MARGIN = 1.5
#: Smallest estimate of an analysis [bytes]: its fixed part (the model, the optimiser, the
#: answer's structure) whatever its records, about 8 MB of resident growth measured for a
#: comparison of 2,000 samples
FLOOR_BYTES = 10_000_000
#: Share of the machine's memory given to analyses by default [-]: the rest holds the server's
#: own 300-400 MB (the compiled core, the modules), an upload's decode budget
#: (``max_request_memory``, 256 MB), the studies' processes, the OS and its page cache
DEFAULT_SHARE = 0.5
#: Seconds a refused request is told to wait (``Retry-After``): an analysis of a typical size
#: takes 1-10 s on 2 cores; one at the cost limit longer, and the client is told again then
RETRY_AFTER_S = 10

#: The budget of the analysis this context (a synchronous request and its worker thread)
#: runs, set by :func:`app.sync_pool.sync_slot`; None outside (a job holds its own)
CURRENT = contextvars.ContextVar("pneucore_memory_budget", default=None)


@contextmanager
def budget_of_request(budget):
    """:data:`CURRENT` set to ``budget`` for the block (a request's work and the worker threads
    it starts, which get a copy of this context), put back after; a block exited in another
    context (the request's task ends anyway) leaves it."""
    token = CURRENT.set(budget)
    try:
        yield
    finally:
        try:
            CURRENT.reset(token)
        except ValueError:
            pass


#: Malloc arenas of the server's process [-] (glibc's ``M_ARENA_MAX``; its default is 8 per
#: core): each thread that allocates gets an arena of its own, which keeps its high-water mark
#: once its analysis is done, so that the resident memory grew as the sum of every thread's
#: peak rather than of the analyses running at once. Four clients diagnosing 1 s + 20 s at
#: once, two admitted by a 400 MB budget: the resident memory grew 478 MB with glibc's
#: default, 215-288 MB with 2 arenas (``benchmarks/bench_analysis_budget.py``, 2-core VM), in
#: the same wall time; ``benchmarks/bench_api.py``'s server CPU a simulation request was 2.0-4.1
#: ms with 2 arenas (two runs) and 2.85-3.85 ms with 16, no difference beyond the noise.
#: ``MALLOC_ARENA_MAX`` in the environment is the operator's choice and is left as it is.
MALLOC_ARENAS = 2


def limit_malloc_arenas(arenas=MALLOC_ARENAS):
    """Limit glibc's malloc arenas of this process to ``arenas`` (:data:`MALLOC_ARENAS`), at
    the app's creation, before its worker threads exist; nothing where ``MALLOC_ARENA_MAX`` is
    set or the C library is not glibc.

    Returns
    -------
    done : bool
        Whether the limit was set [-]
    """
    if os.environ.get("MALLOC_ARENA_MAX"):
        return False
    try:
        import ctypes
        import ctypes.util
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
        libc.gnu_get_libc_version   # noqa: B018 - glibc only (musl's mallopt does nothing)
    except (OSError, AttributeError):
        return False
    return bool(mallopt(-8, int(arenas)))   # -8: M_ARENA_MAX


def machine_memory():
    """Memory this process may use [bytes]: the physical memory, or the container's limit
    (cgroup v2 ``memory.max``, v1 ``memory.limit_in_bytes``) where smaller; None if unknown."""
    sizes = []
    try:
        sizes.append(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        pass
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(path) as fh:
                text = fh.read().strip()
        except OSError:
            continue
        if text.isdigit() and int(text) < 1 << 60:   # "max" or a huge number: no limit
            sizes.append(int(text))
    return min(sizes) if sizes else None


def default_budget():
    """``Limits.analysis_memory_budget`` unless ``PNEUCORE_ANALYSIS_MEMORY`` says [bytes]:
    :data:`DEFAULT_SHARE` of :func:`machine_memory` (2 GB where it is unknown)."""
    total = machine_memory()
    return int(DEFAULT_SHARE * total) if total else 2_000_000_000


def analysis_estimate(kind, experiments, models=1):
    """Peak memory one analysis of ``kind`` is expected to take [bytes].

    Parameters
    ----------
    kind : str
        A key of :data:`BYTES_PER_SAMPLE` [-]
    experiments : list of pneucore.data.experiment.Experiment
        What it replays (each record's samples: its simulated seconds times its sample rate) [-]
    models : int
        Heat models compared (``heat``) [-]

    Returns
    -------
    estimate : int
        [bytes]
    """
    samples = sum(e.measurement.n for e in experiments)
    return samples_estimate(kind, samples, models)


def samples_estimate(kind, samples, models=1):
    """:func:`analysis_estimate` from a count of samples [bytes]."""
    return max(FLOOR_BYTES, int(math.ceil(samples * BYTES_PER_SAMPLE[kind] * MARGIN * models)))


# ----------------------------------------------------------------------------- other kinds
# One estimate per kind of heavy work, all here: the analyses above (analysis_estimate), a
# simulation (simulation_estimate), and what follows. Each is held on the same budget
# (MemoryBudget) by a synchronous request (503 when it does not fit) and by a job (waits in
# the queue), and refused at once (check_alone, 422) when it alone exceeds the budget.

#: Resident memory one worker process of a study's local pool adds besides its run [bytes]:
#: a fork of the warm forkserver (pneucore.study._worker) shares its imports and compiled
#: core; what it writes (its interpreter's heap, a batch's metrics) is its own. Measured by
#: ``benchmarks/bench_job_memory.py --kinds study`` (the peak unique set size of each pool
#: worker, sampled every 20 ms; 2-core AMD EPYC VM shared, load 4.9-5.0): 15.7-15.8 MB a
#: worker on 1 s runs (1 and 2 workers, 32 runs each), 18.8 MB on 10 s runs; 25 MB is a
#: margin of 1.6 on the largest. The run itself is the simulation's estimate beside it
#: (60 s runs: 44.5-83.5 MB a worker measured, 25 + 108 MB estimated). The forkserver's own
#: 110-210 MB, once per server, is the server's, outside the budget as its imports are.
#: Was 60 MB, set from the server's size before it was measured
STUDY_WORKER_BYTES = 25_000_000
#: What a run of a closed-loop study or tuning adds to the job's own process [bytes]: its
#: parameter values, metrics and error in the answer and its JSON. Measured by
#: ``benchmarks/bench_job_memory.py --kinds control`` (the tracemalloc peak of the calling
#: process, the answer's JSON written; the runs simulated by a pool of one worker; 0.5 s
#: runs; load 4.8-5.0): a closed-loop study 858-1,047 B a run over 100-3,000 runs (1,167 B
#: a run from 400 to 1,000 runs, the steepest step), a tuning 246-754 B; 1,750 B is a margin
#: of 1.5 on the largest. Was 2,000 B, set from a count of floats before it was measured
CONTROL_RUN_BYTES = 1_750
#: Bytes a friction-bench sample takes at the identification's peak [bytes], before
#: :data:`MARGIN` (the estimate is samples x this x 1.5, as an analysis's): measured by
#: ``benchmarks/bench_job_memory.py --kinds friction`` (POST /api/identify/friction's work
#: and its answer's JSON, in a forked child of a warm process, the larger of its resident
#: growth and its tracemalloc peak; five records at 100 Hz, one of them validated; load
#: 4.2-4.5): 1,184-1,195 B a sample on 10,000 samples (its fixed part, 12 MB, counts most),
#: 599-800 B on 50,000, 599-628 B on 200,000, with and without the extras; the largest,
#: rounded up. Was 1,000 B, set from the calibration's before it was measured (10,000
#: samples: 15 MB estimated, 12 MB measured; now 18 MB)
IDENTIFY_FRICTION_BYTES_PER_SAMPLE = 1_200


def simulation_estimate(samples, runs=1):
    """``runs`` simulations of ``samples`` output samples each held at once [bytes]
    (:data:`BYTES_PER_SAMPLE` ``simulate``)."""
    return samples_estimate("simulate", samples, runs)


def study_estimate(run_samples, workers, local=True):
    """A robustness study's job [bytes]: each worker process of the local pool
    (:data:`STUDY_WORKER_BYTES`) simulating one run of ``run_samples`` output samples; on a
    Dask cluster (``local`` False) the runs take the cluster's memory, not this server's:
    the floor (the batches' metrics pass through to the store).

    Parameters
    ----------
    run_samples : int
        Output samples of one run [-]
    workers : int
        Processes of the local pool (0: the runs in the job's own thread) [-]
    """
    if not local:
        return FLOOR_BYTES
    per_run = samples_estimate("simulate", run_samples)
    return max(FLOOR_BYTES, max(1, workers) * (STUDY_WORKER_BYTES * (workers > 0) + per_run))


def control_estimate(run_samples, runs, workers=0, local=True):
    """A closed-loop robustness study or a tuning [bytes]: its runs on the studies' engine as a
    study's are (:func:`study_estimate`: each of the local pool's ``workers`` processes
    simulating one closed-loop run of ``run_samples`` output samples; 0 workers: one run at a
    time in the job's thread; a Dask cluster's runs are not this server's), and every run's
    row of the answer (:data:`CONTROL_RUN_BYTES`; a tuning: runs times gain sets)."""
    return study_estimate(run_samples, workers, local) + int(runs) * CONTROL_RUN_BYTES


def sizing_estimate(run_samples, workers):
    """A sizing [bytes]: ``workers`` threads each simulating one candidate's run of at most
    ``run_samples`` output samples (:func:`pneucore.sizing.search.run_samples_bound`)."""
    return samples_estimate("simulate", run_samples, max(1, workers))


def identify_estimate(kind, samples):
    """An identification [bytes]: ``valve`` (flow-bench points, a few kB): the floor;
    ``friction``: the bench records' ``samples`` at
    :data:`IDENTIFY_FRICTION_BYTES_PER_SAMPLE` each, with :data:`MARGIN`."""
    if kind == "valve":
        return FLOOR_BYTES
    return max(FLOOR_BYTES, int(math.ceil(samples * IDENTIFY_FRICTION_BYTES_PER_SAMPLE * MARGIN)))


def body_estimate(values):
    """A JSON request body's parsed values held while its request is answered [bytes]
    (:data:`app.request_memory.JSON_VALUE_BYTES` each, the figure its 413 uses)."""
    from .request_memory import JSON_VALUE_BYTES
    return int(values) * JSON_VALUE_BYTES


#: The estimate of this request's body, held on the budget while it is answered
#: (:class:`app.bodies.OffLoopRoute`) [bytes]; 0 for a small one (not counted). Added to a
#: job's estimate, since the job keeps the parsed request until it ends
BODY = contextvars.ContextVar("pneucore_body_estimate", default=0)


def _mb(n):
    return f"{n / 1e6:,.0f} MB"


def check_alone(estimate, budget, field, what):
    """Refuse at once (422 naming ``field``) a request whose own estimate exceeds the whole
    budget: it would never be admitted.

    Parameters
    ----------
    estimate, budget : int
        [bytes]
    field : str
        The request's field that sets its size (``experiments``, ``scenario.duration``) [-]
    what : str
        Its size in words (``200 s of records, 200,000 samples``) [-]
    """
    estimate += BODY.get()   # the request's own body, held besides
    if estimate > budget:
        raise FieldError(field, f"{what} would take about {_mb(estimate)} of memory, more than the "
                                f"server's whole analysis memory budget of {_mb(budget)} "
                                f"(analysis_memory_budget, GET /api/limits); shorten or decimate "
                                f"the records, or split the analysis")


class MemoryBusy(Exception):
    """The budget has no room for this analysis now: 503 with ``Retry-After`` (see
    :func:`app.main.create_app`'s handler), nothing started."""

    def __init__(self, what, estimate, budget, held, running):
        self.estimate, self.budget, self.held, self.running = estimate, budget, held, running
        self.retry_after = RETRY_AFTER_S
        super().__init__(
            f"not enough memory for this {what} now: it needs about {_mb(estimate)}, and "
            f"{running} running analyses hold {_mb(held)} of the {_mb(budget)} budget "
            f"(analysis_memory_budget, GET /api/limits); try again in {RETRY_AFTER_S} s, or "
            f"submit it as a job, which waits for memory in the queue")

    def body(self):
        """The answer's JSON: the message and the figures [bytes]."""
        return {"detail": str(self), "memory_budget": self.budget, "estimate": self.estimate,
                "held": self.held, "running": self.running, "retry_after": self.retry_after}


class MemoryBudget:
    """The analyses' memory estimates held at once, against a budget.

    Parameters
    ----------
    budget : int
        Sum of the estimates of the analyses running at once [bytes]
    """

    def __init__(self, budget):
        self.budget = int(budget)
        self.held = 0       # sum of the estimates held [bytes]
        self.running = 0    # analyses holding one [-]
        self._cv = threading.Condition()
        self._queue = collections.deque()   # jobs waiting, first come first served: [token, bytes]

    def _fits(self, estimate):
        # an analysis alone always runs (its estimate was checked against the whole budget)
        return self.running == 0 or self.held + estimate <= self.budget

    def _fits_now(self, estimate):
        """Whether a synchronous request fits besides the first job waiting, whose place it
        must not take (else a steady flow of small requests would hold a large job back)."""
        if not self._queue:
            return self._fits(estimate)
        return self.held + estimate + self._queue[0][1] <= self.budget

    def _take(self, estimate):
        self.held += estimate
        self.running += 1

    def release(self, estimate):
        """Give back what :meth:`hold` or :meth:`wait_for` took."""
        with self._cv:
            self.held -= estimate
            self.running -= 1
            self._cv.notify_all()

    @contextmanager
    def hold(self, estimate, what="analysis"):
        """Hold ``estimate`` [bytes] while the block runs; :class:`MemoryBusy` at once when it
        does not fit (a synchronous request)."""
        with self._cv:
            if not self._fits_now(estimate):
                raise MemoryBusy(what, estimate, self.budget, self.held, self.running)
            self._take(estimate)
        try:
            yield
        finally:
            self.release(estimate)

    def wait_for(self, estimate, waiting=None, stop=None, period=0.25):
        """Block until ``estimate`` [bytes] fits, then hold it (:meth:`release` gives it back);
        False, nothing held, when ``stop()`` turns true meanwhile (a job's queue).

        Parameters
        ----------
        waiting : callable or None
            ``waiting(text)``, called once if it has to wait, with why
        stop : callable or None
            Checked every ``period`` seconds while waiting
        """
        told = False
        place = [object(), estimate]
        with self._cv:
            self._queue.append(place)
            try:
                # first come first served: only the first job waiting may take its place
                while not (self._queue[0] is place and self._fits(estimate)):
                    if stop is not None and stop():
                        return False
                    if not told and waiting is not None:
                        ahead = self._queue.index(place)
                        waiting(f"waiting for memory: needs about {_mb(estimate)}, {self.running} "
                                f"running analyses hold {_mb(self.held)} of the "
                                f"{_mb(self.budget)} budget (analysis_memory_budget)"
                                + (f"; {ahead} jobs ahead" if ahead else ""))
                        told = True
                    self._cv.wait(period)
                self._take(estimate)
            finally:
                self._queue.remove(place)
                self._cv.notify_all()   # the next in line may fit now
        return True

    def state(self):
        """``{"budget", "held", "running", "waiting"}`` now [bytes, bytes, -, -]."""
        with self._cv:
            return {"budget": self.budget, "held": self.held, "running": self.running,
                    "waiting": len(self._queue)}


def job_estimate(estimate):
    """A job's estimate [bytes]: its work's and the body of the request that queued it
    (:data:`BODY`), which the job keeps until it ends."""
    return int(estimate) + BODY.get()


@contextmanager
def admitted(estimate, what):
    """Hold ``estimate`` on the budget of this context's synchronous request
    (:data:`CURRENT`), raising :class:`MemoryBusy` when it does not fit; nothing outside one
    (a job has held its estimate before it started)."""
    budget = CURRENT.get()
    if budget is None:
        yield
        return
    with budget.hold(estimate, what):
        yield


def seconds_of(experiments):
    """The records' size in words, for the messages: simulated seconds and samples [-]."""
    samples = sum(e.measurement.n for e in experiments)
    seconds = sum(float(e.measurement.duration) for e in experiments)
    return f"{seconds:g} s of records ({samples:,} samples)"

