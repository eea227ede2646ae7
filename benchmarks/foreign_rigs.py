"""The foreign rigs (issue 43): diagnosis cases made by an independent simulator.

The cases live outside the repository, in ``../shared/foreign-rigs`` from its root
(:data:`ROOT`; ``PNEUCORE_FOREIGN_RIGS`` overrides it): ``index.json`` lists each case's
file, the effects its truth holds (``expected``) and how it is graded (``graded_by``); each
case file holds the request body ``POST /api/diagnose`` takes as it is, and its ``truth``
(``floor_overall``: the truth's own Eq. 25 error against the record, the noise floor).

A case is right when

* ``one diagnosis``: the verdict of one diagnosis is the one expected effect (none: no
  verdict);
* ``refine loop``: diagnose, take the answer's model, diagnose again, until a round names
  nothing and recalibrates nothing (at most :data:`MAX_ROUNDS`); the effects of the model
  the loop ends with are exactly those expected.

A request the service refuses (a 4xx: :class:`pneucore.description.validation.FieldError`) is wrong.
Beside the verdict each row gives the error the last round ends with against the truth's
floor (:data:`FLOOR_FACTOR`).

Used by ``bench_diagnosis_confusion.py --foreign`` (categories ``foreign/set1`` ...) and by
the fast subset of ``tests/analysis/test_foreign_rigs.py``.
"""
from __future__ import annotations

import fnmatch
import json
import os
import time

HERE = os.path.dirname(os.path.abspath(__file__))

#: The folder of the foreign rigs: beside the repository's clone (CI has shared/ there)
ROOT = os.environ.get("PNEUCORE_FOREIGN_RIGS",
                      os.path.join(os.path.dirname(HERE), "..", "shared", "foreign-rigs"))
#: Rounds of the refine loop (the cases' README: at most 5)
MAX_ROUNDS = 5
#: The loop should end within this factor of the truth's own error (the issue's 1.5x: the two
#: simulators differ in small ways, so a case may sit a little above the floor here)
FLOOR_FACTOR = 1.5


def available(root=ROOT):
    """Is the foreign set there (its index readable)?"""
    return os.path.isfile(os.path.join(root, "index.json"))


def index(root=ROOT, pattern="*"):
    """The index's entries whose file matches ``pattern`` (``fnmatch``), in index order."""
    with open(os.path.join(root, "index.json")) as f:
        idx = json.load(f)
    return [e for e in idx if fnmatch.fnmatch(e["file"], pattern)
            or fnmatch.fnmatch(e["file"], pattern + ".json")]


def load(entry, root=ROOT):
    """The case file of an index entry (request, expected, graded_by, truth)."""
    with open(os.path.join(root, entry["file"])) as f:
        return json.load(f)


def category(entry):
    """``foreign/set1`` ...: the set a case belongs to."""
    return "foreign/" + entry["file"].split("/")[0]


def _effects(model):
    eff = model.get("effects") or {}
    return sorted(eff) if isinstance(eff, dict) else sorted(
        e.get("name") if isinstance(e, dict) else e for e in eff)


def run_case(entry, root=ROOT):
    """Run one case as the API would (:func:`app.services.run_diagnose`); returns the row:
    ``named``, ``ok``, ``error`` (the last round's), ``floor``, ``rounds``, ``seconds``,
    ``refused`` (the 4xx's text, or None)."""
    import tempfile
    from app.config import Limits
    from app.schemas import DiagnoseRequest
    from app.services import run_diagnose
    from app.store import Store
    from pneucore.description.validation import FieldError
    case = load(entry, root)
    body = dict(case["request"])
    store = Store(os.path.join(tempfile.mkdtemp(), "foreign.sqlite3"))
    limits = Limits()
    loop = entry["graded_by"] == "refine loop"
    rounds, refused, named = [], None, None
    t0 = time.perf_counter()
    try:
        for _ in range(MAX_ROUNDS if loop else 1):
            d = run_diagnose(DiagnoseRequest(**body), store, limits)
            rounds.append({"verdict": d.get("verdict"), "recalibrated": bool(d.get("recalibrate")),
                           "error_before": d["error_before"]["overall"],
                           "error": (d.get("remaining") or {}).get("error"),
                           "message": d.get("message", "")})
            if not loop:
                named = [d["verdict"]] if d.get("verdict") else []
                break
            body["model"] = d["model"]
            if not d.get("verdict") and not d.get("recalibrate"):
                break
        if loop:
            named = _effects(body["model"])
    except FieldError as exc:
        refused = f"{exc.path}: {exc.detail}" if hasattr(exc, "path") else str(exc)
    seconds = time.perf_counter() - t0
    floor = (case.get("truth") or {}).get("floor_overall")
    error = rounds[-1]["error"] if rounds else None
    return {"case": entry["file"], "category": category(entry), "expected": entry["expected"],
            "graded_by": entry["graded_by"], "named": named,
            "ok": named is not None and sorted(named) == sorted(entry["expected"]),
            "error": error, "floor": floor,
            "at_floor": bool(error is not None and floor and error <= FLOOR_FACTOR * floor),
            "rounds": rounds, "seconds": seconds, "refused": refused}


def line(row):
    """One printed line per case."""
    err = (f"; error {100 * row['error']:.3f} % (floor {100 * row['floor']:.3f} %"
           f"{'' if row['at_floor'] else ', above ' + str(FLOOR_FACTOR) + 'x'})"
           if row["error"] is not None and row["floor"] else "")
    return (f"{'OK ' if row['ok'] else 'BAD'} {row['case']:38s} expected "
            f"{row['expected'] or '-'}; named {row['named'] if row['named'] is not None else '-'}"
            f"{'; REFUSED ' + row['refused'] if row['refused'] else ''}{err}; "
            f"{len(row['rounds'])} round(s); {row['seconds']:.1f} s")
