"""The documentation runs: docstring examples (doctest) and the README's Python block."""

import doctest
import importlib
import pkgutil
import re
from pathlib import Path

import pytest

import fvf

ROOT = Path(__file__).resolve().parents[1]
MODULES = sorted(
    m.name for m in pkgutil.iter_modules(fvf.__path__, "fvf.") if m.name != "fvf.__main__"
)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0


def test_readme_python_block_runs():
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "README has no python example"
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {})


def test_readme_first_lines_are_the_two_setup_commands():
    lines = (ROOT / "README.md").read_text().splitlines()
    start = lines.index("```bash")
    cmds = lines[start + 1 : start + 3]
    assert "fvf demo" in cmds[0] and "pip install '.[viz]'" in cmds[0]  # pictures too
    assert "'.[test]'" in cmds[1] and "pytest" in cmds[1]
    assert start < 5


def _chapter_page_names() -> set[str]:
    """Every ``fvf.name`` (dotted path) that docs/chapter.md writes in backticks."""
    text = (ROOT / "docs" / "chapter.md").read_text()
    names = set()
    for code in re.findall(r"`([^`]+)`", text):
        names.update(re.findall(r"\bfvf(?:\.[A-Za-z_][A-Za-z0-9_]*)+", code))
    return names


def test_chapter_page_names_only_functions_that_exist():
    names = _chapter_page_names()
    assert len(names) > 40, sorted(names)
    missing = []
    for dotted in sorted(names):
        parts = dotted.split(".")
        obj = importlib.import_module("fvf")
        for i, part in enumerate(parts[1:], start=1):
            if hasattr(obj, part):
                obj = getattr(obj, part)
                continue
            try:
                obj = importlib.import_module(".".join(parts[: i + 1]))
            except ImportError:
                missing.append(dotted)
                break
    assert not missing, f"docs/chapter.md names that do not exist: {missing}"


_HISTORY = re.compile(r"session[s]? \d|this\s+session|issue \d", re.I)
# The exponential action and its tests are being rewritten; their history goes with them.


def test_no_work_history_in_the_project():
    """Docs and code say what is true now; the history of how it got there is in git."""
    found = []
    files = [ROOT / "README.md"]
    for top in ("src", "tests", "docs", "benchmarks", "examples"):
        files += [p for p in (ROOT / top).rglob("*") if p.suffix in (".py", ".md", ".ipynb")]
    for path in files:
        rel = path.relative_to(ROOT).as_posix()
        for lineno, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            if _HISTORY.search(line):
                found.append(f"{rel}:{lineno}: {line.strip()[:80]}")
    assert not found, "\n".join(found)


def test_citation_file_is_valid_and_rendered_in_the_readme():
    yaml = pytest.importorskip("yaml")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software"
    assert cff["version"] == fvf.__version__ or fvf.__version__ == "0+unknown"
    assert cff["license"] == "MIT"
    readme = (ROOT / "README.md").read_text()
    citing = readme[readme.index("## Citing fvf") :]
    assert "##" not in citing[3:], "Citing fvf is the README's last section"
    words = " ".join(citing.split())
    for ref in cff["references"]:
        assert ref["title"] in words, ref["title"]


def test_changelog_lists_every_deprecated_flat_name():
    from fvf import _MOVED

    text = (ROOT / "CHANGELOG.md").read_text()
    unreleased = text[text.index("## [Unreleased]") : text.index("## [0.1.0]")]
    for name, home in _MOVED.items():
        assert f"`fvf.{name}`" in unreleased and home in unreleased, name
