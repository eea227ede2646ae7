"""Servo-pneumatic position control (issue 42).

* :mod:`pneucore.control.linearize`: state-space model at an operating point, from the same
  right-hand side the integrator uses (:func:`pneucore.core.rhs.rhs`);
* :mod:`pneucore.control.setpoints`: reference trajectories (step, multi-step, ramp, sine,
  jerk-limited point-to-point, recorded);
* :mod:`pneucore.control.controllers`: the controller registry (PID, sliding mode, on/off
  with dead band, PVA, pressure-difference inner loop), checked gains;
* :mod:`pneucore.control.closed_loop`: :func:`simulate_closed_loop`, the loop closed inside
  the compiled core at the controller's sample period;
* :mod:`pneucore.control.metrics`: rise time, settling time, overshoot, ... of a run.

See docs/guides/position-control.md.
"""
