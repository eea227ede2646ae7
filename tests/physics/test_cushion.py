"""End cushions (effect ``end_cushion``, pneucore/physics/cushion.py) against physics nobody
here made up: the gas the spear traps compresses adiabatically (p V^gamma constant) and its
compression work takes the piston's kinetic energy (energy balance of the moving mass); a
needle closing trades stroke time for impact speed; every end stop logs the speed and the
kinetic energy of the impact; off, the base model bit for bit; bad input a FieldError naming
the field and its unit."""
import math

import numpy as np
import pytest

from pneucore import model_preset, simulate
from pneucore.physics.cushion import cushioned_outflow, kinetic_energy
from pneucore.physics.flow import iso6358_mass_flow
from pneucore.description.model import Model
from pneucore.description.validation import FieldError

R, GAMMA = 287.05, 1.4


def _model(heat="convective", **cushion):
    m = model_preset("paper-4way")
    m["heat"] = {"model": heat}
    if cushion:
        m["effects"] = {"end_cushion": cushion}
    return m


def _extend(duration=0.4, dt=1e-3):
    return {"duration": duration, "sample_period": dt, "x0": 0.0, "locked": False,
            "command": [[0.0, 0.0], [0.05, 1.0]], "command_interpolation": "hold",
            "solver": {"rtol": 1e-7, "max_step": 0.002}}


def _cycle():
    return {"duration": 3.0, "sample_period": 1e-3, "x0": 0.0, "locked": False,
            "command": [[0.0, 0.0], [0.05, 1.0], [1.0, -1.0], [2.0, 1.0]],
            "command_interpolation": "hold", "solver": {"rtol": 1e-7, "max_step": 0.002}}


def test_needle_law_is_the_iso6358_flow_bounded_by_the_edge_and_inflow_passes_the_check_valve():
    args = (6e5, 293.15, 1e5, 293.15, 1e-9, 0.3, 0.999, R, GAMMA)
    needle = iso6358_mass_flow(6e5, 293.15, 1e5, 293.15, 1e-9, 0.3, 0.5, 0.999, R, GAMMA)
    assert cushioned_outflow(1.0, *args) == needle          # edge wider: the needle sets it
    assert cushioned_outflow(0.5 * needle, *args) == 0.5 * needle   # edge narrower: the edge
    assert cushioned_outflow(-2e-3, *args) == -2e-3          # inflow: the check valve opens
    # choked needle: rho_0 C p sqrt(T_0 / T) (ISO 6358-1), T = T_0 here
    assert needle == pytest.approx(1.185 * 1e-9 * 6e5, rel=1e-3)   # rho_0 = 1.185 to 4 digits


def test_off_reproduces_the_base_model_bit_for_bit():
    base = simulate(_model(), _cycle())
    off = simulate(_model(length_a=0.0, length_b=0.0, C_a=2e-9, C_b=2e-9, capacity=0.1), _cycle())
    for name in ("t", "p_a", "p_b", "T_a", "T_b", "x", "v", "q_supply"):
        assert np.array_equal(getattr(base, name), getattr(off, name)), name
    assert [(e["t"], e["kind"]) for e in base.events] == [(e["t"], e["kind"]) for e in off.events]


def test_needle_sweep_trades_stroke_time_against_impact_speed_monotonically():
    """Closing the needle raises the trapped gas's back pressure over the cushion length: the
    stroke takes longer and the piston meets the end slower, strictly so, as long as it still
    reaches the end on its first approach (below ~2e-9 m^3/(s Pa) this 2 kg piston bounces off
    the trapped air first, and the second approach is a different motion)."""
    needles = (1e-8, 8e-9, 6e-9, 5e-9, 4e-9, 3e-9)
    times, speeds = [], []
    for C in needles:
        res = simulate(_model(length_a=0.0, length_b=0.02, C_a=C, C_b=C), _extend())
        ext = [s for s in res.stroke_metrics()["strokes"] if s["direction"] == "extend"]
        assert len(ext) == 1
        times.append(ext[0]["full_stroke_time"])
        speeds.append(ext[0]["end_speed"])
    base = simulate(_model(), _extend()).stroke_metrics()["strokes"][-1]
    assert times[0] >= base["full_stroke_time"] and speeds[0] <= base["end_speed"]
    assert all(b > a for a, b in zip(times, times[1:])), times
    assert all(b < a for a, b in zip(speeds, speeds[1:])), speeds
    # the sweep spans the useful range: from the uncushioned impact to a fifth of it
    assert speeds[-1] < 0.25 * base["end_speed"]


