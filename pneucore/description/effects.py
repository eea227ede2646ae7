"""Catalog of switchable physical effects, as a registry of names.

An effect is added to a model by name: ``model.effects["piston_leakage"] =
{"conductance": 5e-11}``. Each effect has named parameters (unit, default,
bounds), a one-line physical description, the residual signature it
explains and a reference. It acts in one or both of two ways, never by
editing the base equations:

* ``transform(model, params)`` rewrites base parameters on a copy of the
  model (e.g. ``dead_volume`` adds tubing volume to the jack's dead volumes);
* ``pack(params, build)`` writes its own slots of the compiled core's
  parameter vector and declares its own states (e.g. ``valve_spool_dynamics``
  adds the effective spool opening as a state);
* ``series(params, model)`` puts fixed restrictions in series with the valve's
  edges, with no volume between them (a flow control in a port, a silencer on
  an exhaust): ``{edge: (upstream, downstream)}``, lists of ``(C, b)``. The
  restrictions of every such effect in the model are combined with each edge
  table once, by ISO 6358-3 (:mod:`pneucore.physics.series`).

An effect may also give ``check(params, model, path)``, raising a
:class:`~pneucore.description.validation.FieldError` for parameters this model
cannot take (a throttle on a port the valve does not have).

With its parameters at their ``off`` values every effect reproduces the base
model exactly. Users register their own with :func:`register_effect`, giving
a compiled ``terms`` hook (see :func:`pneucore.core.rhs.no_terms`) that adds
mass, enthalpy and heat flows to the chambers and a force on the piston.
"""
from __future__ import annotations

import copy
import functools
import math
from dataclasses import dataclass, field
from typing import Callable, Optional

from pneucore.core import layout as L
from pneucore.physics.flow_control import (METER_IN, METER_OUT, NODE_STATES, PORT_NODE,
                                           node_slots)
from pneucore.physics.heat import HEAT_PARAMETERS, add_wall
from pneucore.physics.line import LUMPED_MARGIN, delay_cells, line_regime, sound_speed
from pneucore.physics.sensors import PRESSURE_SENSOR
from pneucore.physics.series import combine_table
from pneucore.physics.tube import (LINE_STATES, MAX_SEGMENTS, SEGMENTED_LINE, line_slots,
                                   line_volume, tube_characteristic)
from pneucore.description.validation import FieldError, mapping, number, optional_mapping


@dataclass
class Parameter:
    """A named effect parameter.

    Parameters
    ----------
    name : str
        Parameter name
    unit : str
        SI unit
    default : float
        Value used when the user gives none
    min, max : float
        Bounds for validation and calibration
    off : float or None
        Value at which the effect vanishes (base model)
    description : str
        One line
    integer : bool
        A whole number (a count that shapes the model, e.g. a line's segments): refused
        otherwise, and never fitted
    """
    name: str
    unit: str
    default: float
    min: float
    max: float
    off: Optional[float] = 0.0
    description: str = ""
    integer: bool = False

    def to_dict(self):
        return {"name": self.name, "unit": self.unit, "default": self.default, "min": self.min,
                "max": self.max, "off": self.off, "description": self.description,
                "integer": self.integer}


@dataclass
class Effect:
    """A switchable physical extension of the base model (see module docstring)."""
    name: str
    description: str
    signature: str
    reference: str
    parameters: list
    strength: str = ""
    transform: Optional[Callable] = None
    pack: Optional[Callable] = None
    applies: Optional[Callable] = None
    terms: Optional[Callable] = None
    states: tuple = ()
    state_units: tuple = ()
    user: bool = False
    observable_in: tuple = ("locked", "free")
    fit_params: tuple = ()
    probe: dict = field(default_factory=dict)
    #: ``{base path: (paths that follow it, ...)}`` while the effect is in a model: a base
    #: parameter the effect's applicability keeps equal to another (quadrant friction keeps the
    #: base retract set equal to the extend set; the effect carries their difference), so that
    #: a recalibration of one never produces a model the effect cannot be part of
    ties: dict = field(default_factory=dict)
    #: ``series(params, model) -> {edge: (upstream, downstream)}``: fixed restrictions in
    #: series with the valve's edges (see the module docstring)
    series: Optional[Callable] = None
    #: ``check(params, model, path)``: raises a FieldError for parameters this model cannot take
    check: Optional[Callable] = None
    #: ``unused(model) -> names``: parameters this model has no place for (a port the valve does
    #: not drive); a candidate built for it holds them off and the diagnosis does not fit them,
    #: so it never proposes a model ``check`` refuses
    unused: Optional[Callable] = None
    #: ``warn(params, model, time_scale) -> [message, ...]``: where the effect's model is not
    #: adequate for a command that changes on ``time_scale`` [s] (:func:`effect_warnings`)
    warn: Optional[Callable] = None
    #: ``fit_max(model) -> {parameter: upper bound}``: tighter upper bounds a fit on ``model``
    #: keeps to, where ``check`` ties a parameter to the model (a cushion within the stroke),
    #: so that a fit never ends on a model ``check`` refuses
    fit_max: Optional[Callable] = None
    #: ``forms(values, model, sample_period) -> [overrides, ...]``: structural variants of the
    #: effect besides its default (parameters that shape the model and are not fitted, e.g. a
    #: line's segments), for records sampled every ``sample_period`` [s]; the diagnosis tries
    #: each and keeps the one the data favour (:meth:`forms_for`)
    forms: Optional[Callable] = None
    #: ``form_min(form, model, sample_period) -> {parameter: lower bound}``: tighter lower
    #: bounds a fit keeps to in a structural form of :attr:`forms` (a line in segments no
    #: shorter than a sample's delay: shorter, the lumped form is the one)
    form_min: Optional[Callable] = None
    #: ``form_finer(new, old) -> bool``: does structural form ``new`` resolve more than ``old``
    #: (a line in more segments)? A fit whose values call for a coarser form is not fitted
    #: again in it: the finer form it has is at least as accurate, and the default form is
    #: fitted beside it anyway (:meth:`needs_refit_in`); None = every other form is refitted
    form_finer: Optional[Callable] = None
    #: Catalog effects this one becomes in a limit of its parameters (a line whose resistance
    #: vanishes is a dead volume): the simpler physics, named instead where the records cannot
    #: tell the two apart (:func:`pneucore.analysis.diagnosis.rules.simpler`)
    reduces_to: tuple = ()
    #: Catalog effects whose change in the records this one's resembles at the score pass's
    #: dose, while a fit tells them apart (a valve's switching delay and a line's transport delay
    #: L / c: both start each pressure change later; only the line also fills its volume
    #: through its resistance). The score pass, linear at the probes' doses, may rank this one
    #: ahead and push them out of the refits; before this one is named, they are fitted on the
    #: same records and every candidate is judged again
    #: (:func:`pneucore.analysis.diagnosis.rules.unfitted_resemblances`), so the evidence of
    #: both decides
    resembles: tuple = ()
    #: Parameters held at their defaults while the effect is sought (a strength and a shape
    #: fitted together on records that barely separate them wander) and refitted with its
    #: diagnosis parameters once it is in the model (a supply line's volume: the rounds after
    #: the regulator's conductance was named bring the model to the noise floor)
    refit_params: tuple = ()
    #: ``refit_only(values) -> names``: of :attr:`refit_params`, those to refit at the effect's
    #: values in the model (a flow control's volume only where its node is there: a volume 0
    #: is the series form, which the diagnosis named; refitted from 0 it would grow a node the
    #: records did not ask for); None = all of them
    refit_only: Optional[Callable] = None
    #: ``base_change(params, model) -> {base path: value}``: for an effect that is nothing but
    #: a difference of the model's own base parameters (the quadrant effect: the retract set
    #: minus the extend set), the base values it amounts to on ``model``; where they lie within
    #: a catalogue error of the user's values, the diagnosis reports a recalibration, not the
    #: effect (:func:`pneucore.analysis.diagnosis.stages.as_recalibration`)
    base_change: Optional[Callable] = None

    def refit_in(self, values):
        """The :attr:`refit_params` refitted once the effect is in a model at ``values``."""
        if self.refit_only is None:
            return tuple(self.refit_params)
        return tuple(self.refit_only(values))

    def needs_refit_in(self, new, old):
        """Must a fit in structural form ``old`` whose values call for form ``new`` (both
        overrides, :meth:`forms_for`) be fitted again in ``new``? Only where ``new`` is finer
        (:attr:`form_finer`), or where the effect orders no forms."""
        return self.form_finer is None or bool(self.form_finer(new, old))

    def fit_bounds(self, name, model):
        """Bounds ``(min, max)`` of parameter ``name`` in a fit on ``model`` (SI): the
        parameter's own, the upper one tightened by :attr:`fit_max`."""
        par = self.param(name)
        hi = (self.fit_max(model) if self.fit_max is not None else {}).get(name, par.max)
        return par.min, min(par.max, hi)

    def forms_for(self, values, model, sample_period):
        """The structural forms to try at parameter ``values``: ``[{}]`` (the values as they
        are) followed by the overrides :attr:`forms` gives for records sampled every
        ``sample_period`` [s]."""
        extra = self.forms(values, model, sample_period) if self.forms is not None else []
        return [{}] + [f for f in extra if f]

    def form_bounds(self, name, model, form, sample_period):
        """:meth:`fit_bounds` of parameter ``name`` in structural form ``form`` (overrides,
        :meth:`forms_for`) for records sampled every ``sample_period`` [s]: the lower bound
        raised by :attr:`form_min`."""
        lo, hi = self.fit_bounds(name, model)
        if form and self.form_min is not None:
            lo = max(lo, self.form_min(form, model, sample_period).get(name, lo))
        return lo, hi

    def unused_in(self, model):
        """Parameters ``model`` has no place for (held at their ``off`` value)."""
        return tuple(self.unused(model)) if self.unused is not None else ()

    @property
    def diagnosis_params(self):
        """Parameters the diagnosis refits (all parameters unless ``fit_params`` says otherwise)."""
        return tuple(self.fit_params) or tuple(p.name for p in self.parameters)

    @property
    def score_params(self):
        """Parameters that carry the effect's strength (they have an ``off`` value)."""
        return tuple(n for n in self.diagnosis_params if self.param(n).off is not None)

    def probe_values(self, model=None):
        """A moderate strength used to probe the outputs' sensitivity to the effect; with a
        ``model``, the parameters it has no place for held off (:meth:`unused_in`)."""
        vals = self.defaults()
        vals.update(self.probe)
        if model is not None:
            for name in self.unused_in(model):
                vals[name] = self.param(name).off
        return vals

    def param(self, name):
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    def defaults(self, model=None):
        return {p.name: p.default for p in self.parameters}

    def applicable(self, model):
        """``(True, "")`` when the effect can be added to ``model``, else ``(False, reason)``."""
        if self.applies is None:
            return True, ""
        return self.applies(model)

    def to_dict(self):
        return {"name": self.name, "description": self.description, "signature": self.signature,
                "reference": self.reference, "strength": self.strength,
                "parameters": [p.to_dict() for p in self.parameters],
                "fit_params": list(self.diagnosis_params), "states": list(self.states),
                "user": self.user, "observable_in": list(self.observable_in)}


