"""Measurements and the files rigs write: parsing, experiments, synthetic rigs, samples, exports."""
