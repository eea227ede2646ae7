"""Imported by the local study pool's forkserver: loads the compiled core once (see :mod:`pneucore._study_worker`)."""
from ._study_worker import warm

warm()