class CoreBuild:
    """What effects write into while the compiled core's inputs are assembled.

    ``prm`` is the parameter vector (``layout.P_*`` slots), ``iy`` the
    optional state positions, and ``states`` the list of extra states as
    ``(name, initial value, absolute tolerance)``.
    """

    def __init__(self, prm, iy, model, y_base):
        self.prm = prm
        self.iy = iy
        self.model = model
        self.y_base = y_base
        self.states = []

    def add_state(self, name, y0, atol):
        """Append a state; returns its index in the full state vector."""
        self.states.append((name, float(y0), float(atol)))
        return L.N_BASE_STATES + len(self.states) - 1

    def add_term(self, term, values):
        """Switch a state term on (:mod:`pneucore.physics.states`): its parameters into the
        slots its registry assigned, its two states (chamber A's, then B's) appended.

        Parameters
        ----------
        term : pneucore.physics.states.StateTerm
            The registered term
        values : tuple of float
            Its parameters, in the order of ``term.parameters`` (SI units)
        """
        k0 = L.STATE_PRM0[term.name]
        for k, value in enumerate(values):
            self.prm[k0 + k] = value
        b = self.y_base
        starts = term.start(b["p_a"], b["p_b"], b["T_a"], b["T_b"], self.model.ambient.temperature,
                            self.model.supply.pressure)
        i0 = L.STATE_IY0[term.name]
        for k, (name, (y0, atol)) in enumerate(zip(term.states, starts)):
            self.iy[i0 + k] = self.add_state(name, y0, atol)


EFFECTS: dict = {}


def register_effect(effect: Effect, replace=False):
    """Add an effect to the catalog (a user effect needs no change to the package).

    Parameters
    ----------
    effect : Effect
        The effect; a user effect gives ``terms``, a numba-compiled
        function ``terms(t, y, sig, p, out, dy, i0)`` where ``p`` is its own
        parameter vector (in the order of ``effect.parameters``), ``i0`` the
        index of its first state in ``y`` / ``dy``, ``sig`` the signals named
        by ``layout.SIG_NAMES`` and ``out`` the terms named by
        ``layout.TERM_NAMES`` (add to them).
    replace : bool
        Allow replacing an existing name
    """
    if effect.name in EFFECTS and not replace:
        raise ValueError(f"effect {effect.name!r} is already registered")
    if effect.terms is not None:
        effect.user = True
    EFFECTS[effect.name] = effect
    return effect


def unregister_effect(name):
    """Remove a user effect from the catalog."""
    EFFECTS.pop(name, None)


def validate_effects(effects, model):
    """Check names and parameters of ``model.effects``; fill defaults. Returns a new dict."""
    mapping(effects, "effects")
    out = {}
    for name, params in effects.items():
        path = f"effects.{name}"
        if name not in EFFECTS:
            raise FieldError(path, f"unknown effect; the catalog has {sorted(EFFECTS)}")
        eff = EFFECTS[name]
        params = optional_mapping(params, path)
        known = {p.name for p in eff.parameters}
        for key in params:
            if key not in known:
                raise FieldError(f"{path}.{key}", f"unknown parameter; expected one of {sorted(known)}")
        vals = {}
        for p in eff.parameters:
            v = params.get(p.name, p.default)
            try:
                vals[p.name] = number(v, f"{path}.{p.name}", low=p.min, high=p.max)
            except FieldError as e:
                raise FieldError(e.path, f"{e.detail} [{p.unit}]") from None
            if p.integer and vals[p.name] != int(vals[p.name]):
                raise FieldError(f"{path}.{p.name}",
                                 f"a whole number from {p.min:g} to {p.max:g}, got "
                                 f"{vals[p.name]:g} [{p.unit}]")
        ok, why = eff.applicable(model)
        if not ok:
            raise FieldError(path, f"cannot be added to this model: {why}")
        if eff.check is not None:
            eff.check(vals, model, path)
        out[name] = vals
    return out


