"""Command line of the control tools: ``pneucore linearize`` and the closed-loop summary lines
of ``pneucore run`` with a scenario that carries a ``controller``."""
from __future__ import annotations

import json


def add_control_commands(sub):
    """The ``linearize`` subcommand on the CLI's subparsers."""
    p = sub.add_parser("linearize", help="state-space model, poles and natural frequency at an "
                                         "operating point (default: the valve's null at mid-stroke)")
    p.add_argument("--model", default="paper-4way", help="preset or model JSON file")
    p.add_argument("--x", type=float, default=None, help="position [m]")
    p.add_argument("--p-a", type=float, default=None, help="chamber A pressure [Pa abs]")
    p.add_argument("--p-b", type=float, default=None, help="chamber B pressure [Pa abs]")
    p.add_argument("--u", type=float, default=0.0, help="valve command [-]")
    p.add_argument("--json", help="write the whole result (A, B, C, D, poles, response) here")


def linearize_lines(args):
    """Run ``pneucore linearize``; the lines to print."""
    from pneucore.analysis.command_line import load_model
    from pneucore.control.linearize import linearize, to_json

    lin = linearize(load_model(args.model), args.x, args.p_a, args.p_b, args.u)
    op = lin["operating_point"]
    lines = [f"operating point: x {op['x'] * 1e3:.1f} mm, p_a {op['p_a'] / 1e5:.3f} bar abs, "
             f"p_b {op['p_b'] / 1e5:.3f} bar abs, u {op['u']:g}",
             f"natural frequency {lin['natural_frequency']:.3f} Hz, damping {lin['damping']:.3f}",
             f"closed form (closed chambers, no friction): isothermal "
             f"{lin['closed_form']['isothermal']:.3f} Hz, adiabatic "
             f"{lin['closed_form']['adiabatic']:.3f} Hz",
             "poles [1/s]: " + ", ".join(f"{p.real:.4g}{p.imag:+.4g}j" for p in lin["poles"])]
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(to_json(lin), fh)
        lines.append(f"wrote {args.json}")
    return lines


def control_lines(res):
    """Summary lines of a closed-loop result's ``stats.control`` (empty for an open loop)."""
    c = res.stats.get("control")
    if not c:
        return []

    def f(v, scale=1.0, fmt=".4g"):
        return "-" if v is None else format(v * scale, fmt)
    return [f"controller {c['kind']} at {1 / c['sample_period']:g} Hz, gains {c['gains']}",
            f"rise {f(c['rise_time'], 1e3)} ms, settling (2 %) {f(c['settling_time'], 1e3)} ms, "
            f"overshoot {f(c['overshoot'], 100)} %, steady-state error "
            f"{f(c['steady_state_error'], 1e6)} um, RMS error {f(c['rms_error'], 1e6)} um",
            f"hunting {f(c['hunting_amplitude'], 1e3)} mm at {f(c['hunting_frequency'])} Hz, "
            f"{c['switchings']} valve switchings, air {f(c['air_per_move'])} NL per move"]
