"""The response object of a simulation: plain arrays, events, statistics, export."""
from __future__ import annotations

import numpy as np

from pneucore.core import layout as L
from pneucore.core.integrator import ST_BACKSTEPS, ST_EVENTS, ST_FEVALS, ST_JACOBIANS, ST_REJECTED, ST_STEPS, \
    STATUS_MESSAGES
from pneucore.physics.tube import line_state_unit

#: Sampled series of every result, with their units
SERIES_UNITS = {
    "t": "s", "u": "-", "p_a": "Pa", "p_b": "Pa", "T_a": "K", "T_b": "K", "m_a": "kg", "m_b": "kg",
    "x": "m", "v": "m/s", "a": "m/s^2", "q_a": "kg/s", "q_b": "kg/s", "friction": "N",
    "mode": "-", "u_eff": "-", "p_supply": "Pa", "q_supply": "kg/s", "net_force": "N",
    "heat_a": "W", "heat_b": "W", "V_a": "m^3", "V_b": "m^3", "rod_force": "N",
}

#: Measured signal (:data:`pneucore.data.measurement.SIGNALS`) -> the series that models it,
#: where the names differ: the rod force, the supply flow and the supply pressure
OBSERVED_SERIES = {"F": "rod_force", "q_s": "q_supply", "p_s": "p_supply"}

#: Text of each piston mode code (``layout.MODE_*``), then "" for code -1 (sample not
#: reached): a lookup table indexed by the codes, built once
_MODE_TEXT = np.array(L.MODE_NAMES + ("",))


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
        eff = core["effective_model"]
        s = {"t": t_out, "u": u_out}
        s["p_a"] = aux_out[:, L.AUX_PA]
        s["p_b"] = aux_out[:, L.AUX_PB]
        s["T_a"] = y_out[:, L.Y_TA]
        s["T_b"] = y_out[:, L.Y_TB]
        s["m_a"] = y_out[:, L.Y_MA]
        V_b = aux_out[:, L.AUX_VB]
        if eff.b_chamber_pressure is not None:
            s["m_b"] = s["p_b"] * V_b / (eff.gas.r * s["T_b"])
        else:
            s["m_b"] = y_out[:, L.Y_MB]
        s["x"] = y_out[:, L.Y_X]
        s["v"] = y_out[:, L.Y_V]
        s["a"] = aux_out[:, L.AUX_ACC]
        s["q_a"] = aux_out[:, L.AUX_QA]
        s["q_b"] = aux_out[:, L.AUX_QB]
        s["friction"] = aux_out[:, L.AUX_FRICTION]
        s["mode"] = _MODE_TEXT[mode_out]      # code -1 (sample not reached) -> ""
        s["u_eff"] = aux_out[:, L.AUX_UEFF]
        s["p_supply"] = aux_out[:, L.AUX_PSUP]
        s["q_supply"] = aux_out[:, L.AUX_QSUP]
        s["net_force"] = aux_out[:, L.AUX_FNET]
        s["heat_a"] = aux_out[:, L.AUX_HEAT_A]
        s["heat_b"] = aux_out[:, L.AUX_HEAT_B]
        s["V_a"] = aux_out[:, L.AUX_VA]
        s["V_b"] = V_b
        # Eq. 17 with the moving mass on the load's side (see the class docstring)
        load = eff.jack.total_load
        s["rod_force"] = np.where(mode_out == L.MODE_LOCKED, s["net_force"] + load,
                                  eff.jack.moving_mass * s["a"] + load)
        for i, name in enumerate(core["state_names"][L.N_BASE_STATES:]):
            s[name] = y_out[:, L.N_BASE_STATES + i]
        events = [{"t": float(t[0]), "kind": L.EVENT_NAMES[k], "mode": L.MODE_DETAIL[m]}
                  for t, k, m in zip(ev_t, ev_kind, ev_mode)]
        for e, t in zip(events, ev_t):
            if e["kind"] == "stop":
                e["v"] = float(t[1])     # the piston's velocity at the impact [m/s]
        st = {"steps": int(stats[ST_STEPS]), "rejected": int(stats[ST_REJECTED]),
              "rhs_evaluations": int(stats[ST_FEVALS]), "jacobians": int(stats[ST_JACOBIANS]),
              "events": int(stats[ST_EVENTS]), "backsteps": int(stats[ST_BACKSTEPS]),
              "t_reached": float(t_reached), "method": "RODAS4 (Rosenbrock, order 4, L-stable)",
              "rtol": scenario.solver.rtol}
        return cls(s, events, st, model, scenario, status, STATUS_MESSAGES[status])

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
    if name.startswith("p_"):
        return "Pa"
    if name.startswith("m_"):
        return "kg"
    if name.startswith("u_spool_rate"):
        return "1/s"
    if name.startswith("u_"):
        return "-"
    return ""
