"""Simulation scenarios: valve command, duration, sampling, initial state, solver settings.

A scenario is a plain dataclass that round-trips to JSON::

    {"duration": 1.0, "sample_period": 0.001,
     "command": [[0, 0], [0.18, 0.7]], "command_interpolation": "hold",
     "locked": false, "x0": 0.05,
     "initial": {"p_a": null, "p_b": null, "T_a": null, "T_b": null}}

The command is a list of breakpoints ``[t, u]`` ([s], [-]), held between
breakpoints (``hold``) or joined by straight lines (``linear``). A locked
piston reproduces the paper's chamber tests (Fig. 6-7) and makes a rigid
vessel of any volume.
"""
from __future__ import annotations

import math

from dataclasses import dataclass, field
from typing import Optional

from pneucore.description.validation import FieldError, choice, integer, known_keys, mapping, number, optional_mapping

#: Longest simulated time accepted [s]
MAX_DURATION = 3600.0
#: Most output samples accepted per simulation
MAX_SAMPLES = 2_000_001
#: Most command breakpoints accepted
MAX_COMMAND_POINTS = 1_000_000
COMMAND_INTERPOLATIONS = ("hold", "linear")
#: How a run starts: ``given`` = ``initial`` and ``x0`` as stated; ``cyclic`` = the cyclic
#: steady state of the scenario repeated with period ``duration`` (the machine running:
#: :func:`pneucore.simulate.cyclic_start`), ``initial`` and ``x0`` its first guess
STARTS = ("given", "cyclic")


@dataclass
class Initial:
    """Initial chamber state; None = ambient.

    Parameters
    ----------
    p_a : float or None
        Initial absolute pressure in A; None = ambient [Pa]
    p_b : float or None
        Initial absolute pressure in B; None = ambient [Pa]
    T_a : float or None
        Initial gas temperature in A; None = ambient [K]
    T_b : float or None
        Initial gas temperature in B; None = ambient [K]
    """
    p_a: Optional[float] = None
    p_b: Optional[float] = None
    T_a: Optional[float] = None
    T_b: Optional[float] = None

    def to_dict(self):
        return dict(self.__dict__)


@dataclass
class Solver:
    """Integrator settings.

    Parameters
    ----------
    rtol : float
        Relative tolerance of the error control [-]
    max_step : float
        Largest integration step [s]
    max_steps : int
        Step budget; the simulation stops with an error beyond it [-]
    max_events : int
        Event budget (stick/slip/stop/command) [-]
    """
    rtol: float = 1e-5
    max_step: float = 0.05
    max_steps: int = 5_000_000
    max_events: int = 200_000

    def to_dict(self):
        return dict(self.__dict__)