def test_every_stop_event_reports_its_impact_speed_and_kinetic_energy():
    """A cycle of three full strokes with cushions at both ends: each stop event carries the
    piston's velocity at the located impact; the stroke metrics give its speed and m v^2 / 2
    against the capacity. The logged speed is the limit of the sampled speed: at 10 us
    before the impact the speed differs by |a| dt (|a| < 5e3 m/s^2 here: < 0.05 m/s)."""
    m = _model(length_a=0.015, length_b=0.015, C_a=4e-9, C_b=4e-9, capacity=0.2)
    res = simulate(m, _cycle())
    stops = [e for e in res.events if e["kind"] == "stop"]
    assert len(stops) >= 3
    sm = res.stroke_metrics()
    mass = Model.from_dict(m).jack.moving_mass
    assert len(sm["impacts"]) == len(stops)
    for e, imp in zip(stops, sm["impacts"]):
        assert math.isfinite(e["v"]) and e["v"] != 0.0
        assert (e["v"] > 0) == (e["mode"] == "stop@stroke")        # arriving towards that end
        assert imp["speed"] == abs(e["v"])
        assert imp["energy"] == pytest.approx(0.5 * mass * e["v"] ** 2, rel=1e-15)
        assert imp["capacity"] == 0.2
        assert imp["energy_ratio"] == pytest.approx(imp["energy"] / 0.2, rel=1e-15)
    assert sm["end_speed_max"] == max(abs(e["v"]) for e in stops)
    assert sm["end_energy_max"] == pytest.approx(0.5 * mass * sm["end_speed_max"] ** 2, rel=1e-15)
    for s in sm["strokes"]:
        assert s["direction"] in ("extend", "retract")
        assert s["end_energy"] == pytest.approx(kinetic_energy(mass, s["end_speed"]), rel=1e-15)
    # the logged speed against a fine sampling just before the first impact
    t_hit = stops[0]["t"]
    fine = simulate(m, {**_cycle(), "duration": t_hit + 1e-3, "sample_period": 1e-5})
    k = int(np.searchsorted(fine.t, t_hit)) - 1
    assert abs(fine.v[k]) == pytest.approx(abs(stops[0]["v"]), abs=0.05)


def test_closed_needle_trapped_gas_is_adiabatic_and_its_work_takes_the_kinetic_energy():
    """Needle closed, adiabatic gas: once the spear is in, chamber B holds a fixed mass that
    follows p V^gamma = const exactly (Poisson's law), and the piston's energy balance closes
    on the closed-form compression work  W = (p V - p0 V0) / (gamma - 1):

        m (v^2 - v0^2) / 2 = int (F_net + p_b A_b - F_f) dx - W

    with the other forces (drive, rod, load, friction) from the 10 us samples. The trapped
    gas's pressure follows Poisson within 1e-6 (solver rtol 1e-7 on its mass and temperature,
    a few 1e-7 on p; measured 6e-8); the balance within 1e-4 of the entry kinetic energy: the
    trapezoidal integral of forces that change over ~1 ms at 10 us steps, O((dt/tau)^2) ~ 1e-4
    at most (measured 2e-7)."""
    L_c = 0.02
    m = _model("adiabatic", length_a=0.0, length_b=L_c, C_a=0.0, C_b=0.0)
    res = simulate(m, _extend(duration=0.2, dt=1e-5))
    jack = Model.from_dict(m).jack
    stroke, A_b, mass = jack.stroke, jack.area_b, jack.moving_mass
    x, v = np.asarray(res.x), np.asarray(res.v)
    inside = np.flatnonzero(x > stroke - L_c)
    k0 = int(inside[0])
    # up to the turning point: the piston stops inside the cushion and is pushed back
    turn = [e["t"] for e in res.events if e["kind"] == "reverse" and e["t"] > res.t[k0]]
    assert turn, "a closed needle stops the piston before the end"
    assert not [e for e in res.events if e["kind"] == "stop"]
    k1 = int(np.searchsorted(res.t, turn[0])) - 1
    sl = slice(k0, k1 + 1)
    V = np.asarray(res.V_b)[sl]
    p = np.asarray(res.p_b)[sl]
    p_poisson = p[0] * (V[0] / V) ** GAMMA
    assert np.max(np.abs(p / p_poisson - 1.0)) < 1e-6
    assert np.max(np.abs(np.asarray(res.m_b)[sl] / res.m_b[k0] - 1.0)) < 1e-6   # sealed: rtol 1e-7
    assert p[-1] > 3.0 * p[0]                                 # a real compression
    W_gas = (p_poisson * V - p[0] * V[0]) / (GAMMA - 1.0)
    f_rest = np.asarray(res.net_force)[sl] + p * A_b - np.asarray(res.friction)[sl]
    xs = x[sl]
    W_rest = np.concatenate(([0.0], np.cumsum(0.5 * (f_rest[1:] + f_rest[:-1]) * np.diff(xs))))
    ke0 = 0.5 * mass * v[k0] ** 2
    residual = 0.5 * mass * v[sl] ** 2 - ke0 - (W_rest - W_gas)
    assert ke0 > 1.0                                          # the piston arrives fast
    assert np.max(np.abs(residual)) < 1e-4 * ke0
    # at the turning point the compression took the kinetic energy and the drive's work
    assert W_gas[-1] == pytest.approx(ke0 + W_rest[-1], rel=1e-4)


