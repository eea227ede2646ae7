"""Compressible flow through a restriction: the ISO 6358 law and the ideal nozzle.

Each law is a small pure function with one signature,
``law(p1, T1, p2, T2, C, b, m, r_lam, r, gamma) -> q``, the mass flow [kg/s]
from side 1 to side 2 (negative when side 2 is upstream). They are compiled
with numba so the simulator core calls them directly; they also work on
scalars from plain Python. :data:`FLOW_LAWS` is the registry the model picks
from by name (``valve.flow_law``).

Both laws have an infinite slope ``dq/dp_d`` as the pressure ratio tends to 1,
which would make the chamber equations infinitely stiff near equilibrium.
Above the ratio ``r_lam`` (0.999 by default) the flow is replaced by a
laminar linearisation ``q = q(r_lam) (1 - r) / (1 - r_lam)``: continuous in
value at ``r_lam`` and zero at ``r = 1``.
"""
import math

import numpy as np
from numba import njit

from pneucore.physics.gas import GAMMA_AIR, PSI, R_AIR, RHO_REF, T_REF

#: Default pressure ratio above which the flow is linearised (laminar) [-]
R_LAMINAR = 0.999


@njit(cache=True, error_model="numpy")
def iso6358_ratio_function(ratio, b, m):
    """Dimensionless flow function of ISO 6358 (paper Eq. 4-5).

    ``phi = 1`` for ``ratio <= b`` (choked, Eq. 5) and
    ``phi = [1 - ((ratio - b) / (1 - b))^2]^m`` above (subsonic, Eq. 4 when
    ``m = 0.5``; ISO 6358-1:2013 allows other subsonic indices ``m``).

    Parameters
    ----------
    ratio : float
        Downstream over upstream absolute pressure [-]
    b : float
        Critical pressure ratio [-]
    m : float
        Subsonic index [-]
    """
    if ratio <= b:
        return 1.0
    z = (ratio - b) / (1.0 - b)
    w = 1.0 - z * z
    if w <= 0.0:
        return 0.0
    if m == 0.5:
        return math.sqrt(w)
    return w ** m


@njit(cache=True, error_model="numpy")
def _iso_phi_linearised(ratio, b, m, r_lam):
    if ratio <= r_lam:
        return iso6358_ratio_function(ratio, b, m)
    return iso6358_ratio_function(r_lam, b, m) * (1.0 - ratio) / (1.0 - r_lam)


@njit(cache=True, error_model="numpy")
def iso6358_mass_flow(p1, T1, p2, T2, C, b, m, r_lam, r, gamma):
    """Mass flow through an ISO 6358 restriction, in either direction.

    .. math::
        q = C \\rho_0 p_u \\sqrt{T_0 / T_u}\\;
            \\left[1 - \\left(\\frac{p_d/p_u - b}{1 - b}\\right)^2\\right]^m
        \\quad (p_d/p_u > b), \\qquad
        q = C \\rho_0 p_u \\sqrt{T_0 / T_u} \\quad (p_d/p_u \\le b)

    (paper Eq. 4 and 5, with the ISO 6358-1:2013 subsonic index ``m``;
    ``rho_0 = 1.185 kg/m^3``, ``T_0 = 293.15 K``). The upstream side is the
    one with the higher pressure and its temperature is used. Above the
    ratio ``r_lam`` the law is linearised (see module docstring).

    Parameters
    ----------
    p1 : float
        Absolute pressure on side 1 [Pa]
    T1 : float
        Gas temperature on side 1 [K]
    p2 : float
        Absolute pressure on side 2 [Pa]
    T2 : float
        Gas temperature on side 2 [K]
    C : float
        Sonic conductance [m^3/(s Pa)]
    b : float
        Critical pressure ratio [-]
    m : float
        Subsonic index [-] (0.5 in the paper)
    r_lam : float
        Pressure ratio above which the flow is linearised [-]
    r : float
        Specific gas constant [J/(kg K)] (unused: ISO uses rho_0)
    gamma : float
        Ratio of specific heats [-] (unused)

    Returns
    -------
    q : float
        Mass flow from side 1 to side 2 [kg/s]

    Examples
    --------
    Catalogue check (ISO 6358 worked figures): C = 2 dm^3/(s bar), b = 0.3,
    upstream 0.4 MPa gauge at 20 degC; choked flow is 600 dm^3/min (ANR):

    >>> C = 2e-3 / 1e5
    >>> q = iso6358_mass_flow(5.013e5, 293.15, 1.013e5, 293.15, C, 0.3, 0.5, 0.999, 287.05, 1.4)
    >>> round(q / 1.185 * 60e3)  # ANR dm^3/min
    602
    """
    if C <= 0.0 or p1 == p2:
        return 0.0
    if p1 > p2:
        return C * RHO_REF * p1 * math.sqrt(T_REF / T1) * _iso_phi_linearised(p2 / p1, b, m, r_lam)
    return -C * RHO_REF * p2 * math.sqrt(T_REF / T2) * _iso_phi_linearised(p1 / p2, b, m, r_lam)


