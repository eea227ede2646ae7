"""Results of a robustness study: per-metric distributions, a sensitivity ranking, raw arrays.

Sensitivity methods
-------------------
* **Rank correlation** (every design; the ranking for Monte Carlo and mixed
  designs): Spearman's rank correlation (``scipy.stats.spearmanr``) and the
  partial rank correlation coefficient, PRCC (Marino, Hogue, Ray &
  Kirschner 2008, J. Theor. Biol. 254:178-196): inputs and output are
  rank-transformed (average ranks for ties); for input ``i`` the ranks of
  ``X_i`` and of ``Y`` are each regressed linearly on the ranks of the
  other inputs, and PRCC is the Pearson correlation of the two residuals.
  Its p-value uses ``t = r sqrt((n - 2 - p) / (1 - r^2))``, Student's t
  with ``n - 2 - p`` degrees of freedom, ``p`` = number of other inputs.
  Ranked by ``|PRCC|``. Measures monotonic influence, not a share of variance.
* **Variance-based** only where the design supports it: a complete full
  factorial (grid-only study, every run stored and the metric defined in
  all of them). There the first-order index ``S_i = Var(E[Y | X_i]) /
  Var(Y)`` and the total index ``S_Ti = E[Var(Y | X_~i)] / Var(Y)`` are
  exact over the grid, every grid point weighted equally; ranked by
  ``S_Ti``. Random designs here are plain Monte Carlo, which does not
  support Sobol estimators, so they use rank correlation.
"""
from __future__ import annotations

import json
import math
from collections import Counter

import numpy as np
from scipy import stats

from pneucore.study import store
from pneucore.description.paths import unit_of
from pneucore.study.definition import Study

#: Percentiles reported per metric [%]
PERCENTILES = (5, 25, 50, 75, 95)

METHOD_PRCC = "prcc"
METHOD_ANOVA = "factorial_variance"
METHOD_TEXT = {
    METHOD_PRCC: ("Partial rank correlation coefficient (PRCC, Marino et al. 2008) with its t-test "
                  "p-value (n - 2 - p degrees of freedom), and Spearman's rank correlation with its "
                  "p-value; ranked by |PRCC|. Measures monotonic influence, not a share of variance."),
    METHOD_ANOVA: ("Variance decomposition of the complete full factorial: first-order index "
                   "S_i = Var(E[Y|X_i]) / Var(Y) and total index S_Ti = E[Var(Y|X_~i)] / Var(Y), "
                   "exact over the grid with equal weights; ranked by S_Ti. PRCC and Spearman given "
                   "alongside."),
}


def _f(v):
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def study_results(store_path, study_id, include_runs=True):
    """Summary, sensitivity ranking and raw arrays of a stored study (plain JSON).

    Parameters
    ----------
    store_path : str
        SQLite store
    study_id : str
        Study id
    include_runs : bool
        Include the raw per-run arrays (``runs``); False for a light summary

    Returns
    -------
    results : dict
        ``id``, ``name``, ``status``, ``created``, ``definition``, ``design``, ``n_runs``,
        ``stored``, ``failed``, ``missing``; ``parameters`` (path, unit, spec);
        ``metrics``: name -> ``{unit, definition, count, failed, undefined, mean, std,
        min, max, percentiles: {"5", "25", "50", "75", "95"}}`` (``std`` with ddof = 1;
        ``failed`` = runs whose simulation failed, ``undefined`` = runs where the metric
        does not apply, e.g. ``t95`` without travel); ``sensitivity``: ``{methods,
        ranking: {metric: {method, entries: [{parameter, rank, prcc, prcc_p, spearman,
        spearman_p[, first_order, total]}]}}}``; ``errors``: distinct failure messages
        with counts; ``runs``: ``{index, params: {path: [...]}, metrics: {name: [...]},
        error: [...]}`` for histograms and scatter plots. NaN is null.

    Raises
    ------
    KeyError  Unknown study id
    """
    db = store.connect(store_path)
    try:
        return results_from_db(db, study_id, include_runs)
    finally:
        db.close()


