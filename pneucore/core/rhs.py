"""The actuator's right-hand side: one signature for every configuration.

``rhs(t, y, mode, u, prm, iy, tx, tC, tb, tm, toff, prm_user, scratch, dy, aux)``
fills ``dy`` with the state derivatives and ``aux`` with the algebraic
outputs (pressures, valve flows, friction, acceleration, ...). It assembles
the component laws: valve edges (:mod:`pneucore.physics.valve`, :mod:`pneucore.physics.flow`),
chambers (:mod:`pneucore.physics.chamber`, :mod:`pneucore.physics.heat`), jack
(:mod:`pneucore.physics.jack`) and friction (:mod:`pneucore.physics.friction`). Effects
write their parameters into ``prm`` and their states into ``iy``
(:mod:`pneucore.core.layout`); user-registered effects add terms through the
module-level ``user_terms`` hook (see :func:`pneucore.core.integrator.specialize`).

The flow and friction laws come from their registries
(:data:`pneucore.physics.flow.FLOW_LAWS`, :data:`pneucore.physics.friction.FRICTION_LAWS`):
the core dispatches on the law codes in ``prm`` (``P_FLOW_LAW``, ``P_FRICTION_LAW``)
over the module-level tables :data:`flow_laws` and :data:`friction_laws`, which hold
the built-in laws; a model naming a law registered at run time runs on a copy of the
core compiled over the registry's table, as for a user effect's hook. The effects with a
state per chamber and the lines between valve and chamber (:mod:`pneucore.physics.states`)
are called from the tables :data:`state_terms` and :data:`line_terms` likewise.

Within one piston ``mode`` the equations are smooth; stick, slip and end
stops switch the mode (handled as events by :mod:`pneucore.core.integrator`).

The right-hand side and everything it calls are compiled without numba's
reference-counting runtime (``_nrt=False``, see :mod:`pneucore.core.integrator`):
they never allocate, so the user hook's signal and term vectors are views of
a ``scratch`` vector allocated once per simulation. Together with the
inlined valve edge this took one evaluation from about 0.21 to 0.07 us.
"""
from numba import njit
from numba.extending import overload

from pneucore.core import layout as L
from pneucore.physics.chamber import chamber_pressure, chamber_rates, enthalpy_flow
from pneucore.physics.cushion import cushioned_outflow, in_cushion
from pneucore.physics.flow import FLOW_LAWS, iso6358_mass_flow, laminar_mass_flow
from pneucore.physics.heat import convective_heat_flow, exchange_coefficient
from pneucore.physics.friction import FRICTION_LAWS, coulomb_level, viscous_coefficient
from pneucore.physics.jack import chamber_volumes, net_pressure_force, spring_force, wall_area
from pneucore.physics.states import LINE_TERMS, STATE_TERMS
from pneucore.physics.valve import table_segment


@njit(cache=True, error_model="numpy", _nrt=False)
def no_terms(t, y, sig, prm_user, terms, dy):
    """Default user hook: adds nothing. A user effect's hook has this signature.

    Parameters
    ----------
    t : float
        Time [s]
    y : ndarray
        Full state vector (user states at ``iy[IY_USER0]`` onwards)
    sig : ndarray
        Current signals, named by ``layout.SIG_NAMES`` (SI units)
    prm_user : ndarray
        Parameters of the user effects
    terms : ndarray
        Contributions to add, named by ``layout.TERM_NAMES``
    dy : ndarray
        Derivatives; the hook writes those of its own states
    """
    return


#: Hook called for user effect terms; the default adds nothing. A model with
#: user effects gets its own compiled copy of the core with this name rebound.
user_terms = no_terms


@njit(cache=True, error_model="numpy", _nrt=True)
def call_user_terms(t, y, sig, prm_user, terms, dy):
    """Call the user hook with numba's runtime switched back on.

    A function compiled from a caller inherits the caller's runtime setting
    unless it sets its own; the right-hand side runs without the runtime, so
    a user's terms function that allocates (``np.empty``) would not compile.
    This explicit ``_nrt=True`` layer gives the user's code the runtime.
    """
    user_terms(t, y, sig, prm_user, terms, dy)


