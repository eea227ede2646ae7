"""Command line: ``pneucore run`` simulates a preset and prints a summary.

Examples
--------
``pneucore run`` (paper-4way, Fig. 10 pulse train), ``pneucore run --model
paper-3way --scenario paper-fig9-switching --csv out.csv``,
``pneucore run --model my_model.json --scenario my_scenario.json --json out.json``.
"""
import argparse
import json
import sys
import time

from pneucore.spec.presets import MODEL_PRESETS, SCENARIO_PRESETS, model_preset, scenario_preset
from pneucore.simulate import SimulationError, simulate
from pneucore.spec.validation import FieldError

#: A simulation of a preset takes milliseconds once compiled; a run above this wall time
#: [s] includes numba's compilation, and only then the summary says so
COMPILE_NOTE_S = 2.0


class CliError(Exception):
    """A bad command-line argument, with the message to print."""


def _load(arg, presets, loader, what):
    """A preset by name, or a JSON file; a clear message listing the presets otherwise."""
    if arg in presets:
        return loader(arg)
    try:
        with open(arg) as fh:
            return json.load(fh)
    except FileNotFoundError:
        raise CliError(f"--{what} {arg!r} is neither a preset ({', '.join(presets)}) nor an "
                       "existing JSON file") from None
    except json.JSONDecodeError as exc:
        raise CliError(f"--{what} {arg!r}: not valid JSON ({exc})") from None