def study_status(store_path, study_id):
    """``{id, status, n_runs, stored, failed, fraction}`` (cheap: for progress displays)."""
    db = store.connect(store_path)
    try:
        info = store.get_study(db, study_id)
        if info is None:
            raise KeyError(f"no study {study_id!r} in {store_path!r}")
        n = Study.from_json(info["definition"]).n_runs
        stored, failed = store.count_runs(db, study_id)
        return {"id": study_id, "status": info["status"], "n_runs": n, "stored": stored,
                "failed": failed, "fraction": stored / n}
    finally:
        db.close()


def results_from_db(db, study_id, include_runs=True):
    """:func:`study_results` on an open store connection."""
    info = store.get_study(db, study_id)
    if info is None:
        raise KeyError(f"no study {study_id!r} in the store")
    study = Study.from_json(info["definition"])
    paths, names = study.paths, study.metric_names
    block = store.load_arrays(db, study_id, paths, names)
    idx, X, errs = block.indices, block.params, block.errors
    ok = np.array([e is None for e in errs], bool)
    Y = {m: block.metrics[:, j] for j, m in enumerate(names)}
    n_failed = int((~ok).sum())

    metrics = {}
    table = study.metric_table
    for m in names:
        y = Y[m]
        good = np.isfinite(y)
        v = y[good]
        d = {"unit": table[m][0], "definition": table[m][1], "count": int(good.sum()),
             "failed": n_failed, "undefined": int((ok & ~good).sum())}
        if v.size:
            same = v.min() == v.max()  # exact zero spread, not rounding noise
            d.update(mean=_f(v[0] if same else v.mean()),
                     std=(0.0 if same else _f(v.std(ddof=1))) if v.size > 1 else None,
                     min=_f(v.min()), max=_f(v.max()),
                     percentiles={str(q): _f(x) for q, x in zip(PERCENTILES, np.percentile(v, PERCENTILES))})
        else:
            d.update(mean=None, std=None, min=None, max=None,
                     percentiles={str(q): None for q in PERCENTILES})
        metrics[m] = d

    ranking = {}
    complete_factorial = study.design == "factorial" and len(idx) == study.n_runs and n_failed == 0
    x_ok = np.all(np.isfinite(X), axis=1)
    cache = {}   # the parameters' ranks per set of usable runs (most metrics share one)
    for m in names:
        ranking[m] = _rank(study, X, Y[m], idx, complete_factorial, x_ok, cache)

    errors = Counter(e for e in errs if e is not None)
    first = {}
    if errors:
        for i, e in zip(idx.tolist(), errs):
            if e is not None:
                first.setdefault(e, []).append(i)
    out = {
        "id": study_id, "name": study.name, "status": info["status"], "created": info["created"],
        "definition": json.loads(info["definition"]), "design": study.design,
        "n_runs": study.n_runs, "stored": len(idx), "failed": n_failed,
        "missing": study.n_runs - len(idx),
        "parameters": [{"path": p.path, "unit": unit_of(p.path), "spec": p.to_dict()}
                       for p in study.parameters],
        "metrics": metrics,
        "sensitivity": {"methods": dict(METHOD_TEXT), "ranking": ranking},
        "errors": [{"message": msg, "count": c, "runs": first[msg][:20]}
                   for msg, c in errors.most_common()],
    }
    if include_runs:
        out["runs"] = {"index": idx.tolist(),
                       "params": {p: _list(X[:, j]) for j, p in enumerate(paths)},
                       "metrics": {m: _list(Y[m]) for m in names},
                       "error": list(errs)}
    return out


def _list(a):
    """Floats for JSON: NaN and inf become None."""
    a = np.asarray(a, float)
    out = a.tolist()
    bad = np.flatnonzero(~np.isfinite(a))
    for j in bad.tolist():
        out[j] = None
    return out