def _table_dispatch(column):
    """A function for compiled code, ``f(table, code, args)``: calls the function in column
    ``column`` of the entry of ``table`` (a law table, :func:`law_table`) whose code is
    ``code``, with the tuple ``args``; 0.0 when no entry has that code.

    Its compiled form is generated from the table's type when a caller is compiled: one
    test of the code and one direct call per entry, the code a hand-written
    ``if law == 1: ... else: ...`` gives (and as fast: LLVM inlines the small dispatch
    and the laws; inlining at numba's IR level, ``inline="always"``, only lengthened
    the first compile).
    """
    def call(table, code, args):
        raise NotImplementedError("called from compiled code only")

    @overload(call)
    def _generate(table, code, args):
        lines = ["def impl(table, code, args):"]
        for i in range(len(table)):
            lines += [f"    if code == table[{i}][0]:",
                      f"        return table[{i}][{column}](*args)"]
        lines.append("    return 0.0")
        namespace = {}
        exec("\n".join(lines), namespace)   # text built from integers only
        return namespace["impl"]

    call.__name__ = call.__qualname__ = f"call_column_{column}"
    return call


#: ``call_law(table, code, args)`` in compiled code: the law (flow table) or the force
#: (friction table) of the entry with ``code``
call_law = _table_dispatch(1)
#: ``call_static(table, code, args)`` in compiled code: the static limit of the friction
#: law with ``code``
call_static = _table_dispatch(2)


def law_table(registry, builtin_only=False):
    """The core's dispatch table of a law registry: each law's ``core_entry()``, by code.

    Parameters
    ----------
    registry : dict
        :data:`pneucore.physics.flow.FLOW_LAWS` or
        :data:`pneucore.physics.friction.FRICTION_LAWS`
    builtin_only : bool
        Only the laws of the package (the table of the core cached on disk)

    Returns
    -------
    table : tuple
        ``((code, function, ...), ...)`` in increasing code
    """
    laws = sorted(registry.values(), key=lambda law: law.code)
    return tuple(law.core_entry() for law in laws if law.builtin or not builtin_only)


#: Flow laws compiled into the core cached on disk, ``((code, law), ...)``: the
#: built-in entries of :data:`pneucore.physics.flow.FLOW_LAWS`. A model naming a law
#: registered at run time runs on a copy of the core compiled over the registry's
#: table (:func:`pneucore.core.integrator.specialize`).
flow_laws = law_table(FLOW_LAWS, builtin_only=True)
#: Friction laws compiled into the core cached on disk, ``((code, force, static), ...)``:
#: the built-in entries of :data:`pneucore.physics.friction.FRICTION_LAWS`
friction_laws = law_table(FRICTION_LAWS, builtin_only=True)


def state_table(terms=None):
    """The core's table of state terms (:mod:`pneucore.physics.states`):
    ``((iy slot of chamber A's state, first parameter slot, frozen with a constant chamber B,
    rate), ...)`` in registration order, slots from :mod:`pneucore.core.layout` (the function
    last, as in :func:`law_table`: numba then calls it directly, not as a first-class value).

    Parameters
    ----------
    terms : dict or None
        Terms by name (default :data:`pneucore.physics.states.STATE_TERMS`)
    """
    terms = STATE_TERMS if terms is None else terms
    return tuple((L.STATE_IY0[name], L.STATE_PRM0[name], t.frozen_with_constant_b, t.rate)
                 for name, t in terms.items())


#: State terms compiled into the core: every registered term (its rate, slots and flag)
state_terms = state_table()


def call_state_rates(table, iy, y, dy, prm, sa, sb, T_amb, b_const):
    """In compiled code: the rate of every state term of ``table`` present in the model
    (``iy`` at its slot >= 0), for chamber A with the signals ``sa = (p, T, Q, S)`` and for
    chamber B with ``sb`` (skipped when chamber B is constant and the term says so).

    Generated from the table's type when a caller is compiled (as :func:`_table_dispatch`):
    one test and one or two direct calls per term.
    """
    raise NotImplementedError("called from compiled code only")


