"""Read and write triangle meshes: Wavefront OBJ, OFF and PLY.

:func:`read_mesh` keeps the file's vertices exactly as stored (order, count, unreferenced
vertices; OBJ vertices are the ``v`` lines only, never split at UV seams) and returns
``(vertices, faces)`` ready for :class:`fvf.TriMesh`. Polygons are fan-triangulated with a
:class:`PolygonTriangulatedWarning`. Every parse failure raises
:class:`fvf.errors.MeshReadError` naming the file, where the problem is and how to fix it.
:func:`write_mesh` writes OBJ and OFF as text with 17 significant digits and PLY as binary
little endian, so a round trip is exact.
"""

from __future__ import annotations

import os
import re
import struct
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import NamedTuple, TypeVar

import numpy as np
import numpy.typing as npt

from ..errors import (
    FvfError,
    MeshIndexError,
    MeshReadError,
    MeshShapeError,
    PolygonTriangulatedWarning,  # noqa: F401 (re-exported)
)
from .atomic import atomic_path
from .inputfile import read_bytes

__all__ = [
    "read_mesh",
    "write_mesh",
    "read_quad_mesh",
    "write_quad_mesh",
    "write_uv_mesh",
]

_T = TypeVar("_T")

SUFFIXES = (".obj", ".off", ".ply")
_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}  # fmt: skip
_PLY_FORMATS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}
_FACE_LISTS = ("vertex_indices", "vertex_index")
_STRUCT = {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I"}


class _Polygons(NamedTuple):
    """What a format reader hands to :func:`_triangulate`."""

    vertices: np.ndarray  # (n, 3) float64
    counts: np.ndarray  # (m,) int64, vertices per polygon
    flat: np.ndarray  # (counts.sum(),) int64, 0-based indices (-1 when invalid)
    shown: np.ndarray  # like flat, the indices as written in the file
    where: Callable[[int], str]  # polygon number -> "line 12" / "face 3"
    valid: str  # the valid index range, as the file's convention writes it


def read_mesh(path: str | os.PathLike) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Read a triangle mesh from an OBJ, OFF or PLY file.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its suffix (case-insensitive) selects the format: ``.obj``, ``.off`` or
        ``.ply`` (ascii, binary_little_endian or binary_big_endian).

    Returns
    -------
    vertices : numpy.ndarray of float64, shape (n, 3), C-contiguous
        Vertex positions in file order; every vertex of the file is kept, including
        vertices no face refers to.
    faces : numpy.ndarray of int64, shape (m, 3)
        0-based vertex indices of the triangles. Polygons ``(v0, ..., vk)`` become the
        fan ``(v0, vi, vi+1)``.

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    fvf.errors.MeshReadError
        The suffix is unsupported, or the file cannot be parsed, has no faces, has a face
        with fewer than 3 vertices or an index out of range.

    Warns
    -----
    PolygonTriangulatedWarning
        Once per file, when polygons with more than 3 vertices were triangulated.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    reader = _READERS.get(suffix)
    if reader is None:
        raise MeshReadError(
            f"{path}: unsupported mesh file suffix {path.suffix!r}; read_mesh reads "
            f"{', '.join(SUFFIXES)} (case-insensitive): convert the mesh or rename the file"
        )
    poly, (faces, n_split) = _parsed(path, lambda p, data: _checked(p, reader(p, data)))
    if n_split:
        warnings.warn(
            f"{path}: fan-triangulated {n_split} polygons with more than 3 vertices into "
            f"{faces.shape[0]} triangles in all",
            PolygonTriangulatedWarning,
            stacklevel=2,
        )
    return np.ascontiguousarray(poly.vertices, dtype=np.float64), faces


def read_ply_properties(
    path: str | os.PathLike,
) -> tuple[dict[str, npt.NDArray[np.float64]], dict[str, npt.NDArray[np.float64]]]:
    """Read the scalar vertex and face properties of a PLY file, aligned with :func:`read_mesh`.

    Lets a PLY file carry functions (one value per vertex, e.g. ``property float f``) and
    per-face fields (three face properties, e.g. ``vx vy vz``) next to its mesh. Lists
    (such as the face index list) are not properties in this sense and are left out.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.ply`` file (ascii or binary), as accepted by :func:`read_mesh`.

    Returns
    -------
    vertex_properties : dict of str to numpy.ndarray of float64, shape (n,)
        Every scalar property of the ``vertex`` element except ``x``, ``y``, ``z``, in
        file order; n is the number of vertices :func:`read_mesh` returns.
    face_properties : dict of str to numpy.ndarray of float64, shape (m,)
        Every scalar property of the ``face`` element. A polygon's value is repeated for
        each of its fan triangles, so row t belongs to ``read_mesh(path)[1][t]``.

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

    def parse(p: Path, data: bytes) -> tuple[dict, np.ndarray]:
        values, where, face_list = _parse_ply(p, data)
        counts, flat = values["face"][face_list]
        vertices = np.column_stack([values["vertex"][c] for c in "xyz"])
        _checked(p, _Polygons(vertices, counts, flat, flat, where, f"0..{len(vertices) - 1}"))
        return values, counts

    values, counts = _parsed(path, parse)
    ntri = counts - 2  # each polygon becomes counts - 2 fan triangles, in order
    vertex = {
        name: np.asarray(a, dtype=np.float64)
        for name, a in values["vertex"].items()
        if not isinstance(a, tuple) and name not in ("x", "y", "z")
    }
    face = {
        name: np.repeat(np.asarray(a, dtype=np.float64), ntri)
        for name, a in values["face"].items()
        if not isinstance(a, tuple)
    }
    return vertex, face


#: Bytes of a file's start that are checked before the whole file is read.
SNIFF_BYTES = 1 << 16
_BOM = b"\xef\xbb\xbf"


def _sniff(path: Path, head: bytes) -> None:
    """Refuse, from its first bytes, a file that cannot be a mesh of its suffix, before a
    possibly huge file is read whole."""
    suffix = path.suffix.lower()
    head = head.removeprefix(_BOM)
    if suffix == ".ply":
        if head[:3] != b"ply" and head.strip():
            first = head[:40].split(b"\n")[0].decode("latin-1").strip()
            raise MeshReadError(
                f"{path}: line 1: a PLY file starts with 'ply', not {first!r}; is it a PLY file?"
            )
        return
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


def _parsed(path: Path, parse: Callable[[Path, bytes], _T]) -> _T:
    """``parse(path, bytes)`` with every parse failure turned into a MeshReadError.

    The path must be a regular file (not a FIFO or a device); its start is checked
    (:func:`_sniff`) before it is read whole, with a size check; a UTF-8 byte order mark
    is dropped.
    """
    _sniff(path, read_bytes(path, MeshReadError, head=SNIFF_BYTES))
    data = read_bytes(path, MeshReadError).removeprefix(_BOM)
    if not data.strip():
        raise MeshReadError(f"{path}: the file is empty; write a mesh into it or pick another")
    suffix = path.suffix.lower()
    try:
        return parse(path, data)
    except MeshReadError:
        raise
    except (ValueError, TypeError, IndexError, OverflowError, struct.error) as exc:
        raise MeshReadError(
            f"{path}: cannot parse this {suffix} file ({type(exc).__name__}: {exc}); "
            f"check that it is a valid {suffix[1:].upper()} file, or re-export it"
        ) from exc


def _checked(path: Path, poly: _Polygons) -> tuple[_Polygons, tuple[np.ndarray, int]]:
    """The polygons and their triangulation (:func:`_triangulate`, which checks them)."""
    return poly, _triangulate(path, poly)


#: Formats :func:`write_mesh` writes besides :data:`SUFFIXES` (through meshio or PyVista).
VTK_SUFFIXES = (".vtu", ".vtp")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.-]*")


def write_mesh(
    path: str | os.PathLike,
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    *,
    vertex_data: Mapping[str, npt.ArrayLike] | None = None,
    face_data: Mapping[str, npt.ArrayLike] | None = None,
    comments: tuple[str, ...] = (),
) -> None:
    """Write a triangle mesh as OBJ, OFF (ascii), PLY (binary little endian) or VTK.

    The file is written whole or not at all (:func:`fvf.io.atomic.atomic_path`).

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its suffix (case-insensitive) selects the format: ``.obj``, ``.off``,
        ``.ply``, or VTK XML for ParaView: ``.vtu`` (through meshio, else PyVista) or
        ``.vtp`` (through PyVista); both are optional (``pip install 'fvf[vtk]'``). Text
        formats print coordinates with ``%.17g``, so reading the file back with
        :func:`read_mesh` gives exactly the same arrays.
    vertices : array_like of float, shape (n, 3)
        Vertex positions.
    faces : array_like of int, shape (m, 3)
        0-based vertex indices of the triangles, in ``[0, n)``.
    vertex_data, face_data : dict of str to array_like, optional
        Per-vertex (n,) / (n, 3) and per-face (m,) / (m, 3) arrays (functions, fields,
        marks), PLY and VTK only. In a PLY a scalar array ``p`` is the property ``p`` and a
        3-vector array the three properties ``px py pz``, exactly what
        :func:`read_ply_properties` and :func:`fvf.io.read_data` read back (a face triple
        ``vx vy vz`` is the field ``v``). In VTK they are point and cell data of those
        names (3-vectors as vectors). Names: letters, digits, ``_ . -``.
    comments : tuple of str
        PLY ``comment`` lines (provenance).

    Raises
    ------
    fvf.errors.FvfError
        The suffix is unsupported, or data were given for OBJ/OFF (which cannot hold
        them), or a name is not usable.
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
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES + VTK_SUFFIXES:
        raise FvfError(
            f"{path}: cannot write {path.suffix!r} files; use one of {SUFFIXES + VTK_SUFFIXES}"
        )
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces)
    if V.ndim != 2 or V.shape[1] != 3:
        raise MeshShapeError(f"vertices must have shape (n, 3), got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or not (F.size == 0 or np.issubdtype(F.dtype, np.integer)):
        raise MeshShapeError(f"faces must be integers of shape (m, 3), got {F.dtype} {F.shape}")
    F = F.astype(np.int64)
    if F.size and (F.min() < 0 or F.max() >= len(V)):
        raise MeshIndexError(f"faces refer to vertices outside [0, {len(V)}); fix the faces")
    vdata = _checked_data(vertex_data, len(V), "vertex_data", ("x", "y", "z"))
    fdata = _checked_data(face_data, len(F), "face_data", ("vertex_indices",))
    if (vdata or fdata) and suffix in (".obj", ".off"):
        raise FvfError(
            f"{path}: {suffix[1:].upper()} files cannot hold vertex or face data; write "
            ".ply (read back by fvf.io.read_data) or .vtp/.vtu (ParaView)"
        )
    if suffix == ".ply":
        data = _ply_bytes(V, F, vdata, fdata, comments)
        with atomic_path(path) as tmp:
            tmp.write_bytes(data)
        return
    if suffix in VTK_SUFFIXES:
        _write_vtk(path, V, F, vdata, fdata)
        return
    n, m = len(V), len(F)
    if suffix == ".obj":
        v_text = ("v %.17g %.17g %.17g\n" * n) % tuple(V.ravel().tolist())
        f_text = ("f %d %d %d\n" * m) % tuple((F + 1).ravel().tolist())
        text = f"# written by fvf: {n} vertices, {m} faces\n{v_text}{f_text}"
    else:
        v_text = ("%.17g %.17g %.17g\n" * n) % tuple(V.ravel().tolist())
        f_text = ("3 %d %d %d\n" * m) % tuple(F.ravel().tolist())
        text = f"OFF\n{n} {m} 0\n{v_text}{f_text}"
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="ascii")


