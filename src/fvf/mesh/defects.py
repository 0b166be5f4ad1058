"""Finding what the repairs fix, in raw vertex and face arrays that may be broken.

:mod:`fvf.mesh.repair` removes what these functions find and :mod:`fvf.mesh.diagnostics`
(the report of ``fvf info``) names it; both read the arrays through :func:`raw_arrays`.
The edges of a broken mesh come from the same sorted half-edge pass as a
:class:`~fvf.TriMesh`'s (:mod:`fvf.mesh.halfedges`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..errors import MeshIndexError, MeshShapeError, format_indices
from . import halfedges

__all__ = [
    "raw_arrays",
    "repeats_vertex",
    "zero_area_faces",
    "duplicate_faces",
    "nonmanifold_message",
    "non_orientable_message",
]


def raw_arrays(vertices: npt.ArrayLike, faces: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Check shapes, dtypes and index range; allow faces that repeat a vertex, and m = 0.

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)

    Returns
    -------
    V : float64 (n, 3)
    F : int64 (m, 3)
        May be the caller's own arrays (no copy): the repairs never write into them.

    Raises
    ------
    MeshShapeError
        Ragged input, wrong shapes or dtypes.
    MeshIndexError
        A face index outside ``[0, n)`` (no repair can guess the intended vertex).
    """
    try:
        V = np.asarray(vertices)
        F = np.asarray(faces)
    except ValueError as exc:  # ragged nested lists
        raise MeshShapeError(
            f"vertices and faces must be rectangular arrays ({exc}). Fix: pass (n, 3) "
            "vertices and (m, 3) faces."
        ) from exc
    if V.ndim != 2 or V.shape[1] != 3 or not (V.dtype.kind in "fiu" or V.size == 0):
        raise MeshShapeError(
            f"vertices must be real numbers of shape (n, 3); got {V.dtype} {V.shape}. "
            "Fix: pass one xyz row per vertex."
        )
    if F.ndim != 2 or F.shape[1] != 3 or not (F.dtype.kind in "iu" or F.size == 0):
        raise MeshShapeError(
            f"faces must be integers of shape (m, 3); got {F.dtype} {F.shape}. Fix: "
            "triangulate polygons first and pass faces.astype(np.int64)."
        )
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    out = (F < 0) | (F >= V.shape[0])
    if out.any():
        bad = np.flatnonzero(out.any(axis=1))
        raise MeshIndexError(
            f"faces {format_indices(bad)} refer to vertex indices outside [0, {V.shape[0]}). "
            "No repair can guess the intended vertex: fix the faces (0-based indices)."
        )
    return V, F


def repeats_vertex(F: np.ndarray) -> np.ndarray:
    """Faces that list a vertex twice, bool (m,)."""
    return (F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 2] == F[:, 0])


def zero_area_faces(V: np.ndarray, F: np.ndarray, area_rtol: float) -> np.ndarray:
    """Faces of (numerically) zero area by TriMesh's rule, bool (m,).

    Area <= ``area_rtol`` times the longest edge squared
    (:data:`fvf.mesh.trimesh.DEGENERATE_AREA_RTOL` is the threshold :class:`fvf.TriMesh`
    uses). Faces with non-finite corners are not flagged.
    """
    P = V[F]
    # the test is scale-free: bring each face to unit size by a power of two (exact), so
    # coordinates of 1e300 do not overflow the products, nor those of 1e-300 underflow
    big = np.abs(P).max(axis=(1, 2), initial=0.0)
    ok = (big > 0) & np.isfinite(big)
    scale = np.exp2(np.floor(np.log2(np.where(ok, big, 1.0))))
    P = P / scale[:, None, None]
    e = P[:, [2, 0, 1]] - P[:, [1, 2, 0]]  # edge opposite each corner, (m, 3, 3)
    area = 0.5 * np.linalg.norm(np.cross(e[:, 2], -e[:, 1]), axis=1)
    return area <= area_rtol * np.einsum("tij,tij->ti", e, e).max(axis=1, initial=0.0)


def duplicate_faces(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Faces repeating the vertex set of an earlier face, and whether in the opposite order.

    Returns
    -------
    duplicate : bool (m,)
        True for every face but the first with its vertex set.
    reversed_ : bool (m,)
        True for duplicates whose cyclic order differs from the first face's.
    """
    m = F.shape[0]
    key = np.sort(F, axis=1)
    even = ((F[:, 0] < F[:, 1]).astype(int) + (F[:, 1] < F[:, 2]) + (F[:, 2] < F[:, 0])) == 2
    if m == 0:
        return np.zeros(0, bool), np.zeros(0, bool)
    order = np.lexsort((np.arange(m), key[:, 2], key[:, 1], key[:, 0]))
    ks = key[order]
    new = np.ones(m, dtype=bool)
    new[1:] = (ks[1:] != ks[:-1]).any(axis=1)
    first = order[np.flatnonzero(new)][np.cumsum(new) - 1]  # first face of each one's group
    duplicate = np.zeros(m, dtype=bool)
    duplicate[order] = first != order
    reversed_ = np.zeros(m, dtype=bool)
    reversed_[order] = duplicate[order] & (even[order] != even[first])
    return duplicate, reversed_


def non_orientable_message(bad_faces: np.ndarray, component: np.ndarray) -> str:
    """What is wrong with a non-orientable surface, and that no repair fixes it.

    Parameters
    ----------
    bad_faces : int64 (k,)
        Faces whose two orientations are one sheet
        (:func:`fvf.mesh.halfedges.orientation_sheets`).
    component : int64 (m,)
        The component label of each face (the same function's second result).
    """
    comps = np.unique(component[bad_faces])
    return (
        f"faces {format_indices(bad_faces)} form {comps.size} non-orientable "
        "component(s) (a Moebius strip or Klein bottle): no vertex order makes every "
        "shared edge run in opposite directions. No repair can fix this: cut the "
        "surface open, or remove those faces."
    )


def nonmanifold_message(F: np.ndarray, runs: halfedges.EdgeRuns, bad: np.ndarray) -> str:
    """What is wrong with the edges ``bad`` (in more than two faces) and the repair to call.

    Parameters
    ----------
    F : int64 (m, 3)
    runs : EdgeRuns
        :func:`fvf.mesh.halfedges.sort_halfedges` of ``F``.
    bad : int64 (k,)
        Indices into ``runs.edges`` of the edges in more than two faces.
    """
    faces = halfedges.faces_of_edges(runs, bad)
    dup = np.flatnonzero(duplicate_faces(F)[0])
    hint = (
        f"faces {format_indices(dup)} repeat another face: call fvf.remove_duplicate_faces(V, F) "
        "first"
        if dup.size
        else "call fvf.split_nonmanifold_edges(V, F) to cut the faces apart along them"
    )
    return (
        f"edges {[tuple(map(int, e)) for e in runs.edges[bad[:5]]]} ({bad.size} in all) are "
        f"shared by {int(runs.counts[bad].max())} or more faces (faces "
        f"{format_indices(faces)}). Fix: {hint}."
    )
