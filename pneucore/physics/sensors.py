"""Sensors with a response time: first-order lags of the pressure and gas-temperature
transducers of each chamber, as state terms (:mod:`pneucore.physics.states`).

A transducer of time constant ``tau`` reports ``y_s`` with

.. math:: \\frac{dy_s}{dt} = \\frac{y - y_s}{\\tau}

(the first-order instrument of Doebelin, *Measurement Systems*, 5th ed., Sect. 3.3),
``y`` the chamber's pressure or gas temperature. The comparison with a measurement reads
the sensor's state in place of the chamber's value
(:meth:`pneucore.result.SimulationResult.observed`). Each sensor is registered here, once:
its rate law, its parameter (the time constant), its states and where they start.
"""
from numba import njit

from pneucore.physics.states import StateTerm, register_state_term


@njit(cache=True, error_model="numpy", _nrt=False)
def first_order_lag(y_s, y, tau):
    """Rate of a first-order sensor [unit of ``y`` / s].

    Parameters
    ----------
    y_s : float
        Sensor reading (pressure [Pa] or temperature [K])
    y : float
        True value, same unit
    tau : float
        Time constant [s]

    Examples
    --------
    A sensor reading 1 bar below the chamber with tau = 2 ms closes the gap at 500 bar/s:

    >>> first_order_lag(4e5, 5e5, 0.002)
    50000000.0
    """
    return (y - y_s) / tau


@njit(cache=True, error_model="numpy", _nrt=False)
def pressure_sensor_rate(y_s, p, T, Q, S, T_amb, prm, k0):
    """State-term rate of a pressure transducer [Pa/s]: lag of ``p`` [Pa], time constant
    ``prm[k0]`` [s] (signature of :mod:`pneucore.physics.states`)."""
    return first_order_lag(y_s, p, prm[k0])


@njit(cache=True, error_model="numpy", _nrt=False)
def temperature_sensor_rate(y_s, p, T, Q, S, T_amb, prm, k0):
    """State-term rate of a gas-temperature sensor [K/s]: lag of ``T`` [K], time constant
    ``prm[k0]`` [s] (signature of :mod:`pneucore.physics.states`)."""
    return first_order_lag(y_s, T, prm[k0])


def _pressure_start(p_a, p_b, T_a, T_b, T_amb, p_sup):
    # the transducers start at the chambers' pressures; tolerance a millionth of the supply
    return (p_a, 1e-6 * p_sup), (p_b, 1e-6 * p_sup)


def _temperature_start(p_a, p_b, T_a, T_b, T_amb, p_sup):
    return (T_a, 1e-6 * T_a), (T_b, 1e-6 * T_b)


#: Pressure transducers' lag (effect ``sensor_lag``): states ``p_a_sensor``, ``p_b_sensor``
PRESSURE_SENSOR = register_state_term(StateTerm(
    "pressure_sensor", pressure_sensor_rate, (("time_constant", "s"),),
    ("p_a_sensor", "p_b_sensor"), "Pa", _pressure_start,
    description="first-order lag of the pressure transducers"))

#: Gas-temperature sensors' lag (``heat.sensor_time_constant``): states ``T_a_sensor``,
#: ``T_b_sensor``
TEMPERATURE_SENSOR = register_state_term(StateTerm(
    "temperature_sensor", temperature_sensor_rate, (("time_constant", "s"),),
    ("T_a_sensor", "T_b_sensor"), "K", _temperature_start,
    description="first-order lag of the gas-temperature sensors"))
