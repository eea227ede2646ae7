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


class FrictionLaw:
    """A registered friction law (name, description)."""

    def __init__(self, name, description):
        self.name = name
        self.description = description


#: Friction laws the model can name; the catalog effect ``stribeck_friction``
#: switches the breakaway term on.
FRICTION_LAWS = {
    "coulomb_viscous": FrictionLaw("coulomb_viscous",
                                   "Coulomb + viscous, pressure and quadrant dependent (Eq. 18-20)"),
}