@njit(cache=True, error_model="numpy")
def saint_venant_critical_ratio(gamma):
    """Theoretical critical pressure ratio of an ideal nozzle (paper Eq. 3).

    ``Omega = (2 / (gamma + 1)) ** (gamma / (gamma - 1))`` = 0.528 for air.
    (The exponent is printed as gamma/(gamma+1) in the paper, a typo: the
    text gives the theoretical value 0.52, which only the form above yields.)
    """
    return (2.0 / (gamma + 1.0)) ** (gamma / (gamma - 1.0))


@njit(cache=True, error_model="numpy")
def saint_venant_area(C, r, gamma):
    """Throat area of an ideal nozzle with the same choked flow as conductance ``C``.

    Equating Eq. 2 and Eq. 5: ``s = C rho_0 sqrt(r T_0) / sqrt(gamma (2/(gamma+1))^((gamma+1)/(gamma-1)))``.

    Parameters
    ----------
    C : float
        Sonic conductance [m^3/(s Pa)]
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]

    Returns
    -------
    s : float
        Effective throat area [m^2]
    """
    k = gamma * (2.0 / (gamma + 1.0)) ** ((gamma + 1.0) / (gamma - 1.0))
    return C * RHO_REF * math.sqrt(r * T_REF) / math.sqrt(k)


@njit(cache=True, error_model="numpy")
def _sv_phi(ratio, gamma):
    # Flow function normalised by its choked value, Eq. 1 / Eq. 2.
    omega = saint_venant_critical_ratio(gamma)
    if ratio <= omega:
        return 1.0
    a = ratio ** (1.0 / gamma)   # r^(2/g) = a^2 and r^((g+1)/g) = r a: one power instead of two
    sub = 2.0 * gamma / (gamma - 1.0) * (a * a - ratio * a)
    if sub <= 0.0:
        return 0.0
    son = gamma * (2.0 / (gamma + 1.0)) ** ((gamma + 1.0) / (gamma - 1.0))
    return math.sqrt(sub / son)


@njit(cache=True, error_model="numpy")
def _sv_phi_linearised(ratio, gamma, r_lam):
    if ratio <= r_lam:
        return _sv_phi(ratio, gamma)
    return _sv_phi(r_lam, gamma) * (1.0 - ratio) / (1.0 - r_lam)


@njit(cache=True, error_model="numpy")
def saint_venant_mass_flow(p1, T1, p2, T2, C, b, m, r_lam, r, gamma):
    """Mass flow through an ideal nozzle (Saint-Venant, paper Eq. 1-3).

    .. math::
        q = s p_u \\sqrt{\\frac{2\\gamma}{(\\gamma-1) r T_u}
            \\left[(p_d/p_u)^{2/\\gamma} - (p_d/p_u)^{(\\gamma+1)/\\gamma}\\right]}
        \\quad (p_d/p_u > \\Omega)

        q = s p_u \\sqrt{\\frac{\\gamma}{r T_u}
            \\left(\\frac{2}{\\gamma+1}\\right)^{(\\gamma+1)/(\\gamma-1)}}
        \\quad (p_d/p_u \\le \\Omega)

    The throat area ``s`` is the one with the same choked flow as the
    conductance ``C`` (:func:`saint_venant_area`), so the two laws differ
    only in the shape of the subsonic branch and the critical ratio
    (0.528 instead of the measured ``b``). ``b`` and ``m`` are ignored.

    Parameters and return value as :func:`iso6358_mass_flow`.
    """
    if C <= 0.0 or p1 == p2:
        return 0.0
    # s p_u sqrt(gamma (2/(gamma+1))^((gamma+1)/(gamma-1)) / (r T_u)) with the area s of
    # saint_venant_area reduces exactly to C rho_0 p_u sqrt(T_0 / T_u): the choked flows match
    if p1 > p2:
        return C * RHO_REF * p1 * math.sqrt(T_REF / T1) * _sv_phi_linearised(p2 / p1, gamma, r_lam)
    return -C * RHO_REF * p2 * math.sqrt(T_REF / T2) * _sv_phi_linearised(p1 / p2, gamma, r_lam)


