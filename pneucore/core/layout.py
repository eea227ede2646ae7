"""Slot layout of the flat arrays passed to the compiled core.

The compiled right-hand side receives the model as one float vector ``prm``
and the positions of optional states as one integer vector ``iy``. The names
below are module constants, which numba folds into the compiled code. Effects
(``pneucore.description.effects``) fill their own slots and declare their own states, so
the base equations never change when an effect is added. The effects with a
state per chamber (:mod:`pneucore.physics.states`) get their slots from their
registry, after the base slots written out here.
"""

import pneucore.physics.heat       # noqa: F401  (registers the state term ``wall``)
import pneucore.physics.sensors    # noqa: F401  (registers the sensors' state terms)
import pneucore.physics.tube       # noqa: F401  (registers the line term ``line``)
import pneucore.physics.flow_control  # noqa: F401  (registers the line term ``flow_control_node``)
from pneucore.physics.states import slot_blocks
from pneucore.physics.valve import PORT_NAMES

_STATE_BLOCKS = slot_blocks()

# --- base states (always present) --------------------------------------------
Y_MA, Y_TA, Y_MB, Y_TB, Y_X, Y_V = 0, 1, 2, 3, 4, 5
N_BASE_STATES = 6
BASE_STATE_NAMES = ("m_a", "T_a", "m_b", "T_b", "x", "v")
#: Unit of each base state, for the docs and the result object
STATE_UNITS = {"m_a": "kg", "T_a": "K", "m_b": "kg", "T_b": "K", "x": "m", "v": "m/s"}

# --- optional state positions in ``iy`` (-1 when the state is absent) ---------
IY_SPOOL = 0        # effective spool opening [-]
IY_SPOOL_RATE = 1   # its rate [1/s] (second-order spool only)
IY_SUPPLY_M = 2     # gas mass in the supply line [kg]
IY_USER0 = 3        # first state of user-registered effects
IY_NUSER = 4        # number of user states
IY_HOOK = 5         # 1 when user effect terms are present
N_IY = 6
# the state terms' positions follow (STATE_IY0 below)

# --- parameter slots in ``prm`` ------------------------------------------------
# Written out (not generated) so that a search finds each slot; PRM_INDEX below is
# read back from these names, and tests/test_layout_names.py checks that the slots
# are 0 .. N_PRM - 1 without gaps or repeats.
# gas: specific gas constant [J/(kg K)], ratio of specific heats [-]
P_R = 0
P_GAMMA = 1
# supply and ambient (exhaust) nodes: pressures [Pa], temperatures [K]
P_SUP = 2
P_T_SUP = 3
P_ATM = 4
P_T_ATM = 5
# jack geometry and load: areas [m^2], stroke [m], dead volumes [m^3], mass [kg],
# load [N], diameters [m], wall areas [m^2] (0 = from the geometry)
P_A_A = 6
P_A_B = 7
P_A_ROD_A = 8
P_A_ROD_B = 9
P_STROKE = 10
P_V0_A = 11
P_V0_B = 12
P_MASS = 13
P_LOAD = 14
P_BORE = 15
P_ROD_A = 16
P_ROD_B = 17
P_WALL_A = 18
P_WALL_B = 19
# heat exchange: coefficient [W/(m^2 K)], isothermal flag
P_H = 20
P_ISOTHERMAL = 21
# heat models (pneucore.physics.heat): natural and jet multipliers, inlet diameter [m]
P_HEAT_NAT = 22
P_HEAT_JET = 23
P_HEAT_D_IN = 24
# friction (Eq. 19-20), extend set then retract set: fc0 [N], fc_a, fc_b [N/Pa],
# kv0 [N s/m], kv_a, kv_b [N s/(m Pa)]
P_FE_FC0 = 25
P_FE_FCA = 26
P_FE_FCB = 27
P_FE_KV0 = 28
P_FE_KVA = 29
P_FE_KVB = 30
P_FR_FC0 = 31
P_FR_FCA = 32
P_FR_FCB = 33
P_FR_KV0 = 34
P_FR_KVA = 35
P_FR_KVB = 36
# Stribeck breakaway: Fs/Fc ratio (1 = none) and Stribeck velocity [m/s]
P_STRIBECK_RATIO = 37
P_STRIBECK_V = 38
# laminar leaks [kg/(s Pa)]: across the piston, chamber A and B to ambient
P_G_AB = 39
P_G_A = 40
P_G_B = 41
# valve: centred-spool leakage fraction, flow law code (FLOW_LAWS[...].code), laminar ratio
P_NULL_LEAK = 42
P_FLOW_LAW = 43
P_R_LAM = 44
# spool dynamics: time constant [s], natural frequency [rad/s], damping [-]
P_SPOOL_TAU = 45
P_SPOOL_WN = 46
P_SPOOL_ZETA = 47
# supply line: regulator conductance [m^3/(s Pa)], critical ratio, volume [m^3]
P_SUP_C = 48
P_SUP_B = 49
P_SUP_V = 50
# 3/2 mode: constant pressure of chamber B [Pa] (0 = chamber B is dynamic)
P_B_CONST = 51
# full-opening C [m^3/(s Pa)] and b [-] of each edge, in PORT_NAMES order (null leakage)
P_CMAX_PA = 52
P_CMAX_AR = 53
P_CMAX_PB = 54
P_CMAX_BR = 55
P_BMAX_PA = 56
P_BMAX_AR = 57
P_BMAX_PB = 58
P_BMAX_BR = 59
# friction law code (FRICTION_LAWS[...].code)
P_FRICTION_LAW = 60
# return spring (effect ``return_spring``): rate [N/m], force at x = 0 [N]; both 0 = none
P_SPRING_K = 61
P_SPRING_F0 = 62
# end cushions (effect ``end_cushion``, pneucore.physics.cushion): lengths at the x = 0 end
# (chamber A) and the x = stroke end (chamber B) [m], both 0 = none; needle conductances
# [m^3/(s Pa)] and critical ratio [-]
P_CUSHION_LA = 63
P_CUSHION_LB = 64
P_CUSHION_CA = 65
P_CUSHION_CB = 66
P_CUSHION_B = 67

