"""Oracle tests of the orifice flow laws in :mod:`pneucore.physics.flow`.

The oracles are external to the code base:

* ISO 6358 worked catalogue numbers (C = 2 dm^3/(s bar), b = 0.3, 0.4 MPa gauge
  upstream: 600 dm^3/min ANR choked, 420 dm^3/min ANR at 0.3 MPa gauge
  downstream);
* the ISO 6358 formula (paper Eq. 4-5), re-typed here from the paper;
* the Saint-Venant ideal-nozzle formula (paper Eq. 1-3), re-typed here in its
  textbook form (critical ratio (2/(gamma+1))^(gamma/(gamma-1)) = 0.528 for air).

Every expected value is computed in this file with plain ``math``; nothing is
taken from the package except the constants rho_0 = 1.185 kg/m^3 and
T_0 = 293.15 K, which are the ISO 8778 reference values and are checked too.
"""
import math

import numpy as np
import pytest

from pneucore.physics import flow
from pneucore.physics.flow import (FLOW_LAWS, iso6358_mass_flow, saint_venant_critical_ratio,
                           saint_venant_mass_flow)

# ISO 8778 reference atmosphere used by ISO 6358 (ANR): rho_0 and T_0.
RHO0 = 1.185
T0 = 293.15
R = 287.05
GAMMA = 1.4
R_LAM = 0.999
P_ATM = 101.3e3

# Pure floating-point comparisons: the package and this file evaluate the same
# closed form with a different operation order, so they agree to a few ulp.
# 1e-12 relative leaves ~4 orders of magnitude above double rounding (~1e-16)
# while any modelling difference (a wrong exponent, T_u vs T_d, ...) is >1e-4.
FP_RTOL = 1e-12


def iso(p1, T1, p2, T2, C, b, m=0.5, r_lam=R_LAM):
    return iso6358_mass_flow(p1, T1, p2, T2, C, b, m, r_lam, R, GAMMA)


def sv(p1, T1, p2, T2, C, b=0.3, m=0.5, r_lam=R_LAM, gamma=GAMMA):
    return saint_venant_mass_flow(p1, T1, p2, T2, C, b, m, r_lam, R, gamma)


def iso_eq45(pu, Tu, pd, C, b):
    """Paper Eq. 4 (subsonic) and Eq. 5 (sonic), typed from the paper."""
    q_sonic = C * RHO0 * pu * math.sqrt(T0 / Tu)
    ratio = pd / pu
    if ratio <= b:
        return q_sonic
    return q_sonic * math.sqrt(1.0 - ((ratio - b) / (1.0 - b)) ** 2)


def saint_venant_textbook(pu, Tu, pd, s, gamma=GAMMA, r=R):
    """Paper Eq. 1-3 with the textbook exponents (ideal nozzle of throat area s)."""
    omega = (2.0 / (gamma + 1.0)) ** (gamma / (gamma - 1.0))
    ratio = pd / pu
    if ratio <= omega:
        return s * pu * math.sqrt(gamma / (r * Tu) * (2.0 / (gamma + 1.0)) ** ((gamma + 1.0) / (gamma - 1.0)))
    return s * pu * math.sqrt(2.0 * gamma / ((gamma - 1.0) * r * Tu)
                              * (ratio ** (2.0 / gamma) - ratio ** ((gamma + 1.0) / gamma)))


def anr_dm3_per_min(q):
    """Mass flow [kg/s] -> volume flow at ANR reference conditions [dm^3/min]."""
    return q / RHO0 * 1e3 * 60.0


# ---------------------------------------------------------------- ISO 6358

def test_reference_constants_are_iso8778():
    """Oracle: ISO 8778 reference atmosphere (ANR): rho_0 = 1.185 kg/m^3, T_0 = 293.15 K."""
    from pneucore.physics.gas import RHO_REF, T_REF
    assert RHO_REF == 1.185
    assert T_REF == 293.15
    assert flow.anr_volume_flow(1.185) == pytest.approx(1.0, rel=FP_RTOL)


def test_iso6358_catalogue_choked_flow():
    """Oracle: ISO 6358 worked example, C = 2 dm^3/(s bar), b = 0.3, 0.4 MPa gauge upstream,
    20 degC, exhausting to atmosphere: 600 dm^3/min ANR."""
    C = 2e-3 / 1e5          # 2 dm^3/(s bar) in m^3/(s Pa)
    assert C == pytest.approx(2e-8, rel=FP_RTOL)
    p_up = 0.4e6 + P_ATM
    q = iso(p_up, T0, P_ATM, T0, C, 0.3)
    # The catalogue rounds to 2 significant figures (600 for 601.6): 0.5 % covers
    # the rounding (0.26 %) while a units slip (bar vs Pa, gauge vs absolute) is >20 %.
    assert anr_dm3_per_min(q) == pytest.approx(600.0, rel=5e-3)
    # exact value of Eq. 5: C p_up (ANR volume flow) = 601.56 dm^3/min
    assert anr_dm3_per_min(q) == pytest.approx(C * p_up * 60e3, rel=FP_RTOL)
    assert q == pytest.approx(iso_eq45(p_up, T0, P_ATM, C, 0.3), rel=FP_RTOL)


