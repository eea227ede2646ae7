"""Controllers by name (issue 42, item 2): each kind's compiled law
(:mod:`pneucore.core.controllers`), its gains with their units and defaults, the valve kinds
it can drive, and the checks of a request's gains.

==============  =========================================================================
kind            gains (SI)
==============  =========================================================================
pid             kp [1/m] (valve opening per metre of error), ki [1/(m s)], kd [s/m],
                tf [s] derivative filter time constant, deadband [m], kff [s/m]
                velocity feedforward
sliding_mode    lambda [1/s] (surface slope), k [-] (valve opening at the layer's edge),
                phi [m/s] (boundary layer width)
onoff           deadband [m], level [-] (fraction of the valve's half range)
pwm             kp [1/m] (duty per metre of error), period [s], deadband [m], level [-]
pva             kp [1/m], kv [s/m], ka [s^2/m], ff_v [s/m], ff_a [s^2/m]
force_pid       kx [N/m], kd [N s/m] (position loop giving the force reference), kf [1/N]
                (inner pressure-difference loop: opening per newton of force error)
==============  =========================================================================

A proportional law needs a valve whose opening it can set: the 4/2 proportional valve. The
on/off law drives a 4/2 valve (extend, centre, retract) or a 3/2 valve (supply, exhaust).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pneucore.core import controllers as C
from pneucore.description.validation import FieldError


@dataclass
class Gain:
    """One gain: name, unit, default (None: required), lower bound, description."""
    name: str
    unit: str
    default: float | None
    minimum: float = 0.0
    description: str = ""


@dataclass
class ControllerKind:
    """A controller kind of the registry."""
    name: str
    code: int
    gains: tuple
    valves: tuple
    description: str
    slots: dict = field(default_factory=dict)
    #: A user's compiled law (:func:`register_user_controller`); None for the built-in ones
    law: object = None

    def pack(self, gains, path):
        """Checked gains as the core's vector (``G_*`` slots); errors name ``path.<gain>``."""
        if not isinstance(gains, dict):
            raise FieldError(path, "must be an object of gains by name (SI units)")
        known = {g.name for g in self.gains}
        for k in gains:
            if k not in known:
                raise FieldError(f"{path}.{k}", f"unknown gain of a {self.name} controller; "
                                                f"its gains: {sorted(known)}")
        g = np.zeros(C.N_GAINS)
        for i, spec in enumerate(self.gains):
            v = gains.get(spec.name, spec.default)
            if v is None:
                raise FieldError(f"{path}.{spec.name}", f"is required [{spec.unit}]")
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise FieldError(f"{path}.{spec.name}",
                                 f"must be a finite number [{spec.unit}], got {v!r}")
            if v < spec.minimum or (spec.minimum > 0 and v <= 0):
                raise FieldError(f"{path}.{spec.name}",
                                 f"must be >= {spec.minimum:g} [{spec.unit}], got {v!r}")
            g[i] = float(v)
        return g

    def describe(self):
        """JSON description (GET /api/controllers)."""
        return {"kind": self.name, "description": self.description, "valves": list(self.valves),
                "gains": {g.name: {"unit": g.unit, "default": g.default,
                                   "description": g.description} for g in self.gains}}


CONTROLLERS = {}


def register_controller(kind):
    """Add a :class:`ControllerKind` to the registry (by its name)."""
    CONTROLLERS[kind.name] = kind
    return kind


_TINY = 1e-300
register_controller(ControllerKind(
    "pid", C.CTL_PID,
    (Gain("kp", "1/m", None, description="proportional: valve opening per metre of error"),
     Gain("ki", "1/(m s)", 0.0, description="integral"),
     Gain("kd", "s/m", 0.0, description="derivative"),
     Gain("tf", "s", 2e-3, _TINY, "time constant of the derivative's first-order filter"),
     Gain("deadband", "m", 0.0, description="error dead band: valve centred, integral frozen"),
     Gain("kff", "s/m", 0.0, description="velocity feedforward")),
    ("4/2",), "PID with filtered derivative and anti-windup (conditional integration)"))
register_controller(ControllerKind(
    "sliding_mode", C.CTL_SLIDING,
    (Gain("lambda", "1/s", None, _TINY, "slope of the surface s = (v_ref - v) + lambda e"),
     Gain("k", "-", 1.0, _TINY, "valve opening at the edge of the boundary layer"),
     Gain("phi", "m/s", 0.02, _TINY, "boundary-layer width")),
    ("4/2",), "sliding mode (variable structure) with a boundary layer"))
