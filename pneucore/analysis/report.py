"""Self-contained HTML reports of a comparison or a diagnosis.

One file that opens offline in any browser: plots as inline SVG drawn here
(no script, no CDN, no external asset), tables of the Eq. 25 errors (as
percentages in the text; the API's fields are fractions), the failure
windows, the diagnosis ranking, the model as JSON and the data provenance
(experiment, dataset, samples, time span, source file and unit conversions
when known). Every text that comes from a request is escaped.
"""
from __future__ import annotations

import html
import json
import math
import time

import numpy as np

from pneucore.data.measurement import SIGNAL_UNITS

__all__ = ["comparison_report", "diagnosis_report", "diagnosis_report_on", "refinement_report", "svg_plot"]

#: Display scale of each signal in the plots: (factor from SI, unit shown)
_DISPLAY = {"p_a": (1e-5, "bar abs"), "p_b": (1e-5, "bar abs"), "x": (1e3, "mm"),
            "v": (1.0, "m/s"), "T_a": (1.0, "K"), "T_b": (1.0, "K")}
_COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd")
#: Points drawn per line at most (min/max per bucket keeps the peaks)
MAX_POINTS = 1500

_CSS = """body{font-family:system-ui,sans-serif;margin:2em auto;max-width:980px;color:#222}
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:.2em .6em;
text-align:right}th{background:#f4f4f4}td.l,th.l{text-align:left}pre{background:#f7f7f7;
padding:.6em;overflow:auto;max-height:24em;font-size:.8em}svg{display:block;margin:.4em 0}
.note{color:#555;font-size:.9em}"""


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _pct(x) -> str:
    return "—" if x is None or not math.isfinite(float(x)) else f"{100 * float(x):.3g} %"


def _decimate(x, y):
    x, y = np.asarray(x, float), np.asarray(y, float)
    n = len(x)
    if n <= MAX_POINTS:
        return x, y
    k = int(math.ceil(n / (MAX_POINTS / 2)))
    idx = []
    for i in range(0, n, k):
        seg = y[i:i + k]
        if np.all(np.isnan(seg)):
            continue
        a, b = i + int(np.nanargmin(seg)), i + int(np.nanargmax(seg))
        idx += sorted({a, b})
    idx = np.array(idx, dtype=int)
    return x[idx], y[idx]


def nice_ticks(lo: float, hi: float, target: int = 6) -> np.ndarray:
    """Tick values on a 1-2-5 grid covering ``[lo, hi]``, as a person would label an axis.

    The step is the power of ten times 1, 2 or 5 nearest to the range over ``target``
    (Heckbert, "Nice numbers for graph labels", Graphics Gems, 1990: a fraction below 1.5
    rounds to 1, below 3 to 2, below 7 to 5, else 10); the ticks are the step's
    multiples inside the range, so they read 0, 0.2, 0.4 ... and never 0.2083.

    Parameters
    ----------
    lo, hi : float
        The axis range, any unit [-]
    target : int
        About how many intervals [-]

    Returns
    -------
    ticks : numpy.ndarray
        Multiples of the step within ``[lo, hi]`` (at least two values) [-]

    Examples
    --------
    >>> nice_ticks(0.0, 1.25).tolist()
    [0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.2]
    >>> nice_ticks(1.37, 6.2, 4).tolist()
    [2.0, 3.0, 4.0, 5.0, 6.0]
    """
    lo, hi = float(lo), float(hi)
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return np.array([lo, hi])
    raw = (hi - lo) / max(int(target), 1)
    mag = 10.0 ** math.floor(math.log10(raw))
    frac = raw / mag
    step = mag * (1.0 if frac < 1.5 else 2.0 if frac < 3.0 else 5.0 if frac < 7.0 else 10.0)
    first, last = math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9)
    ticks = np.arange(first, last + 1) * step
    # round away the float noise of k * step (0.30000000000000004 -> 0.3)
    digits = max(0, -int(math.floor(math.log10(step))) + 2)
    ticks = np.round(ticks, digits) + 0.0
    return ticks if ticks.size >= 2 else np.array([lo, hi])


