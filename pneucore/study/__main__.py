"""``python -m pneucore.study``: run, resume and read robustness studies from a shell."""
import sys

from pneucore.study import main

# guarded: the study pool's forkserver imports the caller's main module (this one, under
# another name) to preload it, and must not run the command line again
if __name__ == "__main__":
    sys.exit(main())
