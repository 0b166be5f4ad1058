r"""T-junctions: zero-area faces whose apex lies on their longest edge.

A CAD exporter or a mesh boolean leaves faces :math:`(u, w, a)` whose apex :math:`a` lies
on the segment :math:`uw` (three distinct, collinear vertices). Dropping such a face leaves
a slit: the face across :math:`uw` still spans the whole segment, and :math:`a` is a
T-junction on it. Splitting that face at :math:`a` instead,

$$ (x_0, x_1, x_2) \;\to\; (x_0, a, x_2),\ (a, x_1, x_2) \qquad (\{x_0, x_1\} = \{u, w\}), $$

closes the slit, keeps the face's orientation, and leaves nothing to drop but the zero-area
face itself. Two zero-area faces :math:`(u, w, a)` and :math:`(w, u, b)` can share their
long edge (a remesher's pocket along a crease: both apexes on :math:`uw`); flipping that
edge,

$$ (u, w, a),\ (w, u, b) \;\to\; (u, b, a),\ (b, w, a), $$

keeps the (zero) area and the orientation and gives two zero-area faces whose long edges
(each has an end of :math:`uw` as an end: :math:`ub` or :math:`ua`, :math:`aw` or
:math:`bw`) are the pocket's sides, split in a later pass. Flips run only in a pass that
splits nothing, and neither is made where it would add an edge the mesh has (a remesher's
fold beside a pocket), so that every pass keeps the mesh manifold. A face is split or
flipped at most once per pass; a zero-area face whose long edge is on the boundary or is
shared by more than one other face is left for :func:`fvf.remove_degenerate_faces`.
"""

from __future__ import annotations

import numpy as np

from .defects import repeats_vertex, zero_area_faces
from .halfedges import sort_halfedges

__all__ = ["t_junction_splits"]


def t_junction_splits(
    V: np.ndarray, F: np.ndarray, area_rtol: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One pass of the splits and flips of the module docstring.

    Parameters
    ----------
    V : float64 (n, 3)
    F : int64 (m, 3)
    area_rtol : float
        Zero area as in :func:`fvf.mesh.defects.zero_area_faces`.

    Returns
    -------
    faces : int64 (m', 3)
        The faces kept (split ones replaced by their first half and flipped pairs by the
        flipped pair, in place), then the second halves.
    face_origin : int64 (m',)
        The old face of each new face.
    removed : int64 (k,)
        The zero-area faces removed.
    split : int64 (k,)
        The faces split, one per removed face.
    flipped : int64 (l, 2)
        The pairs of zero-area faces whose shared long edge was flipped.
    """
    flat = np.flatnonzero(~repeats_vertex(F) & zero_area_faces(V, F, area_rtol))
    empty = np.zeros(0, np.int64)
    if flat.size == 0:
        return F.copy(), np.arange(F.shape[0]), empty, empty, empty.reshape(0, 2)
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
    long_corner = np.full(F.shape[0], -1, dtype=np.int64)
    long_corner[flat] = corner
    apex = F[flat, corner]
    n = V.shape[0]
    keys = _key(runs.edges[:, 0], runs.edges[:, 1], n)  # the mesh's edges, sorted
    made = _key(apex, F[g, j], n)  # the edge a split makes
    ok = two & (long_corner[g] < 0) & ~np.isin(made, keys)
    ok &= _first_use(g, ok) & _first_use(made, ok)  # one split per face and edge and pass
    out = F.copy()
    pairs = np.zeros((0, 2), dtype=np.int64)
    if not ok.any():  # flips only where nothing is split, so that no two make one edge
        pairs = _pocket_pairs(F, flat[two], g[two], corner[two], j[two], long_corner, keys, n)
        t, s = pairs[:, 0], pairs[:, 1]
        u, w = F[t, (long_corner[t] + 1) % 3], F[t, (long_corner[t] + 2) % 3]
        a, b = F[t, long_corner[t]], F[s, long_corner[s]]
        out[t], out[s] = np.stack([u, b, a], axis=1), np.stack([b, w, a], axis=1)
    flat, g, j, apex = flat[ok], g[ok], j[ok], apex[ok]
    x0, x1, x2 = F[g, (j + 1) % 3], F[g, (j + 2) % 3], F[g, j]
    out[g] = np.stack([x0, apex, x2], axis=1)
    keep = np.ones(F.shape[0], dtype=bool)
    keep[flat] = False
    faces = np.concatenate([out[keep], np.stack([apex, x1, x2], axis=1)])
    origin = np.concatenate([np.flatnonzero(keep), g])
    return faces, origin, flat.astype(np.int64), g.astype(np.int64), pairs


def _key(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """The undirected edge (a, b) as one int64 key."""
    return np.minimum(a, b) * n + np.maximum(a, b)


def _pocket_pairs(
    F: np.ndarray,
    flat: np.ndarray,
    g: np.ndarray,
    corner: np.ndarray,
    j: np.ndarray,
    long_corner: np.ndarray,
    keys: np.ndarray,
    n: int,
) -> np.ndarray:
    """The pairs (t, s), t < s, of zero-area faces that share their long edge, oppositely
    oriented, whose flip (module docstring) makes no edge of ``keys`` (edges of a mesh
    with n vertices): int64 (l, 2)."""
    mine = (long_corner[g] == j) & (flat < g)
    t, s, c, k = flat[mine], g[mine], corner[mine], j[mine]
    u, w, a, b = F[t, (c + 1) % 3], F[t, (c + 2) % 3], F[t, c], F[s, k]
    ok = (F[s, (k + 1) % 3] == w) & (F[s, (k + 2) % 3] == u) & (a != b)
    made = _key(a, b, n)
    ok &= ~np.isin(made, keys)
    ok &= _first_use(made, ok)
    return np.stack([t[ok], s[ok]], axis=1).astype(np.int64)


def _first_use(g: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """``ok`` and the first of the entries with the same value of g (a face to split, an
    edge to make)."""
    first = np.zeros(g.size, dtype=bool)
    idx = np.flatnonzero(ok)
    _, at = np.unique(g[idx], return_index=True)
    first[idx[at]] = True
    return first
