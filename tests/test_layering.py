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