def _rank(study, X, y, idx, complete_factorial, x_ok, cache):
    good = np.isfinite(y) & x_ok
    Xg, yg = X[good], y[good]
    key = good.tobytes()
    if key not in cache:
        cache.clear()
        cache[key] = _rank_columns(Xg)
    corr = rank_correlations(Xg, yg, ranks=cache[key])
    entries = [{"parameter": p, **c} for p, c in zip(study.paths, corr)]
    method = METHOD_PRCC
    if complete_factorial and good.all():
        idx_order = np.argsort(idx)
        S1, ST = factorial_indices(y[idx_order], study.grid_shape)
        for e, s1, st in zip(entries, S1, ST):
            e["first_order"], e["total"] = _f(s1), _f(st)
        method = METHOD_ANOVA
        key = lambda e: (-(e["total"] if e["total"] is not None else -1.0),  # noqa: E731
                         -abs(e["prcc"] or 0.0))
    else:
        key = lambda e: (e["prcc"] is None, -abs(e["prcc"] or 0.0),  # noqa: E731
                         -abs(e["spearman"] or 0.0))
    entries.sort(key=key)
    for k, e in enumerate(entries):
        e["rank"] = k + 1
    return {"method": method, "n": int(good.sum()), "entries": entries}


def rankdata(a):
    """Ranks from 1 with ties given their average rank (``scipy.stats.rankdata``'s default).

    An unstable sort suffices (tied values get the same average whatever their order), which
    makes it several times faster than scipy's on 100,000 values.

    Parameters
    ----------
    a : ndarray (n,)
        Values

    Returns
    -------
    r : ndarray (n,)
        Average ranks [-]
    """
    a = np.asarray(a, float)
    n = a.size
    if n == 0:
        return np.empty(0)
    order = np.argsort(a)
    s = a[order]
    new = np.empty(n, bool)
    new[0] = True
    np.not_equal(s[1:], s[:-1], out=new[1:])
    starts = np.flatnonzero(new)
    ends = np.append(starts[1:], n)
    r = np.empty(n)
    r[order] = ((starts + ends + 1) / 2.0)[np.cumsum(new) - 1]
    return r


def _rank_columns(X):
    n, k = X.shape
    return np.column_stack([rankdata(X[:, j]) for j in range(k)]) if k else np.empty((n, 0))


def rank_correlations(X, y, ranks=None):
    """Spearman and PRCC of each column of ``X`` against ``y``, with p-values.

    Spearman's rho is Pearson's correlation of the average ranks, with the two-sided
    p-value of ``t = rho sqrt((n - 2) / (1 - rho^2))`` on Student's t with ``n - 2``
    degrees of freedom (what ``scipy.stats.spearmanr`` computes).

    Parameters
    ----------
    X : ndarray (n, k)
        Inputs of the usable runs, in the parameters' units
    y : ndarray (n,)
        Output, in the metric's unit
    ranks : ndarray (n, k) or None
        Average ranks of the columns of ``X`` when already computed (several outputs
        over the same runs) [-]

    Returns
    -------
    out : list of dict
        Per column: ``spearman``, ``spearman_p``, ``prcc``, ``prcc_p``, correlations and
        p-values [-] (None where undefined: constant column or output, too few runs)
    """
    n, k = X.shape
    out = [{"spearman": None, "spearman_p": None, "prcc": None, "prcc_p": None} for _ in range(k)]
    if n < 3:
        return out
    R = _rank_columns(X) if ranks is None else ranks
    ry = rankdata(y)
    varying = [j for j in range(k) if R[:, j].min() < R[:, j].max()]
    if ry.min() == ry.max():
        return out
    # Spearman's rho from the rank correlation matrix C; PRCC from its inverse P:
    # PRCC_j = -P[j, y] / sqrt(P[j, j] P[y, y]), the same partial correlation as the
    # residual regression below, in one O(n k^2) pass over the runs
    C = np.corrcoef(np.vstack([R[:, varying].T, ry[None, :]]))
    C = np.atleast_2d(C)
    q = len(varying)
    for a, j in enumerate(varying):
        rho = float(np.clip(C[a, q], -1.0, 1.0))
        out[j]["spearman"], out[j]["spearman_p"] = rho, _t_pvalue(rho, n - 2)
    dof = n - 2 - (q - 1)
    if dof < 1:
        return out
    try:
        well_posed = np.linalg.cond(C) < 1e10
        P = np.linalg.inv(C) if well_posed else None
    except np.linalg.LinAlgError:
        P = None
    for a, j in enumerate(varying):
        if P is not None:
            r = float(np.clip(-P[a, q] / math.sqrt(P[a, a] * P[q, q]), -1.0, 1.0))
        else:   # near-collinear inputs: residual regression, skipping inputs the others explain
            r = _prcc_residual(R, ry, j, [i for i in varying if i != j], n)
            if r is None:
                continue
        out[j]["prcc"], out[j]["prcc_p"] = r, _t_pvalue(r, dof)
    return out


