"""Every benchmark runs: each script at a tiny size, in its own process, as a user runs it.

Speed is measured in ``benchmarks/`` and never asserted here (the machine is shared); what
is asserted is that the scripts still work after a change of the code they time (a renamed
import, a changed signature) and that their ``--json`` figures are numbers. The long ones
(a cold compile in a fresh process, a refine loop at 1 and 2 workers, a live server's URL)
are checked for their command line only.
"""
import json
import math
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BENCH = os.path.join(ROOT, "benchmarks")

#: script -> arguments of a run small enough for the suite (seconds, not minutes)
SMALL = {
    "bench_simulator.py": ["--runs", "20", "--scipy-runs", "1", "--skip-compile"],
    "bench_api.py": ["--requests", "20", "--clients", "2", "--per-client", "2", "--warmup", "2"],
    # Dask included (one worker): its task-stream figures and the --big path are code too
    "bench_study.py": ["--runs", "200", "--workers", "1", "--skip-startup", "--big", "200"],
    "bench_study_store.py": ["--runs", "2000", "--batch", "250"],
    "bench_diagnosis_confusion.py": ["--cases", "base/exhaust*"],
    "bench_request_memory.py": ["--rows", "2000", "--kinds", "csv,npz"],
    "bench_sizing.py": ["--families", "36", "--workers", "1"],
    "bench_long_records.py": ["--lengths", "1", "--counts", "2", "--duration", "1",
                              "--refine-lengths", "1", "--pairs", "1", "--memory",
                              "--memory-kinds", "compare,simulate"],
    "bench_analysis_budget.py": ["--length", "1", "--records", "2", "--clients", "2",
                                 "--workers", "2", "--budget", "0", "--retry", "0.2"],
    "bench_memory_estimate.py": ["--lengths", "1", "--kinds", "compare"],
    "bench_job_memory.py": ["--study-workers", "1", "--study-durations", "1", "--study-runs", "2",
                            "--friction-samples", "2000", "--control-runs", "25",
                            "--control-duration", "0.2"],
    "bench_heat_transfer.py": ["--quick"],
    # the table of the presets as they are (six short runs); --fit adds about 130 more
    "bench_table2_presets.py": [],
    "bench_closed_loop.py": ["--runs", "1", "--duration", "0.5"],
    "bench_tuning.py": ["--duration", "0.2", "--kp", "1", "--workers", "1", "--single-runs", "2"],
    "bench_tube_segments.py": ["--runs", "2", "--pairs", "1", "--segments", "1", "2"],
    "bench_flow_control_node.py": [],
}
#: figures a script must write (phases that could silently drop out of its --json)
KEYS = {"bench_api.py": ("sequential_lean", "sequential_lean_npz", "http_alone_lean",
                         "http_alone_lean_npz", "work_bound_ratio", "above_work_bound_ms")}
#: scripts whose smallest run is too long for the suite: their command line only
HELP_ONLY = ["bench_cold_start.py", "bench_diagnosis_threads.py", "bench_loop_block.py",
             "bench_analysis.py", "bench_initial_state.py",
             # two source trees, each compiled in its own children
             "bench_core_ab.py"]


def _run(args, timeout=600):
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable] + args, cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=timeout)


def _numbers(value):
    if isinstance(value, dict):
        for v in value.values():
            yield from _numbers(v)
    elif isinstance(value, list):
        for v in value:
            yield from _numbers(v)
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield value


def test_every_benchmark_is_listed():
    scripts = {f for f in os.listdir(BENCH) if f.startswith("bench_") and f.endswith(".py")}
    assert scripts == set(SMALL) | set(HELP_ONLY)


@pytest.mark.parametrize("script", sorted(SMALL))
def test_benchmark_runs_at_a_small_size(script, tmp_path):
    out = tmp_path / "figures.json"
    r = _run([os.path.join(BENCH, script)] + SMALL[script] + ["--json", str(out)])
    assert r.returncode == 0, (r.stdout[-2000:], r.stderr[-3000:])
    figures = json.loads(out.read_text())
    numbers = list(_numbers(figures))
    assert numbers, figures
    assert all(math.isfinite(x) for x in numbers), figures
    missing = [k for k in KEYS.get(script, ()) if k not in figures]
    assert not missing, missing
    if script == "bench_api.py":
        # the floor plus the work in process is more than the simulation alone, by construction
        assert min(figures["work_bound_ratio"].values()) > 1.0, figures["work_bound_ratio"]


@pytest.mark.parametrize("script", HELP_ONLY)
def test_long_benchmark_command_line(script):
    r = _run([os.path.join(BENCH, script), "--help"], timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "usage" in r.stdout.lower()
