"""What a user describes: the model, the scenario, effects, parameter paths, presets, units.

Every object here round-trips through JSON (``from_dict`` / ``to_dict``) and
validates its input once, raising :class:`~pneucore.description.validation.FieldError`
naming the offending field.
"""