@dataclass
class Scenario:
    """What to simulate (see module docstring).

    Parameters
    ----------
    duration : float
        Simulated time [s]
    sample_period : float
        Output sample period [s]
    command : list of [t, u]
        Valve command breakpoints [[t [s], u [-]], ...]
    command_interpolation : str
        ``hold`` (zero-order hold) or ``linear`` between breakpoints [-]
    locked : bool
        Piston locked at ``x0`` (chamber test) [-]
    x0 : float
        Initial position from the A end [m]
    initial : Initial
        Initial chamber state: pressures [Pa] and temperatures [K]
    start : str
        ``given`` (``initial`` and ``x0`` as stated) or ``cyclic`` (the cyclic steady state:
        the scenario repeated, its command a period of ``duration``, until pressures,
        temperatures and position repeat; ``initial`` and ``x0`` are the first guess) [-]
    solver : Solver
        Integrator settings
    name : str
        Label
    description : str
        Free text
    """
    duration: float = 1.0
    sample_period: float = 0.001
    command: list = field(default_factory=lambda: [[0.0, 0.0]])
    command_interpolation: str = "hold"
    locked: bool = False
    x0: float = 0.05
    initial: Initial = field(default_factory=Initial)
    start: str = "given"
    solver: Solver = field(default_factory=Solver)
    name: str = ""
    description: str = ""

    @classmethod
    def from_dict(cls, d, model=None):
        """Build and validate; with ``model``, also check ``x0`` and the command range.

        A Scenario (built, hence validated, here) is returned as it is, after only the
        checks that need ``model`` (:meth:`check_against`); :func:`pneucore.simulate`
        trusts it the same way. A Scenario whose fields were edited afterwards should be
        rebuilt: ``Scenario.from_dict(s.to_dict())``.
        """
        if isinstance(d, Scenario):
            if model is not None:
                d.check_against(model)
            return d
        mapping(d, "scenario")
        known_keys(d, cls.__dataclass_fields__, "scenario")
        s = cls()
        s.duration = number(d.get("duration", s.duration), "scenario.duration", positive=True,
                            high=MAX_DURATION)
        s.sample_period = number(d.get("sample_period", s.sample_period), "scenario.sample_period",
                                 positive=True)
        n_samples = s.duration / s.sample_period + 1.0
        if n_samples > MAX_SAMPLES:
            raise FieldError("scenario.sample_period",
                             f"{n_samples:.4g} output samples requested; the limit is {MAX_SAMPLES} "
                             f"(increase the sample period or shorten the duration)")
        cmd = d.get("command", s.command)
        if not isinstance(cmd, (list, tuple)) or len(cmd) == 0:
            raise FieldError("scenario.command", "must be a non-empty list of [t, u] breakpoints")
        if len(cmd) > MAX_COMMAND_POINTS:
            raise FieldError("scenario.command", f"{len(cmd)} breakpoints; the limit is {MAX_COMMAND_POINTS}")
        out = _plain_command(cmd)
        if out is None:   # the per-breakpoint check, which names the bad one
            out = []
            t_prev = -float("inf")
            for i, pt in enumerate(cmd):
                if not isinstance(pt, (list, tuple)) or len(pt) != 2:
                    raise FieldError(f"scenario.command[{i}]", f"must be a [t, u] pair, got {pt!r}")
                t = number(pt[0], f"scenario.command[{i}][0]", nonnegative=True)
                u = number(pt[1], f"scenario.command[{i}][1]")
                if t < t_prev:
                    raise FieldError(f"scenario.command[{i}][0]",
                                     f"breakpoint times must not decrease ({t_prev:g} s then {t:g} s)")
                t_prev = t
                out.append([t, u])
        s.command = out
        s.command_interpolation = choice(d.get("command_interpolation", s.command_interpolation),
                                         COMMAND_INTERPOLATIONS, "scenario.command_interpolation")
        locked = d.get("locked", s.locked)
        if not isinstance(locked, bool):
            raise FieldError("scenario.locked", f"must be true or false, got {locked!r}")
        s.locked = locked
        s.x0 = number(d.get("x0", s.x0), "scenario.x0", nonnegative=True)
        ini = optional_mapping(d.get("initial"), "scenario.initial")
        known_keys(ini, Initial.__dataclass_fields__, "scenario.initial")
        s.initial = Initial(*(number(ini.get(k), f"scenario.initial.{k}", positive=True, allow_none=True)
                              for k in Initial.__dataclass_fields__))
        s.start = choice(d.get("start", s.start), STARTS, "scenario.start")
        sol = optional_mapping(d.get("solver"), "scenario.solver")
        known_keys(sol, Solver.__dataclass_fields__, "scenario.solver")
        d0 = Solver()      # the defaults, stated once on the dataclass
        s.solver = Solver(
            rtol=number(sol.get("rtol", d0.rtol), "scenario.solver.rtol", low=1e-13, high=1e-2),
            max_step=number(sol.get("max_step", d0.max_step), "scenario.solver.max_step", positive=True,
                            high=1.0),
            max_steps=integer(sol.get("max_steps", d0.max_steps), "scenario.solver.max_steps",
                              low=10, high=1e8),
            max_events=integer(sol.get("max_events", d0.max_events), "scenario.solver.max_events",
                               low=10, high=1e7),
        )
        s.name = str(d.get("name", ""))
        s.description = str(d.get("description", ""))
        if model is not None:
            s.check_against(model)
        return s

    def check_against(self, model):
        """Checks that need the model: position within the stroke, command within the valve's range."""
        if self.x0 > model.jack.stroke:
            raise FieldError("scenario.x0", f"initial position {self.x0:g} m is outside the stroke "
                                            f"[0, {model.jack.stroke:g}] m")
        lo, hi = model.valve.opening_range
        us = [p[1] for p in self.command]
        if us and (min(us) < lo or max(us) > hi):     # the loop only to name the first culprit
            for i, u in enumerate(us):
                if u < lo or u > hi:
                    raise FieldError(f"scenario.command[{i}][1]",
                                     f"command {u:g} is outside the {model.valve.kind} valve's range "
                                     f"[{lo:g}, {hi:g}]")
        if (model.valve.on_time > 0.0 or model.valve.off_time > 0.0) and \
                self.command_interpolation != "hold":
            raise FieldError("scenario.command_interpolation",
                             "the valve's switching times (valve.on_time, valve.off_time) shift "
                             "an on/off command's changes: use a held command ('hold')")
        if model.b_chamber_pressure is not None and self.initial.p_b is not None:
            raise FieldError("scenario.initial.p_b", "chamber B of this 3/2 valve is held at a "
                                                     "constant pressure (valve.b_chamber "
                                                     f"{model.valve.b_chamber!r}); leave "
                                                     "initial.p_b null [Pa]")
        if model.heat.model == "isothermal" and "heat_exchange" not in model.effects:
            for k in ("T_a", "T_b"):
                T = getattr(self.initial, k)
                if T is not None and abs(T - model.ambient.temperature) > 1e-9:
                    raise FieldError(f"scenario.initial.{k}",
                                     "an isothermal model holds the gas at ambient.temperature; "
                                     "leave it null or use another heat model")

    def to_dict(self):
        d = {"duration": self.duration, "sample_period": self.sample_period,
             "command": [list(p) for p in self.command],
             "command_interpolation": self.command_interpolation, "locked": self.locked,
             "x0": self.x0, "initial": self.initial.to_dict(), "solver": self.solver.to_dict()}
        if self.start != "given":     # absent when default: stored scenarios keep their form
            d["start"] = self.start
        for key in ("name", "description"):
            if getattr(self, key):
                d[key] = getattr(self, key)
        return d