def effective_model(model):
    """The model with every effect's ``transform`` applied (base parameters rewritten).

    Returns ``model`` itself (not a copy) when no effect transforms it.
    """
    if not any(EFFECTS[name].transform is not None or EFFECTS[name].series is not None
               for name in model.effects):
        return model
    m = model.copy()
    chains = {}
    for name, params in model.effects.items():
        eff = EFFECTS[name]
        if eff.transform is not None:
            eff.transform(m, params)
        if eff.series is not None:
            for edge, (up, down) in eff.series(params, model).items():
                u, d = chains.setdefault(edge, ([], []))
                u.extend(up)
                d.extend(down)
    for edge, (up, down) in chains.items():
        port = m.valve.ports.get(edge)
        if port is None or not (up or down):
            continue
        C, b, mm = _combined(tuple(port.C), tuple(port.b), None if port.m is None else tuple(port.m),
                             tuple(up), tuple(down))
        port.C, port.b, port.m = list(C), list(b), list(mm)
    return m


@functools.lru_cache(maxsize=4096)
def _combined(C, b, m, up, down):
    """:func:`pneucore.physics.series.combine_table`, memoised (a fit simulates the same
    circuit many times)."""
    return tuple(map(tuple, combine_table(C, b, m, up, down)))


# ---------------------------------------------------------------------------
# built-in catalog
# ---------------------------------------------------------------------------

def _heat_transform(m, p):
    if m.heat.model in ("isothermal", "adiabatic"):
        m.heat.model = "convective"
        m.heat.coefficient = p["h"]


def _heat_applies(m):
    if m.heat.model not in ("isothermal", "adiabatic"):
        return False, f"the model already exchanges heat with its walls ({m.heat.model})"
    return True, ""


def _exchanging(m, term):
    """``(ok, why)``: a heat-model term can be added unless the model's heat model has it."""
    if getattr(m.heat.spec, term):
        return False, f"the model's heat model ({m.heat.model}) already has it"
    return True, ""


def _free_gas_transform(m, p):
    # on an isothermal model the term becomes the exchange (as heat_exchange does)
    if m.heat.model == "isothermal":
        m.heat.model = "adiabatic"


def _pack_natural(p, build):
    build.prm[L.P_HEAT_NAT] = p["multiplier"]


def _pack_jet(p, build):
    build.prm[L.P_HEAT_JET] = p["multiplier"]
    build.prm[L.P_HEAT_D_IN] = p["inlet_diameter"]


def _wall_applies(m):
    if m.heat.model == "isothermal":
        return False, "the gas is held at the wall temperature (isothermal): no wall state to add"
    if m.heat.wall_mass > 0.0:
        return False, "the model's walls already have a thermal capacity (heat.wall_mass)"
    return True, ""


def _pack_wall(p, build):
    if p["mass"] > 0.0:
        add_wall(build, p["mass"], p["specific_heat"], p["outer_coefficient"])


def _pack_slot(slot, key):
    def pack(p, build):
        build.prm[L.PRM_INDEX[slot]] = p[key]
    return pack


def _pack_ext_leak(p, build):
    build.prm[L.P_G_A] = p["conductance_a"]
    build.prm[L.P_G_B] = p["conductance_b"]


def _pack_spool(p, build):
    wn = p["natural_frequency"]
    tau = p["time_constant"]
    u0 = build.y_base["u0"]
    if wn > 0.0:
        build.prm[L.P_SPOOL_WN] = wn
        build.prm[L.P_SPOOL_ZETA] = p["damping"]
        build.iy[L.IY_SPOOL] = build.add_state("u_spool", u0, 1e-6)
        build.iy[L.IY_SPOOL_RATE] = build.add_state("u_spool_rate", 0.0, 1e-3)
    elif tau > 0.0:
        build.prm[L.P_SPOOL_TAU] = tau
        build.iy[L.IY_SPOOL] = build.add_state("u_spool", u0, 1e-6)


def _pack_null_leak(p, build):
    build.prm[L.P_NULL_LEAK] = p["fraction"]


def _pack_stribeck(p, build):
    build.prm[L.P_STRIBECK_RATIO] = p["static_ratio"]
    build.prm[L.P_STRIBECK_V] = p["stribeck_velocity"]


def _pdf_transform(m, p):
    for s in (m.friction.extend, m.friction.retract):
        s.fc_a += p["fc_a"]
        s.fc_b += p["fc_b"]
        s.kv_a += p["kv_a"]
        s.kv_b += p["kv_b"]


def _pdf_applies(m):
    for s in (m.friction.extend, m.friction.retract):
        if any(getattr(s, k) != 0.0 for k in ("fc_a", "fc_b", "kv_a", "kv_b")):
            return False, "the model's friction already depends on pressure"
    return True, ""


_FRICTION_KEYS = ("fc0", "fc_a", "fc_b", "kv0", "kv_a", "kv_b")


def _quadrant_transform(m, p):
    for k in _FRICTION_KEYS:
        v = p[k]
        setattr(m.friction.retract, k, getattr(m.friction.extend, k) + v)


def _switching_transform(m, p):
    # the valve's catalogue switching times (ISO 12238), lengthened by the delay found
    m.valve = copy.copy(m.valve)
    m.valve.on_time = m.valve.on_time + p["on_time"]
    m.valve.off_time = m.valve.off_time + p["off_time"]


def _switching_unused(model):
    # a valve without a rest position (a proportional spool, a bistable valve) takes on_time
    # for every change (physics.valve.switched_command): off_time acts on nothing
    return ("off_time",) if model.valve.rest_opening is None else ()


def _quadrant_base_change(p, m):
    # the retract values the difference gives on top of the extend set (those it moves)
    return {f"friction.retract.{k}": getattr(m.friction.extend, k) + p[k]
            for k in _FRICTION_KEYS if p.get(k, 0.0) != 0.0}


def _quadrant_applies(m):
    if m.friction.extend.to_dict() != m.friction.retract.to_dict():
        return False, "the model already has separate extend and retract friction"
    return True, ""


def _static_b(*names):
    """``unused`` of an effect on chamber B: its ``names`` where chamber B holds no gas of its
    own (a 3/2 valve's B held at a pressure or vented: ``B_CHAMBER_MODES``, not dynamic), so
    that they act on nothing and a fit would leave them wherever it starts or wanders (a dead
    volume on a held B fitted at 202 cm^3, beyond the chamber, then called impossible)."""
    def unused(model):
        from pneucore.description.model import B_CHAMBER_MODES
        v = model.valve
        if v.kind == "3/2" and not B_CHAMBER_MODES[v.b_chamber]["dynamic"]:
            return names
        return ()
    return unused


def _dead_transform(m, p):
    m.jack.dead_volume_a += p["volume_a"]
    m.jack.dead_volume_b += p["volume_b"]


def _pack_supply(p, build):
    m = build.model
    if p["C"] <= 0.0:
        return
    V = p["volume"]
    build.prm[L.P_SUP_C] = p["C"]
    build.prm[L.P_SUP_B] = p["b"]
    build.prm[L.P_SUP_V] = V
    m0 = m.supply.pressure * V / (m.gas.r * m.supply.temperature)
    build.iy[L.IY_SUPPLY_M] = build.add_state("m_supply", m0, 1e-6 * m0)


def _pack_sensor(p, build):
    if p["time_constant"] > 0.0:
        build.add_term(PRESSURE_SENSOR, (p["time_constant"],))


def _pack_spring(p, build):
    build.prm[L.P_SPRING_K] = p["rate"]
    build.prm[L.P_SPRING_F0] = p["preload"]


#: Ports of a flow control: the parameter suffix, the port's exhaust edge and supply edge
_FLOW_CONTROL_PORTS = {"a": ("A", "A-R", "P-A"), "b": ("B", "B-R", "P-B")}
#: Unit of a sonic conductance, for the messages
_C_UNIT = "m^3/(s Pa)"


