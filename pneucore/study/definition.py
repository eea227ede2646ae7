"""Robustness study definitions: parameters by path, grids and distributions, deterministic samples.

A study runs one model and scenario over many parameter sets::

    {"model": {...}, "scenario": {...},
     "parameters": {
         "supply.pressure":      {"grid": [5e5, 6e5, 7e5]},
         "friction.extend.fc0":  {"distribution": "uniform", "min": 4, "max": 16},
         "heat.coefficient":     {"distribution": "normal", "mean": 25, "std": 5, "min": 0},
         "valve.ports.*.C":      {"distribution": "lognormal", "median": 1.0, "sigma": 0.1}},
     "samples": 200, "seed": 1, "metrics": null}

Design
------
* Parameters are kept **sorted by path** (the order of the JSON object's
  keys never matters, so the canonical JSON and the user's dict give the
  same parameter sets).
* **Grid parameters** form a full factorial over their listed values (the
  first grid parameter in path order varies slowest).
* **Distribution parameters** are drawn independently for every run with
  ``numpy.random.default_rng(seed)``: one call ``rng.random((n_runs,
  n_distributions))`` gives the uniforms, row ``r`` belongs to run ``r``,
  column ``j`` to the ``j``-th distribution parameter in path order;
  each uniform is mapped through the inverse CDF of its distribution
  truncated to ``[min, max]`` (``x = F^-1(F(min) + u (F(max) - F(min)))``),
  so truncation never rejects or redraws.
* Grid only: ``n_runs`` = the factorial's size; ``samples`` may be omitted
  (null) or must equal it. Distributions only: ``n_runs = samples``. Both:
  every grid point gets ``samples`` runs (``n_runs = grid points x samples``,
  run ``r`` at grid point ``r // samples``), each with its own draw.
* At most :data:`MAX_RUNS` runs per study.

The parameter sets are a pure function of the definition, so any process
(a pool worker, a Dask worker) regenerates run ``r``'s values from the
definition and the index alone (:func:`run_values`).

Distributions
-------------
``uniform``: ``min`` < ``max`` (both required). ``normal``: ``mean``,
``std`` > 0, optional ``min``/``max``. ``lognormal``: ``median`` > 0 and
``sigma`` > 0 of ``ln x`` (``ln x ~ N(ln median, sigma)``), optional bounds.
Bounds keeping less than :data:`MIN_MASS` of the probability mass are
rejected (e.g. a pressure in bar against a mean in Pa).
"""
from __future__ import annotations

import copy
import json
import math
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np
from scipy import special

from pneucore.description.model import Model
from pneucore.description.paths import get_value, set_values
from pneucore.description.scenario import Scenario
from pneucore.description.validation import FieldError, integer, known_keys, mapping, number

#: Most runs accepted in one study (grid points x samples)
MAX_RUNS = 1_000_000
#: Most values in one grid
MAX_GRID_VALUES = 10_000
#: Smallest probability mass that a truncated distribution's bounds may keep [-]
MIN_MASS = 1e-12


@dataclass(frozen=True)
class Distribution:
    """A distribution a study parameter may follow, by name in :data:`DISTRIBUTIONS`.

    It unpacks as ``(required, optional)``, the pair :data:`DISTRIBUTIONS` held before.

    Parameters
    ----------
    required : tuple of str
        Fields that must be given (:class:`StudyParameter` attributes) [-]
    optional : tuple of str
        Fields that may be given [-]
    inverse_cdf : callable
        ``inverse_cdf(parameter, u) -> ndarray``: uniforms ``u`` in [0, 1) mapped through
        the inverse CDF truncated to ``[min, max]`` (unit of the parameter)
    mass : callable
        ``mass(parameter) -> float``: probability mass kept by the bounds [-]
    positive : tuple of str
        Fields that must be > 0 [-]
    in_support : callable
        ``in_support(value) -> bool``: a bound outside the support (a lognormal's
        ``min <= 0``) truncates nothing and is not checked against the model
    """
    required: tuple
    optional: tuple
    inverse_cdf: Callable
    mass: Callable
    positive: tuple = ()
    in_support: Callable = lambda v: True

    def __iter__(self):
        return iter((self.required, self.optional))


#: name -> :class:`Distribution`; parsing, validation and sampling all read it, so a
#: distribution registered here (:func:`register_distribution`) is one a study can use
DISTRIBUTIONS: dict[str, Distribution] = {}


