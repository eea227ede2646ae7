"""The response object of a simulation: plain arrays, events, statistics, export."""
from __future__ import annotations

import numpy as np

from pneucore.core import layout as L
from pneucore.core.integrator import ST_BACKSTEPS, ST_EVENTS, ST_FEVALS, ST_JACOBIANS, ST_REJECTED, ST_STEPS, \
    STATUS_MESSAGES
from pneucore.physics.flow_control import node_state_unit
from pneucore.physics.tube import line_state_unit

#: Sampled series of every result, with their units
SERIES_UNITS = {
    "t": "s", "u": "-", "p_a": "Pa", "p_b": "Pa", "T_a": "K", "T_b": "K", "m_a": "kg", "m_b": "kg",
    "x": "m", "v": "m/s", "a": "m/s^2", "q_a": "kg/s", "q_b": "kg/s", "friction": "N",
    "mode": "-", "u_eff": "-", "p_supply": "Pa", "q_supply": "kg/s", "net_force": "N",
    "heat_a": "W", "heat_b": "W", "V_a": "m^3", "V_b": "m^3", "rod_force": "N",
    # a closed loop's (pneucore.control.closed_loop): the reference, and what the controller
    # read: the position as sensed, the velocity and acceleration estimated, the pressures
    "x_ref": "m", "x_sensed": "m", "v_est": "m/s", "a_est": "m/s^2", "p_a_sensed": "Pa",
    "p_b_sensed": "Pa",
}

#: Measured signal (:data:`pneucore.data.measurement.SIGNALS`) -> the series that models it,
#: where the names differ: the rod force, the supply flow and the supply pressure
OBSERVED_SERIES = {"F": "rod_force", "q_s": "q_supply", "p_s": "p_supply"}

#: Text of each piston mode code (``layout.MODE_*``), then "" for code -1 (sample not
#: reached): a lookup table indexed by the codes, built once
_MODE_TEXT = np.array(L.MODE_NAMES + ("",))


def _m_b(c):
    eff = c.effective_model
    if eff.b_chamber_pressure is not None:
        return c.aux_out[:, L.AUX_PB] * c.aux_out[:, L.AUX_VB] / (eff.gas.r * c.y_out[:, L.Y_TB])
    return c.y_out[:, L.Y_MB]


def _rod_force(c):
    # Eq. 17 with the moving mass on the load's side (see :class:`SimulationResult`)
    j = c.effective_model.jack
    load = j.total_load
    return np.where(c.mode_out == L.MODE_LOCKED, c.aux_out[:, L.AUX_FNET] + load,
                    j.moving_mass * c.aux_out[:, L.AUX_ACC] + load)


def _aux(k):
    return lambda c: c.aux_out[:, k]


def _y(k):
    return lambda c: c.y_out[:, k]


#: Every result's sampled series, in their order, each read off a :class:`CoreRun`'s output
#: arrays (the effect states follow, one column each): one source for the full result and for
#: the signals a replay reads alone
_SERIES = {
    "t": lambda c: c.t_out, "u": lambda c: c.u_out,
    "p_a": _aux(L.AUX_PA), "p_b": _aux(L.AUX_PB), "T_a": _y(L.Y_TA), "T_b": _y(L.Y_TB),
    "m_a": _y(L.Y_MA), "m_b": _m_b, "x": _y(L.Y_X), "v": _y(L.Y_V), "a": _aux(L.AUX_ACC),
    "q_a": _aux(L.AUX_QA), "q_b": _aux(L.AUX_QB), "friction": _aux(L.AUX_FRICTION),
    "mode": lambda c: _MODE_TEXT[c.mode_out],      # code -1 (sample not reached) -> ""
    "u_eff": _aux(L.AUX_UEFF), "p_supply": _aux(L.AUX_PSUP), "q_supply": _aux(L.AUX_QSUP),
    "net_force": _aux(L.AUX_FNET), "heat_a": _aux(L.AUX_HEAT_A), "heat_b": _aux(L.AUX_HEAT_B),
    "V_a": _aux(L.AUX_VA), "V_b": _aux(L.AUX_VB), "rod_force": _rod_force,
}


