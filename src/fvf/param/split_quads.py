r"""Quads that do not follow a field: each triangle of the surface split into three.

:func:`fvf.quad_mesh` with ``fallback="split"`` uses these for a component where no
field-aligned attempt passed the gate (a knife edge or sliver thinner than a quad left by
a boolean, *Fallback* in ``docs/quads.md``). Each triangle $(a, b, c)$ with edge midpoints
$m_{ab}, m_{bc}, m_{ca}$ and centroid $g$ gives the quads

.. math::

    (a, m_{ab}, g, m_{ca}),\quad (b, m_{bc}, g, m_{ab}),\quad (c, m_{ca}, g, m_{bc}),

each counter-clockwise about the triangle's normal and lying in its plane. So the quad
mesh is the triangle mesh's own surface: every edge of the triangles is split in two
quad edges, the quads are manifold and oriented as the triangles are, with the same χ
($V' - E' + F' = (V + E + F) - (2E + 3F) + 3F$) and boundary loops, no quad folds
against it and the Hausdorff distance is zero. The triangles are the component's own,
midpoint-subdivided as often as brings the quads closest to the count asked. (Remeshing
first, at the edge $\ell = h\sqrt{12/\sqrt3}$ whose equilateral triangles split into quads
of area $h^2$, gave better shaped quads but never passed the gate on the parts where every
field-aligned attempt had failed: it fails at the same knife edges.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mesh.shapes import midpoint_subdivision
from ..mesh.trimesh import TriMesh
from ..numerics.summary import short_repr
from .quad_folds import quad_normals
from .quad_validity import QuadValidity, check_quad_mesh

__all__ = [
    "SplitQuads",
    "triangle_quads",
    "subdivided_for_split",
    "split_quad_mesh",
]

#: At most this many triangles from the subdivision (four times more per step).
MAX_SPLIT_TRIANGLES = 2_000_000


@dataclass(frozen=True)
class SplitQuads:
    """What :func:`split_quad_mesh` made.

    Attributes
    ----------
    vertices : float64 (k, 3)
        On the mesh.
    quads : int64 (q, 4)
        Counter-clockwise about the outward normal.
    vertex_faces : int64 (k,)
        The triangle of the mesh each vertex lies on.
    surface : TriMesh
        The triangles that were split.
    validity : QuadValidity
        The gate's verdict, against the mesh.
    """

    vertices: np.ndarray
    quads: np.ndarray
    vertex_faces: np.ndarray
    surface: TriMesh
    validity: QuadValidity

    __repr__ = short_repr  # arrays by dtype and shape


def triangle_quads(mesh: TriMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each triangle of ``mesh`` split into three quads (module docstring).

    Parameters
    ----------
    mesh : TriMesh
        n vertices, E edges, m triangles.

    Returns
    -------
    vertices : float64 (n + E + m, 3)
        The mesh's vertices, then its edge midpoints (in the order of ``mesh.edges``),
        then its triangles' centroids.
    quads : int64 (3m, 4)
        Quads 3t, 3t + 1, 3t + 2 are those of triangle t, at its corners 0, 1, 2,
        counter-clockwise about its normal.
    vertex_faces : int64 (n + E + m,)
        A triangle of ``mesh`` each quad vertex lies on.
    """
    n, m, F = mesh.n_vertices, mesh.n_faces, mesh.faces
    E = mesh.edges
    mid = n + mesh.face_edges[:, [2, 0, 1]]  # (m, 3): the midpoint of side (i, i + 1)
    g = n + E.shape[0] + np.arange(m)
    V = np.concatenate([mesh.vertices, mesh.vertices[E].mean(axis=1), mesh.face_centroids])
    Q = np.stack(
        [
            np.stack([F[:, i], mid[:, i], g, mid[:, (i + 2) % 3]], axis=1)
            for i in range(3)  # the three corners
        ],
        axis=1,
    ).reshape(-1, 4)
    vf = np.empty(V.shape[0], dtype=np.int64)
    vf[F.ravel()] = np.repeat(np.arange(m), 3)
    vf[mid.ravel()] = np.repeat(np.arange(m), 3)
    vf[g] = np.arange(m)
    return V, Q.astype(np.int64), vf


def subdivided_for_split(mesh: TriMesh, h: float) -> tuple[TriMesh, np.ndarray]:
    r"""``mesh`` midpoint-subdivided $k$ times, $k \ge 0$ the count whose $3 \cdot 4^k m$
    quads come closest (in ratio) to the $A / h^2$ asked (at most
    :data:`MAX_SPLIT_TRIANGLES` triangles): the same surface, exactly. Returns it and,
    per new triangle, the input triangle it lies in (int64 (m',))."""
    m = mesh.n_faces
    k = int(np.round(np.log(mesh.total_area / (h * h) / (3.0 * m)) / np.log(4.0)))
    k = max(0, min(k, int(np.log(MAX_SPLIT_TRIANGLES / m) / np.log(4.0))))
    V, F = mesh.vertices, mesh.faces
    parent = np.arange(m)
    for _ in range(k):  # a few subdivision steps
        V, F = midpoint_subdivision(V, F)
        parent = np.tile(parent, 4)  # blocks of m: fine face j comes from face j mod m
    return (mesh if k == 0 else TriMesh(V, F)), parent


def split_quad_mesh(mesh: TriMesh, h: float) -> SplitQuads:
    """Quads of about edge ``h`` (at least three per triangle) on ``mesh``, not aligned to
    any field: its triangles midpoint-subdivided (:func:`subdivided_for_split`), each
    split into three quads (:func:`triangle_quads`), judged by the gate
    (:func:`fvf.param.quad_validity.check_quad_mesh`) with each quad's own triangle as
    the surface under it: it lies in that triangle's plane, with its normal.

    Parameters
    ----------
    mesh : TriMesh
        One component or several, closed or with boundary loops.
    h : float
        The target quad edge.

    Returns
    -------
    SplitQuads
    """
    surface, parent = subdivided_for_split(mesh, h)
    V, Q, vf = triangle_quads(surface)
    vf = parent[vf]
    # the fold test's reference normal (the surface in a ball about the quad) can take a
    # facing sheet closer than the ball (a knife edge) for the surface under the quad
    own = mesh.face_normals[vf[Q[:, 2]]]  # (corner 2 is the triangle's centroid)
    folded = np.flatnonzero(np.einsum("qd,qd->q", quad_normals(V, Q), own) <= 0)
    return SplitQuads(V, Q, vf, surface, check_quad_mesh(mesh, V, Q, folded=folded))