def register_distribution(name, distribution):
    """Add (or replace) the distribution ``name`` for study parameters.

    Parameters
    ----------
    name : str
        Name given as ``{"distribution": name, ...}``
    distribution : Distribution
        Its fields and inverse CDF

    Notes
    -----
    Every process regenerates its runs' values from the definition, so the
    distribution must be registered where the runs execute: this process
    (``workers=0``) or Dask workers that preload the registering module; the
    local pool's forkserver workers import pneucore only.
    """
    DISTRIBUTIONS[name] = distribution
    return distribution


def _bound(v, missing):
    return missing if v is None else v


def _normal_form(p):
    """``(loc, scale, lo, hi)``: a normal parameter is its own normal variable."""
    return p.mean, p.std, _bound(p.min, -math.inf), _bound(p.max, math.inf)


def _lognormal_form(p):
    """``(loc, scale, lo, hi)`` of ``ln x ~ N(ln median, sigma)``."""
    lo = -math.inf if p.min is None or p.min <= 0 else math.log(p.min)
    hi = math.inf if p.max is None else (math.log(p.max) if p.max > 0 else -math.inf)
    return math.log(p.median), p.sigma, lo, hi


def _truncation(form, p):
    """``(loc, scale, za, zb, flip)`` of the standard-normal form of ``p``.

    The truncated range is handled on the lower tail (``flip``: by symmetry) so
    that far-tail bounds keep their precision.
    """
    loc, scale, lo, hi = form(p)
    za, zb = (lo - loc) / scale, (hi - loc) / scale
    flip = za > 0.0
    if flip:
        za, zb = -zb, -za
    return loc, scale, za, zb, flip


def _normal_family(form, back=None):
    """``(inverse_cdf, mass)`` of a truncated distribution whose variable ``form`` maps to a
    normal one (``back`` maps a normal value back to the parameter: ``exp`` for lognormal)."""
    def mass(p):
        _, _, za, zb, _ = _truncation(form, p)
        if not zb > za:
            return 0.0
        return float(special.ndtr(zb) - special.ndtr(za))

    def inverse_cdf(p, u):
        loc, scale, za, zb, flip = _truncation(form, p)
        fa, fb = special.ndtr(za), special.ndtr(zb)
        q = np.maximum(fa + u * (fb - fa), np.nextafter(0.0, 1.0))
        z = np.clip(special.ndtri(q), za, zb)
        if flip:
            z = -z
        x = loc + scale * z
        if back is not None:
            x = back(x)
        return np.clip(x, _bound(p.min, -math.inf), _bound(p.max, math.inf))
    return inverse_cdf, mass


register_distribution("uniform", Distribution(
    ("min", "max"), (), inverse_cdf=lambda p, u: p.min + u * (p.max - p.min),
    mass=lambda p: 1.0))
register_distribution("normal", Distribution(
    ("mean", "std"), ("min", "max"), *_normal_family(_normal_form), positive=("std",)))
register_distribution("lognormal", Distribution(
    ("median", "sigma"), ("min", "max"), *_normal_family(_lognormal_form, np.exp),
    positive=("median", "sigma"), in_support=lambda v: v > 0))


@dataclass
class StudyParameter:
    """One varied model parameter.

    Parameters
    ----------
    path : str
        Model path (see :mod:`pneucore.description.paths`), e.g. ``friction.extend.fc0``
    kind : str
        ``grid``, ``uniform``, ``normal`` or ``lognormal``
    grid : list of float or None
        Grid values, in the unit of the parameter (scale factors [-] for valve tables)
    min, max : float or None
        Bounds, in the unit of the parameter (required for uniform; optional truncation
        otherwise)
    mean, std : float or None
        Normal distribution's mean and standard deviation (std > 0), in the unit of the
        parameter
    median, sigma : float or None
        Lognormal: median of x (unit of the parameter) and standard deviation of ln x [-]
    """
    path: str
    kind: str
    grid: Optional[list] = None
    min: Optional[float] = None
    max: Optional[float] = None
    mean: Optional[float] = None
    std: Optional[float] = None
    median: Optional[float] = None
    sigma: Optional[float] = None

    def to_dict(self):
        if self.kind == "grid":
            return {"grid": list(self.grid)}
        d = {"distribution": self.kind}
        dist = DISTRIBUTIONS[self.kind]
        for k in dist.required + dist.optional:
            v = getattr(self, k)
            if v is not None:
                d[k] = v
        return d

    @property
    def distribution(self):
        """The registered :class:`Distribution` (None for a grid)."""
        return None if self.kind == "grid" else DISTRIBUTIONS[self.kind]

    def mass(self):
        """Probability mass kept by the bounds [-] (1 for grids)."""
        return 1.0 if self.kind == "grid" else self.distribution.mass(self)

    def from_uniform(self, u):
        """Map uniforms ``u`` in [0, 1) through the truncated inverse CDF."""
        return self.distribution.inverse_cdf(self, np.asarray(u, float))


