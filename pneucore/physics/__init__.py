"""The paper's physical laws, SI units, one module per effect.

``gas`` (air properties; Eq. 10-11), ``flow`` (ISO 6358 orifice; Eq. 1-5),
``valve`` (C and b against the spool opening), ``chamber`` (mass and energy
conservation; Eq. 12-15, 22-24), ``heat`` (wall exchange; Eq. 9), ``jack``
(piston dynamics; Eq. 17, 23-24), ``friction`` (Coulomb and viscous,
pressure and quadrant; Eq. 18-20), ``vessel`` (a rigid chamber filled through
an orifice), ``series`` (restrictions in series without a volume between them,
ISO 6358-3), ``tube`` (a line: volume and Fanno-flow characteristic). Pure functions; the compiled ones are what :mod:`pneucore.core`
links into its right-hand side.
"""
