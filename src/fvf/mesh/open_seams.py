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

from .defects import repeats_vertex
from .halfedges import misoriented_edges, sort_halfedges
from .repair import remove_duplicate_vertices, remove_unreferenced_vertices
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
    groups = remove_duplicate_vertices(mesh.vertices[b], np.zeros((0, 3), dtype=np.int64))
    if groups.vertices.shape[0] == b.size:
        return mesh, 0
    to = np.arange(mesh.n_vertices)
    to[b] = b[groups.vertex_origin[groups.vertex_map]]  # the lowest index of each group
    F = to[mesh.faces]
    if not _oriented_manifold(F, mesh.n_vertices):
        return mesh, 0
    joined = remove_unreferenced_vertices(mesh.vertices, F)
    return joined.mesh, int(mesh.n_vertices - joined.vertices.shape[0])


def _oriented_manifold(F: np.ndarray, n_vertices: int) -> bool:
    """No face repeats a vertex, no edge has more than two faces, and every edge of two
    faces is traversed once each way (the checks of ``TriMesh``, on the sorted
    half-edges)."""
    if repeats_vertex(F).any():
        return False
    runs = sort_halfedges(F, n_vertices)
    return bool(runs.counts.max(initial=0) <= 2 and misoriented_edges(runs).size == 0)
