"""Checks that turn bad input into one clear ``ValueError`` naming the field path."""
import math


class FieldError(ValueError):
    """Invalid input; ``path`` is the dotted field path (e.g. ``jack.rod_a``)."""

    def __init__(self, path, message):
        self.path = path
        self.detail = message
        super().__init__(f"{path}: {message}")


def number(value, path, *, positive=False, nonnegative=False, low=None, high=None,
           low_open=False, high_open=False, allow_none=False):
    """Check and return ``value`` as a finite float, with optional bounds.

    Parameters
    ----------
    value : object
        The input value
    path : str
        Dotted field path used in the error message
    positive, nonnegative : bool
        Require > 0 or >= 0
    low, high : float or None
        Bounds; ``low_open`` / ``high_open`` exclude them
    allow_none : bool
        Accept ``None`` (returned as is)
    """
    if value is None:
        if allow_none:
            return None
        raise FieldError(path, "is required (got null)")
    kind = type(value)
    if kind is not float and (kind is bool or not isinstance(value, (int, float))):
        try:
            import numpy as np
            if isinstance(value, np.generic) and np.issubdtype(type(value), np.number):
                value = float(value)
            else:
                raise TypeError
        except TypeError:
            raise FieldError(path, f"must be a number, got {type(value).__name__} {value!r}") from None
    try:
        value = float(value)
    except OverflowError:
        raise FieldError(path, f"must be a finite number, got an integer with {len(str(value))} digits") from None
    if value - value != 0.0:
        raise FieldError(path, f"must be a finite number, got {value}")
    if positive and value <= 0.0:
        raise FieldError(path, f"must be > 0, got {value:g}")
    if nonnegative and value < 0.0:
        raise FieldError(path, f"must be >= 0, got {value:g}")
    if low is not None and (value < low or (low_open and value == low)):
        raise FieldError(path, f"must be {'>' if low_open else '>='} {low:g}, got {value:g}")
    if high is not None and (value > high or (high_open and value == high)):
        raise FieldError(path, f"must be {'<' if high_open else '<='} {high:g}, got {value:g}")
    return value


def number_list(values, path, *, min_len=1, **bounds):
    """Check a list of finite numbers; each element's path is ``path[i]``."""
    if not isinstance(values, (list, tuple)) and not hasattr(values, "tolist"):
        raise FieldError(path, f"must be a list of numbers, got {type(values).__name__}")
    values = list(values.tolist() if hasattr(values, "tolist") else values)
    if len(values) < min_len:
        raise FieldError(path, f"must have at least {min_len} value(s), got {len(values)}")
    fast = _plain_within(values, **bounds)
    if fast is not None:
        return fast
    return [number(v, f"{path}[{i}]", **bounds) for i, v in enumerate(values)]


def _plain_within(values, **bounds):
    """Fast acceptance of a list of plain finite numbers within the bounds of :func:`number`.

    Returns the floats, or None when any element needs the per-element check
    (which then names the offending index). The bounds are monotone, so
    checking the smallest and the largest value with :func:`number` checks
    them all. Valve tables are validated on every simulation, and a
    per-element call with its path string cost about 70 us per simulation of
    the paper's 4/2 valve.
    """
    for v in values:
        kind = type(v)
        if kind is not float and kind is not int:
            return None
    try:
        out = [float(v) for v in values]
    except OverflowError:
        return None
    if not math.isfinite(sum(out)):
        return None
    try:
        number(min(out), "", **bounds)
        number(max(out), "", **bounds)
    except FieldError:
        return None
    return out


def integer(value, path, low=None, high=None):
    """Check an integer-valued number (``10`` or ``10.0``, not ``10.7``)."""
    v = number(value, path, low=low, high=high)
    if v != int(v):
        raise FieldError(path, f"must be a whole number, got {v:g}")
    return int(v)


def optional_mapping(value, path):
    """A dict, or ``{}`` when the value is null/absent; anything else is an error."""
    if value is None:
        return {}
    return mapping(value, path)


def mapping(value, path):
    """Check that ``value`` is a dict (JSON object)."""
    if not isinstance(value, dict):
        raise FieldError(path, f"must be an object, got {type(value).__name__}")
    return value


def known_keys(d, allowed, path):
    """Reject keys not in ``allowed`` (catches typos such as ``jack.bor``)."""
    for key in d:
        if key not in allowed:
            where = f"{path}.{key}" if path else key
            raise FieldError(where, f"unknown field; expected one of {sorted(allowed)}")


def choice(value, options, path):
    """Check that ``value`` is one of ``options`` (a registry's names)."""
    if not isinstance(value, str) or value not in options:
        raise FieldError(path, f"unknown value {value!r}; expected one of {sorted(options)}")
    return value


#: Deepest nesting accepted in free-form JSON fields [-]
MAX_JSON_DEPTH = 32


def finite_json(value, path, depth=0):
    """Check free-form JSON (objects, lists, strings, booleans, null, finite numbers).

    Rejects NaN and infinities (which have no JSON text) and nesting deeper than
    :data:`MAX_JSON_DEPTH`, naming the offending entry (``params.conductance``,
    ``experiments[0].scenario.x0``). Returns ``value``.
    """
    if depth > MAX_JSON_DEPTH:
        raise FieldError(path, f"is nested deeper than {MAX_JSON_DEPTH} levels")
    if value is None or isinstance(value, (str, bool)):
        return value
    if isinstance(value, (int, float)):
        number(value, path)
        return value
    if isinstance(value, dict):
        for k, v in value.items():
            if not isinstance(k, str):
                raise FieldError(path, f"keys must be strings, got {k!r}")
            finite_json(v, f"{path}.{k}" if path else k, depth + 1)
        return value
    if isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            finite_json(v, f"{path}[{i}]", depth + 1)
        return value
    raise FieldError(path, f"must be JSON (object, list, string, number, boolean or null), "
                           f"got {type(value).__name__}")