def _prcc_residual(R, ry, j, others, n):
    """PRCC of column ``j`` by regressing both ranks on the ``others`` (None if undefined)."""
    A = np.column_stack([np.ones(n)] + [R[:, i] for i in others])
    rx = R[:, j] - A @ np.linalg.lstsq(A, R[:, j], rcond=None)[0]
    rr = ry - A @ np.linalg.lstsq(A, ry, rcond=None)[0]
    sx, sy = np.sqrt(rx @ rx), np.sqrt(rr @ rr)
    if sx <= 1e-12 * n or sy <= 1e-12 * n:  # an input fully explained by the others
        return None
    return float(np.clip((rx @ rr) / (sx * sy), -1.0, 1.0))


def _t_pvalue(r, dof):
    """Two-sided p-value of a correlation ``r`` with ``dof`` degrees of freedom (Student's t)."""
    if r is None:
        return None
    if abs(r) >= 1.0:
        return 0.0
    t = r * math.sqrt(dof / (1.0 - r * r))
    return float(2.0 * stats.t.sf(abs(t), dof))


def factorial_indices(y, shape):
    """First-order and total variance indices of a complete full factorial.

    Parameters
    ----------
    y : ndarray
        Output of every grid point, in run order (C order over ``shape``), in the
        metric's unit
    shape : tuple
        Number of levels of each grid parameter [-]

    Returns
    -------
    S1, ST : list of float or None
        Per parameter, first-order and total shares of Var(y) [-] (None if Var(y) = 0)

    Examples
    --------
    ``y = 2 i + j`` on a 2 x 2 grid: the level means of ``i`` vary four times as much
    as those of ``j``, and nothing interacts:

    >>> factorial_indices(np.array([0.0, 1.0, 2.0, 3.0]), (2, 2))
    ([0.8, 0.2], [0.8, 0.2])
    """
    Y = np.asarray(y, float).reshape(shape)
    var = Y.var()
    if not var > 0:
        return [None] * len(shape), [None] * len(shape)
    S1, ST = [], []
    for i in range(len(shape)):
        others = tuple(a for a in range(len(shape)) if a != i)
        S1.append(float(Y.mean(axis=others).var() / var) if others else 1.0)
        ST.append(float(Y.var(axis=i).mean() / var))
    return S1, ST


def _stored_runs(store_path, study_id):
    """``(paths, names, units, block)``: a study's parameter paths, metric names, the metrics'
    units (its :attr:`pneucore.study.definition.Study.metric_table`'s: a closed-loop study's
    are the loop's) and every stored run (:func:`pneucore.study.store.load_arrays`); KeyError
    for an unknown study."""
    db = store.connect(store_path)
    try:
        info = store.get_study(db, study_id)
        if info is None:
            raise KeyError(f"no study {study_id!r} in the store")
        study = Study.from_json(info["definition"])
        paths, names = study.paths, study.metric_names
        units = [study.metric_table[m][0] for m in names]
        return paths, names, units, store.load_arrays(db, study_id, paths, names)
    finally:
        db.close()


