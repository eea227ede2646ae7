"""Command line of the modelling loop: ``pneucore compare``, ``pneucore diagnose`` and
``pneucore refine`` over a model and measurement files (or a shipped sample).

The answers are the API's: the same functions (:func:`pneucore.analysis.compare.compare`,
:func:`pneucore.analysis.diagnose.diagnose`, :func:`pneucore.analysis.history.refine` with
:func:`pneucore.analysis.history.refinement_answer`) and the same JSON (``--json``) as
POST /api/compare, /api/diagnose and /api/refine, and the same HTML reports (``--report``).

Examples
--------
``pneucore diagnose --sample leak-and-lag`` (the paper's model on a shipped sample),
``pneucore refine --model my_model.json --data hold.csv --scenario '{"locked": true}'
--data pulses.csv --scenario '{"x0": 0.05}' --report refine.html --model-out fitted.json``,
``pneucore compare --data rig.csv --columns '{"Zeit": "t", "pA": "p_a[bar(g)]"}' --json out.json``,
``pneucore propose-command rig.mat --columns map.json`` (a record without a command column: the
command read from its pressure's edges, as the page proposes it; ``--propose-command`` on the
loop's commands uses it directly).

A record made in closed loop (its ``--scenario`` names the ``controller``, as POST
/api/simulate takes it) is replayed open loop with its recorded valve command (the file's
``u`` column, or ``scenario.command``), the controller not simulated, and the output says so:
a ``closed loop:`` line per such record, and ``closed_loop`` in the JSON as the API answers it.
"""
from __future__ import annotations

import json
from pathlib import Path

from pneucore.description.presets import MODEL_PRESETS, SCENARIO_PRESETS, model_preset, scenario_preset

#: The loop's commands: name -> one line of help
COMMANDS = {
    "compare": "compare a model with measurements (Eq. 25 errors per signal, where it fails)",
    "diagnose": "name the physical effect the model misses (one round of the diagnosis)",
    "refine": "diagnose, apply, repeat to the noise floor (the refinement loop)",
    "propose-command": "propose a valve command from a record's pressure edges (a record "
                       "without a command column), as the page and POST "
                       "/api/datasets/{id}/propose-command do",
}


class LoopArgumentError(ValueError):
    """A bad argument of a loop command, with the message to print."""


def add_loop_commands(sub):
    """Add ``compare``, ``diagnose`` and ``refine`` to an argparse subparsers object.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The command line's subparsers [-]
    """
    for name, helptext in COMMANDS.items():
        p = sub.add_parser(name, help=helptext, description=helptext)
        if name == "propose-command":
            p.add_argument("data", metavar="FILE", help="the measurement file (CSV, TDMS, "
                                                        "MATLAB .mat, .npz)")
            p.add_argument("--columns", help="column mapping, as inline JSON or a JSON file")
            p.add_argument("--model", default="paper-4way",
                           help="preset or model JSON file (its ambient pressure reads gauge "
                                "columns)")
            p.add_argument("--signal", choices=("p_a", "p_b"), default=None,
                           help="the pressure read (default: p_a if measured, else p_b)")
            _switching_arg(p)
            p.add_argument("--json", help="write the proposal (the API's JSON) to this file")
            continue
        p.add_argument("--model", default="paper-4way",
                       help=f"preset ({', '.join(MODEL_PRESETS)}) or a model JSON file "
                            "(the API's model, or a refine/diagnose --json answer holding one)")
        src = p.add_mutually_exclusive_group(required=True)
        src.add_argument("--sample", help="a shipped sample's experiments (see `pneucore samples`)")
        src.add_argument("--data", action="append", metavar="FILE",
                         help="a measurement file (CSV, TDMS, MATLAB .mat, .npz); repeat for "
                              "several tests diagnosed together")
        p.add_argument("--scenario", action="append", metavar="SCENARIO",
                       help="the context of each --data file, in order (one for all, or one "
                            "each): a scenario preset, a JSON file, or inline JSON such as "
                            "'{\"locked\": true}' or '{\"x0\": 0.05}'; command and duration "
                            "default to the file's")
        p.add_argument("--columns", help="column mapping for every --data file, as inline JSON "
                                         "or a JSON file: {\"Zeit\": \"t\", \"pA\": \"p_a[bar(g)]\"}")
        p.add_argument("--json", help="write the answer (the API's JSON) to this file")
        p.add_argument("--report", help="write a self-contained HTML report to this file")
        p.add_argument("--propose-command", action="store_true",
                       help="a --data file without a command column and without "
                            "scenario.command gets the command proposed from its pressure's "
                            "edges (printed; as `pneucore propose-command` gives it)")
        _switching_arg(p)
        if name in ("diagnose", "refine"):
            p.add_argument("--uncertain", help="base parameter paths refitted along, comma "
                                               "separated (default: chosen automatically)")
            p.add_argument("--known", help="parameter paths whose values are known (a weighed "
                                           "mass, a measured bore), comma separated: never "
                                           "fitted; a disagreement is said as a finding")
            p.add_argument("--model-out", help="write the refined model (verdict applied) as "
                                               "JSON to this file")
        if name == "diagnose":
            p.add_argument("--candidates", help="catalog effects to try, comma separated "
                                                "(default: every applicable one)")
        if name == "refine":
            p.add_argument("--max-rounds", type=int, default=4, help="most effects to add (1-10)")


