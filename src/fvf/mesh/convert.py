"""Meshes from other libraries: :func:`as_mesh`, and the :func:`takes_mesh` entrance.

Every public function of fvf that takes a mesh accepts, besides a :class:`TriMesh`, a
``(vertices, faces)`` pair, a mesh file path and the mesh objects of trimesh, meshio,
PyVista, pyFM and Open3D (:data:`MeshLike`): its entrance converts them with
:func:`as_mesh` (the :func:`takes_mesh` decorator, one line above each such function,
``docs/architecture.md``). No library is imported to recognise its objects: they are read
by their attributes.

Paths are read by the file layer above this one: :mod:`fvf.io` registers its reader here
(:func:`register_path_reader`) when it is imported, which ``import fvf`` does; this module
never imports :mod:`fvf.io`.

A foreign mesh is converted once and the :class:`TriMesh` remembered (by the object's
identity, weakly, while its arrays equal the TriMesh's copies), so calling several fvf
functions on one trimesh or PyVista object does not validate it again each time, and
editing the object's arrays (in place or not) gives a new TriMesh.
"""

from __future__ import annotations

import functools
import inspect
import os
import warnings
import weakref
from collections.abc import Callable
from typing import Any, Concatenate, ParamSpec, TypeVar, Union, overload

import numpy as np
import numpy.typing as npt

from ..errors import MeshShapeError, PolygonTriangulatedWarning
from .trimesh import TriMesh

__all__ = [
    "as_mesh",
    "takes_mesh",
    "mesh_arrays",
    "input_arrays",
    "MeshLike",
    "register_path_reader",
]

#: What a function taking a mesh accepts: a :class:`TriMesh`, a ``(vertices, faces)``
#: pair of array_like (n, 3) float and (m, 3) int, a mesh file path (str or
#: ``os.PathLike``; OBJ, OFF, PLY, STL), or a mesh object of trimesh, meshio, PyVista,
#: pyFM or Open3D (typed ``Any``: fvf imports none of them). See :func:`as_mesh`.
MeshLike = Union[  # noqa: UP007  (a runtime alias: ``X | Any`` needs Python 3.11)
    TriMesh,
    tuple[npt.ArrayLike, npt.ArrayLike],
    list,
    str,
    os.PathLike,
    Any,
]

P = ParamSpec("P")
R = TypeVar("R")
S = TypeVar("S")

_HOW = (
    "pass a fvf.TriMesh, a (vertices (n, 3), faces (m, 3)) pair, a mesh file path "
    "(OBJ, OFF, PLY, STL), or a mesh of trimesh "
    "(.vertices/.faces), meshio (.points, triangle cells), PyVista (PolyData), pyFM "
    "(.vertlist/.facelist) or Open3D (.vertices/.triangles); for anything else build "
    "fvf.TriMesh(V, F) from its vertex and face arrays"
)

#: ``id(obj) -> (weak reference to obj, TriMesh)``: keyed by
#: identity, so objects that are not hashable (PyVista's, which define ``==``) are
#: remembered too; an entry goes when its object does.
_MEMO: dict[int, tuple[weakref.ref, TriMesh]] = {}


def _fan(counts: np.ndarray, flat: np.ndarray, what: str) -> np.ndarray:
    """Faces (m, 3) from polygons given as counts (k,) and a flat index list: each
    polygon (v0, ..., vj) becomes the fan (v0, vi, vi+1), with one warning."""
    counts = np.asarray(counts, dtype=np.int64)
    flat = np.asarray(flat, dtype=np.int64)
    if counts.size == 0:
        return np.zeros((0, 3), dtype=np.int64)
    if (counts < 3).any():
        raise MeshShapeError(
            f"{what} has cells with fewer than 3 vertices (points or lines); keep only its "
            "polygons (e.g. PyVista: mesh.extract_surface().triangulate())"
        )
    if (counts == 3).all():
        return flat.reshape(-1, 3)
    ntri = counts - 2
    first = np.repeat(np.cumsum(counts) - counts, ntri)
    j = first + np.arange(ntri.sum()) - np.repeat(np.cumsum(ntri) - ntri, ntri) + 1
    warnings.warn(
        f"{what}: fan-triangulated {int((counts > 3).sum())} polygons with more than 3 "
        f"vertices into {int(ntri.sum())} triangles in all",
        PolygonTriangulatedWarning,
        stacklevel=3,
    )
    return np.column_stack([flat[first], flat[j], flat[j + 1]])


