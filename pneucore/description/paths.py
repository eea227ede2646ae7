"""Model parameters addressed by path (``heat.coefficient``, ``friction.extend.fc0``, ...).

Paths name numeric fields of :class:`pneucore.description.model.Model`:

* ``jack.<field>``, ``supply.pressure``, ``ambient.temperature``, ``heat.coefficient`` and the
  other parameters of the model's heat model (``heat.natural_multiplier``, ... :mod:`pneucore.physics.heat`),
  ``friction.extend.fc0`` ... ``friction.retract.kv_b``, ``gas.r``, ``gas.gamma``;
  ``friction.*.<field>`` (:data:`BOTH_DIRECTIONS`) is a level of both directions at once: it
  reads the extend value and writes both (a catalogue level off by the same amount extending
  and retracting is one recalibration, not a difference between the directions);
* ``effects.<name>.<parameter>`` for a catalog effect (added with its defaults if absent);
* ``valve.ports.<edge>.C`` and ``valve.ports.<edge>.b``: a *scale factor* on the
  whole table (1 = as given); ``valve.ports.*.C`` scales every edge together, and an
  edge group is named by a pattern on the edge names (``fnmatch``): ``valve.ports.P-*.C``
  scales the supply edges (P-A, P-B), ``valve.ports.*-R.C`` the exhaust edges (A-R, B-R)
  (:data:`VALVE_GROUPS`).
"""
from __future__ import annotations

import fnmatch
from dataclasses import dataclass

from pneucore.description.effects import EFFECTS
from pneucore.physics.heat import HEAT_PARAMETERS
from pneucore.description.validation import FieldError, number

_SECTIONS = {"jack", "supply", "ambient", "heat", "friction", "gas"}

#: Named edge groups of a valve (patterns on the edge names of
#: :data:`pneucore.description.model.VALVE_KINDS`): the edges from the supply P, and the edges to
#: the exhaust R
VALVE_GROUPS = {"supply": "P-*", "exhaust": "*-R"}


#: The direction of a friction path that names both directions at once (``friction.*.fc0``)
BOTH_DIRECTIONS = "*"


def both_directions(path):
    """``(extend path, retract path)`` of a ``friction.*.<field>`` path, else None."""
    parts = path.split(".")
    if len(parts) == 3 and parts[0] == "friction" and parts[1] == BOTH_DIRECTIONS:
        return f"friction.extend.{parts[2]}", f"friction.retract.{parts[2]}"
    return None


def valve_edges(model, pattern):
    """Edges of ``model``'s valve matched by ``pattern`` (an edge name, ``*`` or a glob)."""
    return [e for e in model.valve.ports if e == pattern or fnmatch.fnmatchcase(e, pattern)]


@dataclass
class ParameterSpec:
    """A parameter to fit (lmfit style): value, bounds, vary flag.

    Parameters
    ----------
    path : str
        Model path
    value : float
        Starting value (SI; a scale factor for valve tables)
    min, max : float
        Bounds
    vary : bool
        Fit it (False = hold at ``value``)
    unit : str
        Unit, for reports
    """
    path: str
    value: float
    min: float
    max: float
    vary: bool = True
    unit: str = ""

    def to_dict(self):
        return {"path": self.path, "value": self.value, "min": self.min, "max": self.max,
                "vary": self.vary, "unit": self.unit}


def unit_of(path):
    """Unit of the parameter at ``path`` (``""`` when unknown)."""
    return _unit(path)


