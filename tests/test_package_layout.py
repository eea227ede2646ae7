"""The package layout: subpackages by topic, the public API unchanged. The flat module names
of version 0.1 (``pneucore.model``, ``pneucore.flow``) and the name ``pneucore.spec``, which
readers from other ecosystems took for a test folder (issue 40), are gone: the project had no
outside users to keep them for; the model's and scenario's description is
``pneucore.description``."""
import importlib
import os
import subprocess
import sys
import re

import pytest

import pneucore

PKG = os.path.dirname(os.path.abspath(pneucore.__file__))

#: The public API of ``import pneucore`` (pneucore/__init__.py). A name leaving this list
#: breaks users' code: change it only with a deprecation.
PUBLIC = [
    "EFFECTS", "Effect", "FLOW_LAWS", "FRICTION_LAWS", "FieldError", "HEAT_MODELS",
    "MODEL_PRESETS", "Model", "Parameter", "SCENARIO_PRESETS", "Scenario", "SimulationError",
    "SimulationResult", "iso6358_mass_flow", "model_preset", "pulse_train", "register_effect",
    "register_flow_law", "register_friction_law", "register_heat_model", "saint_venant_mass_flow",
    "scenario_preset", "simulate", "unregister_effect", "unregister_flow_law",
    "unregister_friction_law", "unregister_heat_model",
]

#: The subpackages and the modules each holds (a new module is added here on purpose)
LAYOUT = {
    "physics": {"chamber", "cushion", "flow", "flow_control", "friction", "gas", "heat", "jack",
                "line", "sensors",
                "series", "states", "tube", "valve", "vessel"},
    "core": {"cache", "controllers", "integrator", "layout", "rhs"},
    # position control (issue 42): linearisation, controllers, setpoints, metrics, closed loop
    "control": {"closed_loop", "command_line", "controllers", "linearize", "metrics", "models",
                "robustness", "setpoints"},
    "description": {"docstrings", "effects", "model", "paths", "presets", "provenance", "scenario", "units",
             "validation", "valve_data"},
    "data": {"command", "experiment", "export", "fileformats", "matfile", "measurement", "npz", "samples", "synthetic"},
    "analysis": {"autocorrelation", "blas_threads", "calibrate", "calibration_options", "compare", "diagnose",
                 "command_line", "engineering", "heat_compare", "history", "hypotheses", "metrics", "parallel", "report",
                 "phase_excess", "records", "shown", "strokes"},
    # the diagnosis's stages, its acceptance rules, its evidence and its findings (and what a
    # designer can act on for a restricted valve path: circuits)
    "analysis/diagnosis": {"circuits", "evidence", "findings", "rules", "stages"},
    "study": {"__main__", "_warm", "_worker", "definition", "execute", "metrics", "results", "store"},
    "identify": {"friction_bench", "valve_bench"},
    "sizing": {"requirement", "search", "series", "stroke"},
}
TOP_LEVEL = {"__main__", "cli", "progress", "result", "simulate"}


def test_public_api_is_unchanged():
    assert sorted(pneucore.__all__) == sorted(PUBLIC)
    for name in PUBLIC:
        assert getattr(pneucore, name) is not None


def test_modules_live_in_their_subpackages():
    found = {}
    for sub in LAYOUT:
        files = os.listdir(os.path.join(PKG, sub))
        found[sub] = {f[:-3] for f in files if f.endswith(".py") and f != "__init__.py"}
    assert found == LAYOUT
    top = {f[:-3] for f in os.listdir(PKG) if f.endswith(".py") and f != "__init__.py"}
    assert top == TOP_LEVEL, "a flat module beside the subpackages: put it where it belongs"


#: names that no longer exist: the flat modules of version 0.1 and the package once called spec
GONE = ["spec", "spec.model", "model", "flow", "effects", "scenario", "study_def", "_moved"]


@pytest.mark.parametrize("old", GONE)
def test_old_names_are_gone(old):
    sys.modules.pop(f"pneucore.{old}", None)
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(f"pneucore.{old}")
    with pytest.raises(AttributeError):
        getattr(pneucore, old.split(".")[0])


def test_the_package_itself_uses_no_old_name():
    """Importing every module of the package raises no DeprecationWarning."""
    code = ("import warnings, importlib, pkgutil, pneucore, app.main\n"
            "warnings.simplefilter('error', DeprecationWarning)\n"
            "for m in pkgutil.walk_packages(pneucore.__path__, 'pneucore.'):\n"
            "    if not m.name.endswith('__main__'):\n"
            "        importlib.import_module(m.name)\n")
    env = dict(os.environ, PYTHONWARNINGS="error::DeprecationWarning:pneucore")
    root = os.path.dirname(PKG)
    out = subprocess.run([sys.executable, "-W", "error::DeprecationWarning", "-c", code],
                         cwd=root, env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]


def test_study_command_line_runs_as_a_module():
    out = subprocess.run([sys.executable, "-m", "pneucore.study", "--help"], capture_output=True,
                         text=True, timeout=300, cwd=os.path.dirname(PKG))
    assert out.returncode == 0, out.stderr[-3000:]
    assert "usage" in out.stdout.lower()


def test_internal_imports_use_new_names():
    """No source file of the repository names a module by a name that is gone."""
    root = os.path.dirname(PKG)
    bad = []
    old = re.compile(r"\bpneucore\.(" + "|".join(sorted(GONE, key=len, reverse=True)) + r")\b(?![\w/])")
    for top in ("pneucore", "app", "benchmarks", "tests"):
        for dirpath, dirs, files in os.walk(os.path.join(root, top)):
            dirs[:] = [d for d in dirs if d != "__pycache__"]
            for f in files:
                if f.endswith(".py") and f != "test_package_layout.py":
                    path = os.path.join(dirpath, f)
                    with open(path, encoding="utf-8") as fh:
                        for i, line in enumerate(fh, 1):
                            if old.search(line):
                                bad.append(f"{os.path.relpath(path, root)}:{i}: {line.strip()}")
    assert not bad, "\n".join(bad)