class CoreRun:
    """What the compiled core returned for one simulation, before it is wrapped.

    :meth:`result` builds the :class:`SimulationResult` (every series, the events, the
    statistics); :meth:`observed` reads one measured signal's series alone, as the full result's
    :meth:`SimulationResult.observed` gives it (the same arrays): a calibration replays an
    experiment hundreds of times and reads only its measured signals.
    """

    def __init__(self, model, scenario, core, t_out, y_out, aux_out, mode_out, u_out,
                 ev_t, ev_kind, ev_mode, stats, status, t_reached, warnings=None):
        # of the core's inputs only what the series need (the compiled hook and law tables
        # stay out: a replay may be pickled to a cluster)
        self.model, self.scenario = model, scenario
        self.effective_model, self.state_names = core["effective_model"], core["state_names"]
        self.t_out, self.y_out, self.aux_out, self.mode_out, self.u_out = \
            t_out, y_out, aux_out, mode_out, u_out
        self.ev_t, self.ev_kind, self.ev_mode, self.stats = ev_t, ev_kind, ev_mode, stats
        self.status, self.t_reached, self.warnings = status, t_reached, warnings

    def _state(self, name):
        names = self.state_names
        for i in range(L.N_BASE_STATES, len(names)):
            if names[i] == name:
                return self.y_out[:, i]
        return None

    def observed(self, name):
        """:meth:`SimulationResult.observed` of the result this run gives."""
        name = OBSERVED_SERIES.get(name, name)
        lagged = self._state(f"{name}_sensor")
        if lagged is not None:
            return lagged
        if name in _SERIES:
            return _SERIES[name](self)
        state = self._state(name)
        if state is None:
            raise KeyError(name)
        return state

    def events(self):
        """:attr:`SimulationResult.events` of the result this run gives (a new list)."""
        events = [{"t": float(t[0]), "kind": L.EVENT_NAMES[k], "mode": L.MODE_DETAIL[m]}
                  for t, k, m in zip(self.ev_t, self.ev_kind, self.ev_mode)]
        for e, t in zip(events, self.ev_t):
            if e["kind"] == "stop":
                e["v"] = float(t[1])     # the piston's velocity at the impact [m/s]
        return events

    def result(self):
        """The :class:`SimulationResult` (a new one each call)."""
        s = {name: f(self) for name, f in _SERIES.items()}
        for i, name in enumerate(self.state_names[L.N_BASE_STATES:]):
            s[name] = self.y_out[:, L.N_BASE_STATES + i]
        events = self.events()
        stats = self.stats
        st = {"steps": int(stats[ST_STEPS]), "rejected": int(stats[ST_REJECTED]),
              "rhs_evaluations": int(stats[ST_FEVALS]), "jacobians": int(stats[ST_JACOBIANS]),
              "events": int(stats[ST_EVENTS]), "backsteps": int(stats[ST_BACKSTEPS]),
              "t_reached": float(self.t_reached),
              "method": "RODAS4 (Rosenbrock, order 4, L-stable)",
              "rtol": self.scenario.solver.rtol}
        if self.warnings:
            st["warnings"] = self.warnings
        return SimulationResult(s, events, st, self.model, self.scenario, self.status,
                                STATUS_MESSAGES[self.status])


class LazyResult:
    """A :class:`SimulationResult` built on first use of anything but its status and its
    measured signals (:meth:`observed`), which are read off the :class:`CoreRun` directly.

    What a replay holds: a fit reads only the measured signals of most of its replays; the
    phase labels, the events and the report read the full result, built then (once).
    """

    def __init__(self, run):
        self._run = run
        self._full = None
        self.status = run.status
        self.message = STATUS_MESSAGES[run.status]

    def observed(self, name):
        """:meth:`SimulationResult.observed`."""
        if self._full is not None:
            return self._full.observed(name)
        return self._run.observed(name)

    @property
    def full(self):
        """The :class:`SimulationResult` (built once)."""
        if self._full is None:
            self._full = self._run.result()
        return self._full

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self.full, name)

    def summarised(self, keep=(), given=None):
        """:class:`SummarisedResult` of this result: its status, piston modes, events and the
        ``keep`` observed series (copies; ``given``: those already copied), read off the full result if built, else off the core's
        outputs (the same arrays), which it does not hold. The modes are kept as the core's
        codes (8 bytes a sample) and made text on first use, as the full result makes them."""
        if self._full is not None:
            return SummarisedResult(self.status, self.message, self._full.mode,
                                    self._full.events, kept_columns(self._full, keep, given))
        return SummarisedResult(self.status, self.message, None, self._run.events(),
                                kept_columns(self._run, keep, given), mode_codes=self._run.mode_out)


def kept_columns(src, keep, given=None):
    """``{name: copy of src.observed(name)}`` for the names of ``keep`` that ``src`` gives
    (``given``: name -> such a copy already made, used as it is)."""
    out = {}
    for name in keep:
        if given and name in given:
            out[name] = given[name]
            continue
        try:
            out[name] = np.array(src.observed(name), float)
        except KeyError:   # a series this model does not produce (p_b of a 3/2 valve)
            continue
    return out


