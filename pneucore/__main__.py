"""``python -m pneucore``: see :mod:`pneucore.cli`."""
import sys

from .cli import main

sys.exit(main())