@njit(cache=True, error_model="numpy")
def laminar_mass_flow(p1, T1, p2, T2, G):
    """Laminar leak ``q = G (p1 - p2)`` from side 1 to side 2.

    Parameters
    ----------
    p1, p2 : float
        Absolute pressures [Pa]
    T1, T2 : float
        Temperatures [K] (unused; kept for a uniform signature)
    G : float
        Leak conductance [kg/(s Pa)]

    Returns
    -------
    q : float
        Mass flow from side 1 to side 2 [kg/s]
    """
    return G * (p1 - p2)


class FlowLaw:
    """A registered flow law: its compiled function and its integer code in the core.

    Parameters
    ----------
    name : str
        Registry name (``valve.flow_law``)
    code : int
        Integer the compiled core selects the law by (parameter slot
        ``layout.P_FLOW_LAW``)
    func : numba dispatcher
        ``func(p1, T1, p2, T2, C, b, m, r_lam, r, gamma) -> q``, mass flow from
        side 1 to side 2 [kg/s] (arguments as :func:`iso6358_mass_flow`); it
        must not allocate (the core runs without numba's reference-counting runtime)
    description : str
        One line: the equation and its source
    builtin : bool
        Part of the package: compiled into the core that numba caches on disk.
        A model that names a law registered at run time runs on a core compiled
        for the registry as it stands (:func:`pneucore.core.integrator.specialize`)
    """

    def __init__(self, name, code, func, description, builtin=False):
        self.name = name
        self.code = code
        self.func = func
        self.description = description
        self.builtin = builtin

    def core_entry(self):
        """``(code, func)``: this law's entry in the core's dispatch table
        (:data:`pneucore.core.rhs.flow_laws`)."""
        return (self.code, self.func)

    def __call__(self, p1, T1, p2, T2, C, b, m=0.5, r_lam=R_LAMINAR, r=R_AIR, gamma=GAMMA_AIR):
        f = np.vectorize(self.func, otypes=[float])
        out = f(p1, T1, p2, T2, C, b, m, r_lam, r, gamma)
        return float(out) if np.ndim(out) == 0 else out


#: Registry of flow laws by name (``valve.flow_law``); the compiled core dispatches
#: on their codes (:func:`pneucore.core.rhs.edge_flow`)
FLOW_LAWS = {
    "iso6358": FlowLaw("iso6358", 0, iso6358_mass_flow,
                       "ISO 6358 sonic conductance C and critical ratio b (paper Eq. 4-5)",
                       builtin=True),
    "saint_venant": FlowLaw("saint_venant", 1, saint_venant_mass_flow,
                            "ideal nozzle, critical ratio 0.528 (paper Eq. 1-3), area matched to C",
                            builtin=True),
}


def compiled(func, what):
    """``func`` as a numba dispatcher: compiled with the core's options if it is a plain
    Python function (a law registered at run time); a ``TypeError`` naming ``what`` if
    it is not callable."""
    from numba.core.registry import CPUDispatcher

    if isinstance(func, CPUDispatcher):
        return func
    if not callable(func):
        raise TypeError(f"{what}: expected a function, got {type(func).__name__}")
    return njit(error_model="numpy")(func)


def next_code(registry):
    """The smallest code no law of ``registry`` uses (codes of removed laws are reused)."""
    used = {law.code for law in registry.values()}
    code = 0
    while code in used:
        code += 1
    return code


