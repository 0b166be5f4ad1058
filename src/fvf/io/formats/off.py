"""OFF (Object File Format, ascii): ``OFF``, the counts, vertex lines, ``k i0 ... i(k-1)``.

Read: the variants ``COFF``, ``NOFF``, ``CNOFF`` (MeshLab writes ``NCOFF``), ``STOFF``
(colours, normals and texture coordinates after x y z are left out) and ``4OFF``
(homogeneous x y z w, the point (x, y, z) / w); polygons of any size; ``#`` comments.
Binary OFF is refused. Written as ``OFF`` text with 17 significant digits, so a round trip
is exact; no vertex or face data.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ...errors import MeshReadError
from ._text import first3, flatten, numbers, text_lines
from ._text import words as line_words
from .base import MeshFormat, Polygons, rows_text, sniff_text, write_text

__all__ = ["read", "write", "FORMAT"]


def read(path: Path, data: bytes) -> Polygons:
    """The vertices and polygons of an ascii OFF file (see the module docstring)."""
    lines = text_lines(data)
    words = [line_words(line) for line in lines]
    content = [i for i, w in enumerate(words) if w]
    if not content:
        raise MeshReadError(f"{path}: the file holds only comments; write a mesh into it")
    first = words[content[0]]
    if not re.fullmatch(r"(ST)?(C|N|CN|NC)?4?OFF", first[0]) or first[1:2] == ["BINARY"]:
        raise MeshReadError(
            f"{path}: line {content[0] + 1}: expected the OFF header (OFF, COFF, NOFF, "
            f"CNOFF, NCOFF, STOFF; ascii only) but found {' '.join(first)[:40]!r}; is it an "
            "ascii OFF file?"
        )
    header, rest = (first[1:], content[1:]) if len(first) > 1 else (None, content[1:])
    count_line = content[0] + 1
    if header is None and rest:
        header, count_line, rest = words[rest[0]], rest[0] + 1, rest[1:]
    nv = nf = -1
    if header and len(header) >= 2 and all(w.isascii() and w.isdigit() for w in header[:2]):
        nv, nf = int(header[0]), int(header[1])
    if nv < 0:
        raise MeshReadError(
            f"{path}: line {count_line}: the OFF header needs the counts 'n_vertices n_faces "
            f"n_edges' but found {' '.join(header or ['nothing'])[:40]!r}; add the counts line"
        )
    if len(rest) < nv + nf:
        raise MeshReadError(
            f"{path}: line {count_line}: the OFF header promises {nv} vertices and {nf} faces, "
            f"but only {len(rest)} data lines follow; the file is truncated or the counts wrong"
        )
    if len(rest) > nv + nf:  # never dropped unsaid: 320 faces under a header of 300
        raise MeshReadError(
            f"{path}: line {rest[nv + nf] + 1}: {len(rest) - nv - nf} data lines follow the "
            f"{nv} vertices and {nf} faces the header (line {count_line}) declares; the "
            "header's counts are wrong (or the file was joined with another): fix the counts "
            "or re-export the mesh"
        )
    v_at, f_at = rest[:nv], rest[nv : nv + nf]
    v_line, f_line = [i + 1 for i in v_at], [i + 1 for i in f_at]
    tokens, counts = flatten([words[i] for i in v_at])
    if "4" in first[0]:  # 4OFF: homogeneous x y z w, the point (x, y, z) / w
        vertices = _homogeneous(path, tokens, counts, v_line)
    else:
        vertices = first3(path, tokens, counts, v_line, "an OFF vertex line")
    rows = [words[i] for i in f_at]
    counts = np.fromiter(map(len, rows), np.int64, len(rows))
    what = "an OFF face line (vertex count)"
    k = numbers(path, [r[0] for r in rows], np.ones_like(counts), f_line, np.int64, what)
    short = np.flatnonzero((k < 0) | (counts < k + 1))
    if short.size:
        i = short[0]
        raise MeshReadError(
            f"{path}: line {f_line[i]}: the face line says it has {k[i]} vertices but lists "
            f"only {counts[i] - 1} values; write 'k i0 ... i(k-1)' on one line"
        )
    idx = [t for r, c in zip(rows, k.tolist(), strict=True) for t in r[1 : 1 + c]]
    flat = numbers(path, idx, k, f_line, np.int64, "an OFF face line (vertex index)")
    valid = f"0..{len(vertices) - 1}"
    return Polygons(vertices, k, flat, flat, lambda i: f"line {f_line[i]}", valid)


def _homogeneous(
    path: Path, tokens: list[str], counts: np.ndarray, lineno: list[int]
) -> np.ndarray:
    """Vertex positions (k, 3) of a 4OFF file: (x, y, z) / w from each line's x y z w."""
    short = np.flatnonzero(counts < 4)
    if short.size:
        i = short[0]
        raise MeshReadError(
            f"{path}: line {lineno[i]}: a 4OFF vertex needs x y z w (homogeneous "
            f"coordinates) but has {counts[i]} values; fix that line or the header"
        )
    starts = (np.cumsum(counts) - counts).tolist()
    xyzw = [t for s in starts for t in tokens[s : s + 4]]
    four = np.full(len(counts), 4, dtype=np.int64)
    what = "a 4OFF vertex line"
    X = numbers(path, xyzw, four, lineno, np.float64, what).reshape(-1, 4)
    zero = np.flatnonzero(X[:, 3] == 0)
    if zero.size:
        raise MeshReadError(
            f"{path}: line {lineno[zero[0]]}: w = 0 puts the 4OFF vertex at infinity "
            f"({zero.size} such vertices); fix the coordinates"
        )
    return X[:, :3] / X[:, 3:]


def write(
    path: Path,
    V: np.ndarray,
    F: np.ndarray,
    vertex_data: Mapping[str, np.ndarray],
    face_data: Mapping[str, np.ndarray],
    comments: tuple[str, ...] = (),
) -> None:
    """``OFF``, ``n m 0``, one ``x y z`` line per vertex (``%.17g``), ``k i ...`` per face."""
    k = F.shape[1]
    faces = rows_text(str(k), F, "%d")
    write_text(path, f"OFF\n{len(V)} {len(F)} 0\n" + rows_text("", V, "%.17g") + faces)


FORMAT = MeshFormat(
    name="OFF",
    suffixes=(".off",),
    read=read,
    write=write,
    sniff=sniff_text,
    description="Object File Format, ascii (COFF, NOFF, CNOFF, STOFF, 4OFF read); polygons read, "
    "triangles and quads written",
)
