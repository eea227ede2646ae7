"""The findings of a diagnosis once its verdict is in: the residual's tests, the mis-set
base parameters, the next model, what the data cannot tell apart, what remains (and whether
a sensor's zero or gain accounts for it), and the message in words."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pneucore.analysis import calibrate as _calibrate
from pneucore.analysis import hypotheses as H
from pneucore.analysis.calibrate import Objective, fit
from pneucore.analysis.compare import replay, summarise
from pneucore.analysis.diagnosis.evidence import excess_drop as _excess_drop
from pneucore.analysis.diagnosis.rules import AT_FLOOR, EXCESS_MAJOR, indistinct
from pneucore.analysis.diagnosis.stages import RECAL_MIN, with_effect as _with_effect
from pneucore.analysis.engineering import in_words
from pneucore.analysis.metrics import cross_correlation_test, ljung_box
from pneucore.description.effects import EFFECTS
from pneucore.description.paths import ParameterSpec, get_value, model_changes

#: Relative rise of the Eq. 25 error within which an effect already in the model may be dropped
#: (its strength indistinguishable from off): 1 %, the scatter of refits stopped by the
#: optimiser's budget; an effect whose removal costs more is still doing work
DROP_TOLERANCE = 0.01
#: Misfit above this factor of the floor, with a command-dependent residual, lies outside
OUTSIDE_FACTOR = 1.5
#: Share of the remaining residual a physical signal must explain for the remainder to count as
#: structure (:func:`pneucore.analysis.hypotheses.residual_signature`)
SIGNATURE_R2 = 0.5



def residual_tests(replays, lags=20):
    """Whiteness (Ljung-Box) and command cross-correlation tests of each residual.

    ``structure_remains``: some residual is not white noise (either test
    rejects at p < 0.001). ``command_dependent``: some residual depends on
    the command (the cross-correlation test, which allows for coloured noise,
    rejects): the physics the command drives is incomplete. An autocorrelated
    residual without a significant dependence on the command is ambiguous:
    coloured measurement noise, or missing physics that acts slowly (a leak
    during a hold, heat exchange); the summary says so.
    """
    out = []
    dependent = False
    coloured = False
    for rp in replays:
        u = rp.experiment.command_samples[:len(rp.t)]
        for s in rp.measured:
            d = rp.measured[s] - rp.simulated[s]
            q, p = ljung_box(d, lags)
            c, pc = cross_correlation_test(d, u, lags)
            out.append({"experiment": rp.experiment.name, "signal": s, "ljung_box_q": q,
                        "ljung_box_p": p, "cross_corr_s": c, "cross_corr_p": pc})
            if pc == pc and pc < 1e-3:
                dependent = True
            if p == p and p < 1e-3:
                coloured = True
    if dependent:
        text = ("the residual depends on the command (cross-correlation test rejected at "
                "p < 0.001): some physics is still missing or mis-set")
    elif coloured:
        text = ("the residual is autocorrelated (Ljung-Box rejected at p < 0.001) without a "
                "significant dependence on the command: coloured measurement noise, or missing "
                "physics that acts slowly (a leak, heat exchange); a recording of the sensors at "
                "rest tells them apart")
    else:
        text = "the residual is consistent with white measurement noise"
    return {"tests": out, "structure_remains": dependent or coloured,
            "command_dependent": dependent, "summary": text}



#: A joint sensor refit is kept when it removes at least this share of the misfit in excess of
#: the noise floor (the rule a named effect must meet, :data:`EXCESS_MAJOR`)
SENSOR_EXCESS = EXCESS_MAJOR


def _sensor_refit(model, exps, verdict, refits, u_specs, prior, replays, err, floor, max_nfev):
    """The base parameters (and the verdict's effect) refitted with the sensor offsets and gains
    the residual asks for (:func:`pneucore.analysis.hypotheses.sensor_findings`), from the model
    as given; ``(calibration, findings, summary)`` when it removes at least
    :data:`SENSOR_EXCESS` of the misfit in excess of the floor, else None. ``replays``: the
    fitted model's and the model's as given, each screened (a recalibration may have taken up
    part of a sensor's error: a load for a pressure offset)."""
    fields = {}
    for rps in replays:
        for f in H.sensor_findings(rps, model.ambient.pressure, H.SENSOR_SCREEN):
            fields.setdefault(f["signal"], set()).update(
                {"offset": ("offset",), "gain": ("gain",)}.get(f["kind"], ("offset", "gain")))
    if not fields:
        return None
    specs = []
    for sig, fs in fields.items():
        specs += _calibrate.sensor_specs(exps, [sig], [f for f in ("offset", "gain") if f in fs])
    m0 = model
    if verdict is not None:
        eff = EFFECTS[verdict]
        start = refits[verdict].model.effects[verdict]
        m0 = _with_effect(model, verdict, start)
        specs += [ParameterSpec(f"effects.{verdict}.{p}", start[p], eff.param(p).min, eff.param(p).max,
                                True, eff.param(p).unit) for p in eff.diagnosis_params
                  if p not in eff.unused_in(model)]
    cal = fit(m0, exps, list(u_specs) + specs, max_nfev=max_nfev, compute_before=False,
              reweight=True, prior=prior)
    e1 = cal.error_after.overall
    if not _excess_drop(err, e1, floor) >= SENSOR_EXCESS:
        return None
    out = []
    for sp in specs:
        if not sp.path.startswith(_calibrate.SENSOR_PREFIX):
            continue
        sig, what = _calibrate.sensor_path(sp.path)
        v = cal.values[sp.path]
        if not abs(v["value"]) > 3.0 * v["stderr"]:
            continue   # not told apart from a right sensor (3 standard errors)
        unit, k = H.SENSOR_WORDS.get(sig, ("", 1.0))
        if what == "offset":
            words = (f"sensor {sig} reads {abs(v['value']) * k:.3g} {unit} "
                     f"{'more' if v['value'] > 0 else 'less'} than the model (its zero; "
                     f"± {v['stderr'] * k:.2g} {unit})")
        else:
            words = f"sensor {sig}'s gain is {100 * v['value']:+.3g} % off (± {100 * v['stderr']:.2g} %)"
        out.append({"path": sp.path, "signal": sig, "field": what, "value": v["value"],
                    "stderr": v["stderr"], "unit": v["unit"], "at_bound": v["at_bound"],
                    "description": words})
    if not out:
        return None
    summary = {"error": e1, "error_without": err,
               "description": "; ".join(f["description"] for f in out) + (
                   f": fitted with the base parameters, the error falls from {100 * err:.2f} % to "
                   f"{100 * e1:.2f} % (noise floor {100 * floor:.2f} %). A sensor finding, not "
                   "physics: correct the sensor, or give its offset and gain in the upload's "
                   "column mapping")}
    return cal, out, summary



def _recalibration(model, cal, paths):
    """``(recalibrate, refitted)``: base parameters moved materially by ``cal``, and all refitted.

    A parameter is mis-set when its fitted value differs from the model's by more than
    three standard errors *and* by more than :data:`RECAL_MIN` of its value: standard
    errors under a misspecified model are optimistic, so a statistically clear but
    practically nil change is not reported.
    """
    if cal is None:
        return [], []
    recal, refitted = [], []
    for p in paths:
        v = cal.values.get(p)
        if v is None:
            continue
        before = get_value(model, p)
        after = v["value"]
        se = v.get("stderr", 0.0)
        entry = {"path": p, "label": H.label_of(p), "before": before, "after": after,
                 "stderr": se, "unit": v.get("unit", "") or ("-" if p.startswith("valve.") else ""),
                 "at_bound": v.get("at_bound", False)}
        why = H.plausibility(model, p, after, entry["at_bound"])
        if why:
            entry["implausible"] = why
        refitted.append(entry)
        d = abs(after - before)
        if d > 3.0 * se and d > RECAL_MIN * max(abs(before), 1e-300):
            recal.append(entry)
    recal += _confounded_group(cal, refitted, recal)
    return recal, refitted


def _effect_refits(model, cal, verdict):
    """Parameters of the effects already in ``model`` (not the verdict's) that ``cal`` moved
    by the rule of :func:`_recalibration` (beyond three standard errors and
    :data:`RECAL_MIN` of the value): a line's length, a control's volume, refitted beside the
    base parameters (:meth:`pneucore.description.effects.Effect.refit_in`). The answer's
    model carries them; the message says so."""
    if cal is None:
        return []
    out = []
    for p, v in cal.values.items():
        parts = p.split(".")
        if len(parts) != 3 or parts[0] != "effects" or parts[1] == verdict \
                or parts[1] not in model.effects:
            continue
        before, after, se = get_value(model, p), v["value"], v.get("stderr", 0.0)
        d = abs(after - before)
        if d > 3.0 * se and d > RECAL_MIN * max(abs(before), 1e-300):
            out.append({"path": p, "label": f"{parts[1]} {parts[2]}", "before": before,
                        "after": after, "stderr": se, "unit": v.get("unit", "") or "",
                        "at_bound": v.get("at_bound", False)})
    return out


#: Correlation of two fitted parameters above which they form a confounded group
CONFOUNDED_CORR = 0.9


def _confounded_group(cal, refitted, recal):
    """Parameters that moved materially but only in a combination the data identify.

    Strongly correlated parameters (``|corr| > CONFOUNDED_CORR`` in the fit) each get a
    large standard error, so none passes the three-standard-error rule alone, while their
    joint change can be unmistakable (a load confounded with the two Coulomb levels). The
    group of the materially moved, correlated parameters is reported, each entry with
    ``confounded_with``, when its change along the combinations the data identify is
    beyond three standard errors (``sum_i (v_i^T dθ)^2 / λ_i > 9 k`` over the ``k``
    eigenpairs of the group's covariance with ``λ_i`` under 1 % of the largest); only the
    identified combinations are meaningful, not the split among the members.
    """
    done = {r["path"] for r in recal}
    moved = [r for r in refitted if r["path"] not in done
             and abs(r["after"] - r["before"]) > RECAL_MIN * max(abs(r["before"]), 1e-300)
             and r["stderr"] > 0]
    corr = getattr(cal, "correlations", None) or {}
    out = []
    for r in moved:
        if r["path"] in {q["path"] for q in out}:
            continue
        group = [r] + [q for q in refitted if q is not r and q["stderr"] > 0
                       and abs(corr.get(r["path"], {}).get(q["path"]) or 0.0) > CONFOUNDED_CORR]
        if len(group) < 2:
            continue
        dth = np.array([q["after"] - q["before"] for q in group])
        se = np.array([q["stderr"] for q in group])
        c = np.array([[1.0 if a is b else (corr.get(a["path"], {}).get(b["path"]) or 0.0)
                       for b in group] for a in group])
        # the combinations the data identify: eigen-directions of the group's covariance whose
        # variance is under 1 % of the worst one's (the near-null direction of the confounding,
        # along which the split between the members is arbitrary, is left out)
        cov = c * np.outer(se, se)
        try:
            lam, vec = np.linalg.eigh(cov)
        except np.linalg.LinAlgError:
            continue
        keep = lam < 1e-2 * lam.max()
        if not keep.any():
            continue
        proj = vec[:, keep].T @ dth
        m2 = float(np.sum(proj ** 2 / np.maximum(lam[keep], 1e-300)))
        if m2 > 9.0 * int(keep.sum()):
            paths = [q["path"] for q in group]
            for q in group:
                if q["path"] not in done:
                    q = dict(q)
                    q["confounded_with"] = [p for p in paths if p != q["path"]]
                    out.append(q)
                    done.add(q["path"])
    return out


def _redundant(model, cal, verdict):
    """Effects already in the model whose refitted strength is indistinguishable from off."""
    if cal is None:
        return []
    out = []
    for name in model.effects:
        if name == verdict:
            continue
        eff = EFFECTS[name]
        sp = eff.score_params
        if not sp:
            continue
        gone = True
        for p in sp:
            v = cal.values.get(f"effects.{name}.{p}")
            if v is None:
                gone = False
                break
            off = eff.param(p).off
            if abs(v["value"] - off) > max(2.0 * v.get("stderr", 0.0), 1e-300):
                gone = False
        if gone:
            out.append(name)
    return out


def _separating_words(suggestions):
    if not suggestions:
        return ("; no variation of the recorded tests (piston locked or free, supply pressure, "
                "position, load) would separate them")
    s = suggestions[0]
    return (f"; {s['experiment']} would separate them (their predictions would differ by "
            f"{math.sqrt(s['separation']):.0f} noise standard deviations in all, against "
            f"{math.sqrt(s['recorded']):.1f} in the records)")


def _alternatives(ranking, verdict, refits=None, exps=None):
    """Candidates the data cannot tell apart from the verdict (delta BIC within 10 of it).

    Each says which experiment would separate it from the verdict
    (:func:`pneucore.analysis.hypotheses.separating_experiments` on the two fitted models,
    ``separating``), falling back to the locked/free rule of the effects' catalog entries.
    """
    if verdict is None or not ranking:
        return []
    best = ranking[0]
    out = []
    for c in ranking[1:]:
        if c["significant"] and c["material"] and indistinct(c, best):
            eff_b, eff_c = EFFECTS[best["effect"]], EFFECTS[c["effect"]]
            note = (f"{c['effect']} explains the data about as well as {best['effect']} "
                    f"(delta BIC {c['delta_bic']:.1f} against {best['delta_bic']:.1f})")
            alt = {"effect": c["effect"], "kind": "effect", "delta_bic": c["delta_bic"],
                   "error_after_overall": c["error_after_overall"]}
            if refits and exps and best["effect"] in refits and c["effect"] in refits:
                alt["separating"] = H.separating_experiments(
                    refits[best["effect"]].model, refits[c["effect"]].model, exps)
                note += _separating_words(alt["separating"])
            else:
                for kind in ("locked", "free"):
                    if (kind in eff_b.observable_in) != (kind in eff_c.observable_in):
                        note += f"; a {kind} test (only one of them acts there) would separate them"
            alt["note"] = note
            out.append(alt)
    return out


def _remaining(err, floor, tests, replays, verdict):
    """What neither recalibration nor a catalog effect explains."""
    at_floor = bool(floor == floor and err <= AT_FLOOR * floor)
    sig = H.residual_signature(replays) if not at_floor else {}
    # misfit well above the floor that either depends on the command or follows a physical
    # signal closely: structure, not coloured noise (which neither test would show)
    outside = bool(not at_floor and floor == floor and err > OUTSIDE_FACTOR * floor
                   and (tests.get("command_dependent") or sig.get("r2", 0.0) >= SIGNATURE_R2))
    out = {"error": err, "noise_floor": floor, "ratio": err / floor if floor else None,
           "at_floor": at_floor, "outside_catalog": outside, "residual": tests.get("summary", "")}
    if not at_floor:
        out["signature"] = sig
        if outside:
            out["description"] = ("misfit remains that neither recalibration nor a catalog effect "
                                  f"explains (error {100 * err:.2f} %, noise floor "
                                  f"{100 * floor:.2f} %): " + sig.get("description", ""))
        else:
            out["description"] = sig.get("description", "")
    else:
        out["description"] = f"the error ({100 * err:.2f} %) is at the noise floor ({100 * floor:.2f} %)"
    return out


def _fmt(v):
    return f"{v:.3g}"


def _message(message, recal, remaining, verdict, initial_state=(), recal_fx=()):
    parts = []
    if initial_state:
        parts.append("initial state not in the records: " + "; ".join(
            f"{r['label']} {_fmt(r['after'])} {r['unit']} (the replay assumed {_fmt(r['before'])})"
            for r in initial_state))
    if recal:
        parts.append("mis-set: " + "; ".join(
            f"{r['label']} {_fmt(r['before'])} -> {_fmt(r['after'])} {r['unit']}".rstrip()
            for r in recal))
        groups = []
        for r in recal:
            g = sorted([r["path"]] + r.get("confounded_with", []))
            if len(g) > 1 and g not in groups:
                groups.append(g)
        for g in groups:
            parts.append("these experiments identify " + ", ".join(H.label_of(p) for p in g)
                         + " only in combination (the split among them is not determined)")
    if recal_fx:
        parts.append("refitted in the model's own effects: " + "; ".join(
            f"{r['label']} {_fmt(r['before'])} -> {_fmt(r['after'])} {r['unit']}".rstrip()
            for r in recal_fx))
    odd = [r for r in recal if r.get("implausible")]
    if odd:
        parts.append("implausible as catalogue errors: " + "; ".join(
            f"{r['label']} ({r['implausible']})" for r in odd)
            + ": a missing effect or a wrong declaration may stand behind "
            + ("it" if len(odd) == 1 else "them"))
    if remaining.get("outside_catalog"):
        parts.append("outside the catalog: " + remaining.get("description", ""))
        if remaining.get("sensor_fit"):
            parts.append(remaining["sensor_fit"]["description"])
    elif remaining.get("at_floor"):
        parts.append(remaining["description"])
    parts += [f["description"] for f in remaining.get("known_disagree", [])]
    parts = [q[:1].upper() + q[1:] for q in parts]
    return message + (" " + ". ".join(parts) + "." if parts else "")



@dataclass
class Findings:
    """What :func:`findings` reports: the residual tests (of the null, and after the verdict),
    ``recalibrate``/``refitted`` base parameters, the next ``model``, the effects ``dropped``
    from it, ``alternatives``, ``remaining``, the ``message`` and ``recalibrate_effects``."""
    tests: dict
    recalibrate: list
    refitted: list
    model: object
    dropped: list = field(default_factory=list)
    alternatives: list = field(default_factory=list)
    remaining: dict = field(default_factory=dict)
    message: str = ""
    #: parameters of the effects already in the model that the data moved (:func:`_effect_refits`)
    recalibrate_effects: list = field(default_factory=list)


def findings(model, exps, verdict, message, ranking, refits, null, hyp, comp_start, rps_start,
             known, lead, max_nfev, report):
    """The findings stage: mis-set base parameters, the next model (an effect named in an
    earlier round leaves it only when the data say so), alternatives, what remains (with a
    joint sensor refit when it lies outside the catalog), and the message."""
    tests = residual_tests(null.replays)
    if verdict is not None:
        chosen = refits[verdict]
        best_rps = chosen.error_after.replays
        tests["after_verdict"] = residual_tests(best_rps)
    else:
        chosen = null.fit
        best_rps = null.replays
    final_tests = tests.get("after_verdict", tests)

    recal, refitted = _recalibration(model, chosen, null.base_paths)
    recal_fx = _effect_refits(model, chosen, verdict)
    next_model = chosen.model.copy() if chosen is not None else model.copy()
    # an effect named in an earlier round leaves the model only when the data say so: its
    # refitted strength is indistinguishable from off *and* the model without it fits as well
    err_chosen = chosen.error_after.overall if chosen is not None else null.error
    dropped, kept = [], []
    for name in _redundant(model, chosen, verdict):
        trial = next_model.copy()
        trial.effects.pop(name, None)
        e_trial = summarise([replay(trial, e) for e in exps]).overall
        if e_trial <= (1.0 + DROP_TOLERANCE) * err_chosen:
            next_model = trial
            dropped.append(name)
        else:
            kept.append((name, e_trial))
    report(0.97, "which experiment would separate what the records cannot")
    alternatives = _alternatives(ranking, verdict, refits, exps) + _base_alternatives(
        model, exps, hyp, recal, null)
    err_final = chosen.error_after.overall if chosen is not None else null.error
    remaining = _remaining(err_final, null.floor_overall, final_tests, best_rps, verdict)
    if remaining.get("outside_catalog"):
        # a remainder a sensor's zero or gain accounts for: a finding about the rig's sensors,
        # fitted jointly with the base parameters (what the sensor error made them take up)
        report(0.98, "sensor offsets and gains")
        sensed = _sensor_refit(model, exps, verdict, refits, null.specs_start, null.prior,
                               (best_rps, rps_start), err_final, null.floor_overall, max_nfev)
        if sensed is not None:
            cal_s, remaining["sensor"], remaining["sensor_fit"] = sensed
            recal, refitted = _recalibration(model, cal_s, null.base_paths)
            recal_fx = _effect_refits(model, cal_s, verdict)
            next_model = cal_s.model.copy()
            for name in dropped:
                next_model.effects.pop(name, None)
    if known:
        m_final = chosen.model if chosen is not None else model
        remaining["known_disagree"] = H.known_disagreements(
            m_final, exps, known, best_rps, Objective(m_final, exps, []))
    message = _message(message, recal, remaining, verdict, hyp.initial_state, recal_fx)
    for name in dropped:
        message += (f" Dropped {name}: its refitted strength is indistinguishable from off and "
                    f"the model without it fits as well (error {100 * err_chosen:.2f} %).")
    for name, e_trial in kept:
        message += (f" Kept {name}: its strength is poorly determined by these records, but "
                    f"without it the error rises from {100 * err_chosen:.2f} % to "
                    f"{100 * e_trial:.2f} %.")
    if hyp.auto and not any(h["status"] == "identifiable" for h in hyp.identifiability
                            if "experiment" not in h):
        remaining["identifies_no_base"] = True
        remaining["identifies_nothing"] = not lead
        message += (" These experiments identify none of the base parameters (none of "
                    f"{', '.join(h['label'] for h in hyp.identifiability)} changes the recorded signals "
                    "measurably): record the chamber pressures during valve moves, and a free test "
                    "for friction and mass.")
    given = model.to_dict()
    for r in ranking:   # what taking each candidate would change, listed before it is taken
        if r.get("model"):
            r["changes"] = model_changes(given, r["model"])
            words = in_words(r["effect"], (r["model"].get("effects") or {}).get(r["effect"])
                             or r.get("params"), model)
            if words:   # where it acts and how big, in the units it is checked by
                r["in_words"] = words
                r["explanation"] = r.get("explanation", "") + f" In engineering terms: {words}."
                if r["effect"] == verdict:
                    message += f" In engineering terms: {words}."
    for hint in comp_start.hints:   # the records contradict their declared context
        message += " Check the context: " + hint["message"]
    return Findings(tests, recal, refitted, next_model, dropped, alternatives, remaining, message,
                    recal_fx)


def _base_alternatives(model, exps, hyp, recal, null):
    """Base parameters the experiments cannot tell apart (only their combination is fitted);
    where their partners were found mis-set, the experiment that would separate them."""
    out = []
    moved = {r["path"] for r in recal}
    for h in hyp.identifiability:
        if h["status"] in ("not separable", "held"):
            alt = {"path": h["path"], "label": h["label"], "kind": "base",
                   "with": h.get("with", []),
                   "note": f"{h['label']} cannot be told apart from "
                           f"{', '.join(H.label_of(w) for w in h.get('with', []))} "
                           f"by these experiments: only their combination is fitted"}
            if h["status"] == "held":   # a value the user knows, the data do not demand
                hb = H.BASE_HYPOTHESES[h["path"]]
                alt["note"] = (f"{h['label']} is held at the value given: these experiments "
                               f"cannot tell it apart from "
                               f"{', '.join(H.label_of(w) for w in h.get('with', []))}; "
                               + (hb.separated_by or "check it"))
                alt["held"] = True
                out.append(alt)
                continue
            # the split matters once its partners were found mis-set: say what would separate
            if moved & set(h.get("with", [])):
                twin = H.confounded_twin(model, h["path"], [q.path for q in null.auto_specs],
                                         hyp.id_cols)
                if twin is not None:
                    alt["separating"] = H.separating_experiments(model, twin, exps)
                    alt["note"] += _separating_words(alt["separating"])
            out.append(alt)
    return out