def _checked_data(
    data: Mapping[str, npt.ArrayLike] | None, rows: int, what: str, reserved: tuple[str, ...]
) -> dict[str, np.ndarray]:
    """Each array as float64 (rows,) or (rows, 3), names checked."""
    from ..errors import FieldShapeError

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


def _ply_bytes(
    V: np.ndarray, F: np.ndarray, vdata: dict, fdata: dict, comments: tuple[str, ...]
) -> bytes:
    """Binary little-endian PLY with double properties after x y z / the index list."""

    def columns(data: dict) -> list[tuple[str, np.ndarray]]:
        out = []
        for name, a in data.items():
            out += (
                [(name, a)] if a.ndim == 1 else [(name + c, a[:, i]) for i, c in enumerate("xyz")]
            )
        return out

    vcols = [("x", V[:, 0]), ("y", V[:, 1]), ("z", V[:, 2]), *columns(vdata)]
    fcols = columns(fdata)
    lines = ["ply", "format binary_little_endian 1.0", "comment written by fvf"]
    lines += [f"comment {' '.join(c.split())}" for c in comments]
    lines += [f"element vertex {len(V)}", *[f"property double {n}" for n, _ in vcols]]
    lines += [f"element face {len(F)}", "property list uchar int vertex_indices"]
    lines += [f"property double {n}" for n, _ in fcols]
    header = "\n".join([*lines, "end_header"]) + "\n"
    vrec = np.empty(len(V), dtype=[(n, "<f8") for n, _ in vcols])
    for n, a in vcols:
        vrec[n] = a
    frec = np.empty(
        len(F), dtype=[("k", "u1"), ("i", "<i4", (3,))] + [(n, "<f8") for n, _ in fcols]
    )
    frec["k"], frec["i"] = 3, F
    for n, a in fcols:
        frec[n] = a
    return header.encode("ascii") + vrec.tobytes() + frec.tobytes()