def _unit(path):
    units = {"bore": "m", "rod_a": "m", "rod_b": "m", "stroke": "m", "dead_volume_a": "m^3",
             "dead_volume_b": "m^3", "moving_mass": "kg", "load_force": "N", "wall_area_a": "m^2",
             "wall_area_b": "m^2", "mounting_angle": "deg", "pressure": "Pa", "temperature": "K", "coefficient": "W/(m^2 K)",
             "fc0": "N", "fc_a": "N/Pa", "fc_b": "N/Pa", "kv0": "N s/m", "kv_a": "N s/(m Pa)",
             "kv_b": "N s/(m Pa)", "r": "J/(kg K)", "gamma": "-"}
    parts = path.split(".")
    if parts[0] == "effects" and len(parts) == 3 and parts[1] in EFFECTS:
        try:
            return EFFECTS[parts[1]].param(parts[2]).unit
        except KeyError:
            return ""
    if parts[0] == "valve":
        return "-"
    if parts[0] == "heat" and len(parts) == 2 and parts[1] in HEAT_PARAMETERS:
        return HEAT_PARAMETERS[parts[1]].unit
    return units.get(parts[-1], "")


def get_value(model, path):
    """Current value of ``path`` on ``model`` (1.0 for valve scale factors)."""
    parts = path.split(".")
    if parts[0] == "valve":
        _check_valve_path(model, path)
        return 1.0
    both = both_directions(path)
    if both:
        # the level both directions share: the extend value (written to both by set_values)
        return get_value(model, both[0])
    if parts[0] == "effects":
        if len(parts) != 3 or parts[1] not in EFFECTS:
            raise FieldError(f"parameters.{path}", f"unknown effect; the catalog has {sorted(EFFECTS)}")
        eff = EFFECTS[parts[1]]
        try:
            p = eff.param(parts[2])
        except KeyError:
            raise FieldError(f"parameters.{path}", f"unknown parameter of {parts[1]}; expected one of "
                                                   f"{[q.name for q in eff.parameters]}") from None
        return float(model.effects.get(parts[1], {}).get(parts[2], p.default))
    if parts[0] == "heat" and len(parts) == 2 and parts[1] in HEAT_PARAMETERS \
            and parts[1] != "coefficient" and parts[1] not in model.heat.spec.parameters:
        raise FieldError(f"parameters.{path}",
                         f"not a parameter of heat model {model.heat.model!r}; it has "
                         f"{list(model.heat.spec.parameters)}")
    if parts[0] not in _SECTIONS:
        raise FieldError(f"parameters.{path}", f"unknown parameter path; paths start with one of "
                                               f"{sorted(_SECTIONS | {'effects', 'valve'})}")
    obj = model
    for i, k in enumerate(parts):
        # only declared dataclass fields: properties (jack.area_a) and attributes of a
        # number (supply.pressure.real) are not parameters and cannot be set
        fields = getattr(obj, "__dataclass_fields__", None)
        if i == 1 and parts[0] == "heat":
            fields = HEAT_PARAMETERS   # the heat registry declares the heat parameters
        if fields is None or k not in fields:
            where = ".".join(parts[:i]) or "model"
            hint = f"; {where} has {sorted(fields)}" if fields else f"; {where} is a number"
            raise FieldError(f"parameters.{path}", f"unknown parameter path{hint}")
        obj = getattr(obj, k)
    if obj is None or isinstance(obj, bool) or not isinstance(obj, (int, float)):
        raise FieldError(f"parameters.{path}", "is not a numeric parameter"
                         + (" (it is null: give a value in the model first)" if obj is None else ""))
    return float(obj)


def _check_valve_path(model, path):
    parts = path.split(".")
    if len(parts) != 4 or parts[1] != "ports" or parts[3] not in ("C", "b"):
        raise FieldError(f"parameters.{path}", "valve paths are valve.ports.<edge>.C or .b (scale factors)")
    if not valve_edges(model, parts[2]):
        raise FieldError(f"parameters.{path}", f"no edge of this valve matches {parts[2]!r}; it has "
                                               f"{sorted(model.valve.ports)} (or a group such as "
                                               f"{', '.join(VALVE_GROUPS.values())})")


