"""Reference trajectories of the position loop (issue 42, item 3), SI units (m, s).

A setpoint is given as

* a list of breakpoints ``[[t, x], ...]``: held from each to the next (steps, multi-steps);
* a shape ``{"kind": ...}``:

  - ``step``: ``x0`` [m] before ``t`` [s], ``x1`` [m] from it;
  - ``multi_step``: ``points`` ``[[t, x], ...]``, held;
  - ``ramp``: from ``x0`` at ``t0`` to ``x1`` at ``t1`` [m, s], straight;
  - ``sine``: ``center + amplitude sin(2 pi frequency (t - t0))`` [m, Hz, s] from ``t0``;
  - ``jerk_limited``: point to point from ``x0`` to ``x1`` starting at ``t0``, velocity,
    acceleration and jerk within ``v_max`` [m/s], ``a_max`` [m/s^2], ``j_max`` [m/s^3]
    (the trapezoidal-velocity move, its acceleration averaged over ``a_max / j_max``: the
    seven-segment S-curve);
  - ``recorded``: ``t`` [s] and ``x`` [m] lists, linear between samples, held outside.

:meth:`Setpoint.evaluate` gives position, velocity and acceleration (the feedforward of the
PVA law); a held step has zero velocity and acceleration between its jumps.
"""
from __future__ import annotations

import math

import numpy as np

from pneucore.description.validation import FieldError

SETPOINT_KINDS = ("step", "multi_step", "ramp", "sine", "jerk_limited", "recorded")


def _num(d, key, path, positive=False, default=None):
    v = d.get(key, default)
    if v is None:
        raise FieldError(f"{path}.{key}", "is required")
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise FieldError(f"{path}.{key}", f"must be a finite number, got {v!r}")
    if positive and v <= 0:
        raise FieldError(f"{path}.{key}", f"must be > 0, got {v!r}")
    return float(v)


def _points(pts, path):
    if not isinstance(pts, (list, tuple)) or not pts:
        raise FieldError(path, "must be a non-empty list of [t [s], x [m]] pairs")
    out = []
    for i, p in enumerate(pts):
        if not isinstance(p, (list, tuple)) or len(p) != 2:
            raise FieldError(f"{path}[{i}]", f"must be a [t [s], x [m]] pair, got {p!r}")
        for j, what in ((0, "time [s]"), (1, "position [m]")):
            v = p[j]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise FieldError(f"{path}[{i}][{j}]", f"{what} must be a finite number, got {v!r}")
        if out and p[0] < out[-1][0]:
            raise FieldError(f"{path}[{i}][0]", "times must not decrease [s]")
        out.append((float(p[0]), float(p[1])))
    return np.array(out)


