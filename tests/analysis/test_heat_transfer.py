"""Heat models that transfer: fitted on a vessel's filling, they predict its discharge unrefitted.

The records come from a reference vessel written independently of the simulator's core
(:func:`pneucore.physics.vessel.reference_vessel_run`: its own nozzle law, a wall conducted
through its thickness in several slabs, an implicit Radau integration, a first-order
thermocouple), with noise. The simulator's physically based model (``natural_and_jet``: natural
convection + the inflow jet, the 26 kg lumped steel wall, a thermocouple lag) is fitted on the
filling alone and must predict the discharge within the issue-22 goal (p Eq. 25 <= 1 %, gas
T rms <= 8 K); a fixed coefficient fitted on the same filling must not. On the published filling
(shared/data/vessel-filling) the model is fitted on the filling proper and predicts the
relaxation held out.
"""
from pathlib import Path

import pytest

from pneucore.analysis.heat_compare import record_errors, transfer, transfer_table
from pneucore.physics.vessel import (FILLING_TEST, VESSEL_WALL, filling_test, nozzle_mass_flow,
                                     orifice_conductance, reference_inner_coefficient,
                                     reference_records, reference_vessel_run, vessel_dimensions,
                                     published_vessel)
from pneucore.physics.gas import RHO_REF, T_REF

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "vessel-filling"

D, D_IN = FILLING_TEST["diameter"], FILLING_TEST["orifice"]
#: The simulator's vessel: the physically based model, its multipliers started at the
#: published correlations (1) and a 1 s thermocouple
PHYSICAL = {"model": "natural_and_jet", "natural_multiplier": 1.0, "jet_multiplier": 1.0,
            "inlet_diameter": D_IN, "sensor_time_constant": 1.0, **VESSEL_WALL}
FITTED = ["natural_multiplier", "jet_multiplier", "sensor_time_constant"]
FIXED = {"model": "convective", "coefficient": 10.0, "sensor_time_constant": 1.0, **VESSEL_WALL}


def test_reference_nozzle_chokes_at_the_conductance_of_the_orifice():
    """The reference's own nozzle law and the simulator's orifice conductance are two
    writings of the same choked flow (ISO 6358: q = C p rho_0 sqrt(T_0 / T))."""
    g = FILLING_TEST
    area = g["Cd"] * 3.141592653589793 * g["orifice"] ** 2 / 4.0
    q_ref = nozzle_mass_flow(1e5, 295.0, 1e3, area)
    q_iso = orifice_conductance(g["orifice"], g["Cd"]) * 1e5 * RHO_REF * (T_REF / 295.0) ** 0.5
    # both are exact closed forms of the same flow: they agree to rounding (1e-9)
    assert q_ref == pytest.approx(q_iso, rel=1e-9)
    assert nozzle_mass_flow(1e5, 295.0, 1e5, area) == 0.0


def test_reference_vessel_conserves_energy_when_closed():
    """No orifice, no outer exchange: the gas's and the wall's energy together are constant."""
    V, S, _ = vessel_dimensions()
    mass, c = 5.0, 500.0
    run = reference_vessel_run([0.0, 200.0], 5e5, 400.0, 1e5, 295.0, V, S, 0.0,
                               lambda p, T, Tw, q: 20.0, mass, 8e-3, wall_specific_heat=c,
                               layers=4, outer_coefficient=0.0)
    cv = 287.05 / 0.4
    m_gas = 5e5 * V / (287.05 * 400.0)
    # the wall ends uniform (its conduction time ~ e^2 rho c / k ~ 1 s, << 200 s), in
    # equilibrium with the gas: the final temperature from the energy balance
    T_end = (m_gas * cv * 400.0 + mass * c * 295.0) / (m_gas * cv + mass * c)
    # 1e-4 K: the solver's tolerance (rtol 1e-8 on ~300 K) with margin, far below any heat effect
    assert run["T"][-1] == pytest.approx(T_end, abs=1e-4)
    assert run["T_wall"][-1] == pytest.approx(T_end, abs=1e-4)


