"""Speed of the loop closed inside the compiled core (issue 42): closed loop against open loop,
time per simulated second.

Run from the repository root::

    python benchmarks/bench_closed_loop.py [--runs N] [--duration S] [--json PATH]

Cases, on the servo actuator (:func:`pneucore.control.models.servo_model`, isothermal, viscous
friction; the paper's convective model with ``--heat convective``), 1 kHz output:

* **closed**: PID (kp 15 1/m, ki 40 1/(m s), kd 0.1 s/m) at a 1 kHz sample period over a
  multi-step setpoint (10 mm steps every 0.5 s), :func:`simulate_closed_loop`;
* **replay**: the same run open loop, its command the closed loop's own output held between the
  1 kHz sample instants (as many breakpoints as samples): the same valve signal and the same
  discontinuities, without the controller. The issue's bound (closed loop at most 1.3x the
  open loop per simulated second) is read on this pair: it prices the controller's
  evaluation, the measurement and the held output, not the 1 kHz breakpoints themselves;
* **open, few breakpoints**: the open loop on a command of one change per setpoint step (what
  an open-loop user typically replays): the floor a sampled controller cannot reach, since
  each sample instant ends a step.

Wall time: median of ``--runs`` calls after a warm-up (the compile excluded), validation and
result wrapping included.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from pneucore import simulate  # noqa: E402
from pneucore.control.closed_loop import simulate_closed_loop  # noqa: E402
from pneucore.control.models import servo_model  # noqa: E402


def timed(fn, runs):
    fn()
    ts = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--duration", type=float, default=4.0)
    ap.add_argument("--heat", default="isothermal")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    m = servo_model(heat=a.heat)
    D = a.duration
    sp = [[0.0, 0.1]] + [[0.5 * k, 0.1 + 0.01 * (k % 2)] for k in range(1, int(D / 0.5) + 1)]
    base = {"duration": D, "sample_period": 1e-3, "x0": 0.1,
            "initial": {"p_a": 5.3e5, "p_b": 5.3e5}}
    ctl = {"kind": "pid", "gains": {"kp": 15, "ki": 40, "kd": 0.1}, "setpoint": sp}
    res = simulate_closed_loop(m, dict(base, controller=ctl))
    n = int(round(D / 1e-3))
    # the controller's output at each sample instant is the held command from it on
    cmd = [[k * 1e-3, float(res.series["u"][k])] for k in range(n)]
    replay = dict(base, command=cmd, solver={"max_events": 4 * n + 1000, "max_steps": 10 ** 7})
    few = dict(base, command=[[p[0], 0.0] for p in sp[:1]] +
               [[p[0], 0.3 if k % 2 == 0 else -0.3] for k, p in enumerate(sp[1:])] +
               [[p[0] + 0.05, 0.0] for p in sp[1:]])
    few["command"].sort()
    t_closed = timed(lambda: simulate_closed_loop(m, dict(base, controller=ctl)), a.runs)
    t_replay = timed(lambda: simulate(m, replay), a.runs)
    t_few = timed(lambda: simulate(m, few), a.runs)
    rr = simulate(m, replay)
    out = {
        "duration_s": D, "heat": a.heat,
        "closed_ms_per_s": 1e3 * t_closed / D,
        "replay_ms_per_s": 1e3 * t_replay / D,
        "open_few_breakpoints_ms_per_s": 1e3 * t_few / D,
        "ratio_closed_over_replay": t_closed / t_replay,
        "ratio_closed_over_few": t_closed / t_few,
        "closed_steps": int(res.stats["steps"]), "replay_steps": int(rr.stats["steps"]),
        "replay_max_abs_x_difference_m": float(abs(rr.series["x"] - res.series["x"]).max()),
        "runs": a.runs,
    }
    for k, v in out.items():
        print(f"{k:34s} {v:.4g}" if isinstance(v, float) else f"{k:34s} {v}")
    print("target: closed loop <= 1.3x the open-loop replay per simulated second:",
          "met" if out["ratio_closed_over_replay"] <= 1.3 else "NOT met")
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
