"""``python -m pneucore``: see :mod:`pneucore.cli`."""
import sys

from pneucore.cli import main

sys.exit(main())
