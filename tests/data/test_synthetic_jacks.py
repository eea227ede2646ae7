"""Rig cases on other jacks and operating points (issue 43 item 6): the 20 mm and 63 mm jacks
scaled from the paper's 32 mm one, an absolute supply setting, other sample rates and a PWM free
test; the draws of the existing cases are unchanged by the new keywords.
"""
import hashlib
import json
import math

import numpy as np
import pytest

from pneucore.data.synthetic import (JACK_CASES, OTHER_JACKS, PWM_BURSTS, RIG_CASES, rig_case,
                                     scaled_jack)
from pneucore.description.model import Model
from pneucore.description.presets import model_preset
from pneucore.description.scenario import pwm_train
from pneucore.simulate import simulate

#: Ambient pressure of the paper's preset [Pa abs]
P_ATM = 101300.0


def _digest(case):
    """A hash of a drawn case: its models, its errors and every recorded sample."""
    h = hashlib.sha256(json.dumps([case.start, case.truth, case.misset, list(case.effects)],
                                  sort_keys=True, default=list).encode())
    for e in case.experiments:
        m = e["measurement"]
        h.update(json.dumps(m.meta["scenario"], sort_keys=True).encode())
        h.update(np.ascontiguousarray(m.t).tobytes())
        for s in sorted(m.signals):
            h.update(s.encode() + np.ascontiguousarray(m.signals[s]).tobytes())
    return h.hexdigest()


def test_63mm_jack_areas_volumes_and_scaled_catalogue_values():
    m = Model.from_dict(scaled_jack(*OTHER_JACKS["63mm"]))
    paper = Model.from_dict(model_preset("paper-4way"))
    a = (0.063 / 0.032) ** 2
    # annulus pi/4 (D^2 - d^2) of a 63 mm bore on a 20 mm rod: 2.803e-3 m^2 (exact arithmetic,
    # compared to round-off)
    assert m.jack.area_a == pytest.approx(math.pi / 4 * (0.063 ** 2 - 0.020 ** 2), rel=1e-12)
    assert m.jack.area_b == pytest.approx(2.803e-3, rel=1e-3)   # the figure to 4 digits
    # mid-stroke chamber: dead volume (5 cm^3 x area ratio, to 0.1 cm^3) plus half the swept one
    va, vb = m.jack.volumes(0.125)
    assert m.jack.dead_volume_a == pytest.approx(1.94e-5, rel=1e-12)
    assert va == pytest.approx(1.94e-5 + m.jack.area_a * 0.125, rel=1e-12)
    assert vb == pytest.approx(1.94e-5 + m.jack.area_b * 0.125, rel=1e-12)
    # mass by area (to 0.1 kg), friction by perimeter, valve by area (to 0.1)
    assert m.jack.moving_mass == pytest.approx(7.8)
    assert m.friction.extend.fc0 == pytest.approx(paper.friction.extend.fc0 * 0.063 / 0.032)
    assert m.friction.retract.kv_b == pytest.approx(paper.friction.retract.kv_b * 0.063 / 0.032)
    c_max = max(m.valve.ports["P-A"].C)
    assert c_max == pytest.approx(round(a, 1) * max(paper.valve.ports["P-A"].C), rel=1e-12)
    small = Model.from_dict(scaled_jack(*OTHER_JACKS["20mm"]))
    assert (small.jack.moving_mass, small.jack.dead_volume_a) == (0.8, 2e-6)


def test_63mm_jack_at_8_bar_abs_settles_where_the_spring_balances_the_thrust():
    """The static force balance at the supply pressure, in closed form: valve fully open towards
    A, A ends at the supply, B at ambient, and the piston stops where a return spring's force
    ``F0 + k x`` equals the thrust ``(p_s - p_atm) A_a`` to within the Coulomb band."""
    d = scaled_jack(*OTHER_JACKS["63mm"])
    d["supply"]["pressure"] = 8e5                  # 8 bar ABSOLUTE
    k, f0 = 15000.0, 100.0                        # puts the balance near x = 0.12 m
    d["effects"] = {"return_spring": {"rate": k, "preload": f0}}
    m = Model.from_dict(d)
    res = simulate(m, {"duration": 3.0, "sample_period": 0.001, "command": [[0.0, 0.0], [0.05, 1.0]],
                       "locked": False, "x0": 0.0})
    thrust = (8e5 - P_ATM) * m.jack.area_a        # 1958 N
    # steady chambers: no flow through the open edges, so the supply and the ambient pressure;
    # 200 Pa (0.025 % of the supply) takes the slow end of the settling after 3 s
    assert res.p_a[-1] == pytest.approx(8e5, abs=200.0)
    assert res.p_b[-1] == pytest.approx(P_ATM, abs=200.0)
    # the Coulomb level there (Eq. 20, gauge pressures): the piston may stop anywhere the net
    # force stays inside it
    fr = m.friction.extend
    fc = fr.fc0 + fr.fc_a * (8e5 - P_ATM)
    x_eq = (thrust - f0) / k
    assert abs(res.x[-1] - x_eq) <= fc / k + 1e-4   # 1e-4 m: the last of the settling at 3 s
    assert abs(res.v[-1]) < 1e-3                    # at rest [m/s]


