"""Sizing: from a required motion to the circuits that meet it (issue 25).

``size(requirement, choices)`` tries every family of discrete choices (cylinder bore and
rod, valve, tube inner diameter), solves each one's meter-out settings for the required
times, and ranks the feasible designs by air per cycle, then size; each infeasible family
comes back with its reason. Every design carries a model that :func:`pneucore.simulate`
and the REST API accept as it is.

The series (ISO 15552 and ISO 6432 cylinders, tubes, valves by C and b) are data with their
sources (:mod:`pneucore.sizing.series`); the circuit is the model's own (``jack.mounting_angle``,
the ``tubing`` and ``meter_out_throttle`` effects) and the stroke metrics are
:mod:`pneucore.analysis.strokes`' (:func:`pneucore.sizing.stroke.direction_metrics`).
"""
from pneucore.sizing.requirement import Choices, Requirement
from pneucore.sizing.search import (REASONS, build_model, check, evaluate_family, families,
                                     meter_out_throttles, robustness_studies, size)
from pneucore.sizing.series import load_series, nominal_flow
from pneucore.sizing.stroke import STROKE_METRIC_UNITS, direction_metrics

__all__ = ["Choices", "Requirement", "REASONS", "build_model", "check", "evaluate_family",
           "families", "meter_out_throttles", "robustness_studies", "size", "load_series",
           "nominal_flow", "STROKE_METRIC_UNITS", "direction_metrics"]