def _json_arg(text, what, presets=()):
    """Inline JSON, or a JSON file's content; ``presets``: the names that were also possible,
    listed when ``text`` is none of them."""
    stripped = text.strip()
    if stripped.startswith(("{", "[")):
        try:
            return json.loads(stripped)
        except json.JSONDecodeError as exc:
            raise LoopArgumentError(f"{what}: not valid JSON ({exc})") from None
    try:
        return json.loads(Path(text).read_text())
    except FileNotFoundError:
        named = f"a preset ({', '.join(presets)}), " if presets else ""
        raise LoopArgumentError(f"{what} {text!r} is neither {named}inline JSON nor an existing "
                                "JSON file") from None
    except json.JSONDecodeError as exc:
        raise LoopArgumentError(f"{what} {text!r}: not valid JSON ({exc})") from None


def load_model(arg):
    """A model dict: a preset by name, a model JSON file, or the ``model`` of a saved answer.

    Parameters
    ----------
    arg : str
        Preset name or path [-]

    Returns
    -------
    model : dict
        The model's JSON [-]
    """
    if arg in MODEL_PRESETS:
        return model_preset(arg)
    d = _json_arg(arg, "--model", MODEL_PRESETS)
    if isinstance(d, dict) and isinstance(d.get("model"), dict) and "jack" not in d:
        d = d["model"]   # a refine/diagnose answer saved with --json, or a fitted-model export
    if not isinstance(d, dict):
        raise LoopArgumentError(f"--model {arg!r}: a JSON object is expected")
    return d


def _switching_arg(p):
    p.add_argument("--switching-time", type=float, default=0.0, metavar="SECONDS",
                   help="the valve's switching time after its command [s]: a proposed "
                        "command leads the pressure's turns by it (default 0)")


def _proposal_lines(name, prop):
    """The lines printed for a proposed command: its pulses, its rule, its unsure edges."""
    pulses = ", ".join(f"{a:.3f}-{'end' if b is None else f'{b:.3f}'} s"
                       for a, b in prop["pulses"][:12])
    more = f" (+{len(prop['pulses']) - 12} more)" if len(prop["pulses"]) > 12 else ""
    return [f"{name}: proposed command, {len(prop['pulses'])} pulse(s): {pulses}{more}",
            f"  {prop['note']}"]