@pytest.fixture(scope="module")
def same_law():
    """Reference with the simulator's own correlations at multipliers 2 and 0.5, a 2 s
    thermocouple and a six-slab wall."""
    fill, dis = reference_records(reference_inner_coefficient(D, D_IN, "churchill_chu", 2.0, 0.5),
                                  2.0, seed=0)
    rows = [transfer(published_vessel(PHYSICAL), fill, dis, FITTED),
            transfer(published_vessel(FIXED), fill, dis, ["coefficient", "sensor_time_constant"])]
    print("\nreference with the simulator's correlations (x2 natural, x0.5 jet, tau 2 s):\n"
          + transfer_table(rows, "filling", "discharge"))
    return rows


def test_fitted_on_the_filling_the_physical_model_predicts_the_discharge(same_law):
    row = same_law[0]
    v = row["values"]
    # the filling alone identifies the truth: the noise (0.2 % on p, 0.3 K) and 160 samples
    # leave a few per cent on each; 15 % is the margin for the model's lumped wall and the
    # simulator's own nozzle linearisation near equal pressures
    assert v["natural_multiplier"] == pytest.approx(2.0, rel=0.15)
    assert v["jet_multiplier"] == pytest.approx(0.5, rel=0.15)
    assert v["sensor_time_constant"] == pytest.approx(2.0, rel=0.15)
    # the discharge, never fitted: the noise alone gives p 0.2 % and T 0.3 K rms (Eq. 25 of
    # 200 Pa on ~1-8 bar; 0.3 K); the limits are the noise plus half the goal
    # (p <= 1.0 %, T <= 8 K), so a model that merely meets the goal by luck would not pass
    assert row["predicted"]["p"] < 0.5e-2
    assert row["predicted"]["T"] < 1.0


def test_a_fixed_coefficient_fitted_on_the_same_filling_does_not_transfer(same_law):
    """The control: the test above can fail. A fixed h fits the filling as well (within the
    noise) but misses the discharge's temperature by several times the physical model's error."""
    phys, fixed = same_law
    # on the filling both sit at the noise (0.2 % and 0.3 K): within a factor 3 of each other
    assert fixed["fit"]["p"] < 3 * phys["fit"]["p"] and fixed["fit"]["T"] < 3 * phys["fit"]["T"]
    # on the discharge the fixed h misses by more than the goal's 8 K (about 10 K measured)
    assert fixed["predicted"]["T"] > 8.0
    assert fixed["predicted"]["T"] > 5 * phys["predicted"]["T"]


def test_a_multiplier_transfers_across_a_misspecified_natural_law():
    """Reference with another natural-convection law (Woodfield's Nu = 0.104 Ra^0.352, not
    Churchill-Chu), a slower wall (15 W/(m K), eight slabs), a 4 s thermocouple: the fitted
    Churchill-Chu multiplier stands in for it and still predicts the discharge within the goal."""
    fill, dis = reference_records(reference_inner_coefficient(D, D_IN, "woodfield", 1.0, 0.5),
                                  4.0, seed=1, layers=8, wall_conductivity=15.0,
                                  outer_coefficient=3.0)
    row = transfer(published_vessel(PHYSICAL), fill, dis, FITTED)
    print("\nreference with Woodfield's natural law:\n" + transfer_table([row], "filling",
                                                                          "discharge"))
    # the goal itself (p <= 1.0 %, T rms <= 8 K): measured 0.87 % and 4.1 K, the
    # misspecified law's exponent (0.352 against about 1/3) showing at the discharge's larger
    # temperature differences
    assert row["predicted"]["p"] <= 1.0e-2
    assert row["predicted"]["T"] <= 8.0
    # and the multipliers within a factor 3 of the correlations (the goal's limit)
    for k in ("natural_multiplier", "jet_multiplier"):
        assert 1 / 3 <= row["values"][k] <= 3, (k, row["values"])


