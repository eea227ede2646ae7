"""The lumped line (``tubing``): its volume, its Fanno-flow characteristic against an
independent integration of the Fanno equations, the ideal-nozzle limit, and a choked
discharge through line + valve edge against the chain solved by root finding."""
import math

import numpy as np
import pytest
from scipy.integrate import quad

from pneucore import model_preset, simulate
from pneucore.physics.flow import conductance_from_area
from pneucore.physics.tube import darcy_friction, line_volume, tube_characteristic
from pneucore.description.effects import effective_model
from pneucore.description.model import Model
from pneucore.description.validation import FieldError

GAMMA, R, T0, RHO0 = 1.4, 287.05, 293.15, 1.185


def test_line_volume_joins_the_dead_volume_exactly():
    d = model_preset("paper-4way")
    d["effects"] = {"tubing": {"length_a": 2.0, "diameter_a": 4e-3, "length_b": 0.7,
                               "diameter_b": 6e-3}}
    m = Model.from_dict(d)
    eff = effective_model(m)
    # exactly, to the rounding of the product's order (1e-15)
    assert eff.jack.dead_volume_a == pytest.approx(m.jack.dead_volume_a
                                                   + math.pi * 4e-3 ** 2 / 4 * 2.0, rel=1e-15)
    assert eff.jack.dead_volume_b == pytest.approx(m.jack.dead_volume_b
                                                   + math.pi * 6e-3 ** 2 / 4 * 0.7, rel=1e-15)
    assert line_volume(4e-3, 2.0) == pytest.approx(math.pi * 4e-3 ** 2 / 4 * 2.0, rel=1e-15)


@pytest.mark.parametrize("d,L", [(4e-3, 2.0), (6e-3, 5.0), (2.5e-3, 0.5)])
def test_choked_line_against_an_integration_of_the_fanno_equations(d, L):
    """Fanno flow integrated along the line (Shapiro ch. 6: dM^2/dx = gamma M^4 (1 +
    (gamma-1)/2 M^2) / (1 - M^2) f / d, integrated as dx/dM^2 from the inlet Mach number
    implied by C up to M = 1), with the friction factor of the same Reynolds number: the
    length to Mach 1 is L within 1e-6 (quadrature and the bisection of the inlet Mach)."""
    p0 = 7e5
    C, b = tube_characteristic(d, L, p0)
    A = math.pi * d * d / 4
    q = C * RHO0 * p0
    # inlet Mach from the flow: q = A p0 sqrt(gamma/(R T0)) M (1 + 0.2 M^2)^-3
    from scipy.optimize import brentq
    M1 = brentq(lambda M: A * p0 * math.sqrt(GAMMA / (R * T0)) * M * (1 + 0.2 * M * M) ** -3 - q,
                1e-6, 1.0)
    mu = 1.716e-5 * (T0 / 273.15) ** 1.5 * (273.15 + 110.4) / (T0 + 110.4)
    f = darcy_friction(4 * q / (math.pi * d * mu))

    def dx_dM2(M2):
        return (1 - M2) / (GAMMA * M2 * M2 * (1 + 0.5 * (GAMMA - 1) * M2)) * d / f

    length, _ = quad(dx_dM2, M1 * M1, 1.0, epsabs=0.0, epsrel=1e-12)
    assert length == pytest.approx(L, rel=1e-6)
    # outlet pressure of the choked line over p0 is b (static: p1/p0 isentropic, p*/p1 Fanno)
    p1 = p0 * (1 + 0.2 * M1 * M1) ** -3.5
    p_star = p1 * M1 * math.sqrt((GAMMA + 1) / (2 + (GAMMA - 1) * M1 * M1))
    assert b == pytest.approx(p_star / p0, rel=1e-6)


def test_a_line_of_no_length_is_the_ideal_nozzle_of_its_bore():
    """L -> 0: b -> 0.528 (Eq. 3) and C -> the nozzle's (conductance_from_area), 1e-6."""
    C, b = tube_characteristic(4e-3, 0.0, 7e5)
    assert b == pytest.approx((2 / 2.4) ** 3.5, rel=1e-6)
    assert C == pytest.approx(conductance_from_area(math.pi * 4e-3 ** 2 / 4), rel=1e-6)


def test_longer_and_thinner_lines_pass_less():
    Cs = [tube_characteristic(4e-3, L, 7e5)[0] for L in (0.5, 1.0, 2.0, 5.0)]
    assert all(a > b for a, b in zip(Cs, Cs[1:]))
    assert tube_characteristic(3e-3, 2.0, 7e5)[0] < tube_characteristic(4e-3, 2.0, 7e5)[0]


def test_off_is_the_base_model_bit_for_bit():
    from pneucore import scenario_preset
    m, s = model_preset("paper-4way"), scenario_preset("paper-fig10-pulses")
    base = simulate(m, s)
    res = simulate(dict(m, effects={"tubing": {"length_a": 0.0, "length_b": 0.0}}), s)
    assert np.array_equal(res.x, base.x) and np.array_equal(res.p_a, base.p_a)


@pytest.mark.parametrize("params,field", [
    ({"length_a": -1.0}, "effects.tubing.length_a"),
    ({"diameter_b": 0.0}, "effects.tubing.diameter_b"),
])
def test_bad_lines_name_field_and_unit(params, field):
    d = model_preset("paper-4way")
    d["effects"] = {"tubing": params}
    with pytest.raises(FieldError) as e:
        Model.from_dict(d)
    assert e.value.path == field and "[m]" in str(e.value)


def test_a_line_on_a_port_the_valve_does_not_have():
    d = model_preset("paper-3way")
    d["effects"] = {"tubing": {"length_a": 1.0}}
    with pytest.raises(FieldError) as e:
        Model.from_dict(d)
    assert e.value.path == "effects.tubing.length_b" and "[m]" in str(e.value)
    d["effects"] = {"tubing": {"length_a": 1.0, "length_b": 0.0}}
    Model.from_dict(d)


def test_one_friction_law_for_both_lines_continuous_through_the_transition():
    """The segments' wall friction is :func:`darcy_friction` (64/Re written out below 2300),
    and that law is continuous from 64/Re to Haaland's through Re 2300-4000: the lumped
    line's characteristic then varies smoothly with its length where its choked flow crosses
    the transition (1 mm at 2 bar, around 9 m). With a jump in the law (64/Re to Haaland at
    2300, the lumped line's law before) C stepped by 14 % between two lengths 5 cm apart;
    here no step exceeds twice the mean of its neighbours
    (measured 1.3; with the jump, 28)."""
    from pneucore.physics.tube import segment_friction

    d, A, mu, rho = 4e-3, math.pi * 4e-6, 1.8e-5, 1.2
    for Re in (500.0, 2299.0, 2301.0, 3000.0, 3999.0, 4001.0, 3e4):
        q = Re * A * mu / d
        f = segment_friction(q, rho, A, d, mu) * 2.0 * d * rho * A / (q * q)
        assert f == pytest.approx(darcy_friction(Re), rel=1e-12)   # the same law, to rounding
    lengths = np.linspace(6.0, 12.0, 121)
    C = np.array([tube_characteristic(1e-3, length, 2e5)[0] for length in lengths])
    step = np.abs(np.diff(np.log(C)))
    assert np.all(step[1:-1] < (step[:-2] + step[2:]))          # twice the neighbours' mean
