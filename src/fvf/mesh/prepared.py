"""One clean manifold piece of a mesh as a user has it, with index maps both ways.

Spectral methods need a valid :class:`~fvf.TriMesh` of one connected shape, but meshes
come with non-manifold edges and vertices, duplicated faces, stray vertices, or small
pieces glued on at a non-manifold edge (the camel-gallop frames of the correspondence data
have two fans touching at an edge). :func:`prepare_mesh` repairs such arrays with
:func:`~fvf.repair_mesh` (cutting non-manifold edges), keeps the largest connected piece,
and records how every input vertex is represented on the clean mesh, so that a result on
the clean mesh (a vertex map, a function) can be carried back to the vertices the user
passed.

The input must be one shape with at most small specks beside it. One rule, in
:func:`_keep_largest`, decides for the input's own connected components (a scan with
floating specks) and for the pieces the repair cut apart: the largest is kept and every
other one is dropped when it holds at most ``max_dropped_fraction`` of the input
vertices (1 %); a larger one means several shapes and raises
:class:`~fvf.errors.DisconnectedMeshError`. The input vertices of a dropped piece (and
unreferenced ones) are represented by the nearest kept vertex in space, so a result
carried back still covers every input vertex. Dropping the input's own components warns
(:class:`~fvf.errors.SmallComponentWarning`); pieces only the repair made are recorded in
the log.
"""

from __future__ import annotations

import warnings
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
    SmallComponentWarning,
    user_stacklevel,
)
from ..numerics.summary import html_repr, short_repr
from .geometry import coincident_vertices
from .repair import DEFAULT_REPAIR_STEPS, remove_unreferenced_vertices, repair_mesh
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


def _keep_largest(
    label: np.ndarray,
    used: np.ndarray,
    n_input: int,
    max_fraction: float,
    what: str,
) -> tuple[np.ndarray, np.ndarray]:
    """The rule for several pieces: keep the largest, drop the others when each holds at
    most ``max_fraction`` of the ``n_input`` input vertices.

    Parameters
    ----------
    label : int (n,)
        Component label of each vertex.
    used : bool (n,)
        Vertices referenced by a face (the others are not counted in any piece).
    n_input : int
        Number of input vertices (the fraction's denominator).
    max_fraction : float
    what : str
        Names the pieces in the error message: "mesh_2 has" or "repairing mesh_2 (...)
        split it into".

    Returns
    -------
    keep : bool (n,)
        The vertices of the largest piece.
    sizes : int (p,)
        Vertex counts of the pieces, largest first.

    Raises
    ------
    DisconnectedMeshError
        A piece besides the largest holds more than ``max_fraction`` of the vertices.
    """
    pieces, size = np.unique(label[used], return_counts=True)
    order = np.argsort(-size, kind="stable")
    pieces, size = pieces[order], size[order]
    limit = max_fraction * max(n_input, 1)
    if size.size > 1 and size[1] > limit:
        large = size[size > limit]
        rest = size.size - large.size
        small = f", and {rest} more of at most {int(limit)} vertices" if rest else ""
        raise DisconnectedMeshError(
            f"{what} {size.size} connected components; {large.size} of them hold more "
            f"than {max_fraction:.0%} of the {n_input} vertices ({', '.join(map(str, large))} "
            f"vertices{small}). Matching needs one shape: only components of at most "
            f"{max_fraction:.0%} of the vertices are dropped as specks. Fix: match each "
            "shape separately (fvf.TriMesh(V, F).vertex_components labels the components; "
            "keep the faces of one label), or repair the mesh by hand (fvf.repair_mesh)."
        )
    return label == pieces[0], size


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