def _preset(value, key):
    """A study's ``model`` or ``scenario``: its JSON, or the name of a preset (``"paper-4way"``,
    ``"paper-fig10-pulses"``: :mod:`pneucore.description.presets`)."""
    if not isinstance(value, str):
        return value
    from pneucore.description.presets import MODEL_PRESETS, SCENARIO_PRESETS, model_preset, scenario_preset
    known, load = (MODEL_PRESETS, model_preset) if key == "model" else (SCENARIO_PRESETS, scenario_preset)
    if value not in known:
        raise FieldError(key, f"unknown {key} preset {value!r}; the presets are {sorted(known)}")
    return load(value)


@dataclass
class Study:
    """A robustness study (see the module docstring).

    Parameters
    ----------
    model : Model
        Nominal model
    scenario : Scenario
        Scenario run for every parameter set
    parameters : list of StudyParameter
        Varied parameters, sorted by path
    samples : int or None
        Draws per grid point (None for a grid-only study) [-]
    seed : int
        Seed of ``numpy.random.default_rng`` [-]
    metrics : list of str or None
        Metrics to compute (None = all of :data:`pneucore.study.metrics.METRICS`, or of
        :data:`pneucore.control.metrics.CONTROL_METRICS` for a closed-loop study)
    name, description : str
        Free text
    controller : dict or None
        A closed-loop study's controller (the scenario's ``controller``, as POST /api/simulate
        takes it: every run is that closed loop on the run's model,
        :func:`pneucore.control.closed_loop.simulate_closed_loop`, its metrics the loop's);
        None: open loop [-]
    """
    model: Model
    scenario: Scenario
    parameters: list
    samples: Optional[int] = None
    seed: int = 0
    metrics: Optional[list] = None
    name: str = ""
    description: str = ""
    controller: Optional[dict] = None
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    # -- derived sizes ----------------------------------------------------------------
    @property
    def grid_parameters(self):
        return [p for p in self.parameters if p.kind == "grid"]

    @property
    def random_parameters(self):
        return [p for p in self.parameters if p.kind != "grid"]

    @property
    def grid_shape(self):
        return tuple(len(p.grid) for p in self.grid_parameters)

    @property
    def n_grid(self):
        return int(np.prod(self.grid_shape, dtype=np.int64)) if self.grid_parameters else 1

    @property
    def n_runs(self):
        """Number of runs of the study."""
        return self.n_grid * (self.samples if self.random_parameters else 1)

    @property
    def paths(self):
        return [p.path for p in self.parameters]

    @property
    def design(self):
        """``factorial`` (grid only), ``monte_carlo`` (distributions only) or ``mixed``."""
        if not self.random_parameters:
            return "factorial"
        return "monte_carlo" if not self.grid_parameters else "mixed"

    @property
    def metric_names(self):
        return list(self.metrics) if self.metrics else list(self.metric_table)

    @property
    def metric_table(self):
        """The metrics this study can record: name -> ``(unit, definition)``
        (:data:`pneucore.study.metrics.METRICS` for an open-loop study, the closed loop's
        :data:`pneucore.control.metrics.CONTROL_METRICS` for one with a controller)."""
        return metric_table(self.controller is not None)

    # -- JSON -------------------------------------------------------------------------
    def to_dict(self):
        scenario = self.scenario.to_dict()
        if self.controller is not None:
            scenario["controller"] = self.controller
        d = {"model": self.model.to_dict(), "scenario": scenario,
             "parameters": {p.path: p.to_dict() for p in self.parameters},
             "samples": self.samples, "seed": self.seed, "metrics": self.metrics}
        for key in ("name", "description"):
            if getattr(self, key):
                d[key] = getattr(self, key)
        return d

    def to_json(self):
        """Canonical JSON text (keys sorted): what the store keeps and workers receive."""
        return json.dumps(self.to_dict(), sort_keys=True, allow_nan=False)

    @classmethod
    def from_json(cls, text):
        return cls.from_dict(json.loads(text))

    @classmethod
    def from_dict(cls, d):
        """Build and validate; raises :class:`FieldError` naming the field (``parameters.<path>...``)."""
        if isinstance(d, Study):
            return d
        mapping(d, "study")
        known_keys(d, ("model", "scenario", "parameters", "samples", "seed", "metrics", "name",
                       "description"), "")
        for key in ("model", "scenario", "parameters"):
            if key not in d:
                raise FieldError(key, "is required")
        try:
            model = Model.from_dict(_preset(d["model"], "model"))
        except FieldError as exc:
            raise FieldError(f"model.{exc.path}" if exc.path != "model" else "model", exc.detail) from None
        scen = _preset(d["scenario"], "scenario")
        controller = None
        if isinstance(scen, dict) and scen.get("controller") is not None:
            scen = dict(scen)
            controller = scen.pop("controller")
        scenario = Scenario.from_dict(scen, model)
        if controller is not None:
            from pneucore.control.closed_loop import parse_controller
            # checked against the nominal model (errors name scenario.controller.<field>)
            parse_controller(controller, model, scenario.duration)
            controller = json.loads(json.dumps(controller, allow_nan=False))
        params = _parse_parameters(model, d["parameters"])
        seed = _seed(d.get("seed", 0))
        samples = d.get("samples")
        study = cls(model, scenario, params, None, seed,
                    _parse_metrics(d.get("metrics"), controller is not None),
                    str(d.get("name", "")), str(d.get("description", "")), controller)
        n_grid = _factorial_size(study)
        if study.random_parameters:
            if samples is None:
                raise FieldError("samples", "is required when a parameter has a distribution")
            study.samples = integer(samples, "samples", low=1)
            if n_grid * study.samples > MAX_RUNS:
                raise FieldError("samples", f"{n_grid} grid point(s) x {study.samples} samples = "
                                            f"{n_grid * study.samples} runs; the limit is {MAX_RUNS}")
        elif samples is not None:
            s = integer(samples, "samples", low=1)
            if s != n_grid:
                raise FieldError("samples", f"a grid-only study runs its full factorial of {n_grid} "
                                            f"runs; leave samples null or set it to {n_grid}, got {s}")
        return study

    # -- parameter sets -----------------------------------------------------------------
    def values(self):
        """All parameter values, shape ``(n_runs, n_parameters)``, columns in :attr:`paths` order.

        Deterministic: a function of the definition only (cached on the object).
        """
        if "values" in self._cache:
            return self._cache["values"]
        n = self.n_runs
        out = np.empty((n, len(self.parameters)))
        reps = self.samples if self.random_parameters else 1
        grid_idx = np.arange(n) // reps
        if self.grid_parameters:
            multi = np.unravel_index(grid_idx, self.grid_shape)
        rnd = self.random_parameters
        u = np.random.default_rng(self.seed).random((n, len(rnd))) if rnd else None
        ig = ir = 0
        for j, p in enumerate(self.parameters):
            if p.kind == "grid":
                out[:, j] = np.asarray(p.grid, float)[multi[ig]]
                ig += 1
            else:
                out[:, j] = p.from_uniform(u[:, ir])
                ir += 1
        out.setflags(write=False)
        self._cache["values"] = out
        return out

    def run_values(self, index):
        """``{path: value}`` of run ``index``."""
        row = self.values()[index]
        return {p: float(v) for p, v in zip(self.paths, row)}

    def run_model(self, index):
        """The validated model of run ``index`` (raises FieldError if the values make it invalid)."""
        m = set_values(self.model, self.run_values(index))
        return Model.from_dict(m.to_dict())

    def copy(self):
        return copy.deepcopy(self)


