r"""T-junctions: zero-area faces whose apex lies on their longest edge.

A CAD exporter or a mesh boolean leaves faces :math:`(u, w, a)` whose apex :math:`a` lies
on the segment :math:`uw` (three distinct, collinear vertices). Dropping such a face leaves
a slit: the face across :math:`uw` still spans the whole segment, and :math:`a` is a
T-junction on it. Splitting that face at :math:`a` instead,

$$ (x_0, x_1, x_2) \;\to\; (x_0, a, x_2),\ (a, x_1, x_2) \qquad (\{x_0, x_1\} = \{u, w\}), $$

closes the slit, keeps the face's orientation, and leaves nothing to drop but the zero-area
face itself. A face is split at most once per pass; a zero-area face whose long edge is on
the boundary, or is shared by another zero-area face or by more than one other face, is
left for :func:`fvf.remove_degenerate_faces`.
"""

from __future__ import annotations

import numpy as np

from .defects import repeats_vertex, zero_area_faces
from .halfedges import sort_halfedges

__all__ = ["t_junction_splits"]


def t_junction_splits(
    V: np.ndarray, F: np.ndarray, area_rtol: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One pass of the splits of the module docstring.

    Parameters
    ----------
    V : float64 (n, 3)
    F : int64 (m, 3)
    area_rtol : float
        Zero area as in :func:`fvf.mesh.defects.zero_area_faces`.

    Returns
    -------
    faces : int64 (m', 3)
        The faces kept (split ones replaced by their first half, in place), then the
        second halves.
    face_origin : int64 (m',)
        The old face of each new face.
    removed : int64 (k,)
        The zero-area faces removed.
    split : int64 (k,)
        The faces split, one per removed face.
    """
    flat = np.flatnonzero(~repeats_vertex(F) & zero_area_faces(V, F, area_rtol))
    empty = np.zeros(0, np.int64)
    if flat.size == 0:
        return F.copy(), np.arange(F.shape[0]), empty, empty
    # half-edge 3t + i runs F[t, i+1] -> F[t, i+2], opposite corner i: the long edge of a
    # flat face is the half-edge of its apex
    P = V[F[flat]]
    corner = np.argmax(np.linalg.norm(np.roll(P, -2, axis=1) - np.roll(P, -1, axis=1), axis=2), 1)
    runs = sort_halfedges(F, V.shape[0])
    at = np.empty(runs.halfedges.size, dtype=np.int64)
    at[runs.halfedges] = np.arange(runs.halfedges.size)
    edge = np.repeat(np.arange(runs.counts.size), runs.counts)[at[3 * flat + corner]]
    two = runs.counts[edge] == 2  # the flat face and one other
    first = runs.halfedges[runs.starts[edge]]
    other = np.where(first // 3 == flat, runs.halfedges[runs.starts[edge] + two], first)
    g, j = other // 3, other % 3  # j: the corner of g opposite the shared edge
    is_flat = np.zeros(F.shape[0], dtype=bool)
    is_flat[flat] = True
    ok = two & ~is_flat[g]
    ok &= _first_use(g, ok)  # one split per face and pass
    flat, g, j, apex = flat[ok], g[ok], j[ok], F[flat[ok], corner[ok]]
    x0, x1, x2 = F[g, (j + 1) % 3], F[g, (j + 2) % 3], F[g, j]
    out = F.copy()
    out[g] = np.stack([x0, apex, x2], axis=1)
    keep = np.ones(F.shape[0], dtype=bool)
    keep[flat] = False
    faces = np.concatenate([out[keep], np.stack([apex, x1, x2], axis=1)])
    origin = np.concatenate([np.flatnonzero(keep), g])
    return faces, origin, flat.astype(np.int64), g.astype(np.int64)


def _first_use(g: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """``ok`` and the first of the flat faces that would split the same face g."""
    first = np.zeros(g.size, dtype=bool)
    idx = np.flatnonzero(ok)
    _, at = np.unique(g[idx], return_index=True)
    first[idx[at]] = True
    return first