def pulse_train(pulses, width, rest=0.0):
    """Command breakpoints for a train of rectangular valve pulses.

    Parameters
    ----------
    pulses : list of (t, u)
        Start time [s] and opening [-] of each pulse
    width : float
        Pulse duration [s]
    rest : float
        Opening between pulses [-]

    Returns
    -------
    command : list of [t, u]
        Breakpoints for :class:`Scenario` (hold interpolation): time [s], opening [-]

    Examples
    --------
    >>> pulse_train([(0.1, 0.7)], 0.05)
    [[0.0, 0.0], [0.1, 0.7], [0.15000000000000002, 0.0]]
    """
    cmd = [[0.0, rest]]
    for t, u in sorted(pulses):
        cmd.append([float(t), float(u)])
        cmd.append([float(t) + width, rest])
    return cmd


def pwm_train(t_start, t_end, frequency, duty, opening, rest=0.0):
    """Command breakpoints of a valve switched on and off at a fixed frequency and duty (PWM).

    A pulse of ``opening`` starts every ``1 / frequency`` seconds from ``t_start`` and lasts
    ``duty / frequency``; the last starts before ``t_end``. Times are rounded to the nanosecond
    (far below any sample period) so that a pulse edge written as a sum lands on the instant it
    names.

    Parameters
    ----------
    t_start, t_end : float
        First pulse's start, and the time no pulse starts at or after [s]
    frequency : float
        Switching frequency [Hz]
    duty : float
        Fraction of each period the valve is at ``opening`` [-], in (0, 1)
    opening : float
        Opening during a pulse [-]
    rest : float
        Opening between pulses [-]

    Returns
    -------
    command : list of [t, u]
        Breakpoints (hold interpolation): time [s], opening [-]

    Examples
    --------
    >>> pwm_train(0.1, 0.2, 20.0, 0.4, 0.7)
    [[0.0, 0.0], [0.1, 0.7], [0.12, 0.0], [0.15, 0.7], [0.17, 0.0]]
    """
    if frequency <= 0.0 or not 0.0 < duty < 1.0:
        raise ValueError("pwm_train: frequency > 0 and 0 < duty < 1")
    period = 1.0 / frequency
    n = int(math.ceil((t_end - t_start) * frequency - 1e-9))
    cmd = [[0.0, float(rest)]]
    for k in range(n):
        t = t_start + k * period
        cmd += [[round(t, 9), float(opening)], [round(t + duty * period, 9), float(rest)]]
    return cmd


def _plain_command(cmd):
    """Fast acceptance of a command whose breakpoints are all ``[t, u]`` pairs of plain finite
    numbers with ``t >= 0`` not decreasing: the breakpoints as floats, or None when any
    needs the per-breakpoint check of :meth:`Scenario.from_dict` (which names it). The
    check with a path string per number cost about 20 us on the paper's pulse command.
    """
    ts, us = [], []
    for pt in cmd:
        if type(pt) is not list and type(pt) is not tuple or len(pt) != 2:
            return None
        t, u = pt
        if (type(t) is not float and type(t) is not int) or (type(u) is not float and type(u) is not int):
            return None
        ts.append(t)
        us.append(u)
    try:
        ts = [float(t) for t in ts]
        us = [float(u) for u in us]
    except OverflowError:
        return None
    if not math.isfinite(sum(ts) + sum(us)) or ts[0] < 0.0 or \
            any(b < a for a, b in zip(ts, ts[1:])):
        return None
    return [[t, u] for t, u in zip(ts, us)]