def _check_ports(p, model, path):
    """A flow control on a port the valve does not drive is refused, naming the parameter."""
    for sfx, (port, exhaust, supply) in _FLOW_CONTROL_PORTS.items():
        if p[f"C_{sfx}"] > 0.0 and exhaust not in model.valve.ports:
            raise FieldError(f"{path}.C_{sfx}",
                             f"the {model.valve.kind} valve has no port {port} (edges "
                             f"{sorted(model.valve.ports)}): set C_{sfx} to 0 (no throttle) "
                             f"[{_C_UNIT}]")


def _value(model, effect, name):
    """Parameter ``name`` of ``effect`` in ``model`` as given, its default where not given
    (None where the effect is not in the model)."""
    given = (model.effects or {}).get(effect)
    if given is None:
        return None
    given = given if isinstance(given, dict) else {}
    return given.get(name, EFFECTS[effect].param(name).default)


def _line_on_port(model, sfx, other):
    """What else holds a line term on port ``sfx`` besides the flow control ``other`` excludes:
    ``tubing`` in segments, or the other flow control with a volume (None: nothing)."""
    seg = _value(model, "tubing", "segments")
    if seg is not None and seg > 1 and (_value(model, "tubing", f"length_{sfx}") or 0.0) > 0.0:
        return "a tubing line in segments"
    V = _value(model, other, f"volume_{sfx}")
    if V is not None and V > 0.0 and (_value(model, other, f"C_{sfx}") or 0.0) > 0.0:
        return f"{other} with a volume"
    return None


def _check_flow_control(other):
    """``check`` of a flow control: its ports (:func:`_check_ports`), and a volume before it
    only on a port no other line term holds (the node and a line in segments, or two nodes,
    on one port are not modelled)."""
    def check(p, model, path):
        _check_ports(p, model, path)
        for sfx, (port, _, _) in _FLOW_CONTROL_PORTS.items():
            if p[f"C_{sfx}"] <= 0.0 or p[f"volume_{sfx}"] <= 0.0:
                continue
            held = _line_on_port(model, sfx, other)
            if held is not None:
                raise FieldError(f"{path}.volume_{sfx}",
                                 f"port {port} already has {held} between the valve and the "
                                 f"chamber: a flow control's volume is not modelled beside it; "
                                 f"set volume_{sfx} to 0 (the control in series with the valve's "
                                 f"edge) or give the volume as a lumped line [m^3]")
    return check


def _has_node(p, sfx):
    """The control on port ``sfx`` has a volume before the valve: its node
    (physics.flow_control) holds it."""
    return p.get(f"C_{sfx}", 0.0) > 0.0 and p.get(f"volume_{sfx}", 0.0) > 0.0


def _flow_control_refit(p):
    # the volumes of the ports whose control has its node: a volume 0 stays the series form
    return tuple(f"volume_{sfx}" for sfx in _FLOW_CONTROL_PORTS if _has_node(p, sfx))


def _in_series(p, sfx):
    """The control on port ``sfx`` is in series with the valve's edge, no volume between."""
    return p[f"C_{sfx}"] > 0.0 and not _has_node(p, sfx)


def _meter_out_series(p, model):
    # chamber -> throttle (check valve closed) -> exhaust edge; the check valve opens for
    # the flow into the chamber, which passes freely (its conductance taken as large); with
    # a volume between, the node (physics.flow_control, _pack_flow_control) holds the control
    return {exhaust: ([(p[f"C_{sfx}"], p[f"b_{sfx}"])], [])
            for sfx, (_, exhaust, _) in _FLOW_CONTROL_PORTS.items() if _in_series(p, sfx)}


def _meter_in_series(p, model):
    # supply edge -> throttle (check valve closed) -> chamber; the exhaust passes freely
    return {supply: ([], [(p[f"C_{sfx}"], p[f"b_{sfx}"])])
            for sfx, (_, _, supply) in _FLOW_CONTROL_PORTS.items() if _in_series(p, sfx)}


def _pack_flow_control(direction):
    """``pack`` of a flow control: on each port whose control has a volume before it, the
    node's slots (``physics.flow_control.node_slots``) and its states, the gas at the
    chamber's pressure and temperature."""
    def pack(p, build):
        m = build.model
        term = PORT_NODE
        k0 = L.STATE_PRM0[term.name]
        i0 = L.STATE_IY0[term.name]
        size = len(term.parameters)
        for k, sfx in enumerate(("a", "b")):
            if not _has_node(p, sfx):
                continue
            V = p[f"volume_{sfx}"]
            build.prm[k0 + k * size:k0 + (k + 1) * size] = node_slots(
                V, p[f"C_{sfx}"], p[f"b_{sfx}"], p.get("C_check", _CHECK[0]),
                p.get("b_check", _CHECK[1]), direction,
                build.prm[L.P_H], m.ambient.temperature)
            p0, T0 = build.y_base[f"p_{sfx}"], build.y_base[f"T_{sfx}"]
            m0 = p0 * V / (m.gas.r * T0)
            # tolerances: a millionth of the node's mass at the supply pressure and of its
            # temperature, as a line's cells (_pack_tubing)
            m_tol = 1e-6 * m.supply.pressure * V / (m.gas.r * T0)
            start = {"m": (m0, m_tol), "T": (T0, 1e-6 * T0)}
            first = [build.add_state(f"node_{sfx}_{kind}", *start[kind])
                     for kind, _ in NODE_STATES][0]     # the order node_rates reads them
            build.iy[i0 + k] = first
    return pack


def _silencer_series(p, model):
    if p["C"] <= 0.0:
        return {}
    return {edge: ([], [(p["C"], p["b"])]) for edge in ("A-R", "B-R")}


def _missing_ports(*prefixes):
    """``unused`` of a per-port effect: its ``<prefix>_<port>`` parameters on ports the valve
    does not drive (port B of a 3/2 valve)."""
    return lambda model: tuple(f"{prefix}_{sfx}" for prefix in prefixes
                               for sfx, (_, exhaust, _) in _FLOW_CONTROL_PORTS.items()
                               if exhaust not in model.valve.ports)


def _check_line_ports(p, model, path):
    for sfx, (port, exhaust, _) in _FLOW_CONTROL_PORTS.items():
        if p[f"length_{sfx}"] > 0.0 and exhaust not in model.valve.ports:
            raise FieldError(f"{path}.length_{sfx}",
                             f"the {model.valve.kind} valve has no port {port}: set length_{sfx} "
                             f"to 0 (no line) [m]")


def _segments(p):
    """The line's segments; 1 (lumped) where the parameters predate them (a model built
    without validation, e.g. a stored synthetic rig's)."""
    return int(p.get("segments", 1))


def _lumped(p):
    """The line is lumped (one segment: today's volume and series resistance)."""
    return _segments(p) <= 1


def _tubing_transform(m, p):
    # lumped: the line's volume joins the chamber's dead volume; in segments, the cells hold it
    if _lumped(p):
        m.jack.dead_volume_a += line_volume(p["diameter_a"], p["length_a"])
        m.jack.dead_volume_b += line_volume(p["diameter_b"], p["length_b"])