def _points(P: Any, what: str) -> np.ndarray:
    P = np.asarray(P)
    if P.ndim == 2 and P.shape[1] == 2:  # planar meshes: z = 0
        P = np.column_stack([P, np.zeros(len(P), dtype=P.dtype)])
    return P


def _meshio(obj: Any) -> tuple[np.ndarray, np.ndarray]:
    tris, polys, other = [], [], []
    for block in obj.cells:
        kind, data = getattr(block, "type", None), np.asarray(getattr(block, "data", []))
        if kind == "triangle":
            tris.append(data.reshape(-1, 3))
        elif kind in ("quad", "polygon") or (kind or "").startswith("polygon"):
            polys.append(data)
        else:
            other.append(kind)
    if other and not (tris or polys):
        raise MeshShapeError(
            f"the meshio mesh has no surface cells (cells: {sorted(map(str, set(other)))}); "
            "fvf needs a triangle surface: extract the boundary surface first"
        )
    faces = list(tris)
    for data in polys:
        counts = np.full(len(data), data.shape[1])
        faces.append(_fan(counts, data.ravel(), "the meshio mesh"))
    F = np.concatenate(faces) if faces else np.zeros((0, 3), dtype=np.int64)
    return _points(obj.points, "meshio"), F


def _pyvista(obj: Any) -> tuple[np.ndarray, np.ndarray]:
    if not hasattr(obj, "faces"):
        raise TypeError(
            f"as_mesh: a PyVista {type(obj).__name__} is not a surface; use "
            "mesh.extract_surface().triangulate() and pass that PolyData"
        )
    if getattr(obj, "n_strips", 0) and hasattr(obj, "triangulate"):
        obj = obj.triangulate()  # triangle strips are not in .faces: as triangles
    if getattr(obj, "is_all_triangles", False) and hasattr(obj, "regular_faces"):
        triangles = np.asarray(obj.regular_faces)  # PyVista >= 0.43: a view, no copy
        if triangles.size:
            return np.asarray(obj.points), triangles
    faces = np.asarray(obj.faces, dtype=np.int64)
    counts, flat, at = [], [], 0
    if faces.size and getattr(obj, "is_all_triangles", False):
        return np.asarray(obj.points), faces.reshape(-1, 4)[:, 1:]
    while at < faces.size:  # mixed polygons: [k, i0, ..., ik-1, k', ...]
        k = int(faces[at])
        counts.append(k)
        flat.append(faces[at + 1 : at + 1 + k])
        at += 1 + k
    flat_all = np.concatenate(flat) if flat else np.zeros(0, dtype=np.int64)
    return np.asarray(obj.points), _fan(np.array(counts), flat_all, "the PyVista mesh")