def svg_plot(lines, title="", xlabel="t [s]", ylabel="", width=900, height=230) -> str:
    """A line plot as inline SVG.

    Parameters
    ----------
    lines : list of (x, y, label)
        Series to draw; NaN breaks a line [-]
    title, xlabel, ylabel : str
        Texts (escaped) [-]
    width, height : int
        Size in CSS pixels [-]

    Returns
    -------
    svg : str
        An ``<svg>`` element with axes, ticks and a legend [-]
    """
    ml, mr, mt, mb = 64, 12, 24, 36
    pw, ph = width - ml - mr, height - mt - mb
    data = [(*_decimate(x, y), lab) for x, y, lab in lines]
    xs = np.concatenate([d[0] for d in data]) if data else np.array([0.0, 1.0])
    ys = np.concatenate([d[1] for d in data]) if data else np.array([0.0, 1.0])
    ys = ys[np.isfinite(ys)]
    x0, x1 = (float(np.nanmin(xs)), float(np.nanmax(xs))) if xs.size else (0.0, 1.0)
    y0, y1 = (float(ys.min()), float(ys.max())) if ys.size else (0.0, 1.0)
    if x1 <= x0:
        x1 = x0 + 1.0
    if y1 <= y0:
        y0, y1 = y0 - 0.5 * (abs(y0) or 1.0), y1 + 0.5 * (abs(y1) or 1.0)
    pad = 0.05 * (y1 - y0)
    y0, y1 = y0 - pad, y1 + pad

    def px(v):
        return ml + (v - x0) / (x1 - x0) * pw

    def py(v):
        return mt + (1 - (v - y0) / (y1 - y0)) * ph

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'viewBox="0 0 {width} {height}" font-size="11" font-family="sans-serif">',
           f'<text x="{ml}" y="15" font-weight="bold">{_e(title)}</text>',
           f'<rect x="{ml}" y="{mt}" width="{pw}" height="{ph}" fill="none" stroke="#999"/>']
    for v in nice_ticks(x0, x1, 6):
        out.append(f'<line x1="{px(v):.1f}" y1="{mt + ph}" x2="{px(v):.1f}" y2="{mt + ph + 4}" stroke="#999"/>'
                   f'<text x="{px(v):.1f}" y="{mt + ph + 15}" text-anchor="middle">{v:.6g}</text>')
    for v in nice_ticks(y0, y1, 4):
        out.append(f'<line x1="{ml - 4}" y1="{py(v):.1f}" x2="{ml + pw}" y2="{py(v):.1f}" stroke="#eee"/>'
                   f'<text x="{ml - 6}" y="{py(v) + 4:.1f}" text-anchor="end">{v:.6g}</text>')
    out.append(f'<text x="{ml + pw / 2}" y="{height - 4}" text-anchor="middle">{_e(xlabel)}</text>')
    out.append(f'<text x="12" y="{mt + ph / 2}" text-anchor="middle" '
               f'transform="rotate(-90 12 {mt + ph / 2})">{_e(ylabel)}</text>')
    # the legend's box fits its longest label (about 6.5 px a character at 11 px), drawn over
    # the lines with a white background so that neither clips the other
    legend_w = min(pw - 8, 30 + int(6.5 * max((len(str(d[2])) for d in data), default=0)))
    legend_out = []
    if data:
        legend_out.append(f'<rect class="legend" x="{ml + pw - legend_w - 6}" y="{mt + 3}" '
                          f'width="{legend_w + 2}" height="{14 * len(data) + 6}" fill="white" '
                          f'fill-opacity="0.85" stroke="#ccc"/>')
    for k, (x, y, lab) in enumerate(data):
        color = _COLORS[k % len(_COLORS)]
        segs, cur = [], []
        for a, b in zip(x, y):
            if math.isfinite(b):
                cur.append(f"{px(a):.1f},{py(b):.1f}")
            elif cur:
                segs.append(cur)
                cur = []
        if cur:
            segs.append(cur)
        for seg in segs:
            out.append(f'<polyline fill="none" stroke="{color}" stroke-width="1.2" points="{" ".join(seg)}"/>')
        lx = ml + pw - legend_w
        ly = mt + 14 + 14 * k
        legend_out.append(f'<line x1="{lx}" y1="{ly - 4}" x2="{lx + 18}" y2="{ly - 4}" stroke="{color}" '
                          f'stroke-width="2"/><text x="{lx + 22}" y="{ly}">{_e(lab)}</text>')
    out += legend_out
    out.append("</svg>")
    return "".join(out)


