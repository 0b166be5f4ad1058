r"""STL (stereolithography): a triangle soup, ascii or binary.

Binary or ascii is decided by the file's size, not by its first word: a binary STL has an
80-byte header, a ``uint32`` triangle count n and n records of 50 bytes, so exactly
:math:`84 + 50 n` bytes, and its header may well begin with ``solid`` (many exporters
write that). A file of any other size that begins with ``solid`` and holds no NUL byte is
ascii; every other file is a damaged binary STL, reported with the sizes (truncated, or
bytes after the last triangle). Ascii files may hold several ``solid ... endsolid``
blocks; their facets are read in order into one mesh, and each block must be closed.

Both are parsed with whole-array numpy operations (a binary file is one structured
:func:`numpy.frombuffer`; an ascii file one token list, checked facet by facet as rows of
21 tokens). Facet normals are never used (NaN normals are fine): orientation is the
order of the corners.

**Welding.** An STL lists three corners per facet and no shared vertices. Corners are
welded into one vertex when their three coordinates are *equal as floating-point
numbers* (:math:`0.0 = -0.0`; NaN equals nothing, so a NaN corner stays alone); no
tolerance, so corners that differ by round-off stay apart (then merge them with
:func:`fvf.remove_duplicate_vertices` and a ``tol``). This is the rule of
:func:`fvf.remove_duplicate_vertices` with ``tol=0``. The vertices are numbered in the
order their first corner appears in the file and keep that corner's stored value. The
reading function reports it with a :class:`fvf.errors.VerticesWeldedWarning` (how many
corners were merged, and how many facets now repeat a vertex: zero-area facets, which
``fvf repair`` removes). Faces are never dropped.

Written: binary, little endian, float32 coordinates (about 7 significant digits: a round
trip is exact only for coordinates that are float32 numbers), each facet's unit normal
(zero for a zero-area facet), attribute 0; the header never begins with ``solid``.
Triangles only; no vertex or face data.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ...errors import MeshReadError, VerticesWeldedWarning
from ..atomic import atomic_write_bytes
from ._text import numbers
from .base import BOM, MeshFormat, Polygons

__all__ = ["read", "write", "weld", "FORMAT"]

#: One binary facet: normal, three corners, attribute byte count (50 bytes).
RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
HEADER_BYTES = 84
#: The 21 tokens of an ascii facet: keyword columns (the others are numbers).
_KEYWORDS = {0: "facet", 1: "normal", 5: "outer", 6: "loop", 7: "vertex", 11: "vertex",
             15: "vertex", 19: "endloop", 20: "endfacet"}  # fmt: skip
_COORDS = [8, 9, 10, 12, 13, 14, 16, 17, 18]


def read(path: Path, data: bytes) -> Polygons:
    """The welded triangles of an ascii or binary STL file (see the module docstring)."""
    if _is_binary(path, data):
        n = int.from_bytes(data[80:84], "little")
        rec = np.frombuffer(data, RECORD, n, HEADER_BYTES)
        corners = rec["corners"].reshape(-1, 3).astype(np.float64)
        kind = "binary"
    else:
        corners = _ascii_corners(path, data.removeprefix(BOM))
        kind = "ascii"
    V, F = weld(corners)
    m = len(F)
    flat = F.reshape(-1)
    notes: tuple[tuple[type[Warning], str], ...] = ()
    merged = 3 * m - len(V)
    if merged:
        repeats = int(np.count_nonzero(_repeats_vertex(F)))
        text = (
            f"{path}: welded the {3 * m} corners of {m} {kind} STL facets into {len(V)} "
            f"vertices ({merged} corners at exactly the position of an earlier corner)"
        )
        if repeats:
            text += f"; {repeats} facets now repeat a vertex (zero area): fvf repair removes them"
        notes = ((VerticesWeldedWarning, text),)
    counts = np.full(m, 3, dtype=np.int64)
    where, valid = (lambda i: f"facet {i} (0-based)"), f"0..{len(V) - 1}"
    return Polygons(V, counts, flat, flat, where, valid, notes)


def _is_binary(path: Path, data: bytes) -> bool:
    """Whether ``data`` is a binary STL; raise for a damaged one (see the module docstring)."""
    size = len(data)
    n = int.from_bytes(data[80:84], "little") if size >= HEADER_BYTES else -1
    expected = HEADER_BYTES + RECORD.itemsize * n
    if size == expected:
        return True
    says_solid = data.removeprefix(BOM).lstrip()[:5].lower() == b"solid"
    if says_solid and b"\x00" not in data:
        return False
    if not says_solid:
        _refuse_other_format(path, data)
    if size < HEADER_BYTES:
        raise MeshReadError(
            f"{path}: the file has {size} bytes, fewer than the 84 of a binary STL's header "
            "and triangle count, and is not ascii STL text ('solid' ...): it is truncated or "
            "not an STL file"
        )
    like = "begins with 'solid' like an ascii STL but holds NUL bytes, so it is binary: "
    like = like if says_solid else ""
    complete = (size - HEADER_BYTES) // RECORD.itemsize
    if size < expected:
        what = f"ends early after {complete} complete triangles: the file is truncated"
    else:
        what = f"has {size - expected} bytes after the last triangle: its count is damaged"
    raise MeshReadError(
        f"{path}: {like}the binary STL header promises {n} triangles, so 84 + 50*{n} = "
        f"{expected} bytes, but the file has {size}; it {what}: re-export the mesh"
    )


#: The first bytes of files that are often named ``.stl`` by mistake, and what they are.
OTHER_FORMATS = (
    (b"\x1f\x8b", "gzip-compressed (decompress it first: gunzip)"),
    (b"PK\x03\x04", "a zip archive (unzip it first)"),
    (b"ply", "a PLY file (name it .ply)"),
    (b"OFF", "an OFF file (name it .off)"),
    (b"glTF", "a binary glTF file (name it .glb)"),
)


def _refuse_other_format(path: Path, data: bytes) -> None:
    """Raise for a file that is not an STL at all, before it is judged as a damaged
    binary STL: a known signature, or text (an OBJ named .stl got "truncated")."""
    head = data.removeprefix(BOM)[:4096]
    for magic, what in OTHER_FORMATS:
        if head.startswith(magic):
            raise MeshReadError(f"{path}: this is not an STL file: it is {what}")
    printable = sum(32 <= b < 127 or b in (9, 10, 13) for b in head)
    # text that is not ascii STL ('solid' ...); a binary STL's 80-byte header is text too
    if len(head) > HEADER_BYTES and printable == len(head):
        first = head.split(b"\n", 1)[0].decode("ascii", "replace").strip()[:40]
        raise MeshReadError(
            f"{path}: this is not an STL file: it is text that does not begin with 'solid' "
            f"(it begins with {first!r}: an OBJ file? name it by its format)"
        )


def _ascii_corners(path: Path, data: bytes) -> np.ndarray:
    """The facet corners (3 m, 3) of an ascii STL, facets of all ``solid`` blocks in order."""
    text = data.decode("latin-1").lower()
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    body = _without_solid_lines(path, text)
    tokens = body.split()
    k, rest = divmod(len(tokens), 21)
    T = np.array(tokens[: 21 * k], dtype=object).reshape(k, 21)
    ok = np.ones(k, dtype=bool)
    for col, word in _KEYWORDS.items():
        ok &= T[:, col] == word
    bad = np.flatnonzero(~ok)
    if bad.size or rest:
        _bad_facet(path, body, tokens, int(bad[0]) if bad.size else k)
    values = T[:, _COORDS].reshape(-1).tolist()
    three = np.full(3 * k, 3, dtype=np.int64)
    lines = _VertexLines(body, k)
    return numbers(path, values, three, lines, np.float64, "an STL 'vertex' line").reshape(-1, 3)


def _solid_lines(text: str) -> list[tuple[int, int, bool]]:
    """``(start, end, is_endsolid)`` of each ``solid`` / ``endsolid`` line of the lower-case
    ``text``: a scan for the word ``solid`` (a few hits), not a pass per line."""
    found = []
    pos = text.find("solid")
    while pos >= 0:
        start = text.rfind("\n", 0, pos) + 1
        end = text.find("\n", pos)
        end = len(text) if end < 0 else end
        lead = text[start:pos].strip(" \t")
        after = text[pos + 5 : pos + 6]
        if lead in ("", "end") and after in ("", " ", "\t", "\n"):
            found.append((start, end, lead == "end"))
        pos = text.find("solid", end)
    return found


def _without_solid_lines(path: Path, text: str) -> str:
    """``text`` with its ``solid`` / ``endsolid`` lines blanked (line numbers kept),
    checking that each ``solid`` line is closed by an ``endsolid`` before the next one."""
    found = _solid_lines(text)
    for i, (start, end, is_end) in enumerate(found):
        if is_end != (i % 2 == 1):
            raise MeshReadError(
                f"{path}: line {text.count(chr(10), 0, start) + 1}: "
                f"{text[start:end].strip()[:40]!r} where {'endsolid' if i % 2 else 'solid'} "
                "belongs: every 'solid' block of an ascii STL ends with 'endsolid' before the "
                "next begins"
            )
    if len(found) % 2:
        line = text.count("\n", 0, found[-1][0]) + 1
        raise MeshReadError(
            f"{path}: the 'solid' block of line {line} has no 'endsolid': the file ends "
            "inside it, so it is truncated; re-export the mesh"
        )
    ends = [0] + [x for start, end, _ in found for x in (start, end)] + [len(text)]
    return "".join(text[ends[j] : ends[j + 1]] for j in range(0, len(ends), 2))


def _bad_facet(path: Path, body: str, tokens: list[str], i: int) -> None:
    """Raise the error for facet ``i``, the first not laid out as ascii STL says."""
    row = tokens[21 * i : 21 * i + 21]
    if len(row) < 21:  # the last facet, cut short
        raise MeshReadError(
            f"{path}: line {_line_of_token(body, len(tokens) - 1)}: facet {i} (0-based) is "
            f"incomplete: {len(row)} of its 21 words before the end of the file (it is "
            "truncated, or a value is missing); re-export the mesh"
        )
    for col, want in _KEYWORDS.items():
        if row[col] != want:
            raise MeshReadError(
                f"{path}: line {_line_of_token(body, 21 * i + col)}: facet {i} (0-based) has "
                f"{row[col][:30]!r} where {want!r} belongs; an ascii STL facet is 'facet "
                "normal nx ny nz', 'outer loop', three 'vertex x y z', 'endloop', 'endfacet'"
            )


def _line_of_token(body: str, t: int) -> int:
    """The 1-based line of the ``t``-th token of ``body`` (for error messages only)."""
    per_line = np.fromiter((len(s.split()) for s in body.split("\n")), np.int64)
    return int(np.searchsorted(np.cumsum(per_line), t, side="right")) + 1


class _VertexLines:
    """``lines[i]``: the line of the i-th ``vertex`` statement, found only when asked (an
    error message), so a clean file costs nothing."""

    def __init__(self, body: str, k: int) -> None:
        self.body, self.k = body, k

    def __len__(self) -> int:
        return 3 * self.k

    def __getitem__(self, i: int) -> int:
        return _line_of_token(self.body, 21 * (i // 3) + 7 + 4 * (i % 3))


def weld(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weld facet corners at equal positions into shared vertices.

    Parameters
    ----------
    corners : numpy.ndarray of float64, shape (3 m, 3)
        The corners of m triangles, three by three.

    Returns
    -------
    vertices : numpy.ndarray of float64, shape (n, 3)
        One vertex per distinct position, in the order of first appearance, at the stored
        value of that first corner.
    faces : numpy.ndarray of int64, shape (m, 3)
        The triangles on the welded vertices.

    Notes
    -----
    Positions are equal when their coordinates compare equal (``0.0 == -0.0``; NaN never
    equals anything). One sort of the corners (``numpy.lexsort``), no loop.
    """
    X = corners + 0.0  # -0.0 -> 0.0
    n = len(X)
    order = np.lexsort((np.arange(n), X[:, 2], X[:, 1], X[:, 0]))
    Xs = X[order]
    new = np.ones(n, dtype=bool)
    new[1:] = (Xs[1:] != Xs[:-1]).any(axis=1)
    group = np.cumsum(new) - 1  # group of each sorted corner
    first = order[new]  # each group's first corner in the file (stable ties by index)
    rank = np.empty(first.size, dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(first.size)
    vid = np.empty(n, dtype=np.int64)
    vid[order] = rank[group]
    return corners[np.sort(first)], vid.reshape(-1, 3)


def _repeats_vertex(F: np.ndarray) -> np.ndarray:
    return (F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2])


def write(
    path: Path,
    V: np.ndarray,
    F: np.ndarray,
    vertex_data: Mapping[str, np.ndarray],
    face_data: Mapping[str, np.ndarray],
    comments: tuple[str, ...] = (),
) -> None:
    """Binary little-endian STL of the triangles ``F`` (see the module docstring)."""
    T = V[F]
    normal = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    unit = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    rec = np.zeros(len(F), dtype=RECORD)
    with np.errstate(over="ignore", invalid="ignore"):
        rec["normal"], rec["corners"] = unit, T
    header = f"binary STL written by fvf: {len(F)} triangles".encode("ascii").ljust(80)
    data = header + np.uint32(len(F)).astype("<u4").tobytes() + rec.tobytes()
    atomic_write_bytes(path, data)


FORMAT = MeshFormat(
    name="STL",
    suffixes=(".stl",),
    read=read,
    write=write,
    face_sizes=(3,),
    polygons=False,
    text_start=False,
    description="stereolithography, ascii or binary; a triangle soup, welded on reading "
    "(exact equality); written binary (float32), triangles only",
)
