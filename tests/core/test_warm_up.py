"""The service's background warm-up of the compiled core (``pneucore.simulate.warm_up``)."""
import threading

import numpy as np

from pneucore import model_preset, scenario_preset, simulate
from pneucore.simulate import warm_up


def test_simulation_during_the_warm_up_waits_for_it_and_is_unchanged():
    ref = simulate(model_preset("paper-4way"), scenario_preset("paper-fig10-pulses"))
    t = threading.Thread(target=warm_up)
    t.start()
    res = simulate(model_preset("paper-4way"), scenario_preset("paper-fig10-pulses"))
    t.join()
    for name in ref.series:
        assert np.array_equal(ref.series[name], res.series[name]), name
    assert warm_up() > 0.0