def propose_lines(args):
    """``pneucore propose-command FILE``: the proposal's lines (and its JSON with ``--json``).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line [-]

    Returns
    -------
    lines : list of str
        The summary printed on the terminal [-]
    """
    from pneucore.data.command import propose_command
    from pneucore.data.fileformats import read_measurement
    from pneucore.description.model import Model
    if not 0.0 <= args.switching_time <= 0.5:
        raise LoopArgumentError(f"--switching-time {args.switching_time}: between 0 and 0.5 s")
    amb = Model.from_dict(load_model(args.model)).ambient.pressure
    path = Path(args.data)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise LoopArgumentError(f"{args.data!r}: {exc.strerror or exc}") from None
    columns = _json_arg(args.columns, "--columns") if args.columns else None
    meas = read_measurement(data, filename=path.name, ambient_pressure=amb, columns=columns,
                            isolated=False)
    prop = propose_command(meas, args.signal, switching_time=args.switching_time)
    prop["has_command"] = "u" in meas.signals
    from pneucore.data.command import propose_b_chamber
    prop["chamber_b"] = propose_b_chamber(meas, prop["pulses"], amb)
    lines = _proposal_lines(path.stem, prop)
    cb = prop["chamber_b"]
    if cb["b_chamber"]:
        lines.append(f"  chamber B of a 3/2 valve: {cb['b_chamber']} proposed"
                     f"{'' if cb['sure'] else ' (likely)'}: {cb['why']}; set valve.b_chamber")
    if prop["has_command"]:
        lines.append("  the record has its own command column u: it is used unless a "
                     "scenario.command is given")
    lines.append("  give it as --scenario '{\"command\": ...}' (see --json), or run the loop "
                 "with --propose-command")
    if args.json:
        Path(args.json).write_text(json.dumps(prop))
        lines.append(f"wrote {args.json}")
    return lines


def load_scenario(arg):
    """A scenario dict: a preset by name, a scenario JSON file, or inline JSON.

    Parameters
    ----------
    arg : str
        Preset name, path or JSON text [-]

    Returns
    -------
    scenario : dict
        The scenario's JSON [-]
    """
    if arg in SCENARIO_PRESETS:
        return scenario_preset(arg)
    d = _json_arg(arg, "--scenario", SCENARIO_PRESETS)
    if not isinstance(d, dict):
        raise LoopArgumentError(f"--scenario {arg!r}: a JSON object is expected")
    return d


def load_experiments(args, ambient_pressure):
    """The experiments of a loop command: a sample's, or the ``--data`` files read with the
    API's reader, each with its ``--scenario``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line [-]
    ambient_pressure : float
        The model's ambient pressure, added to gauge pressures [Pa]

    Returns
    -------
    experiments : list of dict
        ``{"name", "scenario", "measurement"}`` each, as
        :func:`pneucore.data.experiment.as_experiments` takes them [-]
    """
    if args.sample:
        from pneucore.data.samples import list_samples, load_sample
        try:
            return load_sample(args.sample)
        except KeyError:
            ids = ", ".join(s["id"] for s in list_samples())
            raise LoopArgumentError(f"--sample {args.sample!r} is not a shipped sample "
                                    f"({ids})") from None
    from pneucore.data.fileformats import read_measurement
    files = args.data
    scen = args.scenario or []
    if len(scen) not in (0, 1, len(files)):
        raise LoopArgumentError(f"{len(scen)} --scenario for {len(files)} --data: give one for "
                                "all files or one for each, in order")
    columns = _json_arg(args.columns, "--columns") if args.columns else None
    out = []
    for i, f in enumerate(files):
        path = Path(f)
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise LoopArgumentError(f"--data {f!r}: {exc.strerror or exc}") from None
        meas = read_measurement(data, filename=path.name, ambient_pressure=ambient_pressure,
                                columns=columns, isolated=False)   # the user's own files
        s = load_scenario(scen[0] if len(scen) == 1 else scen[i]) if scen else {}
        if getattr(args, "propose_command", False) and "u" not in meas.signals \
                and "command" not in s:
            from pneucore.data.command import propose_command
            prop = propose_command(meas, switching_time=args.switching_time)
            s = dict(s, command=prop["command"])
            args.proposals = getattr(args, "proposals", []) + _proposal_lines(path.stem, prop)
        out.append({"name": path.stem, "scenario": s, "measurement": meas})
    return out


def _paths(text):
    return [p.strip() for p in text.split(",") if p.strip()] if text else None


def _errors_line(errors, overall):
    parts = [f"{s} {100 * e:.3g} %" for s, e in errors.items() if e is not None]
    return f"Eq. 25 error {100 * overall:.3g} % ({', '.join(parts)})" if overall is not None \
        else "Eq. 25 error: none computable"


