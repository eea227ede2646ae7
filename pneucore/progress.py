"""Progress reporting for long computations, and how a caller stops them.

Long functions (calibration, diagnosis, comparison) accept
``progress(fraction, step)``; the callback may raise :class:`Cancelled` (for
instance when a time limit is exceeded) and the computation stops at once,
without swallowing it as a numerical failure.
"""


class Cancelled(Exception):
    """Raised by a progress callback to stop a computation."""


def no_progress(fraction, step):
    """The default callback: does nothing."""
    return None