def _table(header, rows, left=1) -> str:
    th = "".join(f'<th class="l">{_e(h)}</th>' if i < left else f"<th>{_e(h)}</th>"
                 for i, h in enumerate(header))
    body = "".join("<tr>" + "".join(f'<td class="l">{_e(c)}</td>' if i < left else f"<td>{_e(c)}</td>"
                                    for i, c in enumerate(r)) + "</tr>" for r in rows)
    return f"<table><tr>{th}</tr>{body}</table>"


def _page(title, sections) -> str:
    stamp = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())
    return (f"<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>{_e(title)}</title>"
            f"<style>{_CSS}</style></head><body><h1>{_e(title)}</h1>"
            f'<p class="note">pneucore report, {stamp}. Errors are the paper\'s Eq. 25 normalised '
            f"RMS errors, shown in percent. SI units inside; plots in bar absolute, mm, m/s, K.</p>"
            + "".join(sections) + "</body></html>")


def _conversion_words(c) -> str:
    """One column's reading in words: ``pressure_V: 2 bar per V, offset -0.5 bar, barg → Pa``."""
    out = f"{c.get('column')}: "
    if c.get("gain") is not None:
        out += (f"{c['gain']:g} {c['from']} per {c.get('raw_unit') or 'raw unit'}, offset "
                f"{c.get('offset', 0.0):g} {c['from']}, ")
    out += f"{c.get('from')} → {c.get('to')}"
    if c.get("ambient_pressure"):
        out += f" (+{c['ambient_pressure']:g} Pa ambient)"
    return out


def _provenance(comparison, provenance) -> str:
    rows = []
    prov = {p.get("dataset_id"): p for p in (provenance or []) if p.get("dataset_id")}
    for rp in comparison.replays:
        exp = rp.experiment
        m = exp.measurement
        info = prov.get(exp.dataset_id, {})
        imp = m.meta.get("import") or {}
        # how the columns were read on upload (stored with the dataset), else by this reader
        convs = info.get("sensors") or m.meta.get("sensors") or imp.get("conversions", [])
        conv = "; ".join(_conversion_words(c) for c in convs
                         if c.get("from") != c.get("to") or c.get("gain") is not None)
        rows.append([exp.name, exp.dataset_id or "inline", info.get("name", ""), m.n,
                     f"{m.t[0]:.6g} – {m.t[-1]:.6g} s", ", ".join(m.measured_signals),
                     m.meta.get("source", info.get("description", "")), conv or "none (SI)",
                     "given with the experiment" if exp.command_source == "scenario"
                     else "measured (u)"])
    return ("<h2>Data provenance</h2>" + _table(
        ["experiment", "dataset", "dataset name", "samples", "time span", "signals", "source",
         "unit conversions and sensors", "valve command"], rows, left=3)
        + '<p class="note">The model\'s t = 0 is the measurement\'s t = 0.</p>')


def _comparison_sections(comparison, label="model") -> list[str]:
    c = comparison
    out = ["<h2>Errors (Eq. 25)</h2>",
           _table(["signal", "error"], [[s, _pct(e)] for s, e in c.errors.items()]
                  + [["overall", _pct(c.overall)]]),
           _table(["signal", "noise floor"], [[s, _pct(e)] for s, e in c.noise_floor.items()])]
    phases = c.phases or {}
    if phases:
        names = sorted({p for v in phases.values() for p in v})
        out.append("<h3>By command phase</h3>" + _table(
            ["signal"] + names, [[s] + [_pct(v.get(p)) for p in names] for s, v in phases.items()]))
    if c.windows:
        out.append("<h2>Where the model fails most</h2>" + _table(
            ["description"], [[w.get("description", "")] for w in c.windows]))
    out.append("<h2>Measured and model</h2>")
    for rp in c.replays:
        for s in rp.measured:
            f, unit = _DISPLAY.get(s, (1.0, SIGNAL_UNITS.get(s, "")))
            t = np.asarray(rp.t) + rp.experiment.t0
            meas, sim = np.asarray(rp.measured[s]) * f, np.asarray(rp.simulated[s]) * f
            out.append(svg_plot([(t, meas, "measured"), (t, sim, label)],
                                title=f"{rp.experiment.name}: {s}", ylabel=f"{s} [{unit}]"))
            out.append(svg_plot([(t, sim - meas, f"{label} − measured")],
                                title=f"{rp.experiment.name}: residual of {s}",
                                ylabel=f"[{unit}]", height=150))
    return out


