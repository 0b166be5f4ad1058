"""What the mesh format modules share: the polygons a reader returns, the record of a
format's capabilities that the registry keeps, reading a file safely, and the checks and
fan triangulation of a file's faces.

A reader is ``read(path, data) -> Polygons``: ``data`` is the whole file (a UTF-8 byte
order mark dropped when the format starts with text). A writer is ``write(path, V, F,
vertex_data, face_data, comments)`` with checked arrays (:mod:`fvf.io.meshfile` checks
them) and writes through :func:`fvf.io.atomic.atomic_path`.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple, TypeVar

import numpy as np

from ...errors import MeshReadError, MissingExtraError
from ..atomic import atomic_path
from ..inputfile import read_bytes

__all__ = [
    "Polygons",
    "MeshFormat",
    "SNIFF_BYTES",
    "parsed",
    "check_polygons",
    "fan_triangulate",
    "sniff_text",
    "write_text",
]

_T = TypeVar("_T")

#: Bytes of a file's start that are checked before the whole file is read.
SNIFF_BYTES = 1 << 16
BOM = b"\xef\xbb\xbf"


class Polygons(NamedTuple):
    """What a format reader returns: the file's vertices and faces as stored."""

    vertices: np.ndarray  # (n, 3) float64
    counts: np.ndarray  # (m,) int64, vertices per polygon
    flat: np.ndarray  # (counts.sum(),) int64, 0-based indices (-1 when invalid)
    shown: np.ndarray  # like flat, the indices as written in the file
    where: Callable[[int], str]  # polygon number -> "line 12" / "face 3"
    valid: str  # the valid index range, as the file's convention writes it
    #: (warning class, message) pairs that the reading function emits for the user
    notes: tuple[tuple[type[Warning], str], ...] = ()


Reader = Callable[[Path, bytes], Polygons]
Writer = Callable[
    [Path, np.ndarray, np.ndarray, Mapping[str, np.ndarray], Mapping[str, np.ndarray], tuple],
    None,
]


@dataclass(frozen=True)
class MeshFormat:
    """A mesh file format: its suffixes, reader, writer and what its files can hold.

    Attributes
    ----------
    name : str
        Short name, as messages print it (``"OBJ"``).
    suffixes : tuple of str
        Lower-case file suffixes with the dot (``(".obj",)``).
    read : callable or None
        ``read(path, data) -> Polygons``; None for a format fvf only writes.
    write : callable or None
        ``write(path, V, F, vertex_data, face_data, comments)``; None for read-only.
    face_sizes : tuple of int
        Face sizes the writer writes: ``(3,)`` triangles only, ``(3, 4)`` quads too.
    polygons : bool
        Whether the format's files hold polygons of any size (else triangles only).
    vertex_data, face_data : bool
        Whether the format holds per-vertex / per-face arrays (functions, fields).
    text_start : bool
        Whether files start with text: a UTF-8 byte order mark there is dropped.
    sniff : callable or None
        ``sniff(path, head)`` refuses a file from its first :data:`SNIFF_BYTES` bytes.
    requires : callable or None
        ``requires(path)`` raises :class:`fvf.errors.MissingExtraError` when the optional
        packages the writer needs are not installed.
    description : str
        One line for the documentation's table of formats.
    """

    name: str
    suffixes: tuple[str, ...]
    read: Reader | None
    write: Writer | None
    face_sizes: tuple[int, ...] = (3, 4)
    polygons: bool = True
    vertex_data: bool = False
    face_data: bool = False
    text_start: bool = True
    sniff: Callable[[Path, bytes], None] | None = None
    requires: Callable[[Path], None] | None = None
    description: str = ""


