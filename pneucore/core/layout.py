"""Slot layout of the flat arrays passed to the compiled core.

The compiled right-hand side receives the model as one float vector ``prm``
and the positions of optional states as one integer vector ``iy``. The names
below are module constants, which numba folds into the compiled code. Effects
(``pneucore.spec.effects``) fill their own slots and declare their own states, so
the base equations never change when an effect is added.
"""

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
IY_SENSOR_A = 3     # pressure seen by the transducer of chamber A [Pa]
IY_SENSOR_B = 4     # pressure seen by the transducer of chamber B [Pa]
IY_USER0 = 5        # first state of user-registered effects
IY_NUSER = 6        # number of user states
IY_HOOK = 7         # 1 when user effect terms are present
IY_WALL_A = 8       # wall temperature of chamber A [K] (heat model with a wall capacity)
IY_WALL_B = 9       # wall temperature of chamber B [K]
IY_TSENSOR_A = 10   # gas temperature seen by the sensor of chamber A [K]
IY_TSENSOR_B = 11   # gas temperature seen by the sensor of chamber B [K]
N_IY = 12

# --- parameter slots in ``prm`` ------------------------------------------------
_names = [
    # gas
    "R", "GAMMA",
    # supply and ambient (exhaust) nodes
    "SUP", "T_SUP", "ATM", "T_ATM",
    # jack geometry and load
    "A_A", "A_B", "A_ROD_A", "A_ROD_B", "STROKE", "V0_A", "V0_B", "MASS", "LOAD",
    "BORE", "ROD_A", "ROD_B", "WALL_A", "WALL_B",
    # heat exchange: coefficient, isothermal flag
    "H", "ISOTHERMAL",
    # heat models (pneucore.physics.heat): natural and jet multipliers, inlet diameter [m];
    # wall mass [kg], specific heat [J/(kg K)], outer coefficient [W/(m^2 K)];
    # gas-temperature sensor time constant [s]
    "HEAT_NAT", "HEAT_JET", "HEAT_D_IN", "WALL_MASS", "WALL_CP", "WALL_H_OUT", "TSENSOR_TAU",
    # friction, extend set then retract set
    "FE_FC0", "FE_FCA", "FE_FCB", "FE_KV0", "FE_KVA", "FE_KVB",
    "FR_FC0", "FR_FCA", "FR_FCB", "FR_KV0", "FR_KVA", "FR_KVB",
    # Stribeck breakaway: Fs/Fc ratio (1 = none) and Stribeck velocity [m/s]
    "STRIBECK_RATIO", "STRIBECK_V",
    # laminar leaks [kg/(s Pa)]: across the piston, chamber A and B to ambient
    "G_AB", "G_A", "G_B",
    # valve: centred-spool leakage fraction, flow law code, laminar ratio
    "NULL_LEAK", "FLOW_LAW", "R_LAM",
    # spool dynamics: time constant [s], natural frequency [rad/s], damping [-]
    "SPOOL_TAU", "SPOOL_WN", "SPOOL_ZETA",
    # supply line: regulator conductance [m^3/(s Pa)], critical ratio, volume [m^3]
    "SUP_C", "SUP_B", "SUP_V",
    # pressure transducer lag [s]
    "SENSOR_TAU",
    # 3/2 mode: constant pressure of chamber B [Pa] (0 = chamber B is dynamic)
    "B_CONST",
    # scratch for the full-opening C and b of each edge (null leakage)
    "CMAX_PA", "CMAX_AR", "CMAX_PB", "CMAX_BR",
    "BMAX_PA", "BMAX_AR", "BMAX_PB", "BMAX_BR",
]
PRM_INDEX = {name: i for i, name in enumerate(_names)}
N_PRM = len(_names)
globals().update({"P_" + name: i for name, i in PRM_INDEX.items()})

# --- valve edges ---------------------------------------------------------------
PORT_NAMES = ("P-A", "A-R", "P-B", "B-R")
N_PORTS = 4

# --- auxiliary outputs computed by the right-hand side --------------------------
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
N_SIG = len(SIG_NAMES)
#: Terms a user effect may add: mass flow [kg/s], enthalpy flow [W] and heat
#: flow [W] into each chamber, and a force on the piston towards +x [N]
TERM_NAMES = ("q_a", "H_a", "Q_a", "q_b", "H_b", "Q_b", "force")
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