def _model_section(model_dict) -> str:
    return ("<h2>Model</h2><pre>" + _e(json.dumps(model_dict, indent=1, sort_keys=True)) + "</pre>")


def comparison_report(model, comparison, provenance=None, title="Model versus measurement") -> str:
    """HTML report of a comparison.

    Parameters
    ----------
    model : Model or dict
        The model compared [-]
    comparison : pneucore.analysis.compare.Comparison
        Result of :func:`pneucore.analysis.compare.compare` (with its replays) [-]
    provenance : list of dict or None, optional
        Stored dataset records (``dataset_id``, ``name``, ``description``...) [-]
    title : str, optional
        Page title [-]

    Returns
    -------
    html : str
        A self-contained page (no script, no external asset) [-]
    """
    md = model if isinstance(model, dict) else model.to_dict()
    return _page(title, [_provenance(comparison, provenance)] + _comparison_sections(comparison)
                 + [_model_section(md)])


def diagnosis_report(model, diagnosis, comparison, provenance=None, refined=None,
                     title="Diagnosis") -> str:
    """HTML report of a diagnosis: verdict, ranking, residual tests, plots, model.

    Parameters
    ----------
    model : Model or dict
        The model diagnosed [-]
    diagnosis : dict
        ``Diagnosis.to_dict()`` [-]
    comparison : pneucore.analysis.compare.Comparison
        The diagnosed model compared with the data (for the plots) [-]
    provenance : list of dict or None, optional
        Stored dataset records [-]
    refined : pneucore.analysis.compare.Comparison or None, optional
        The verdict's refitted model compared with the data, drawn too [-]
    title : str, optional
        Page title [-]

    Returns
    -------
    html : str
        A self-contained page [-]
    """
    md = model if isinstance(model, dict) else model.to_dict()
    d = diagnosis
    sections = _diagnosis_sections(d)
    sections.append(_provenance(comparison, provenance))
    sections += _comparison_sections(comparison, "diagnosed model")
    if refined is not None:
        sections.append(f"<h2>With {_e(d.get('verdict'))} added</h2>")
        sections += _comparison_sections(refined, f"+ {d.get('verdict')}")[1:]
    sections.append(_model_section(md))
    return _page(title, sections)


def _quantity(x) -> str:
    """A value of a model change as text: a number to 4 significant digits, text as it is,
    nothing as a dash."""
    if x is None:
        return "—"
    if isinstance(x, (int, float)) and not isinstance(x, bool):
        return f"{x:.4g}"
    return str(x)


def _fitted(name, v) -> str:
    """One fitted parameter as text: ``name = value unit (± stderr)``; a parameter is a plain
    number or the diagnosis' ``{"value", "stderr", "unit"}``."""
    if isinstance(v, dict):
        val, err, unit = v.get("value"), v.get("stderr"), v.get("unit") or ""
        if not isinstance(val, (int, float)):
            return f"{name} = —"
        text = f"{name} = {val:.4g}" + (f" {unit}" if unit and unit != "-" else "")
        if isinstance(err, (int, float)) and math.isfinite(err):
            text += f" (± {err:.2g})"
        return text
    return f"{name} = {v:.4g}" if isinstance(v, (int, float)) else f"{name} = {v}"


