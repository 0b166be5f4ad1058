"""Read and write meshes: OBJ, OFF, PLY and STL read; those and VTK written.

The formats are modules of :mod:`fvf.io.formats` behind one registry (suffix -> reader,
writer and what the format's files hold); the functions here are what users call.

:func:`read_mesh` keeps the file's vertices exactly as stored (order, count, unreferenced
vertices; OBJ vertices are the ``v`` lines only, never split at UV seams) and returns
``(vertices, faces)`` ready for :class:`fvf.TriMesh`. By default polygons are
fan-triangulated with a :class:`PolygonTriangulatedWarning` (a non-convex polygon whose
fan would fold over is split otherwise: :mod:`fvf.io.formats.triangulate`); ``faces="quads"`` and
``faces="any"`` return quad (or other polygon) meshes as stored. An STL file is a
triangle soup: its coincident corners are welded into shared vertices, reported by a
:class:`~fvf.errors.VerticesWeldedWarning` (the rule: :mod:`fvf.io.formats.stl`). Every
parse failure raises :class:`fvf.errors.MeshReadError` naming the file, where the
problem is and how to fix it.

:func:`write_mesh` writes triangles (m, 3) or quads (m, 4): OBJ and OFF as text with 17
significant digits and PLY as binary little endian, so a round trip is exact; STL binary
(float32, triangles only); VTK through meshio or PyVista. What a format cannot hold (quads
in STL, data in OBJ) is refused before anything is written, by :func:`check_writable`,
which a program can call before a long computation.
"""

from __future__ import annotations

import os
import re
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..errors import (
    FieldShapeError,
    FvfError,
    MeshIndexError,
    MeshReadError,
    MeshShapeError,
    ParameterError,
    PolygonTriangulatedWarning,
    user_stacklevel,
)
from .fieldorder import order_comments, orders_of
from .formats import obj as _obj
from .formats import ply as _ply
from .formats._text import strict as _strict  # noqa: F401 (tests time it)
from .formats.base import (
    SNIFF_BYTES,  # noqa: F401 (re-exported)
    Polygons,
    check_polygons,
    parsed,
)
from .formats.registry import (
    FORMATS,
    check_writable,
    readable_suffixes,
    reader_for,
    writer_for,
)
from .formats.triangulate import triangulate

__all__ = [
    "read_mesh",
    "write_mesh",
    "read_quad_mesh",
    "write_quad_mesh",
    "write_uv_mesh",
    "check_writable",
]

#: Suffixes :func:`read_mesh` reads (the registry's readable formats).
SUFFIXES = readable_suffixes()
#: The VTK XML formats :func:`write_mesh` writes and :func:`read_mesh` reads (through
#: meshio or PyVista); :func:`read_mesh` also reads legacy ``.vtk``.
VTK_SUFFIXES = tuple(s for s, f in FORMATS.items() if f.name == "VTK")
#: The values of ``faces=`` of :func:`read_mesh` and :func:`read_ply_properties`.
FACE_MODES = ("triangles", "quads", "any")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.-]*")


