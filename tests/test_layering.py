"""The layering rules the import graph must keep: no private name imported from another
module, routers never import one another nor pneucore (they call app.services, the one place
in app/ that calls the simulator), pneucore never imports the web layer."""
import ast
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

def _sources(package):
    for root, dirs, files in os.walk(os.path.join(ROOT, package)):
        dirs[:] = [d for d in dirs if not d.startswith((".", "__"))]
        for f in sorted(files):
            if f.endswith(".py"):
                path = os.path.join(root, f)
                rel = os.path.relpath(path, ROOT).replace(os.sep, "/")
                with open(path, encoding="utf-8") as fh:
                    yield rel, ast.parse(fh.read(), rel)


def _imports(tree):
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            for alias in node.names:
                yield node.level, node.module or "", alias.name, node.lineno


def _own_private_module(rel, module, name):
    """``from <package> import _name`` where ``_name`` is a module of ``<package>`` and the
    importing file lies inside that package."""
    pkg_dir = module.replace(".", "/")
    return os.path.isfile(os.path.join(ROOT, pkg_dir, name + ".py")) and rel.startswith(pkg_dir + "/")


@pytest.mark.parametrize("package", ["pneucore", "app"])
def test_no_private_name_is_imported_from_another_module(package):
    bad = []
    for rel, tree in _sources(package):
        for level, module, name, line in _imports(tree):
            # a private module of the package itself (``from . import _cache``,
            # ``from pneucore.study import _worker`` inside pneucore/study/) is its own
            own_private = module.split(".")[-1].startswith("_") or (level and not module) \
                or _own_private_module(rel, module, name)
            if name.startswith("_") and not name.startswith("__") and not own_private:
                bad.append(f"{rel}:{line} imports {name} from {'.' * level}{module}")
    assert not bad, "\n".join(bad)


def test_routers_do_not_import_one_another():
    routers = {f[:-3] for f in os.listdir(os.path.join(ROOT, "app", "routers")) if f.endswith(".py")}
    bad = set()
    for rel, tree in _sources("app/routers"):
        for level, module, name, line in _imports(tree):
            target = module if module else name
            if level == 1 and target in routers:
                bad.add(f"{rel}:{line} imports from the router {target}")
    assert not bad, "\n".join(sorted(bad))


def _absolute_imports(tree):
    """``(module, line)`` of every absolute import in ``tree`` (``import a.b``, ``from a.b import
    c``, at any depth: inside a function too)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from ((a.name, node.lineno) for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            yield node.module or "", node.lineno


def test_routers_do_not_import_pneucore():
    # routers parse the request, call app.services and shape the answer (thin routers over services)
    bad = [f"{rel}:{line} imports {module}" for rel, tree in _sources("app/routers")
           for module, line in _absolute_imports(tree) if module.split(".")[0] == "pneucore"]
    assert not bad, "\n".join(bad)


def test_every_router_takes_its_work_from_the_services():
    users = {rel for rel, tree in _sources("app/routers") for level, module, _, _ in _imports(tree)
             if level == 2 and module == "services"}
    routers = {rel for rel, _ in _sources("app/routers") if not rel.endswith("__init__.py")}
    assert routers - users == set(), sorted(routers - users)


def test_pneucore_does_not_import_the_web_layer():
    bad = []
    for rel, tree in _sources("pneucore"):
        for node in ast.walk(tree):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) and node.level == 0 else []
            bad += [f"{rel}:{node.lineno} imports {n}" for n in names
                    if n.split(".")[0] in ("app", "fastapi", "pydantic", "starlette")]
    assert not bad, "\n".join(bad)


#: What each lower layer of pneucore may not import: physics is the bottom (the laws, their
#: registries and the state terms' rates), the core assembles them, description describes models
_LOWER_LAYERS = {"physics": ("core", "description", "simulate", "result", "strokes", "analysis", "data",
                             "study", "identify", "sizing")}


def _pneucore_targets(rel, tree):
    """``(subpackage or module of pneucore, line)`` of every import in ``tree`` (absolute
    ``pneucore.x``, and relative ``..x`` from inside a subpackage)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                parts = a.name.split(".")
                if parts[0] == "pneucore" and len(parts) > 1:
                    yield parts[1], node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0:
                parts = (node.module or "").split(".")
                if parts[0] == "pneucore":
                    if len(parts) > 1:
                        yield parts[1], node.lineno
                    else:
                        yield from ((a.name, node.lineno) for a in node.names)
            elif node.level >= 2:
                # from inside pneucore/<sub>/: ``..x`` is pneucore.x
                if node.module:
                    yield node.module.split(".")[0], node.lineno
                else:
                    yield from ((a.name, node.lineno) for a in node.names)


@pytest.mark.parametrize("layer", sorted(_LOWER_LAYERS))
def test_lower_layers_do_not_import_the_layers_above(layer):
    bad = [f"{rel}:{line} imports pneucore.{target}"
           for rel, tree in _sources(f"pneucore/{layer}")
           for target, line in _pneucore_targets(rel, tree) if target in _LOWER_LAYERS[layer]]
    assert not bad, "\n".join(bad)


def test_the_layer_check_catches_an_import_of_the_core():
    # the rule above on a made-up module: one import of the core, absolute, relative or lazy
    for src in ("from pneucore.core import layout as L\n", "import pneucore.core.layout\n",
                "from ..core.layout import PORT_NAMES\n", "def f():\n    from pneucore import core\n"):
        targets = [t for t, _ in _pneucore_targets("pneucore/physics/x.py", ast.parse(src))]
        assert "core" in targets, src