def register_flow_law(name, func, description="", replace=False):
    """Add a flow law that a model selects by name (``valve.flow_law``).

    The law is compiled into the simulator's core: the first :func:`pneucore.simulate`
    of a model naming it compiles a core for the registry as it stands, in memory:
    about as long as the core's first compile (12 s of CPU time on a shared 2-core
    machine), once per process and set of registered laws and user effects. Models
    naming only built-in laws keep the core numba caches on disk.

    Parameters
    ----------
    name : str
        Registry name
    func : callable
        ``func(p1, T1, p2, T2, C, b, m, r_lam, r, gamma) -> q`` [kg/s], arguments as
        :func:`iso6358_mass_flow`; a numba ``@njit`` function, or plain Python that
        numba can compile (it is compiled here). It must not allocate arrays.
    description : str
        One line: the equation and its source
    replace : bool
        Allow replacing a law registered at run time (a built-in law cannot be replaced)

    Returns
    -------
    law : FlowLaw
        The registered entry

    Examples
    --------
    A law twice ISO 6358 (as a larger valve would give):

    >>> from numba import njit
    >>> @njit
    ... def double_iso(p1, T1, p2, T2, C, b, m, r_lam, r, gamma):
    ...     return 2.0 * iso6358_mass_flow(p1, T1, p2, T2, C, b, m, r_lam, r, gamma)
    >>> law = register_flow_law("double_iso", double_iso, "2 x ISO 6358")
    >>> round(law(5e5, 293.15, 1e5, 293.15, 1e-8, 0.3) / FLOW_LAWS["iso6358"](5e5, 293.15, 1e5, 293.15, 1e-8, 0.3), 12)
    2.0
    >>> unregister_flow_law("double_iso")
    """
    return register_law(FLOW_LAWS, name, replace,
                     lambda code: FlowLaw(name, code, compiled(func, f"flow law {name!r}"),
                                          description))


def unregister_flow_law(name):
    """Remove a flow law registered with :func:`register_flow_law` (a built-in law stays)."""
    unregister_law(FLOW_LAWS, name, "flow law")


def register_law(registry, name, replace, make):
    """Add ``make(code)`` to ``registry`` under ``name``; shared by the law registries.

    Parameters
    ----------
    registry : dict
        :data:`FLOW_LAWS` or :data:`pneucore.physics.friction.FRICTION_LAWS`
    name : str
        Registry name
    replace : bool
        Allow replacing a law registered at run time
    make : callable
        ``make(code)`` builds the entry for the integer ``code``
    """
    if not isinstance(name, str) or not name:
        raise ValueError("a law's name must be a non-empty string")
    old = registry.get(name)
    if old is not None:
        if old.builtin:
            raise ValueError(f"{name!r} is a built-in law and cannot be replaced")
        if not replace:
            raise ValueError(f"{name!r} is already registered (replace=True to replace it)")
    law = make(old.code if old is not None else next_code(registry))
    registry[name] = law
    return law


def unregister_law(registry, name, what):
    """Remove ``name`` from ``registry`` unless it is built in (``what`` names the kind)."""
    law = registry.get(name)
    if law is not None and law.builtin:
        raise ValueError(f"{name!r} is a built-in {what} and cannot be removed")
    registry.pop(name, None)


def anr_volume_flow(q):
    """Convert a mass flow to a volume flow at ISO 8778 reference conditions (ANR).

    Parameters
    ----------
    q : float
        Mass flow [kg/s]

    Returns
    -------
    Q : float
        Volume flow at 20 degC, 100 kPa, 65 % RH [m^3/s] (ANR)
    """
    return q / RHO_REF


# --- valve data as catalogues give them -> C [m^3/(s Pa)] ------------------------------
# The model keeps C and b (ISO 6358) as the one source; these convert what a catalogue
# prints into them. Pressures absolute [Pa], flows at ANR (ISO 8778: 20 degC, 100 kPa).

#: Reference atmosphere of ISO 8778 (ANR) to which catalogue gauge pressures are added [Pa]
P_ANR = 1e5
#: Nominal-flow test conditions of VDI 3290 / ISO 6358 catalogue data: 6 bar gauge
#: upstream, 1 bar pressure drop (5 bar gauge downstream) [Pa]
QN_P1_GAUGE = 6e5
QN_DP = 1e5
#: 1 ft^3 [m^3] by the unit's definition (international foot 0.3048 m); 1 psi [Pa] comes from
#: :data:`pneucore.physics.gas.PSI` (one source)
FT3 = 0.3048 ** 3
#: Kv [m^3/h of water at 1 bar] per Cv [US gal/min of water at 1 psi]: (3.785411784 L x 60)
#: x sqrt(1e5 Pa / 1 psi), from the units' definitions (IEC 60534-1: Kv = 0.865 Cv) [-]
KV_PER_CV = 3.785411784e-3 * 60.0 * math.sqrt(1e5 / PSI)


