"""Command line: ``pneucore run`` simulates a preset and prints a summary; ``pneucore
compare``, ``diagnose`` and ``refine`` run the modelling loop on measurement files
(:mod:`pneucore.analysis.command_line`).

Examples
--------
``pneucore run`` (paper-4way, Fig. 10 pulse train), ``pneucore run --model
paper-3way --scenario paper-fig9-switching --csv out.csv``,
``pneucore run --model my_model.json --scenario my_scenario.json --json out.json``.

``pneucore identify valve points.csv --edge P-A --model paper-4way --json out.json`` fits an
edge's C(u), b(u) tables to flow-bench points (CSV with a header ``opening,p_up,p_down,T_up,flow``
in SI units, or JSON); ``pneucore identify friction --model m.json --fit O-ring_1bar.csv
O-ring_3bar.csv --validate O-ring_5bar.csv`` fits the friction law to friction-bench records
(the TU Delft bench's 7-column files as they are, or JSON records ``{t, x, p_a, p_b, F}``).
"""
import argparse
import json
import sys
import time

from pneucore.analysis.command_line import (COMMANDS, LoopArgumentError, add_loop_commands, load_model,
                                            load_scenario, run_loop)
from pneucore.physics.gas import T_ZERO_CELSIUS
from pneucore.description.presets import MODEL_PRESETS, SCENARIO_PRESETS
from pneucore.simulate import SimulationError, simulate
from pneucore.description.validation import FieldError

#: A simulation of a preset takes milliseconds once compiled; a run above this wall time
#: [s] includes numba's compilation, and only then the summary says so
COMPILE_NOTE_S = 2.0


class CliError(Exception):
    """A bad command-line argument, with the message to print."""


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
        f"T_a  [degC]     min {res.T_a.min() - T_ZERO_CELSIUS:7.1f}  max {res.T_a.max() - T_ZERO_CELSIUS:7.1f}",
        f"T_b  [degC]     min {res.T_b.min() - T_ZERO_CELSIUS:7.1f}  max {res.T_b.max() - T_ZERO_CELSIUS:7.1f}",
        f"x    [mm]       min {res.x.min() * 1e3:7.2f}  max {res.x.max() * 1e3:7.2f}  end {res.x[-1] * 1e3:7.2f}",
        f"v    [m/s]      min {res.v.min():7.3f}  max {res.v.max():7.3f}",
        "events: " + (", ".join(f"{k} x{n}" for k, n in sorted(ev.items())) or "none"),
    ]
    cyc = res.stats.get("cyclic")
    if cyc:
        st = cyc["state"]
        lines.insert(2, f"start: cyclic steady state after {cyc['cycles']} cycles"
                        f"{'' if cyc['converged'] else ' (NOT converged)'}: p_a {st['p_a'] / 1e5:.4f}, "
                        f"p_b {st['p_b'] / 1e5:.4f} bar abs, T_a {st['T_a'] - T_ZERO_CELSIUS:.2f}, "
                        f"T_b {st['T_b'] - T_ZERO_CELSIUS:.2f} degC, x0 {st['x0'] * 1e3:.3f} mm")
    for e in res.events[:40]:
        lines.append(f"  {e['t']:9.6f} s  {e['kind']:<8s} -> {e['mode']}")
    return lines


def _description():
    """The module docstring's first paragraph, whole (its first line alone stops mid-sentence),
    with the reST double backquotes dropped for the terminal."""
    import re
    first = " ".join(__doc__.strip().split("\n\n")[0].split())
    return re.sub(r":\w+:`([^`]*)`", r"\1", first).replace("``", "")


def stroke_table_lines(res, model):
    """The stroke table (:func:`pneucore.analysis.strokes.stroke_metrics`, SMC's definitions
    timed from the valve switching) as lines: one row per command, times [s], speeds [m/s],
    impact energy [J], air [NL]; ``-`` where undefined (a partial stroke)."""
    from pneucore.analysis.strokes import stroke_metrics
    from pneucore.description.model import Model
    m = stroke_metrics(res, model if isinstance(model, Model) else Model.from_dict(model))
    if not m["strokes"]:
        return ["strokes: none (no command event)"]
    cols = [("t_command", "t_cmd s", ".4f"), ("direction", "stroke", ""),
            ("start_up_time", "start-up s", ".4f"), ("full_stroke_time", "full s", ".4f"),
            ("force_90_time", "90% force s", ".4f"), ("mean_speed", "mean m/s", ".3f"),
            ("max_speed", "max m/s", ".3f"), ("end_speed", "end m/s", ".3f"),
            ("end_energy", "end J", ".4f"), ("air_NL", "air NL", ".4f")]
    width = [max(len(h), 10) for _, h, _ in cols]
    lines = ["strokes (SMC: times from the valve switching):",
             "  " + " ".join(f"{h:>{w}}" for (_, h, _), w in zip(cols, width))]
    for s in m["strokes"]:
        cells = ["-" if s[k] is None else format(s[k], f) for k, _, f in cols]
        lines.append("  " + " ".join(f"{c:>{w}}" for c, w in zip(cells, width)))
    if m["air_per_cycle_NL"] is not None:
        lines.append(f"  air per cycle {m['air_per_cycle_NL']:.4f} NL (ANR)")
    return lines


