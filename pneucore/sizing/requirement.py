"""What a sizing is asked for: the required motion (:class:`Requirement`) and what may vary
(:class:`Choices`), both from plain JSON with every field checked.

A bad field raises one :class:`~pneucore.description.validation.FieldError` naming its path
(``requirement.stroke``) and its unit. The angle becomes the model's ``jack.mounting_angle``
and the tube its ``tubing`` effect (:func:`pneucore.sizing.search.build_model`).
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Optional

from pneucore.physics.gas import P_ATM
from pneucore.physics.jack import ANGLE_MAX
from pneucore.description.effects import EFFECTS
from pneucore.description.model import MAX_SWITCHING_TIME
from pneucore.description.validation import FieldError, known_keys, mapping, number

#: Upper bounds of the requirement's fields, in their units: well beyond any pneumatic drive
#: (ISO 15552 cylinders are rated 10 bar, strokes of a few metres), they keep a mistyped
#: number from asking the simulator for nonsense
BOUNDS = {"stroke": 10.0, "moving_mass": 1e5, "load_force": 1e7, "supply_pressure": 5e6,
          "extend_time": 600.0, "retract_time": 600.0, "cycle_time": 1200.0, "dwell": 600.0,
          "max_end_speed": 100.0, "max_end_energy": 1e6,
          "ambient_pressure": 5e6,
          # the tube's and the cushion's: the tubing and end_cushion effects' own bounds (the
          # one source: a design's model carries them, and a longer line would be refused there)
          "tube_length": EFFECTS["tubing"].param("length_a").max,
          "cushion_length": EFFECTS["end_cushion"].param("length_a").max,
          "cushion_capacity": EFFECTS["end_cushion"].param("capacity").max,
          "valve_on_time": MAX_SWITCHING_TIME, "valve_off_time": MAX_SWITCHING_TIME}


#: Highest load factor accepted (the load as large as the theoretical output: the cylinder
#: stalls) [-]; highest buckling safety factor accepted [-]
MAX_LOAD_FACTOR = 1.0
MAX_BUCKLING_SAFETY = 100.0
#: Two bores closer than this are the same bore (a table's 0.016 and a series' 16 mm) [m]
BORE_MATCH = 1e-6
#: Most entries of cushion_capacities [-]
MAX_CAPACITY_ENTRIES = 200


def _capacities(value, path, cushion_length):
    """``cushion_capacities`` checked: a list of ``{"bore", "capacity", "series"}``."""
    if value is None:
        return []
    if not isinstance(value, (list, tuple)):
        raise FieldError(path, f"must be a list of {{bore [m], capacity [J], series}}, got "
                               f"{type(value).__name__} (unit: -)")
    if value and cushion_length is None:
        raise FieldError(path, "per-bore capacities need the cushion: give cushion_length "
                               "(unit: -)")
    if len(value) > MAX_CAPACITY_ENTRIES:
        raise FieldError(path, f"{len(value)} entries, more than {MAX_CAPACITY_ENTRIES} (unit: -)")
    out, seen = [], {}
    for i, e in enumerate(value):
        p = f"{path}[{i}]"
        mapping(e, p)
        known_keys(e, ("bore", "capacity", "series"), p)
        for key in ("bore", "capacity"):
            if e.get(key) is None:
                raise FieldError(f"{p}.{key}", f"is required (unit: {'m' if key == 'bore' else 'J'})")
        bore = _checked(e["bore"], f"{p}.bore", "m", positive=True, high=1.0)
        cap = _checked(e["capacity"], f"{p}.capacity", "J", positive=True,
                       high=BOUNDS["cushion_capacity"])
        series = e.get("series")
        if series is not None and (not isinstance(series, str) or not series.strip()):
            raise FieldError(f"{p}.series", f"must be a series name (iso6432), got {series!r} "
                                            "(unit: -)")
        key = (series, round(bore / BORE_MATCH))
        if key in seen:
            raise FieldError(f"{p}.bore", f"{bore:g} m{' of ' + series if series else ''} is "
                                          f"already given in entry {seen[key]} (unit: m)")
        seen[key] = i
        out.append({"bore": bore, "capacity": cap, "series": series})
    return out


def _checked(value, path, unit, **bounds):
    """``number(value, path, **bounds)`` whose error also states the unit; the field's upper
    bound is :data:`BOUNDS`'s."""
    name = path.rsplit(".", 1)[-1]
    if name in BOUNDS:
        bounds["high"] = BOUNDS[name]
        if name == "load_force":
            bounds["low"] = -BOUNDS[name]
    try:
        return number(value, path, **bounds)
    except FieldError as exc:
        raise FieldError(path, f"{exc.detail} (unit: {unit})") from None