register_controller(ControllerKind(
    "onoff", C.CTL_ONOFF,
    (Gain("deadband", "m", 1e-3, description="error dead band: valve centred inside it"),
     Gain("level", "-", 1.0, _TINY, "opening outside the dead band, fraction of the half range")),
    ("4/2", "3/2"), "on/off with dead band (three positions; a 3/2 valve: supply/exhaust)"))
register_controller(ControllerKind(
    "pwm", C.CTL_PWM,
    (Gain("kp", "1/m", None, _TINY, "duty cycle per metre of error"),
     Gain("period", "s", 0.01, _TINY, "PWM period (rounded to whole sample periods)"),
     Gain("deadband", "m", 0.0, description="error dead band: duty zero inside it"),
     Gain("level", "-", 1.0, _TINY, "opening while on, fraction of the half range")),
    ("4/2", "3/2"), "PWM of an on/off valve: duty proportional to the error, dead band"))
register_controller(ControllerKind(
    "pva", C.CTL_PVA,
    (Gain("kp", "1/m", None), Gain("kv", "s/m", 0.0), Gain("ka", "s^2/m", 0.0),
     Gain("ff_v", "s/m", 0.0), Gain("ff_a", "s^2/m", 0.0)),
    ("4/2",), "position-velocity-acceleration state feedback with feedforward"))
register_controller(ControllerKind(
    "force_pid", C.CTL_FORCE,
    (Gain("kx", "N/m", None), Gain("kd", "N s/m", 0.0), Gain("kf", "1/N", None, _TINY)),
    ("4/2",), "pressure-difference (force) inner loop under a PD position loop"))


def controller_kind(name, path="controller.kind"):
    """The registered kind ``name``; an unknown name is a FieldError listing the kinds."""
    if not isinstance(name, str) or name not in CONTROLLERS:
        raise FieldError(path, f"unknown controller {name!r}; registered: {sorted(CONTROLLERS)}")
    return CONTROLLERS[name]


def register_user_controller(name, law, gains=(), valves=("4/2",), description=""):
    """Register a user's own controller, compiled with numba, under ``name``.

    Parameters
    ----------
    name : str
        Its name (``controller.kind``) [-]
    law : numba dispatcher
        ``@njit`` function ``law(g, x_ref, v_ref, a_ref, meas, cst, Ts, u_lo, u_hi) -> u``:
        gains vector (in the order of ``gains``), reference position [m], velocity [m/s],
        acceleration [m/s^2], measured signals (``pneucore.core.controllers.MEAS_*``: x [m],
        v [m/s], a [m/s^2] (estimated from the sensed position), p_a, p_b [Pa abs], A_a,
        A_b [m^2], t [s]), memory (slots from
        ``CST_USER0`` are the law's), sample period [s], valve range [-]; returns the valve
        command (clipped to the range after it). No allocation, no Python objects.
    gains : sequence of (name, unit, default) or Gain
        Its gains, at most ``N_GAINS`` [-]
    valves : tuple of str
        Valve kinds it can drive [-]
    description : str
        One line [-]

    Returns
    -------
    kind : ControllerKind
        The registered kind; the first run compiles a core for it (about the first compile
        of the core)

    Examples
    --------
    >>> from numba import njit
    >>> @njit
    ... def bang(g, x_ref, v_ref, a_ref, meas, cst, Ts, u_lo, u_hi):
    ...     return u_hi if x_ref > meas[0] + g[0] else (u_lo if x_ref < meas[0] - g[0] else 0.0)
    >>> kind = register_user_controller("my_bang", bang, [("band", "m", 1e-3)])
    >>> kind.code == C.CTL_USER
    True
    >>> unregister_controller("my_bang")
    """
    if name in CONTROLLERS and CONTROLLERS[name].law is None:
        raise ValueError(f"{name!r} is a built-in controller")
    gs = tuple(g if isinstance(g, Gain) else Gain(g[0], g[1], g[2] if len(g) > 2 else None,
                                                   -math.inf) for g in gains)
    if len(gs) > C.N_GAINS:
        raise ValueError(f"at most {C.N_GAINS} gains")
    return register_controller(ControllerKind(name, C.CTL_USER, gs, tuple(valves),
                                              description or "user controller", law=law))


def unregister_controller(name):
    """Remove a user's controller (a built-in one stays)."""
    if name in CONTROLLERS and CONTROLLERS[name].law is not None:
        del CONTROLLERS[name]