class SummarisedResult:
    """What a replay keeps of its simulation once summarised
    (:func:`pneucore.analysis.compare.summarise`): the status, the piston modes, the events and a
    few observed series (copies), not the compiled core's outputs.

    A full result holds every series (the core's outputs, about 30 columns of float64 a sample:
    55 MB of ``aux_out`` and 21 MB of ``y_out`` near the peak of a diagnosis on 1 + 20 s,
    ``benchmarks/bench_long_records.py --memory``), kept alive as long as a calibration's
    summary holds its replays; what is read after the summary is only this.

    Attributes
    ----------
    status : int
        The solver's status (0: ok) [-]
    message : str
        Its words [-]
    mode : ndarray of str
        The piston mode of each sample (:attr:`SimulationResult.mode`) [-]
    events : list of dict
        :attr:`SimulationResult.events`
    """

    def __init__(self, status, message, mode, events, columns, mode_codes=None):
        self.status, self.message, self._mode, self.events = status, message, mode, events
        self._columns, self._codes = columns, mode_codes

    @property
    def mode(self):
        """The piston mode of each sample as text, made once from the codes if need be [-]"""
        if self._mode is None:
            self._mode = _MODE_TEXT[self._codes]   # as _SERIES["mode"]: code -1 -> ""
            self._codes = None
        return self._mode

    def observed(self, name):
        """:meth:`SimulationResult.observed` for the series kept; KeyError for the others."""
        try:
            return self._columns[name]
        except KeyError:
            raise KeyError(f"{name}: a summarised replay keeps only the observed series "
                           f"{sorted(self._columns)}") from None

    def summarised(self, keep=(), given=None):
        """Itself (already summarised)."""
        return self