def set_values(model, values, copy=True):
    """``model`` with ``{path: value}`` applied (valve entries scale the tables).

    ``copy=False`` edits ``model`` in place (for callers that own a fresh copy).
    """
    m = model.copy() if copy else model
    # base paths that an effect of the model keeps equal to others (:attr:`Effect.ties`)
    ties = {}
    for name in m.effects:
        for src, dst in getattr(EFFECTS.get(name), "ties", {}).items():
            ties.setdefault(src, []).extend(dst)
    for path, v in list(values.items()):
        both = both_directions(path)
        if both:
            values = {**{k: w for k, w in values.items() if k != path},
                      **{q: v for q in both if q not in values}}
    for path, v in values.items():
        for q in ties.get(path, ()):
            if q not in values:
                values = {**values, q: v}
    for path, v in values.items():
        parts = path.split(".")
        if parts[0] == "valve":
            for e in valve_edges(m, parts[2]):
                port = m.valve.ports[e]
                if parts[3] == "C":
                    port.C = [c * v for c in port.C]
                else:
                    port.b = [min(b * v, 0.999) for b in port.b]
        elif parts[0] == "effects":
            eff = m.effects.setdefault(parts[1], EFFECTS[parts[1]].defaults())
            eff[parts[2]] = float(v)
        else:
            obj = m
            for k in parts[:-1]:
                obj = getattr(obj, k)
            setattr(obj, parts[-1], float(v))
    return m


def parse_parameters(model, parameters):
    """Turn ``{path: {"min", "max", "value"?, "vary"?}}`` (or a list of paths) into specs.

    Missing bounds come from the effect catalog, or default to a factor 10
    around the current value (and 0 for non-negative quantities).
    """
    if isinstance(parameters, (list, tuple)):
        parameters = {p: {} for p in parameters}
    if not isinstance(parameters, dict) or not parameters:
        raise FieldError("parameters", "give at least one parameter path to fit")
    specs = []
    for path, opts in parameters.items():
        opts = opts or {}
        if not isinstance(opts, dict):
            raise FieldError(f"parameters.{path}", "must be an object with min/max/value/vary")
        value = get_value(model, path)
        lo, hi = _default_bounds(model, path, value)
        lo = number(opts.get("min", lo), f"parameters.{path}.min")
        hi = number(opts.get("max", hi), f"parameters.{path}.max")
        value = number(opts.get("value", value), f"parameters.{path}.value")
        if not lo < hi:
            raise FieldError(f"parameters.{path}", f"min {lo:g} must be below max {hi:g}")
        if not lo <= value <= hi:
            # a starting value outside its bounds is a unit mix-up (physical bounds on a scale
            # factor): starting the fit at the bound would answer a model far from the user's
            unit = _unit(path) or "-"
            what = "the starting value" if "value" in opts else "the model's current value"
            scale = " (a scale factor on the valve table: 1 is the model as given)" \
                if path.startswith("valve.") else ""
            raise FieldError(f"parameters.{path}",
                             f"bounds [{lo:g}, {hi:g}] {unit} exclude {what} {value:g} {unit}"
                             f"{scale}")
        vary = opts.get("vary", True)
        if not isinstance(vary, bool):
            raise FieldError(f"parameters.{path}.vary", "must be true or false")
        parts = path.split(".")
        if vary and parts[0] == "effects" and EFFECTS[parts[1]].param(parts[2]).integer:
            raise FieldError(f"parameters.{path}",
                             f"a whole number that shapes the model, not a parameter to fit: "
                             f"set it in the model [{_unit(path) or '-'}]")
        specs.append(ParameterSpec(path, value, lo, hi, vary, _unit(path)))
    return specs


#: Fields the model validation requires to be > 0 (default calibration bounds keep them so)
_STRICTLY_POSITIVE = {"bore", "stroke", "dead_volume_a", "dead_volume_b", "moving_mass", "wall_area_a",
                      "wall_area_b", "pressure", "temperature", "r"}