@overload(call_state_rates)
def _generate_state_rates(table, iy, y, dy, prm, sa, sb, T_amb, b_const):
    lines = ["def impl(table, iy, y, dy, prm, sa, sb, T_amb, b_const):"]
    for i in range(len(table)):
        lines += [f"    i = iy[table[{i}][0]]",
                  "    if i >= 0:",
                  f"        dy[i] = table[{i}][3](y[i], sa[0], sa[1], sa[2], sa[3], T_amb, prm, "
                  f"table[{i}][1])",
                  f"        if not (b_const and table[{i}][2]):",
                  f"            j = iy[table[{i}][0] + 1]",
                  f"            dy[j] = table[{i}][3](y[j], sb[0], sb[1], sb[2], sb[3], T_amb, prm, "
                  f"table[{i}][1])"]
    lines.append("    return")
    namespace = {}
    exec("\n".join(lines), namespace)   # text built from integers only
    return namespace["impl"]


def line_table(terms=None):
    """The core's table of line terms (:mod:`pneucore.physics.states`): ``((iy slot of port
    A's first state, first parameter slot of port A, parameter slots per port, node, rate,
    cells), ...)`` in registration order, slots from :mod:`pneucore.core.layout`.

    Parameters
    ----------
    terms : dict or None
        Terms by name (default :data:`pneucore.physics.states.LINE_TERMS`)
    """
    terms = LINE_TERMS if terms is None else terms
    return tuple((L.STATE_IY0[name], L.STATE_PRM0[name], len(t.parameters), t.node, t.rate,
                  t.cells) for name, t in terms.items())


#: Line terms compiled into the core: every registered term (its slots, node and rate)
line_terms = line_table()


def call_line_node(table, port, iy, y, prm, p, T, r):
    """In compiled code: ``(p, T, line)`` of the node port ``port`` (0 = A, 1 = B) connects the
    valve edges to: a line term's first cell where one is present on that port (its ``iy``
    slot >= 0; ``line`` True), else the chamber's ``p`` [Pa], ``T`` [K] themselves (``line``
    False).

    Generated from the table's type when a caller is compiled (as :func:`_table_dispatch`).
    """
    raise NotImplementedError("called from compiled code only")


# The line terms' dispatchers are inlined at numba IR level: called as a function, the table
# is an argument, and numba lowers each compiled function in it as a dynamic address (numba
# 0.68's first-class functions), which LLVM drops only where it inlines the callee; with two
# line terms it did not, and the core could no longer be cached (16 "cannot cache" warnings,
# the first compile repeated in every process)
@overload(call_line_node, inline="always")
def _generate_line_node(table, port, iy, y, prm, p, T, r):
    lines = ["def impl(table, port, iy, y, prm, p, T, r):"]
    for i in range(len(table)):
        lines += [f"    i = iy[table[{i}][0] + port]",
                  "    if i >= 0:",
                  f"        pn, Tn = table[{i}][3](y, i, prm, table[{i}][1] + port * table[{i}][2], r)",
                  "        return pn, Tn, True"]
    lines.append("    return p, T, False")
    namespace = {}
    exec("\n".join(lines), namespace)   # text built from integers only
    return namespace["impl"]


def call_line_rates(table, port, iy, y, dy, prm, q, H, p, T, r, cp, cv, isothermal, C_end, b_end,
                    r_lam, gamma):
    """In compiled code: a line term's rates on port ``port`` where one is present, and the
    mass flow [kg/s] and enthalpy flow [W] into the chamber it gives from the valve's ``q``,
    ``H`` into the port (with a cushion's needle of conductance ``C_end`` at the chamber's
    end, < 0 = none); ``(q, H)`` unchanged without one.

    Generated from the table's type when a caller is compiled (as :func:`_table_dispatch`).
    """
    raise NotImplementedError("called from compiled code only")


@overload(call_line_rates, inline="always")
def _generate_line_rates(table, port, iy, y, dy, prm, q, H, p, T, r, cp, cv, isothermal, C_end,
                         b_end, r_lam, gamma):
    lines = ["def impl(table, port, iy, y, dy, prm, q, H, p, T, r, cp, cv, isothermal, C_end, "
             "b_end, r_lam, gamma):"]
    for i in range(len(table)):
        lines += [f"    i = iy[table[{i}][0] + port]",
                  "    if i >= 0:",
                  f"        return table[{i}][4](y, dy, i, prm, table[{i}][1] + port * table[{i}][2], "
                  "q, H, p, T, r, cp, cv, isothermal, C_end, b_end, r_lam, gamma)"]
    lines.append("    return q, H")
    namespace = {}
    exec("\n".join(lines), namespace)   # text built from integers only
    return namespace["impl"]


