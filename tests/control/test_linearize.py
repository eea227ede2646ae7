"""Linearisation (issue 42, item 5): the mechanical mode of the state matrix taken from the
core's right-hand side against the closed form of the pneumatic spring."""
import math

import numpy as np
import pytest

from pneucore import model_preset
from pneucore.control.linearize import closed_form_natural_frequency, equilibrium_pressures, linearize
from pneucore.description.model import Model
from pneucore.description.validation import FieldError


def frictionless(heat):
    m = model_preset("paper-4way")
    m["heat"] = {"model": heat}
    for side in ("extend", "retract"):
        m["friction"][side] = {k: 0.0 for k in m["friction"][side]}
    return m


@pytest.mark.parametrize("heat", ["isothermal", "adiabatic"])
@pytest.mark.parametrize("x", [0.03, 0.125, 0.21])
def test_natural_frequency_matches_the_closed_form(heat, x):
    # closed chambers (u = 0 inside the 15 % overlap), no friction: the piston's pair of
    # poles is the undamped pneumatic spring w_n = sqrt(k A^2 (p_a/V_a + p_b/V_b) / m),
    # k = 1 isothermal, gamma adiabatic. The 2 % tolerance; the central differences
    # agree to ~1e-9 (measured), so 2 % also catches a wrong k (gamma = 1.4 is 18 % apart)
    m = frictionless(heat)
    lin = linearize(m, x=x, p_a=4.5e5, p_b=3.5e5)
    model = Model.from_dict(m)
    k = 1.0 if heat == "isothermal" else model.gas.gamma
    wn = closed_form_natural_frequency(model, x, 4.5e5, 3.5e5, k) / (2 * math.pi)
    assert lin["natural_frequency"] == pytest.approx(wn, rel=0.02)
    assert abs(lin["damping"]) < 1e-3          # undamped: no friction, no flow, no heat
    other = closed_form_natural_frequency(model, x, 4.5e5, 3.5e5,
                                          model.gas.gamma if k == 1.0 else 1.0) / (2 * math.pi)
    assert abs(lin["natural_frequency"] - other) > 0.1 * wn


def test_equilibrium_defaults_at_mid_stroke_and_viscous_friction_damps():
    lin = linearize(model_preset("paper-4way"))
    op = lin["operating_point"]
    assert op["x"] == pytest.approx(0.125)
    m = Model.from_dict(model_preset("paper-4way"))
    # equal areas and no load: equal pressures at the mean of supply and ambient
    assert op["p_a"] == pytest.approx(0.5 * (7e5 + 1.013e5))
    assert op["p_b"] == pytest.approx(op["p_a"])
    assert 0.05 < lin["damping"] < 1.0         # viscous friction (Eq. 18) damps the mode
    pa, pb = equilibrium_pressures(m, 0.1, p_a=5e5)
    assert pb == pytest.approx(5e5)            # double rod, no load: balance at equal pressures
    # shapes of the state-space model
    n = len(lin["states"])
    assert lin["A"].shape == (n, n) and lin["B"].shape == (n, 1) and lin["C"].shape == (1, n)


def test_flow_gain_beyond_the_overlap_gives_a_position_response():
    # inside the overlap the valve passes nothing: B = 0; at u = 0.4 it opens
    inside = linearize(model_preset("paper-4way"), u=0.0)
    beyond = linearize(model_preset("paper-4way"), u=0.4, frequencies=[1.0, 10.0, 100.0])
    assert np.all(inside["B"] == 0.0)
    assert np.all(beyond["frequency_response"]["magnitude"] > 0.0)
    # an integrator (the flow integrates into position) falls with frequency
    mag = beyond["frequency_response"]["magnitude"]
    assert mag[0] > mag[1] > mag[2]


@pytest.mark.parametrize("kw,field", [({"x": 0.3}, "operating_point.x"),
                                      ({"x": float("nan")}, "operating_point.x"),
                                      ({"p_a": -1.0}, "operating_point.p_a"),
                                      ({"u": 2.0}, "operating_point.u")])
def test_bad_operating_point_names_the_field(kw, field):
    with pytest.raises(FieldError) as exc:
        linearize(model_preset("paper-4way"), **kw)
    assert exc.value.path == field
