"""Piston friction: Coulomb plus viscous, pressure and quadrant dependent (paper Eq. 18-20).

When sliding, ``F = Kv(p) v + Fc(p) sign(v)`` (Eq. 18) with
``Fc = fc0 + fc_a (p_a - p_atm) + fc_b (p_b - p_atm)`` and
``Kv = kv0 + kv_a (p_a - p_atm) + kv_b (p_b - p_atm)`` (Eq. 19-20, written on
gauge pressures with a constant term), one coefficient set for extension
(``v > 0``) and one for retraction (``v < 0``): the quadrant effect. At rest
the piston sticks while the net force stays within the static limit, the
value of the Coulomb term at ``v = 0`` (times the Stribeck ratio when that
effect is on). There is no smoothing: stick and slip are events.
"""
import math

from numba import njit

from pneucore.physics.flow import compiled, register_law, unregister_law


@njit(cache=True, error_model="numpy")
def coulomb_level(fc0, fc_a, fc_b, p_a, p_b, p_atm):
    """Coulomb friction level ``Fc(p)`` (Eq. 20), clipped at zero [N].

    Parameters
    ----------
    fc0 : float
        Constant part [N]
    fc_a, fc_b : float
        Pressure coefficients [N/Pa]
    p_a, p_b : float
        Chamber pressures [Pa]
    p_atm : float
        Ambient pressure [Pa]
    """
    f = fc0 + fc_a * (p_a - p_atm) + fc_b * (p_b - p_atm)
    return f if f > 0.0 else 0.0


@njit(cache=True, error_model="numpy")
def viscous_coefficient(kv0, kv_a, kv_b, p_a, p_b, p_atm):
    """Viscous coefficient ``Kv(p)`` (Eq. 19), clipped at zero [N s/m]."""
    k = kv0 + kv_a * (p_a - p_atm) + kv_b * (p_b - p_atm)
    return k if k > 0.0 else 0.0


@njit(cache=True, error_model="numpy")
def stribeck_factor(v, ratio, v_s):
    """Breakaway factor ``1 + (ratio - 1) exp(-(v / v_s)^2)`` multiplying Fc [-].

    ``ratio = Fs / Fc``; 1 gives plain Coulomb friction (paper Fig. 4 found no
    Stribeck effect on its jack).

    Parameters
    ----------
    v : float
        Velocity [m/s]
    ratio : float
        Static over Coulomb friction [-]
    v_s : float
        Stribeck velocity [m/s]
    """
    if ratio == 1.0 or v_s <= 0.0:
        return 1.0
    z = v / v_s
    return 1.0 + (ratio - 1.0) * math.exp(-z * z)


@njit(cache=True, error_model="numpy")
def sliding_friction(v, direction, fc, kv, ratio, v_s):
    """Friction force opposing a sliding piston, Eq. 18 [N].

    Parameters
    ----------
    v : float
        Velocity [m/s]
    direction : float
        +1 while sliding towards +x, -1 towards -x
    fc : float
        Coulomb level of the active quadrant [N]
    kv : float
        Viscous coefficient of the active quadrant [N s/m]
    ratio, v_s : float
        Stribeck ratio [-] and velocity [m/s]

    Returns
    -------
    F : float
        Friction force, counted positive towards -x [N]
    """
    return kv * v + direction * fc * stribeck_factor(v, ratio, v_s)


@njit(cache=True, error_model="numpy")
def breakaway_friction(fc, ratio, v_s):
    """Static friction limit of a resting piston, the Coulomb level times the Stribeck ratio [N].

    The piston stays at rest while the net force is within this limit (Eq. 18 at
    ``v = 0``, with the breakaway term of :func:`stribeck_factor`).

    Parameters
    ----------
    fc : float
        Coulomb level of the quadrant the piston would move in [N]
    ratio : float
        Static over Coulomb friction [-] (1 = no breakaway term)
    v_s : float
        Stribeck velocity [m/s] (unused here; part of the laws' signature)

    Returns
    -------
    Fs : float
        Static limit [N]

    Examples
    --------
    >>> breakaway_friction(40.0, 1.5, 0.01)
    60.0
    """
    return fc * ratio