def read_mesh(
    path: str | os.PathLike, *, faces: str = "triangles"
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Read a mesh from an OBJ, OFF, PLY, STL, VTK or glTF file.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its suffix (case-insensitive) selects the format: ``.obj``, ``.off``,
        ``.ply`` (ascii, binary_little_endian or binary_big_endian), ``.stl`` (ascii or
        binary), or VTK: ``.vtu``, ``.vtp`` (XML) and legacy ``.vtk``, read through
        PyVista, else meshio (``pip install 'fvf[vtk]'``; :mod:`fvf.io.formats.vtk`),
        their triangle, quad and polygon cells, or glTF ``.glb`` / ``.gltf`` through
        trimesh (:mod:`fvf.io.formats.gltf`: the scene's triangles, welded at seams).
    faces : {"triangles", "quads", "any"}
        ``"triangles"`` (default): every face a triangle, polygons ``(v0, ..., vk)``
        fan-triangulated into ``(v0, vi, vi+1)``; a non-convex polygon whose fan would
        fold over is split along another diagonal (quads) or ear-clipped
        (:mod:`fvf.io.formats.triangulate`). ``"quads"``: the faces as stored, which
        must all be quads. ``"any"``: the faces as stored when they all have the same
        number d of vertices (triangles or quads), else fan-triangulated as by default.

    Returns
    -------
    vertices : numpy.ndarray of float64, shape (n, 3), C-contiguous
        Vertex positions in file order; every vertex of the file is kept, including
        vertices no face refers to. STL: the welded facet corners, in the order of their
        first appearance.
    faces : numpy.ndarray of int64, shape (m, 3), (m, 4) or (m, d)
        0-based vertex indices: (m, 3) triangles by default, (m, 4) with
        ``faces="quads"``, (m, d) with ``faces="any"``.

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    fvf.errors.MeshReadError
        The suffix is unsupported, or the file cannot be parsed (a truncated STL among
        others), has no faces, has a face with fewer than 3 vertices or an index out of
        range; with ``faces="quads"``, a face that is not a quad.
    fvf.errors.ParameterError
        ``faces`` is not one of the three values.
    fvf.errors.MissingExtraError
        A VTK file without PyVista or meshio (``.vtp``: without PyVista), a glTF file
        without trimesh.

    Warns
    -----
    PolygonTriangulatedWarning
        Once per file, when polygons with more than 3 vertices were triangulated.
    VerticesWeldedWarning
        An STL file's coincident corners were welded (how many; facets that now repeat a
        vertex).
    """
    path = Path(path)
    poly = _read_polygons(path, faces)
    if _kept_as_stored(path, poly, faces):
        F, n_split, n_resplit = poly.flat.reshape(len(poly.counts), -1), 0, 0
    else:
        F, n_split, n_resplit = triangulate(poly.vertices, poly.counts, poly.flat)
    for category, message in poly.notes:
        warnings.warn(message, category, stacklevel=user_stacklevel())
    if n_split:
        other = (
            f" ({n_resplit} non-convex ones split where their fan would fold over)"
            if n_resplit
            else ""
        )
        warnings.warn(
            f"{path}: fan-triangulated {n_split} polygons with more than 3 vertices into "
            f"{F.shape[0]} triangles in all{other}",
            PolygonTriangulatedWarning,
            stacklevel=user_stacklevel(),
        )
    return np.ascontiguousarray(poly.vertices, dtype=np.float64), F


def _read_polygons(path: Path, faces: str) -> Polygons:
    """The checked polygons of a mesh file, read by the format of its suffix."""
    if faces not in FACE_MODES:
        raise ParameterError(f"faces must be one of {FACE_MODES}, got {faces!r}")
    fmt = reader_for(path)
    read = fmt.read
    assert read is not None  # reader_for returns formats that read
    return parsed(path, lambda p, data: check_polygons(p, read(p, data)), fmt)


def _kept_as_stored(path: Path, poly: Polygons, faces: str) -> bool:
    """Whether the faces are returned as stored (else fan-triangulated), per ``faces``."""
    counts = poly.counts
    if faces == "quads":
        bad = np.flatnonzero(counts != 4)
        if bad.size:
            raise MeshReadError(
                f"{path}: {poly.where(int(bad[0]))}: face has {counts[bad[0]]} vertices "
                f"({bad.size} non-quads in all); faces='quads' (and read_quad_mesh) read "
                "pure-quad meshes only: use faces='any' or the default for triangles and "
                "mixed polygons"
            )
        return True
    return faces == "any" and bool(np.all(counts == counts[0]))


def read_quad_mesh(
    path: str | os.PathLike,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Read a pure-quad mesh (OBJ, OFF or PLY): vertices float64 (n, 3), quads int64 (q, 4).

    The same as ``read_mesh(path, faces="quads")``. Raises
    :class:`fvf.errors.MeshReadError` when a face does not have 4 vertices (and for every
    failure of :func:`read_mesh`).
    """
    return read_mesh(path, faces="quads")


def read_ply_properties(
    path: str | os.PathLike, *, faces: str = "triangles"
) -> tuple[dict[str, npt.NDArray[np.float64]], dict[str, npt.NDArray[np.float64]]]:
    """Read the scalar vertex and face properties of a PLY file, aligned with :func:`read_mesh`.

    Lets a PLY file carry functions (one value per vertex, e.g. ``property float f``) and
    per-face fields (three face properties, e.g. ``vx vy vz``) next to its mesh. Lists
    (such as the face index list) are not properties in this sense and are left out, and
    so is the picture that fvf writes for MeshLab (``quality``, ``red``, ``green``,
    ``blue`` on an element that its ``comment fvf picture <element>: <name>`` marks:
    :func:`fvf.io.formats.ply.ply_bytes`); a file from elsewhere keeps them as data.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.ply`` file (ascii or binary), as accepted by :func:`read_mesh`.
    faces : {"triangles", "quads", "any"}
        As for :func:`read_mesh`, whose faces the face properties are aligned with.

    Returns
    -------
    vertex_properties : dict of str to numpy.ndarray of float64, shape (n,)
        Every scalar property of the ``vertex`` element except ``x``, ``y``, ``z``, in
        file order; n is the number of vertices :func:`read_mesh` returns.
    face_properties : dict of str to numpy.ndarray of float64, shape (m,)
        Every scalar property of the ``face`` element. When the polygons are
        triangulated, a polygon's value is repeated for each of its fan triangles, so row
        t belongs to ``read_mesh(path, faces=faces)[1][t]``.

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    fvf.errors.MeshReadError
        Not a ``.ply`` file, or the file cannot be read by :func:`read_mesh`.
    """
    path = Path(path)
    if path.suffix.lower() != ".ply":
        raise MeshReadError(
            f"{path}: only PLY files carry vertex and face properties; got suffix "
            f"{path.suffix!r} (store functions and fields in an .npz file instead)"
        )
    if faces not in FACE_MODES:
        raise ParameterError(f"faces must be one of {FACE_MODES}, got {faces!r}")

    def parse(p: Path, data: bytes) -> tuple[dict, Polygons, dict[str, str]]:
        values, where, face_list = _ply.parse(p, data)
        counts, flat = values["face"][face_list]
        vertices = np.column_stack([values["vertex"][c] for c in "xyz"])
        valid = f"0..{len(vertices) - 1}"
        pictures = _ply.picture_elements(_ply.header_comments(data))
        poly = check_polygons(p, Polygons(vertices, counts, flat, flat, where, valid))
        return values, poly, pictures

    values, poly, pictures = parsed(path, parse, _ply.FORMAT)
    # each polygon becomes counts - 2 fan triangles, in order, unless kept as stored
    rows = 1 if _kept_as_stored(path, poly, faces) else poly.counts - 2
    # fvf's picture of its data for MeshLab (quality, red, green, blue) is not data
    skip = {e: _ply.PICTURE if e in pictures else () for e in ("vertex", "face")}
    vertex = {
        name: np.asarray(a, dtype=np.float64)
        for name, a in values["vertex"].items()
        if not isinstance(a, tuple) and name not in ("x", "y", "z", *skip["vertex"])
    }
    face = {
        name: np.repeat(np.asarray(a, dtype=np.float64), rows)
        for name, a in values["face"].items()
        if not isinstance(a, tuple) and name not in skip["face"]
    }
    return vertex, face


def write_mesh(
    path: str | os.PathLike,
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    *,
    vertex_data: Mapping[str, npt.ArrayLike] | None = None,
    face_data: Mapping[str, npt.ArrayLike] | None = None,
    comments: tuple[str, ...] = (),
) -> None:
    """Write a triangle or quad mesh as OBJ, OFF (ascii), PLY (binary), STL (binary), VTK
    or glTF.

    The file is written whole or not at all (:func:`fvf.io.atomic.atomic_path`), and
    everything is checked (:func:`check_writable` among others) before it is written.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its suffix (case-insensitive) selects the format: ``.obj``, ``.off``,
        ``.ply``, ``.stl`` (binary, float32 coordinates, triangles only), or VTK XML for
        ParaView: ``.vtu`` (through meshio, else PyVista) or ``.vtp`` (through PyVista),
        legacy ``.vtk`` (binary, through PyVista); all optional
        (``pip install 'fvf[vtk]'``); glTF ``.glb`` / ``.gltf`` (triangles, float32
        positions, through trimesh). Text formats print coordinates
        with ``%.17g`` and PLY stores doubles, so reading the file back with
        :func:`read_mesh` gives exactly the same arrays.
    vertices : array_like of float, shape (n, 3)
        Vertex positions.
    faces : array_like of int, shape (m, 3) or (m, 4)
        0-based vertex indices of the triangles, or of the quads, in ``[0, n)``. Quads
        are read back with ``read_mesh(path, faces="quads")``.
    vertex_data, face_data : dict of str to array_like, optional
        Per-vertex (n,) / (n, 3) and per-face (m,) / (m, 3) arrays (functions, fields,
        marks), PLY and VTK only. In a PLY a scalar array ``p`` is the property ``p`` and a
        3-vector array the three properties ``px py pz``, exactly what
        :func:`read_ply_properties` and :func:`fvf.io.read_data` read back (a face triple
        ``vx vy vz`` is the field ``v``); for MeshLab, the first array of each element is
        also pictured by the standard properties ``quality`` and ``red green blue``
        (a 3-vector by its length; :func:`fvf.io.formats.ply.ply_bytes`), which fvf's
        readers leave out. In VTK they are point and cell data of those names
        (3-vectors as vectors). Names: letters, digits, ``_ . -``.
    comments : tuple of str
        PLY ``comment`` lines (provenance). The N of each :class:`fvf.NField` in the
        data is stored too (a PLY comment ``fvf n_<name>: N``, VTK field data
        ``n_<name>``; :mod:`fvf.io.fieldorder`), and :func:`fvf.io.read_data` gives the
        field back as an NField.

    Raises
    ------
    fvf.errors.MeshFormatError
        The suffix is unsupported, or the format cannot hold the faces (quads as STL) or
        the data (OBJ, OFF, STL hold none).
    fvf.errors.FvfError
        A name is not usable.
    fvf.errors.FieldShapeError
        A data array has neither n nor m rows, or is not (k,) / (k, 3).
    fvf.errors.MeshShapeError
        ``vertices`` or ``faces`` have the wrong shape or dtype.
    fvf.errors.MeshIndexError
        A face index is outside ``[0, n)``.
    fvf.errors.MissingExtraError
        ``.vtu`` without meshio or PyVista, ``.vtp`` without PyVista.
    fvf.errors.OutputWriteError
        The file could not be written; a file already at ``path`` is unchanged.
    """
    path = Path(path)
    writer_for(path)  # an unknown suffix first, whatever the arrays
    V, F = _checked_mesh(vertices, faces, "faces", (3, 4))
    orders = orders_of({**(vertex_data or {}), **(face_data or {})})
    comments = (*comments, *order_comments(orders))
    vdata = _checked_data(vertex_data, len(V), "vertex_data", ("x", "y", "z"))
    fdata = _checked_data(face_data, len(F), "face_data", ("vertex_indices",))
    fmt = check_writable(path, F.shape[1], vertex_data=bool(vdata), face_data=bool(fdata))
    write = fmt.write
    assert write is not None  # check_writable returns formats that write
    write(path, V, F, vdata, fdata, tuple(comments))


def _checked_mesh(
    vertices: npt.ArrayLike, faces: npt.ArrayLike, what: str, sizes: tuple[int, ...]
) -> tuple[np.ndarray, np.ndarray]:
    """Vertices float64 (n, 3) and faces int64 (m, k), k in ``sizes``, indices in range."""
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces)
    if V.ndim != 2 or V.shape[1] != 3:
        raise MeshShapeError(f"vertices must have shape (n, 3), got {V.shape}")
    integer = F.size == 0 or np.issubdtype(F.dtype, np.integer)
    if F.ndim != 2 or F.shape[1] not in sizes or not integer:
        shapes = " or ".join(f"(m, {k})" for k in sizes)
        raise MeshShapeError(f"{what} must be integers of shape {shapes}, got {F.dtype} {F.shape}")
    F = F.astype(np.int64)
    if F.size and (F.min() < 0 or F.max() >= len(V)):
        raise MeshIndexError(f"{what} refer to vertices outside [0, {len(V)}); fix the {what}")
    return V, F