def _default_bounds(model, path, value):
    parts = path.split(".")
    if parts[0] == "effects":
        p = EFFECTS[parts[1]].param(parts[2])
        return p.min, p.max
    if parts[0] == "valve":
        return (0.1, 10.0) if parts[3] == "C" else (0.5, 1.5)
    if parts[0] == "heat" and parts[-1] in HEAT_PARAMETERS and parts[-1] != "coefficient":
        # heat-model parameters carry their bounds (heat.coefficient keeps the factor-10 rule)
        return HEAT_PARAMETERS[parts[-1]].min, HEAT_PARAMETERS[parts[-1]].max
    if parts[-1] == "gamma":
        return 1.01, 2.0
    if value > 0 and parts[-1] in _STRICTLY_POSITIVE:
        return value / 10.0, value * 10.0   # the model rejects zero for these
    if value > 0:
        return 0.0, value * 10.0
    if value == 0:
        return -1.0, 1.0
    return value * 10.0, -value * 10.0


def _leaves(d, prefix=""):
    """The leaves of a model's JSON as ``path -> value`` (numbers, strings, None); a list of
    numbers (a valve table's column, a command) is one leaf."""
    out = {}
    if isinstance(d, dict):
        for k, v in d.items():
            out.update(_leaves(v, f"{prefix}.{k}" if prefix else str(k)))
    else:
        out[prefix] = d
    return out


def model_changes(before, after):
    """What changes from one model to another, parameter by parameter, with units.

    What a finding would do to the user's model, listed before it is applied (issue 24):
    every number that moves (a base parameter the diagnosis recalibrated along with the
    effect it names, too), an effect added or removed, a valve table scaled.

    Parameters
    ----------
    before : Model or dict
        The model as it is (a dict is validated, its defaults filled) [-]
    after : Model or dict
        The model proposed [-]

    Returns
    -------
    changes : list of dict
        ``{"path", "before", "after", "unit", "kind"}`` each, ``kind`` one of ``changed``,
        ``added`` (an effect or a field), ``removed``, ``scaled`` (a valve edge's C or b
        table multiplied by ``after`` with ``before`` = 1); values in SI (the unit) [-]

    Examples
    --------
    >>> from pneucore import model_preset
    >>> a = model_preset("paper-4way"); b = model_preset("paper-4way")
    >>> b["heat"]["coefficient"] = 35.0
    >>> b["effects"]["piston_leakage"] = {"conductance": 8e-11}
    >>> [(c["path"], c["before"], c["after"], c["kind"]) for c in model_changes(a, b)]
    [('effects.piston_leakage', None, 'added', 'added'), ('heat.coefficient', 25.0, 35.0, 'changed'), ('effects.piston_leakage.conductance', None, 8e-11, 'added')]
    """
    from pneucore.description.model import Model   # a dict is read as the API reads it (defaults filled)
    a, b = ((m if isinstance(m, Model) else Model.from_dict(m)).to_dict() for m in (before, after))
    la, lb = _leaves(a), _leaves(b)
    out = []
    for name in sorted(set(b.get("effects") or {}) - set(a.get("effects") or {})):
        out.append({"path": f"effects.{name}", "before": None, "after": "added", "unit": "",
                    "kind": "added"})
    for name in sorted(set(a.get("effects") or {}) - set(b.get("effects") or {})):
        out.append({"path": f"effects.{name}", "before": "present", "after": None, "unit": "",
                    "kind": "removed"})
    for path in list(la) + [p for p in lb if p not in la]:
        va, vb = la.get(path), lb.get(path)
        if va == vb or path in ("name", "description", "notes"):
            continue
        parts = path.split(".")
        if parts[0] == "valve" and len(parts) == 4 and parts[3] in ("C", "b") \
                and isinstance(va, list) and isinstance(vb, list) and len(va) == len(vb):
            ratios = {round(y / x, 9) for x, y in zip(va, vb) if x}
            if len(ratios) == 1 and all((x == 0) == (y == 0) for x, y in zip(va, vb)):
                out.append({"path": path, "before": 1.0, "after": ratios.pop(), "unit": "-",
                            "kind": "scaled"})
                continue
        kind = "added" if path not in la else "removed" if path not in lb else "changed"
        out.append({"path": path, "before": va, "after": vb, "unit": _unit(path), "kind": kind})
    return out