def test_pwm_train_edges_and_the_pwm_free_test_on_a_2_khz_grid():
    cmd = pwm_train(0.15, 0.35, 25.0, 0.3, 0.7)
    on = [t for t, u in cmd if u == 0.7]
    off = [t for t, u in cmd[1:] if u == 0.0]
    # five 12 ms pulses every 40 ms, at times exact to the nanosecond the train rounds to
    assert on == pytest.approx([0.15, 0.19, 0.23, 0.27, 0.31], abs=1e-12)
    assert np.diff(on) == pytest.approx([0.04] * 4, abs=1e-12)
    assert np.subtract(off, on) == pytest.approx([0.012] * 5, abs=1e-12)
    c = rig_case("t", seed=54, jack="20mm", supply_pressure=8e5, sample_period=0.0005,
                 pwm=(25.0, 0.3), base_errors={})
    free = next(e for e in c.experiments if e["name"] == "free-pulses")["measurement"]
    assert np.diff(free.t) == pytest.approx(0.0005, abs=1e-12)
    u = free.signals["u"]
    # every logged pulse is 24 samples (12 ms at 2 kHz): the edges on the grid
    rises = np.flatnonzero(np.diff((u > 0).astype(int)) == 1)
    falls = np.flatnonzero(np.diff((u > 0).astype(int)) == -1)
    assert len(rises) == 5 and (falls - rises == 24).all()
    assert len(PWM_BURSTS) == 2 and (u < 0).any()
    assert Model.from_dict(c.start).supply.pressure == 8e5


def _models_digest(case):
    """A hash of a drawn case's models and errors (the seeded draws; no simulation, so the same
    on every platform)."""
    return hashlib.sha256(json.dumps([case.start, case.truth, case.misset, list(case.effects)],
                                     sort_keys=True).encode()).hexdigest()


#: :func:`_models_digest` of a few existing cases (the paper's jack, the 50 mm one, two hidden
#: effects), taken on the tree before the new keywords were added
EXISTING = {
    "base/paper-4way": "1bd1d71653e85f22ae930ec69752fc37e2223d5b87051918841b342a93fd9da6",
    "base/50mm-4way": "e7cb721fb2683a0916c35743ef494468e74d8df16faa48e7b280287d2817f77f",
    "effect/dead+lag/pressures-only":
        "33d75f68fdfc8935ce95fee505df1a31a171eb96800fd82c0faab4c3179ca845",
}


@pytest.mark.parametrize("name", sorted(EXISTING))
def test_existing_draws_are_unchanged(name):
    """The new keywords' defaults draw the existing cases as before: the same models, and the
    same records as the old fixed values (the paper's 7 bar abs, 1 ms, the pulse train) given
    explicitly, bit for bit."""
    kw = dict(RIG_CASES)[name]
    case = rig_case(name, **kw)
    assert _models_digest(case) == EXISTING[name]
    explicit = rig_case(name, **kw, sample_period=0.001, pwm=None, supply_pressure=7e5)
    assert _digest(case) == _digest(explicit)


def test_jack_cases_draw():
    names = [n for n, _ in JACK_CASES]
    assert len(names) == len(set(names)) and 10 <= len(names) <= 14   # issue 43 item 6: 10-14
    name, kw = JACK_CASES[1]                        # the 63 mm jack at 4 bar abs, 500 Hz
    c = rig_case(name, **kw)
    assert Model.from_dict(c.start).supply.pressure == 4e5
    assert all(np.diff(e["measurement"].t) == pytest.approx(0.002, abs=1e-12)
               for e in c.experiments)
