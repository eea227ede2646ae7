"""An experiment: a measurement plus the scenario context it was recorded in.

JSON shape::

    {"name": "locked-hold",
     "scenario": {"locked": true, "x0": 0.125},
     "measurement": {"t": [...], "u": [...], "p_a": [...], "p_b": [...], "x": [...]},
     "load_force": null, "supply_pressure": null}

The scenario's command defaults to the measured ``u`` (zero-order hold at
the measured breakpoints) and its duration to the measurement's; the initial
pressures and position default to the first measured samples. The model is
run at the measurement's own (possibly irregular) sample times, shifted so
that the first sample is ``t = 0``.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from .measurement import Measurement, MeasurementError
from .scenario import Scenario
from .simulate import simulate
from .validation import FieldError, known_keys, mapping, number

#: Signals that can be compared with the model
COMPARABLE = ("p_a", "p_b", "x", "v", "T_a", "T_b")


@dataclass
class Experiment:
    """A measurement with its scenario context.

    Parameters
    ----------
    measurement : Measurement  The recorded series (SI units)
    scenario : dict  Scenario fields that override the defaults taken from the measurement
    name : str  Label used in reports
    load_force : float or None  External load during this experiment [N] (None = the model's)
    supply_pressure : float or None  Supply pressure during this experiment [Pa abs] (None = the model's)
    """
    measurement: Measurement
    scenario: dict = field(default_factory=dict)
    name: str = ""
    load_force: Optional[float] = None
    supply_pressure: Optional[float] = None
    dataset_id: Optional[str] = None

    @classmethod
    def from_dict(cls, d, path="experiment", ambient_pressure=101300.0, datasets=None):
        """Build from plain JSON; ``datasets`` resolves a ``dataset_id`` to a measurement."""
        if isinstance(d, Experiment):
            return d
        mapping(d, path)
        known_keys(d, ("scenario", "measurement", "dataset_id", "name", "load_force",
                       "supply_pressure"), path)
        if d.get("measurement") is not None:
            meas = d["measurement"]
            if not isinstance(meas, Measurement):
                try:
                    meas = Measurement.from_dict(mapping(meas, f"{path}.measurement"),
                                                 ambient_pressure=ambient_pressure)
                except MeasurementError as exc:
                    raise FieldError(f"{path}.measurement", str(exc)) from exc
        elif d.get("dataset_id") is not None:
            if datasets is None:
                raise FieldError(f"{path}.dataset_id", "no dataset store is available here")
            meas = datasets(d["dataset_id"])
            if meas is None:
                raise FieldError(f"{path}.dataset_id", f"unknown dataset {d['dataset_id']!r}")
        else:
            raise FieldError(f"{path}.measurement", "an experiment needs a measurement or a dataset_id")
        scen = dict(mapping(d.get("scenario") or {}, f"{path}.scenario"))
        load = number(d.get("load_force"), f"{path}.load_force", allow_none=True)
        sup = number(d.get("supply_pressure"), f"{path}.supply_pressure", positive=True, allow_none=True)
        return cls(meas, scen, str(d.get("name") or meas.name or ""), load, sup,
                   d.get("dataset_id") if d.get("measurement") is None else None)

    def to_dict(self):
        return {"name": self.name, "scenario": copy.deepcopy(self.scenario),
                "measurement": self.measurement.to_dict(), "load_force": self.load_force,
                "supply_pressure": self.supply_pressure}

    # ------------------------------------------------------------------
    @property
    def t0(self):
        """Time of the first sample [s]."""
        return float(self.measurement.t[0])

    @property
    def times(self):
        """Sample times shifted to start at 0 [s]."""
        return self.measurement.t - self.t0

    @property
    def signals(self):
        """Measured signals that the model predicts (``p_a``, ``p_b``, ``x``, ...)."""
        return tuple(s for s in self.measurement.measured_signals if s in COMPARABLE)

    def model_for(self, model):
        """The model with this experiment's load and supply pressure applied."""
        if self.load_force is None and self.supply_pressure is None:
            return model
        m = model.copy()
        if self.load_force is not None:
            m.jack.load_force = self.load_force
        if self.supply_pressure is not None:
            m.supply.pressure = self.supply_pressure
        return m

    def _first(self, name, max_window=200):
        """Initial value of a signal, estimated from the samples before the command first changes.

        A straight line is fitted to (at most ``max_window`` of) those samples
        and evaluated at the first sample time: it averages the noise over the
        whole quiet window without being biased by a slow drift (a leak).
        """
        if name not in self.measurement.signals:
            return None
        v = self.measurement.signals[name]
        t = self.measurement.t
        u = self.measurement.signals["u"]
        changes = np.flatnonzero(np.diff(u) != 0)
        end = min(changes[0] + 1 if changes.size else len(u), max_window)
        ok = np.flatnonzero(np.isfinite(v[:end]))
        if ok.size == 0:
            ok = np.flatnonzero(np.isfinite(v))
            return float(v[ok[0]]) if ok.size else None
        if ok.size < 3:
            return float(np.mean(v[ok]))
        slope, icpt = np.polyfit(t[ok] - t[0], v[ok], 1)
        return float(icpt)

    def scenario_for(self, model):
        """The :class:`Scenario` that replays this experiment on ``model`` (validated)."""
        meas = self.measurement
        d = dict(self.scenario)
        if "command" not in d:
            lo, hi = model.valve.opening_range
            u = meas.signals["u"]
            bad = np.flatnonzero((u < lo - 1e-12) | (u > hi + 1e-12))
            if bad.size:
                raise MeasurementError(
                    f"command {u[bad[0]]:g} is outside the {model.valve.kind} valve's range "
                    f"[{lo:g}, {hi:g}]", column="u", row=int(bad[0]) + 1)
            d["command"] = [[max(0.0, t - self.t0), u] for t, u in meas.command_breakpoints()]
        d.setdefault("duration", float(meas.t[-1] - meas.t[0]))
        d.setdefault("sample_period", float(np.min(np.diff(meas.t))))
        ini = dict(d.get("initial") or {})
        for key in ("p_a", "p_b", "T_a", "T_b"):
            if ini.get(key) is None and not (key == "p_b" and model.valve.kind == "3/2"):
                if key.startswith("T") and model.heat.model == "isothermal" and \
                        "heat_exchange" not in model.effects:
                    continue
                first = self._first(key)
                if first is not None:
                    ini[key] = first
        d["initial"] = ini
        if "x0" not in d:
            x0 = self._first("x")
            if x0 is not None:
                d["x0"] = min(max(x0, 0.0), model.jack.stroke)
        return Scenario.from_dict(d, model)

    def simulate(self, model, raise_on_error=False):
        """Run ``model`` on this experiment, sampled at the measurement's times."""
        m = self.model_for(model)
        scen = self.scenario_for(m)
        t = self.times
        t = t[t <= scen.duration * (1 + 1e-12)]
        return simulate(m, scen, raise_on_error=raise_on_error, t_out=t)


def as_experiments(experiments, ambient_pressure=101300.0, datasets=None):
    """Normalise a list of experiments given as objects or JSON dicts."""
    if isinstance(experiments, (Experiment, dict)):
        experiments = [experiments]
    if not experiments:
        raise FieldError("experiments", "at least one experiment is required")
    out = []
    for i, e in enumerate(experiments):
        ex = Experiment.from_dict(e, f"experiments[{i}]", ambient_pressure, datasets)
        if not ex.name:
            ex.name = f"experiment {i + 1}"
        out.append(ex)
    return out
