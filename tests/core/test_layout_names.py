"""The compiled core's slot names: written out in ``core/layout.py`` (a search finds
each one), without gaps or repeats, and used by name, not by bare index, where
``core/rhs.py`` fills the user hook's signals and reads its terms.
"""
import ast
import inspect

from pneucore.core import layout as L
from pneucore.core import rhs


def _assigned_names(module):
    """Names bound by a plain or tuple assignment at the top level of ``module``'s source."""
    tree = ast.parse(inspect.getsource(module))
    names = set()
    for node in tree.body:
        if isinstance(node, ast.Assign):
            for target in node.targets:
                elts = target.elts if isinstance(target, ast.Tuple) else [target]
                names |= {e.id for e in elts if isinstance(e, ast.Name)}
    return names


def test_parameter_slots_are_written_out():
    written = {n for n in _assigned_names(L) if n.startswith("P_")}
    assert written == {"P_" + name for name in L.PRM_INDEX}
    for name, i in L.PRM_INDEX.items():
        assert getattr(L, "P_" + name) == i
    assert "globals().update" not in inspect.getsource(L)


def test_parameter_slots_are_contiguous():
    assert sorted(L.PRM_INDEX.values()) == list(range(L.N_PRM))


def test_edge_slots_follow_the_port_order():
    # rhs reads P_CMAX_PA + k and P_BMAX_PA + k for edge k of PORT_NAMES
    for k, port in enumerate(L.PORT_NAMES):
        tag = port.replace("-", "")
        assert L.PRM_INDEX[f"CMAX_{tag}"] == L.P_CMAX_PA + k
        assert L.PRM_INDEX[f"BMAX_{tag}"] == L.P_BMAX_PA + k


def _const(name):
    return name.upper().replace("_", "").replace("SUPPLY", "SUP")


def test_signal_and_term_constants_match_the_names():
    for prefix, names in (("SIG_", L.SIG_NAMES), ("TERM_", L.TERM_NAMES), ("AUX_", L.AUX_NAMES)):
        consts = {n: getattr(L, n) for n in _assigned_names(L)
                  if n.startswith(prefix) and isinstance(getattr(L, n), int)}
        assert sorted(consts.values()) == list(range(len(names))), prefix
    # the signal constants spell their signal's name (p_supply -> SIG_PSUP)
    for i, name in enumerate(L.SIG_NAMES):
        assert getattr(L, "SIG_" + _const(name)) == i


#: Local variable of rhs that holds each signal
RHS_VARIABLE = {"p_supply": "p_sup", "T_supply": "T_sup"}


def test_rhs_fills_the_signals_by_name():
    tree = ast.parse(inspect.getsource(rhs.rhs))
    filled = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Subscript) \
                and isinstance(node.targets[0].value, ast.Name) and node.targets[0].value.id == "sig":
            index = node.targets[0].slice
            assert isinstance(index, ast.Attribute), ast.unparse(node)   # L.SIG_..., no bare number
            filled[getattr(L, index.attr)] = ast.unparse(node.value)
    assert filled == {i: RHS_VARIABLE.get(n, n) for i, n in enumerate(L.SIG_NAMES)}


def test_rhs_reads_the_terms_by_name():
    tree = ast.parse(inspect.getsource(rhs.rhs))
    read = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name) \
                and node.value.id == "terms" and isinstance(node.ctx, ast.Load):
            assert isinstance(node.slice, ast.Attribute), ast.unparse(node)
            read.append(getattr(L, node.slice.attr))
    assert sorted(read) == list(range(L.N_TERMS))