def test_iso6358_catalogue_subsonic_flow():
    """Oracle: ISO 6358 worked example, same valve, downstream 0.3 MPa gauge: 420 dm^3/min ANR."""
    C = 2e-8
    p_up = 0.4e6 + P_ATM
    p_dn = 0.3e6 + P_ATM
    q = iso(p_up, T0, p_dn, T0, C, 0.3)
    # catalogue rounding: 420.6 printed as 420 (0.14 %); 0.5 % tolerance as above
    assert anr_dm3_per_min(q) == pytest.approx(420.0, rel=5e-3)
    ratio = p_dn / p_up
    exact = C * p_up * math.sqrt(1.0 - ((ratio - 0.3) / 0.7) ** 2) * 60e3
    assert anr_dm3_per_min(q) == pytest.approx(exact, rel=FP_RTOL)


@pytest.mark.parametrize("ratio", [0.05, 0.2, 0.3, 0.31, 0.5, 0.75, 0.9, 0.99, 0.998])
@pytest.mark.parametrize("Tu", [250.0, 293.15, 400.0])
def test_iso6358_matches_eq4_eq5(ratio, Tu):
    """Oracle: paper Eq. 4 (subsonic, m = 0.5) and Eq. 5 (sonic) below the laminar ratio."""
    C, b, pu = 1.3e-8, 0.3, 6e5
    q = iso(pu, Tu, ratio * pu, 300.0, C, b)
    assert q == pytest.approx(iso_eq45(pu, Tu, ratio * pu, C, b), rel=FP_RTOL)


@pytest.mark.parametrize("m", [0.3, 0.5, 0.65, 1.0])
def test_iso6358_subsonic_index(m):
    """Oracle: ISO 6358-1:2013 subsonic branch [1 - ((r - b)/(1 - b))^2]^m; m = 0.5 is Eq. 4."""
    C, b, pu = 1e-8, 0.25, 5e5
    for ratio in (0.26, 0.5, 0.8, 0.95):
        q = iso(pu, T0, ratio * pu, T0, C, b, m=m)
        expected = C * RHO0 * pu * (1.0 - ((ratio - b) / (1.0 - b)) ** 2) ** m
        assert q == pytest.approx(expected, rel=FP_RTOL)
        if m == 0.5:
            assert q == pytest.approx(iso_eq45(pu, T0, ratio * pu, C, b), rel=FP_RTOL)


def test_iso6358_laminar_transition_continuity_and_zero_at_ratio_one():
    """Oracle: the laminar linearisation is continuous in value at r_lam = 0.999 and gives
    q = 0 at ratio 1 (no flow without a pressure difference)."""
    C, b, pu = 1e-8, 0.3, 5e5
    at = iso(pu, T0, R_LAM * pu, T0, C, b)
    assert at == pytest.approx(iso_eq45(pu, T0, R_LAM * pu, C, b), rel=FP_RTOL)
    eps = 1e-12
    below = iso(pu, T0, (R_LAM - eps) * pu, T0, C, b)
    above = iso(pu, T0, (R_LAM + eps) * pu, T0, C, b)
    # Slopes at r_lam (b = 0.3): elliptic branch d(ln q)/dr = -z/((1-b) w) ~ -500, laminar
    # branch d(ln q)/dr = -1/(1 - r_lam) = -1000. Over dr = 1e-12 a continuous law changes
    # by <= 1e-9 relative; 1e-8 leaves 10x margin while any jump of the order of the
    # branch mismatch (>= 1e-3 for a wrong r_lam or a missing factor) fails.
    assert above == pytest.approx(at, rel=1e-8)
    assert below == pytest.approx(at, rel=1e-8)
    assert iso(pu, T0, pu, T0, C, b) == 0.0
    # inside the laminar band the flow decreases monotonically to 0 (linear in 1 - r)
    rs = np.linspace(R_LAM, 1.0, 11)
    qs = np.array([iso(pu, T0, r * pu, T0, C, b) for r in rs])
    assert np.all(np.diff(qs) < 0.0)
    assert qs[-1] == 0.0
    # linear: the midpoint carries half the value at r_lam (same algebra, fp-level agreement)
    assert qs[5] == pytest.approx(0.5 * qs[0], rel=1e-9)