def _with_line(segments, length, heat="convective", **cushion):
    m = _model(heat, **cushion)
    m["effects"] = {**m.get("effects", {}),
                    "tubing": {"length_a": length, "length_b": length, "diameter_a": 4e-3,
                               "diameter_b": 4e-3, "segments": segments}}
    return m


def test_a_closed_needle_at_the_chamber_end_of_a_line_in_segments_seals_the_chamber():
    """With a line in segments the needle sits between the chamber and the line's last cell:
    closed, it seals the trapped gas from the entry into the cushion to the piston's first
    turn, however the line's gas moves (the last face still carries a flow: the line
    drains through the valve). Sealed: chamber B's mass constant to the solver's rtol 1e-7
    (measured 2e-15: no term adds to it)."""
    m = _with_line(2, 0.5, "adiabatic", length_a=0.0, length_b=0.02, C_a=0.0, C_b=0.0)
    res = simulate(m, _extend(duration=0.25, dt=1e-4))
    stroke = Model.from_dict(m).jack.stroke
    x, m_b = np.asarray(res.x), np.asarray(res.m_b)
    k0 = int(np.flatnonzero(x > stroke - 0.02)[0]) + 1
    turn = [e["t"] for e in res.events if e["kind"] == "reverse" and e["t"] > res.t[k0]]
    assert turn, "a closed needle stops the piston before the end"
    k1 = int(np.searchsorted(res.t, turn[0])) - 1
    assert k1 > k0 + 5
    assert np.max(np.abs(m_b[k0:k1] / m_b[k0] - 1.0)) < 1e-7
    assert np.max(np.abs(np.asarray(res.series["line_b_q2"])[k0:k1])) > 1e-4   # the line flows [kg/s]
    # the same needle left out of the model lets the gas out of chamber B
    free = simulate(_with_line(2, 0.5, "adiabatic"), _extend(duration=0.25, dt=1e-4))
    assert free.m_b[k1] < 0.5 * m_b[k0]


def test_a_cushion_at_the_end_of_a_short_line_in_segments_acts_as_at_the_lumped_line():
    """5 cm of 4 mm line on each port, cushions of 20 mm with a needle of 4e-9 m^3/(s Pa): the
    stroke-end speed with the line in 2 segments within 10 % of the lumped line's. The two
    lines differ by 4 % without cushions already (measured: the lumped line is a Fanno
    characteristic at the supply pressure in series with the edges, the segments wall
    friction along the line), and the lumped line's 0.6 cm^3 join the chamber's dead volume,
    inside the trapped cushion volume, where the segments hold them beyond the needle
    (measured: 0.689 against 0.730 m/s, 5.6 %). Both cushions take the impact speed below 60 %
    of the uncushioned one (measured 49 % and 44 %)."""
    speeds = {}
    for segments in (1, 2):
        for cushioned in (False, True):
            cushion = dict(length_a=0.0, length_b=0.02, C_a=4e-9, C_b=4e-9) if cushioned else {}
            res = simulate(_with_line(segments, 0.05, **cushion), _extend())
            ext = [s for s in res.stroke_metrics()["strokes"] if s["direction"] == "extend"]
            assert len(ext) == 1
            speeds[segments, cushioned] = ext[0]["end_speed"]
    assert speeds[2, True] == pytest.approx(speeds[1, True], rel=0.10)
    for segments in (1, 2):
        assert speeds[segments, True] < 0.6 * speeds[segments, False]


@pytest.mark.parametrize("params, field, text", [
    ({"length_b": 0.3}, "effects.end_cushion.length_b", "longer than the stroke"),
    ({"length_a": -0.01}, "effects.end_cushion.length_a", "[m]"),
    ({"length_a": 0.15, "length_b": 0.15}, "effects.end_cushion.length_b", "overlap"),
    ({"C_a": -1e-9}, "effects.end_cushion.C_a", "[m^3/(s Pa)]"),
    ({"capacity": -1.0}, "effects.end_cushion.capacity", "[J]"),
])
def test_bad_cushions_are_refused_naming_the_field_and_its_unit(params, field, text):
    with pytest.raises(FieldError) as e:
        Model.from_dict(_model(**params))
    assert e.value.path == field
    assert text in e.value.detail and "[" in e.value.detail


def test_a_cushion_on_the_missing_port_of_a_3_2_valve_is_refused():
    m = model_preset("paper-3way")
    m["effects"] = {"end_cushion": {"length_a": 0.01, "length_b": 0.01}}
    with pytest.raises(FieldError) as e:
        Model.from_dict(m)
    assert e.value.path == "effects.end_cushion.length_b"
    m["effects"] = {"end_cushion": {"length_a": 0.01, "length_b": 0.0}}
    Model.from_dict(m)                                        # port A only: accepted
