"""The actuator model as plain dataclasses that round-trip to JSON.

``Model.from_dict(d)`` validates everything and raises one
:class:`~pneucore.description.validation.FieldError` (a ``ValueError``) naming the field
path; ``Model.to_dict()`` gives back plain JSON. Units are SI, pressures
absolute [Pa], temperatures [K].
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Optional

from pneucore.physics.flow import FLOW_LAWS, R_LAMINAR
from pneucore.physics.friction import FRICTION_LAWS
from pneucore.physics.gas import GAMMA_AIR, P_ATM, P_CONTINUUM_MIN, R_AIR, T_REF
from pneucore.physics.heat import HEAT_MODELS, HEAT_PARAMETERS
from pneucore.physics.jack import ANGLE_MAX, annulus_area, chamber_volumes, gravity_load, rod_area
from pneucore.description.validation import FieldError, choice, known_keys, mapping, number, number_list, optional_mapping
from pneucore.description.provenance import check_provenance

#: Edges of each valve kind and the opening range of their tables
VALVE_KINDS = {
    "4/2": {"ports": ("P-A", "A-R", "P-B", "B-R"), "range": (-1.0, 1.0)},
    "3/2": {"ports": ("P-A", "A-R"), "range": (0.0, 1.0)},
}

#: Longest valve switching time accepted [s]: solenoid valves switch in 5 to 100 ms (SMC,
#: Festo catalogues); a large pilot-operated valve or a process valve in a few tenths
MAX_SWITCHING_TIME = 1.0

#: What is on chamber B of a 3/2 valve (``valve.b_chamber``): ``dynamic`` says whether
#: chamber B is a gas volume with its own mass and energy balance (Eq. 14-15) or a node
#: held at a constant pressure
B_CHAMBER_MODES = {
    "held": {"dynamic": False,
             "description": "held at valve.b_chamber_pressure (half the supply by default, as in "
                            "the paper): a pressure regulator or a large reservoir on port B"},
    "vented": {"dynamic": False,
               "description": "open to the ambient (a single-acting cylinder's vent): held at "
                              "ambient.pressure"},
    "closed": {"dynamic": True,
               "description": "a closed volume of gas (an air spring) compressed and expanded "
                              "by the piston, Eq. 14-15 with no flow"},
    "restriction": {"dynamic": True,
                    "description": "vented to the ambient through an ISO 6358 restriction "
                                   "(valve.b_chamber_conductance, valve.b_chamber_critical_ratio): "
                                   "a breather, filter or throttle on port B"},
}


@dataclass
class Jack:
    """Cylinder geometry and load.

    Parameters
    ----------
    bore : float
        Bore (piston) diameter [m]
    rod_a : float
        Rod diameter on the chamber-A side, 0 = no rod [m]
    rod_b : float
        Rod diameter on the chamber-B side, 0 = no rod [m]
    stroke : float
        Stroke [m]
    dead_volume_a : float
        Volume of chamber A at x = 0, ports included [m^3]
    dead_volume_b : float
        Volume of chamber B at x = stroke [m^3]
    moving_mass : float
        Moving mass: piston, rod and load [kg]
    load_force : float
        Constant external force pushing towards x = 0 [N]
    wall_area_a : float or None
        Heat-exchange area of chamber A; None = lateral area of the gas column plus both
        end faces, following the piston [m^2]
    wall_area_b : float or None
        Heat-exchange area of chamber B; None = lateral area of the gas column plus both
        end faces, following the piston [m^2]
    mounting_angle : float
        Angle of the rod over the horizontal, -90 to 90: 0 horizontal, 90 vertical with the rod
        up (extension lifts the moving mass: m g sin(angle) adds to the load), -90 rod down [deg]
    """
    bore: float = 0.032
    rod_a: float = 0.012
    rod_b: float = 0.012
    stroke: float = 0.25
    dead_volume_a: float = 5e-6
    dead_volume_b: float = 5e-6
    moving_mass: float = 2.0
    load_force: float = 0.0
    wall_area_a: Optional[float] = None
    wall_area_b: Optional[float] = None
    mounting_angle: float = 0.0

    @property
    def gravity_force(self):
        """Weight of the moving mass along the rod, towards x = 0 [N]
        (:func:`pneucore.physics.jack.gravity_load`)."""
        return gravity_load(self.moving_mass, self.mounting_angle)

    @property
    def total_load(self):
        """Load of Eq. 17: ``load_force`` plus the weight along the rod [N] (the load
        itself, bit for bit, on a horizontal jack)."""
        if self.mounting_angle == 0.0:
            return self.load_force
        return self.load_force + self.gravity_force

    @property
    def area_a(self):
        """Annulus area of chamber A [m^2]."""
        return annulus_area(self.bore, self.rod_a)

    @property
    def area_b(self):
        """Annulus area of chamber B [m^2]."""
        return annulus_area(self.bore, self.rod_b)

    @property
    def rod_area_a(self):
        """Rod cross-section on side A [m^2]."""
        return rod_area(self.rod_a)

    @property
    def rod_area_b(self):
        """Rod cross-section on side B [m^2]."""
        return rod_area(self.rod_b)

    def volumes(self, x):
        """Chamber volumes ``(V_a, V_b)`` at position ``x`` [m] (Eq. 23-24) [m^3]."""
        return chamber_volumes(x, self.area_a, self.area_b, self.stroke, self.dead_volume_a,
                               self.dead_volume_b)

    @staticmethod
    def checked_rod(rod, bore, path):
        """A rod diameter checked against its bore: the jack's one rule, also used for the
        cylinders a sizing request gives (:mod:`pneucore.sizing.series`).

        Parameters
        ----------
        rod : float
            Rod diameter as given [m]
        bore : float
            Bore diameter, already checked positive [m]
        path : str
            Field path named in errors

        Returns
        -------
        rod : float
            The rod diameter, non-negative and smaller than the bore [m]

        Examples
        --------
        >>> Jack.checked_rod(0.012, 0.032, "jack.rod_a")
        0.012
        >>> Jack.checked_rod(0.032, 0.032, "jack.rod_a")
        Traceback (most recent call last):
        ...
        pneucore.description.validation.FieldError: jack.rod_a: rod diameter 0.032 m must be smaller than the bore 0.032 m
        """
        rod = number(rod, path, nonnegative=True)
        if rod >= bore:
            raise FieldError(path, f"rod diameter {rod:g} m must be smaller than the bore {bore:g} m")
        return rod

    @classmethod
    def from_dict(cls, d, path="jack"):
        mapping(d, path)
        known_keys(d, cls.__dataclass_fields__, path)
        j = cls(**{**cls().__dict__, **d})
        j.bore = number(j.bore, f"{path}.bore", positive=True)
        j.rod_a = cls.checked_rod(j.rod_a, j.bore, f"{path}.rod_a")
        j.rod_b = cls.checked_rod(j.rod_b, j.bore, f"{path}.rod_b")
        j.stroke = number(j.stroke, f"{path}.stroke", positive=True)
        j.dead_volume_a = number(j.dead_volume_a, f"{path}.dead_volume_a", positive=True)
        j.dead_volume_b = number(j.dead_volume_b, f"{path}.dead_volume_b", positive=True)
        j.moving_mass = number(j.moving_mass, f"{path}.moving_mass", positive=True)
        j.load_force = number(j.load_force, f"{path}.load_force")
        j.wall_area_a = number(j.wall_area_a, f"{path}.wall_area_a", positive=True, allow_none=True)
        j.wall_area_b = number(j.wall_area_b, f"{path}.wall_area_b", positive=True, allow_none=True)
        try:
            j.mounting_angle = number(j.mounting_angle, f"{path}.mounting_angle", low=-ANGLE_MAX,
                                      high=ANGLE_MAX)
        except FieldError as e:
            raise FieldError(e.path, f"{e.detail} [deg] (0 horizontal, 90 vertical rod up, "
                                     f"-90 rod down)") from None
        return j

    def to_dict(self):
        """Plain JSON; ``mounting_angle`` only when the jack is not horizontal (the JSON of
        earlier versions round-trips unchanged)."""
        d = dict(self.__dict__)
        if d["mounting_angle"] == 0.0:
            del d["mounting_angle"]
        return d


#: Largest sonic conductance a valve edge may have [m^3/(s Pa)]: what this package's own
#: conversions (:mod:`pneucore.description.valve_data`) give for a Cv of about 2,600 (a large process
#: valve) or a nominal flow of about 2.5 million NL/min, hundreds of times the largest
#: directional valves' (nominal flows of some 10^4 NL/min). Beyond it the number is a slip (a
#: catalogue's dm^3/(s bar) typed as SI), and a table a thousand times too large makes a
#: solver grind for seconds before it fails
VALVE_C_MAX = 1e-4


@dataclass
class PortTable:
    """One metering edge: sonic conductance and critical ratio against spool opening.

    Parameters
    ----------
    opening : list of float
        Strictly increasing spool openings, at least two (one point would never close the valve) [-]
    C : list of float
        Sonic conductance at each opening, at most :data:`VALVE_C_MAX` [m^3/(s Pa)]
    b : list of float
        Critical pressure ratio at each opening, in [0, 1) [-]
    m : list of float or None
        Subsonic index at each opening; None = 0.5 (Eq. 4) [-]
    """
    opening: list
    C: list
    b: list
    m: Optional[list] = None

    @classmethod
    def from_dict(cls, d, path, u_range=(-1.0, 1.0)):
        mapping(d, path)
        known_keys(d, ("opening", "C", "b", "m"), path)
        for key in ("opening", "C", "b"):
            if key not in d:
                raise FieldError(f"{path}.{key}", "is required")
        lo, hi = u_range
        # two points at least: one point would hold its conductance at every opening (linear
        # interpolation with the ends held), a valve that never closes
        opening = number_list(d["opening"], f"{path}.opening", min_len=2, low=lo, high=hi)
        for i in range(1, len(opening)):
            if opening[i] <= opening[i - 1]:
                raise FieldError(f"{path}.opening[{i}]",
                                 f"openings must be strictly increasing ({opening[i - 1]:g} then {opening[i]:g})")
        n = len(opening)
        C = number_list(d["C"], f"{path}.C", nonnegative=True, high=VALVE_C_MAX)
        b = number_list(d["b"], f"{path}.b", low=0.0, high=1.0, high_open=True)
        m = d.get("m")
        if m is not None:
            m = number_list(m, f"{path}.m", positive=True, high=2.0)
        for key, vals in (("C", C), ("b", b), ("m", m)):
            if vals is not None and len(vals) != n:
                raise FieldError(f"{path}.{key}", f"must have one value per opening ({n}), got {len(vals)}")
        return cls(opening, C, b, m)

    def to_dict(self):
        d = {"opening": list(self.opening), "C": list(self.C), "b": list(self.b)}
        if self.m is not None:
            d["m"] = list(self.m)
        return d

    @property
    def C_max(self):
        """Largest conductance of the table [m^3/(s Pa)]."""
        return max(self.C)

    @property
    def b_at_C_max(self):
        """Critical ratio at the largest conductance [-]."""
        return self.b[self.C.index(max(self.C))]


@dataclass
class Valve:
    """Directional control valve.

    Parameters
    ----------
    kind : str
        Valve kind: ``4/2`` (edges P-A, A-R, P-B, B-R; opening -1..1) or ``3/2`` (edges P-A,
        A-R; opening 0..1; chamber B at constant pressure) [-]
    ports : dict
        Metering edge tables (:class:`PortTable`) by edge name
    b_chamber_pressure : float or None
        3/2 mode: absolute pressure held in chamber B; None = half the supply pressure,
        as in the paper [Pa]
    flow_law : str
        Flow law, a name in :data:`pneucore.physics.flow.FLOW_LAWS`: ``iso6358`` (Eq. 4-5),
        ``saint_venant`` (Eq. 1-3), or a law added with
        :func:`pneucore.physics.flow.register_flow_law`; every valve edge of the compiled
        core computes its mass flow with it [-]
    laminar_ratio : float
        Pressure ratio above which edge flows are linearised [-]
    b_chamber : str
        3/2 mode: what is on chamber B, a name in :data:`B_CHAMBER_MODES`: ``held`` (at
        b_chamber_pressure), ``vented`` (at the ambient pressure), ``closed`` (an air spring) or
        ``restriction`` (vented through b_chamber_conductance) [-]
    b_chamber_conductance : float
        3/2 mode ``restriction``: sonic conductance C of the restriction between chamber B and
        the ambient (ISO 6358) [m^3/(s Pa)]
    b_chamber_critical_ratio : float
        3/2 mode ``restriction``: critical pressure ratio b of that restriction [-]
    on_time : float
        Switching time on energising, as solenoid-valve catalogues give it (ISO 12238): from
        the command to the spool's shift, for every command change to a position other than
        rest_opening; 0 = the valve shifts at the command [s]
    off_time : float
        Switching time on de-energising: from the command back to rest_opening to the spool's
        return (the spring's); with rest_opening null, on_time applies to every change [s]
    rest_opening : float or None
        Opening the valve rests at de-energised (a monostable valve's spring position: -1 for
        a 5/2 valve returning the rod, 0 for a 5/3 valve's centre or a normally closed 3/2);
        null = bistable (double solenoid: every change takes on_time) [-]
    """
    kind: str = "4/2"
    ports: dict = field(default_factory=dict)
    b_chamber_pressure: Optional[float] = None
    flow_law: str = "iso6358"
    laminar_ratio: float = R_LAMINAR
    b_chamber: str = "held"
    b_chamber_conductance: float = 0.0
    b_chamber_critical_ratio: float = 0.5
    on_time: float = 0.0
    off_time: float = 0.0
    rest_opening: Optional[float] = None

    @classmethod
    def from_dict(cls, d, path="valve"):
        mapping(d, path)
        known_keys(d, cls.__dataclass_fields__, path)
        kind = choice(d.get("kind", "4/2"), VALVE_KINDS, f"{path}.kind")
        spec = VALVE_KINDS[kind]
        ports_in = optional_mapping(d.get("ports"), f"{path}.ports")
        known_keys(ports_in, spec["ports"], f"{path}.ports")
        ports = {}
        for name in spec["ports"]:
            if name not in ports_in:
                raise FieldError(f"{path}.ports.{name}", f"is required for a {kind} valve")
            ports[name] = PortTable.from_dict(ports_in[name], f"{path}.ports.{name}", spec["range"])
        bcp = number(d.get("b_chamber_pressure"), f"{path}.b_chamber_pressure", positive=True,
                     allow_none=True)
        law = choice(d.get("flow_law", "iso6358"), FLOW_LAWS, f"{path}.flow_law")
        r_lam = number(d.get("laminar_ratio", R_LAMINAR), f"{path}.laminar_ratio", low=0.9,
                       high=1.0, high_open=True)
        dflt = cls          # the defaults are the dataclass's class attributes
        mode = choice(d.get("b_chamber", dflt.b_chamber), B_CHAMBER_MODES, f"{path}.b_chamber")
        b_C = number(d.get("b_chamber_conductance", dflt.b_chamber_conductance),
                     f"{path}.b_chamber_conductance", nonnegative=True)
        b_b = number(d.get("b_chamber_critical_ratio", dflt.b_chamber_critical_ratio),
                     f"{path}.b_chamber_critical_ratio", low=0.0, high=1.0, high_open=True)
        if mode != dflt.b_chamber and kind != "3/2":
            raise FieldError(f"{path}.b_chamber", f"{mode!r} only applies to a 3/2 valve (a "
                                                  f"{kind} valve drives chamber B itself)")
        if bcp is not None and mode != "held":
            raise FieldError(f"{path}.b_chamber_pressure",
                             f"chamber B is {mode}, not held at a pressure: leave it null [Pa]")
        if mode == "restriction" and b_C <= 0.0:
            raise FieldError(f"{path}.b_chamber_conductance",
                             "a restriction on chamber B needs its sonic conductance > 0 "
                             "[m^3/(s Pa)]")
        if mode != "restriction" and b_C != dflt.b_chamber_conductance:
            raise FieldError(f"{path}.b_chamber_conductance",
                             f"only with b_chamber 'restriction' (chamber B is {mode}) [m^3/(s Pa)]")
        on = number(d.get("on_time", dflt.on_time), f"{path}.on_time", nonnegative=True,
                    high=MAX_SWITCHING_TIME)
        off = number(d.get("off_time", dflt.off_time), f"{path}.off_time", nonnegative=True,
                     high=MAX_SWITCHING_TIME)
        rest = number(d.get("rest_opening"), f"{path}.rest_opening", allow_none=True,
                      low=spec["range"][0], high=spec["range"][1])
        return cls(kind, ports, bcp, law, r_lam, mode, b_C, b_b, on, off, rest)

    def to_dict(self):
        """Plain JSON; the chamber-B fields only when not at their defaults (the JSON of
        earlier versions round-trips unchanged)."""
        d = {"kind": self.kind, "ports": {k: p.to_dict() for k, p in self.ports.items()},
             "b_chamber_pressure": self.b_chamber_pressure, "flow_law": self.flow_law,
             "laminar_ratio": self.laminar_ratio}
        for key in ("b_chamber", "b_chamber_conductance", "b_chamber_critical_ratio",
                    "on_time", "off_time", "rest_opening"):
            if getattr(self, key) != getattr(Valve, key):
                d[key] = getattr(self, key)
        return d

    def core_ports(self):
        """The edge tables the compiled core integrates: :attr:`ports`, and on a 3/2 valve
        whose chamber B is vented through a restriction, a ``B-R`` edge of that constant
        conductance over the whole opening range (ISO 6358, Eq. 4-5)."""
        if self.kind != "3/2" or self.b_chamber != "restriction":
            return self.ports
        lo, hi = self.opening_range
        C, b = self.b_chamber_conductance, self.b_chamber_critical_ratio
        return {**self.ports, "B-R": PortTable([lo, hi], [C, C], [b, b])}

    @property
    def b_dynamic(self):
        """Chamber B has its own mass and energy balance (a 4/2 valve, or a 3/2 valve whose
        chamber B is closed or vented through a restriction) [-]."""
        return self.kind != "3/2" or B_CHAMBER_MODES[self.b_chamber]["dynamic"]

    @property
    def opening_range(self):
        """Valid command range ``(low, high)`` of this valve kind [-]."""
        return VALVE_KINDS[self.kind]["range"]


@dataclass
class Source:
    """A pressure node: supply or ambient.

    Parameters
    ----------
    pressure : float
        Absolute pressure [Pa]
    temperature : float
        Temperature [K]
    """
    pressure: float
    temperature: float = T_REF

    @classmethod
    def from_dict(cls, d, path, default_pressure):
        mapping(d, path)
        known_keys(d, ("pressure", "temperature"), path)
        p = number(d.get("pressure", default_pressure), f"{path}.pressure", positive=True)
        T = number(d.get("temperature", T_REF), f"{path}.temperature", positive=True)
        return cls(p, T)

    def to_dict(self):
        return {"pressure": self.pressure, "temperature": self.temperature}


class Heat:
    """Heat exchange model: a name in :data:`pneucore.physics.heat.HEAT_MODELS` and its parameters.

    Every parameter of :data:`pneucore.physics.heat.HEAT_PARAMETERS` is an attribute
    (its default when not given), so calibration paths ``heat.<parameter>``
    reach it; :meth:`to_dict` writes the model's own parameters (and
    ``coefficient``, kept for every model as before; the others when not at their default).

    Parameters
    ----------
    model : str
        Heat model, a name in :data:`pneucore.physics.heat.HEAT_MODELS` (isothermal, adiabatic,
        convective, natural_convection, natural_and_jet, or one registered; GET /api/heat-models
        lists them with their parameters) [-]
    coefficient : float
        Convection coefficient h of Eq. 9 [W/(m^2 K)]
    **params : float
        Other parameters of the model, in the units of :data:`pneucore.physics.heat.HEAT_PARAMETERS`
    """

    def __init__(self, model="convective", coefficient=HEAT_PARAMETERS["coefficient"].default,
                 **params):
        self.model = model
        for name, p in HEAT_PARAMETERS.items():
            setattr(self, name, float(params.pop(name, p.default)))
        self.coefficient = coefficient
        if params:
            raise TypeError(f"unknown heat parameters {sorted(params)}")

    @property
    def spec(self):
        """The registered :class:`pneucore.physics.heat.HeatModel`."""
        return HEAT_MODELS[self.model]

    @classmethod
    def from_dict(cls, d, path="heat"):
        mapping(d, path)
        model = choice(d.get("model", "convective"), HEAT_MODELS, f"{path}.model")
        # "coefficient" stays accepted whatever the model (the JSON of earlier versions)
        known_keys(d, tuple(dict.fromkeys(("model", "coefficient") + HEAT_MODELS[model].parameters)),
                   path)
        vals = {}
        for name, p in HEAT_PARAMETERS.items():
            vals[name] = number(d.get(name, p.default), f"{path}.{name}", low=p.min, high=p.max)
        return cls(model, **vals)

    def to_dict(self):
        """``model``, ``coefficient`` and the model's other parameters that differ from their
        defaults (so that the JSON of earlier versions round-trips unchanged)."""
        d = {"model": self.model, "coefficient": self.coefficient}
        for name in HEAT_MODELS[self.model].parameters:
            v = getattr(self, name)
            if name != "coefficient" and v != HEAT_PARAMETERS[name].default:
                d[name] = v
        return d

    def copy(self):
        return Heat(**self.__dict__)

    def __eq__(self, other):
        return isinstance(other, Heat) and self.__dict__ == other.__dict__

    def __repr__(self):
        return f"Heat({self.to_dict()!r})"


@dataclass
class FrictionSet:
    """Friction coefficients of one quadrant (Eq. 18-20, gauge pressures).

    Parameters
    ----------
    fc0 : float
        Constant Coulomb force [N]
    fc_a : float
        Coulomb force per gauge pressure in A (Eq. 20) [N/Pa]
    fc_b : float
        Coulomb force per gauge pressure in B (Eq. 20) [N/Pa]
    kv0 : float
        Constant viscous coefficient [N s/m]
    kv_a : float
        Viscous coefficient per gauge pressure in A (Eq. 19) [N s/(m Pa)]
    kv_b : float
        Viscous coefficient per gauge pressure in B (Eq. 19) [N s/(m Pa)]
    """
    fc0: float = 10.0
    fc_a: float = 0.0
    fc_b: float = 0.0
    kv0: float = 30.0
    kv_a: float = 0.0
    kv_b: float = 0.0

    @classmethod
    def from_dict(cls, d, path):
        mapping(d, path)
        known_keys(d, cls.__dataclass_fields__, path)
        out = cls()
        for key in cls.__dataclass_fields__:
            kw = {"nonnegative": True} if key in ("fc0", "kv0") else {}
            setattr(out, key, number(d.get(key, getattr(out, key)), f"{path}.{key}", **kw))
        return out

    def to_dict(self):
        return dict(self.__dict__)


@dataclass
class Friction:
    """Piston friction: extension (v > 0) and retraction (v < 0) sets, and the law's name.

    Parameters
    ----------
    extend : FrictionSet
        Coefficients while extending (v > 0)
    retract : FrictionSet
        Coefficients while retracting (v < 0); None = same as extend
    law : str
        Friction law, a name in :data:`pneucore.physics.friction.FRICTION_LAWS`
        (``coulomb_viscous``, or a law added with
        :func:`pneucore.physics.friction.register_friction_law`); the compiled core computes
        the sliding force and the static limit with it [-]
    """
    extend: FrictionSet = field(default_factory=FrictionSet)
    retract: FrictionSet = field(default_factory=FrictionSet)
    law: str = "coulomb_viscous"

    @classmethod
    def from_dict(cls, d, path="friction"):
        mapping(d, path)
        known_keys(d, ("extend", "retract", "law"), path)
        ext = FrictionSet.from_dict(d.get("extend", {}), f"{path}.extend")
        ret = FrictionSet.from_dict(d.get("retract", d.get("extend", {})), f"{path}.retract")
        law = choice(d.get("law", "coulomb_viscous"), FRICTION_LAWS, f"{path}.law")
        return cls(ext, ret, law)

    def to_dict(self):
        return {"extend": self.extend.to_dict(), "retract": self.retract.to_dict(), "law": self.law}


@dataclass
class Gas:
    """Ideal gas (Eq. 10-11).

    Parameters
    ----------
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]
    """
    r: float = R_AIR
    gamma: float = GAMMA_AIR

    @classmethod
    def from_dict(cls, d, path="gas"):
        mapping(d, path)
        known_keys(d, ("r", "gamma"), path)
        return cls(number(d.get("r", R_AIR), f"{path}.r", positive=True),
                   number(d.get("gamma", GAMMA_AIR), f"{path}.gamma", low=1.0, low_open=True, high=2.0))

    def to_dict(self):
        return {"r": self.r, "gamma": self.gamma}


@dataclass
class Model:
    """A complete actuator model: jack, valve, supply, ambient, heat, friction, effects.

    ``effects`` maps catalog effect names (:mod:`pneucore.description.effects`) to their
    parameters; an empty dict is the paper's base model.

    Parameters
    ----------
    jack : Jack
        Cylinder geometry and load
    valve : Valve
        Directional valve
    supply : Source
        Supply node (absolute pressure [Pa], temperature [K])
    ambient : Source
        Ambient/exhaust node (absolute pressure [Pa], temperature [K])
    heat : Heat
        Heat exchange model
    friction : Friction
        Piston friction (Eq. 18-20)
    effects : dict
        Catalog effects by name with their parameters (units in GET /api/effects)
    gas : Gas
        Ideal gas constants
    name : str
        Label
    description : str
        Free text
    notes : str
        Free text
    provenance : dict
        Where each identified value came from, by parameter path (``friction.extend.fc0``,
        ``valve.ports.P-A.C`` for an edge's table): ``{"source": "catalogue", "bench",
        "calibration" or "diagnosis", "stderr" (the parameter's unit, null when not known),
        "unit", "method", "note"}`` (:mod:`pneucore.description.provenance`); the valve and friction
        benches write theirs; a bench value is known to later fits unless a request's
        ``bench_known`` is false [-]
    """
    jack: Jack = field(default_factory=Jack)
    valve: Valve = field(default_factory=Valve)
    supply: Source = field(default_factory=lambda: Source(7e5))
    ambient: Source = field(default_factory=lambda: Source(P_ATM))
    heat: Heat = field(default_factory=Heat)
    friction: Friction = field(default_factory=Friction)
    effects: dict = field(default_factory=dict)
    gas: Gas = field(default_factory=Gas)
    name: str = ""
    description: str = ""
    notes: str = ""
    provenance: dict = field(default_factory=dict)

    @classmethod
    def from_dict(cls, d):
        """Build and validate a model from plain JSON (see the README for the shape)."""
        if isinstance(d, Model):
            return d.copy()
        mapping(d, "model")
        known_keys(d, ("jack", "valve", "supply", "ambient", "heat", "friction", "effects", "gas",
                       "name", "description", "notes", "provenance"), "")
        for key in ("jack", "valve"):
            if key not in d:
                raise FieldError(key, "is required")
        m = cls(
            jack=Jack.from_dict(d["jack"]),
            valve=Valve.from_dict(d["valve"]),
            supply=Source.from_dict(d.get("supply", {}), "supply", 7e5),
            ambient=Source.from_dict(d.get("ambient", {}), "ambient", P_ATM),
            heat=Heat.from_dict(d.get("heat", {})),
            friction=Friction.from_dict(d.get("friction", {})),
            effects=dict(optional_mapping(d.get("effects"), "effects")),
            gas=Gas.from_dict(d.get("gas", {})),
            name=str(d.get("name", "")),
            description=str(d.get("description", "")),
            notes=str(d.get("notes", "")),
            provenance=check_provenance(d.get("provenance")),
        )
        # A supply at or below the ambient pressure (a vessel filled from the atmosphere, a
        # vacuum line) is physics the flow laws hold for, in either direction; what they do not
        # hold for is rarefied gas (gas.P_CONTINUUM_MIN), and a 3/2 valve's chamber B at half a
        # supply that is no longer the high pressure
        for key, src in (("supply", m.supply), ("ambient", m.ambient)):
            if src.pressure < P_CONTINUUM_MIN:
                raise FieldError(f"{key}.pressure",
                                 f"{src.pressure:g} Pa is below {P_CONTINUUM_MIN:g} Pa, where air "
                                 f"through a valve is no longer a continuum (Knudsen number > 0.01)")
        if m.valve.kind == "3/2" and m.valve.b_chamber == "held" \
                and m.valve.b_chamber_pressure is None and m.supply.pressure <= m.ambient.pressure:
            raise FieldError("valve.b_chamber_pressure",
                             f"with a supply ({m.supply.pressure:g} Pa) at or below the ambient "
                             f"pressure ({m.ambient.pressure:g} Pa) the default chamber-B pressure "
                             f"of a 3/2 valve (half the supply) has no meaning: give it")
        if m.valve.b_chamber_pressure is not None and m.valve.kind != "3/2":
            raise FieldError("valve.b_chamber_pressure", "only applies to a 3/2 valve")
        from pneucore.description.effects import validate_effects
        m.effects = validate_effects(m.effects, m)
        return m

    def to_dict(self):
        """Plain JSON of the model (round-trips through :meth:`from_dict`)."""
        d = {"jack": self.jack.to_dict(), "valve": self.valve.to_dict(),
             "supply": self.supply.to_dict(), "ambient": self.ambient.to_dict(),
             "heat": self.heat.to_dict(), "friction": self.friction.to_dict(),
             "effects": copy.deepcopy(self.effects), "gas": self.gas.to_dict()}
        for key in ("name", "description", "notes"):
            if getattr(self, key):
                d[key] = getattr(self, key)
        if self.provenance:
            d["provenance"] = {k: dict(v) for k, v in self.provenance.items()}
        return d

    def copy(self):
        """Deep copy (written out: ``copy.deepcopy`` costs more than a simulation here)."""
        v = self.valve
        ports = {k: PortTable(list(p.opening), list(p.C), list(p.b), None if p.m is None else list(p.m))
                 for k, p in v.ports.items()}
        f = self.friction
        return Model(
            jack=Jack(**self.jack.__dict__),
            valve=Valve(v.kind, ports, v.b_chamber_pressure, v.flow_law, v.laminar_ratio,
                        v.b_chamber, v.b_chamber_conductance, v.b_chamber_critical_ratio,
                        v.on_time, v.off_time, v.rest_opening),
            supply=Source(**self.supply.__dict__), ambient=Source(**self.ambient.__dict__),
            heat=self.heat.copy(),
            friction=Friction(FrictionSet(**f.extend.__dict__), FrictionSet(**f.retract.__dict__), f.law),
            effects={k: dict(p) for k, p in self.effects.items()},
            gas=Gas(**self.gas.__dict__), name=self.name, description=self.description,
            notes=self.notes, provenance={k: dict(v) for k, v in self.provenance.items()})

    @property
    def b_chamber_pressure(self):
        """Constant chamber-B pressure in 3/2 mode [Pa] (half the supply by default, the ambient
        pressure when vented), else None (a 4/2 valve, or a 3/2 valve whose chamber B is a gas
        volume: closed or vented through a restriction)."""
        if self.valve.b_dynamic:
            return None
        if self.valve.b_chamber == "vented":
            return self.ambient.pressure
        if self.valve.b_chamber_pressure is not None:
            return self.valve.b_chamber_pressure
        return 0.5 * self.supply.pressure



def _mechanical_coefficients(model):
    """``(Kv_max [N s/m], k_max [N/m])``: the largest viscous coefficient and gas stiffness."""
    j, f = model.jack, model.friction
    dp = model.supply.pressure - model.ambient.pressure
    kv = max(max(s.kv0 + max(s.kv_a, 0.0) * dp + max(s.kv_b, 0.0) * dp, 0.0)
             for s in (f.extend, f.retract))
    k = max(model.gas.gamma * model.supply.pressure * area ** 2 / v0
            for area, v0 in ((j.area_a, j.dead_volume_a), (j.area_b, j.dead_volume_b)))
    return kv, k


def mechanical_time_constant(model):
    """Shortest time constant of the piston's motion, from the model's own numbers [s].

    Two time scales bound how fast the velocity can change (Eq. 17-19):

    * viscous: ``m / Kv_max``, with ``Kv_max`` the largest viscous coefficient of
      Eq. 19 (either quadrant, both chambers at the supply pressure);
    * pneumatic: ``sqrt(m / k_max)``, with ``k_max = gamma p_s A^2 / V_0`` the stiffest
      gas spring (a chamber at the supply pressure compressed to its dead volume,
      adiabatic index gamma).

    Parameters
    ----------
    model : Model
        A validated model

    Returns
    -------
    tau : float
        The smaller of the two [s]
    """
    import math
    kv, k = _mechanical_coefficients(model)
    m = model.jack.moving_mass
    return min(m / kv, math.sqrt(m / k)) if kv > 0.0 else math.sqrt(m / k)



def check_resolvable(model, rtol, max_step, path="jack.moving_mass"):
    """Refuse a moving mass too light for the integrator to resolve at tolerance ``rtol``.

    The velocity follows the net force with the mechanical time constant
    ``tau`` (:func:`mechanical_time_constant`). The integrator's error control
    sees that fast mode only while its transient spans at least the fraction
    ``rtol`` of the longest step ``max_step``; a shorter one is stepped over by
    steps sized for the chambers, with a Jacobian the fast mode makes
    inaccurate, and the run ends "ok" with a wrong velocity (1e-9 kg: 145 m/s
    where a tight solve gives 2.03 m/s). Hence the bound
    ``tau >= rtol * max_step``, i.e. ``m >= max(Kv_max tau, k_max tau^2)``:
    5e-7 s and 0.05 g for the paper's jack at the defaults (rtol 1e-5,
    max_step 0.05 s). Measured on the Fig. 10 pulses (error of x and peak |v|
    against rtol 1e-9, in units of rtol): at ``tau`` = 0.7 x the bound 1.2
    (rtol 1e-5), 3.1 (1e-4), 2.4 (1e-3); at 0.02 x the bound 98, 100, 32.

    Parameters
    ----------
    model : Model
        A validated model
    rtol : float
        Relative tolerance of the run [-]
    max_step : float
        Longest integration step of the run [s]
    path : str
        Field named in the error
    """
    tau = mechanical_time_constant(model)
    need = rtol * max_step
    if tau < need:
        kv, k = _mechanical_coefficients(model)
        m_min = max(kv * need, k * need ** 2)
        raise FieldError(path, f"moving mass {model.jack.moving_mass:g} kg gives a mechanical time "
                               f"constant of {tau:.3g} s, below the {need:.3g} s the solver resolves "
                               f"(rtol x max_step = {rtol:g} x {max_step:g} s); use at least "
                               f"{m_min:.3g} kg, or a smaller scenario.solver.rtol or max_step")
