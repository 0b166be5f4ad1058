"""One clean manifold piece of a mesh as a user has it, with index maps both ways.

Spectral methods need a valid :class:`~fvf.TriMesh` of one connected shape, but meshes
come with non-manifold edges and vertices, duplicated faces, stray vertices, or small
pieces glued on at a non-manifold edge (the camel-gallop frames of the correspondence data
have two fans touching at an edge). :func:`prepare_mesh` repairs such arrays with
:func:`~fvf.repair_mesh` (cutting non-manifold edges), keeps the largest connected piece,
and records how every input vertex is represented on the clean mesh, so that a result on
the clean mesh (a vertex map, a function) can be carried back to the vertices the user
passed.

The input must be one shape: faces connected through shared vertices. Pieces that only
the repair cut apart are dropped when small (at most ``max_dropped_fraction`` of the
vertices); their input vertices are represented by the nearest kept vertex in space.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..errors import (
    DisconnectedMeshError,
    MeshError,
    MeshIndexError,
    MeshShapeError,
    NonFiniteError,
)
from ..numerics.summary import html_repr, short_repr
from .repair import DEFAULT_REPAIR_STEPS, repair_mesh
from .trimesh import TriMesh

__all__ = ["PreparedMesh", "prepare_mesh", "MATCH_REPAIR_STEPS"]

#: The repairs :func:`prepare_mesh` applies when the arrays are not a valid TriMesh:
#: the default ones, cutting non-manifold edges instead of only splitting vertices.
MATCH_REPAIR_STEPS = tuple(
    "split_nonmanifold_edges" if s == "split_nonmanifold_vertices" else s
    for s in DEFAULT_REPAIR_STEPS
)


@dataclass(frozen=True, eq=False)
class PreparedMesh:
    """A clean one-piece TriMesh and its correspondence with the input vertices.

    Attributes
    ----------
    mesh : TriMesh
        Valid, connected; n vertices.
    n_input : int
        Number of input vertices.
    input_to_mesh : int64 (n_input,)
        For each input vertex, the mesh vertex that stands for it: itself (or the copy
        that kept its position after a split), or, for a vertex of a dropped piece or an
        unreferenced one, the nearest mesh vertex in space.
    mesh_to_input : int64 (n,)
        For each mesh vertex, the input vertex it is (or is a copy of).
    log : tuple of str
        What was repaired or dropped (empty when the input was already clean).
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    mesh: TriMesh
    n_input: int
    input_to_mesh: np.ndarray
    mesh_to_input: np.ndarray
    log: tuple[str, ...] = ()

    @property
    def changed(self) -> bool:
        """True when the mesh differs from the input arrays."""
        return bool(self.log)

    def to_input(self, values: npt.ArrayLike) -> np.ndarray:
        """Per-vertex values on the mesh (n, ...) -> on the input vertices (n_input, ...)."""
        return np.asarray(values)[self.input_to_mesh]

    def from_input(self, values: npt.ArrayLike) -> np.ndarray:
        """Per-vertex values on the input (n_input, ...) -> on the mesh vertices (n, ...)."""
        return np.asarray(values)[self.mesh_to_input]


def _disconnected(name: str, count: int) -> DisconnectedMeshError:
    return DisconnectedMeshError(
        f"{name} has {count} connected components; matching needs one shape. Fix: match "
        "each component separately (TriMesh.vertex_components labels them)."
    )


def _vertex_components(F: np.ndarray, n: int) -> tuple[int, np.ndarray]:
    """Components of the referenced vertices through faces: (count, label (n,)).

    Unreferenced vertices get labels of their own but are not counted.
    """
    rows = np.repeat(F[:, 0], 2)
    cols = F[:, 1:].ravel()
    A = sp.coo_array((np.ones(rows.size), (rows, cols)), shape=(n, n))
    count, label = connected_components(A, directed=False)
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    # unreferenced vertices are their own components: count only referenced ones
    return int(np.unique(label[used]).size), label


def prepare_mesh(
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    *,
    name: str = "mesh",
    max_dropped_fraction: float = 0.01,
) -> PreparedMesh:
    """Repair arrays into one clean connected TriMesh, keeping maps to the input vertices.

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)
    name : str
        Used in messages (e.g. "mesh_1").
    max_dropped_fraction : float
        Largest fraction of the input vertices that may be dropped with the pieces the
        repair cut off.

    Returns
    -------
    PreparedMesh

    Raises
    ------
    DisconnectedMeshError
        The input has several connected components (several shapes), or the repair split
        it into pieces too large to drop.
    MeshError
        Arrays that no repair fixes (bad shapes, indices out of range, non-finite
        coordinates).
    """
    try:
        mesh = TriMesh(vertices, faces)
    except (MeshShapeError, MeshIndexError, NonFiniteError):
        raise  # no repair guesses coordinates or indices
    except MeshError:
        mesh = None
    if mesh is not None:
        if mesh.n_components > 1:
            raise _disconnected(name, mesh.n_components)
        ident = np.arange(mesh.n_vertices, dtype=np.int64)
        return PreparedMesh(mesh, mesh.n_vertices, ident, ident)
    V = np.asarray(vertices, dtype=float)
    F = np.asarray(faces, dtype=np.int64)
    n_in, _ = _vertex_components(F, V.shape[0])
    if n_in > 1:
        raise _disconnected(name, n_in)
    rep = repair_mesh(V, F, MATCH_REPAIR_STEPS)
    log: list[str] = []
    log.extend(rep.log)
    V2, F2 = rep.vertices, rep.faces
    n2 = V2.shape[0]
    count, label = _vertex_components(F2, n2)
    keep_label = np.bincount(label).argmax()
    keep = label == keep_label
    dropped = n2 - int(keep.sum())
    if dropped > max_dropped_fraction * max(V.shape[0], 1):
        raise DisconnectedMeshError(
            f"repairing {name} ({'; '.join(rep.log)}) split it into {count} pieces; the "
            f"largest has {int(keep.sum())} of {n2} vertices, more than "
            f"{max_dropped_fraction:.0%} would be dropped. Fix: repair the mesh by hand "
            "(fvf.repair_mesh) and pass one connected piece."
        )
    new_index = np.full(n2, -1, dtype=np.int64)
    new_index[keep] = np.arange(int(keep.sum()))
    face_keep = keep[F2[:, 0]]
    mesh = TriMesh(V2[keep], new_index[F2[face_keep]])
    if dropped:
        log.append(
            f"dropped {count - 1} small piece(s) cut off by the repair ({dropped} vertices, "
            f"{int((~face_keep).sum())} faces)"
        )
    mesh_to_input = rep.vertex_origin[keep]
    input_to_mesh = np.full(V.shape[0], -1, dtype=np.int64)
    # the copy that kept an input vertex's index wins; otherwise any kept copy
    input_to_mesh[mesh_to_input[::-1]] = np.arange(mesh.n_vertices)[::-1]
    own = rep.vertex_map >= 0
    own_new = np.where(own, new_index[np.maximum(rep.vertex_map, 0)], -1)
    input_to_mesh = np.where(own_new >= 0, own_new, input_to_mesh)
    missing = np.flatnonzero(input_to_mesh < 0)
    if missing.size:
        _, nearest = cKDTree(mesh.vertices).query(V[missing])
        input_to_mesh[missing] = nearest
        log.append(
            f"{missing.size} input vertices (unreferenced or in dropped pieces) stand for "
            "their nearest kept vertex"
        )
    return PreparedMesh(mesh, V.shape[0], input_to_mesh, mesh_to_input, tuple(log))