def _pack_tubing(p, build):
    """A line in segments: its slots per port (``physics.tube.line_slots``) and its states,
    cells at the chamber's pressure and temperature, gas at rest."""
    if _lumped(p):
        return
    m = build.model
    r = m.gas.r
    n = _segments(p)
    k0 = L.STATE_PRM0[SEGMENTED_LINE.name]
    i0 = L.STATE_IY0[SEGMENTED_LINE.name]
    size = len(SEGMENTED_LINE.parameters)
    for k, sfx in enumerate(("a", "b")):
        if p[f"length_{sfx}"] <= 0.0:
            continue
        vals = line_slots(p[f"diameter_{sfx}"], p[f"length_{sfx}"], n, m.supply.temperature,
                          build.prm[L.P_H], m.ambient.temperature)
        build.prm[k0 + k * size:k0 + (k + 1) * size] = vals
        p0, T0 = build.y_base[f"p_{sfx}"], build.y_base[f"T_{sfx}"]
        V, A = vals[1], vals[2]
        m_cell = p0 * V / (r * T0)
        # tolerances: a millionth of a cell's mass at the supply pressure and of the
        # temperature; for the faces' flows 1e-4 of the bore's choked flow at the supply
        # (order of magnitude p A / sqrt(r T)): 1e-6 made the integrator follow the line's
        # ringing long after it stopped mattering (724 steps against 471 on the pulse
        # benchmark with 2 segments, positions and pressures the same to 1e-6)
        m_tol = 1e-6 * m.supply.pressure * V / (r * T0)
        q_tol = 1e-4 * m.supply.pressure * A / math.sqrt(r * T0)
        start = {"m": (m_cell, m_tol), "T": (T0, 1e-6 * T0), "q": (0.0, q_tol)}
        first = None
        for kind, _ in LINE_STATES:            # the blocks in the order line_rates reads them
            for i in range(1, n + 1):
                j = build.add_state(f"line_{sfx}_{kind}{i}", *start[kind])
                first = j if first is None else first
        build.iy[i0 + k] = first


@functools.lru_cache(maxsize=1024)
def _line(diameter, length, p0, T0):
    return tube_characteristic(diameter, length, p0, T0)


def _tubing_series(p, model):
    # the line's resistance sits between the valve and the chamber: downstream of the supply
    # edge, upstream of the exhaust edge; its friction evaluated at the supply pressure
    out = {}
    if not _lumped(p):
        return out       # in segments, the line's friction acts along it (physics.tube)
    for sfx, (_, exhaust, supply) in _FLOW_CONTROL_PORTS.items():
        if p[f"length_{sfx}"] > 0.0:
            cb = _line(p[f"diameter_{sfx}"], p[f"length_{sfx}"], model.supply.pressure,
                       model.supply.temperature)
            out[supply] = ([], [cb])
            out[exhaust] = ([cb], [])
    return out


def _cushion_transform(m, p):
    # the cushion cavity beyond the piston's travel is part of the chamber's dead volume
    m.jack.dead_volume_a += p["volume_a"]
    m.jack.dead_volume_b += p["volume_b"]


def _pack_cushion(p, build):
    build.prm[L.P_CUSHION_LA] = p["length_a"]
    build.prm[L.P_CUSHION_LB] = p["length_b"]
    build.prm[L.P_CUSHION_CA] = p["C_a"]
    build.prm[L.P_CUSHION_CB] = p["C_b"]
    build.prm[L.P_CUSHION_B] = p["b"]


def _cushion_fit_max(model):
    # each cushion within half the stroke: the pair never overlaps, whatever the other's fit
    # (a fit once stretched a cushion past the stroke to stand in for a meter-out throttle)
    half = 0.5 * model.jack.stroke
    return {"length_a": half, "length_b": half}


def _check_cushion(p, model, path):
    """A cushion longer than the stroke, two cushions that overlap, or a cushion on a port the
    valve does not drive is refused, naming the parameter and its unit."""
    stroke = model.jack.stroke
    for sfx in ("a", "b"):
        if p[f"length_{sfx}"] > stroke:
            raise FieldError(f"{path}.length_{sfx}",
                             f"a cushion longer than the stroke ({stroke:g} m) [m]")
    if p["length_a"] + p["length_b"] > stroke:
        raise FieldError(f"{path}.length_b",
                         f"the two cushions overlap: length_a + length_b exceeds the stroke "
                         f"({stroke:g} m) [m]")
    for sfx, (port, exhaust, _) in _FLOW_CONTROL_PORTS.items():
        if p[f"length_{sfx}"] > 0.0 and exhaust not in model.valve.ports:
            raise FieldError(f"{path}.length_{sfx}",
                             f"the {model.valve.kind} valve has no port {port}: set length_{sfx} "
                             f"to 0 (no cushion) [m]")
def _tubing_forms(p, model, sample_period):
    # a line whose delay L / c spans more than a sample shows it in the records, which the
    # lumped line (no delay) cannot: the line in segments resolving it to a sample
    # (physics.line.delay_cells) is the other form
    n = delay_cells(max(p["length_a"], p["length_b"]), sample_period, model.supply.temperature)
    return [{"segments": n}] if n > 1 else []


def _tubing_form_finer(new, old):
    # more segments resolve the line's delay and waves more finely; fewer (or the lumped line)
    # only cost less: a line fitted in more cells than its fitted length needs is accurate
    return _segments(new) > _segments(old)


def _tubing_form_min(form, model, sample_period):
    # in segments, a line no shorter than one sample's delay c dt: a shorter one is within a
    # sample, the lumped form's (and its cells, L / N each, would make the core's steps tiny)
    if _segments(form) <= 1:
        return {}
    shortest = sound_speed(model.supply.temperature) * sample_period
    return {"length_a": shortest, "length_b": shortest}


def _tubing_warn(p, model, time_scale):
    # the chosen segments against those the command's time scale needs
    # (physics.line.line_regime): warned only where the line is too coarse
    out = []
    n = _segments(p)
    for sfx, (port, _, _) in _FLOW_CONTROL_PORTS.items():
        if p[f"length_{sfx}"] > 0.0:
            r = line_regime(p[f"diameter_{sfx}"], p[f"length_{sfx}"], time_scale,
                            model.supply.temperature)
            if n >= r["cells"]:
                continue
            advice = (f"set tubing.segments to {r['cells']} or more" if r["cells"] <= MAX_SEGMENTS
                      else f"even the most segments, {MAX_SEGMENTS}, are too coarse")
            out.append(f"tubing on port {port} ({p[f'length_{sfx}']:g} m, {n} segment"
                       f"{'s' if n > 1 else ''}): transport delay "
                       f"{r['delay'] * 1e3:.3g} ms, quarter-wave period "
                       f"{r['quarter_wave_period'] * 1e3:.3g} ms, against command changes "
                       f"{time_scale * 1e3:.3g} ms apart; the lumped line (no delay) is "
                       f"adequate from {LUMPED_MARGIN:g} quarter-wave periods on, a line in "
                       f"segments needs {r['cells']}: {advice}")
    return out


def effect_warnings(model, time_scale):
    """Messages of the model's effects whose model is not adequate for the command.

    Parameters
    ----------
    model : Model
        The actuator with its effects
    time_scale : float
        Shortest interval between command changes [s]

    Returns
    -------
    messages : list of str
        One message per inadequate effect and port (empty when all are adequate)
    """
    out = []
    for name, params in model.effects.items():
        eff = EFFECTS[name]
        if eff.warn is not None:
            out.extend(eff.warn(params, model, time_scale))
    return out


#: The open check valve of a flow control, (C [m^3/(s Pa)], b [-]): 1 dm^3/(s bar), the order of
#: the free flow of a cylinder-port speed controller for 6 mm tube (no one model's value: a user
#: with a catalogue gives its own), b 0.3 as the throttle's
_CHECK = (1e-8, 0.3)


