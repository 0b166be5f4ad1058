"""The snippets of docs/interop.md's "Coming from ..." section run as written, each checked
against its library (skipped when the library is not installed)."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs"
PEERS = {"igl": "libigl", "potpourri3d": "potpourri3d", "pyFM": "pyFM", "trimesh": "trimesh"}
PEERS["pyvista"] = "PyVista"


def _section_blocks() -> list[tuple[str, str]]:
    """(subsection title, code) of every python block of the "Coming from" section."""
    text = (DOCS / "interop.md").read_text()
    start = text.index("## Coming from")
    end = text.index("\n## ", start + 3)
    out = []
    for part in re.split(r"^### ", text[start:end], flags=re.M)[1:]:
        title = part.splitlines()[0].strip()
        out += [(title, code) for code in re.findall(r"```python\n(.*?)```", part, flags=re.S)]
    return out


BLOCKS = _section_blocks()


def test_the_page_covers_every_peer():
    titles = {title for title, _ in BLOCKS}
    assert titles == {"libigl", "potpourri3d", "pyFM", "trimesh", "PyVista"}


@pytest.mark.parametrize("title,code", BLOCKS, ids=[t for t, _ in BLOCKS])
def test_snippet_runs(title, code, tmp_path, monkeypatch):
    for module in re.findall(r"^import (\w+)", code, flags=re.M):
        if module in PEERS:
            pytest.importorskip(module)
    monkeypatch.chdir(tmp_path)  # the snippets write their files here
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # the peers' own
        exec(compile(code, f"docs/interop.md ({title})", "exec"), {})