def _seed(seed):
    if isinstance(seed, float) and seed.is_integer():
        seed = int(seed)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise FieldError("seed", f"must be a whole number, got {seed!r}")
    if not 0 <= seed < 2 ** 63:
        raise FieldError("seed", f"must be in [0, 2^63), got {seed}")
    return int(seed)


def _factorial_size(study):
    n = 1
    for p in study.grid_parameters:
        n *= len(p.grid)
        if n > MAX_RUNS:
            raise FieldError("parameters", f"the full factorial of the grids has more than {MAX_RUNS} "
                                           f"runs (the limit)")
    return n


def metric_table(closed_loop=False):
    """The metrics a study can record: name -> ``(unit, definition)``.

    Parameters
    ----------
    closed_loop : bool
        A closed-loop study's (:data:`pneucore.control.metrics.CONTROL_METRICS`: its
        ``overshoot`` [-] and ``settling_time`` [s] are the loop's, not the open-loop
        stroke's), else an open-loop one's (:data:`pneucore.study.metrics.METRICS`) [-]

    Returns
    -------
    table : dict
        ``{name: (unit, definition)}`` [-]
    """
    if closed_loop:
        from pneucore.control.metrics import CONTROL_METRICS
        return dict(CONTROL_METRICS)
    from pneucore.study.metrics import METRICS
    return {k: (m[0], m[1]) for k, m in METRICS.items()}


