"""Field descriptions read from numpydoc docstrings: the one place a parameter is described.

A dataclass of :mod:`pneucore.description` describes each field once, in its
``Parameters`` section (``name : type`` on one line, the description ending
in its ``[unit]`` on the next). The REST schemas take their field
descriptions from here (:func:`api_description`), so the library and the
API cannot drift apart.

>>> from pneucore.description.model import Jack
>>> field_docs(Jack)["bore"]
'Bore (piston) diameter [m]'
"""
import functools
import inspect
import re

_ENTRY = re.compile(r"^(\*{0,2}\w+(?:\s*,\s*\*{0,2}\w+)*) : ?(.*)$")
_SECTION_END = re.compile(r"^-{3,}\s*$")
_ROLE = re.compile(r":(?:class|data|func|meth|mod|attr):`~?(?:[\w.]*\.)?([\w]+)`")


@functools.lru_cache(maxsize=None)
def field_docs(cls):
    """Each parameter's description from the ``Parameters`` section of ``cls``'s docstring.

    Parameters
    ----------
    cls : type
        A class with a numpydoc docstring

    Returns
    -------
    docs : dict
        Parameter name -> description (continuation lines joined by a space);
        an entry naming several parameters (``p_a, p_b : float``) gives each the
        same text
    """
    doc = inspect.getdoc(cls) or ""
    lines = doc.splitlines()
    try:
        start = next(i for i, line in enumerate(lines[:-1])
                     if line.strip() == "Parameters" and _SECTION_END.match(lines[i + 1]))
    except StopIteration:
        return {}
    out, names, text = {}, [], []

    def flush():
        for name in names:
            out[name] = " ".join(text).strip()

    for i, line in enumerate(lines[start + 2:], start + 2):
        if i + 1 < len(lines) and _SECTION_END.match(lines[i + 1]):
            break                                    # the next section's title
        if not line.strip():
            continue
        m = _ENTRY.match(line) if not line.startswith(" ") else None
        if m:
            flush()
            names = [n.strip().lstrip("*") for n in m.group(1).split(",")]
            text = []
        else:
            text.append(line.strip())
    flush()
    return out


def api_description(cls, name):
    """The description of field ``name`` of ``cls`` as the REST API states it.

    Sphinx roles and literals are reduced to plain text and Python's ``None``
    becomes JSON's ``null``.

    Parameters
    ----------
    cls : type
        A dataclass of :mod:`pneucore.description`
    name : str
        One of its fields

    Returns
    -------
    description : str
        The description, ending in the field's ``[unit]`` where it has one

    Raises
    ------
    KeyError
        When the docstring does not describe the field (every field must be)

    >>> from pneucore.description.model import Valve
    >>> api_description(Valve, "b_chamber_pressure")
    '3/2 mode: absolute pressure held in chamber B; null = half the supply pressure, as in the paper [Pa]'
    """
    docs = field_docs(cls)
    if name not in docs:
        raise KeyError(f"{cls.__name__}'s docstring does not describe the field {name!r}")
    text = _ROLE.sub(r"\1", docs[name]).replace("``", "")
    return re.sub(r"\bNone\b", "null", text)
