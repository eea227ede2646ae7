"""Step-by-step identification on benches made for one component (paper section 2, 4).

The paper does not fit its model to one dynamic test: each component is identified on a
test made for it. :mod:`pneucore.identify.valve_bench` fits a valve edge's ISO 6358 tables
C(u), b(u) to flow-bench points (section 2.1, Fig. 2); :mod:`pneucore.identify.friction_bench`
fits the friction law of Eq. 18-20 to prescribed-motion records with a load cell on the rod
(section 2.3, Eq. 17, Fig. 4). Both write their result into a model's own fields.
"""
from pneucore.identify.friction_bench import (FrictionBenchResult, FrictionRecord, identify_friction,
                                              predict_rod_force, read_bench_file)
from pneucore.identify.valve_bench import BenchPoint, ValveBenchResult, identify_valve

__all__ = ["BenchPoint", "FrictionBenchResult", "FrictionRecord", "ValveBenchResult",
           "identify_friction", "identify_valve", "predict_rod_force", "read_bench_file"]
