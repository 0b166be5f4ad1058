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
    slot = np.argmax(np.linalg.norm(V[np.roll(F[flat], -1, axis=1)] - V[F[flat]], axis=2), 1)
    u, w = F[flat, slot], F[flat, (slot + 1) % 3]
    apex = F[flat, (slot + 2) % 3]
    n = V.shape[0]
    keys = np.sort(np.stack([F, np.roll(F, -1, axis=1)], axis=2), axis=2)  # (m, 3, 2)
    keys = (keys[..., 0] * n + keys[..., 1]).ravel()  # edge of face t at slot s: 3 t + s
    order = np.argsort(keys, kind="stable")
    want = np.minimum(u, w) * n + np.maximum(u, w)
    lo, hi = np.searchsorted(keys[order], want), np.searchsorted(keys[order], want, "right")
    two = hi - lo == 2  # the flat face and one other
    other = np.where(two, order[np.minimum(lo, keys.size - 1)], -1)
    other = np.where(two & (other // 3 == flat), order[np.minimum(lo + 1, keys.size - 1)], other)
    g, t = other // 3, other % 3
    is_flat = np.zeros(F.shape[0], dtype=bool)
    is_flat[flat] = True
    ok = two & ~is_flat[np.maximum(g, 0)]
    ok &= _first_use(g, ok)  # one split per face and pass
    flat, g, t, apex = flat[ok], g[ok], t[ok], apex[ok]
    x0, x1, x2 = F[g, t], F[g, (t + 1) % 3], F[g, (t + 2) % 3]
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