def runs_csv(store_path, study_id, chunk_rows=5000):
    """The stored runs of a study as CSV text, in chunks (for a download).

    Columns: ``run_index``, every parameter ``PATH [unit]`` (``Study.paths`` order),
    every metric ``NAME [unit]`` (units of :data:`~pneucore.study.metrics.METRICS`, or of
    :data:`~pneucore.control.metrics.CONTROL_METRICS` for a closed-loop study),
    ``error``. Values in SI units with 17 significant digits (exact round trip);
    an undefined metric, and every metric of a failed run, is an empty cell.

    Parameters
    ----------
    store_path : str
        SQLite store
    study_id : str
        Study id
    chunk_rows : int
        Rows per yielded chunk [-]

    Returns
    -------
    chunks : iterator of str
        The header line first, then the rows ordered by run index

    Raises
    ------
    KeyError
        Unknown study id (raised at the call, before any chunk)
    """
    import csv
    import io
    from pneucore.data.export import spreadsheet_safe
    paths, names, units, block = _stored_runs(store_path, study_id)
    # text cells neutralised for spreadsheets (a parameter path, an error message): CSV injection
    header = [spreadsheet_safe(h) for h in ["run_index"] + [f"{p} [{unit_of(p)}]" for p in paths]
              + [f"{m} [{u}]" for m, u in zip(names, units)] + ["error"]]

    def cells(a):
        return ["" if not math.isfinite(v) else repr(v) for v in a.tolist()]

    def chunks():
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(header)
        for j, i in enumerate(block.indices.tolist()):
            w.writerow([i] + cells(block.params[j]) + cells(block.metrics[j])
                       + [spreadsheet_safe(block.errors[j] or "")])
            if (j + 1) % chunk_rows == 0:
                yield buf.getvalue()
                buf.seek(0)
                buf.truncate()
        yield buf.getvalue()
    return chunks()


def runs_npz(store_path, study_id):
    """The stored runs of a study as a NumPy ``.npz`` archive (:mod:`pneucore.data.npz`).

    Members: ``run_index`` (n,) int64; ``params`` (n, k) float64 in SI units, columns in
    ``param_paths`` order with ``param_units``; ``metrics`` (n, m) float64, columns
    ``metric_names`` with ``metric_units`` (NaN: undefined, and every metric of a failed
    run); ``failed_index`` and ``failed_error``, the index and the message of each failed
    run. The same numbers as :func:`runs_csv`, without conversion to text: about 8 bytes
    a value where the CSV takes 20, and written at memory speed.

    Parameters
    ----------
    store_path : str
        SQLite store
    study_id : str
        Study id

    Returns
    -------
    data : bytes
        The archive (``numpy.load(io.BytesIO(data))`` reads it; nothing is unpickled)

    Raises
    ------
    KeyError
        Unknown study id
    """
    from pneucore.data.npz import npz_bytes
    paths, names, units, block = _stored_runs(store_path, study_id)
    failed = [(int(i), e) for i, e in zip(block.indices.tolist(), block.errors) if e is not None]
    n, k, m = len(block.indices), len(paths), len(names)
    return npz_bytes({
        "run_index": np.asarray(block.indices, dtype=np.int64),
        "params": np.asarray(block.params, dtype=np.float64).reshape(n, k),
        "param_paths": np.array(paths, dtype=str),
        "param_units": np.array([unit_of(q) for q in paths], dtype=str),
        "metrics": np.asarray(block.metrics, dtype=np.float64).reshape(n, m),
        "metric_names": np.array(names, dtype=str),
        "metric_units": np.array(units, dtype=str),
        "failed_index": np.array([i for i, _ in failed], dtype=np.int64),
        "failed_error": np.array([str(e) for _, e in failed], dtype=str),
    })