def _drop_own_specks(
    V: np.ndarray, F: np.ndarray, name: str, max_fraction: float
) -> tuple[np.ndarray, str | None]:
    """The faces of the input's largest component, after :func:`_keep_largest`'s rule,
    and a log line (None when the input is one component); warns when specks are dropped."""
    count, label = _vertex_components(F, V.shape[0])
    if count <= 1:
        return F, None
    used = np.zeros(V.shape[0], dtype=bool)
    used[F.ravel()] = True
    keep, size = _keep_largest(label, used, V.shape[0], max_fraction, f"{name} has")
    face_keep = keep[F[:, 0]]
    line = (
        f"dropped {count - 1} small component(s) of the input ({int(size[1:].sum())} "
        f"vertices, {int((~face_keep).sum())} faces; at most {int(size[1])} vertices each); "
        f"kept the largest ({int(size[0])} vertices)"
    )
    warnings.warn(
        f"{name}: {line}. Each dropped vertex stands for its nearest kept vertex in the map.",
        SmallComponentWarning,
        stacklevel=user_stacklevel(),
    )
    return F[face_keep], line


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
        Largest fraction of the input vertices that one dropped piece may hold: a
        component of the input besides the largest (a speck), or a piece the repair cut
        off. A larger piece raises.

    Returns
    -------
    PreparedMesh

    Warns
    -----
    SmallComponentWarning
        Small components of the input were dropped (the message gives their sizes).

    Raises
    ------
    DisconnectedMeshError
        The input (or the repair) has a second piece holding more than
        ``max_dropped_fraction`` of the vertices (several shapes); the message gives the
        component sizes.
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
    if mesh is not None and mesh.n_components == 1:
        ident = np.arange(mesh.n_vertices, dtype=np.int64)
        return PreparedMesh(mesh, mesh.n_vertices, ident, ident)
    V = np.asarray(vertices, dtype=float)
    F = np.asarray(faces, dtype=np.int64)
    log: list[str] = []
    if not _pieces_touch(V, F):  # else a soup or seams: welded by the repair below
        F, own = _drop_own_specks(V, F, name, max_dropped_fraction)
        log = [own] if own else []
        if mesh is not None:  # valid apart from the specks: keep the vertices as they are
            return _subset(V, F, log)
    rep = repair_mesh(V, F, MATCH_REPAIR_STEPS)
    log.extend(rep.log)
    V2, F2 = rep.vertices, rep.faces
    n2 = V2.shape[0]
    count, label = _vertex_components(F2, n2)
    keep, size = _keep_largest(
        label,
        np.ones(n2, dtype=bool),
        V.shape[0],
        max_dropped_fraction,
        f"repairing {name} ({'; '.join(rep.log)}) split it into",
    )
    dropped = n2 - int(keep.sum())
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
    own_index = rep.vertex_map >= 0
    own_new = np.where(own_index, new_index[np.maximum(rep.vertex_map, 0)], -1)
    input_to_mesh = np.where(own_new >= 0, own_new, input_to_mesh)
    _nearest_for_missing(V, mesh, input_to_mesh, log)
    return PreparedMesh(mesh, V.shape[0], input_to_mesh, mesh_to_input, tuple(log))


def _subset(V: np.ndarray, F: np.ndarray, log: list[str]) -> PreparedMesh:
    """The valid mesh of the vertices ``F`` references, in their input order."""
    sub = remove_unreferenced_vertices(V, F)
    input_to_mesh = sub.vertex_map.copy()  # -1 for the vertices of dropped pieces
    _nearest_for_missing(V, sub.mesh, input_to_mesh, log)
    return PreparedMesh(sub.mesh, V.shape[0], input_to_mesh, sub.vertex_origin, tuple(log))


def _pieces_touch(V: np.ndarray, F: np.ndarray) -> bool:
    """Whether two referenced vertices sit at one position (a triangle soup, a mesh split
    at its UV seams or exported in patches): its pieces are one surface once welded, not
    specks beside a shape (a soup's 5,855 one-triangle pieces were dropped but one)."""
    return coincident_vertices(V[np.unique(F)]) > 0


def _nearest_for_missing(
    V: np.ndarray, mesh: TriMesh, input_to_mesh: np.ndarray, log: list[str]
) -> None:
    """Entries -1 of ``input_to_mesh`` (n_input,) -> the nearest mesh vertex in space."""
    missing = np.flatnonzero(input_to_mesh < 0)
    if missing.size:
        _, nearest = cKDTree(mesh.vertices).query(V[missing])
        input_to_mesh[missing] = nearest
        log.append(
            f"{missing.size} input vertices (unreferenced or in dropped pieces) stand for "
            "their nearest kept vertex"
        )