def _write_vtk(path: Path, V: np.ndarray, F: np.ndarray, vdata: dict, fdata: dict) -> None:
    """.vtu through meshio (else PyVista), .vtp through PyVista."""
    import importlib.util

    from ..errors import MissingExtraError

    suffix = path.suffix.lower()
    have_meshio = importlib.util.find_spec("meshio") is not None
    have_pyvista = importlib.util.find_spec("pyvista") is not None
    if suffix == ".vtu" and have_meshio:
        import meshio

        mesh = meshio.Mesh(
            V,
            [("triangle", F)],
            point_data=dict(vdata),
            cell_data={k: [a] for k, a in fdata.items()},
        )
        with atomic_path(path) as tmp:
            meshio.write(tmp, mesh, file_format="vtu")
        return
    if not have_pyvista:
        need = "meshio or PyVista" if suffix == ".vtu" else "PyVista"
        raise MissingExtraError(
            f"{path}: writing {suffix} files needs {need}: pip install 'fvf[vtk]'"
        )
    import pyvista

    cells = np.column_stack([np.full(len(F), 3), F]).ravel()
    poly = pyvista.PolyData(V, cells)
    for k, a in vdata.items():
        poly.point_data[k] = a
    for k, a in fdata.items():
        poly.cell_data[k] = a
    grid = poly if suffix == ".vtp" else poly.cast_to_unstructured_grid()
    with atomic_path(path) as tmp:
        grid.save(str(tmp), binary=True)


