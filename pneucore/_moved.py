"""Old module names of pneucore, kept working with a DeprecationWarning.

Up to version 0.1 every module sat flat in ``pneucore/``; they now live in
subpackages by topic (``physics``, ``core``, ``spec``, ``data``, ``analysis``,
``study``). ``import pneucore.model`` or ``from pneucore import flow`` still
work: a finder on ``sys.meta_path`` answers an old name with the module at its
new place (the very same module object, so monkeypatching and ``isinstance``
keep working) and warns. :data:`MOVED` is the one table of the
moves.
"""
import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: old module name (under ``pneucore.``) -> new name (under ``pneucore.``)
MOVED = {
    "gas": "physics.gas", "flow": "physics.flow", "valve": "physics.valve", "chamber": "physics.chamber", "heat": "physics.heat", "jack": "physics.jack", "friction": "physics.friction", "vessel": "physics.vessel",
    "layout": "core.layout", "rhs": "core.rhs", "integrator": "core.integrator", "_cache": "core.cache",
    "validation": "spec.validation", "model": "spec.model", "scenario": "spec.scenario", "effects": "spec.effects", "paths": "spec.paths", "presets": "spec.presets", "units": "spec.units",
    "measurement": "data.measurement", "fileformats": "data.fileformats", "experiment": "data.experiment", "synthetic": "data.synthetic", "samples": "data.samples", "export": "data.export",
    "metrics": "analysis.metrics", "autocorrelation": "analysis.autocorrelation", "compare": "analysis.compare", "calibrate": "analysis.calibrate", "calibration_options": "analysis.calibration_options", "diagnose": "analysis.diagnose", "hypotheses": "analysis.hypotheses", "history": "analysis.history", "heat_compare": "analysis.heat_compare", "report": "analysis.report", "strokes": "analysis.strokes",
    "study_def": "study.definition", "study_exec": "study.execute", "study_metrics": "study.metrics", "study_results": "study.results", "study_store": "study.store", "_study_worker": "study._worker", "_study_warm": "study._warm",
}


def _warn(old, new, stacklevel):
    warnings.warn(f"pneucore.{old} moved to pneucore.{new}; the old name will be removed in a "
                  "future version", DeprecationWarning, stacklevel=stacklevel)


def resolve(old):
    """The module now at the place of ``pneucore.<old>``, imported; warns that the name moved.

    Parameters
    ----------
    old : str
        The module's former name under ``pneucore.`` (a key of :data:`MOVED`)

    Returns
    -------
    module : types.ModuleType
        The module at its new place
    """
    new = MOVED[old]
    _warn(old, new, stacklevel=4)
    return importlib.import_module(f"pneucore.{new}")


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Answers ``pneucore.<old>`` with the module that moved to ``pneucore.<new>``."""

    def find_spec(self, fullname, path=None, target=None):
        pkg, _, old = fullname.partition(".")
        if pkg != "pneucore" or old not in MOVED:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec):
        module = resolve(spec.name.partition(".")[2])
        sys.modules[spec.name] = module
        return module

    def exec_module(self, module):
        pass                     # already executed under its new name


def install():
    """Put the alias finder on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _Alias) for f in sys.meta_path):
        sys.meta_path.append(_Alias())
