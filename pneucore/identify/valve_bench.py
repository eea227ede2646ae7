"""A valve flow bench to ISO 6358-1: an edge's C(u) and b(u) tables from measured points.

Each bench point is a steady flow through one metering edge at a spool opening ``u``:
upstream and downstream absolute pressures ``p_up``, ``p_down`` [Pa], upstream temperature
``T_up`` [K] and mass flow ``q`` [kg/s]. The model's flow law (paper Eq. 4-5, ISO 6358),

.. math::
    q = C \\rho_0 p_{up} \\sqrt{T_0 / T_{up}}\\,
        \\sqrt{1 - \\left(\\frac{p_{down}/p_{up} - b}{1 - b}\\right)^2}
    \\quad (p_{down}/p_{up} > b), \\qquad
    q = C \\rho_0 p_{up} \\sqrt{T_0 / T_{up}} \\quad (\\text{choked}),

linearised above the valve's ``laminar_ratio`` exactly as the simulator does
(:func:`pneucore.physics.flow.iso6358_mass_flow`), is fitted at each opening by least squares
on the mass flow: the sonic conductance ``C`` [m^3/(s Pa)], the model's own unit, and the
critical ratio ``b`` [-], with standard errors from the residuals (``s^2 (J^T J)^-1``). The
openings where the edge passes no more than a leak (``CLOSED_FRACTION`` of the largest C) form
the null / overlap band (paper Fig. 2: 15 % overlap); there only C is fitted, b is copied from
the nearest open opening. Points without an opening are a fixed orifice: one C and one b.

The catalogue check (SMC, "Flow-rate characteristics", ISO 6358): C = 2 dm^3/(s bar),
b = 0.3, 0.4 MPa gauge upstream to 0.3 MPa gauge at 20 degC gives 420 dm^3/min (ANR), and
600 dm^3/min choked:

>>> from pneucore.physics.flow import FLOW_LAWS
>>> from pneucore.physics.gas import RHO_REF
>>> C = 2e-3 / 1e5        # 2 dm^3/(s bar) in m^3/(s Pa)
>>> q = FLOW_LAWS["iso6358"](0.5e6, 293.15, 0.4e6, 293.15, C, 0.3)
>>> round(q / RHO_REF * 60e3)   # dm^3/min ANR
420
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
from scipy.optimize import least_squares

from pneucore.physics.flow import FLOW_LAWS, R_LAMINAR
from pneucore.physics.gas import RHO_REF, T_REF
from pneucore.description.model import VALVE_KINDS, Model, PortTable
from pneucore.description.provenance import record
from pneucore.description.validation import FieldError, number

#: An opening is closed (null / overlap band) when its fitted C is at most this fraction of the
#: edge's largest C: a leak of 1 % of the full conductance is the order of a centred spool's
#: leakage (ISO 10770-1), well above the flow meter's resolution [-]
CLOSED_FRACTION = 0.01

#: Openings in one cell of this width are one table opening (a spool position read by a
#: sensor scatters by about 0.1 % of its range; 0.5 % of the 4/2 range -1..1 keeps the
#: paper's Fig. 2 table steps, 5 %, apart) [-]
OPENING_RESOLUTION = 0.01

#: Upper bound of a fitted critical ratio: the model's tables hold b in [0, 1) [-]
B_MAX = 0.999

#: The unit of C in the model's tables and in every answer
C_UNIT = "m^3/(s Pa)"

#: Bounds of a bench point: absolute pressures up to 1 GPa [Pa] (ten times any pneumatic
#: component's), temperatures 1 K to 2000 K [K], flows up to 1000 kg/s [kg/s]: beyond them a
#: value is a unit mistake, and the fit's arithmetic would overflow
P_MAX = 1e9
T_RANGE = (1.0, 2000.0)
FLOW_MAX = 1e3


@dataclass
class BenchPoint:
    """One steady point of a flow bench.

    Parameters
    ----------
    opening : float or None
        Spool opening [-]; None for a fixed orifice
    p_up : float
        Upstream absolute pressure [Pa]
    p_down : float
        Downstream absolute pressure, at most ``p_up`` [Pa]
    T_up : float
        Upstream gas temperature [K]
    flow : float
        Mass flow from upstream to downstream, >= 0 [kg/s]
    """
    opening: Optional[float]
    p_up: float
    p_down: float
    T_up: float
    flow: float

    @classmethod
    def from_dict(cls, d, path, u_range=(-1.0, 1.0)):
        """A validated point; a :class:`~pneucore.description.validation.FieldError` names the field."""
        if not isinstance(d, dict):
            raise FieldError(path, f"must be an object with opening, p_up, p_down, T_up, flow, "
                                   f"got {type(d).__name__}")
        unknown = sorted(set(d) - {"opening", "p_up", "p_down", "T_up", "flow"})
        if unknown:
            raise FieldError(f"{path}.{unknown[0]}", "unknown field (known: opening, p_up, p_down, "
                                                     "T_up, flow)")
        for key in ("p_up", "p_down", "T_up", "flow"):
            if key not in d:
                raise FieldError(f"{path}.{key}", "is required")
        lo, hi = u_range
        u = d.get("opening")
        if u is not None:
            u = number(u, f"{path}.opening")
            if not lo <= u <= hi:
                raise FieldError(f"{path}.opening", f"opening {u:g} is outside the valve's range "
                                                    f"[{lo:g}, {hi:g}] [-]")
        p_up = number(d["p_up"], f"{path}.p_up", positive=True, high=P_MAX)
        p_down = number(d["p_down"], f"{path}.p_down", positive=True, high=P_MAX)
        if p_down > p_up:
            raise FieldError(f"{path}.p_down", f"downstream pressure {p_down:g} Pa is above the "
                                               f"upstream pressure {p_up:g} Pa (absolute [Pa])")
        T_up = number(d["T_up"], f"{path}.T_up", low=T_RANGE[0], high=T_RANGE[1])
        flow = number(d["flow"], f"{path}.flow", high=FLOW_MAX)
        if flow < 0.0:
            raise FieldError(f"{path}.flow", f"negative mass flow {flow:g} kg/s: the flow runs "
                                             f"from upstream to downstream [kg/s]")
        return cls(u, p_up, p_down, T_up, flow)


def _scale_se(values, ses):
    """Relative standard error of a scale factor on a table whose points have standard errors
    ``ses``: ``1 / sqrt(sum (value / se)^2)`` over the points with a value and a positive se;
    None when no point has one [-]."""
    w = sum((v / se) ** 2 for v, se in zip(values, ses or ())
            if se is not None and se > 0 and v is not None and math.isfinite(v) and v != 0)
    return 1.0 / math.sqrt(w) if w > 0 else None


@dataclass
class ValveBenchResult:
    """An edge identified on a flow bench.

    Parameters
    ----------
    edge : str
        Edge name (``P-A``, ``A-R``, ``P-B``, ``B-R``) [-]
    opening : list of float or None
        Table openings, increasing; ``[None]`` for a fixed orifice [-]
    C : list of float
        Sonic conductance at each opening [m^3/(s Pa)]
    b : list of float
        Critical pressure ratio at each opening [-]
    C_se : list of float or None
        Standard error of each C; None where the points fit exactly (as many points as
        parameters) [m^3/(s Pa)]
    b_se : list of float or None
        Standard error of each b; None where b was not fitted [-]
    b_fitted : list of bool
        False where b was copied from the nearest open opening (closed openings) [-]
    closed : list of bool
        True at the openings of the null / overlap band (C at most ``CLOSED_FRACTION`` of
        the largest C) [-]
    null_band : dict or None
        ``low``, ``high``: the closed openings' range, and ``onset_low``, ``onset_high``: the
        openings where C(u), extrapolated linearly from the first two open openings on
        either side, reaches zero [-]; None when no opening is closed
    points : list of dict
        Every point with its ``opening`` [-], measured ``flow`` and model ``flow_model``
        [kg/s], ``residual`` = measured - model [kg/s] and ``ratio`` p_down/p_up [-]
    laminar_ratio : float
        The ratio above which the fitted law is linearised, as in the model [-]
    """
    edge: str
    opening: list
    C: list
    b: list
    C_se: list
    b_se: list
    b_fitted: list
    closed: list
    null_band: Optional[dict]
    points: list
    laminar_ratio: float

    @property
    def fixed_orifice(self):
        """The points carried no opening: one C and one b [-]."""
        return self.opening == [None]

    def port_table(self, u_range=(-1.0, 1.0)):
        """The result as a model's :class:`~pneucore.description.model.PortTable`.

        A fixed orifice holds its C and b over the whole range ``u_range`` [-]; an edge
        identified at one opening only likewise.
        """
        if len(self.opening) < 2:
            lo, hi = u_range
            return PortTable([lo, hi], [self.C[0]] * 2, [self.b[0]] * 2)
        return PortTable(list(self.opening), list(self.C), list(self.b))

    def write_into(self, model):
        """A copy of ``model`` whose valve table of this edge is the identified one.

        Parameters
        ----------
        model : pneucore.description.model.Model
            The model to write into (left unchanged)

        Returns
        -------
        pneucore.description.model.Model
            The copy, validated again (``Model.from_dict``)
        """
        valve = model.valve
        if self.edge not in VALVE_KINDS[valve.kind]["ports"]:
            raise FieldError("edge", f"a {valve.kind} valve has no edge {self.edge!r} (its edges: "
                                     f"{', '.join(VALVE_KINDS[valve.kind]['ports'])})")
        d = model.to_dict()
        d["valve"]["ports"][self.edge] = self.port_table(valve.opening_range).to_dict()
        note = f"valve.ports.{self.edge} identified on a flow bench (ISO 6358, Eq. 4-5), " \
               f"{len(self.points)} points"
        d["notes"] = (d.get("notes") or "") + ("\n" if d.get("notes") else "") + note
        # provenance: the edge's table as its scale paths (pneucore.description.paths), with the scale's
        # relative standard error, 1 / sqrt(sum (value / se)^2) over the table's fitted points
        # (the inverse-variance combination of independent estimates of one common factor)
        d["provenance"] = record(d.get("provenance"), {
            f"valve.ports.{self.edge}.C": (_scale_se(self.C, self.C_se), "-"),
            f"valve.ports.{self.edge}.b": (_scale_se(self.b, self.b_se), "-")},
            "bench", "valve flow bench (ISO 6358, Eq. 4-5)", f"{len(self.points)} points")
        return Model.from_dict(d)

    def to_dict(self):
        """JSON form: ``edge`` holds the table (opening, C, b), the rest beside it."""
        def clean(values):
            return [None if v is None or not math.isfinite(v) else float(v) for v in values]
        return {"name": self.edge,
                "edge": {"opening": list(self.opening), "C": clean(self.C), "b": clean(self.b)},
                "C_se": clean(self.C_se), "b_se": clean(self.b_se), "b_fitted": list(self.b_fitted),
                "closed": list(self.closed), "null_band": self.null_band,
                "fixed_orifice": self.fixed_orifice, "laminar_ratio": self.laminar_ratio,
                "points": self.points, "units": {"C": C_UNIT, "b": "-", "opening": "-",
                                                  "flow": "kg/s", "residual": "kg/s"},
                "rms_residual": float(np.sqrt(np.mean([p["residual"] ** 2 for p in self.points]))),
                "report": self.report()}

    def report(self):
        """A plain-text table: opening, C [dm^3/(s bar)] +- se, b +- se."""
        lines = [f"edge {self.edge}: ISO 6358 (Eq. 4-5), C in dm^3/(s bar)"]
        for i, u in enumerate(self.opening):
            cse = "" if self.C_se[i] is None else f" +- {self.C_se[i] * 1e8:.3g}"
            bse = "" if self.b_se[i] is None else f" +- {self.b_se[i]:.2g}"
            tag = " (closed)" if self.closed[i] else ""
            lines.append(f"  u = {'-' if u is None else f'{u:g}'}: C = {self.C[i] * 1e8:.4g}{cse}, "
                         f"b = {self.b[i]:.3f}{bse}{tag}")
        return "\n".join(lines)


def _phi_flow(C, b, p_up, T_up, p_down, r_lam):
    """Model mass flow [kg/s] of each point, by the model's own ISO 6358 law."""
    law = FLOW_LAWS["iso6358"].func
    return np.array([law(pu, Tu, pd, Tu, C, b, 0.5, r_lam, 0.0, 0.0)
                     for pu, Tu, pd in zip(p_up, T_up, p_down)])


