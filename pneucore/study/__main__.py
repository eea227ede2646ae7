"""``python -m pneucore.study``: run, resume and read robustness studies from a shell."""
import sys

from pneucore.study import main

sys.exit(main())