def _checked_data(
    data: Mapping[str, npt.ArrayLike] | None, rows: int, what: str, reserved: tuple[str, ...]
) -> dict[str, np.ndarray]:
    """Each array as float64 (rows,) or (rows, 3), names checked."""
    out = {}
    for name, a in (data or {}).items():
        a = np.asarray(a)
        if a.dtype.kind not in "biuf":
            raise FieldShapeError(f"{what}[{name!r}] must hold real numbers; got {a.dtype}")
        if not (a.shape == (rows,) or a.shape == (rows, 3)):
            raise FieldShapeError(
                f"{what}[{name!r}] has shape {a.shape}; expected ({rows},) or ({rows}, 3)"
            )
        names = [name] if a.ndim == 1 else [name + c for c in "xyz"]
        if _NAME.fullmatch(name) is None or set(names) & set(reserved):
            raise FvfError(
                f"{what}: {name!r} cannot be a property name (letters, digits, _ . - and not "
                f"{', '.join(reserved)})"
            )
        out[name] = a.astype(np.float64)
    return out


def write_quad_mesh(path: str | os.PathLike, vertices: npt.ArrayLike, quads: npt.ArrayLike) -> None:
    """Write a quad mesh as OBJ or OFF text (17 significant digits), atomically.

    :func:`write_mesh` writes quads too, in every format that holds them (also PLY and
    VTK); this function keeps to the two text formats.

    Parameters
    ----------
    path : str or os.PathLike
        ``.obj`` or ``.off``; written through :func:`fvf.io.atomic.atomic_path`.
    vertices : array_like (n, 3) float
    quads : array_like (q, 4) int
        0-based vertex indices.
    """
    path = Path(path)
    if path.suffix.lower() not in (".obj", ".off"):
        raise FvfError(
            f"{path}: write_quad_mesh writes quad meshes as .obj or .off; got "
            f"{path.suffix!r} (fvf.write_mesh(path, V, Q) also writes .ply, .vtu and .vtp)"
        )
    V, Q = _checked_mesh(vertices, quads, "quads", (4,))
    write_mesh(path, V, Q)


