"""Sensors with a response time: first-order lags of the pressure and gas-temperature
transducers of each chamber, as state terms (:mod:`pneucore.physics.states`).

A transducer of time constant ``tau`` reports ``y_s`` with

.. math:: \\frac{dy_s}{dt} = \\frac{y - y_s}{\\tau}

(the first-order instrument of Doebelin, *Measurement Systems*, 5th ed., Sect. 3.3),
``y`` the chamber's pressure or gas temperature. The comparison with a measurement reads
the sensor's state in place of the chamber's value
(:meth:`pneucore.result.SimulationResult.observed`). Each sensor is registered here, once:
its rate law, its parameter (the time constant), its states and where they start.

The closed loop's controller (:func:`pneucore.core.integrator.integrate_closed`) reads the
signals at its sample instants ``t_k = k T_s`` through the model's sensors (effect
``sensor_lag``, :mod:`pneucore.description.effects`): the position through
:func:`sense_position` (a first-order lag, then a seeded Gaussian noise drawn before the run,
then the encoder's quantisation: the chain of an analog sensor read by a converter, or of an
encoder with a resolution), the pressures through the transducers' lag above plus their noise.
"""
import math

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
def quantise(y, q):
    """A reading on a grid of step ``q`` (the mid-tread quantiser: the nearest level, error
    within ``q / 2``); ``q <= 0`` leaves it as it is.

    Parameters
    ----------
    y : float
        Reading (position [m])
    q : float
        Resolution, same unit (an encoder's count)

    Examples
    --------
    >>> quantise(0.10034, 0.0005)
    0.1005
    """
    if q <= 0.0:
        return y
    return q * math.floor(y / q + 0.5)


@njit(cache=True, error_model="numpy", _nrt=False)
def sampled_lag(y_s, y_prev, y, dt, tau):
    """The first-order sensor (:func:`first_order_lag`) advanced over one sample interval
    ``dt`` exactly, its input ``y`` taken straight (linear) between the two samples.

    Parameters
    ----------
    y_s : float
        Reading at the previous sample (position [m])
    y_prev, y : float
        True value at the previous and at this sample, same unit
    dt : float
        Sample interval [s]
    tau : float
        Time constant [s]; ``tau <= 0``: no lag (returns ``y``)

    Returns
    -------
    y_s : float
        Reading at this sample

    Examples
    --------
    From rest, a 1 mm rise over one 1 ms sample read through a 10 ms lag: 48.4 um
    (``1 mm (1 - tau / dt (1 - exp(-dt / tau)))``)

    >>> round(sampled_lag(0.0, 0.0, 1e-3, 1e-3, 0.01) * 1e6, 3)
    48.374
    """
    if tau <= 0.0:
        return y
    a = math.exp(-dt / tau)
    # exact for y(s) = y_prev + (y - y_prev) s / dt on [0, dt]
    return a * y_s + (1.0 - a) * y_prev + (y - y_prev) * (1.0 - tau / dt * (1.0 - a))


#: Slots of the position sensor's state (``sense_position``) and the rate estimator's
#: (``estimate_rates``) in the closed loop's sensor state vector
SST_LAG, SST_XPREV, SST_STARTED, SST_XS_PREV, SST_V, SST_A, SST_EST_STARTED = range(7)
N_SST = 7

#: Slots of the closed loop's sensor parameters (:func:`pneucore.control.closed_loop.sensor_signals`):
#: position resolution [m], position lag [s], sample period [s], the rate estimator's filter
#: time constant [s], the ideal-rates flag (1: the laws read the piston's true velocity and
#: acceleration) [-], the pressure transducers' resolution [Pa]
SENS_Q, SENS_TAU, SENS_TS, SENS_RATE_TAU, SENS_IDEAL_RATES, SENS_P_Q = range(6)
N_SENS = 6