def call_line_cells(table, port, iy, prm, cell):
    """In compiled code: ``(i0, n_states, n_cells)`` of the line term on port ``port``, its
    states' cells written into ``cell[i0:i0 + n_states]`` (line term ``cells``); ``(-1, 0, 0)``
    where no line term is present on that port.

    Generated from the table's type when a caller is compiled (as :func:`_table_dispatch`).
    """
    raise NotImplementedError("called from compiled code only")


@overload(call_line_cells, inline="always")
def _generate_line_cells(table, port, iy, prm, cell):
    lines = ["def impl(table, port, iy, prm, cell):"]
    for i in range(len(table)):
        lines += [f"    i = iy[table[{i}][0] + port]",
                  "    if i >= 0:",
                  f"        ns, nc = table[{i}][5](prm, table[{i}][1] + port * table[{i}][2], i, cell)",
                  "        return i, ns, nc"]
    lines.append("    return -1, 0, 0")
    namespace = {}
    exec("\n".join(lines), namespace)   # text built from integers only
    return namespace["impl"]


@njit(cache=True, error_model="numpy", _nrt=False)
def edge_flow(law, p1, T1, p2, T2, C, b, m, r_lam, r, gamma):
    """Mass flow from node 1 to node 2 through one valve edge [kg/s], by flow-law code.

    Dispatches on the codes of :data:`flow_laws` (``FLOW_LAWS[name].code``): one test
    and one direct call per law (:func:`_table_dispatch`).
    """
    return call_law(flow_laws, law, (p1, T1, p2, T2, C, b, m, r_lam, r, gamma))


@njit(cache=True, error_model="numpy", _nrt=False)
def friction_force(law, v, direction, fc, kv, ratio, v_s):
    """Friction on a sliding piston [N], counted positive towards -x, by friction-law code.

    Dispatches on the codes of :data:`friction_laws` (``FRICTION_LAWS[name].code``)
    to the law's ``force(v, direction, fc, kv, ratio, v_s)``.
    """
    return call_law(friction_laws, law, (v, direction, fc, kv, ratio, v_s))


@njit(cache=True, error_model="numpy", _nrt=False)
def static_friction(law, fc, ratio, v_s):
    """Static friction limit of a resting piston [N], by friction-law code.

    Dispatches on the codes of :data:`friction_laws` to the law's ``static(fc, ratio, v_s)``.
    """
    return call_static(friction_laws, law, (fc, ratio, v_s))


@njit(cache=True, error_model="numpy", _nrt=False, inline="always")
def _edge(k, u, p1, T1, p2, T2, prm, tx, tC, tb, tm, toff):
    lo, hi, w = table_segment(u, tx, toff[k], toff[k + 1])
    C = tC[lo] + w * (tC[hi] - tC[lo])
    law = int(prm[L.P_FLOW_LAW])
    q = 0.0
    if C > 0.0:   # a closed edge (spool overlap) needs no b(u), m(u)
        b = tb[lo] + w * (tb[hi] - tb[lo])
        m = tm[lo] + w * (tm[hi] - tm[lo])
        q = edge_flow(law, p1, T1, p2, T2, C, b, m, prm[L.P_R_LAM], prm[L.P_R], prm[L.P_GAMMA])
    frac = prm[L.P_NULL_LEAK]
    if frac > 0.0:
        q += edge_flow(law, p1, T1, p2, T2, frac * prm[L.P_CMAX_PA + k], prm[L.P_BMAX_PA + k],
                       0.5, prm[L.P_R_LAM], prm[L.P_R], prm[L.P_GAMMA])
    return q


