"""A Dask LocalCluster for the tests (shared by the study and the API study test files)."""
from __future__ import annotations

import logging


def local_cluster(n_workers):
    """A quiet Dask LocalCluster of ``n_workers`` single-threaded worker processes.

    Its scheduler's HTTP server (the health and metrics routes, served even without a
    dashboard) listens on a free localhost port: on Dask's default 8787, two clusters of
    one test run at once, or a cluster of the user's own, would collide (Dask then warns
    and moves to another port).
    """
    import distributed  # a core dependency: a missing one must fail, not skip
    return distributed.LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                    dashboard_address="127.0.0.1:0", silence_logs=logging.CRITICAL)