@njit(cache=True, error_model="numpy", _nrt=False)
def sense_position(x, sens, state, noise):
    """The position a controller reads at one sample instant: the true ``x`` [m] through the
    position sensor's lag, plus the sample's noise draw, quantised to the resolution.

    Parameters
    ----------
    x : float
        True position at this sample [m]
    sens : ndarray
        Sensor parameters (``SENS_*`` slots; here the resolution [m], the time constant [s]
        and the sample interval [s])
    state : ndarray
        The sensor state: ``(lagged reading [m], previous true position [m], started flag)``
        in slots ``SST_LAG``, ``SST_XPREV``, ``SST_STARTED``, updated
    noise : float
        This sample's noise [m] (drawn before the run from the controller's seed)

    Returns
    -------
    x_s : float
        Sensed position [m]
    """
    if state[SST_STARTED] == 0.0:
        state[SST_LAG] = x              # the sensor starts settled at the true position
    else:
        state[SST_LAG] = sampled_lag(state[SST_LAG], state[SST_XPREV], x, sens[SENS_TS],
                                     sens[SENS_TAU])
    state[SST_XPREV] = x
    state[SST_STARTED] = 1.0
    return quantise(state[SST_LAG] + noise, sens[SENS_Q])


@njit(cache=True, error_model="numpy", _nrt=False)
def estimate_rates(x_s, state, Ts, tau):
    """The velocity and acceleration a controller reads: estimated from the sensed position by
    a first-order filtered differentiator at the sample period, twice (the velocity from the
    position, the acceleration from that velocity).

    Each stage is the filtered derivative ``s / (tau s + 1)`` discretised by backward
    differences, ``s -> (1 - z^-1) / T_s`` (the derivative term of a digital PID as Astrom
    and Hagglund implement it, *PID Controllers: Theory, Design and Tuning*, 2nd ed., ISA,
    1995, computer implementation; the PID law here does the same on the error; stable for
    every ``tau >= 0``)::

        v_k = a v_(k-1) + (1 - a) (x_k - x_(k-1)) / T_s,   a = tau / (tau + T_s)
        a_k = a a_(k-1) + (1 - a) (v_k - v_(k-1)) / T_s

    so that ``V(z) / X(z) = (1 - z^-1) / (tau + T_s - tau z^-1)``: on a ramp the estimate
    converges to the slope (geometrically, ratio ``a``), a sine of frequency ``w`` comes out
    multiplied by ``H(exp(j w T_s))``, and a reading quantised to a step ``q`` (error within
    ``q / 2``) errs by at most ``q / (tau + T_s)``. ``tau = 0``: the plain backward difference.
    The first sample starts the estimator at rest (``v = a = 0``).

    Parameters
    ----------
    x_s : float
        Sensed position at this sample [m]
    state : ndarray
        The sensor state (``SST_*`` slots; the estimator's: the previous sensed position [m],
        the velocity [m/s] and acceleration [m/s^2] estimates, a started flag), updated
    Ts : float
        Sample period [s]
    tau : float
        Filter time constant [s] (cut-off ``1 / (2 pi tau)`` [Hz])

    Examples
    --------
    A ramp of 0.1 m/s sampled at 1 ms through a 2 ms filter: after 60 samples the estimate is
    ``0.1 (1 - (2/3)^59)``, the slope to 4e-12 m/s

    >>> import numpy as np
    >>> st = np.zeros(N_SST)
    >>> for k in range(60):
    ...     estimate_rates(1e-4 * k, st, 1e-3, 2e-3)
    >>> round(float(st[SST_V]), 9), round(float(st[SST_A]), 6)
    (0.1, 0.0)
    """
    if state[SST_EST_STARTED] == 0.0:
        state[SST_XS_PREV] = x_s
        state[SST_V] = 0.0
        state[SST_A] = 0.0
        state[SST_EST_STARTED] = 1.0
        return
    a = tau / (tau + Ts)
    v = a * state[SST_V] + (1.0 - a) * (x_s - state[SST_XS_PREV]) / Ts
    state[SST_A] = a * state[SST_A] + (1.0 - a) * (v - state[SST_V]) / Ts
    state[SST_V] = v
    state[SST_XS_PREV] = x_s


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