class SimulationResult:
    """Sampled series, events and solver statistics of one simulation.

    Attributes
    ----------
    t : ndarray
        Sample times [s]
    u : ndarray
        Valve command [-]
    p_a, p_b : ndarray
        Chamber pressures [Pa abs]
    T_a, T_b : ndarray
        Gas temperatures [K]
    m_a, m_b : ndarray
        Gas masses [kg]
    x, v, a : ndarray
        Position [m], velocity [m/s], acceleration [m/s^2]
    q_a, q_b : ndarray
        The valve's net mass flow into each port [kg/s] (what a flow meter at the valve
        reads): into the chamber without a line or with a lumped one (whose volume is the
        chamber's), into the line with a line in segments (the flow into the chamber is then
        the last face's state ``line_<port>_q<N>``)
    friction : ndarray
        Friction force, positive towards -x [N] (holding force while stuck, 0 at a stop)
    rod_force : ndarray
        Force the rod exerts on its load, positive outward (what a load cell between rod and
        load reads, the measured signal ``F``) [N]. From the force balance of Eq. 17 with the
        moving mass ``M`` lumped on the load's side: ``F = M a + F_load``, ``F_load`` the load of
        Eq. 17 (``load_force`` plus the weight along the rod). While sliding this is
        ``p_a A_a - p_b A_b + p_atm (A_rod,a - A_rod,b) - F_friction - F_spring`` (+ a user
        effect's force), the jack's side of the same balance; stuck it is the load; at an end
        stop the end cap takes the pressure force and the rod still carries only the load;
        locked (the clamp is the rod's load) it is the net pressure force less the spring
        (``net_force + F_load``)
    q_supply, p_supply : ndarray
        Mass flow drawn from the supply [kg/s] and the supply pressure (the supply-line state
        with ``supply_pressure_drop``, else the supply's own) [Pa abs]
    mode : ndarray of str
        ``slide``, ``stick``, ``stop`` or ``locked``
    events : list of dict
        ``{"t": [s], "kind": "command|slip|stick|stop|reverse", "mode": ...}``; a ``stop``
        also has ``"v"``, the piston's velocity at the impact [m/s] (the state at the located
        event time)
    stats : dict
        Solver statistics (steps, rejected, rhs evaluations, jacobians, events, back-steps);
        :meth:`summary` adds ``stroke``, the stroke metrics (:meth:`stroke_metrics`)
    series : dict
        Every sampled series by name, including effect states (e.g. ``p_a_sensor``)
    """

    def __init__(self, series, events, stats, model, scenario, status=0, message="ok"):
        self.series = series
        self.events = events
        self.stats = stats
        self.model = model
        self.scenario = scenario
        self.status = status
        self.message = message
        self._strokes = None
        for k, v in series.items():
            setattr(self, k, v)

    def stroke_metrics(self):
        """Start-up time, full stroke time, 90 % force time, mean, maximum and stroke end
        speed per stroke, and the air used per cycle [NL] (:func:`pneucore.analysis.strokes.stroke_metrics`,
        SMC's definitions); computed on first use."""
        if self._strokes is None:
            from pneucore.analysis.strokes import stroke_metrics
            self._strokes = stroke_metrics(self, self.model)
        return self._strokes

    @classmethod
    def from_core(cls, model, scenario, core, t_out, y_out, aux_out, mode_out, u_out,
                  ev_t, ev_kind, ev_mode, stats, status, t_reached):
        return CoreRun(model, scenario, core, t_out, y_out, aux_out, mode_out, u_out, ev_t,
                       ev_kind, ev_mode, stats, status, t_reached).result()

    # -- views -------------------------------------------------------------------
    def observed(self, name):
        """The series a sensor would report for the measured signal ``name``: ``p_a``/``p_b``
        through the transducer lag if modelled; ``F`` the rod force (``rod_force``), ``q_s`` the
        supply flow (``q_supply``), ``p_s`` the supply pressure (``p_supply``)
        (:data:`OBSERVED_SERIES`); ``q_a``/``q_b`` the valve's net mass flow into each port
        (into the line where a line in segments sits between valve and chamber)."""
        name = OBSERVED_SERIES.get(name, name)
        lagged = f"{name}_sensor"
        if lagged in self.series:
            return self.series[lagged]
        return self.series[name]

    def events_of(self, kind):
        """Times [s] of the events of one kind (``command``, ``slip``, ``stick``, ``stop``, ``reverse``)."""
        return [e["t"] for e in self.events if e["kind"] == kind]

    def to_dict(self, series=None, arrays=False, inputs=True):
        """Plain JSON: series as lists (NaN -> None), events, stats, units, model and scenario.

        ``arrays=True`` keeps the series as numpy arrays (for a serialiser such as
        orjson that writes arrays directly and NaN as null); ``inputs=False`` leaves
        out ``model`` and ``scenario`` (the REST answer does not repeat them).
        """
        names = series or list(self.series)
        out = {}
        for k in names:
            v = self.series[k]
            if arrays and v.dtype.kind in "fi":
                out[k] = np.ascontiguousarray(v)
            elif v.dtype.kind == "f":
                lst = v.tolist()
                if not np.all(np.isfinite(v)):
                    lst = [x if np.isfinite(x) else None for x in lst]
                out[k] = lst
            else:
                out[k] = v.tolist()
        d = {"series": out, **self.summary(names)}
        if inputs:
            d["model"] = self.model.to_dict()
            d["scenario"] = self.scenario.to_dict()
        return d

    def summary(self, series=None):
        """What :meth:`to_dict` holds besides the series and the inputs: ``units`` (of each
        named series), ``events``, ``stats``, ``status`` and ``message``.

        Parameters
        ----------
        series : list of str, optional
            Series whose units are listed (default: all)
        """
        names = series or list(self.series)
        stats = dict(self.stats)
        if "t" in self.series and "q_supply" in self.series and len(self.t):
            stats["stroke"] = self.stroke_metrics()
        return {"units": {k: SERIES_UNITS.get(k, _state_unit(k)) for k in names},
                "events": list(self.events), "stats": stats, "status": self.status,
                "message": self.message}

    def to_pandas(self):
        """A ``pandas.DataFrame`` indexed by time (needs pandas)."""
        try:
            import pandas as pd
        except ImportError as exc:  # pragma: no cover - pandas is optional
            raise ImportError("to_pandas() needs pandas: pip install pandas") from exc
        df = pd.DataFrame({k: v for k, v in self.series.items() if k != "t"}, index=self.series["t"])
        df.index.name = "t"
        return df

    def __repr__(self):
        return (f"SimulationResult({len(self.t)} samples, {len(self.events)} events, "
                f"{self.stats['steps']} steps, status={self.message!r})")


def _state_unit(name):
    line = line_state_unit(name)
    if line is not None:
        return line
    node = node_state_unit(name)
    if node is not None:
        return node
    if name.startswith("p_"):
        return "Pa"
    if name.startswith("m_"):
        return "kg"
    if name.startswith("u_spool_rate"):
        return "1/s"
    if name.startswith("u_"):
        return "-"
    return ""
