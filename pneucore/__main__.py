"""``python -m pneucore``: see :mod:`pneucore.cli`."""
import sys

from pneucore.cli import main

# guarded: the study pool's forkserver imports the caller's main module (this one, under
# another name) to preload it, and must not run the command line again
if __name__ == "__main__":
    sys.exit(main())
