r"""Open seams: boundary vertices at exactly the position of another boundary vertex.

A triangle soup (an STL file's facets, arrays exported without an index buffer) or a mesh
split along its texture seams arrives as pieces whose boundary edges lie on top of each
other. Algorithms that see the pieces — a quad mesher meshes every connected component on
its own — would work on hundreds of separate triangles.

:func:`weld_open_seams` joins them: boundary vertices with equal coordinates become one
vertex (the lowest index, at its position), and the weld is kept only when the result is
still an oriented 2-manifold with edges — every undirected edge used by at most two faces,
each directed edge by at most one face, no face repeating a vertex. Interior vertices are
never merged: coincident interior vertices belong to a closed surface touching itself
(welding them would pinch it). Faces keep their order, so face indices into the input
stay valid for the welded mesh.
"""

from __future__ import annotations

import numpy as np

from .trimesh import TriMesh

__all__ = ["weld_open_seams"]


def weld_open_seams(mesh: TriMesh) -> tuple[TriMesh, int]:
    """Join boundary vertices that sit at exactly the same position (module docstring).

    Parameters
    ----------
    mesh : TriMesh

    Returns
    -------
    welded : TriMesh
        ``mesh`` itself when nothing was merged or the weld would leave a non-manifold
        or inconsistently oriented mesh; otherwise the welded mesh: the same faces in the
        same order, on the remaining vertices (kept in their order).
    merged : int
        How many vertices were merged into another (0 when ``mesh`` is returned).
    """
    b = mesh.boundary_vertices
    if b.size < 2:
        return mesh, 0
    X = mesh.vertices[b] + 0.0  # -0.0 -> 0.0
    order = np.lexsort((b, X[:, 2], X[:, 1], X[:, 0]))
    new = np.ones(b.size, dtype=bool)
    new[1:] = (X[order][1:] != X[order][:-1]).any(axis=1)
    if new.all():
        return mesh, 0
    rep = np.empty(b.size, dtype=np.int64)
    rep[order] = b[order][np.flatnonzero(new)][np.cumsum(new) - 1]
    to = np.arange(mesh.n_vertices)
    to[b] = rep
    F = to[mesh.faces]
    if not _oriented_manifold(F):
        return mesh, 0
    kept = np.unique(F)
    index = np.full(mesh.n_vertices, -1, dtype=np.int64)
    index[kept] = np.arange(kept.size)
    return TriMesh(mesh.vertices[kept], index[F]), int(mesh.n_vertices - kept.size)


def _oriented_manifold(F: np.ndarray) -> bool:
    """No face repeats a vertex, each directed edge has one face, each edge at most two."""
    if (F[:, 0] == F[:, 1]).any() or (F[:, 1] == F[:, 2]).any() or (F[:, 2] == F[:, 0]).any():
        return False
    directed = np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)
    if np.unique(directed, axis=0).shape[0] < directed.shape[0]:
        return False
    undirected = np.sort(directed, axis=1)
    _, uses = np.unique(undirected, axis=0, return_counts=True)
    return bool(uses.max() <= 2)
