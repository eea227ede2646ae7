"""Machine description printed with every benchmark figure."""
from __future__ import annotations

import importlib
import json
import os
import platform


def machine_info(*modules):
    """CPU model, core counts, Python and the versions of ``modules`` (those importable)."""
    cpu = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    info = {"cpu": cpu, "cores": os.cpu_count(), "usable_cores": usable,
            "python": platform.python_version(), "platform": platform.platform()}
    for name in ("numpy", "numba") + tuple(modules):
        try:
            info[name] = importlib.import_module(name).__version__
        except ImportError:
            pass
    return info


def save_figures(path, figures):
    """Write a benchmark's figures to ``path`` as JSON (its ``--json`` option); no-op for None."""
    if not path:
        return
    with open(path, "w") as fh:
        # numpy scalars as numbers, anything else (a path, a date) as text
        json.dump(figures, fh, indent=1, default=lambda o: o.item() if hasattr(o, "item") else str(o))
    print(f"figures written to {path}")
