"""The layers of docs/architecture.md, read from the source.

Every module imports only the layers below its own: module-level, lazy (function-level),
``TYPE_CHECKING`` and ``importlib.import_module("fvf....")`` imports alike. The core never
imports the command line or the pictures, and the numerics import nothing about meshes.
The one upward arrow is :data:`EXCEPTIONS`, which docs/architecture.md justifies.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "fvf"
FRONT = ("fvf.cli", "fvf.viz", "fvf.batch", "fvf.peers", "fvf.__main__")  # the layers users run

#: The layers, bottom first: each is the set of top-level names (subpackage or module of
#: ``fvf``; ``""`` is the package root, fvf/__init__.py) that sit at that height. A module
#: may import its own subpackage or module and anything in a lower layer, never a layer
#: beside or above it. Drawn, top first, in docs/architecture.md.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("_version", "errors"),
    ("numerics",),
    ("mesh",),
    ("io",),
    ("calculus",),
    ("operators",),
    ("flows",),
    ("spectral",),
    ("design",),
    ("param",),
    ("chapter", "examples"),  # names and scenes for readers of the chapter
    ("",),  # the root hands the names of the layers below on, and never imports above
    ("batch", "viz", "peers"),
    ("cli",),  # the command runs the batches and draws the pictures
    ("__main__",),
)
RANK = {name: i for i, layer in enumerate(LAYERS) for name in layer}

#: (importer, imported) pairs allowed to point up, each justified in docs/architecture.md.
EXCEPTIONS = {
    # fig12_fields and compressible_case moved to fvf.examples; the old names warn
    ("fvf.mesh.builtin", "fvf.examples"),
}


def _module_name(path: Path, src: Path = SRC) -> str:
    parts = path.relative_to(src.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(name: str, src: Path) -> bool:
    """Whether a dotted fvf name is a module or package of the source tree at ``src``."""
    rel = Path(*name.split(".")[1:]) if "." in name else Path()
    return (src / rel).with_suffix(".py").is_file() or (src / rel / "__init__.py").is_file()


def _targets(path: Path, src: Path = SRC) -> Iterator[tuple[str, int]]:
    """(module, line) for every import in a file, anywhere in it, made absolute.

    ``from package import name`` imports ``package.name`` when that is a module, else
    ``package`` (``from .. import __version__`` imports the package root). Calls of
    ``import_module``/``__import__`` with a literal name count as imports; with any other
    argument they yield ``("?", line)``, checked by :func:`_names_fvf_modules`.
    """
    name = _module_name(path, src)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            base = base[: len(base) - node.level + 1] if node.level else []
            mod = ".".join([*base, node.module] if node.module else base)
            for alias in node.names:
                sub = f"{mod}.{alias.name}"
                yield (sub if mod.startswith("fvf") and _is_module(sub, src) else mod), node.lineno
        elif isinstance(node, ast.Call):
            func = node.func
            called = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if called in ("import_module", "__import__") and node.args:
                arg = node.args[0]
                literal = isinstance(arg, ast.Constant) and isinstance(arg.value, str)
                yield (arg.value if literal else "?"), node.lineno


def _imports(path: Path) -> set[str]:
    """Every module a file imports, anywhere in it (lazy imports too), made absolute."""
    return {target for target, _ in _targets(path)}


def _part(module: str) -> str:
    """The top-level name of an fvf module: ``fvf.mesh.trimesh`` -> ``mesh``; root -> ``""``."""
    return module.split(".")[1] if "." in module else ""


def _names_fvf_modules(path: Path) -> bool:
    """Whether a file holds a string naming an fvf module (``"fvf.x"``): with a computed
    ``import_module`` it could import it (third-party names, as the optional solvers of
    ``fvf.numerics.cholesky``, are fine)."""
    strings = (
        n.value for n in ast.walk(ast.parse(path.read_text())) if isinstance(n, ast.Constant)
    )
    return any(isinstance(v, str) and re.match(r"fvf(\.\w+)+$", v) for v in strings)


def _upward(path: Path, src: Path = SRC) -> list[str]:
    """The imports of one file that break the order of :data:`LAYERS`."""
    name = _module_name(path, src)
    mine = RANK[_part(name)]
    bad = []
    for target, line in _targets(path, src):
        if target == "?":
            if mine < RANK[""] and _names_fvf_modules(path):  # a hidden arrow, maybe
                bad.append(f"line {line}: import_module of a computed fvf name")
            continue
        if not (target == "fvf" or target.startswith("fvf.")) or _part(target) == _part(name):
            continue
        if RANK.get(_part(target), len(LAYERS)) >= mine and (name, target) not in EXCEPTIONS:
            bad.append(f"line {line}: {target}")
    return bad


def _files(src: Path = SRC) -> list[Path]:
    return sorted(src.rglob("*.py"))


def _core_files() -> list[Path]:
    return [p for p in _files() if not _module_name(p).startswith(FRONT)]


@pytest.mark.parametrize("path", _files(), ids=lambda p: _module_name(p))
def test_every_module_imports_only_the_layers_below_its_own(path):
    bad = _upward(path)
    assert not bad, f"{_module_name(path)} imports upward or sideways: {bad}"


def test_every_module_has_a_layer():
    """A new subpackage or top-level module must be placed in LAYERS (and in the docs)."""
    missing = sorted({_part(_module_name(p)) for p in _files()} - set(RANK))
    assert not missing, f"place these in LAYERS and docs/architecture.md: {missing}"


def test_the_exceptions_are_justified_in_the_architecture_page():
    text = (ROOT / "docs" / "architecture.md").read_text()
    for importer, imported in EXCEPTIONS:
        assert f"`{importer}` → `{imported}`" in text, (importer, imported)
        assert RANK[_part(importer)] < RANK[_part(imported)], "not an upward arrow: drop it"


def test_the_architecture_page_draws_the_layers_in_this_order():
    """The diagram of docs/architecture.md, read top down, is LAYERS upside down."""
    text = (ROOT / "docs" / "architecture.md").read_text()
    drawing = re.search(r"```\n(.*?)```", text, flags=re.S)
    assert drawing
    drawn = []
    for line in drawing.group(1).splitlines():
        names = line[:28].split()  # the left column; a description follows
        if names:
            drawn.append(tuple("" if w == "fvf/__init__.py" else w.rstrip("/") for w in names))
    assert [set(names) for names in drawn[::-1]] == [set(layer) for layer in LAYERS]


@pytest.mark.parametrize("path", _core_files(), ids=lambda p: _module_name(p))
def test_core_never_imports_the_command_line_or_the_pictures(path):
    bad = sorted(m for m in _imports(path) if m.startswith(("fvf.cli", "fvf.viz", "fvf.peers")))
    assert not bad, f"{_module_name(path)} imports {bad}"


@pytest.mark.parametrize(
    "path", sorted((SRC / "numerics").rglob("*.py")), ids=lambda p: _module_name(p)
)
def test_numerics_import_nothing_about_meshes(path):
    allowed = ("fvf.numerics", "fvf.errors")
    bad = sorted(m for m in _imports(path) if m.startswith("fvf") and not m.startswith(allowed))
    assert not bad, f"{_module_name(path)} imports {bad}"


def test_the_import_reader_sees_relative_and_lazy_imports(tmp_path):
    """A guard against a test that cannot fail: the reader resolves what the checks need."""
    demo = SRC / "cli" / "demo.py"
    assert "fvf.cli.report" in _imports(demo)  # from .report import ...
    assert "fvf.io.atomic" in _imports(demo)  # from ..io.atomic import ...
    assert "fvf.peers" in _imports(demo)  # from fvf.peers import ... (inside a function)
    assert any(m.startswith("fvf.viz") for m in _imports(SRC / "cli" / "report.py"))
    assert "fvf.examples" in _imports(SRC / "mesh" / "builtin.py")  # lazy, in __getattr__


def test_a_planted_upward_import_is_detected(tmp_path):
    """Every way of pointing up is caught, in a copy of the package's layout."""
    src = tmp_path / "fvf"
    for package in ("mesh", "spectral", "batch", "viz"):
        (src / package).mkdir(parents=True)
        (src / package / "__init__.py").write_text("")
    (src / "__init__.py").write_text("")
    (src / "chapter.py").write_text("")
    (src / "mesh" / "fine.py").write_text(
        "import numpy as np\nfrom . import other\nfrom ..errors import FvfError\n"
    )
    planted = {
        "mesh/lazy.py": "def f():\n    from ..spectral import basis\n",
        "mesh/absolute.py": "import fvf.spectral.basis\n",
        "mesh/typing.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
        "    from fvf.spectral import SpectralBasis\n",
        "mesh/root.py": "def version():\n    from .. import __version__\n",
        "mesh/by_name.py": "import importlib\nimportlib.import_module('fvf.spectral')\n",
        "mesh/computed.py": "from importlib import import_module\nNAME = 'fvf.spectral'\n"
        "import_module(NAME)\n",
        "chapter.py": "from . import batch\n",
        "batch/peer.py": "from ..viz import render\n",
    }
    for rel, code in planted.items():
        (src / rel).write_text(code)
    assert _upward(src / "mesh" / "fine.py", src) == []
    for rel in planted:
        assert _upward(src / rel, src), f"{rel} not caught"