def _fit_group(p_up, T_up, p_down, q, r_lam, b_fixed=None):
    """C, b and their standard errors at one opening (b held at ``b_fixed`` when given)."""
    scale = q / (RHO_REF * p_up * np.sqrt(T_REF / T_up))   # each point's choked-equivalent C
    c_ref = float(max(scale.max(), 1e-300))
    n = len(q)

    if b_fixed is not None:
        # q is linear in C: ordinary least squares
        g = _phi_flow(1.0, b_fixed, p_up, T_up, p_down, r_lam)
        gg = float(g @ g)
        C = float(g @ q) / gg if gg > 0.0 else 0.0
        C = max(C, 0.0)
        res = q - C * g
        se = math.sqrt(float(res @ res) / (n - 1) / gg) if n > 1 and gg > 0.0 else None
        return C, b_fixed, se, None, res

    q_ref = float(max(q.max(), 1e-300))

    def resid(theta):
        return (_phi_flow(theta[0] * c_ref, theta[1], p_up, T_up, p_down, r_lam) - q) / q_ref

    best = None
    for b0 in (0.2, 0.4, 0.6):   # a few starts: the subsonic branch is not convex in b
        sol = least_squares(resid, [1.0, b0], bounds=([0.0, 0.0], [np.inf, B_MAX]), x_scale=[1.0, 0.1],
                            xtol=1e-12, ftol=1e-12, gtol=1e-12)
        if best is None or sol.cost < best.cost:
            best = sol
    C, b = best.x[0] * c_ref, float(best.x[1])
    res = q - _phi_flow(C, b, p_up, T_up, p_down, r_lam)
    C_se = b_se = None
    if n > 2:
        J = best.jac * q_ref                    # d(model flow)/d(theta) [kg/s per unit theta]
        J = J / np.array([c_ref, 1.0])          # per unit C and unit b
        s2 = float(res @ res) / (n - 2)
        try:
            cov = s2 * np.linalg.inv(J.T @ J)
            C_se, b_se = math.sqrt(max(cov[0, 0], 0.0)), math.sqrt(max(cov[1, 1], 0.0))
        except np.linalg.LinAlgError:
            C_se = b_se = None
    return float(C), b, C_se, b_se, res