def sniff_text(path: Path, head: bytes) -> None:
    """Refuse, from its first bytes, a file that cannot be a text mesh of its suffix
    (UTF-16 text, NUL bytes), before a possibly huge file is read whole."""
    suffix = path.suffix.lower()
    head = head.removeprefix(BOM)
    if head[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raise MeshReadError(
            f"{path}: the file is UTF-16 text; save it as ASCII or UTF-8 (fvf reads "
            f"{suffix[1:].upper()} as 8-bit text)"
        )
    if b"\x00" in head:
        k = head.index(b"\x00")
        raise MeshReadError(
            f"{path}: byte {k} is NUL: this is a binary file, not a text "
            f"{suffix[1:].upper()} file; check the file (or its suffix)"
        )


def parsed(path: Path, parse: Callable[[Path, bytes], _T], fmt: MeshFormat) -> _T:
    """``parse(path, bytes)`` with every parse failure turned into a MeshReadError.

    The path must be a regular file (not a FIFO or a device); its start is checked
    (``fmt.sniff``) before it is read whole, with a size check; a UTF-8 byte order mark
    is dropped from formats that start with text.
    """
    head = read_bytes(path, MeshReadError, head=SNIFF_BYTES)
    if fmt.sniff is not None:
        fmt.sniff(path, head)
    data = read_bytes(path, MeshReadError)
    if fmt.text_start:
        data = data.removeprefix(BOM)
    if not data.strip():
        raise MeshReadError(f"{path}: the file is empty; write a mesh into it or pick another")
    suffix = path.suffix.lower()
    try:
        return parse(path, data)
    except (MeshReadError, MissingExtraError):
        raise
    except (ValueError, TypeError, IndexError, OverflowError, struct.error) as exc:
        raise MeshReadError(
            f"{path}: cannot parse this {suffix} file ({type(exc).__name__}: {exc}); "
            f"check that it is a valid {suffix[1:].upper()} file, or re-export it"
        ) from exc


def check_polygons(path: Path, p: Polygons) -> Polygons:
    """The polygons of a file, checked: some faces, each with >= 3 vertices in range."""
    n, counts, flat = len(p.vertices), p.counts, p.flat
    if counts.size == 0:
        raise MeshReadError(
            f"{path}: the file has {n} vertices but no faces; read_mesh needs a surface "
            "mesh, not a point cloud: export the mesh with its faces"
        )
    small = np.flatnonzero(counts < 3)
    if small.size:
        i = small[0]
        raise MeshReadError(
            f"{path}: {p.where(i)}: face has {counts[i]} vertices, but faces need at least 3 "
            f"({small.size} such faces in all); remove points and edges from the face list"
        )
    bad = np.flatnonzero((flat < 0) | (flat >= n))
    if bad.size:
        face = int(np.searchsorted(np.cumsum(counts), bad[0], side="right"))
        raise MeshReadError(
            f"{path}: {p.where(face)}: face refers to vertex index {p.shown[bad[0]]}, but the "
            f"file has {n} vertices (valid indices: {p.valid}); {bad.size} out-of-range "
            "indices in all: fix the faces or the vertex list"
        )
    return p


def fan_triangulate(counts: np.ndarray, flat: np.ndarray) -> tuple[np.ndarray, int]:
    """Polygons ``(v0, ..., vk)`` as the fans ``(v0, vi, vi+1)``: ``(faces (m, 3), #split)``.

    Parameters
    ----------
    counts : numpy.ndarray of int64, shape (p,)
        Vertices per polygon (each >= 3).
    flat : numpy.ndarray of int64, shape (counts.sum(),)
        The polygons' vertex indices, one after the other.

    Returns
    -------
    faces : numpy.ndarray of int64, shape (counts.sum() - 2 p, 3)
        The triangles, polygon by polygon in order (polygon i gives ``counts[i] - 2``).
    n_split : int
        How many polygons had more than 3 vertices.
    """
    if np.all(counts == 3):
        return flat.reshape(-1, 3), 0
    ntri = counts - 2
    poly = np.repeat(np.arange(counts.size), ntri)
    first = (np.cumsum(counts) - counts)[poly]
    j = first + np.arange(ntri.sum()) - np.repeat(np.cumsum(ntri) - ntri, ntri) + 1
    faces = np.column_stack([flat[first], flat[j], flat[j + 1]])
    return faces, int(np.count_nonzero(counts > 3))


def write_text(path: Path, text: str) -> None:
    """Write ASCII text to ``path`` whole or not at all."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="ascii")


def rows_text(prefix: str, values: np.ndarray, spec: str) -> str:
    """One line ``prefix v0 v1 ...`` per row of a 2-D array, each value printed ``spec``
    (``"%.17g"``, ``"%d"``); one ``%`` formatting of the whole array."""
    m, k = values.shape
    line = (prefix + " " if prefix else "") + " ".join([spec] * k) + "\n"
    return (line * m) % tuple(values.ravel().tolist())
