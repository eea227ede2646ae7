"""Service settings, read from environment variables.

``PNEUCORE_DB``: SQLite file (default ``./pneucore.sqlite3`` in the working directory).
``PNEUCORE_MAX_UPLOAD``: largest accepted request body, upload or JSON [bytes] (default 20 MB).
``PNEUCORE_ALLOWED_HOSTS``: comma-separated host names the server answers to (default
``localhost,127.0.0.1,::1``; ``*`` = any, only behind a proxy that checks the host).
``PNEUCORE_TOKEN``: when set, every request needs it (``Authorization: Bearer <token>``, or the
cookie the page gets from ``/?token=<token>``); see :mod:`app.security`.
``PNEUCORE_ANALYSIS_MEMORY``: memory the analyses running at once may take together, by
their estimates [bytes] (default half of the machine's memory; :mod:`app.analysis_memory`).
``PNEUCORE_DASK_SCHEDULER``: address of the Dask scheduler that studies may use
(e.g. ``tcp://10.0.0.5:8786``; also ``python -m app --scheduler``). A request
never gives an address: it may only name this cluster (``"dask"``) or the
local process pool (``"local"``), see :data:`STUDY_CLUSTERS`.
"""
import os
from dataclasses import dataclass, field
from typing import Optional


def _env_int(name, default):
    v = os.environ.get(name)
    return int(v) if v else default


def _decode_budget():
    from pneucore.data.fileformats import DECODE_BUDGET
    return DECODE_BUDGET


def _analysis_memory():
    from .analysis_memory import default_budget
    return default_budget()


def _machine_workers():
    from pneucore.study import max_workers
    return max_workers()


#: Names a study request may give in ``scheduler``: the local process pool, and the Dask
#: cluster at ``Settings.dask_scheduler`` (only when one is configured)
STUDY_CLUSTERS = ("local", "dask")