def _flow_control_parameters(what):
    return [Parameter("C_a", _C_UNIT, 3e-9, 0.0, 1e-6, 0.0,
                      f"sonic conductance of the {what} throttle on port A (0 = none)"),
            Parameter("b_a", "-", 0.3, 0.0, 0.99, None, "its critical pressure ratio"),
            Parameter("C_b", _C_UNIT, 3e-9, 0.0, 1e-6, 0.0,
                      f"sonic conductance of the {what} throttle on port B (0 = none)"),
            Parameter("b_b", "-", 0.3, 0.0, 0.99, None, "its critical pressure ratio"),
            Parameter("volume_a", "m^3", 0.0, 0.0, 1e-3, 0.0,
                      "volume between the flow control on port A and the valve (tube and "
                      "fittings, the control at the cylinder's port: physics.flow_control); "
                      "0 = none, the throttle in series with the valve's edge"),
            Parameter("volume_b", "m^3", 0.0, 0.0, 1e-3, 0.0,
                      "volume between the flow control on port B and the valve; 0 = none"),
            Parameter("C_check", _C_UNIT, _CHECK[0], 1e-10, 1e-6, None,
                      "sonic conductance of the open check valve, in parallel with the "
                      "throttle, where a volume lies before the control (with volume 0 the "
                      "check valve passes freely)"),
            Parameter("b_check", "-", _CHECK[1], 0.0, 0.99, None,
                      "the open check valve's critical pressure ratio")]