def _parse_metrics(metrics, closed_loop=False):
    METRICS = metric_table(closed_loop)
    if metrics is None:
        return None
    if not isinstance(metrics, (list, tuple)) or not metrics:
        raise FieldError("metrics", "must be null (all metrics) or a non-empty list of metric names")
    seen = []
    for i, m in enumerate(metrics):
        if not isinstance(m, str) or m not in METRICS:
            raise FieldError(f"metrics[{i}]", f"unknown metric {m!r}; expected one of {list(METRICS)}")
        if m in seen:
            raise FieldError(f"metrics[{i}]", f"metric {m!r} is listed twice")
        seen.append(m)
    return seen


def _parse_parameters(model, parameters):
    mapping(parameters, "parameters")
    if not parameters:
        raise FieldError("parameters", "give at least one parameter path to vary")
    out = []
    for path, spec in sorted(parameters.items(), key=lambda kv: str(kv[0])):
        where = f"parameters.{path}"
        if not isinstance(path, str) or not path:
            raise FieldError("parameters", f"parameter paths must be non-empty strings, got {path!r}")
        get_value(model, path)  # unknown path -> FieldError("parameters.<path>")
        mapping(spec, where)
        if "grid" in spec:
            known_keys(spec, ("grid",), where)
            grid = spec["grid"]
            if not isinstance(grid, (list, tuple)) or not grid:
                raise FieldError(f"{where}.grid", "must be a non-empty list of numbers")
            if len(grid) > MAX_GRID_VALUES:
                raise FieldError(f"{where}.grid", f"{len(grid)} values; the limit is {MAX_GRID_VALUES}")
            values = [number(v, f"{where}.grid[{i}]") for i, v in enumerate(grid)]
            for i, v in enumerate(values):
                _check_model_at(model, path, v, f"{where}.grid[{i}]")
            out.append(StudyParameter(path, "grid", grid=values))
            continue
        if "distribution" not in spec:
            names = " | ".join(f'"{n}"' for n in DISTRIBUTIONS)
            raise FieldError(where, f'give either {{"grid": [...]}} or {{"distribution": {names}, ...}}')
        kind = spec["distribution"]
        if not isinstance(kind, str) or kind not in DISTRIBUTIONS:
            raise FieldError(f"{where}.distribution",
                             f"unknown distribution {kind!r}; expected one of {list(DISTRIBUTIONS)}")
        dist = DISTRIBUTIONS[kind]
        req, opt = dist.required, dist.optional
        known_keys(spec, ("distribution",) + req + opt, where)
        vals = {}
        for k in req:
            if spec.get(k) is None:
                raise FieldError(f"{where}.{k}", f"is required for a {kind} distribution")
        for k in req + opt:
            kw = {"positive": True} if k in dist.positive else {}
            vals[k] = number(spec.get(k), f"{where}.{k}", allow_none=True, **kw)
        p = StudyParameter(path, kind, **vals)
        if p.min is not None and p.max is not None and not p.min < p.max:
            raise FieldError(where, f"min {p.min:g} must be below max {p.max:g}")
        mass = p.mass()
        if not mass >= MIN_MASS:
            bounds = f"[{_fmt(p.min, '-inf')}, {_fmt(p.max, 'inf')}]"
            raise FieldError(where, f"the bounds {bounds} exclude all the probability mass of this "
                                    f"{kind} distribution (kept {mass:.3g}; at least {MIN_MASS:g} "
                                    f"needed) - check the units")
        for k in ("min", "max"):
            v = getattr(p, k)
            if v is not None and dist.in_support(v):
                _check_model_at(model, path, v, f"{where}.{k}")
        out.append(p)
    return out


def _fmt(v, missing):
    return missing if v is None else f"{v:g}"


def _check_model_at(model, path, value, where):
    """The model must stay valid with ``path`` at ``value`` (others nominal)."""
    try:
        Model.from_dict(set_values(model, {path: value}).to_dict())
    except FieldError as exc:
        raise FieldError(where, f"the model is invalid with {path} = {value:g}: {exc}") from None