def test_iso6358_antisymmetry_with_swapped_temperatures():
    """Oracle: reversing the pressure difference reverses the flow, q(p1,T1,p2,T2) = -q(p2,T2,p1,T1)."""
    C, b = 1e-8, 0.3
    for p1, T1, p2, T2 in [(5e5, 300.0, 2e5, 250.0), (2e5, 250.0, 5e5, 330.0),
                           (3e5, 280.0, 2.9999e5, 320.0), (1e5, 293.15, 7e5, 350.0)]:
        assert iso(p1, T1, p2, T2, C, b) == pytest.approx(-iso(p2, T2, p1, T1, C, b), rel=FP_RTOL)
    # and the flow uses the *upstream* temperature: side 2 upstream -> T2 matters, T1 does not
    q1 = iso(2e5, 250.0, 5e5, 330.0, C, b)
    q2 = iso(2e5, 999.0, 5e5, 330.0, C, b)
    assert q1 == q2 < 0.0


@pytest.mark.parametrize("Tu", [200.0, 250.0, 350.0, 500.0])
def test_iso6358_upstream_temperature_correction(Tu):
    """Oracle: ISO 6358 temperature correction q(T_u) = q(T_0) sqrt(T_0 / T_u)."""
    C, b, pu = 1e-8, 0.3, 5e5
    for ratio in (0.2, 0.6, 0.95):
        q_ref = iso(pu, T0, ratio * pu, T0, C, b)
        q = iso(pu, Tu, ratio * pu, T0, C, b)
        assert q == pytest.approx(q_ref * math.sqrt(T0 / Tu), rel=FP_RTOL)


def test_iso6358_choked_flow_independent_of_downstream_pressure():
    """Oracle: Eq. 5, the sonic flow does not depend on p_d while p_d/p_u <= b."""
    C, b, pu = 1e-8, 0.3, 5e5
    ref = C * RHO0 * pu
    for ratio in (0.0, 1e-6, 0.1, 0.2, 0.29, 0.3):
        assert iso(pu, T0, ratio * pu, T0, C, b) == pytest.approx(ref, rel=FP_RTOL)
    # and strictly less just above b (subsonic branch starts)
    assert iso(pu, T0, 0.31 * pu, T0, C, b) < ref


def test_iso6358_zero_conductance_and_vectorised_wrapper():
    """Oracle: C = 0 is a closed edge (q = 0); the registry wrapper equals the scalar law."""
    assert iso(5e5, T0, 1e5, T0, 0.0, 0.3) == 0.0
    law = FLOW_LAWS["iso6358"]
    p2 = np.array([1e5, 3e5, 4.9e5, 4.999e5, 6e5])
    q = law(5e5, T0, p2, T0, 1e-8, 0.3)
    expected = [iso(5e5, T0, p, T0, 1e-8, 0.3) for p in p2]
    np.testing.assert_allclose(q, expected, rtol=FP_RTOL)


# ---------------------------------------------------------------- Saint-Venant

def _son(gamma=GAMMA):
    return gamma * (2.0 / (gamma + 1.0)) ** ((gamma + 1.0) / (gamma - 1.0))


def test_saint_venant_critical_ratio_air():
    """Oracle: ideal-nozzle critical ratio (2/(gamma+1))^(gamma/(gamma-1)) = 0.5283 for gamma = 1.4."""
    # textbook value 0.528282 (e.g. Anderson, Modern Compressible Flow, Table A.1 at M = 1)
    assert saint_venant_critical_ratio(1.4) == pytest.approx(0.528282, abs=1e-6)
    # other gases: gamma = 1.3 (superheated steam, 0.5457), 5/3 (monatomic, 0.4871)
    assert saint_venant_critical_ratio(1.3) == pytest.approx((2 / 2.3) ** (1.3 / 0.3), rel=FP_RTOL)
    assert saint_venant_critical_ratio(1.3) == pytest.approx(0.5457, abs=1e-4)
    assert saint_venant_critical_ratio(5.0 / 3.0) == pytest.approx(0.4871, abs=1e-4)


@pytest.mark.parametrize("Tu", [250.0, 293.15, 400.0])
def test_saint_venant_choked_equals_iso_choked(Tu):
    """Oracle: with the throat area matched to C, Eq. 2 gives the same sonic flow as Eq. 5."""
    C, pu = 1e-8, 6e5
    for ratio in (0.0, 0.1, 0.25, 0.5):    # sonic for both laws (b = 0.25 here)
        q_sv = sv(pu, Tu, ratio * pu, 300.0, C)
        q_iso = iso(pu, Tu, min(ratio, 0.25) * pu, 300.0, C, 0.25)
        assert q_sv == pytest.approx(q_iso, rel=FP_RTOL)
    # the throat area matching the choked flow: s = C rho0 sqrt(r T0) / sqrt(son)
    assert flow.saint_venant_area(C, R, GAMMA) == pytest.approx(
        C * RHO0 * math.sqrt(R * T0) / math.sqrt(_son()), rel=FP_RTOL)


