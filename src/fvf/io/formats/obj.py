"""Wavefront OBJ: ``v`` and ``f`` statements, polygons of any size.

Read: the vertices are the ``v`` lines only (never split at UV seams, ``vt``/``vn`` left
out), each the first three numbers of its line (a weight ``w`` or a colour ``r g b`` after
them is left out); ``f`` indices are 1-based, or negative for the k-th ``v`` line before
the face; ``v/vt/vn`` corners keep their ``v``; a line ending with a backslash continues on
the next (:func:`joined_lines`); ``o``, ``g``, ``s``, ``usemtl``, ``mtllib``, ``l`` and
other statements are skipped. Written as text with 17 significant digits, so a round trip
is exact; no vertex or face data.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ._text import first3, numbers, statement_tokens, text_lines
from .base import MeshFormat, Polygons, rows_text, sniff_text, write_text

__all__ = ["read", "write", "write_uv", "FORMAT"]


def read(path: Path, data: bytes) -> Polygons:
    """The vertices and polygons of an OBJ file (see the module docstring)."""
    lines = text_lines(data)
    if b"\\" in data:
        lines = joined_lines(lines)
    heads = [line.lstrip() for line in lines]

    def statements(key: str) -> list[int]:
        return [i for i, s in enumerate(heads) if s[:1] == key and (len(s) == 1 or s[1].isspace())]

    v_at, f_at = statements("v"), statements("f")
    v_line, f_line = [i + 1 for i in v_at], [i + 1 for i in f_at]
    tokens, counts = statement_tokens(lines, v_at, "v")
    vertices = first3(path, tokens, counts, v_line, "an OBJ 'v' line")
    tokens, counts = statement_tokens(lines, f_at, "f")
    if "/" in "".join(tokens):  # v/vt/vn: keep the v
        tokens = [t.partition("/")[0] for t in tokens]
    raw = numbers(path, tokens, counts, f_line, np.int64, "an OBJ 'f' line (vertex index)")
    v_before = np.searchsorted(np.asarray(v_line, dtype=np.int64), f_line)
    flat = np.where(raw > 0, raw - 1, np.repeat(v_before, counts) + raw)
    flat[raw == 0] = -1
    valid = f"1..{len(vertices)}, or -1..-k for the k-th 'v' line before the face"
    return Polygons(vertices, counts, flat, raw, lambda i: f"line {f_line[i]}", valid)


#: The statements whose lines continue on the next after a ``\\``: those of numbers.
CONTINUED = frozenset({"v", "vt", "vn", "vp", "f", "fo", "l", "p"})


def joined_lines(lines: list[str]) -> list[str]:
    """``lines`` with each line that ends with ``\\`` (then maybe blanks) joined to the
    next, the OBJ line continuation; an empty line takes the place of each joined one, so
    line numbers stay those of the file. Only statements of numbers continue
    (:data:`CONTINUED`): a comment or a ``mtllib`` line ending with a Windows folder
    (``# from C:\\scans\\``) swallowed the vertex after it."""
    out: list[str] = []
    carry: list[str] = []
    for line in lines:
        stripped = line.rstrip()
        words = stripped.split(maxsplit=1)
        continues = bool(carry) or (bool(words) and words[0] in CONTINUED)
        if continues and stripped.endswith("\\"):
            carry.append(stripped[:-1])
            continue
        out.append(" ".join([*carry, line]))
        out += [""] * len(carry)
        carry = []
    if carry:  # the last line ends with a backslash: nothing follows to join
        out.append(" ".join(carry))
        out += [""] * (len(carry) - 1)
    return out


def write(
    path: Path,
    V: np.ndarray,
    F: np.ndarray,
    vertex_data: Mapping[str, np.ndarray],
    face_data: Mapping[str, np.ndarray],
    comments: tuple[str, ...] = (),
) -> None:
    """``v x y z`` per vertex (``%.17g``), ``f i j k [l]`` (1-based) per face."""
    what = "quads" if F.shape[1] == 4 else "faces"
    head = f"# written by fvf: {len(V)} vertices, {len(F)} {what}\n"
    write_text(path, head + rows_text("v", V, "%.17g") + rows_text("f", F + 1, "%d"))


def write_uv(path: Path, V: np.ndarray, F: np.ndarray, T: np.ndarray) -> None:
    """Triangles with per-corner texture coordinates ``T`` (m, 3, 2): one ``vt`` line per
    distinct (u, v) pair, faces ``f v/vt ...``, so seams stay seams."""
    vt, inv = np.unique(T.reshape(-1, 2), axis=0, return_inverse=True)
    inv = inv.reshape(-1, 3)
    pairs = np.stack([F + 1, inv + 1], axis=2).reshape(len(F), 6)
    text = (
        f"# written by fvf: {len(V)} vertices, {len(F)} faces\n"
        + rows_text("v", V, "%.17g")
        + rows_text("vt", vt, "%.17g")
        + ("f %d/%d %d/%d %d/%d\n" * len(F)) % tuple(pairs.ravel().tolist())
    )
    write_text(path, text)


FORMAT = MeshFormat(
    name="OBJ",
    suffixes=(".obj",),
    read=read,
    write=write,
    sniff=sniff_text,
    description="Wavefront OBJ, text; polygons read, triangles and quads written",
)