#: Slot of each parameter by name (without the ``P_`` prefix), read from the constants above
PRM_INDEX = dict(sorted(((name[2:], i) for name, i in globals().items()
                         if name.startswith("P_") and isinstance(i, int)), key=lambda kv: kv[1]))
N_PRM = len(PRM_INDEX)

# --- state and line terms (pneucore.physics.states): slots assigned by the registry ---------
#: First parameter slot of each state term and line term (port A's block; port B's follows),
#: after the base slots
STATE_PRM0 = {name: N_PRM + k for name, k in _STATE_BLOCKS[0].items()}
#: Slot in ``iy`` of each state term's first state (chamber A's; chamber B's follows), and of
#: each line term's first state on port A (port B's follows), after the base positions
STATE_IY0 = {name: N_IY + k for name, k in _STATE_BLOCKS[1].items()}
#: Length of the core's parameter vector and of its state-position vector
N_PRM_ALL = N_PRM + _STATE_BLOCKS[2]
N_IY_ALL = N_IY + _STATE_BLOCKS[3]
#: The wall temperatures, which the heat exchange law reads (state term ``wall``)
IY_WALL_A = STATE_IY0["wall"]
IY_WALL_B = IY_WALL_A + 1

# --- valve edges ---------------------------------------------------------------
N_PORTS = len(PORT_NAMES)

# --- auxiliary outputs computed by the right-hand side --------------------------
# q_a, q_b: the valve's net mass flow into each port [kg/s], before a line in segments (the
# flow into the chamber is then the line's last face); into the chamber otherwise
AUX_NAMES = ("p_a", "p_b", "q_a", "q_b", "friction", "a", "u_eff", "p_supply",
             "net_force", "heat_a", "heat_b", "static_limit_ext", "static_limit_ret",
             "V_a", "V_b", "q_supply")
AUX_PA, AUX_PB, AUX_QA, AUX_QB, AUX_FRICTION, AUX_ACC, AUX_UEFF, AUX_PSUP, \
    AUX_FNET, AUX_HEAT_A, AUX_HEAT_B, AUX_FS_E, AUX_FS_R, AUX_VA, AUX_VB, \
    AUX_QSUP = range(len(AUX_NAMES))
N_AUX = len(AUX_NAMES)

# --- signals handed to user effect terms ----------------------------------------
SIG_NAMES = ("p_a", "p_b", "T_a", "T_b", "V_a", "V_b", "x", "v", "u_eff",
             "p_supply", "T_supply", "p_atm", "T_atm")
#: Position of each signal in ``sig`` (pressures [Pa], temperatures [K], volumes [m^3],
#: position [m], velocity [m/s], spool opening [-])
SIG_PA, SIG_PB, SIG_TA, SIG_TB, SIG_VA, SIG_VB, SIG_X, SIG_V, SIG_UEFF, \
    SIG_PSUP, SIG_TSUP, SIG_PATM, SIG_TATM = range(13)
N_SIG = len(SIG_NAMES)
#: Terms a user effect may add: mass flow [kg/s], enthalpy flow [W] and heat
#: flow [W] into each chamber, and a force on the piston towards +x [N]
TERM_NAMES = ("q_a", "H_a", "Q_a", "q_b", "H_b", "Q_b", "force")
#: Position of each term in ``terms``
TERM_QA, TERM_HA, TERM_QHEAT_A, TERM_QB, TERM_HB, TERM_QHEAT_B, TERM_FORCE = range(7)
N_TERMS = len(TERM_NAMES)
#: Length of the right-hand side's work vector (signals, then terms)
N_SCRATCH = N_SIG + N_TERMS

# --- piston modes ----------------------------------------------------------------
MODE_STICK, MODE_SLIDE_POS, MODE_SLIDE_NEG, MODE_STOP_LOW, MODE_STOP_HIGH, MODE_LOCKED = range(6)
MODE_NAMES = ("stick", "slide", "slide", "stop", "stop", "locked")
MODE_DETAIL = ("stick", "slide+", "slide-", "stop@0", "stop@stroke", "locked")

# --- event kinds -------------------------------------------------------------------
EV_COMMAND, EV_SLIP, EV_STICK, EV_STOP, EV_REVERSE = range(5)
EVENT_NAMES = ("command", "slip", "stick", "stop", "reverse")