def conductance_from_flow(Q, p1, p2, b, T1=T_REF):
    """Sonic conductance from one measured flow point (ISO 6358, paper Eq. 4-5 inverted).

    ``C = Q / (p1 sqrt(T0 / T1) phi(p2/p1, b))``, with ``phi`` the flow function of Eq. 4
    (``m = 0.5``).

    Parameters
    ----------
    Q : float
        Volume flow at ANR (ISO 8778) [m^3/s]
    p1 : float
        Upstream absolute pressure [Pa]
    p2 : float
        Downstream absolute pressure [Pa]
    b : float
        Critical pressure ratio [-]
    T1 : float
        Upstream temperature [K]

    Returns
    -------
    C : float
        Sonic conductance [m^3/(s Pa)]

    Examples
    --------
    SMC's worked example (VX solenoid valve datasheet, "Flow-rate characteristics"): a valve
    of C = 2 dm^3/(s bar), b = 0.3 passes 420 dm^3/min (ANR) from 0.4 to 0.3 MPa gauge at
    20 degC; back from that flow:

    >>> C = conductance_from_flow(420e-3 / 60, 5e5, 4e5, 0.3)
    >>> round(C / 1e-8, 2)     # dm^3/(s bar)
    2.0
    """
    phi = iso6358_ratio_function(p2 / p1, b, 0.5)
    return Q / (p1 * math.sqrt(T_REF / T1) * phi)


def conductance_from_qn(qn, b):
    """Sonic conductance from a catalogue's nominal flow Qn [NL/min] and critical ratio b.

    Qn is the flow at ANR with 6 bar gauge upstream and a 1 bar drop (VDI 3290, the
    "standard nominal flow rate" of catalogues; ISO 6358-1 conditions), gauge pressures
    over the ANR atmosphere (100 kPa): :func:`conductance_from_flow` at 7 and 6 bar absolute.

    Parameters
    ----------
    qn : float
        Nominal flow [NL/min] (litres per minute at ANR)
    b : float
        Critical pressure ratio, which Qn alone does not give (0.3 when the catalogue is
        silent, a common spool-valve value) [-]

    Returns
    -------
    C : float
        Sonic conductance [m^3/(s Pa)]

    Examples
    --------
    A valve of C = 1 dm^3/(s bar), b = 0.3 has a nominal flow of 254 NL/min:

    >>> round(conductance_from_qn(254.27, 0.3) / 1e-8, 3)
    1.0
    """
    p1 = P_ANR + QN_P1_GAUGE
    return conductance_from_flow(qn * 1e-3 / 60.0, p1, p1 - QN_DP, b)


def conductance_from_area(S, r=R_AIR, gamma=GAMMA_AIR):
    """Sonic conductance of an effective area S (JIS B 8390), the inverse of
    :func:`saint_venant_area`: the ideal nozzle's choked flow (paper Eq. 2) equated to
    Eq. 5; catalogues round it to ``S [mm^2] = 5.0 C [dm^3/(s bar)]``.

    Parameters
    ----------
    S : float
        Effective area [m^2]
    r : float
        Specific gas constant [J/(kg K)]
    gamma : float
        Ratio of specific heats [-]

    Returns
    -------
    C : float
        Sonic conductance [m^3/(s Pa)]

    Examples
    --------
    >>> round(conductance_from_area(5e-6) / 1e-8, 3)    # 5 mm^2: about 1 dm^3/(s bar)
    0.996
    """
    return S / saint_venant_area(1.0, r, gamma)


#: ISA-75.01.01 (IEC 60534-2-1) numerical constant N7 of the gas sizing equation for a volume
#: flow in scfh (standard cubic feet per hour at 14.73 psia and 60 degF), pressures in psia and
#: temperatures in degR: ``Q = N7 Fp Cv p1 Y sqrt(x / (G T1 Z))`` [-]
N7_SCFH = 1360.0
#: The scfh's standard state, 14.73 psia and 60 degF (ISA-75.01.01), in Pa and K
P_SCFH = 14.73 * PSI
T_SCFH = (60.0 + 459.67) / 1.8