def write_uv_mesh(
    path: str | os.PathLike, vertices: npt.ArrayLike, faces: npt.ArrayLike, uv: npt.ArrayLike
) -> None:
    """Write a triangle mesh with per-corner texture coordinates as OBJ (``vt``), atomically.

    Parameters
    ----------
    path : str or os.PathLike
        ``.obj``.
    vertices : array_like (n, 3) float
    faces : array_like (m, 3) int
    uv : array_like (m, 3, 2) float
        Coordinates of each corner (e.g. :attr:`fvf.SeamlessParameterization.uv`); one
        ``vt`` line per distinct (u, v) pair, so seams stay seams.
    """
    path = Path(path)
    if path.suffix.lower() != ".obj":
        raise FvfError(f"{path}: texture coordinates are written as .obj; got {path.suffix!r}")
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    T = np.asarray(uv, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3:
        raise MeshShapeError(f"need vertices (n, 3) and faces (m, 3); got {V.shape}, {F.shape}")
    if T.shape != (F.shape[0], 3, 2):
        raise MeshShapeError(f"uv must have shape ({F.shape[0]}, 3, 2), got {T.shape}")
    if F.size and (F.min() < 0 or F.max() >= len(V)):
        raise MeshIndexError(f"faces refer to vertices outside [0, {len(V)}); fix the faces")
    _obj.write_uv(path, V, F, T)
