"""The parameters a user may fit, with the default bounds the calibration would use.

:func:`calibration_options` lists, for a model, the base parameters commonly
fitted on rig data and every parameter of the effects the model already
holds, each with its current value, unit and the default bounds of
:func:`pneucore.description.paths.parse_parameters` (so the page shows the very bounds a
fit without explicit bounds would use: one source).
"""
from __future__ import annotations

from pneucore.description.effects import EFFECTS
from pneucore.description.paths import parse_parameters

__all__ = ["BASE_PARAMETERS", "calibration_options"]

#: Base model paths offered for fitting, with a label (valve paths are scale factors)
BASE_PARAMETERS: dict[str, str] = {
    "jack.moving_mass": "moving mass",
    "jack.load_force": "load force",
    "jack.dead_volume_a": "dead volume A",
    "jack.dead_volume_b": "dead volume B",
    "friction.extend.fc0": "Coulomb force, extension",
    "friction.extend.kv0": "viscous coefficient, extension",
    "friction.retract.fc0": "Coulomb force, retraction",
    "friction.retract.kv0": "viscous coefficient, retraction",
    "heat.coefficient": "convection coefficient h (Eq. 9)",
    "supply.pressure": "supply pressure (absolute)",
    "valve.ports.*.C": "sonic conductance C of every edge (scale factor)",
    "valve.ports.*.b": "critical ratio b of every edge (scale factor)",
}


def calibration_options(model) -> list[dict]:
    """Fittable parameters of `model` with value, unit and default bounds.

    Parameters
    ----------
    model : Model
        The model to fit [-]

    Returns
    -------
    options : list of dict
        ``{"path", "label", "value", "min", "max", "unit"}`` in the unit of
        the parameter (SI; a scale factor for valve paths). Paths that do not
        apply to the model (a retraction set identical to extension's, a
        B chamber on a 3/2 valve) are still listed when the model accepts them [-]
    """
    paths = dict(BASE_PARAMETERS)
    for name in model.effects:
        eff = EFFECTS.get(name)
        if eff is None:
            continue
        for p in eff.parameters:
            if not p.integer:           # a count that shapes the model is not fitted
                paths[f"effects.{name}.{p.name}"] = f"{name}: {p.description or p.name}"
    out = []
    for path, label in paths.items():
        try:
            spec = parse_parameters(model, {path: {}})[0]
        except Exception:   # a path this model does not have (e.g. B on a 3/2 valve)
            continue
        out.append({"path": path, "label": label, "value": spec.value, "min": spec.min,
                    "max": spec.max, "unit": spec.unit})
    return out