for _e in [
    Effect("heat_exchange",
           "convective heat exchange with the walls (Eq. 9) on an isothermal or adiabatic model",
           "pressure overshoot then relaxation after each valve switch; model too stiff on "
           "compression and too slow on expansion, errors largest while the valve closes",
           "Maré, Geider & Colin, Eq. 9 and Table 2",
           [Parameter("h", "W/(m^2 K)", 25.0, 0.0, 2000.0, 0.0, "convection coefficient")],
           strength="h", transform=_heat_transform, applies=_heat_applies, probe={"h": 25.0}),
    Effect("natural_convection",
           "natural convection between gas and wall added to the model's fixed coefficient: "
           "Churchill-Chu correlation for a horizontal cylinder of the bore's diameter, air's "
           "properties at the chamber's pressure and temperature (h grows as p^(2/3) dT^(1/3) at large Ra)",
           "temperature relaxes faster when the gas is dense and far from the wall, slower near "
           "equilibrium; one fixed coefficient fits either the transient or the hold, not both",
           "Churchill & Chu, Int. J. Heat Mass Transfer 18 (1975) 1049",
           [Parameter("multiplier", "-", 1.0, 0.0, HEAT_PARAMETERS["natural_multiplier"].max, 0.0,
                      "factor on the correlation's Nusselt number")],
           strength="multiplier", pack=_pack_natural, transform=_free_gas_transform,
           applies=lambda m: _exchanging(m, "natural"), probe={"multiplier": 1.0}),
    Effect("inflow_jet_convection",
           "forced convection of the jet entering a chamber (Nu = 0.56 Re_d^0.67 on the inlet "
           "diameter), added to the model's exchange while gas flows in",
           "gas heats less than the model while a chamber fills, then relaxes as the model says; "
           "a fixed coefficient fitted to the filling is too strong afterwards",
           "Woodfield, Monde & Mitsutake, J. Thermal Sci. Tech. 2 (2007) 180",
           [Parameter("multiplier", "-", 1.0, 0.0, HEAT_PARAMETERS["jet_multiplier"].max, 0.0,
                      "factor on the correlation's Nusselt number"),
            Parameter("inlet_diameter", "m", HEAT_PARAMETERS["inlet_diameter"].default,
                      HEAT_PARAMETERS["inlet_diameter"].min, HEAT_PARAMETERS["inlet_diameter"].max,
                      None, "inlet (jet) diameter")],
           strength="multiplier", pack=_pack_jet, transform=_free_gas_transform,
           fit_params=("multiplier",),
           applies=lambda m: _exchanging(m, "jet"), probe={"multiplier": 1.0}),
    Effect("wall_heat_capacity",
           "walls with a thermal capacity (a wall temperature per chamber, exchanging with the "
           "gas and, through an outer coefficient, with the ambient) instead of walls at ambient",
           "after repeated fills the gas settles above (or below) ambient; the exchange weakens "
           "as the wall follows the gas",
           "HydDown (Andreasen 2021), lumped wall heat balance; paper Eq. 9 with T_w a state",
           [Parameter("mass", "kg", 0.05, 0.0, HEAT_PARAMETERS["wall_mass"].max, 0.0,
                      "wall mass of each chamber"),
            Parameter("specific_heat", "J/(kg K)", HEAT_PARAMETERS["wall_specific_heat"].default,
                      HEAT_PARAMETERS["wall_specific_heat"].min,
                      HEAT_PARAMETERS["wall_specific_heat"].max, None, "wall specific heat"),
            Parameter("outer_coefficient", "W/(m^2 K)", HEAT_PARAMETERS["outer_coefficient"].default,
                      HEAT_PARAMETERS["outer_coefficient"].min,
                      HEAT_PARAMETERS["outer_coefficient"].max, None,
                      "outer coefficient, wall to ambient")],
           strength="mass", pack=_pack_wall, applies=_wall_applies, fit_params=("mass",),
           probe={"mass": 0.05}),
    Effect("piston_leakage",
           "laminar leak across the piston seal, A <-> B, carrying enthalpy",
           "pressures of a locked jack converge towards each other while the valve is closed; "
           "chamber pressure difference decays, piston drifts under load",
           "Beater, Pneumatic Drives (2007), seal leakage; laminar leak q = G (p_a - p_b)",
           [Parameter("conductance", "kg/(s Pa)", 5e-11, 0.0, 1e-8, 0.0, "leak conductance G")],
           strength="conductance", pack=_pack_slot("G_AB", "conductance"), probe={"conductance": 5e-11}),
    Effect("external_leakage",
           "laminar leak from each chamber to ambient (rod seal, fittings)",
           "a pressurised chamber decays towards ambient while the valve is closed",
           "Beater, Pneumatic Drives (2007); laminar leak q = G (p - p_atm)",
           [Parameter("conductance_a", "kg/(s Pa)", 5e-11, 0.0, 1e-8, 0.0, "leak of chamber A"),
            Parameter("conductance_b", "kg/(s Pa)", 5e-11, 0.0, 1e-8, 0.0, "leak of chamber B")],
           strength="conductance_a", pack=_pack_ext_leak,
           probe={"conductance_a": 5e-11, "conductance_b": 5e-11}),
    Effect("valve_spool_dynamics",
           "spool lag between command and effective opening (first order, or second order if "
           "natural_frequency > 0)",
           "model pressures lead the measurement right after every command switch; a delay of a "
           "few ms at each step",
           "paper Sect. 3 (spool dynamics left out of the sixth-order model)",
           [Parameter("time_constant", "s", 0.005, 0.0, 0.2, 0.0, "first-order time constant"),
            Parameter("natural_frequency", "rad/s", 0.0, 0.0, 5000.0, 0.0,
                      "second-order natural frequency (0 = first order)"),
            Parameter("damping", "-", 0.7, 0.05, 5.0, None, "second-order damping ratio")],
           strength="time_constant", pack=_pack_spool, fit_params=("time_constant",),
           probe={"time_constant": 0.005, "natural_frequency": 0.0}),
    Effect("valve_switching_delay",
           "a pure delay between each command change and the valve's switch (a solenoid's "
           "switching time, on energising and on de-energising)",
           "every pressure change starts the same few ms after its command edge, with the shape "
           "it would have at once (a spool lag rounds it instead)",
           "ISO 12238 (switching times of directional control valves); solenoid-valve "
           "catalogues give them (SMC, Festo: 5-30 ms)",
           [Parameter("on_time", "s", 0.005, 0.0, 0.1, 0.0,
                      "switching time on energising, added to the valve's own"),
            Parameter("off_time", "s", 0.005, 0.0, 0.1, 0.0,
                      "switching time on de-energising (back to the rest position), added to "
                      "the valve's own")],
           strength="on_time", transform=_switching_transform, unused=_switching_unused,
           probe={"on_time": 0.005, "off_time": 0.005},
           # a line in finite volumes carries each pressure change to its chamber L / c later
           # (2.5 m: 7.3 ms), the delay this effect is: at the probes' doses (5 ms, against a
           # 1 m line) this one's change explains more of a long line's residual than the line's
           # own, and took the refit's place (the 2.5 m line rig, fitted on its window: a 7.6 ms
           # switching delay named at 1.99 % error against a 0.08 % floor, the line not
           # refitted). Fitted, they differ: a valve's delay shifts each command's edges alike on
           # both ports, on its own times for energising and de-energising, and the pressure then
           # rises as at once; a line delays each port by its own length, the same both ways, and
           # its volume and resistance slow and attenuate the rise
           resembles=("tubing",)),
    Effect("valve_null_leakage",
           "leakage of a centred spool: a fraction of each edge's full C on all four edges",
           "with the valve centred, both chambers drift towards the supply/exhaust equilibrium",
           "ISO 10770-1 (internal leakage of proportional valves); paper Fig. 2 overlap",
           [Parameter("fraction", "-", 0.005, 0.0, 0.2, 0.0, "leak conductance / full conductance")],
           strength="fraction", pack=_pack_null_leak, probe={"fraction": 0.005}),
    Effect("stribeck_friction",
           "breakaway friction above Coulomb: Fc + (Fs - Fc) exp(-(v/vs)^2)",
           "piston starts late and then jumps; position error right after each start from rest",
           "Armstrong-Hélouvry (1991), Control of machines with friction",
           [Parameter("static_ratio", "-", 1.5, 1.0, 5.0, 1.0, "Fs / Fc"),
            Parameter("stribeck_velocity", "m/s", 0.01, 1e-4, 1.0, None, "Stribeck velocity vs")],
           strength="static_ratio", pack=_pack_stribeck, observable_in=("free",),
           probe={"static_ratio": 1.5}),
    Effect("pressure_dependent_friction",
           "Coulomb and viscous friction that grow with the chamber pressures (Eq. 19-20)",
           "position and velocity errors that grow with the working pressure; a constant-friction "
           "model is right at low pressure only",
           "Maré, Geider & Colin, Eq. 19-20",
           [Parameter("fc_a", "N/Pa", 1e-5, -2e-4, 2e-4, 0.0, "Coulomb per gauge pressure in A"),
            Parameter("fc_b", "N/Pa", 1e-5, -2e-4, 2e-4, 0.0, "Coulomb per gauge pressure in B"),
            Parameter("kv_a", "N s/(m Pa)", 0.0, -1e-3, 1e-3, 0.0, "viscous per gauge pressure in A"),
            Parameter("kv_b", "N s/(m Pa)", 0.0, -1e-3, 1e-3, 0.0, "viscous per gauge pressure in B")],
           strength="fc_a", transform=_pdf_transform, applies=_pdf_applies, observable_in=("free",),
           fit_params=("fc_a", "fc_b"), probe={"fc_a": 1e-5, "fc_b": 1e-5}),
    Effect("quadrant_friction",
           "different extend and retract friction (the quadrant effect); parameters are the "
           "retract set minus the extend set",
           "position error of one sign on extension strokes and another on retraction strokes",
           "Maré (1993); paper Sect. 2.3",
           [Parameter("fc0", "N", 5.0, -500.0, 500.0, 0.0, "retract - extend constant Coulomb"),
            Parameter("fc_a", "N/Pa", 0.0, -2e-4, 2e-4, 0.0, "retract - extend Coulomb per p_a"),
            Parameter("fc_b", "N/Pa", 0.0, -2e-4, 2e-4, 0.0, "retract - extend Coulomb per p_b"),
            Parameter("kv0", "N s/m", 10.0, -2000.0, 2000.0, 0.0, "retract - extend viscous"),
            Parameter("kv_a", "N s/(m Pa)", 0.0, -1e-3, 1e-3, 0.0, "retract - extend viscous per p_a"),
            Parameter("kv_b", "N s/(m Pa)", 0.0, -1e-3, 1e-3, 0.0, "retract - extend viscous per p_b")],
           strength="fc0", transform=_quadrant_transform, applies=_quadrant_applies,
           observable_in=("free",), fit_params=("fc0", "kv0"), probe={"fc0": 5.0, "kv0": 10.0},
           base_change=_quadrant_base_change,
           ties={f"friction.extend.{k}": (f"friction.retract.{k}",) for k in _FRICTION_KEYS}),
    Effect("dead_volume",
           "extra volume between valve and chamber (tubing, fittings)",
           "pressure rises and falls slower than the model, most at the small-volume end of stroke",
           "paper Eq. 23-24 (dead volumes v_m)",
           [Parameter("volume_a", "m^3", 5e-6, 0.0, 1e-3, 0.0, "extra volume on A"),
            Parameter("volume_b", "m^3", 5e-6, 0.0, 1e-3, 0.0, "extra volume on B")],
           strength="volume_a", transform=_dead_transform, unused=_static_b("volume_b"),
           probe={"volume_a": 5e-6, "volume_b": 5e-6}),
    Effect("supply_pressure_drop",
           "finite supply: a regulator conductance feeding an (isothermal) supply-line volume",
           "filling chamber pressure sags below the model while flow is high, then recovers",
           "ISO 6358 for the regulator; Beater, Pneumatic Drives (2007), supply lines",
           [Parameter("C", "m^3/(s Pa)", 2e-8, 0.0, 1e-6, 0.0, "regulator sonic conductance (0 = ideal supply)"),
            Parameter("b", "-", 0.3, 0.0, 0.99, None, "regulator critical ratio"),
            Parameter("volume", "m^3", 1e-4, 1e-7, 1e-2, None, "supply-line volume")],
           strength="C", pack=_pack_supply, fit_params=("C",), probe={"C": 5e-8},
           refit_params=("volume",)),
    Effect("sensor_lag",
           "the model's sensors: first-order lag of the pressure transducers; and what a "
           "closed loop's controller reads (pneucore.physics.sensors): the position sensor's "
           "resolution, lag and noise, the transducers' noise and resolution",
           "measured pressures trail the model by a fixed delay at every fast transient",
           "paper Sect. 4 (phase lags of the acquisition chain)",
           [Parameter("time_constant", "s", 0.002, 0.0, 0.1, 0.0, "transducer time constant"),
            Parameter("pressure_noise", "Pa", 0.0, 0.0, 1e5, 0.0,
                      "standard deviation of the transducers' noise a controller reads "
                      "(seeded by scenario.controller.seed)"),
            Parameter("pressure_resolution", "Pa", 0.0, 0.0, 1e5, 0.0,
                      "pressure transducers' resolution a controller reads (the converter's "
                      "step; 0 = continuous)"),
            Parameter("position_resolution", "m", 0.0, 0.0, 0.01, 0.0,
                      "position sensor's resolution (an encoder's count; 0 = continuous)"),
            Parameter("position_time_constant", "s", 0.0, 0.0, 1.0, 0.0,
                      "position sensor's first-order lag (0 = none)"),
            Parameter("position_noise", "m", 0.0, 0.0, 0.01, 0.0,
                      "standard deviation of the position sensor's noise a controller reads "
                      "(seeded by scenario.controller.seed)")],
           strength="time_constant", pack=_pack_sensor, probe={"time_constant": 0.002},
           # the controller's signals only: no open-loop record shows them, the diagnosis
           # fits the transducers' lag alone
           fit_params=("time_constant",)),
    Effect("return_spring",
           "a return spring on the piston, F = F0 + k x towards x = 0 (spring-return "
           "single-acting cylinder, or a spring on any jack)",
           "the net force falls linearly along the stroke: the piston slows as it extends, "
           "retracts with the valve exhausting, and stops short under a weak supply; a constant "
           "load fits one end of the stroke only",
           "Hooke's law in paper Eq. 17; Beater, Pneumatic Drives (2007), single-acting cylinders",
           [Parameter("rate", "N/m", 300.0, 0.0, 1e5, 0.0, "spring rate k"),
            Parameter("preload", "N", 20.0, 0.0, 5000.0, 0.0, "spring force F0 at x = 0")],
           strength="preload", pack=_pack_spring, observable_in=("free",),
           probe={"rate": 300.0, "preload": 20.0}),
    Effect("meter_out_throttle",
           "one-way flow control on a cylinder port, throttling the air leaving the chamber: an "
           "ISO 6358 throttle in parallel with a check valve that lets the inflow pass freely, "
           "in series with the valve's exhaust edge with no volume between (ISO 6358-3); with "
           "volume_a or volume_b the control sits at the cylinder's port and that volume (tube, "
           "fittings) between it and the valve is a node of its own (physics.flow_control)",
           "the exhausting chamber's pressure stays high while the piston moves (back pressure), "
           "speed held low and steady, the exhausting chamber empties slowly after each stroke; "
           "the filling side is as the model says",
           "ISO 6358-3:2014 (series combination); SMC speed controllers (meter-out)",
           _flow_control_parameters("meter-out"),
           strength="C_a", series=_meter_out_series, pack=_pack_flow_control(METER_OUT),
           refit_params=("volume_a", "volume_b"),
           refit_only=_flow_control_refit,
           check=_check_flow_control("meter_in_throttle"), unused=_missing_ports("C", "volume"),
           fit_params=("C_a", "C_b"), probe={"C_a": 3e-9, "C_b": 3e-9}),
    Effect("meter_in_throttle",
           "one-way flow control on a cylinder port, throttling the air entering the chamber: an "
           "ISO 6358 throttle in parallel with a check valve that lets the outflow pass freely, "
           "in series with the valve's supply edge with no volume between (ISO 6358-3); with "
           "volume_a or volume_b the control sits at the cylinder's port and that volume "
           "between it and the valve is a node of its own (physics.flow_control)",
           "the filling chamber's pressure rises slower than the model while the exhaust is as "
           "the model says; a slow, stick-slip prone start",
           "ISO 6358-3:2014 (series combination); SMC speed controllers (meter-in)",
           _flow_control_parameters("meter-in"),
           strength="C_a", series=_meter_in_series, pack=_pack_flow_control(METER_IN),
           refit_params=("volume_a", "volume_b"),
           refit_only=_flow_control_refit,
           check=_check_flow_control("meter_out_throttle"), unused=_missing_ports("C", "volume"),
           fit_params=("C_a", "C_b"), probe={"C_a": 3e-9, "C_b": 3e-9}),
    Effect("tubing",
           "the line between valve and chamber on each port. Lumped (segments 1): its volume "
           "pi d^2 L / 4 joins the dead volume, its resistance (Fanno flow with wall friction) "
           "is in series with the port's valve edges (ISO 6358-3), no transport delay. In "
           "segments (physics.tube): finite volumes with the gas's inertia and wall friction, "
           "carrying the delay L / c and the line's waves; a simulation warns where the "
           "segments are too coarse for the command's changes (physics.line.line_regime)",
           "both filling and exhausting slower than the model, most at the small-volume end of "
           "stroke, and a flow limit the valve alone does not have: a dead volume fits the "
           "pressure rise, not the flow",
           "Shapiro (1953) Fanno flow; Haaland (1983) friction; ISO 6358-3:2014 series combination",
           [Parameter("length_a", "m", 2.0, 0.0, 50.0, 0.0, "line length on port A (0 = none)"),
            Parameter("diameter_a", "m", 4e-3, 5e-4, 0.05, None, "inner diameter on port A"),
            Parameter("length_b", "m", 2.0, 0.0, 50.0, 0.0, "line length on port B (0 = none)"),
            Parameter("diameter_b", "m", 4e-3, 5e-4, 0.05, None, "inner diameter on port B"),
            Parameter("segments", "-", 1.0, 1.0, float(MAX_SEGMENTS), None,
                      "finite volumes per line: 1 = lumped (volume and series resistance, no "
                      "delay); more carry the transport delay and the line's waves",
                      integer=True)],
           strength="length_a", transform=_tubing_transform, series=_tubing_series,
           pack=_pack_tubing,
           check=_check_line_ports, unused=_missing_ports("length"), fit_params=("length_a", "length_b"),
           probe={"length_a": 1.0, "length_b": 1.0}, warn=_tubing_warn, forms=_tubing_forms,
           form_min=_tubing_form_min, form_finer=_tubing_form_finer,
           reduces_to=("dead_volume",)),
    Effect("exhaust_silencer",
           "a silencer on the valve's exhaust ports: an ISO 6358 restriction in series with "
           "each exhaust edge, with no volume between (ISO 6358-3)",
           "every exhausting chamber empties slower than the model, on both ports alike; the "
           "filling is as the model says",
           "ISO 6358-3:2014 (series combination); silencer flow data per ISO 6358-1",
           [Parameter("C", _C_UNIT, 1e-8, 0.0, 1e-6, 0.0,
                      "sonic conductance of the silencer (0 = none)"),
            Parameter("b", "-", 0.4, 0.0, 0.99, None, "its critical pressure ratio")],
           strength="C", series=_silencer_series, fit_params=("C",), probe={"C": 5e-9}),
    Effect("end_cushion",
           "adjustable end cushions (pneucore.physics.cushion): over the last length of its "
           "travel towards an end the piston traps the gas ahead of it, which leaves only "
           "through a needle (ISO 6358 restriction); a check valve lets the piston leave the end "
           "freely",
           "the piston decelerates over the last millimetres before each end stop while the "
           "exhausting chamber's pressure rises above the supply; the impact speed is lower "
           "and the stroke time longer than the model says; starts from the ends unchanged",
           "Beater, Pneumatic Drives (2007) Sect. 6.3; SMC Best Pneumatics, air cushion and "
           "allowable kinetic energy",
           [Parameter("length_a", "m", 0.015, 0.0, 1.0, 0.0,
                      "cushion length at the x = 0 end, chamber A (0 = none)"),
            Parameter("volume_a", "m^3", 0.0, 0.0, 1e-3, 0.0,
                      "cushion cavity at that end beyond the piston's travel, added to the "
                      "dead volume of A (0 = counted in it)"),
            Parameter("C_a", _C_UNIT, 1e-9, 0.0, 1e-6, None,
                      "sonic conductance of the needle of chamber A's cushion"),
            Parameter("length_b", "m", 0.015, 0.0, 1.0, 0.0,
                      "cushion length at the x = stroke end, chamber B (0 = none)"),
            Parameter("volume_b", "m^3", 0.0, 0.0, 1e-3, 0.0,
                      "cushion cavity at that end beyond the piston's travel, added to the "
                      "dead volume of B (0 = counted in it)"),
            Parameter("C_b", _C_UNIT, 1e-9, 0.0, 1e-6, None,
                      "sonic conductance of the needle of chamber B's cushion"),
            Parameter("b", "-", 0.3, 0.0, 0.99, None, "critical pressure ratio of the needles"),
            Parameter("capacity", "J", 0.0, 0.0, 1e5, None,
                      "kinetic energy the cushion absorbs at most (catalogue figure; 0 = not "
                      "given): the stroke metrics check each impact against it")],
           strength="length_a", transform=_cushion_transform, pack=_pack_cushion,
           check=_check_cushion, unused=_missing_ports("length"), observable_in=("free",),
           fit_max=_cushion_fit_max,
           fit_params=("length_a", "length_b", "C_a", "C_b"),
           probe={"length_a": 0.015, "length_b": 0.015}),
]:
    register_effect(_e)
