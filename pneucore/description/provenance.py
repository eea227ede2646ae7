"""Where each identified value of a model came from: the model's ``provenance`` map.

The paper identifies its model step by step (section 4): the valve on a flow bench, the
friction on a friction bench, then validates on the locked-chamber and free-motion tests. A
model records, per parameter path (:mod:`pneucore.description.paths`: ``friction.extend.fc0``,
``jack.moving_mass``, ``valve.ports.P-A.C`` for an edge's whole table), where its value came
from::

    "provenance": {"friction.extend.fc0": {"source": "bench", "stderr": 0.41, "unit": "N",
                                           "method": "friction bench (Eq. 17-20)"}}

A value identified on a bench is treated as *known* by the later fits (calibrate, diagnose,
refine hold it; :func:`bench_known`) unless the request says otherwise (``bench_known:
false``): a separate test that pins a component down is the engineer's answer to the
confounding of a dynamic fit, and the paper's.

Examples
--------
>>> p = check_provenance({"jack.moving_mass": {"source": "bench", "stderr": 0.02}})
>>> p["jack.moving_mass"]["source"], p["jack.moving_mass"]["stderr"]
('bench', 0.02)
"""
from __future__ import annotations

import math
import numbers

from pneucore.description.validation import FieldError

#: Where a value may come from: a maker's catalogue, a bench test made for the component
#: (flow bench, friction bench), a calibration or a diagnosis on dynamic tests
PROVENANCE_SOURCES = ("catalogue", "bench", "calibration", "diagnosis")

#: The fields of one provenance entry, with what each means (and its unit)
PROVENANCE_FIELDS = {
    "source": f"where the value came from: {', '.join(PROVENANCE_SOURCES)} [-]",
    "stderr": "standard error of the value, in the parameter's unit (a relative one [-] for a "
              "valve table's scale path); null when not known",
    "unit": "the parameter's unit, for the reader [-]",
    "method": "how it was identified (the bench, the equations) [-]",
    "note": "free text (the records used, a date) [-]",
}

#: Longest text of a provenance entry's text fields, and longest path [characters]
TEXT_MAX = 2000
PATH_MAX = 200
#: Most entries of one model's provenance map [-]
MAX_ENTRIES = 1000


def check_provenance(d, path="provenance"):
    """A model's provenance map, checked; every error names its field.

    Parameters
    ----------
    d : dict or None
        ``{parameter path: {"source", "stderr"?, "unit"?, "method"?, "note"?}}`` [-]
    path : str
        Where the map is in the request, for the messages [-]

    Returns
    -------
    provenance : dict
        A checked copy (``stderr`` as float or None) [-]
    """
    if d is None:
        return {}
    if not isinstance(d, dict):
        raise FieldError(path, "must be an object {parameter path: {source, stderr, ...}}")
    if len(d) > MAX_ENTRIES:
        raise FieldError(path, f"at most {MAX_ENTRIES} entries, got {len(d)}")
    out = {}
    for key, entry in d.items():
        where = f"{path}.{key}"
        if not isinstance(key, str) or not key or len(key) > PATH_MAX:
            raise FieldError(path, f"{key!r} is not a parameter path (at most {PATH_MAX} characters)")
        if not isinstance(entry, dict):
            raise FieldError(where, "must be an object {source, stderr, unit, method, note}")
        unknown = [k for k in entry if k not in PROVENANCE_FIELDS]
        if unknown:
            raise FieldError(f"{where}.{unknown[0]}", f"unknown field; an entry has "
                                                      f"{', '.join(PROVENANCE_FIELDS)}")
        source = entry.get("source")
        if source not in PROVENANCE_SOURCES:
            raise FieldError(f"{where}.source", f"must be one of {', '.join(PROVENANCE_SOURCES)}, "
                                                f"got {source!r}")
        e = {"source": source}
        se = entry.get("stderr")
        if se is not None:
            if isinstance(se, bool) or not isinstance(se, numbers.Real) or not math.isfinite(se) \
                    or se < 0:
                raise FieldError(f"{where}.stderr", f"must be a finite number >= 0 or null, got {se!r}")
            se = float(se)
        e["stderr"] = se
        for k in ("unit", "method", "note"):
            v = entry.get(k)
            if v is None:
                continue
            if not isinstance(v, str) or len(v) > TEXT_MAX:
                raise FieldError(f"{where}.{k}", f"must be a text of at most {TEXT_MAX} characters")
            e[k] = v
        out[key] = e
    return out


def record(provenance, values, source, method="", note=""):
    """``provenance`` with one entry per identified value added (replacing an older one).

    Parameters
    ----------
    provenance : dict or None
        The model's map so far [-]
    values : dict
        ``{path: (stderr, unit)}``: the standard error in the parameter's unit (None when not
        known) and the unit [-]
    source : str
        One of :data:`PROVENANCE_SOURCES` [-]
    method, note : str
        How and from what [-]

    Returns
    -------
    provenance : dict
        A new map [-]
    """
    out = {k: dict(v) for k, v in (provenance or {}).items()}
    for p, (se, unit) in values.items():
        e = {"source": source, "stderr": None if se is None or not math.isfinite(se) else float(se)}
        if unit:
            e["unit"] = unit
        if method:
            e["method"] = method
        if note:
            e["note"] = note
        out[p] = e
    return check_provenance(out)


def bench_known(model, explicit=()):
    """The parameter paths of ``model`` identified on a bench: known to a later fit.

    Parameters
    ----------
    model : pneucore.description.model.Model
        The model, with its ``provenance`` [-]
    explicit : iterable of str
        Paths the request already names as known (kept once) [-]

    Returns
    -------
    paths : list of str
        ``explicit`` then the bench paths, each once [-]
    """
    out = list(explicit or ())
    for p, e in (getattr(model, "provenance", None) or {}).items():
        if e.get("source") == "bench" and p not in out:
            out.append(p)
    return out