def _diagnosis_sections(d, level=2):
    """Verdict, ranking, explanations and residual tests of one diagnosis (``to_dict()``)."""
    verdict = d.get("verdict") or "no catalog effect explains the remaining residual"
    rows = []
    for r in d.get("ranking", []):
        rows.append([r.get("effect", ""), _pct(r.get("error_before")), _pct(r.get("error_after_overall")),
                     f"{r.get('lr_statistic', float('nan')):.4g}", f"{r.get('p_value', float('nan')):.3g}",
                     f"{r.get('delta_bic', float('nan')):.4g}",
                     ", ".join(_fitted(k, v) for k, v in (r.get("params") or {}).items())])
    sections = [f"<h2>Verdict: {_e(verdict)}</h2><p>{_e(d.get('message', ''))}</p>",
                _table(["effect", "error before", "error after", "LR", "p", "ΔBIC", "fitted"], rows),
                "<h3>Explanations</h3>" + "".join(f"<p><b>{_e(r.get('effect'))}</b>: {_e(r.get('explanation', ''))}</p>"
                                                 for r in d.get("ranking", []))]
    tests = d.get("residual_tests")
    if isinstance(tests, dict) and tests.get("summary"):
        sections.append(f"<h3>Residual tests</h3><p>{_e(tests['summary'])}</p>")
    if level != 2:
        sections[0] = sections[0].replace("<h2>", f"<h{level}>").replace("</h2>", f"</h{level}>")
    return sections


def diagnosis_report_on(model, experiments, diagnosis, provenance=None, title="Diagnosis") -> str:
    """:func:`diagnosis_report` of a diagnosis made on ``experiments``: the diagnosed model and
    the verdict's refitted model are compared with them here (POST /api/reports/diagnose and
    ``pneucore diagnose --report`` share it).

    Parameters
    ----------
    model : Model
        The model diagnosed [-]
    experiments : list of Experiment
        The experiments it was diagnosed on [-]
    diagnosis : dict
        ``Diagnosis.to_dict()`` [-]
    provenance : list of dict or None, optional
        Stored dataset records [-]
    title : str, optional
        Page title [-]

    Returns
    -------
    html : str
        A self-contained page [-]
    """
    from pneucore.analysis.compare import compare
    from pneucore.description.model import Model
    d = diagnosis
    refined = None
    best = next((r for r in d.get("ranking", []) if r.get("effect") == d.get("verdict")), None)
    if best is not None and best.get("model"):
        refined = compare(Model.from_dict(best["model"]), experiments)
    return diagnosis_report(model, d, compare(model, experiments), provenance, refined, title)


def refinement_report(answer, comparison, provenance=None, title="Refinement") -> str:
    """HTML report of a whole refinement: every version with its errors, every round's
    verdict and ranking, the refined model against the data, and the refined model.

    Parameters
    ----------
    answer : dict
        :func:`pneucore.analysis.history.refinement_answer`, or a stored session's versions
        (each may carry ``changes``, :func:`pneucore.description.paths.model_changes` from the
        version before, and a ``note``) [-]
    comparison : pneucore.analysis.compare.Comparison
        The refined model compared with the data [-]
    provenance : list of dict or None, optional
        Stored dataset records [-]
    title : str, optional
        Page title [-]

    Returns
    -------
    html : str
        A self-contained page [-]
    """
    versions = answer.get("versions", [])
    signals = sorted({s for v in versions for s in (v.get("errors") or {})})
    rows = [[v.get("version"), v.get("label", ""), _pct(v.get("overall"))]
            + [_pct((v.get("errors") or {}).get(s)) for s in signals] for v in versions]
    sections = ["<h2>Versions</h2>", _table(["version", "label", "overall"] + signals, rows, left=2),
                f"<p>{_e(answer.get('message', ''))}</p>"]
    # what each version changed (a session's versions carry it: model_changes of the one before)
    changed = [v for v in versions if v.get("changes")]
    if changed:
        sections.append("<h2>What each version changed</h2>")
    for v in changed:
        note = f" ({v['note']})" if v.get("note") else ""
        sections.append(f"<h3>Version {_e(v.get('version'))}: {_e(v.get('label', ''))}{_e(note)}</h3>")
        sections.append(_table(["parameter", "before", "after", "unit"],
                               [[c.get("path", ""), _quantity(c.get("before")), _quantity(c.get("after")),
                                 c.get("unit") or ""] for c in v["changes"]]))
    for k, d in enumerate(answer.get("diagnoses", [])):
        sections.append(f"<h2>Round {k + 1}</h2>")
        sections += _diagnosis_sections(d, level=3)
    sections.append(_provenance(comparison, provenance))
    sections += _comparison_sections(comparison, "refined model")
    sections.append(_model_section(answer.get("model", {})))
    return _page(title, sections)