def test_the_wall_state_is_what_transfers_on_a_thin_vessel():
    """A 1 mm steel wall (3.0 kg, 1.5 kJ/K) warms by about a kelvin while filling, as much as the
    gas's excess over it during the relaxation: the model given the wall's known mass transfers,
    the same model with the wall held at ambient fits the filling almost as well and then
    misses the discharge (its natural multiplier takes the wall's part)."""
    V, S, _ = vessel_dimensions()
    wall = {"wall_mass": 7800.0 * S * 1e-3, "wall_thickness": 1e-3}
    fill, dis = reference_records(reference_inner_coefficient(D, D_IN, "churchill_chu", 2.0, 0.5),
                                  2.0, seed=3, **wall)
    with_wall = transfer(published_vessel({**PHYSICAL, "wall_mass": wall["wall_mass"]}), fill, dis, FITTED,
                         name="natural_and_jet, its 3 kg wall")
    no_wall = transfer(published_vessel({**PHYSICAL, "wall_mass": 0.0}), fill, dis, FITTED,
                       name="natural_and_jet, wall at ambient")
    print("\n1 mm steel wall:\n" + transfer_table([with_wall, no_wall], "filling", "discharge"))
    # with its wall: the noise (0.2 %, 0.3 K) plus half the goal, as for the thick vessel
    assert with_wall["predicted"]["p"] < 0.5e-2 and with_wall["predicted"]["T"] < 1.0
    # without it: beyond the goal's 8 K (measured about 31 K)
    assert no_wall["predicted"]["T"] > 8.0


@pytest.mark.skipif(not (DATA / "pressure.csv").exists(),
                    reason=f"published vessel data not found at {DATA}")
def test_real_filling_predicts_its_held_out_relaxation():
    """Fitted on the filling proper (t <= 20 s, the vessel reaches the atmosphere at about 19 s),
    the physical model predicts the minute after (natural convection, the vessel still open)
    better than the fixed coefficient fitted on the same samples. Figures, and why the natural
    multiplier runs to its bound, in the README's honest limits."""
    _, real = filling_test(str(DATA), PHYSICAL)
    rows = [transfer(published_vessel(PHYSICAL), real, None, FITTED, t_split=20.0),
            transfer(published_vessel(FIXED), real, None, ["coefficient", "sensor_time_constant"],
                     t_split=20.0)]
    published = record_errors(published_vessel({**PHYSICAL, "sensor_time_constant": 0.0}), real,
                              t_min=20.0)
    print("\npublished filling, fitted up to 20 s, the rest held out:\n"
          + transfer_table(rows, "t<=20s", "t>20s")
          + f"\npublished correlations, no fit: t>20s p {100 * published['p']:.2f} %, "
            f"T {published['T']:.2f} K")
    phys, fixed = rows
    # held-out pressure: the vessel is at the atmosphere, every model gives the README's 1.00 bar
    # where the record reads 1.005-1.008 bar: 0.65 % for all; 1 % is the goal
    assert phys["predicted"]["p"] < 1.0e-2
    # held-out temperature: measured 3.6 K against the fixed h's 9.3 K; the goal is 8 K, and the
    # physical model must beat the fixed h by more than the digitisation scatter (1 K)
    assert phys["predicted"]["T"] < 8.0
    assert phys["predicted"]["T"] < fixed["predicted"]["T"] - 1.0
    # the README's honest limit: on this record the natural multiplier runs to its bound, and
    # the answer says so (a symptom, not a measurement of the correlation)
    assert "natural_multiplier" in phys["at_bound"]
    assert not fixed["at_bound"]


def test_the_vessel_records_state_their_accuracy_and_the_fit_weighs_by_it():
    """The heat fit divides each residual by the accuracy the record's metadata states (one
    source: :data:`pneucore.physics.vessel.VESSEL_ACCURACY`), not by a table of its own; a
    record stating another accuracy is weighed by that one; one stating none, by its noise."""
    from pneucore.analysis.calibrate import Objective
    from pneucore.data.experiment import as_experiments
    from pneucore.physics.vessel import VESSEL_ACCURACY, vessel_experiment
    e = vessel_experiment("r", [0.1 * k for k in range(12)], [1e5] * 12, [295.0] * 12, 1e5, 295.0,
                          accuracy=VESSEL_ACCURACY)
    stated = as_experiments([e])[0]
    assert Objective(published_vessel(PHYSICAL), [stated], []).sigma == [VESSEL_ACCURACY]
    e["measurement"]["meta"]["accuracy"] = {"p_a[bar]": 0.01, "T_a[K]": 2.0}
    other = as_experiments([e])[0]
    # 0.01 bar is 1,000 Pa exactly (a difference: no gauge zero), 2 K is 2 K
    assert Objective(published_vessel(PHYSICAL), [other], []).sigma == [{"p_a": 1000.0,
                                                                         "T_a": 2.0}]
    del e["measurement"]["meta"]
    none = Objective(published_vessel(PHYSICAL), [as_experiments([e])[0]], []).sigma[0]
    assert none["p_a"] != VESSEL_ACCURACY["p_a"]
