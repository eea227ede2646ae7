"""Valve data as catalogues print it (Qn, effective area S, Cv/Kv) converted to the model's
C [m^3/(s Pa)], checked against the ISO 6358 law itself and published examples."""
import math

import pytest

from pneucore.physics.flow import (conductance_from_area, conductance_from_flow,
                                   conductance_from_qn, iso6358_mass_flow, kv_from_cv,
                                   saint_venant_area)

RHO0, T0 = 1.185, 293.15


@pytest.mark.parametrize("C,b", [(1e-8, 0.3), (3.2e-9, 0.42), (2.5e-8, 0.15)])
def test_qn_is_the_iso6358_flow_at_6_bar_gauge_and_1_bar_drop(C, b):
    """The nominal flow the ISO 6358 law gives at 7 -> 6 bar absolute, converted back,
    returns C (1e-12: floating point only)."""
    q = iso6358_mass_flow(7e5, T0, 6e5, T0, C, b, 0.5, 0.999, 287.05, 1.4)
    qn = q / RHO0 * 1e3 * 60.0          # NL/min
    assert conductance_from_qn(qn, b) == pytest.approx(C, rel=1e-12)


def test_smc_worked_example():
    """SMC VX datasheet: C = 2 dm^3/(s bar), b = 0.3, 0.4 -> 0.3 MPa gauge: 420 dm^3/min
    (ANR), read from a chart to two digits (flow ratio 0.7), hence 0.5 %."""
    assert conductance_from_flow(420e-3 / 60.0, 5e5, 4e5, 0.3) == pytest.approx(2e-8, rel=5e-3)


def test_effective_area_inverts_the_ideal_nozzle_and_matches_the_5x_rule():
    """S -> C is the inverse of the nozzle area of equal choked flow (1e-12), and S [mm^2]
    = 5.0 C [dm^3/(s bar)] of JIS B 8390 catalogues holds to its rounding (1 %)."""
    C = conductance_from_area(5e-6)
    assert saint_venant_area(C, 287.05, 1.4) == pytest.approx(5e-6, rel=1e-12)
    assert C == pytest.approx(1e-8, rel=0.01)


def test_kv_from_cv_follows_the_units():
    """1 Cv: 1 US gal/min of water at 1 psi; in m^3/h at 1 bar: 0.2271 x sqrt(14.504)."""
    assert kv_from_cv(1.0) == pytest.approx(0.2271247 * math.sqrt(1e5 / 6894.757), rel=1e-6)
    assert kv_from_cv(1.0) == pytest.approx(0.865, abs=5e-4)   # IEC 60534-1's rounded factor
