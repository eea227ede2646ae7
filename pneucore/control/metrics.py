"""Metrics of a closed-loop run (issue 42, item 4), from its sampled series.

For the first move of the setpoint (a step's jump, a ramp's or a point-to-point's whole move)
of size ``D = x1 - x0`` starting at ``t0``:

* ``rise_time`` [s]: from 10 % to 90 % of the move;
* ``settling_time`` [s]: from ``t0`` to the last time the position is outside the band
  ``x1 +- 2 % |D|`` (``settling_time_band`` the same for the band ``band`` [m] given, e.g.
  1 mm); None when it never settles within the run;
* ``overshoot`` [-]: the largest excursion past ``x1``, over ``|D|``;
* ``steady_state_error`` [m]: ``x_ref - x`` averaged over the last 10 % of the run;
* ``rms_error`` [m]: root mean square of ``x_ref - x`` over the run;
* ``hunting_amplitude`` [m] and ``hunting_frequency`` [Hz]: half the peak-to-peak position
  over the last 30 % of the run, and its rate of crossing its mean (half the crossings per
  second); zero when the piston rests there;
* ``switchings`` [-]: changes of the valve command's side of its centre (the controller
  counts them at its sample instants);
* ``air_per_move`` [NL]: supply air over the run per move, at normal conditions (ISO 8778:
  20 degC, 1 bar abs: 1.189 kg/m^3).
"""
from __future__ import annotations

import numpy as np

#: Density of air at ISO 8778 normal conditions (20 degC, 100 kPa) [kg/m^3]
RHO_NORMAL = 1.189

#: The metrics a closed-loop study records per run: name -> (unit, definition) (see the module)
CONTROL_METRICS = {
    "rise_time": ("s", "10 % to 90 % of the first move"),
    "settling_time": ("s", "from the first move's start to its last exit of the 2 % band (or "
                           "the controller's settle_band); null when it never settles"),
    "overshoot": ("-", "largest excursion past the move's end, over the move"),
    "steady_state_error": ("m", "x_ref - x averaged over the last 10 % of the run"),
    "rms_error": ("m", "root mean square of x_ref - x over the run"),
    "hunting_amplitude": ("m", "half the peak-to-peak position over the last 30 % of the run"),
    "hunting_frequency": ("Hz", "rate of the position crossing its mean over the last 30 %, "
                                "halved"),
    "switchings": ("-", "changes of the valve command's side of its centre"),
    "air_per_move": ("NL", "supply air per move at ISO 8778 normal conditions"),
}


def _integral(y, t):
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(t))) if len(t) > 1 else 0.0


def control_metrics(t, x, x_ref, moves, q_supply=None, switchings=None, band=None):
    """Metrics of a run (see the module).

    Parameters
    ----------
    t, x, x_ref : ndarray
        Times [s], position [m], reference [m]
    moves : list of (t0 [s], x0 [m], x1 [m])
        The setpoint's moves (:meth:`pneucore.control.setpoints.Setpoint.moves`)
    q_supply : ndarray or None
        Supply mass flow [kg/s]
    switchings : int or None
        Valve switchings counted by the controller [-]
    band : float or None
        Settling band [m] of ``settling_time_band``

    Returns
    -------
    metrics : dict
        The metrics named in the module (None where undefined)
    """
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    e = np.asarray(x_ref, float) - x
    ok = np.isfinite(x)
    out = {"rise_time": None, "settling_time": None, "settling_time_band": None,
           "overshoot": None, "steady_state_error": None, "rms_error": None,
           "hunting_amplitude": None, "hunting_frequency": None,
           "switchings": None if switchings is None else int(switchings),
           "air_per_move": None, "band": band}
    if not ok.all() or len(t) < 3:
        return out
    out["rms_error"] = float(np.sqrt(np.mean(e ** 2)))
    tail = t >= t[0] + 0.9 * (t[-1] - t[0])
    out["steady_state_error"] = float(np.mean(e[tail]))
    late = t >= t[0] + 0.7 * (t[-1] - t[0])
    xl = x[late]
    amp = 0.5 * float(xl.max() - xl.min())
    out["hunting_amplitude"] = amp
    if amp > 0.0:
        c = xl - xl.mean()
        crossings = np.count_nonzero(np.diff(np.sign(c[np.abs(c) > 0.1 * amp])) != 0)
        span = t[late][-1] - t[late][0]
        out["hunting_frequency"] = float(0.5 * crossings / span) if span > 0 else 0.0
    else:
        out["hunting_frequency"] = 0.0
    if q_supply is not None and moves:
        mass = _integral(np.asarray(q_supply, float), t)
        out["air_per_move"] = mass / RHO_NORMAL * 1e3 / len(moves)
    if not moves:
        return out
    t0, x0, x1 = moves[0]
    t_next = moves[1][0] if len(moves) > 1 else t[-1] + 1.0
    w = (t >= t0) & (t < t_next)
    tw, xw = t[w], x[w]
    D = x1 - x0
    if D == 0.0 or len(tw) < 2:
        return out
    s = (xw - x0) / D                       # progress of the move, 0 -> 1
    i10 = np.flatnonzero(s >= 0.1)
    i90 = np.flatnonzero(s >= 0.9)
    if i10.size and i90.size:
        out["rise_time"] = float(tw[i90[0]] - tw[i10[0]])
    out["overshoot"] = float(max(0.0, s.max() - 1.0))

    def settle(width):
        outside = np.flatnonzero(np.abs(xw - x1) > width)
        if outside.size == 0:
            return 0.0
        if outside[-1] == len(xw) - 1:
            return None                       # still outside at the end of the window
        return float(tw[outside[-1] + 1] - t0)
    out["settling_time"] = settle(0.02 * abs(D))
    if band is not None:
        out["settling_time_band"] = settle(band)
    return out
