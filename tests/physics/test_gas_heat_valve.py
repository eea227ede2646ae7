"""Small component helpers: gas properties, heat models called from Python, valve tables.

Oracles: the ISA sea-level density (ICAO Standard Atmosphere, Doc 7488:
1.2250 kg/m^3 at 101 325 Pa and 288.15 K), textbook specific heats of air
(Cengel & Boles, Table A-2: cp = 1.005, cv = 0.718 kJ/(kg K) at 300 K), the
paper's Eq. 9 and its Fig. 2 spool overlap.
"""
import numpy as np
import pytest

from pneucore import model_preset
from pneucore.physics import gas
from pneucore.physics.heat import HEAT_MODELS
from pneucore.description.model import Model
from pneucore.physics.valve import edge_characteristic, pack_tables, table_interp
from pneucore.core.layout import PORT_NAMES


def test_isa_sea_level_density():
    # ISA gives 1.2250 (5 significant digits); with r = 287.05 the ideal-gas value is
    # 1.22500: 1e-4 relative is the table's own rounding.
    assert gas.density(101325.0, 288.15) == pytest.approx(1.2250, rel=1e-4)


def test_specific_heats_of_air():
    # The textbook rounds to 3 significant digits (and its cp varies by 0.1 % between
    # 250 and 350 K): 1e-3 relative.
    assert gas.cp() == pytest.approx(1005.0, rel=1e-3)
    assert gas.cv() == pytest.approx(718.0, rel=1e-3)
    # Mayer's relation and the ratio hold to rounding (Eq. 11)
    assert gas.cp() - gas.cv() == pytest.approx(gas.R_AIR, rel=1e-12)
    assert gas.cp() / gas.cv() == pytest.approx(gas.GAMMA_AIR, rel=1e-12)


def test_heat_models_from_python():
    # Eq. 9: Phi = h S (T_w - T); gas 20 K above the wall loses 25 * 0.01 * 20 = 5 W.
    conv = HEAT_MODELS["convective"]
    assert conv(25.0, 0.01, 293.15, 313.15) == pytest.approx(-5.0, rel=1e-12)
    q = conv(25.0, 0.01, 293.15, np.array([283.15, 293.15, 303.15]))
    np.testing.assert_allclose(q, [2.5, 0.0, -2.5], rtol=1e-12, atol=1e-15)
    assert HEAT_MODELS["adiabatic"](25.0, 0.01, 293.15, 313.15) == 0.0
    # isothermal: the simulator pins T; the function reports no finite flow
    assert HEAT_MODELS["isothermal"](25.0, 0.01, 293.15, 313.15) == 0.0


def test_edge_characteristic_matches_the_core_tables():
    """The Python view of an edge (for plots) and the compiled core's interpolation agree,
    and the preset has the paper's 15 % overlap (Fig. 2): no flow for |u| < 0.15."""
    model = Model.from_dict(model_preset("paper-4way"))
    tx, tC, tb, _, toff = pack_tables(model.valve.ports)
    u = np.linspace(-1.2, 1.2, 241)
    for k, name in enumerate(PORT_NAMES):
        C, b = edge_characteristic(model.valve.ports[name], u)
        core_C = [table_interp(v, tx, tC, toff[k], toff[k + 1]) for v in u]
        core_b = [table_interp(v, tx, tb, toff[k], toff[k + 1]) for v in u]
        # both are linear interpolation of the same points: equal to rounding
        np.testing.assert_allclose(C, core_C, rtol=1e-12, atol=0)
        np.testing.assert_allclose(b, core_b, rtol=1e-12, atol=0)
        assert np.all(C[np.abs(u) < 0.15] == 0.0)
        assert C.max() > 0.0