def mesh_arrays(obj: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """(vertices, faces) of a foreign mesh object, or None if ``obj`` is not one."""
    module = type(obj).__module__ or ""
    if isinstance(obj, tuple | list) and len(obj) == 2:
        return obj[0], obj[1]
    if module.startswith("meshio"):
        return _meshio(obj)
    if module.startswith("pyvista"):
        return _pyvista(obj)
    if module.startswith("open3d") and hasattr(obj, "triangles"):
        return np.asarray(obj.vertices), np.asarray(obj.triangles)
    if hasattr(obj, "vertices") and hasattr(obj, "faces"):  # trimesh, pyFM, RepairResult
        return np.asarray(obj.vertices), np.asarray(obj.faces)
    if hasattr(obj, "vertlist") and hasattr(obj, "facelist"):  # older pyFM
        return np.asarray(obj.vertlist), np.asarray(obj.facelist)
    if hasattr(obj, "points") and hasattr(obj, "cells"):  # meshio-like
        return _meshio(obj)
    return None


def _unchanged(V: np.ndarray, F: np.ndarray, mesh: TriMesh) -> bool:
    """Whether ``V``, ``F`` hold exactly the values of ``mesh``'s arrays (its own copies,
    so an edit of the foreign object's arrays in place is seen)."""
    return (
        V.shape == mesh.vertices.shape
        and F.shape == mesh.faces.shape
        and bool(np.array_equal(V, mesh.vertices))
        and bool(np.array_equal(F, mesh.faces))
    )


#: The reader of mesh file paths, ``reader(path) -> (vertices, faces)``, installed by
#: :mod:`fvf.io` (:func:`register_path_reader`).
_PATH_READER: list[Callable[[str | os.PathLike], tuple[np.ndarray, np.ndarray]]] = []


def register_path_reader(
    reader: Callable[[str | os.PathLike], tuple[np.ndarray, np.ndarray]],
) -> None:
    """Let :func:`as_mesh` (and so every function taking a mesh) read mesh file paths.

    :mod:`fvf.io` calls it on import with :func:`fvf.io.read_mesh`: the file layer sits
    above the mesh layer, so the mesh layer is handed its reader instead of importing it
    (``docs/architecture.md``). A later call replaces the reader.

    Parameters
    ----------
    reader : callable
        ``reader(path) -> (vertices (n, 3) float64, faces (m, 3) int64)``; raises
        ``OSError`` or :class:`fvf.errors.MeshReadError` for a file it cannot read.
    """
    _PATH_READER[:] = [reader]


def _read_path(path: str | os.PathLike) -> TriMesh:
    """The TriMesh of a mesh file; an invalid mesh's error names the file."""
    from ..errors import MeshError

    if not _PATH_READER:
        raise TypeError(
            f"as_mesh: got the path {os.fspath(path)!r}, but no mesh file reader is "
            "registered: import fvf (or fvf.io) first, or pass the arrays"
        )
    V, F = _PATH_READER[0](path)
    try:
        return TriMesh(V, F)
    except MeshError as exc:
        raise type(exc)(f"{os.fspath(path)}: {exc}") from exc


def as_mesh(obj: MeshLike, *, repair: bool = False) -> TriMesh:
    """A :class:`TriMesh` from any common mesh representation.

    Parameters
    ----------
    obj : TriMesh, (V, F) pair, path, or a mesh object (:data:`MeshLike`)
        - :class:`TriMesh`: returned as is.
        - ``(vertices, faces)``: array_like (n, 3) float and (m, 3) int (a tuple or list).
        - a mesh file path, ``str`` or ``os.PathLike`` (OBJ, OFF, PLY, STL): read with
          :func:`fvf.io.read_mesh` each time it is passed (the file may change).
        - trimesh ``Trimesh`` (``.vertices``, ``.faces``); also anything else with those
          two attributes, e.g. :class:`fvf.RepairResult`.
        - meshio ``Mesh`` (``.points``, triangle cells; quads and polygons are
          fan-triangulated with a :class:`~fvf.errors.PolygonTriangulatedWarning`;
          2-D points get z = 0).
        - PyVista ``PolyData`` (``.points``, the flat ``.faces`` array).
        - pyFM ``TriMesh`` (``.vertlist``, ``.facelist``).
        - Open3D ``TriangleMesh`` (``.vertices``, ``.triangles``).
    repair : bool
        What to do with arrays that are not a valid :class:`TriMesh`. ``False``
        (default): raise the TriMesh's error, which names the fix. ``True``: repair them
        as :func:`fvf.match` does, whatever form they came in (:func:`input_arrays`
        then :func:`fvf.mesh.prepare_mesh`): :func:`fvf.repair_mesh`'s default steps
        with non-manifold edges cut (duplicate vertices welded, degenerate, duplicate
        faces and unreferenced vertices removed, faces oriented), and the one large piece
        kept (pieces of at most 1 % of the vertices each, cut off by the repair or
        components of the input, are dropped; the latter with a
        :class:`~fvf.errors.SmallComponentWarning`).
        The vertices may then be renumbered: :func:`fvf.mesh.prepare_mesh` gives the maps
        to the input vertices. A mesh that is already valid is returned as without
        ``repair``.

    Returns
    -------
    TriMesh
        Validated (see :class:`TriMesh` for the errors). A foreign object is converted
        once and remembered while its arrays are unchanged.

    Raises
    ------
    TypeError
        ``obj`` is none of these; the message names its type and how to convert it.
    fvf.errors.MeshError
        The arrays are not a valid mesh (for a file, the message starts with its path).
    OSError, fvf.errors.MeshReadError
        A path that cannot be read as a mesh file.
    fvf.errors.DisconnectedMeshError
        With ``repair=True``: arrays that are not valid and hold several shapes.

    Examples
    --------
    >>> import fvf
    >>> ico = fvf.icosphere(1)
    >>> fvf.as_mesh((ico.vertices, ico.faces)).n_faces
    80
    """
    if isinstance(obj, TriMesh):
        return obj
    if repair:
        from ..errors import MeshError
        from .prepared import prepare_mesh

        try:
            return as_mesh(obj)
        except MeshError as exc:
            if not _repairable(exc):
                raise
        return prepare_mesh(*input_arrays(obj), name=_name(obj)).mesh
    if isinstance(obj, str | os.PathLike):
        return _read_path(obj)
    V, F = input_arrays(obj)
    return _remembered(obj, V, F)


def _repairable(exc: Exception) -> bool:
    """Whether ``as_mesh(..., repair=True)`` repairs what raised ``exc`` (the arrays'
    shapes, indices and coordinates are never guessed)."""
    from ..errors import MeshIndexError, MeshReadError, MeshShapeError, NonFiniteError

    return not isinstance(exc, MeshShapeError | MeshIndexError | NonFiniteError | MeshReadError)


def _name(obj: Any) -> str:
    """How messages name the mesh ``obj``: its path, else "mesh"."""
    return os.fspath(obj) if isinstance(obj, str | os.PathLike) else "mesh"


def input_arrays(obj: MeshLike) -> tuple[np.ndarray, np.ndarray]:
    """The vertex and face arrays of any :data:`MeshLike`, as given, not validated.

    The one reading of every form a mesh comes in, shared by :func:`as_mesh` and the
    functions that repair their input (:func:`fvf.match` through
    :func:`fvf.spectral.as_prepared_mesh`), so a form never changes what they do.

    Returns
    -------
    vertices : numpy.ndarray, shape (n, 3) as given
    faces : numpy.ndarray, shape (m, 3) as given

    Raises
    ------
    TypeError
        ``obj`` is not a mesh (as :func:`as_mesh`).
    OSError, fvf.errors.MeshReadError
        A path that cannot be read as a mesh file.
    """
    if isinstance(obj, TriMesh):
        return obj.vertices, obj.faces
    if isinstance(obj, str | os.PathLike):
        if not _PATH_READER:
            _read_path(obj)  # raises the TypeError naming the fix
        return _PATH_READER[0](obj)
    arrays = mesh_arrays(obj)
    if arrays is None:
        raise TypeError(f"as_mesh: got {type(obj).__module__}.{type(obj).__qualname__}; {_HOW}")
    V, F = (np.asarray(a) for a in arrays)
    return V, F


def _remembered(obj: Any, V: np.ndarray, F: np.ndarray) -> TriMesh:
    """``TriMesh(V, F)`` of the foreign object ``obj``, converted once while its arrays
    are unchanged (by identity, and the arrays compared with the TriMesh's copies; objects
    that cannot be weakly referenced, tuples and lists, are converted at each call)."""
    key = id(obj)

    def forget(_: weakref.ref) -> None:  # the object is gone: so is its entry
        _MEMO.pop(key, None)

    try:
        ref = weakref.ref(obj, forget)
    except TypeError:  # not weak-referenceable (tuples, lists)
        return TriMesh(V, F)
    memo = _MEMO.get(key)
    if memo is not None and memo[0]() is obj and _unchanged(V, F, memo[1]):
        return memo[1]
    mesh = TriMesh(V, F)
    _MEMO[key] = (ref, mesh)
    return mesh


@overload
def takes_mesh(
    fn: Callable[Concatenate[TriMesh, P], R],
) -> Callable[Concatenate[MeshLike, P], R]: ...


@overload
def takes_mesh(
    fn: Callable[Concatenate[S, TriMesh, P], R],
) -> Callable[Concatenate[S, MeshLike, P], R]: ...


def takes_mesh(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Decorator: the argument ``mesh`` of ``fn`` goes through :func:`as_mesh` first.

    One line above each public function (or ``__init__``) that takes a mesh, as its first
    parameter (after ``self``) annotated :class:`TriMesh`; a :class:`TriMesh` passes at
    the cost of one type check. The decorated function's signature, for type checkers and
    ``inspect.signature`` alike, takes ``mesh: MeshLike``.
    """
    signature = inspect.signature(fn)
    position = list(signature.parameters).index("mesh")

    @functools.wraps(fn)
    def entrance(*args, **kwargs):
        if len(args) > position:
            if type(args[position]) is not TriMesh:
                args = (*args[:position], as_mesh(args[position]), *args[position + 1 :])
        elif "mesh" in kwargs and type(kwargs["mesh"]) is not TriMesh:
            kwargs["mesh"] = as_mesh(kwargs["mesh"])
        return fn(*args, **kwargs)

    entrance.__signature__ = signature.replace(  # type: ignore[attr-defined]
        parameters=[
            p.replace(annotation="MeshLike") if name == "mesh" else p
            for name, p in signature.parameters.items()
        ]
    )
    return entrance