@njit(cache=True, error_model="numpy", _nrt=False)
def _cushion(x, prm, p_sup, T_sup, p_a, T_a, p_b, T_b, p_atm, T_atm, q_pa, q_ar, q_pb, q_br,
             line_a, line_b):
    """The valve edges' flows with the end cushions (:mod:`pneucore.physics.cushion`): inside
    a cushion, the gas leaving that chamber passes the needle (bounded by the edge), the gas
    entering it the check valve. A port with a line in segments (``line_a``, ``line_b``) is
    left alone: its needle sits at the line's chamber end (:func:`_needle`)."""
    stroke = prm[L.P_STROKE]
    r_lam = prm[L.P_R_LAM]
    r = prm[L.P_R]
    gamma = prm[L.P_GAMMA]
    b = prm[L.P_CUSHION_B]
    la = prm[L.P_CUSHION_LA]
    lb = prm[L.P_CUSHION_LB]
    if not line_a and in_cushion(x, stroke, la, lb, 0):
        C = prm[L.P_CUSHION_CA]
        q_ar = cushioned_outflow(q_ar, p_a, T_a, p_atm, T_atm, C, b, r_lam, r, gamma)
        q_pa = -cushioned_outflow(-q_pa, p_a, T_a, p_sup, T_sup, C, b, r_lam, r, gamma)
    if not line_b and in_cushion(x, stroke, la, lb, 1):
        C = prm[L.P_CUSHION_CB]
        q_br = cushioned_outflow(q_br, p_b, T_b, p_atm, T_atm, C, b, r_lam, r, gamma)
        q_pb = -cushioned_outflow(-q_pb, p_b, T_b, p_sup, T_sup, C, b, r_lam, r, gamma)
    return q_pa, q_ar, q_pb, q_br


@njit(cache=True, error_model="numpy", _nrt=False, inline="always")
def _needle(x, prm, end, line):
    """Conductance [m^3/(s Pa)] of the cushion needle between the chamber of ``end`` (0 = A)
    and its line in segments (``line``) while the piston is in that cushion (0: closed);
    -1 otherwise (no restriction)."""
    if not line or not in_cushion(x, prm[L.P_STROKE], prm[L.P_CUSHION_LA], prm[L.P_CUSHION_LB],
                                  end):
        return -1.0
    return prm[L.P_CUSHION_CA + end]