def _loop(args):
    """Run a loop command; the exit status (0, or 2 for bad input with its message)."""
    from pneucore.data.measurement import MeasurementError
    try:
        lines = run_loop(args)
    except (LoopArgumentError, FieldError, MeasurementError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for line in lines:
        print(line)
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(prog="pneucore", description=_description(),
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
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
    sub.add_parser("samples", help="list the shipped samples (rig data hiding known effects)")
    add_loop_commands(sub)
    from pneucore.control.command_line import add_control_commands
    add_control_commands(sub)
    ident = sub.add_parser("identify", help="identify a component on its bench (valve, friction)")
    isub = ident.add_subparsers(dest="bench", required=True)
    iv = isub.add_parser("valve", help="an edge's C(u), b(u) tables from flow-bench points")
    iv.add_argument("points", help="CSV (header opening,p_up,p_down,T_up,flow; SI) or JSON points")
    iv.add_argument("--edge", default="P-A", help="edge name (P-A, A-R, P-B, B-R)")
    iv.add_argument("--model", help="preset or model JSON file to write the table into")
    iv.add_argument("--json", help="write the result (and the model, when given) to this JSON file")
    ifr = isub.add_parser("friction", help="the friction law from friction-bench records")
    ifr.add_argument("--model", default="paper-4way", help="preset or model JSON file (the jack)")
    ifr.add_argument("--fit", nargs="+", required=True, help="records to fit on")
    ifr.add_argument("--validate", nargs="*", default=[], help="records to predict")
    ifr.add_argument("--extras", nargs="*", default=[], help="also identify: offset, area_a, area_b, mass")
    ifr.add_argument("--columns", default=None,
                     help="a headerless file's columns in order, e.g. 't[s],x[mm],p_a[bar(g)],F[N]' "
                          "(- for a column not read, -x negates); default: the TU Delft friction bench's")
    ifr.add_argument("--json", help="write the result (with the model) to this JSON file")
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
    if args.cmd == "samples":
        from pneucore.data.samples import list_samples
        for s in list_samples():
            print(f"{s['id']:24s} {s['description']}")
        return 0
    if args.cmd in COMMANDS:
        return _loop(args)
    if args.cmd == "linearize":
        from pneucore.control.command_line import linearize_lines
        try:
            lines = linearize_lines(args)
        except (LoopArgumentError, FieldError, ValueError, OSError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        print("\n".join(lines))
        return 0
    if args.cmd == "identify":
        try:
            return _identify(args)
        except (CliError, FieldError, ValueError, OSError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
    try:
        model = load_model(args.model)
        scenario = load_scenario(args.scenario)
        t0 = time.perf_counter()
        if isinstance(scenario, dict) and scenario.get("controller") is not None:
            from pneucore.control.closed_loop import simulate_closed_loop  # issue 42
            res = simulate_closed_loop(model, scenario)
        else:
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
    from pneucore.control.command_line import control_lines
    for line in control_lines(res):
        print(line)
    for line in stroke_table_lines(res, res.model):
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


def _bench_points(path):
    """Flow-bench points from a CSV file with a header (SI units) or a JSON file."""
    import csv
    if str(path).endswith(".json"):
        with open(path) as fh:
            data = json.load(fh)
        return data["points"] if isinstance(data, dict) else data
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    return [{k: (None if v in ("", None) else float(v)) for k, v in row.items()} for row in rows]


def _bench_record(path, columns=None):
    """A friction-bench record: JSON ``{t, x, p_a, p_b, F}`` or a headerless file as the rig
    writes it (``columns``: its layout, comma-separated; None = the TU Delft bench's)."""
    from pneucore.identify.friction_bench import RIG_COLUMNS, FrictionRecord, read_bench_file
    if str(path).endswith(".json"):
        with open(path) as fh:
            return FrictionRecord.from_dict(json.load(fh), str(path))
    return read_bench_file(path, columns=columns or RIG_COLUMNS, field=str(path))


def _identify(args):
    """``pneucore identify valve|friction``: print the report, write the JSON."""
    from pneucore.identify import identify_friction, identify_valve, predict_rod_force
    from pneucore.description.model import Model

    if args.bench == "valve":
        model = Model.from_dict(load_model(args.model)) if args.model else None
        kw = {"u_range": model.valve.opening_range, "laminar_ratio": model.valve.laminar_ratio} if model else {}
        res = identify_valve(_bench_points(args.points), args.edge, **kw)
        print(res.report())
        if res.null_band:
            print(f"null band: {res.null_band}")
        out = res.to_dict()
        if model is not None:
            out["model"] = res.write_into(model).to_dict()
    else:
        model = Model.from_dict(load_model(args.model))
        res = identify_friction(model, [_bench_record(p, args.columns) for p in args.fit], extras=args.extras)
        print(res.report())
        out = res.to_dict()
        out["validation"] = []
        for path in args.validate:
            pred = predict_rod_force(res.model, _bench_record(path, args.columns), v_min=res.v_min)
            print(f"validation {pred['name']}: rms {pred['rms']:.3g} N, mean {pred['mean']:+.3g} N; "
                  f"extend {pred['extend']['mean']:+.3g} / {pred['extend']['rms']:.3g} N, "
                  f"retract {pred['retract']['mean']:+.3g} / {pred['retract']['rms']:.3g} N")
            out["validation"].append(pred)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh)
        print(f"wrote {args.json}")
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


def _cushion_cells(c):
    """A design's cushion columns: each end's needle (``open`` where not needed) and the larger
    impact energy over the capacity."""
    needle = [format(c[k]["needle_C"], ".3g") if c[k]["needle_solved"] else "open"
              for k in ("extend", "retract")]
    ratio = max((c[k]["energy_ratio"] or 0.0) for k in ("extend", "retract"))
    return f" {needle[0] + '/' + needle[1]:>36} {ratio:15.3f}"


def _steady_cell(steady):
    """The steady cycle's full-stroke times, extension/retraction [s] (``-`` where not run)."""
    if not steady or "full_stroke_time" not in steady:
        return "-"
    t = steady["full_stroke_time"]
    return "/".join("-" if t[k] is None else format(t[k], ".3f") for k in ("extend", "retract"))


def sizing_lines(ans, top=10):
    """Human-readable table of a sizing answer (list of lines)."""
    cushioned = any(d.get("cushion") for d in ans["designs"])
    lines = [ans["summary"],
             f"{'rank':>4}  {'cylinder':<14} {'valve':<16} {'tube':<16} {'air NL':>8} "
             f"{'t_ext s':>8} {'t_ret s':>8} {'steady ext/ret s':>17} {'v_end m/s':>10} "
             f"{'meter-out C ' + ans['units']['settings.*_meter_out_C']:>23}"
             + (f" {'needle C ext/ret (open: not needed)':>36} {'E_end/capacity':>15}"
                if cushioned else "")]
    for d in ans["designs"][:top]:
        m = d["metrics"]
        fmt = lambda v, f: format(v, f) if v is not None else "-"   # noqa: E731
        lines.append(
            f"{d['rank']:>4}  {d['cylinder']['name']:<14} {d['valve']['name']:<16} "
            f"{(d['tube'] or {}).get('name', '-'):<16} {d['air_per_cycle']:8.3f} "
            f"{fmt(m['extend']['full_stroke_time'], '8.3f')} {fmt(m['retract']['full_stroke_time'], '8.3f')} "
            f"{_steady_cell(d.get('steady_cycle')):>17} "
            f"{fmt(max(m['extend']['end_speed'] or 0, m['retract']['end_speed'] or 0), '10.3f')} "
            f"{d['settings']['extend_meter_out_C']:11.3g}/{d['settings']['retract_meter_out_C']:<9.3g}"
            + (_cushion_cells(d["cushion"]) if cushioned and d.get("cushion") else "")
            + ("" if d["feasible"] else "  (not feasible)"))
    if ans["reasons"]:
        lines.append("infeasible families: " + ", ".join(f"{n} {r}" for r, n in sorted(ans["reasons"].items())))
    for note in ans["notes"]:
        lines.append(f"note: {note}")
    return lines


if __name__ == "__main__":
    sys.exit(main())
