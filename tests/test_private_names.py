"""No module of fvf uses another module's private (underscore) names, read from the source.

A name with a leading underscore belongs to its module. When another module needs it,
it is shared: it gets a public name in the module that owns the concept (mesh quantities
in :mod:`fvf.mesh.geometry`, input checks in :mod:`fvf.mesh.inputs`, ...), or moves to
its one user. The scan sees every form: ``from x import _a`` (also inside functions and
in parenthesised multi-line imports), ``module._a`` through an imported module, and
reaching into the private attributes of :class:`fvf.TriMesh` from outside its module.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "fvf"

#: Private imports inside packages whose clean-up is done elsewhere; each entry is
#: (importing module, owning module, name). Remove an entry once its import is gone.
#: Only fvf.numerics, fvf.cli and fvf.viz may appear here.
ALLOWED = {
    ("fvf.numerics.inverse_iteration", "fvf.numerics.progress", "_silent"),
    ("fvf.numerics.multilevel", "fvf.numerics.eigen", "_finish"),
    ("fvf.viz.backends", "fvf.viz.ps_backend", "_STATE"),
}
ALLOWED_PACKAGES = ("fvf.numerics", "fvf.cli", "fvf.viz")


def _module_name(path: Path, root: Path) -> str:
    parts = path.relative_to(root.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules(root: Path) -> dict[str, Path]:
    return {_module_name(p, root): p for p in sorted(root.rglob("*.py"))}


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _absolute(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    """The module a ``from ... import`` reads from, made absolute."""
    if not node.level:
        return node.module or ""
    base = module.split(".")
    base = base[: len(base) - node.level + (1 if is_package else 0)]
    return ".".join([*base, node.module] if node.module else base)


def private_uses(source: str, module: str, is_package: bool, known: set[str]) -> list[tuple]:
    """(line, owning module, name) for every private name of another module of the same
    package used here (the standard library's, such as ``sys._getframe``, are not ours).

    ``known`` is the set of module names of the package (to tell an imported module
    from an imported name).
    """
    package = module.split(".")[0]

    def ours(owner: str) -> bool:
        return owner != module and (owner == package or owner.startswith(package + "."))

    tree = ast.parse(source)
    found = []
    bound: dict[str, str] = {}  # local name -> module it is bound to
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            owner = _absolute(module, is_package, node)
            for alias in node.names:
                if f"{owner}.{alias.name}" in known:
                    bound[alias.asname or alias.name] = f"{owner}.{alias.name}"
                elif _private(alias.name) and ours(owner):
                    found.append((node.lineno, owner, alias.name))
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.asname:
                    bound[alias.asname] = alias.name
                else:
                    root = alias.name.split(".")[0]
                    bound[root] = root
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute) or not _private(node.attr):
            continue
        chain, value = [node.attr], node.value
        while isinstance(value, ast.Attribute):
            chain.append(value.attr)
            value = value.value
        if not isinstance(value, ast.Name) or value.id not in bound:
            continue
        path = bound[value.id]
        for attr in reversed(chain):
            if f"{path}.{attr}" in known:
                path = f"{path}.{attr}"
                continue
            if _private(attr) and ours(path):
                found.append((node.lineno, path, attr))
            break
    return found


def _trimesh_private_attributes() -> set[str]:
    tree = ast.parse((SRC / "mesh" / "trimesh.py").read_text())
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "TriMesh")
    names = set()
    for node in cls.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            names.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
    return {n for n in names if _private(n)}


MODULES = _modules(SRC)


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_private_name_of_another_module_is_used(name):
    path = MODULES[name]
    uses = private_uses(path.read_text(), name, path.name == "__init__.py", set(MODULES))
    bad = [
        f"{name}:{line} uses {owner}.{attr}"
        for line, owner, attr in uses
        if (name, owner, attr) not in ALLOWED
    ]
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("name", sorted(n for n in MODULES if n != "fvf.mesh.trimesh"))
def test_no_module_reaches_into_trimesh_private_attributes(name):
    private = _trimesh_private_attributes()
    bad = []
    for node in ast.walk(ast.parse(MODULES[name].read_text())):
        if isinstance(node, ast.Attribute) and node.attr in private:
            if not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")):
                bad.append(f"{name}:{node.lineno} reads .{node.attr}")
    assert not bad, "\n".join(bad)


def test_the_allow_list_stays_inside_the_packages_done_elsewhere():
    for importer, owner, attr in ALLOWED:
        assert importer.startswith(ALLOWED_PACKAGES) and owner.startswith(ALLOWED_PACKAGES)
        assert _private(attr)


def test_the_scan_sees_every_form():
    """A guard against a scan that cannot fail: each form of private use is found."""
    known = {"pkg", "pkg.a", "pkg.b", "pkg.main", "pkg.sub", "pkg.sub.c"}
    source = "\n".join(
        [
            "from .a import _one, public",
            "from .b import (",
            "    public_too,",
            "    _two,",
            ")",
            "from . import a as _a_module",
            "import pkg.sub.c",
            "from .sub import c",
            "def f(self):",
            "    from pkg.a import _three",
            "    x = _a_module._four + pkg.sub.c._five + c._six + _a_module.__doc__",
            "    import sys",
            "    return x + self._own + public._attr_of_an_object + sys._getframe",
        ]
    )
    found = {(owner, name) for _, owner, name in private_uses(source, "pkg.main", False, known)}
    assert found == {
        ("pkg.a", "_one"),
        ("pkg.b", "_two"),
        ("pkg.a", "_three"),
        ("pkg.a", "_four"),
        ("pkg.sub.c", "_five"),
        ("pkg.sub.c", "_six"),
    }
