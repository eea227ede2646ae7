"""A meter-out control at each cylinder port with a volume before the valve (issue 43, item 5):
what the volume does to the records, and whether the user's loop recovers it.

A rig of :func:`pneucore.data.synthetic.rig_case` hides meter-out throttles (3e-9 m^3/(s Pa),
b 0.3) with ``--volume`` m^3 between each and the valve (the layout the independent
simulator of set 4 uses). Printed: the truth's Eq. 25 error (the noise floor); the same
model with the controls in series (volume 0); a calibration of the throttles alone at volume
0, and of the throttles and the volumes (from 5 cm^3); with ``--diagnose``, the refine loop
from the user's model (nothing declared) round by round: the diagnosis does not seek the
volume (docs/limits.md), so it names a stand-in there.

Run: ``python benchmarks/bench_flow_control_node.py [--volume 1.5e-5] [--scale 0] [--diagnose]
[--json PATH]``
"""
import argparse
import json
import time

from pneucore.analysis.calibrate import calibrate
from pneucore.analysis.compare import compare
from pneucore.analysis.diagnose import diagnose
from pneucore.data.experiment import as_experiments
from pneucore.data.synthetic import rig_case
from pneucore.description.model import Model

EFFECT = "meter_out_throttle"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--volume", type=float, default=1.5e-5, help="volume before each control [m^3]")
    ap.add_argument("--scale", type=float, default=0.0,
                    help="factor on the drawn catalogue errors (0: the base values right)")
    ap.add_argument("--seed", type=int, default=41)
    ap.add_argument("--diagnose", action="store_true", help="run the refine loop too")
    ap.add_argument("--json", help="write the figures to this file")
    a = ap.parse_args()
    figures = {"volume_m3": a.volume, "scale": a.scale}
    case = rig_case("circuit/meter_out+node", seed=a.seed, effects=(EFFECT,), scale=a.scale,
                    effect_values={EFFECT: {"volume_a": a.volume, "volume_b": a.volume}})
    exps = as_experiments(case.experiments)
    truth = Model.from_dict(case.truth)
    figures["floor"] = compare(truth, exps).overall
    print(f"floor (the truth's error): {figures['floor']:.4%}")
    series = dict(truth.effects[EFFECT], volume_a=0.0, volume_b=0.0)
    figures["series_error"] = compare(Model.from_dict(dict(case.truth, effects={EFFECT: series})),
                                      exps).overall
    print(f"the truth with the controls in series: {figures['series_error']:.4%}")
    throttles = [f"effects.{EFFECT}.C_a", f"effects.{EFFECT}.C_b"]
    volumes = [f"effects.{EFFECT}.volume_a", f"effects.{EFFECT}.volume_b"]
    for params, V0 in ((throttles, 0.0), (throttles + volumes, 5e-6)):
        start = Model.from_dict(dict(case.truth, effects={EFFECT: dict(series, volume_a=V0,
                                                                        volume_b=V0)}))
        t0 = time.perf_counter()
        cal = calibrate(start, exps, params, max_nfev=60)
        seconds = time.perf_counter() - t0
        err = compare(cal.model, exps).overall
        key = "throttles_and_volumes" if len(params) > 2 else "throttles"
        figures[key] = {"error": err, "seconds": seconds,
                        **{p.split(".")[-1]: v["value"] for p, v in cal.values.items()}}
        found = ", ".join(f"{p.split('.')[-1]} {v['value']:.4g}" for p, v in cal.values.items())
        print(f"calibrated {', '.join(p.split('.')[-1] for p in params)}: {found}; error "
              f"{err:.4%} ({seconds:.1f} s)")
    if a.diagnose:
        model = Model.from_dict(case.start)
        for r in range(5):
            t0 = time.perf_counter()
            d = diagnose(model, exps)
            print(f"round {r}: {d.verdict}, error {compare(model, exps).overall:.4%} -> "
                  f"{d.remaining.get('error'):.4%} "
                  f"({time.perf_counter() - t0:.1f} s)")
            if d.verdict is None and not d.recalibrate:
                break
            model = d.model            # the answer's model, as the refine loop takes it
        figures["loop_error"] = compare(model, exps).overall
        print("the loop ends with", sorted(model.effects), f"at {figures['loop_error']:.4%}",
              {k: {p: f"{v:.4g}" for p, v in vals.items()} for k, vals in model.effects.items()})
    if a.json:
        with open(a.json, "w") as f:
            json.dump(figures, f, indent=1)


if __name__ == "__main__":
    main()
