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
