"""The compiled simulator: state layout, right-hand side, integrator and its cache guard.

``layout`` names every state and parameter slot, ``rhs`` assembles the
paper's equations from :mod:`pneucore.physics` into one right-hand side,
``integrator`` is the stiff Rosenbrock (RODAS4) integrator with exact
stick/slip events, ``cache`` keeps numba's on-disk cache consistent with the
sources.
"""