def test_saint_venant_continuity_at_critical_ratio():
    """Oracle: Eq. 1 and Eq. 2 meet at the critical ratio (where Eq. 1 is maximal)."""
    C, pu = 1e-8, 6e5
    omega = (2.0 / 2.4) ** (1.4 / 0.4)
    q_sonic = sv(pu, T0, 0.1 * pu, T0, C)
    eps = 1e-9
    below = sv(pu, T0, (omega - eps) * pu, T0, C)
    above = sv(pu, T0, (omega + eps) * pu, T0, C)
    assert below == pytest.approx(q_sonic, rel=FP_RTOL)
    # Eq. 1 has zero slope at omega (maximum), so over dr = 1e-9 the change is O(dr^2):
    # 1e-9 relative is far above that yet catches any jump between the two branches.
    assert above == pytest.approx(q_sonic, rel=1e-9)
    # Eq. 1 alone is maximal at omega: slightly either side it is lower
    s = flow.saint_venant_area(C, R, GAMMA)

    def eq1(r):
        return s * pu * math.sqrt(2 * GAMMA / ((GAMMA - 1) * R * T0) * (r ** (2 / GAMMA) - r ** ((GAMMA + 1) / GAMMA)))

    assert eq1(omega) > eq1(omega - 0.01) and eq1(omega) > eq1(omega + 0.01)
    assert eq1(omega) == pytest.approx(q_sonic, rel=FP_RTOL)


@pytest.mark.parametrize("ratio", [0.55, 0.6, 0.7, 0.8, 0.9, 0.95, 0.99])
@pytest.mark.parametrize("Tu", [260.0, 293.15, 380.0])
def test_saint_venant_eq1_subsonic_value(ratio, Tu):
    """Oracle: textbook Eq. 1 (ideal nozzle, subsonic), throat area from the choked flow."""
    C, pu = 1e-8, 6e5
    # throat area recovered from the sonic flow, which equals the ISO sonic flow (Eq. 5)
    q_sonic = C * RHO0 * pu * math.sqrt(T0 / Tu)
    s = q_sonic / (pu * math.sqrt(_son() / (R * Tu)))
    q = sv(pu, Tu, ratio * pu, 300.0, C)
    assert q == pytest.approx(saint_venant_textbook(pu, Tu, ratio * pu, s), rel=FP_RTOL)


def test_saint_venant_antisymmetry_laminar_band_and_zero():
    """Oracle: reversal antisymmetry, continuity at r_lam, zero flow at ratio 1 for Eq. 1-3."""
    C = 1e-8
    for p1, T1, p2, T2 in [(5e5, 300.0, 2e5, 250.0), (2e5, 250.0, 5e5, 330.0), (3e5, 280.0, 2.9999e5, 320.0)]:
        assert sv(p1, T1, p2, T2, C) == pytest.approx(-sv(p2, T2, p1, T1, C), rel=FP_RTOL)
    pu = 5e5
    at = sv(pu, T0, R_LAM * pu, T0, C)
    s = flow.saint_venant_area(C, R, GAMMA)
    assert at == pytest.approx(saint_venant_textbook(pu, T0, R_LAM * pu, s), rel=FP_RTOL)
    # same argument as for ISO: |d(ln q)/dr| <= 1/(1 - r_lam) = 1000 near r_lam, so over
    # dr = 1e-12 a continuous law changes by <= 1e-9 relative; 1e-8 gives 10x margin
    assert sv(pu, T0, (R_LAM + 1e-12) * pu, T0, C) == pytest.approx(at, rel=1e-8)
    assert sv(pu, T0, (R_LAM - 1e-12) * pu, T0, C) == pytest.approx(at, rel=1e-8)
    assert sv(pu, T0, pu, T0, C) == 0.0
    assert sv(pu, T0, 1e5, T0, 0.0) == 0.0


def test_saint_venant_other_gamma():
    """Oracle: Eq. 1-3 with gamma = 1.3 (critical ratio 0.5457), value typed from the textbook."""
    C, pu, g = 1e-8, 6e5, 1.3
    s = C * RHO0 * math.sqrt(R * T0) / math.sqrt(_son(g))
    for ratio in (0.3, 0.5, 0.7, 0.9):
        q = sv(pu, T0, ratio * pu, T0, C, gamma=g)
        assert q == pytest.approx(saint_venant_textbook(pu, T0, ratio * pu, s, gamma=g), rel=FP_RTOL)