class FrictionLaw:
    """A registered friction law: its compiled force and static limit, and its code in the core.

    The core computes the Coulomb level ``Fc(p)`` and the viscous coefficient
    ``Kv(p)`` of the active quadrant from the model's friction sets (Eq. 19-20,
    :func:`coulomb_level`, :func:`viscous_coefficient`); the law turns them into
    forces.

    Parameters
    ----------
    name : str
        Registry name (``friction.law``)
    description : str
        One line: the equation and its source
    code : int
        Integer the compiled core selects the law by (parameter slot
        ``layout.P_FRICTION_LAW``)
    force : numba dispatcher
        ``force(v, direction, fc, kv, ratio, v_s) -> F``: friction on a sliding
        piston, counted positive towards -x [N] (arguments as :func:`sliding_friction`)
    static : numba dispatcher
        ``static(fc, ratio, v_s) -> Fs``: the static limit of a resting piston [N]
        (arguments as :func:`breakaway_friction`)
    builtin : bool
        Part of the package: compiled into the core that numba caches on disk
    """

    def __init__(self, name, description, code=0, force=sliding_friction,
                 static=breakaway_friction, builtin=False):
        self.name = name
        self.description = description
        self.code = code
        self.force = force
        self.static = static
        self.builtin = builtin

    def core_entry(self):
        """``(code, force, static)``: this law's entry in the core's dispatch table
        (:data:`pneucore.core.rhs.friction_laws`)."""
        return (self.code, self.force, self.static)


#: Friction laws the model can name (``friction.law``); the compiled core dispatches on
#: their codes (:func:`pneucore.core.rhs.friction_force`). The catalog effect
#: ``stribeck_friction`` switches the breakaway term on.
FRICTION_LAWS = {
    "coulomb_viscous": FrictionLaw("coulomb_viscous",
                                   "Coulomb + viscous, pressure and quadrant dependent (Eq. 18-20)",
                                   0, sliding_friction, breakaway_friction, builtin=True),
}


def _static_from_force(force):
    """A static limit for a law given only its force: the force at ``v = 0`` towards +x."""
    @njit(error_model="numpy")
    def static(fc, ratio, v_s):
        return abs(force(0.0, 1.0, fc, 0.0, ratio, v_s))
    return static


def register_friction_law(name, force, static=None, description="", replace=False):
    """Add a friction law that a model selects by name (``friction.law``).

    The law is compiled into the simulator's core: the first :func:`pneucore.simulate`
    of a model naming it compiles a core for the registry as it stands, in memory:
    about as long as the core's first compile (12 s of CPU time on a shared 2-core
    machine), once per process and set of registered laws and user effects. Models
    naming only built-in laws keep the core numba caches on disk.

    Parameters
    ----------
    name : str
        Registry name
    force : callable
        ``force(v, direction, fc, kv, ratio, v_s) -> F`` [N], arguments as
        :func:`sliding_friction`; a numba ``@njit`` function or plain Python that numba
        can compile (it is compiled here). It must not allocate arrays.
    static : callable or None
        ``static(fc, ratio, v_s) -> Fs`` [N], the static limit (as
        :func:`breakaway_friction`); None: ``|force(0, +1, fc, 0, ratio, v_s)|``
    description : str
        One line: the equation and its source
    replace : bool
        Allow replacing a law registered at run time (a built-in law cannot be replaced)

    Returns
    -------
    law : FrictionLaw
        The registered entry

    Examples
    --------
    Twice the Coulomb + viscous law (a tighter seal):

    >>> @njit
    ... def double_force(v, direction, fc, kv, ratio, v_s):
    ...     return 2.0 * sliding_friction(v, direction, fc, kv, ratio, v_s)
    >>> law = register_friction_law("double", double_force, description="2 x Eq. 18")
    >>> law.static(40.0, 1.0, 0.01)
    80.0
    >>> unregister_friction_law("double")
    """
    def make(code):
        f = compiled(force, f"friction law {name!r}: force")
        s = compiled(static, f"friction law {name!r}: static") if static is not None \
            else _static_from_force(f)
        return FrictionLaw(name, description, code, f, s)
    return register_law(FRICTION_LAWS, name, replace, make)


def unregister_friction_law(name):
    """Remove a friction law registered with :func:`register_friction_law` (a built-in law stays)."""
    unregister_law(FRICTION_LAWS, name, "friction law")