def conductance_from_cv(cv, b):
    """Sonic conductance of a valve rated Cv [US gal/min of water at 1 psi], by the gas sizing
    equation of ISA-75.01.01 / IEC 60534-2-1 at choked flow, with ``x_T = 1 - b``.

    The standard's gas equation ``Q = N7 Fp Cv p1 Y sqrt(x / (G T1 Z))``, with the
    expansion factor ``Y = 1 - x / (3 Fgamma x_T)``, chokes at the pressure drop ratio
    ``x = Fgamma x_T``, where ``Y = 2/3``; for air (``Fgamma = 1``, specific gravity
    ``G = 1``, ``Z = 1``) and a valve without fittings (``Fp = 1``) the choked flow is
    ``Q = (2/3) N7 Cv p1 sqrt(x_T / T1)``, which ISO 6358 writes ``C p1 sqrt(T0 / T1)``
    (paper Eq. 5): ``C = (2/3) N7 Cv sqrt(x_T / T0)``, the scfh taken to ANR (ISO 8778)
    and the psia to Pa. The valve's pressure differential ratio factor ``x_T`` is where the
    standard's law chokes, ``p2/p1 = 1 - x_T``; ISO 6358's law chokes at ``p2/p1 = b``:
    ``x_T = 1 - b`` makes the two laws agree at choke and at zero flow. Between, the
    standard's law is higher, by at most ``1.5 / sqrt(2) - 1 = 6.1 %`` at the smallest drops
    (whatever ``b``): a Cv is a figure of the small-drop flow, and C from it is good to that.
    A Cv alone gives no b; the catalogue's b is taken as it is (the constant's source: the
    equation as the stored page https://midstreamcalculator.com/calculators/utilities/
    regulator-station.html states it, ``N8 = 1360 (SCFH, psia, degR)``,
    ``Y = 1 - x/(3 x_T)``, min 2/3).

    Parameters
    ----------
    cv : float
        Flow coefficient Cv [US gal/min]
    b : float
        Critical pressure ratio, the catalogue's (``x_T = 1 - b``) [-]

    Returns
    -------
    C : float
        Sonic conductance [m^3/(s Pa)]

    Examples
    --------
    A Cv of 1 with b = 0.3 (x_T = 0.7), about 3.9 dm^3/(s bar):

    >>> round(conductance_from_cv(1.0, 0.3) / 1e-8, 3)
    3.885
    """
    q_scfh_per_psia = (2.0 / 3.0) * N7_SCFH * cv * math.sqrt((1.0 - b) / (T_REF * 1.8))
    # scfh at 14.73 psia, 60 degF -> m^3/s at ANR (the same mass: V ~ T / p)
    q = q_scfh_per_psia * FT3 / 3600.0 * (P_SCFH / T_SCFH) * (T_REF / P_ANR)
    return q / PSI


def conductance_from_kv(kv, b):
    """Sonic conductance of a valve rated Kv [m^3/h of water at 1 bar]: its Cv
    (``Kv = 0.865 Cv``, :data:`KV_PER_CV`, IEC 60534-1) through
    :func:`conductance_from_cv`, the same ISA-75.01.01 / IEC 60534-2-1 choked-flow law with
    ``x_T = 1 - b``.

    Parameters
    ----------
    kv : float
        Flow coefficient Kv [m^3/h]
    b : float
        Critical pressure ratio, the catalogue's [-]

    Returns
    -------
    C : float
        Sonic conductance [m^3/(s Pa)]

    Examples
    --------
    >>> round(conductance_from_kv(0.865, 0.3) / 1e-8, 3)    # Kv 0.865 = Cv 1.00003
    3.885
    """
    return conductance_from_cv(kv / KV_PER_CV, b)


def kv_from_cv(cv):
    """Kv [m^3/h of water, 1 bar drop] of a valve rated Cv [US gal/min of water, 1 psi drop]
    (:data:`KV_PER_CV`, from the units' definitions; IEC 60534-1).

    Parameters
    ----------
    cv : float
        Flow coefficient Cv [US gal/min]

    Returns
    -------
    kv : float
        Flow coefficient Kv [m^3/h]

    Examples
    --------
    >>> round(kv_from_cv(1.0), 4)
    0.865
    """
    return KV_PER_CV * cv