@dataclass
class Requirement:
    """The motion a drive must make: load, stroke, mounting, supply and the times allowed.

    Parameters
    ----------
    stroke : float
        Stroke [m]
    moving_mass : float
        Moving mass: load, piston and rod [kg]
    load_force : float
        External force against the extension, pushing the rod in (towards x = 0), gravity
        excluded; negative pulls the rod out [N]
    angle : float
        Mounting angle from the horizontal, -90 to 90: 90 = vertical rod up (the extension
        lifts the load), -90 = vertical rod down [deg]
    supply_pressure : float
        Absolute supply pressure at the valve [Pa]
    extend_time : float or None
        Full-stroke extension time allowed, from the valve's command to the end stop;
        required unless cycle_time is given [s]
    retract_time : float or None
        Full-stroke retraction time allowed, from the valve's command to the end stop;
        required unless cycle_time is given [s]
    cycle_time : float or None
        Time of one whole cycle (extension, dwell, retraction, dwell), instead of extend_time
        and retract_time: each family's time to move, cycle_time less both dwells, is shared
        between its two strokes in proportion to their fully open times (both slowed by the
        same factor); null = the two times given [s]
    dwell : float
        Time held at each end stop within cycle_time (twice per cycle) [s]
    max_end_speed : float or None
        Largest piston speed allowed at either end stop (what the cushion or the stop absorbs);
        null = no limit [m/s]
    max_end_energy : float or None
        Largest kinetic energy of the moving mass allowed at either end stop, checked as it is
        (a cushion's capacity goes in cushion_capacity instead, for which the needles are
        solved); null = no limit [J]
    cushion_length : float or None
        Length of the adjustable end cushion at each end of the cylinder (the spear's travel
        in the cushion seal, a catalogue figure); the search solves each end's cushion needle
        for the impact energy to be within the cylinder's cushion capacity; null = no cushion
        (a series' rubber bumper, where its catalogue gives one, then limits the impact
        energy) [m]
    cushion_capacity : float or None
        Kinetic energy the cushion absorbs at most (the catalogue's cushioning energy), for
        a cylinder whose capacity neither ``cushion_capacities`` nor its series' catalogue
        gives; read with cushion_length only; null = none (such a cylinder is then refused
        with the reason ``cushion``) [J]
    cushion_capacities : list
        Each bore's own cushion capacity, as its catalogue gives it (SMC and Festo publish the
        allowable kinetic energy per bore and cushion): entries ``{"bore": [m], "capacity":
        [J]}``, optionally ``"series"`` (a cylinder series name, ``iso6432``; absent = every
        series with that bore). A family's cylinder takes the entry of its series and bore,
        else the series-less entry of its bore, else its series' catalogue figure (the shipped
        ``smc-cm2``, ``smc-ca2``), else cushion_capacity; needs the cushion (cushion_length)
        [-]
    tube_length : float or None
        Length of the tube between the valve and each cylinder port; null = valve on the
        cylinder [m]
    ambient_pressure : float
        Absolute ambient (exhaust) pressure [Pa]
    valve_on_time : float
        The valve's switching time energising, as its catalogue gives it (ISO 12238): the
        extension starts this long after the command; it counts in the extension's time [s]
    valve_off_time : float
        The valve's switching time de-energising (the 5/2 valve's spring return): the
        retraction starts this long after the command; it counts in the retraction's time [s]
    max_load_factor : float
        Largest load factor a design may have: the static load a stroke works against over
        the cylinder's theoretical output at the supply, (p_s - p_atm) A. SMC's selection
        limits: 0.5 moving a load (the default), 0.7 static (clamping), 1.0 a load carried on
        a guide; a family above it is rejected with the reason load_factor [-]
    min_buckling_safety : float
        Smallest safety factor of the rod against Euler buckling over the stroke (steel rod,
        one end fixed and the rod end free) at the extension's theoretical output; a family
        below it is rejected with the reason buckling [-]
    """
    stroke: float = 0.1
    moving_mass: float = 1.0
    load_force: float = 0.0
    angle: float = 0.0
    supply_pressure: float = 7e5
    extend_time: Optional[float] = None
    retract_time: Optional[float] = None
    cycle_time: Optional[float] = None
    dwell: float = 0.0
    max_end_speed: Optional[float] = None
    max_end_energy: Optional[float] = None
    cushion_length: Optional[float] = None
    cushion_capacity: Optional[float] = None
    tube_length: Optional[float] = None
    ambient_pressure: float = P_ATM
    valve_on_time: float = 0.0
    valve_off_time: float = 0.0
    cushion_capacities: list = field(default_factory=list)
    max_load_factor: float = 0.5
    min_buckling_safety: float = 3.0

    #: fields a request must give (the others have their defaults)
    REQUIRED = ("stroke", "moving_mass", "supply_pressure")
    #: the times a request gives: both of these, or cycle_time (with its dwell)
    TIMES = ("extend_time", "retract_time")
    #: unit of each field, read once from the docstring above (the one source)
    UNITS = {}

    @classmethod
    def from_dict(cls, d, path="requirement"):
        """Check a requirement given as plain JSON.

        Parameters
        ----------
        d : dict
            The requirement's fields (see the class docstring)
        path : str
            Field path named in errors

        Returns
        -------
        requirement : Requirement
        """
        if isinstance(d, Requirement):
            d = d.to_dict()
        mapping(d, path)
        known_keys(d, [f.name for f in fields(cls)], path)
        for key in cls.REQUIRED:
            if d.get(key) is None:
                raise FieldError(f"{path}.{key}", f"is required (unit: {cls.unit(key)})")
        r = cls()
        u = cls.unit
        r.stroke = _checked(d["stroke"], f"{path}.stroke", u("stroke"), positive=True)
        r.moving_mass = _checked(d["moving_mass"], f"{path}.moving_mass", u("moving_mass"),
                                 positive=True)
        r.load_force = _checked(d.get("load_force", r.load_force), f"{path}.load_force",
                                u("load_force"))
        r.angle = _checked(d.get("angle", r.angle), f"{path}.angle", u("angle"), low=-ANGLE_MAX,
                           high=ANGLE_MAX)
        r.ambient_pressure = _checked(d.get("ambient_pressure", r.ambient_pressure),
                                      f"{path}.ambient_pressure", u("ambient_pressure"),
                                      positive=True)
        r.supply_pressure = _checked(d["supply_pressure"], f"{path}.supply_pressure",
                                     u("supply_pressure"), low=r.ambient_pressure, low_open=True)
        if d.get("cycle_time") is None:
            for key in cls.TIMES:
                if d.get(key) is None:
                    raise FieldError(f"{path}.{key}", f"is required, or cycle_time instead of "
                                                      f"both (unit: {u(key)})")
            r.extend_time = _checked(d["extend_time"], f"{path}.extend_time", u("extend_time"),
                                     positive=True)
            r.retract_time = _checked(d["retract_time"], f"{path}.retract_time",
                                      u("retract_time"), positive=True)
            if d.get("dwell") not in (None, 0, 0.0):
                raise FieldError(f"{path}.dwell", "is read with cycle_time only (unit: s)")
        else:
            given = [k for k in cls.TIMES if d.get(k) is not None]
            if given:
                raise FieldError(f"{path}.{given[0]}", "give cycle_time or extend_time and "
                                                       "retract_time, not both (unit: s)")
            r.cycle_time = _checked(d["cycle_time"], f"{path}.cycle_time", u("cycle_time"),
                                    positive=True)
            r.dwell = _checked(d.get("dwell", r.dwell), f"{path}.dwell", u("dwell"),
                               nonnegative=True)
            if r.motion_time <= 0.0:
                raise FieldError(f"{path}.dwell", f"two dwells of {r.dwell:g} s leave no time to "
                                                  f"move in a cycle of {r.cycle_time:g} s "
                                                  f"(unit: {u('dwell')})")
        r.max_end_speed = None if d.get("max_end_speed") is None else _checked(
            d["max_end_speed"], f"{path}.max_end_speed", u("max_end_speed"), positive=True)
        r.max_end_energy = None if d.get("max_end_energy") is None else _checked(
            d["max_end_energy"], f"{path}.max_end_energy", u("max_end_energy"), positive=True)
        for key in ("cushion_length", "cushion_capacity"):
            setattr(r, key, None if d.get(key) is None else _checked(
                d[key], f"{path}.{key}", u(key), positive=True))
        if r.cushion_capacity is not None and r.cushion_length is None:
            # a capacity with no cushion to hold it: the cushion's length makes the cushion
            raise FieldError(f"{path}.cushion_length", "is required with cushion_capacity "
                                                       f"(unit: {u('cushion_length')})")
        if r.cushion_length is not None and 2.0 * r.cushion_length > r.stroke:
            raise FieldError(f"{path}.cushion_length",
                             f"{r.cushion_length:g} m at each end: the two cushions overlap on a "
                             f"stroke of {r.stroke:g} m (unit: {u('cushion_length')})")
        r.tube_length = None if d.get("tube_length") is None else _checked(
            d["tube_length"], f"{path}.tube_length", u("tube_length"), positive=True)
        for key in ("valve_on_time", "valve_off_time"):
            setattr(r, key, _checked(d.get(key, 0.0), f"{path}.{key}", u(key), nonnegative=True))
        r.max_load_factor = _checked(d.get("max_load_factor", r.max_load_factor),
                                     f"{path}.max_load_factor", u("max_load_factor"),
                                     positive=True, high=MAX_LOAD_FACTOR)
        r.min_buckling_safety = _checked(d.get("min_buckling_safety", r.min_buckling_safety),
                                         f"{path}.min_buckling_safety",
                                         u("min_buckling_safety"), low=1.0,
                                         high=MAX_BUCKLING_SAFETY)
        r.cushion_capacities = _capacities(d.get("cushion_capacities"),
                                           f"{path}.cushion_capacities", r.cushion_length)
        return r

    def capacity_for(self, cylinder):
        """The cushion capacity of one cylinder [J]: its series' and bore's entry of
        ``cushion_capacities``, else its bore's series-less entry, else its series'
        catalogue figure (the cylinder's ``cushion_capacity``), else ``cushion_capacity``
        (None without a cushion, or where none of these gives one).

        Parameters
        ----------
        cylinder : dict
            ``bore`` [m], ``name`` (``series:member`` for a shipped one) and, for a member of
            a series whose catalogue gives it, ``cushion_capacity`` [J]

        Returns
        -------
        capacity, source : float or None, str
            The capacity [J] and where it comes from (``cushion_capacities[i]``, ``catalogue
            <series>`` or ``cushion_capacity``; ``none`` where nothing gives one)
        """
        if self.cushion_length is None:
            return None, "no cushion"
        name = str(cylinder.get("name") or "")
        series = name.split(":", 1)[0] if ":" in name else None
        for want in (series, None):
            for i, e in enumerate(self.cushion_capacities):
                if e.get("series") == want and abs(e["bore"] - cylinder["bore"]) <= BORE_MATCH:
                    if want is None or series is not None:
                        return e["capacity"], f"cushion_capacities[{i}]"
        if cylinder.get("cushion_capacity") is not None:
            return cylinder["cushion_capacity"], f"catalogue {cylinder.get('series') or series}"
        if self.cushion_capacity is not None:
            return self.cushion_capacity, "cushion_capacity"
        return None, "none"

    def to_dict(self):
        """Plain JSON (round-trips through :meth:`from_dict`)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @property
    def motion_time(self):
        """Time to move in one cycle: cycle_time less both dwells [s]; None without cycle_time."""
        return None if self.cycle_time is None else self.cycle_time - 2.0 * self.dwell

    def time_bound(self, direction):
        """The longest one stroke may take [s]: its required time, or with cycle_time the
        whole time to move (the share each family gets is at most that)."""
        if self.cycle_time is not None:
            return self.motion_time
        return self.extend_time if direction == "extend" else self.retract_time

    @classmethod
    def unit(cls, name):
        """The unit of field ``name`` as its docstring states it (``m``, ``Pa``, ...)."""
        if not cls.UNITS:
            from pneucore.description.docstrings import field_docs
            for key, text in field_docs(cls).items():
                cls.UNITS[key] = text.rsplit("[", 1)[-1].rstrip("]") if text.endswith("]") else "-"
        return cls.UNITS[name]


@dataclass
class Choices:
    """What the search may vary; each list holds series names, member names or values.

    Parameters
    ----------
    bore : list
        Cylinders: a series name (``iso15552``, ``iso6432``), a member (``iso15552:50``) or
        ``{"bore": [m], "rod": [m]}``; empty = every shipped cylinder series [-]
    valve : list
        Valves: a series name (``ckd-4ga``, ``ckd-4gb``), a member (``ckd-4ga:M4GA2``) or
        ``{"C": [m^3/(s Pa)], "b": [-]}`` (optionally ``C_exhaust``, ``b_exhaust``, ``name``),
        or instead of C a catalogue's figure with its b: ``{"qn": [NL/min], "b": [-]}``,
        ``{"effective_area": [m^2], "b": [-]}`` or one flow point (``flow_rate`` [m^3/s],
        ``p1``, ``p2`` [Pa]); empty = every shipped valve series [-]
    tube_inner_diameter : list
        Tube inner diameters when a tube length is given: a series name (``pu-tube``), a
        member (``pu-tube:TU0604``) or a value [m]; empty = the shipped tube series [-]
    meter_out : bool
        Whether a meter-out flow control may slow each direction down to its required time
        (its throttle's conductance solved for); false = valves fully open only [-]
    min_meter_out : float
        Smallest meter-out throttle tried: its sonic conductance as a fraction of the valve's
        exhaust conductance [-]
    """
    bore: list = field(default_factory=list)
    valve: list = field(default_factory=list)
    tube_inner_diameter: list = field(default_factory=list)
    meter_out: bool = True
    min_meter_out: float = 0.02

    @classmethod
    def from_dict(cls, d, path="choices"):
        """Check the choices given as plain JSON (series names are resolved by the search).

        Parameters
        ----------
        d : dict or None
            The choices; None = the defaults
        path : str
            Field path named in errors

        Returns
        -------
        choices : Choices
        """
        if d is None:
            return cls()
        if isinstance(d, Choices):
            d = d.to_dict()
        mapping(d, path)
        known_keys(d, [f.name for f in fields(cls)], path)
        c = cls()
        for key in ("bore", "valve", "tube_inner_diameter"):
            v = d.get(key, [])
            if v is None:
                v = []
            if not isinstance(v, (list, tuple)):
                v = [v]
            setattr(c, key, list(v))
        mo = d.get("meter_out", c.meter_out)
        if not isinstance(mo, bool):
            raise FieldError(f"{path}.meter_out", f"must be true or false, got {mo!r}")
        c.meter_out = mo
        c.min_meter_out = number(d.get("min_meter_out", c.min_meter_out), f"{path}.min_meter_out",
                                 low=1e-4, high=1.0)
        return c

    def to_dict(self):
        """Plain JSON (round-trips through :meth:`from_dict`)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}
