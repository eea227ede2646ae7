"""Effects with a state per chamber live in one module each (pneucore/physics/states.py): the
registry assigns their slots after the base slots, the core calls every registered rate from
one table, and a term switched on adds its two states to the run."""
import numpy as np

from pneucore import model_preset, scenario_preset, simulate
from pneucore.core import layout as L
from pneucore.core import rhs
from pneucore.physics.states import LINE_TERMS, STATE_TERMS, slot_blocks


def test_the_registry_assigns_contiguous_slots_after_the_base_slots():
    terms = {**STATE_TERMS, **LINE_TERMS}     # the line terms' blocks follow the state terms'
    prm = [(L.STATE_PRM0[n], t.n_parameters) for n, t in terms.items()]
    iy = [(L.STATE_IY0[n], t.n_positions) for n, t in terms.items()]
    for blocks, start, end in ((prm, L.N_PRM, L.N_PRM_ALL), (iy, L.N_IY, L.N_IY_ALL)):
        k = start
        for first, size in blocks:
            assert first == k
            k += size
        assert k == end
    assert slot_blocks()[2] == L.N_PRM_ALL - L.N_PRM
    # no slot of a state term is written out among the base slots
    assert not any(name.startswith(("SENSOR", "TSENSOR", "WALL_M", "WALL_CP", "WALL_H"))
                   for name in L.PRM_INDEX)


def test_the_core_table_holds_every_registered_term_in_order():
    table = rhs.state_table()
    assert [entry[0] for entry in table] == [L.STATE_IY0[n] for n in STATE_TERMS]
    assert [entry[3] for entry in table] == [t.rate for t in STATE_TERMS.values()]
    assert rhs.state_terms == table
    assert {"pressure_sensor", "temperature_sensor", "wall"} <= set(STATE_TERMS)
    lines = rhs.line_table()
    assert [entry[0] for entry in lines] == [L.STATE_IY0[n] for n in LINE_TERMS]
    assert [entry[4] for entry in lines] == [t.rate for t in LINE_TERMS.values()]
    assert rhs.line_terms == lines and "line" in LINE_TERMS


def test_a_term_switched_on_adds_its_states_and_follows_its_law():
    """The pressure transducer's lag: its state obeys tau dy/dt = p - y; checked on the run's
    own samples by the exact solution of that law over each 1 ms step with p linear between
    samples, within 5e-4 of the supply pressure: the linear p misses the pressure's curvature
    at the valve switches (8.5e-5 measured); a time constant 10 % off moves y by a tenth of
    its lag behind p, up to ~1e5 Pa in the transients here, i.e. ~1e-2 of the supply."""
    m = model_preset("paper-4way")
    m["effects"] = {"sensor_lag": {"time_constant": 0.004}}
    res = simulate(m, scenario_preset("paper-fig10-pulses"))
    names = STATE_TERMS["pressure_sensor"].states
    assert set(names) <= set(res.series)
    tau, dt = 0.004, float(res.t[1] - res.t[0])
    y, p = np.asarray(res.series["p_a_sensor"]), np.asarray(res.p_a)
    a = np.exp(-dt / tau)
    slope = (p[1:] - p[:-1]) / dt
    # exact step of tau y' = p0 + s t - y
    y1 = p[1:] - slope * tau + (y[:-1] - p[:-1] + slope * tau) * a
    err = np.max(np.abs(y1 - y[1:])) / 7e5
    assert err < 5e-4