def summary_lines(res):
    """Human-readable summary of a result (list of lines)."""
    ev = {}
    for e in res.events:
        ev[e["kind"]] = ev.get(e["kind"], 0) + 1
    lines = [
        f"model: {res.model.name or '(custom)'}   scenario: {res.scenario.name or '(custom)'}",
        f"duration {res.scenario.duration:g} s, {len(res.t)} samples, {res.stats['steps']} steps "
        f"({res.stats['rejected']} rejected), {res.stats['rhs_evaluations']} rhs evaluations",
        f"p_a  [bar abs]  min {res.p_a.min() / 1e5:7.3f}  max {res.p_a.max() / 1e5:7.3f}  end {res.p_a[-1] / 1e5:7.3f}",
        f"p_b  [bar abs]  min {res.p_b.min() / 1e5:7.3f}  max {res.p_b.max() / 1e5:7.3f}  end {res.p_b[-1] / 1e5:7.3f}",
        f"T_a  [degC]     min {res.T_a.min() - 273.15:7.1f}  max {res.T_a.max() - 273.15:7.1f}",
        f"T_b  [degC]     min {res.T_b.min() - 273.15:7.1f}  max {res.T_b.max() - 273.15:7.1f}",
        f"x    [mm]       min {res.x.min() * 1e3:7.2f}  max {res.x.max() * 1e3:7.2f}  end {res.x[-1] * 1e3:7.2f}",
        f"v    [m/s]      min {res.v.min():7.3f}  max {res.v.max():7.3f}",
        "events: " + (", ".join(f"{k} x{n}" for k, n in sorted(ev.items())) or "none"),
    ]
    for e in res.events[:40]:
        lines.append(f"  {e['t']:9.6f} s  {e['kind']:<8s} -> {e['mode']}")
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(prog="pneucore", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="cmd")
    run = sub.add_parser("run", help="simulate a model and scenario (presets or JSON files)")
    run.add_argument("--model", default="paper-4way",
                     help=f"preset ({', '.join(MODEL_PRESETS)}) or a model JSON file")
    run.add_argument("--scenario", default="paper-fig10-pulses",
                     help=f"preset ({', '.join(SCENARIO_PRESETS)}) or a scenario JSON file")
    run.add_argument("--csv", help="write the sampled series to this CSV file")
    run.add_argument("--json", help="write the full result (series, events, stats) to this JSON file")
    run.add_argument("--npz", help="write every series and a meta.json (units, events, stats) to this "
                                   "NumPy .npz archive (numpy.load reads it)")
    sub.add_parser("presets", help="list the presets")
    sz = sub.add_parser("size", help="size a drive from a requirement JSON file "
                                     "({\"requirement\": {...}, \"choices\": {...}})")
    sz.add_argument("file", help="JSON file: {\"requirement\": {...}, \"choices\": {...}} "
                                 "(or the requirement alone)")
    sz.add_argument("--workers", type=int, default=None, help="threads (default: the CPUs)")
    sz.add_argument("--top", type=int, default=10, help="designs printed (default 10)")
    sz.add_argument("--json", help="write the whole answer to this JSON file")
    sz.add_argument("--model", help="write the best design's model to this JSON file")
    args = parser.parse_args(argv)
    if args.cmd == "size":
        return _size(args)
    if args.cmd in (None, "run") and not hasattr(args, "model"):
        args = parser.parse_args(["run"] + (argv or []))
    if args.cmd == "presets":
        for name, p in {**MODEL_PRESETS, **SCENARIO_PRESETS}.items():
            print(f"{name:24s} {p.get('description', '')}")
        return 0
    try:
        model = _load(args.model, MODEL_PRESETS, model_preset, "model")
        scenario = _load(args.scenario, SCENARIO_PRESETS, scenario_preset, "scenario")
        t0 = time.perf_counter()
        res = simulate(model, scenario)
        wall = time.perf_counter() - t0
    except (CliError, FieldError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except SimulationError as exc:
        print(f"simulation error: {exc}", file=sys.stderr)
        return 3
    for line in summary_lines(res):
        print(line)
    # a run this slow compiled the numba core (first run of a fresh install or after an edit)
    note = " (includes the one-time compilation of the core)" if wall > COMPILE_NOTE_S else ""
    print(f"wall time {wall * 1e3:.1f} ms{note}")
    if args.csv:
        from pneucore.data.export import simulation_csv
        with open(args.csv, "w", newline="") as fh:
            fh.write(simulation_csv(res))
        print(f"wrote {args.csv} (units in the header; POST /api/datasets reads it back)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(res.to_dict(), fh)
        print(f"wrote {args.json}")
    if args.npz:
        from pneucore.data.npz import simulation_npz
        with open(args.npz, "wb") as fh:
            fh.write(simulation_npz(res))
        print(f"wrote {args.npz} (numpy.load reads it; units in meta.json)")
    return 0


def _size(args):
    """``pneucore size requirement.json``: the ranked designs and the reasons, as a table."""
    from pneucore.sizing import size
    try:
        with open(args.file) as fh:
            data = json.load(fh)
        if not isinstance(data, dict):
            raise CliError(f"{args.file}: expected a JSON object")
        req, choices = (data["requirement"], data.get("choices")) if "requirement" in data \
            else (data, None)
        t0 = time.perf_counter()
        ans = size(req, choices, workers=args.workers)
        wall = time.perf_counter() - t0
    except (CliError, FieldError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for line in sizing_lines(ans, args.top):
        print(line)
    print(f"wall time {wall:.2f} s")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(ans, fh, indent=1)
        print(f"wrote {args.json}")
    if args.model:
        if not ans["designs"]:
            print("error: no design to write", file=sys.stderr)
            return 1
        with open(args.model, "w") as fh:
            json.dump(ans["designs"][0]["model"], fh, indent=1)
        print(f"wrote {args.model} (pneucore run --model {args.model} simulates it)")
    return 0 if any(d["feasible"] for d in ans["designs"]) else 1


def sizing_lines(ans, top=10):
    """Human-readable table of a sizing answer (list of lines)."""
    lines = [ans["summary"],
             f"{'rank':>4}  {'cylinder':<14} {'valve':<16} {'tube':<16} {'air NL':>8} "
             f"{'t_ext s':>8} {'t_ret s':>8} {'v_end m/s':>10} {'meter-out':>12}"]
    for d in ans["designs"][:top]:
        m = d["metrics"]
        fmt = lambda v, f: format(v, f) if v is not None else "-"   # noqa: E731
        lines.append(
            f"{d['rank']:>4}  {d['cylinder']['name']:<14} {d['valve']['name']:<16} "
            f"{(d['tube'] or {}).get('name', '-'):<16} {d['air_per_cycle']:8.3f} "
            f"{fmt(m['extend']['full_stroke_time'], '8.3f')} {fmt(m['retract']['full_stroke_time'], '8.3f')} "
            f"{fmt(max(m['extend']['end_speed'] or 0, m['retract']['end_speed'] or 0), '10.3f')} "
            f"{d['settings']['extend_meter_out']:5.3f}/{d['settings']['retract_meter_out']:5.3f}"
            + ("" if d["feasible"] else "  (not feasible)"))
    if ans["reasons"]:
        lines.append("infeasible families: " + ", ".join(f"{n} {r}" for r, n in sorted(ans["reasons"].items())))
    for note in ans["notes"]:
        lines.append(f"note: {note}")
    return lines


if __name__ == "__main__":
    sys.exit(main())
