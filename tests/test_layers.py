"""The layers of docs/architecture.md, read from the source: the core never imports the
command line, the pictures or the wrappers of other projects, and the numerics import
nothing about meshes."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "fvf"
FRONT = ("fvf.cli", "fvf.viz", "fvf.batch", "fvf.peers", "fvf.__main__")  # the layers users run
TOP = ("fvf.cli", "fvf.viz", "fvf.peers")  # never imported by the core


def _module_name(path: Path) -> str:
    parts = path.relative_to(SRC.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """Every module a file imports, anywhere in it (lazy imports too), made absolute."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            base = base[: len(base) - node.level + 1] if node.level else []
            mod = ".".join([*base, node.module] if node.module else base)
            found.add(mod)
            found |= {f"{mod}.{a.name}" for a in node.names}
    return found


def _core_files() -> list[Path]:
    return [p for p in sorted(SRC.rglob("*.py")) if not _module_name(p).startswith(FRONT)]


@pytest.mark.parametrize("path", _core_files(), ids=lambda p: _module_name(p))
def test_core_never_imports_the_command_line_or_the_pictures(path):
    bad = sorted(m for m in _imports(path) if m.startswith(TOP))
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