@dataclass
class Limits:
    """Documented size and time limits of the REST API (refused up front when exceeded)."""
    #: largest request body of any endpoint, CSV upload or JSON, refused with 413 while reading [bytes]
    max_upload_bytes: int = field(default_factory=lambda: _env_int("PNEUCORE_MAX_UPLOAD", 20 * 1024 * 1024))
    #: memory the decoded columns of one uploaded file may take, checked from an archive's
    #: directory and headers before any member is read; refused with 422 naming it [bytes]
    #: (default: a full-size measurement, every signal at MAX_SAMPLES, read and converted: 256 MB)
    max_request_memory: int = field(default_factory=lambda: _env_int("PNEUCORE_MAX_REQUEST_MEMORY",
                                                                     _decode_budget()))
    #: longest name (dataset, experiment, session, study, model) [characters]: a label on a
    #: page or in a file name; a megabyte of name is no label
    max_name_length: int = 200
    #: longest free text (a description) [characters]: notes of a few pages (100 kB), larger
    #: than the body parsed on the event loop, far below the body limit
    max_text_length: int = 100_000
    #: longest JSON text of a form field (an upload's ``columns`` or ``scenario``) [bytes]: a
    #: mapping of MAX_COLUMNS columns takes about 30 kB
    max_form_field_bytes: int = 256 * 1024
    #: deepest nesting of a JSON form field [-]: a scenario nests 3 levels; the parser's own
    #: recursion limit (about 1,000) must never be what stops a request
    max_json_depth: int = 32
    #: most residual evaluations of one calibration [-] (each replays every experiment)
    max_nfev: int = 200
    #: largest request head (request line and headers) [bytes]: browsers send a few kB, and
    #: common servers stop at 8-64 kB (nginx 8 kB a line, Node 16 kB); 431 beyond
    max_header_bytes: int = 64 * 1024
    #: time a client has to send a request's head, from the connection or the previous
    #: answer [s]: a slow-header client (slowloris) holds a socket no longer than this
    header_timeout: float = 10.0
    #: idle time of a kept-alive connection before the server closes it [s]
    keep_alive_timeout: float = 5.0
    #: most connections and requests in progress at once; beyond, 503 at once [-]: well under
    #: the usual 1,024 open files of a process, which must also hold the database and workers
    max_connections: int = 512
    max_duration: float = 120.0          # simulated time per request [s]
    max_samples: int = 200_001           # output samples per simulation
    max_command_points: int = 100_000
    #: experiments of one analysis [-]: what an analysis costs is its samples and simulated
    #: seconds (capped below); the count itself only adds per-experiment work (the consistency
    #: fits, the tables), so that ten tests of a rig, or twenty, fit in one request
    max_experiments: int = 24
    max_analysis_samples: int = 200_000  # measured samples over all experiments of one analysis
    #: simulated seconds over all experiments of one analysis [s]: each residual evaluation
    #: replays them all (200 s: the samples' cap at 1 kHz; a record sampled slower would
    #: otherwise cost more simulation for the same samples)
    max_analysis_seconds: float = 200.0
    max_steps: int = 2_000_000           # solver step budget (about 10 s of compute)
    job_time_limit: float = 300.0        # wall time of one job [s]
    request_time_limit: float = 60.0     # wall time of a synchronous analysis [s]
    max_jobs: int = 16                   # queued or running jobs (analysis and studies together)
    analysis_workers: int = 2            # threads running analysis jobs (studies have their own)
    #: synchronous analyses (POST /api/compare, calibrate, diagnose, refine, the reports, heat
    #: compare) running at once [-]: each keeps a core busy (the compiled core releases the
    #: GIL), so more than the cores only slows every one of them; the server's other threads
    #: stay free for reads
    sync_workers: int = 2
    #: synchronous analyses waiting for a worker; beyond, 429 with Retry-After at once [-]:
    #: with 2 workers and 1-2 s a diagnosis the last one waits about 8 s, well inside
    #: request_time_limit; a longer queue only holds clients past what their own timeouts allow
    max_sync_queue: int = 8
    #: memory the analyses running at once may take together, by their estimates
    #: (:mod:`app.analysis_memory`: samples times the bytes a sample takes at the kind's peak,
    #: measured) [bytes]; a synchronous analysis that does not fit now is 503 with Retry-After,
    #: a job waits for it in the queue, one that alone exceeds it is 422 naming ``experiments``
    #: (default: half of the machine's memory or of its container's limit;
    #: ``PNEUCORE_ANALYSIS_MEMORY``)
    analysis_memory_budget: int = field(default_factory=lambda: _env_int("PNEUCORE_ANALYSIS_MEMORY",
                                                                         _analysis_memory()))
    max_study_runs: int = 100_000        # runs of one robustness study
    study_time_limit: float = 3600.0     # wall time of one study job [s]
    scheduler_timeout: float = 3.0       # time to reach a Dask scheduler [s]
    max_workers: int = field(default_factory=_machine_workers)  # local pool processes of one study: the CPUs available [-]

    def to_dict(self):
        return dict(self.__dict__)


#: Host names a local server answers to (DNS-rebinding guard)
LOCAL_HOSTS = ("localhost", "127.0.0.1", "::1")


def _env_list(name, default):
    v = os.environ.get(name)
    return tuple(h.strip() for h in v.split(",") if h.strip()) if v else tuple(default)


@dataclass
class Settings:
    db_path: str = field(default_factory=lambda: os.environ.get("PNEUCORE_DB", "pneucore.sqlite3"))
    allowed_hosts: tuple = field(default_factory=lambda: _env_list("PNEUCORE_ALLOWED_HOSTS", LOCAL_HOSTS))
    token: str = field(default_factory=lambda: os.environ.get("PNEUCORE_TOKEN") or None)
    limits: Limits = field(default_factory=Limits)
    seed_samples: bool = True
    resume_studies: bool = True
    #: Dask scheduler address for studies (the cluster named "dask"); None = none configured
    dask_scheduler: Optional[str] = field(
        default_factory=lambda: os.environ.get("PNEUCORE_DASK_SCHEDULER", "").strip() or None)
    #: Folder of the built documentation site served at /docs-site/ (``mkdocs build``'s
    #: output); None = ``site/`` beside the package (:mod:`app.docs_site`)
    docs_site: Optional[str] = field(
        default_factory=lambda: os.environ.get("PNEUCORE_DOCS_SITE", "").strip() or None)
