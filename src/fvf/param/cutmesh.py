r"""A combed cross field on the mesh cut to a disk: what the seams of a parameterization need.

The cross field's matching, indices, cut graph and combing come from
:mod:`fvf.design.nfields` (:func:`fvf.cut_graph`, :func:`fvf.comb`,
:func:`fvf.period_jumps`, :func:`fvf.vertex_indices` with n = 4). This module only adds
what a parameterization needs on top: the *wedges*, the vertices of the cut mesh (maximal
fans of corners around a mesh vertex not separated by a cut edge), and the combed
representative as an angle in each face's frame.

Across a cut edge e with faces (s, t) = ``mesh.edge_faces[e]`` the combed frames differ by
the period jump p_e ∈ {0, 1, 2, 3} of :func:`fvf.period_jumps`: s's representative is t's,
transported into s and turned by p_e quarter turns. Off the cut p_e = 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..design.indices import vertex_indices
from ..design.nfields import comb, cut_graph, period_jumps
from ..mesh.trimesh import TriMesh
from ..numerics.summary import html_repr, short_repr

__all__ = ["CutMesh", "cut_mesh"]


@dataclass(frozen=True)
class CutMesh:
    """A combed cross field on a mesh cut to a disk through its singularities.

    Attributes
    ----------
    field : float64 (m, 3)
        Combed unit representative per face (``fvf.comb(...)[0]``, normalized).
    angles : float64 (m,)
        Its angle in the complex frame of each face (``mesh.to_complex``).
    jumps : int64 (E,)
        Period jump p_e ∈ {0, 1, 2, 3} of the combed field per edge (0 off the cut).
    index4 : int64 (n,)
        Four times the cross-field index of each vertex (Σ index4 = 4χ).
    singular : int64 (S,)
        Vertices with index4 ≠ 0.
    cut : bool (E,)
        Edges of the cut graph (:func:`fvf.cut_graph`).
    wedges : int64 (m, 3)
        Cut-mesh vertex of each corner.
    n_wedges : int
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    field: np.ndarray
    angles: np.ndarray
    jumps: np.ndarray
    index4: np.ndarray
    singular: np.ndarray
    cut: np.ndarray
    wedges: np.ndarray
    n_wedges: int


def wedges(mesh: TriMesh, cut: np.ndarray) -> tuple[np.ndarray, int]:
    """Cut-mesh vertex of each corner, int64 (m, 3), and their number.

    Two corners at the same mesh vertex belong to one wedge when a chain of faces around
    the vertex joins them without crossing a cut edge (``cut``: bool (E,)).
    """
    F, E = mesh.faces, mesh.edges
    ef = mesh.edge_faces
    ok = (~cut) & (ef >= 0).all(axis=1)
    s, t = ef[ok, 0], ef[ok, 1]
    rows, cols = [], []
    for end in (0, 1):
        v = E[ok, end]
        rows.append(3 * s + np.argmax(F[s] == v[:, None], axis=1))
        cols.append(3 * t + np.argmax(F[t] == v[:, None], axis=1))
    r, c = np.concatenate(rows), np.concatenate(cols)
    k = 3 * mesh.n_faces
    G = sp.coo_array((np.ones(r.size), (r, c)), shape=(k, k))
    count, labels = connected_components(G, directed=False)
    return labels.reshape(-1, 3).astype(np.int64), int(count)


def cut_mesh(mesh: TriMesh, u: np.ndarray, rotations: np.ndarray | None = None) -> CutMesh:
    """Comb a cross field and cut the mesh to a disk through its cones.

    Parameters
    ----------
    mesh : TriMesh
        One component.
    u : float64 (m, 3)
        One representative tangent vector per face, non-zero on every face.
    rotations : float64 (E,), optional
        ``connection_rotations`` of :func:`fvf.vertex_indices`: cones, period jumps and
        combing relative to that connection (default: Levi-Civita).

    Returns
    -------
    CutMesh
    """
    cg = cut_graph(mesh, u, 4, connection_rotations=rotations)
    combed = comb(mesh, u, 4, cg, connection_rotations=rotations)[0]
    combed = combed / np.linalg.norm(combed, axis=1, keepdims=True)
    jumps = period_jumps(mesh, combed, 4, connection_rotations=rotations)
    jumps[~cg.mask] = 0
    index = vertex_indices(mesh, u, n=4, connection_rotations=rotations)
    index4 = np.rint(4.0 * np.asarray(index, dtype=float)).astype(np.int64)
    w, count = wedges(mesh, cg.mask)
    return CutMesh(
        field=combed,
        angles=np.angle(mesh.to_complex(combed)),
        jumps=jumps.astype(np.int64),
        index4=index4,
        singular=np.flatnonzero(index4),
        cut=cg.mask.copy(),
        wedges=w,
        n_wedges=count,
    )