class Setpoint:
    """A parsed setpoint (see the module); ``path`` names it in errors.

    Parameters
    ----------
    spec : list or dict
        The setpoint as the API gives it
    path : str
        Its field's path, for errors
    """

    def __init__(self, spec, path="setpoint"):
        self.path = path
        self.spec = spec
        if isinstance(spec, (list, tuple)):
            self.kind = "multi_step"
            self.pts = _points(spec, path)
            return
        if not isinstance(spec, dict):
            raise FieldError(path, "must be a list of [t [s], x [m]] pairs or a shape "
                                   f"{{kind: {'|'.join(SETPOINT_KINDS)}, ...}}")
        kind = spec.get("kind")
        if kind not in SETPOINT_KINDS:
            raise FieldError(f"{path}.kind", f"unknown setpoint kind {kind!r}; one of {list(SETPOINT_KINDS)}")
        self.kind = kind
        g = lambda k, **kw: _num(spec, k, path, **kw)  # noqa: E731
        if kind == "step":
            self.pts = np.array([[0.0, g("x0")], [g("t", default=0.0), g("x1")]])
        elif kind == "multi_step":
            self.pts = _points(spec.get("points"), f"{path}.points")
        elif kind == "ramp":
            self.x0, self.x1, self.t0, self.t1 = g("x0"), g("x1"), g("t0", default=0.0), g("t1")
            if self.t1 <= self.t0:
                raise FieldError(f"{path}.t1", "must be after t0 [s]")
        elif kind == "sine":
            self.center, self.amp = g("center"), g("amplitude")
            self.freq, self.t0 = g("frequency", positive=True), g("t0", default=0.0)
        elif kind == "jerk_limited":
            self.x0, self.x1, self.t0 = g("x0"), g("x1"), g("t0", default=0.0)
            self.vmax, self.amax = g("v_max", positive=True), g("a_max", positive=True)
            self.jmax = g("j_max", positive=True)
        else:
            t = spec.get("t")
            x = spec.get("x")
            if not isinstance(t, list) or not isinstance(x, list) or len(t) != len(x) or len(t) < 2:
                raise FieldError(f"{path}.t", "t [s] and x [m] must be lists of equal length >= 2")
            self.pts = _points([[a, b] for a, b in zip(t, x)], path + ".t")

    # ----------------------------------------------------------------- evaluation
    def evaluate(self, t):
        """Reference position [m], velocity [m/s] and acceleration [m/s^2] at times ``t`` [s].

        Examples
        --------
        >>> Setpoint({"kind": "ramp", "x0": 0.1, "x1": 0.2, "t0": 0, "t1": 1}).evaluate([0.5])[:2]
        (array([0.15]), array([0.1]))
        """
        t = np.asarray(t, float)
        z = np.zeros_like(t)
        k = self.kind
        if k in ("step", "multi_step"):
            idx = np.searchsorted(self.pts[:, 0], t, side="right") - 1
            return self.pts[np.clip(idx, 0, None), 1], z, z.copy()
        if k == "recorded":
            tp, xp = self.pts[:, 0], self.pts[:, 1]
            x = np.interp(t, tp, xp)
            slopes = np.diff(xp) / np.maximum(np.diff(tp), 1e-300)
            idx = np.clip(np.searchsorted(tp, t, side="right") - 1, 0, len(slopes) - 1)
            v = np.where((t < tp[0]) | (t >= tp[-1]), 0.0, slopes[idx])
            return x, v, z
        if k == "ramp":
            s = np.clip((t - self.t0) / (self.t1 - self.t0), 0.0, 1.0)
            rate = (self.x1 - self.x0) / (self.t1 - self.t0)
            inside = (t >= self.t0) & (t < self.t1)
            return self.x0 + s * (self.x1 - self.x0), np.where(inside, rate, 0.0), z
        if k == "sine":
            w = 2 * math.pi * self.freq
            on = t >= self.t0
            ph = w * (t - self.t0)
            return (self.center + np.where(on, self.amp * np.sin(ph), 0.0),
                    np.where(on, self.amp * w * np.cos(ph), 0.0),
                    np.where(on, -self.amp * w * w * np.sin(ph), 0.0))
        return self._jerk_limited(t)

    def _trapezoid(self, tau):
        """Trapezoidal-velocity move of |D| within v_max, a_max: (x, v, a) at ``tau`` >= 0."""
        D = abs(self.x1 - self.x0)
        sgn = 1.0 if self.x1 >= self.x0 else -1.0
        vm, am = self.vmax, self.amax
        ta = vm / am
        if am * ta * ta > D:           # no cruise: triangular profile
            ta = math.sqrt(D / am)
            vm = am * ta
        tc = (D - am * ta * ta) / vm if vm > 0 else 0.0
        T = 2 * ta + tc
        tau = np.clip(tau, 0.0, T)
        x = np.where(tau < ta, 0.5 * am * tau ** 2,
                     np.where(tau < ta + tc, 0.5 * am * ta ** 2 + vm * (tau - ta),
                              D - 0.5 * am * (T - tau) ** 2))
        v = np.where(tau < ta, am * tau, np.where(tau < ta + tc, vm, am * (T - tau)))
        a = np.where(tau < ta, am, np.where(tau < ta + tc, 0.0, -am))
        a = np.where(tau >= T, 0.0, a)
        return self.x0 + sgn * x, sgn * v, sgn * a, T

    def _jerk_limited(self, t):
        Tj = self.amax / self.jmax
        _, _, _, T = self._trapezoid(np.zeros(1))
        # the moving average over Tj of the trapezoidal move (exact for the position, the
        # velocity and the acceleration, which it turns into ramps of slope a_max / Tj)
        n = 64
        s = (np.arange(n) + 0.5) / n * Tj
        tau = np.asarray(t, float)[:, None] - self.t0 - s[None, :]
        x, v, a, _ = self._trapezoid(tau)
        x = np.where(tau <= 0, self.x0, x)
        v = np.where(tau <= 0, 0.0, v)
        a = np.where(tau <= 0, 0.0, a)
        return x.mean(axis=1), v.mean(axis=1), a.mean(axis=1)

    def duration_hint(self):
        """Time [s] by which the setpoint has reached its last value (None for a sine)."""
        if self.kind in ("step", "multi_step", "recorded"):
            return float(self.pts[-1, 0])
        if self.kind == "ramp":
            return self.t1
        if self.kind == "jerk_limited":
            return self.t0 + self._trapezoid(np.zeros(1))[3] + self.amax / self.jmax
        return None

    def moves(self):
        """Start times [s], start and end positions [m] of the moves the metrics judge: each
        jump of a held setpoint, or the whole move of a ramp or point-to-point."""
        if self.kind in ("step", "multi_step"):
            out = []
            for i in range(1, len(self.pts)):
                if self.pts[i, 1] != self.pts[i - 1, 1]:
                    out.append((self.pts[i, 0], self.pts[i - 1, 1], self.pts[i, 1]))
            return out
        if self.kind in ("ramp", "jerk_limited"):
            return [(self.t0, self.x0, self.x1)]
        if self.kind == "recorded":
            return [(self.pts[0, 0], self.pts[0, 1], self.pts[-1, 1])]
        return []

    def check_within(self, stroke, duration, path=None):
        """A setpoint outside the stroke ``[0, stroke]`` [m] is a FieldError naming it."""
        path = path or self.path
        t = np.linspace(0.0, duration, 2001)
        if self.kind in ("step", "multi_step", "recorded"):
            for i, (tt, xx) in enumerate(self.pts):
                if not 0.0 <= xx <= stroke:
                    sub = f"[{i}][1]" if isinstance(self.spec, (list, tuple)) else \
                        (f".points[{i}][1]" if self.kind == "multi_step" else
                         (".x0" if self.kind == "step" and i == 0 else ".x1") if self.kind == "step"
                         else f".x[{i}]")
                    raise FieldError(path + sub, f"position {xx:g} m is outside the stroke "
                                                 f"[0, {stroke:g}] m")
            return
        x = self.evaluate(t)[0]
        if x.min() < 0.0 or x.max() > stroke:
            bad = x.min() if x.min() < 0.0 else x.max()
            raise FieldError(path, f"reaches {bad:g} m, outside the stroke [0, {stroke:g}] m")