def identify_valve(points, edge="P-A", *, u_range=(-1.0, 1.0), laminar_ratio=R_LAMINAR,
                   openings=None, progress=None):
    """Fit an edge's ISO 6358 tables C(u), b(u) to flow-bench points (paper Fig. 2, Eq. 4-5).

    Parameters
    ----------
    points : list of dict or BenchPoint
        Bench points: ``opening`` [-] (None or absent: a fixed orifice), ``p_up``, ``p_down``
        [Pa abs], ``T_up`` [K], ``flow`` [kg/s]
    edge : str
        Edge name, one of the model's (``P-A``, ``A-R``, ``P-B``, ``B-R``) [-]
    u_range : tuple of float
        Valid openings ``(low, high)`` of the valve (a 4/2 valve: -1..1, a 3/2: 0..1) [-]
    laminar_ratio : float
        Pressure ratio above which the model linearises the flow (``valve.laminar_ratio``) [-]
    openings : list of float or None
        Table openings to group the points on (a slow sweep: each point goes to the nearest);
        None = every distinct opening of the points, those in one ``OPENING_RESOLUTION`` cell
        taken as one [-]
    progress : callable or None
        ``progress(fraction, step)``, called once per opening

    Returns
    -------
    ValveBenchResult

    Raises
    ------
    pneucore.description.validation.FieldError
        Naming the point and field: a downstream pressure above the upstream one, a negative
        flow, an opening outside ``u_range``; or ``points`` when an open opening has too few
        points to identify C and b (which one, and why)
    """
    all_edges = sorted({e for k in VALVE_KINDS.values() for e in k["ports"]})
    if edge not in all_edges:
        raise FieldError("edge", f"unknown edge {edge!r} (edges: {', '.join(all_edges)})")
    if not isinstance(points, (list, tuple)) or not points:
        raise FieldError("points", "at least one bench point is required")
    pts = [p if isinstance(p, BenchPoint) else BenchPoint.from_dict(p, f"points[{i}]", u_range)
           for i, p in enumerate(points)]
    has_u = [p.opening is not None for p in pts]
    if any(has_u) and not all(has_u):
        i = has_u.index(False)
        raise FieldError(f"points[{i}].opening", "give an opening for every point (a valve edge) "
                                                 "or for none (a fixed orifice) [-]")
    fixed = not any(has_u)
    u = np.array([0.0 if fixed else p.opening for p in pts])
    p_up = np.array([p.p_up for p in pts])
    p_down = np.array([p.p_down for p in pts])
    T_up = np.array([p.T_up for p in pts])
    q = np.array([p.flow for p in pts])

    if fixed:
        levels = np.array([0.0])
        group = np.zeros(len(pts), dtype=int)
    elif openings is None:
        # openings in one OPENING_RESOLUTION cell are one opening (a measured spool position
        # scatters), at their median; cells, not chains, so that a fine sweep stays a sweep
        _, group = np.unique(np.round(u / OPENING_RESOLUTION), return_inverse=True)
        group = group.reshape(-1)
        levels = np.array([float(np.median(u[group == j])) for j in range(int(group.max()) + 1)])
    else:
        levels = np.array(sorted(float(v) for v in openings))
        group = np.abs(u[:, None] - levels[None, :]).argmin(axis=1)
        keep = np.unique(group)
        levels, group = levels[keep], np.searchsorted(keep, group)

    # the choked-equivalent C of each point; the closed openings are those whose points all
    # pass at most CLOSED_FRACTION of the largest one's (checked again on the fitted C below)
    c_pt = q / (RHO_REF * p_up * np.sqrt(T_REF / T_up))
    c_top = float(c_pt.max())
    k = len(levels)
    C = [0.0] * k
    b = [float("nan")] * k
    C_se, b_se = [None] * k, [None] * k
    b_fit = [False] * k
    closed = [False] * k
    res = np.zeros(len(pts))
    open_idx = []
    for j in range(k):
        sel = group == j
        if c_top <= 0.0 or c_pt[sel].max() <= CLOSED_FRACTION * c_top:
            closed[j] = True
            continue
        n = int(sel.sum())
        where = "the orifice" if fixed else f"opening {levels[j]:g}"
        if n < 2:
            raise FieldError("points", f"too few points to identify C and b at {where}: {n} point, "
                                       f"at least 2 (at least one not choked, p_down/p_up above b) "
                                       f"are needed")
        ratio = p_down[sel] / p_up[sel]
        Cj, bj, cse, bse, r = _fit_group(p_up[sel], T_up[sel], p_down[sel], q[sel], laminar_ratio)
        if not (ratio > bj + 1e-9).any():
            raise FieldError("points", f"too few points to identify b at {where}: every point is "
                                       f"choked (p_down/p_up at most {ratio.max():.3g}); add points "
                                       f"with p_down/p_up between 0.5 and 0.95")
        C[j], b[j], C_se[j], b_se[j], b_fit[j] = Cj, bj, cse, bse, True
        res[sel] = r
        open_idx.append(j)
        if progress is not None:
            progress((j + 1) / k, f"{edge}: {where}")
    if not open_idx:
        raise FieldError("points", "every point has zero flow: no conductance can be identified "
                                   "(the edge is closed at every opening)")
    c_max = max(C)
    for j in list(open_idx):   # a fitted C at most CLOSED_FRACTION of the largest: closed too
        if C[j] <= CLOSED_FRACTION * c_max and len(open_idx) > 1:
            closed[j] = True
            open_idx.remove(j)
    for j in range(k):
        if closed[j]:
            near = min(open_idx, key=lambda i: abs(levels[i] - levels[j]))
            sel = group == j
            Cj, _, cse, _, r = _fit_group(p_up[sel], T_up[sel], p_down[sel], q[sel], laminar_ratio,
                                          b_fixed=b[near])
            C[j], b[j], C_se[j], b_se[j], b_fit[j] = Cj, b[near], cse, None, False
            res[sel] = r

    if not all(math.isfinite(v) for v in C + b):
        raise FieldError("points", "the fit gave no finite conductance or critical ratio (check the "
                                   "points' units: Pa abs, K, kg/s)")
    null_band = None
    if any(closed) and not fixed:
        shut = [levels[j] for j in range(k) if closed[j]]
        null_band = {"low": float(min(shut)), "high": float(max(shut)),
                     "onset_low": _onset(levels, C, closed, min(shut), -1),
                     "onset_high": _onset(levels, C, closed, max(shut), +1)}

    ratio = p_down / p_up
    model_q = q - res
    rows = [{"opening": None if fixed else float(u[i]), "flow": float(q[i]),
             "flow_model": float(model_q[i]), "residual": float(res[i]), "ratio": float(ratio[i])}
            for i in range(len(pts))]
    opening = [None] if fixed else [float(v) for v in levels]
    return ValveBenchResult(edge, opening, [float(c) for c in C], [float(v) for v in b], C_se, b_se,
                            b_fit, closed, null_band, rows, float(laminar_ratio))


def _onset(levels, C, closed, edge_u, side):
    """Opening where C(u), extrapolated from the first two open openings beyond ``edge_u`` on
    ``side`` (+1: above, -1: below), reaches zero; None when there are not two [-]."""
    idx = [j for j in range(len(levels)) if not closed[j] and (levels[j] - edge_u) * side > 0]
    idx.sort(key=lambda j: abs(levels[j] - edge_u))
    if len(idx) < 2:
        return None
    j1, j2 = idx[0], idx[1]
    slope = (C[j2] - C[j1]) / (levels[j2] - levels[j1])
    if slope == 0.0:
        return None
    return float(levels[j1] - C[j1] / slope)
