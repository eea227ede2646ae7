"""Sample datasets shipped with the package: synthetic rig data hiding known effects.

Each sample is a pair of experiments (a locked-piston hold test and a free
pulse test, 1 s at 1 kHz) recorded through the paper's 12-bit acquisition
with noise, from the ``paper-4way`` model with hidden effects. The truth is
kept in a separate file (``truth.json``) so the tool never sees it.
Regenerate with ``python -m pneucore.data.samples``.
"""
from __future__ import annotations

import json
from pathlib import Path

from pneucore.data.measurement import read_csv
from pneucore.description.presets import model_preset
from pneucore.data.synthetic import synthetic_experiments

DATA_DIR = Path(__file__).parent / "sample_files"

#: Sample definitions: hidden effects on the paper-4way model
SAMPLES = {
    "clean": {"description": "paper-4way rig data with no hidden effect (control)", "effects": {}},
    "piston-leak": {"description": "rig data hiding a piston-seal leak",
                    "effects": {"piston_leakage": {"conductance": 8e-11}}},
    "spool-lag": {"description": "rig data hiding a 6 ms spool lag",
                  "effects": {"valve_spool_dynamics": {"time_constant": 0.006}}},
    "leak-and-lag": {"description": "rig data hiding a piston-seal leak and a 6 ms spool lag "
                                    "(found in two rounds)",
                     "effects": {"piston_leakage": {"conductance": 8e-11},
                                 "valve_spool_dynamics": {"time_constant": 0.006}}},
}

_UNITS = {"t": "s", "u": "-", "p_a": "bar", "p_b": "bar", "x": "mm"}
_SCALE = {"t": 1.0, "u": 1.0, "p_a": 1e-5, "p_b": 1e-5, "x": 1e3}


def _write_csv(meas, path):
    cols = ["t", "u"] + [s for s in ("p_a", "p_b", "x") if s in meas.signals]
    arrays = [meas.t] + [meas.signals[c] for c in cols[1:]]
    with open(path, "w") as fh:
        fh.write(",".join(f"{c}[{_UNITS[c]}]" for c in cols) + "\n")
        for row in zip(*arrays):
            fh.write(",".join(repr(float(v) * _SCALE[c]) for c, v in zip(cols, row)) + "\n")


def generate(out_dir=DATA_DIR, seed=11):
    """Write the sample CSV files, ``samples.json`` (manifest) and ``truth.json``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    manifest, truth = [], {}
    for k, (sid, spec) in enumerate(SAMPLES.items()):
        model = model_preset("paper-4way")
        model["effects"] = spec["effects"]
        exps = synthetic_experiments(model, seed=seed + 10 * k)
        files = []
        for e in exps:
            fname = f"{sid}--{e['name']}.csv"
            _write_csv(e["measurement"], out_dir / fname)
            files.append({"file": fname, "name": e["name"], "scenario": e["scenario"]})
        manifest.append({"id": sid, "description": spec["description"], "base_model": "paper-4way",
                         "experiments": files})
        truth[sid] = {"effects": spec["effects"], "model": model}
    (out_dir / "samples.json").write_text(json.dumps(manifest, indent=1))
    (out_dir / "truth.json").write_text(json.dumps(truth, indent=1))
    return manifest


def list_samples():
    """The manifest: list of ``{id, description, base_model, experiments: [{file, name, scenario}]}``."""
    return json.loads((DATA_DIR / "samples.json").read_text())


def load_sample(sample_id):
    """Experiments (JSON-ready dicts with :class:`Measurement` objects) of one sample."""
    for s in list_samples():
        if s["id"] == sample_id:
            return [{"name": e["name"], "scenario": dict(e["scenario"]),
                     "measurement": read_csv(DATA_DIR / e["file"], name=e["name"])}
                    for e in s["experiments"]]
    raise KeyError(f"unknown sample {sample_id!r}; available: {[s['id'] for s in list_samples()]}")


def sample_truth(sample_id):
    """The hidden truth of a sample (for tests and demonstrations only)."""
    return json.loads((DATA_DIR / "truth.json").read_text())[sample_id]


if __name__ == "__main__":
    for s in generate():
        print(s["id"], [e["file"] for e in s["experiments"]])
