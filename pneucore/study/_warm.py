"""Imported by the local study pool's forkserver: loads the compiled core once (see :mod:`pneucore.study._worker`)."""
from pneucore.study._worker import warm

warm()