@njit(cache=True, error_model="numpy", _nrt=False)
def rhs(t, y, mode, u, prm, iy, tx, tC, tb, tm, toff, prm_user, scratch, dy, aux):
    """State derivatives ``dy`` and algebraic outputs ``aux`` of the actuator.

    Parameters
    ----------
    t : float
        Time [s]
    y : ndarray
        States: m_a [kg], T_a [K], m_b [kg], T_b [K], x [m], v [m/s], then effect states
    mode : int
        Piston mode (``layout.MODE_*``)
    u : float
        Valve command [-]
    prm : ndarray
        Model parameters (``layout.P_*`` slots, SI units)
    iy : ndarray of int
        Positions of optional states (``layout.IY_*``), -1 if absent
    tx, tC, tb, tm, toff : ndarray
        Valve edge tables (:func:`pneucore.physics.valve.pack_tables`)
    prm_user : ndarray
        Parameters of user effects
    scratch : ndarray
        Work vector of ``layout.N_SCRATCH`` floats (user hook signals and terms)
    dy : ndarray
        Output: derivatives
    aux : ndarray
        Output: ``layout.AUX_NAMES`` values
    """
    r = prm[L.P_R]
    gamma = prm[L.P_GAMMA]
    cv = r / (gamma - 1.0)
    cp = cv + r
    p_atm = prm[L.P_ATM]
    T_atm = prm[L.P_T_ATM]
    for i in range(y.shape[0]):
        dy[i] = 0.0

    # --- piston and volumes (Eq. 23-24) ---------------------------------------
    x = y[L.Y_X]
    v = y[L.Y_V]
    if mode != L.MODE_SLIDE_POS and mode != L.MODE_SLIDE_NEG:
        v = 0.0
    A_a = prm[L.P_A_A]
    A_b = prm[L.P_A_B]
    V_a, V_b = chamber_volumes(x, A_a, A_b, prm[L.P_STROKE], prm[L.P_V0_A], prm[L.P_V0_B])

    m_a = y[L.Y_MA]
    T_a = y[L.Y_TA]
    m_b = y[L.Y_MB]
    T_b = y[L.Y_TB]
    p_a = chamber_pressure(m_a, T_a, V_a, r)
    b_const = prm[L.P_B_CONST] > 0.0
    if b_const:
        p_b = prm[L.P_B_CONST]
    else:
        p_b = chamber_pressure(m_b, T_b, V_b, r)

    # --- supply node: ideal source, or a line volume fed by a regulator ---------
    T_sup = prm[L.P_T_SUP]
    i_ms = iy[L.IY_SUPPLY_M]
    if i_ms >= 0:
        p_sup = chamber_pressure(y[i_ms], T_sup, prm[L.P_SUP_V], r)
    else:
        p_sup = prm[L.P_SUP]

    # --- effective spool opening ---------------------------------------------
    i_sp = iy[L.IY_SPOOL]
    if i_sp >= 0:
        u_eff = y[i_sp]
        i_sr = iy[L.IY_SPOOL_RATE]
        if i_sr >= 0:
            wn = prm[L.P_SPOOL_WN]
            dy[i_sp] = y[i_sr]
            dy[i_sr] = wn * wn * (u - u_eff) - 2.0 * prm[L.P_SPOOL_ZETA] * wn * y[i_sr]
        else:
            dy[i_sp] = (u - u_eff) / prm[L.P_SPOOL_TAU]
    else:
        u_eff = u

    # --- the nodes the valve edges see: the chambers, or a line's first cell ------------
    pn_a, Tn_a, line_a = call_line_node(line_terms, 0, iy, y, prm, p_a, T_a, r)
    pn_b, Tn_b, line_b = call_line_node(line_terms, 1, iy, y, prm, p_b, T_b, r)

    # --- valve edges (Eq. 4-5) --------------------------------------------------
    q_pa = _edge(0, u_eff, p_sup, T_sup, pn_a, Tn_a, prm, tx, tC, tb, tm, toff)   # P -> A
    q_ar = _edge(1, u_eff, pn_a, Tn_a, p_atm, T_atm, prm, tx, tC, tb, tm, toff)   # A -> R
    q_pb = _edge(2, u_eff, p_sup, T_sup, pn_b, Tn_b, prm, tx, tC, tb, tm, toff)   # P -> B
    q_br = _edge(3, u_eff, pn_b, Tn_b, p_atm, T_atm, prm, tx, tC, tb, tm, toff)   # B -> R
    if prm[L.P_CUSHION_LA] > 0.0 or prm[L.P_CUSHION_LB] > 0.0:
        q_pa, q_ar, q_pb, q_br = _cushion(x, prm, p_sup, T_sup, pn_a, Tn_a, pn_b, Tn_b, p_atm,
                                          T_atm, q_pa, q_ar, q_pb, q_br, line_a, line_b)
    q_a = q_pa - q_ar
    q_b = q_pb - q_br
    H_a = enthalpy_flow(q_pa, T_sup, Tn_a, cp) + enthalpy_flow(-q_ar, T_atm, Tn_a, cp)
    H_b = enthalpy_flow(q_pb, T_sup, Tn_b, cp) + enthalpy_flow(-q_br, T_atm, Tn_b, cp)
    aux[L.AUX_QA] = q_a
    aux[L.AUX_QB] = q_b
    isothermal = prm[L.P_ISOTHERMAL] > 0.0

    # --- lines in segments (pneucore.physics.tube): valve flow in, chamber flow out (through
    # a cushion's needle at the chamber's end) ------------------------------------------
    # what enters each chamber, for the jet-convection heat model: the valve edges' inflows,
    # or a line's flow into the chamber
    qin_a = max(q_pa, 0.0) + max(-q_ar, 0.0)
    qin_b = max(q_pb, 0.0) + max(-q_br, 0.0)
    if line_a:
        q_a, H_a = call_line_rates(line_terms, 0, iy, y, dy, prm, q_a, H_a, p_a, T_a, r, cp, cv,
                                   isothermal, _needle(x, prm, 0, line_a), prm[L.P_CUSHION_B],
                                   prm[L.P_R_LAM], gamma)
        qin_a = max(q_a, 0.0)
    if line_b:
        q_b, H_b = call_line_rates(line_terms, 1, iy, y, dy, prm, q_b, H_b, p_b, T_b, r, cp, cv,
                                   isothermal, _needle(x, prm, 1, line_b), prm[L.P_CUSHION_B],
                                   prm[L.P_R_LAM], gamma)
        qin_b = max(q_b, 0.0)

    # --- laminar leaks: across the piston, and to ambient ------------------------
    g_ab = prm[L.P_G_AB]
    if g_ab > 0.0:
        q_ab = laminar_mass_flow(p_a, T_a, p_b, T_b, g_ab)
        q_a -= q_ab
        q_b += q_ab
        H_a += enthalpy_flow(-q_ab, T_b, T_a, cp)
        H_b += enthalpy_flow(q_ab, T_a, T_b, cp)
    g_a = prm[L.P_G_A]
    if g_a > 0.0:
        q_l = laminar_mass_flow(p_atm, T_atm, p_a, T_a, g_a)
        q_a += q_l
        H_a += enthalpy_flow(q_l, T_atm, T_a, cp)
    g_b = prm[L.P_G_B]
    if g_b > 0.0:
        q_l = laminar_mass_flow(p_atm, T_atm, p_b, T_b, g_b)
        q_b += q_l
        H_b += enthalpy_flow(q_l, T_atm, T_b, cp)

    # --- user effect terms (only when a user effect is registered in the model) -----
    t_qa = t_ha = t_qa_heat = t_qb = t_hb = t_qb_heat = t_force = 0.0
    if iy[L.IY_HOOK] > 0:
        sig = scratch[:L.N_SIG]
        sig[L.SIG_PA] = p_a
        sig[L.SIG_PB] = p_b
        sig[L.SIG_TA] = T_a
        sig[L.SIG_TB] = T_b
        sig[L.SIG_VA] = V_a
        sig[L.SIG_VB] = V_b
        sig[L.SIG_X] = x
        sig[L.SIG_V] = v
        sig[L.SIG_UEFF] = u_eff
        sig[L.SIG_PSUP] = p_sup
        sig[L.SIG_TSUP] = T_sup
        sig[L.SIG_PATM] = p_atm
        sig[L.SIG_TATM] = T_atm
        terms = scratch[L.N_SIG:L.N_SIG + L.N_TERMS]
        for i in range(L.N_TERMS):
            terms[i] = 0.0
        call_user_terms(t, y, sig, prm_user, terms, dy)
        t_qa = terms[L.TERM_QA]
        t_ha = terms[L.TERM_HA]
        t_qa_heat = terms[L.TERM_QHEAT_A]
        t_qb = terms[L.TERM_QB]
        t_hb = terms[L.TERM_HB]
        t_qb_heat = terms[L.TERM_QHEAT_B]
        t_force = terms[L.TERM_FORCE]
    q_a += t_qa
    H_a += t_ha
    q_b += t_qb
    H_b += t_hb

    # --- heat exchange with the walls (Eq. 9; heat models of pneucore.physics.heat) -------------
    h_a = prm[L.P_H]
    h_b = h_a
    S_a = prm[L.P_WALL_A]
    if S_a <= 0.0:
        S_a = wall_area(V_a, A_a, prm[L.P_BORE], prm[L.P_ROD_A])
    S_b = prm[L.P_WALL_B]
    if S_b <= 0.0:
        S_b = wall_area(V_b, A_b, prm[L.P_BORE], prm[L.P_ROD_B])
    Tw_a = T_atm
    Tw_b = T_atm
    i_wa = iy[L.IY_WALL_A]
    if i_wa >= 0:
        Tw_a = y[i_wa]
        Tw_b = y[iy[L.IY_WALL_B]]
    if prm[L.P_HEAT_NAT] > 0.0 or prm[L.P_HEAT_JET] > 0.0:
        # inflow jet: what enters the chamber (through the valve edges, or from a line)
        h0 = prm[L.P_H]
        c_n = prm[L.P_HEAT_NAT]
        c_j = prm[L.P_HEAT_JET]
        d_in = prm[L.P_HEAT_D_IN]
        D = prm[L.P_BORE]
        h_a = exchange_coefficient(h0, c_n, c_j, d_in, D, r, gamma, p_a, T_a, Tw_a, qin_a)
        h_b = exchange_coefficient(h0, c_n, c_j, d_in, D, r, gamma, p_b, T_b, Tw_b, qin_b)
    Qw_a = convective_heat_flow(h_a, S_a, Tw_a, T_a)
    Qw_b = convective_heat_flow(h_b, S_b, Tw_b, T_b)
    Q_a = Qw_a + t_qa_heat
    Q_b = Qw_b + t_qb_heat

    # --- chambers (Eq. 14-15) ---------------------------------------------------------
    dm, dT = chamber_rates(m_a, T_a, p_a, A_a * v, q_a, H_a, Q_a, cv, isothermal)
    dy[L.Y_MA] = dm
    dy[L.Y_TA] = dT
    if not b_const:
        dm, dT = chamber_rates(m_b, T_b, p_b, -A_b * v, q_b, H_b, Q_b, cv, isothermal)
        dy[L.Y_MB] = dm
        dy[L.Y_TB] = dT

    # --- piston (Eq. 17-20) -----------------------------------------------------------
    F_net = net_pressure_force(p_a, p_b, p_atm, A_a, A_b, prm[L.P_A_ROD_A], prm[L.P_A_ROD_B],
                               prm[L.P_LOAD]) + t_force
    k_s = prm[L.P_SPRING_K]
    f_s = prm[L.P_SPRING_F0]
    if k_s != 0.0 or f_s != 0.0:   # return spring: a load growing with x (Eq. 17)
        F_net -= spring_force(x, k_s, f_s)
    fc_e = coulomb_level(prm[L.P_FE_FC0], prm[L.P_FE_FCA], prm[L.P_FE_FCB], p_a, p_b, p_atm)
    fc_r = coulomb_level(prm[L.P_FR_FC0], prm[L.P_FR_FCA], prm[L.P_FR_FCB], p_a, p_b, p_atm)
    ratio = prm[L.P_STRIBECK_RATIO]
    v_s = prm[L.P_STRIBECK_V]
    law_f = int(prm[L.P_FRICTION_LAW])
    if mode == L.MODE_SLIDE_POS:
        kv = viscous_coefficient(prm[L.P_FE_KV0], prm[L.P_FE_KVA], prm[L.P_FE_KVB], p_a, p_b, p_atm)
        F_f = friction_force(law_f, v, 1.0, fc_e, kv, ratio, v_s)
        acc = (F_net - F_f) / prm[L.P_MASS]
        dy[L.Y_X] = v
        dy[L.Y_V] = acc
    elif mode == L.MODE_SLIDE_NEG:
        kv = viscous_coefficient(prm[L.P_FR_KV0], prm[L.P_FR_KVA], prm[L.P_FR_KVB], p_a, p_b, p_atm)
        F_f = friction_force(law_f, v, -1.0, fc_r, kv, ratio, v_s)
        acc = (F_net - F_f) / prm[L.P_MASS]
        dy[L.Y_X] = v
        dy[L.Y_V] = acc
    elif mode == L.MODE_STICK:
        F_f = F_net
        acc = 0.0
    else:
        F_f = 0.0
        acc = 0.0

    # --- state terms (sensors, walls: pneucore.physics.states), from their table ------
    call_state_rates(state_terms, iy, y, dy, prm, (p_a, T_a, Qw_a, S_a), (p_b, T_b, Qw_b, S_b),
                     T_atm, b_const)

    # --- supply line mass balance (isothermal line) ------------------------------------
    q_draw = q_pa + q_pb
    if i_ms >= 0:
        # the regulator is an ISO 6358 restriction whatever the valve's law
        q_reg = iso6358_mass_flow(prm[L.P_SUP], T_sup, p_sup, T_sup, prm[L.P_SUP_C], prm[L.P_SUP_B],
                                  0.5, prm[L.P_R_LAM], r, gamma)
        dy[i_ms] = q_reg - q_draw
        q_draw = q_reg

    aux[L.AUX_PA] = p_a
    aux[L.AUX_PB] = p_b
    aux[L.AUX_FRICTION] = F_f
    aux[L.AUX_ACC] = acc
    aux[L.AUX_UEFF] = u_eff
    aux[L.AUX_PSUP] = p_sup
    aux[L.AUX_FNET] = F_net
    aux[L.AUX_HEAT_A] = Q_a
    aux[L.AUX_HEAT_B] = Q_b
    aux[L.AUX_FS_E] = static_friction(law_f, fc_e, ratio, v_s)
    aux[L.AUX_FS_R] = static_friction(law_f, fc_r, ratio, v_s)
    aux[L.AUX_VA] = V_a
    aux[L.AUX_VB] = V_b
    aux[L.AUX_QSUP] = q_draw