def read_quad_mesh(
    path: str | os.PathLike,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Read a pure-quad mesh (OBJ, OFF or PLY): vertices float64 (n, 3), quads int64 (q, 4).

    Raises :class:`fvf.errors.MeshReadError` when a face does not have 4 vertices (and
    for every failure of :func:`read_mesh`).
    """
    path = Path(path)
    reader = _READERS.get(path.suffix.lower())
    if reader is None:
        raise MeshReadError(f"{path}: unsupported mesh file suffix {path.suffix!r}")
    poly, _ = _parsed(path, lambda p, data: _checked(p, reader(p, data)))
    bad = np.flatnonzero(poly.counts != 4)
    if bad.size:
        raise MeshReadError(
            f"{path}: {poly.where(int(bad[0]))}: face has {poly.counts[bad[0]]} vertices "
            f"({bad.size} non-quads in all); read_quad_mesh reads pure-quad meshes only "
            "(use read_mesh for triangles and mixed polygons)"
        )
    return np.ascontiguousarray(poly.vertices, dtype=np.float64), poly.flat.reshape(-1, 4)


def write_quad_mesh(path: str | os.PathLike, vertices: npt.ArrayLike, quads: npt.ArrayLike) -> None:
    """Write a quad mesh as OBJ or OFF text (17 significant digits), atomically.

    Parameters
    ----------
    path : str or os.PathLike
        ``.obj`` or ``.off``; written through :func:`fvf.io.atomic.atomic_path`.
    vertices : array_like (n, 3) float
    quads : array_like (q, 4) int
        0-based vertex indices.
    """
    from .atomic import atomic_path

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".obj", ".off"):
        raise FvfError(f"{path}: quad meshes are written as .obj or .off; got {path.suffix!r}")
    V = np.asarray(vertices, dtype=np.float64)
    Q = np.asarray(quads)
    if V.ndim != 2 or V.shape[1] != 3:
        raise MeshShapeError(f"vertices must have shape (n, 3), got {V.shape}")
    if Q.ndim != 2 or Q.shape[1] != 4 or not (Q.size == 0 or np.issubdtype(Q.dtype, np.integer)):
        raise MeshShapeError(f"quads must be integers of shape (q, 4), got {Q.dtype} {Q.shape}")
    Q = Q.astype(np.int64)
    if Q.size and (Q.min() < 0 or Q.max() >= len(V)):
        raise MeshIndexError(f"quads refer to vertices outside [0, {len(V)}); fix the quads")
    n, q = len(V), len(Q)
    if suffix == ".obj":
        v_text = ("v %.17g %.17g %.17g\n" * n) % tuple(V.ravel().tolist())
        f_text = ("f %d %d %d %d\n" * q) % tuple((Q + 1).ravel().tolist())
        text = f"# written by fvf: {n} vertices, {q} quads\n{v_text}{f_text}"
    else:
        v_text = ("%.17g %.17g %.17g\n" * n) % tuple(V.ravel().tolist())
        f_text = ("4 %d %d %d %d\n" * q) % tuple(Q.ravel().tolist())
        text = f"OFF\n{n} {q} 0\n{v_text}{f_text}"
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="ascii")


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
    from .atomic import atomic_path

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
    vt, inv = np.unique(T.reshape(-1, 2), axis=0, return_inverse=True)
    inv = inv.reshape(-1, 3)
    n, m = len(V), len(F)
    v_text = ("v %.17g %.17g %.17g\n" * n) % tuple(V.ravel().tolist())
    t_text = ("vt %.17g %.17g\n" * len(vt)) % tuple(vt.ravel().tolist())
    pairs = np.stack([F + 1, inv + 1], axis=2).reshape(-1).tolist()
    f_text = ("f %d/%d %d/%d %d/%d\n" * m) % tuple(pairs)
    with atomic_path(path) as tmp:
        tmp.write_text(f"# written by fvf: {n} vertices, {m} faces\n{v_text}{t_text}{f_text}")


def _triangulate(path: Path, p: _Polygons) -> tuple[np.ndarray, int]:
    """Check the polygons of a file and fan-triangulate them: ``(faces (m, 3), #split)``."""
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
    if np.all(counts == 3):
        return flat.reshape(-1, 3), 0
    ntri = counts - 2
    poly = np.repeat(np.arange(counts.size), ntri)
    first = (np.cumsum(counts) - counts)[poly]
    j = first + np.arange(ntri.sum()) - np.repeat(np.cumsum(ntri) - ntri, ntri) + 1
    faces = np.column_stack([flat[first], flat[j], flat[j + 1]])
    return faces, int(np.count_nonzero(counts > 3))


# ---------------------------------------------------------------- text helpers
def _statement_tokens(lines: list[str], at: list[int], key: str) -> tuple[list[str], np.ndarray]:
    """Tokens of the OBJ statements ``lines[at]``, without the ``key`` and comments.

    Returns the concatenated tokens and the token count of each line. When all lines have
    one width and no comment, a single join + split does the work: the key then occurs once
    per line, at multiples of the width, so the lines are aligned.
    """
    if not at:
        return [], np.zeros(0, dtype=np.int64)
    chosen = [lines[i] for i in at]
    joined = " ".join(chosen)
    tokens = joined.split()
    width = len(chosen[0].split())
    if (
        "#" not in joined
        and len(tokens) == width * len(at)
        and tokens.count(key) == len(at) == tokens[::width].count(key)
    ):
        del tokens[::width]
        return tokens, np.full(len(at), width - 1, dtype=np.int64)
    return _flatten([_words(line)[1:] for line in chosen])


def _words(line: str) -> list[str]:
    """The whitespace-separated tokens of a line, without its ``#`` comment."""
    return (line.split("#", 1)[0] if "#" in line else line).split()


def _flatten(rows: list[list[str]]) -> tuple[list[str], np.ndarray]:
    """Concatenated tokens of ``rows`` and the number of tokens of each row."""
    return [t for row in rows for t in row], np.fromiter(map(len, rows), np.int64, len(rows))


#: Numbers in text mesh files: C/printf decimal syntax. Python's float() and int() also
#: take underscores ("1_0" is 10), "nan", "inf" and "infinity": not part of these formats.
_REAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_INTEGER = re.compile(r"[+-]?[0-9]+")
_REAL_CHARS = frozenset("0123456789+-.eE")
_INTEGER_CHARS = frozenset("0123456789+-")


def _strict(
    path: Path, tokens: list[str], counts: np.ndarray, lineno: list[int], kind: type, what: str
) -> None:
    """Refuse tokens that Python would convert but the file format does not allow."""
    allowed = _INTEGER_CHARS if kind is np.int64 else _REAL_CHARS
    if set("".join(tokens)) <= allowed:  # only digits, signs, '.', 'e': float()/int() decide
        return
    grammar = _INTEGER if kind is np.int64 else _REAL
    for k, tok in enumerate(tokens):
        if grammar.fullmatch(tok) is None:
            line = lineno[int(np.searchsorted(np.cumsum(counts), k, side="right"))]
            if kind is not np.int64 and tok.lower().lstrip("+-") in ("nan", "inf", "infinity"):
                why = "is not a finite number; vertex positions and values must be finite"
            elif "_" in tok:
                why = "has an underscore, which is not part of numbers in mesh files"
            else:
                need = "an integer" if kind is np.int64 else "a decimal number"
                why = f"is not {need}"
            raise MeshReadError(
                f"{path}: line {line}: {tok!r} in {what} {why}; fix or delete that line"
            )


def _numbers(
    path: Path, tokens: list[str], counts: np.ndarray, lineno: list[int], kind: type, what: str
) -> np.ndarray:
    """``np.array(tokens, kind)``; on failure a MeshReadError naming the line and the token.

    ``counts[i]`` tokens come from the line ``lineno[i]``. Tokens must be numbers in C
    syntax (:func:`_strict`), not merely something ``float()`` accepts.
    """
    _strict(path, tokens, counts, lineno, kind, what)
    try:
        return np.array(tokens, dtype=kind).reshape(len(tokens))
    except (ValueError, OverflowError):
        pass
    for k, tok in enumerate(tokens):
        try:
            np.array([tok], dtype=kind)
        except (ValueError, OverflowError):
            line = lineno[int(np.searchsorted(np.cumsum(counts), k, side="right"))]
            need = "an integer" if kind is np.int64 else "a number"
            raise MeshReadError(
                f"{path}: line {line}: cannot read {tok!r} as {need} in {what}; "
                "fix or delete that line"
            ) from None
    raise MeshReadError(f"{path}: cannot convert the values of {what}; check the file")


def _first3(
    path: Path, tokens: list[str], counts: np.ndarray, lineno: list[int], what: str
) -> np.ndarray:
    """Vertex positions, shape (k, 3), from the first three numbers of each vertex line."""
    short = np.flatnonzero(counts < 3)
    if short.size:
        i = short[0]
        raise MeshReadError(
            f"{path}: line {lineno[i]}: {what} has {counts[i]} coordinates, but needs x y z; "
            "fix or delete that line"
        )
    if np.any(counts != 3):
        starts = (np.cumsum(counts) - counts).tolist()
        tokens = [t for s in starts for t in tokens[s : s + 3]]
        counts = np.full(len(counts), 3, dtype=np.int64)
    return _numbers(path, tokens, counts, lineno, np.float64, what).reshape(-1, 3)


def _text_lines(data: bytes) -> list[str]:
    """The lines of a text file, whatever its line endings (LF, CRLF or CR alone)."""
    text = data.decode("latin-1")
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    return text.split("\n")


# ---------------------------------------------------------------- OBJ
def _read_obj(path: Path, data: bytes) -> _Polygons:
    lines = _text_lines(data)
    heads = [line.lstrip() for line in lines]

    def statements(key: str) -> list[int]:
        return [i for i, s in enumerate(heads) if s[:1] == key and (len(s) == 1 or s[1].isspace())]

    v_at, f_at = statements("v"), statements("f")
    v_line, f_line = [i + 1 for i in v_at], [i + 1 for i in f_at]
    tokens, counts = _statement_tokens(lines, v_at, "v")
    vertices = _first3(path, tokens, counts, v_line, "an OBJ 'v' line")
    tokens, counts = _statement_tokens(lines, f_at, "f")
    if "/" in "".join(tokens):  # v/vt/vn: keep the v
        tokens = [t.partition("/")[0] for t in tokens]
    raw = _numbers(path, tokens, counts, f_line, np.int64, "an OBJ 'f' line (vertex index)")
    v_before = np.searchsorted(np.asarray(v_line, dtype=np.int64), f_line)
    flat = np.where(raw > 0, raw - 1, np.repeat(v_before, counts) + raw)
    flat[raw == 0] = -1
    valid = f"1..{len(vertices)}, or -1..-k for the k-th 'v' line before the face"
    return _Polygons(vertices, counts, flat, raw, lambda i: f"line {f_line[i]}", valid)


# ---------------------------------------------------------------- OFF
def _read_off(path: Path, data: bytes) -> _Polygons:
    lines = _text_lines(data)
    words = [_words(line) for line in lines]
    content = [i for i, w in enumerate(words) if w]
    if not content:
        raise MeshReadError(f"{path}: the file holds only comments; write a mesh into it")
    first = words[content[0]]
    if not re.fullmatch(r"(ST)?C?N?4?OFF", first[0]) or first[1:2] == ["BINARY"]:
        raise MeshReadError(
            f"{path}: line {content[0] + 1}: expected the OFF header (OFF, COFF, NOFF, CNOFF, "
            f"STOFF; ascii only) but found {' '.join(first)[:40]!r}; is it an ascii OFF file?"
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
    v_at, f_at = rest[:nv], rest[nv : nv + nf]
    v_line, f_line = [i + 1 for i in v_at], [i + 1 for i in f_at]
    tokens, counts = _flatten([words[i] for i in v_at])
    if "4" in first[0]:  # 4OFF: homogeneous x y z w, the point (x, y, z) / w
        vertices = _homogeneous(path, tokens, counts, v_line)
    else:
        vertices = _first3(path, tokens, counts, v_line, "an OFF vertex line")
    rows = [words[i] for i in f_at]
    counts = np.fromiter(map(len, rows), np.int64, len(rows))
    what = "an OFF face line (vertex count)"
    k = _numbers(path, [r[0] for r in rows], np.ones_like(counts), f_line, np.int64, what)
    short = np.flatnonzero((k < 0) | (counts < k + 1))
    if short.size:
        i = short[0]
        raise MeshReadError(
            f"{path}: line {f_line[i]}: the face line says it has {k[i]} vertices but lists "
            f"only {counts[i] - 1} values; write 'k i0 ... i(k-1)' on one line"
        )
    idx = [t for r, c in zip(rows, k.tolist(), strict=True) for t in r[1 : 1 + c]]
    flat = _numbers(path, idx, k, f_line, np.int64, "an OFF face line (vertex index)")
    valid = f"0..{len(vertices) - 1}"
    return _Polygons(vertices, k, flat, flat, lambda i: f"line {f_line[i]}", valid)


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
    X = _numbers(path, xyzw, four, lineno, np.float64, what).reshape(-1, 4)
    zero = np.flatnonzero(X[:, 3] == 0)
    if zero.size:
        raise MeshReadError(
            f"{path}: line {lineno[zero[0]]}: w = 0 puts the 4OFF vertex at infinity "
            f"({zero.size} such vertices); fix the coordinates"
        )
    return X[:, :3] / X[:, 3:]


# ---------------------------------------------------------------- PLY
class _Prop(NamedTuple):
    name: str
    code: str  # numpy type code without byte order, e.g. "f4"
    count: str | None  # type: ignore[assignment]  # type code of a list's length, None for scalars


class _Element(NamedTuple):
    name: str
    size: int
    props: list[_Prop]


def _ply_header(path: Path, data: bytes) -> tuple[str, list[_Element], int, int]:
    """Parse the header: ``(format, elements, byte offset of the body, its line number)``.

    Header lines end with LF, CRLF or (old Mac files) CR alone, as the first line does.
    """
    lines: list[str] = []
    pos = 0
    eol = b"\r" if data[3:4] == b"\r" and data[4:5] != b"\n" else b"\n"
    while not lines or lines[-1] != "end_header":
        nl = data.find(eol, pos)
        if nl < 0:
            raise MeshReadError(
                f"{path}: the PLY header has no 'end_header' line; the file is truncated or "
                "not a PLY file"
            )
        lines.append(data[pos:nl].decode("latin-1").strip())
        pos = nl + 1
        if lines[0] != "ply":
            raise MeshReadError(f"{path}: line 1: a PLY file starts with 'ply', not {lines[0]!r}")
    fmt, elements = None, []
    for ln, line in enumerate(lines[1:-1], 2):
        w = line.split()
        kind = w[0] if w else "comment"
        if kind in ("comment", "obj_info"):
            continue
        if kind == "format" and len(w) == 3 and w[1] in _PLY_FORMATS:
            fmt = w[1]
        elif kind == "element" and len(w) == 3 and w[2].isascii() and w[2].isdigit():
            elements.append(_Element(w[1], int(w[2]), []))
        elif kind == "property" and elements and len(w) == 3 and w[1] in _PLY_TYPES:
            elements[-1].props.append(_Prop(w[2], _PLY_TYPES[w[1]], None))
        elif (kind == "property" and elements and len(w) == 5 and w[1] == "list"
              and _PLY_TYPES.get(w[2], "f")[0] in "iu" and w[3] in _PLY_TYPES):  # fmt: skip
            elements[-1].props.append(_Prop(w[4], _PLY_TYPES[w[3]], _PLY_TYPES[w[2]]))
        else:
            raise MeshReadError(
                f"{path}: line {ln}: cannot understand the PLY header line {line[:60]!r}; "
                f"expected 'format <{'|'.join(_PLY_FORMATS)}> 1.0', 'element <name> <count>' "
                "or 'property [list <count type>] <type> <name>' with types "
                f"{', '.join(_PLY_TYPES)}"
            )
    if fmt is None:
        raise MeshReadError(f"{path}: the PLY header has no 'format' line; add one")
    return fmt, elements, pos, len(lines) + 1


def _read_ply(path: Path, data: bytes) -> _Polygons:
    values, where, face_list = _parse_ply(path, data)
    vertices = np.column_stack([values["vertex"][c] for c in "xyz"]).astype(np.float64)
    counts, flat = values["face"][face_list]
    return _Polygons(vertices, counts, flat, flat, where, f"0..{len(vertices) - 1}")


def _parse_ply(path: Path, data: bytes) -> tuple[dict, Callable[[int], str], str]:
    """Check and parse a PLY file: ``({element: {property: values}}, where, face list name)``.

    Scalar properties are 1-D arrays; the face index list is ``(counts, flat)``.
    """
    fmt, elements, pos, line0 = _ply_header(path, data)
    byname: dict[str, _Element] = {}
    for el in elements:
        byname.setdefault(el.name, el)
    if "vertex" not in byname:
        raise MeshReadError(f"{path}: the PLY header declares no 'vertex' element; add one")
    xyz = {p.name: p for p in byname["vertex"].props if p.count is None}
    if not {"x", "y", "z"} <= set(xyz):
        raise MeshReadError(
            f"{path}: the PLY 'vertex' element needs scalar properties x, y and z; "
            f"it has {[p.name for p in byname['vertex'].props]}"
        )
    face = byname.get("face")
    lists = [p.name for p in face.props if p.count and p.name in _FACE_LISTS] if face else []
    if not lists:
        raise MeshReadError(
            f"{path}: the PLY file has no 'face' element with a 'vertex_indices' (or "
            "'vertex_index') list property, so it has no faces; read_mesh needs a surface mesh"
        )
    if fmt == "ascii":
        values, where = _ply_ascii(path, data[pos:], elements, line0)
    else:
        values, where = _ply_binary(path, data, pos, elements, _PLY_FORMATS[fmt])
    return values, where, lists[0]


def _ply_ascii(
    path: Path, body: bytes, elements: list[_Element], line0: int
) -> tuple[dict, Callable[[int], str]]:
    """Parse an ascii PLY body: one element record per non-blank line."""
    lines = _text_lines(body)
    at = [i for i, line in enumerate(lines) if line.strip()]
    values: dict[str, dict] = {}
    cursor, face_line = 0, []
    for el in elements:
        chunk = at[cursor : cursor + el.size]
        if len(chunk) < el.size:
            raise MeshReadError(
                f"{path}: the ascii PLY body ends after {len(chunk)} of the {el.size} "
                f"'{el.name}' lines; the file is truncated or the header count is wrong"
            )
        cursor += el.size
        if el.name not in ("vertex", "face") or el.name in values:
            continue
        # every scalar property (read_ply_properties wants them) and the face index list
        keep: dict[str, list[list[str]]] = {
            p.name: []
            for p in el.props
            if p.count is None or (el.name == "face" and p.name in _FACE_LISTS)
        }
        lineno = [i + line0 for i in chunk]
        for i, ln in zip(chunk, lineno, strict=True):
            t, c = lines[i].split(), 0
            for p in el.props:
                if p.count is None:
                    v, c = t[c : c + 1], c + 1
                else:
                    n = int(t[c]) if c < len(t) and re.fullmatch("[0-9]+", t[c]) else -1
                    if n < 0:
                        raise MeshReadError(
                            f"{path}: line {ln}: the list length of '{el.name}' property "
                            f"'{p.name}' must be a non-negative integer, not {t[c : c + 1]}"
                        )
                    v, c = t[c + 1 : c + 1 + n], c + 1 + n
                if p.name in keep:
                    keep[p.name].append(v)
            if c != len(t):
                raise MeshReadError(
                    f"{path}: line {ln}: the '{el.name}' line has {len(t)} values but its "
                    f"header properties describe {c}; fix the line or the header"
                )
        out: dict[str, object] = {}
        for name, rows in keep.items():
            lens = np.fromiter(map(len, rows), np.int64, len(rows))
            is_list = name in _FACE_LISTS and el.name == "face"
            kind = np.int64 if is_list else np.float64
            what = f"the '{el.name}' property '{name}'"
            flat = _numbers(path, [x for v in rows for x in v], lens, lineno, kind, what)
            out[name] = (lens, flat) if is_list else flat
        values[el.name] = out
        if el.name == "face":
            face_line = lineno
    return values, lambda i: f"line {face_line[i]} (face {i})"


def _ply_binary(
    path: Path, data: bytes, pos: int, elements: list[_Element], order: str
) -> tuple[dict, Callable[[int], str]]:
    """Parse a binary PLY body with structured dtypes (Python loop only for mixed lists)."""
    values: dict[str, dict] = {}
    for el in elements:
        out, pos = _binary_element(path, data, pos, el, order)
        values.setdefault(el.name, out)
    return values, lambda i: f"face {i} (0-based) of the binary PLY"


def _binary_element(
    path: Path, data: bytes, pos: int, el: _Element, order: str
) -> tuple[dict, int]:
    """Read the records of one element at byte ``pos``: ``({name: values}, end)``."""
    if el.size == 0 or not el.props:
        empty = np.zeros(0, dtype=np.int64)
        return {p.name: (empty, empty) if p.count else empty for p in el.props}, pos
    # Guess that every record has the list lengths of the first one; check afterwards.
    fields: list[tuple] = []
    at = pos
    for i, p in enumerate(el.props):
        if p.count is None:
            fields.append((f"s{i}", order + p.code))
            at += int(p.code[1])
            continue
        if at + int(p.count[1]) > len(data):
            break
        k = int(np.frombuffer(data, order + p.count, 1, at)[0])
        if k <= 0 or at + k * int(p.code[1]) > len(data):
            break
        fields += [(f"c{i}", order + p.count), (f"l{i}", order + p.code, (k,))]
        at += int(p.count[1]) + k * int(p.code[1])
    else:
        dtype = np.dtype(fields)
        if pos + dtype.itemsize * el.size <= len(data):
            rec = np.frombuffer(data, dtype, el.size, pos)
            same = [
                np.all(rec[f"c{i}"] == rec[f"c{i}"][0]) for i, p in enumerate(el.props) if p.count
            ]
            if all(same):
                out: dict[str, object] = {}
                for i, p in enumerate(el.props):
                    if p.count is None:
                        out[p.name] = rec[f"s{i}"]
                    else:
                        lst = rec[f"l{i}"]
                        counts = np.full(el.size, lst.shape[1], dtype=np.int64)
                        out[p.name] = (counts, lst.astype(np.int64).reshape(-1))
                return out, pos + dtype.itemsize * el.size
    return _binary_element_slow(path, data, pos, el, order)


def _binary_element_slow(
    path: Path, data: bytes, pos: int, el: _Element, order: str
) -> tuple[dict, int]:
    """Find each record's property offsets in a loop, then gather the values with numpy.

    For lists whose lengths vary (mixed polygons), and to report truncated files.
    """
    end = len(data)
    starts: list[list[int]] = [[] for _ in el.props]
    lengths: list[list[int]] = [[] for _ in el.props]
    steps = [
        (starts[j], lengths[j], int(p.code[1]), p.count and struct.Struct(order + _STRUCT[p.count]))
        for j, p in enumerate(el.props)
    ]
    for r in range(el.size):
        for at, length, size, count in steps:
            at.append(pos)
            if not count:
                pos += size
                continue
            k = count.unpack_from(data, pos)[0] if pos + count.size <= end else 0
            if k < 0:
                raise MeshReadError(
                    f"{path}: binary PLY element '{el.name}' record {r}: a list has negative "
                    f"length {k}; the file is corrupt, re-export it"
                )
            length.append(k)
            pos += count.size + k * size
        if pos > end:
            raise MeshReadError(
                f"{path}: binary PLY ends early: element '{el.name}' record {r} of {el.size} "
                f"needs {pos} bytes, but the file has {end}; the file is truncated or the "
                "header's counts are wrong: re-export the mesh"
            )
    raw, out = np.frombuffer(data, np.uint8), {}
    for p, at_list, k_list in zip(el.props, starts, lengths, strict=True):
        idx = np.asarray(at_list, dtype=np.int64)
        k = np.asarray(k_list, dtype=np.int64)
        if p.count:
            nth = np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k)
            idx = np.repeat(idx + int(p.count[1]), k) + nth * int(p.code[1])
        values = raw[idx[:, None] + np.arange(int(p.code[1]))].view(order + p.code).ravel()
        out[p.name] = (k, values.astype(np.int64)) if p.count else values
    return out, pos


_READERS: dict[str, Callable[[Path, bytes], _Polygons]] = {
    ".obj": _read_obj,
    ".off": _read_off,
    ".ply": _read_ply,
}