def closed_loop_lines(replays):
    """The terminal's lines on the experiments recorded in closed loop.

    Parameters
    ----------
    replays : list of dict
        :func:`pneucore.data.experiment.closed_loop_replays` [-]

    Returns
    -------
    lines : list of str
        One per experiment: its name and what was replayed [-]
    """
    return [f"closed loop: {r['experiment']}: {r['note']}" for r in replays]


def run_loop(args):
    """Run one loop command; returns the lines to print.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line (``cmd`` is compare, diagnose or refine) [-]

    Returns
    -------
    lines : list of str
        The summary printed on the terminal [-]
    """
    from pneucore.analysis.compare import compare
    from pneucore.analysis.report import comparison_report, diagnosis_report_on, refinement_report
    from pneucore.data.experiment import as_experiments, closed_loop_replays
    from pneucore.description.model import Model

    if args.cmd == "propose-command":
        return propose_lines(args)
    if not 0.0 <= args.switching_time <= 0.5:
        raise LoopArgumentError(f"--switching-time {args.switching_time}: between 0 and 0.5 s")
    model = Model.from_dict(load_model(args.model))
    args.proposals = []
    exps = as_experiments(load_experiments(args, model.ambient.pressure), model.ambient.pressure)
    lines, model_out = list(args.proposals), None
    if args.cmd == "compare":
        c = compare(model, exps)
        answer = c.to_dict()
        html = comparison_report(model, c) if args.report else None
        lines.append(_errors_line(c.errors, c.overall))
        lines += [f"  where: {w.get('description', '')}" for w in c.windows[:3]]
    elif args.cmd == "diagnose":
        from pneucore.analysis.diagnose import check_request, diagnose
        uncertain = _paths(args.uncertain) or ()
        candidates = _paths(args.candidates)
        known = _paths(args.known) or ()
        check_request(model, candidates, uncertain, known)
        d = diagnose(model, exps, candidates=candidates, uncertain=uncertain, validated=True,
                     known=known)
        answer = d.to_dict()
        html = diagnosis_report_on(model, exps, answer) if args.report else None
        lines.append(f"verdict: {d.verdict or 'none'}")
        lines.append(d.message)
        model_out = d.model
    else:
        from pneucore.analysis.diagnose import check_request
        from pneucore.analysis.history import refine, refinement_answer
        if not 1 <= args.max_rounds <= 10:
            raise LoopArgumentError(f"--max-rounds {args.max_rounds}: between 1 and 10")
        uncertain = _paths(args.uncertain) or ()
        known = _paths(args.known) or ()
        check_request(model, None, uncertain, known)
        final, history, diagnoses = refine(model, exps, max_rounds=args.max_rounds,
                                           uncertain=uncertain, validated=True, known=known)
        answer = refinement_answer(final, history, diagnoses)
        html = refinement_report(answer, compare(final, exps)) if args.report else None
        for v in answer["versions"]:
            lines.append(f"version {v['version']}: {v['label']:<40s} "
                         f"{100 * v['overall']:.3g} %" if v.get("overall") is not None
                         else f"version {v['version']}: {v['label']}")
        lines.append(answer["message"])
        model_out = final
    # a record made in closed loop is replayed open loop with its recorded command: said in
    # the answer (compare: each experiment's closed_loop; diagnose and refine: closed_loop, as
    # the API answers) and on the terminal
    closed = closed_loop_replays(exps)
    if closed and args.cmd != "compare" and isinstance(answer, dict):
        answer["closed_loop"] = closed
    lines += closed_loop_lines(closed)
    if args.json:
        Path(args.json).write_text(json.dumps(answer))
        lines.append(f"wrote {args.json}")
    if args.report:
        Path(args.report).write_text(html, encoding="utf-8")
        lines.append(f"wrote {args.report} (opens offline in any browser)")
    if getattr(args, "model_out", None):
        if model_out is None:
            lines.append(f"no refined model to write to {args.model_out}: nothing was found")
        else:
            Path(args.model_out).write_text(json.dumps(model_out.to_dict(), indent=1))
            lines.append(f"wrote {args.model_out} (pneucore and the API read it as a model)")
    return lines
