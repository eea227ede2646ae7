"""An experiment: a measurement plus the scenario context it was recorded in.

JSON shape::

    {"name": "locked-hold",
     "scenario": {"locked": true, "x0": 0.125},
     "measurement": {"t": [...], "u": [...], "p_a": [...], "p_b": [...], "x": [...]},
     "load_force": null, "supply_pressure": null}

The time axis: **the model's t = 0 is the measurement's t = 0.** A record
whose first sample is at 0.226 s is compared from 0.226 s on, with the
model started at t = 0 (the first measured command is held back to t = 0).
An explicit ``time_offset`` [s] moves the model's start to that measurement
time (model time = measurement time - offset); it must not be after the first
sample. A record that starts before t = 0 (a pre-trigger) starts the model
at its first sample.

The scenario's command defaults to the measured ``u`` (zero-order hold at
the measured breakpoints) and its duration to the measurement's. An initial
state given in the scenario (``initial``, ``x0``) applies at the model's
t = 0. A record made in closed loop names the ``controller`` it ran under in its
scenario; it is replayed open loop with its recorded command all the same, and the
answers say so (:attr:`Experiment.closed_loop`). Missing initial pressures, temperatures and position are estimated
from the first measured samples (:meth:`Experiment._first`), once per
experiment: from the quiet samples before the first command change, never
extrapolated across a transient and never outside the measured range.
The model is run at the measurement's own (possibly irregular) sample times.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from pneucore.data.measurement import Measurement, MeasurementError
from pneucore.description.scenario import Scenario
from pneucore.simulate import checked_sample_times, simulate, simulate_run
from pneucore.description.validation import FieldError, known_keys, mapping, number

#: A record may start at most this many record lengths after the model's t = 0 (the model
#: simulates the time before the first sample); beyond, ``time_offset`` is asked for
LEAD_LIMIT = 10.0

#: Scenarios an experiment keeps built and validated, one per model shape (Experiment.scenario_for)
_SCENARIO_CACHE_SIZE = 8

#: Signals that can be compared with the model (:meth:`pneucore.result.SimulationResult.observed`
#: gives the model's: the rod force ``F`` [N], the flows ``q_a``, ``q_b``, ``q_s`` [kg/s] and the
#: supply pressure ``p_s`` [Pa] besides the chamber states)
COMPARABLE = ("p_a", "p_b", "x", "v", "T_a", "T_b", "F", "q_a", "q_b", "q_s", "p_s")

#: What a record without a command column needs
NO_COMMAND = ("the record has no valve command column 'u': give the command as scenario.command "
              "(breakpoints [[t [s], u [-]], ...], held between them), or have one proposed from a "
              "measured pressure's edges (POST /api/datasets/{id}/propose-command, or on the command line "
              "`pneucore propose-command FILE`, or --propose-command on compare, diagnose, "
              "refine) and confirm it")

#: What the answers say of a record made in closed loop (an experiment whose scenario carries the
#: ``controller`` it ran under): it is replayed open loop with its recorded valve command, so the
#: model is judged on the same valve signal as the rig (the controller's own law is not simulated:
#: the model's error would feed back into the command and hide itself)
CLOSED_LOOP_NOTE = ("recorded in closed loop ({kind} controller): replayed open loop with its "
                    "recorded valve command ({source}); the controller is not simulated")


@dataclass
class Experiment:
    """A measurement with its scenario context.

    Parameters
    ----------
    measurement : Measurement
        The recorded series (SI units)
    scenario : dict
        Scenario fields that override the defaults taken from the measurement
    name : str
        Label used in reports
    load_force : float or None
        External load during this experiment [N] (None = the model's)
    supply_pressure : float or None
        Supply pressure during this experiment [Pa abs] (None = the model's)
    """
    measurement: Measurement
    scenario: dict = field(default_factory=dict)
    name: str = ""
    load_force: Optional[float] = None
    supply_pressure: Optional[float] = None
    dataset_id: Optional[str] = None
    time_offset: Optional[float] = None
    _first_cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    _scenario_cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    _signals_cache: tuple = field(default=(None, ()), init=False, repr=False, compare=False)

    @classmethod
    def from_dict(cls, d, path="experiment", ambient_pressure=101300.0, datasets=None):
        """Build from plain JSON; ``datasets`` resolves a ``dataset_id`` to a measurement."""
        if isinstance(d, Experiment):
            return d
        mapping(d, path)
        known_keys(d, ("scenario", "measurement", "dataset_id", "name", "load_force",
                       "supply_pressure", "time_offset"), path)
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
        offset = number(d.get("time_offset"), f"{path}.time_offset", allow_none=True)
        if scen.get("controller") is not None:
            ctl = mapping(scen["controller"], f"{path}.scenario.controller")
            if not isinstance(ctl.get("kind"), str) or not ctl["kind"]:
                raise FieldError(f"{path}.scenario.controller.kind",
                                 "the controller the record ran under, by name (e.g. pid)")
            if "u" not in meas.signals and scen.get("command") is None:
                raise FieldError(f"{path}.scenario.controller", (
                    "a closed-loop record is replayed open loop with its recorded valve "
                    "command: the record needs its command column 'u' [-] (or give "
                    "scenario.command, breakpoints [[t [s], u [-]], ...])"))
        if "u" not in meas.signals and scen.get("command") is None:
            raise FieldError(f"{path}.scenario.command", NO_COMMAND)
        if scen.get("command") is not None:   # read as breakpoints before anything samples it
            try:
                Scenario.from_dict({"command": scen["command"]})
            except FieldError as exc:
                raise FieldError(f"{path}.{exc.path}", exc.detail) from None
        if offset is not None and offset > float(meas.t[0]):
            raise FieldError(f"{path}.time_offset",
                             f"{offset:g} s is after the first sample ({float(meas.t[0]):g} s); the "
                             "model must start at or before the first measured sample")
        return cls(meas, scen, str(d.get("name") or meas.name or ""), load, sup,
                   d.get("dataset_id") if d.get("measurement") is None else None, offset)

    def to_dict(self):
        d = {"name": self.name, "scenario": copy.deepcopy(self.scenario),
             "measurement": self.measurement.to_dict(), "load_force": self.load_force,
             "supply_pressure": self.supply_pressure}
        if self.time_offset is not None:
            d["time_offset"] = self.time_offset
        return d

    def cut(self, seconds):
        """This experiment cut to its first ``seconds`` on the model's time axis (its start:
        initial state, first command, kept); a scenario duration is shortened to match.

        Parameters
        ----------
        seconds : float
            Time kept from the model's t = 0 [s]

        Returns
        -------
        experiment : Experiment
            The cut experiment (the dataset reference dropped: it holds the cut series)
        """
        scen = dict(self.scenario)
        if "duration" in scen:
            scen["duration"] = min(float(scen["duration"]), seconds)
        return Experiment(self.measurement.slice(None, self.t0 + seconds), scen, self.name,
                          self.load_force, self.supply_pressure, None, self.time_offset)

    # ------------------------------------------------------------------
    @property
    def t0(self):
        """Measurement time of the model's t = 0 [s].

        ``time_offset`` when given, else 0 (the measurement's own t = 0), or
        the first sample's time for a record starting before t = 0.
        """
        if self.time_offset is not None:
            return float(self.time_offset)
        return min(0.0, float(self.measurement.t[0]))

    @property
    def times(self):
        """Sample times on the model's time axis, ``t - t0`` [s]."""
        return self.measurement.t - self.t0

    @property
    def command_source(self):
        """Where the command replayed comes from: ``"scenario"`` (given with the experiment) or
        ``"measured"`` (the record's ``u`` column) [-]."""
        return "scenario" if self.scenario.get("command") is not None else "measured"

    @property
    def closed_loop(self):
        """For a record made in closed loop (its scenario names the ``controller``): what was
        replayed, ``{"controller": kind, "command_source", "note"}``; None for an open-loop
        record. The replay is open loop with the recorded command (:data:`CLOSED_LOOP_NOTE`)."""
        ctl = self.scenario.get("controller")
        if ctl is None:
            return None
        source = self.command_source
        return {"controller": str(ctl.get("kind")), "command_source": source,
                "note": CLOSED_LOOP_NOTE.format(
                    kind=ctl.get("kind"),
                    source="the record's u column" if source == "measured"
                    else "scenario.command")}

    @property
    def command_samples(self):
        """The valve command at each sample [-]: the measured ``u``, or the scenario's command
        held between its breakpoints (on the model's time axis) when it gives one."""
        if self.command_source == "measured":
            return self.measurement.signals["u"]
        cmd = np.asarray(self.scenario["command"], dtype=float).reshape(-1, 2)
        idx = np.searchsorted(cmd[:, 0], self.times, side="right") - 1
        return cmd[np.clip(idx, 0, None), 1]

    @property
    def signals(self):
        """Measured signals that the model predicts (``p_a``, ``p_b``, ``x``, ...).

        Found once per measurement (a scan of every sample; a calibration asks at each of
        its replays): like the first-sample estimates, this assumes the measurement's series
        are not edited in place afterwards (a new measurement is found afresh).
        """
        meas, names = self._signals_cache
        if meas is not self.measurement:
            names = tuple(s for s in self.measurement.measured_signals if s in COMPARABLE)
            self._signals_cache = (self.measurement, names)
        return names

    def model_for(self, model):
        """The model with this experiment's load and supply pressure applied.

        A new model with its own jack and supply where it changes them, sharing the rest with
        ``model`` (a calibration replays thousands of models: a deep copy of each cost more
        than its simulation's setting up); ``model`` itself when nothing changes.
        """
        if self.load_force is None and self.supply_pressure is None:
            return model
        m = copy.copy(model)
        if self.load_force is not None:
            m.jack = copy.copy(model.jack)
            m.jack.load_force = self.load_force
        if self.supply_pressure is not None:
            m.supply = copy.copy(model.supply)
            m.supply.pressure = self.supply_pressure
        return m

    def noise(self, name):
        """:func:`pneucore.analysis.metrics.noise_sigma` of a measured signal, found once per
        experiment and signal (every fit on the experiment weighs its residuals by it; like the
        first-sample estimates, this assumes the measurement is not edited afterwards) [SI]."""
        key = ("noise", name)
        if key not in self._first_cache:
            from pneucore.analysis.metrics import noise_sigma
            self._first_cache[key] = noise_sigma(self.measurement.signals[name])
        return self._first_cache[key]

    def _first(self, name, max_window=200):
        """Initial value of a signal, estimated from the quiet samples at the start.

        The window is the samples before the command first changes (at most
        ``max_window``). A straight line fitted to it and evaluated at the
        first sample averages the noise without being biased by a slow drift
        (a leak). A transient inside the window (the chamber filling from the
        first sample on) is no straight line: while the line's residual RMS
        exceeds twice the noise (estimated from successive differences,
        ``sqrt(mean(diff^2) / 2)``, which is the noise's standard deviation
        for white noise), the window is halved. The estimate is clipped to
        the range of the samples it came from, so it never extrapolates
        beyond what was measured (a pressure stays positive). Computed once
        per experiment and signal (replays reuse it).
        """
        if name in self._first_cache:
            return self._first_cache[name]
        out = self._estimate_first(name, max_window)
        self._first_cache[name] = out
        return out

    def _estimate_first(self, name, max_window):
        if name not in self.measurement.signals:
            return None
        v = self.measurement.signals[name]
        t = self.measurement.t
        u = self.command_samples
        changes = np.flatnonzero(np.diff(u) != 0)
        end = min(changes[0] + 1 if changes.size else len(u), max_window)
        ok = np.flatnonzero(np.isfinite(v[:end]))
        if ok.size == 0:
            ok = np.flatnonzero(np.isfinite(v))
            return float(v[ok[0]]) if ok.size else None
        while ok.size >= 3:
            tt, vv = t[ok] - t[ok[0]], v[ok]
            slope, icpt = np.polyfit(tt, vv, 1)
            resid = vv - (icpt + slope * tt)
            noise = np.sqrt(np.mean(np.diff(vv) ** 2) / 2.0)
            if np.sqrt(np.mean(resid ** 2)) <= 2.0 * noise or ok.size <= 4:
                return float(np.clip(icpt, vv.min(), vv.max()))
            ok = ok[: max(ok.size // 2, 4)]
        return float(np.mean(v[ok]))

    def scenario_for(self, model):
        """The :class:`Scenario` that replays this experiment on ``model`` (validated).

        Built and validated once for the facts of the model it depends on (the valve's
        kind and command range, the heat model, the stroke): a calibration replays one
        experiment on hundreds of models, and each later call repeats only the checks
        against the model (:meth:`Scenario.check_against`). Like the first-sample
        estimates, this assumes the experiment's measurement is not edited afterwards
        (its ``scenario`` and ``time_offset`` may be: they are part of the key).
        """
        key = (model.valve.kind, tuple(model.valve.opening_range), model.heat.model,
               "heat_exchange" in model.effects, model.jack.stroke, self.time_offset)
        hit = self._scenario_cache.get(key)
        # the scenario fields it was built from, compared by value (cheaper than hashing them)
        if hit is not None and hit[0] == self.scenario:
            hit[1].check_against(model)
            return hit[1]
        scen = self._build_scenario(model)
        if len(self._scenario_cache) >= _SCENARIO_CACHE_SIZE:
            self._scenario_cache.clear()   # a calibration of the stroke: no unbounded growth
        self._scenario_cache[key] = (copy.deepcopy(self.scenario), scen)
        return scen

    def _build_scenario(self, model):
        meas = self.measurement
        lead = float(meas.t[0]) - self.t0
        if lead > LEAD_LIMIT * meas.duration:
            # a logger's absolute time stamps: simulating the rest before them would be a waste
            raise FieldError("time_offset", (
                f"the first sample is at t = {float(meas.t[0]):g} s, more than {LEAD_LIMIT:g} times the "
                f"record's length ({meas.duration:g} s) after the model's t = 0; give time_offset "
                f"(e.g. {float(meas.t[0]):g} s) to start the model at the first sample"))
        d = dict(self.scenario)
        d.pop("controller", None)   # a closed-loop record: replayed with its recorded command
        if "command" not in d:
            if "u" not in meas.signals:
                raise FieldError("scenario.command", NO_COMMAND)
            lo, hi = model.valve.opening_range
            u = meas.signals["u"]
            bad = np.flatnonzero((u < lo - 1e-12) | (u > hi + 1e-12))
            if bad.size:
                raise MeasurementError(
                    f"command {u[bad[0]]:g} is outside the {model.valve.kind} valve's range "
                    f"[{lo:g}, {hi:g}]", column="u", row=int(bad[0]) + 1)
            cmd = [[t - self.t0, u] for t, u in meas.command_breakpoints()]
            cmd[0][0] = 0.0   # the first measured command is held back to the model's t = 0
            d["command"] = cmd
        end = float(meas.t[-1] - self.t0)
        d.setdefault("duration", end)
        dur = d["duration"]
        # 1e-12 relative: a rounding of n * dt (issue 39); a later sample would be neither
        # simulated nor compared, silently: refused, naming the duration
        if isinstance(dur, (int, float)) and not isinstance(dur, bool) and np.isfinite(dur) \
                and dur > 0 and end > dur * (1 + 1e-12):
            n_after = int(np.count_nonzero(meas.t - self.t0 > dur * (1 + 1e-12)))
            raise FieldError("scenario.duration", (
                f"{dur:g} s ends before the record's last sample at {end:g} s on the model's "
                f"time axis ({n_after} sample(s) after it would be neither simulated nor "
                f"compared): give at least {end:g} s, or leave it out (the record's length)"))
        d.setdefault("sample_period", float(np.min(np.diff(meas.t))))
        ini = dict(d.get("initial") or {})
        for key in ("p_a", "p_b", "T_a", "T_b"):
            if ini.get(key) is None and not (key == "p_b" and model.b_chamber_pressure is not None):
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
        return simulate(m, scen, raise_on_error=raise_on_error, t_out=self._times_to(scen.duration))

    def run(self, model):
        """:meth:`simulate`'s outputs unwrapped (:func:`pneucore.simulate.simulate_run`): a
        :class:`pneucore.result.CoreRun`, a solver failure in its ``status``."""
        m = self.model_for(model)
        scen = self.scenario_for(m)
        key = ("times", self.measurement, self.t0, scen.duration)
        hit = self._first_cache.get(key[0])
        if hit is None or hit[0] is not key[1] or hit[1:3] != key[2:]:
            # checked once for the record and the duration replayed (the measurement is not
            # edited afterwards, as for the first-sample estimates)
            hit = self._first_cache[key[0]] = key[1:] + (
                checked_sample_times(self._times_to(scen.duration), scen.duration),)
        return simulate_run(m, scen, hit[3], checked_times=True)

    def _times_to(self, duration):
        """The sample times up to ``duration`` on the model's time axis [s]."""
        t = self.times
        return t[t <= duration * (1 + 1e-12)]


def closed_loop_replays(experiments):
    """The experiments recorded in closed loop, as a diagnosis or refinement answer names them
    (the API's and the command line's).

    Parameters
    ----------
    experiments : list of Experiment
        The experiments of a request [-]

    Returns
    -------
    replays : list of dict
        ``[{experiment, controller, command_source, note}]``, one per experiment whose scenario
        names a controller (each replayed open loop with its recorded command,
        :attr:`Experiment.closed_loop`); empty when none [-]
    """
    return [dict(experiment=e.name or f"experiments[{i}]", **e.closed_loop)
            for i, e in enumerate(experiments) if e.closed_loop is not None]


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
