r"""Triangulating the polygons of a mesh file: fans where they are right, other splits
for non-convex polygons.

A fan :math:`(v_0, v_i, v_{i+1})` triangulates a convex polygon, and any polygon whose
every vertex is seen from :math:`v_0`; of a non-convex one (an L-shaped hexagon, a dart
quad whose reflex corner is not :math:`v_0`) it makes triangles that fold over and cover
ground outside the polygon. A planar simple polygon's fan is a triangulation exactly when
each fan triangle turns the way the polygon does: their signed areas then add up to the
polygon's area without overlap. The polygon's normal is Newell's,

.. math::

    N = \sum_i v_i \times v_{i+1} = \sum_t n_t,

(twice its vector area; indices cyclic; equal to the sum of the fan triangles' normals
:math:`n_t = (v_i - v_0) \times (v_{i+1} - v_0)`), and a fan triangle :math:`t` is folded when
:math:`n_t \cdot N \le 0` for its normal :math:`n_t`. A quad with a folded fan is split
along its other diagonal, :math:`(v_0, v_1, v_3), (v_1, v_2, v_3)`; a larger polygon is
ear-clipped in the plane normal to :math:`N` (by mapbox_earcut with the ``[fast]`` extra,
else a Python loop over its corners: an extruded outline's cap of 10,000 corners takes
16 s there, 0.1 s by mapbox_earcut). The other split is taken only when all its
triangles turn the polygon's way; a polygon that no split turns so (self-intersecting,
far from planar, or all on a line) keeps its fan. Every polygon of k vertices gives
k - 2 triangles in order, the same rows as the fan, so per-face values line up either way.
"""

from __future__ import annotations

import numpy as np

from .base import fan_triangulate

__all__ = ["triangulate"]


def triangulate(
    vertices: np.ndarray, counts: np.ndarray, flat: np.ndarray
) -> tuple[np.ndarray, int, int]:
    """Triangles of polygons: fans, re-split where a fan folds (module docstring).

    Parameters
    ----------
    vertices : numpy.ndarray of float64, shape (n, 3)
        Vertex positions.
    counts : numpy.ndarray of int64, shape (p,)
        Vertices per polygon (each >= 3).
    flat : numpy.ndarray of int64, shape (counts.sum(),)
        The polygons' vertex indices in ``[0, n)``, one after the other.

    Returns
    -------
    faces : numpy.ndarray of int64, shape (counts.sum() - 2 p, 3)
        The triangles, polygon by polygon in order (polygon i gives ``counts[i] - 2``).
    n_split : int
        How many polygons had more than 3 vertices.
    n_resplit : int
        How many of them were non-convex and split otherwise than by the fan.
    """
    faces, n_split = fan_triangulate(counts, flat)
    if n_split == 0:
        return faces, 0, 0
    with np.errstate(all="ignore"):  # NaN, inf or overflowing products keep their fan
        faces, n_resplit = _resplit(vertices, counts, flat, faces)
    return faces, n_split, n_resplit


def _resplit(
    vertices: np.ndarray, counts: np.ndarray, flat: np.ndarray, faces: np.ndarray
) -> tuple[np.ndarray, int]:
    """The fan ``faces`` with each folded polygon split otherwise: ``(faces, #re-split)``."""
    ntri = counts - 2
    first = np.cumsum(ntri) - ntri  # first triangle of each polygon
    big = np.flatnonzero(counts > 3)
    k = ntri[big]
    rows = np.repeat(first[big] - (np.cumsum(k) - k), k) + np.arange(k.sum())
    fan_normal = _normals(vertices, faces[rows])
    normal = np.add.reduceat(fan_normal, np.cumsum(k) - k, axis=0)  # Newell's N
    owner = np.repeat(np.arange(big.size), k)
    turn = np.einsum("ij,ij->i", fan_normal, normal[owner])
    folded = np.zeros(big.size, dtype=bool)
    folded[owner[turn <= 0]] = True
    folded &= np.any(normal != 0, axis=1) & np.isfinite(normal).all(axis=1)
    if not folded.any():
        return faces, 0
    bad, normal = big[folded], normal[folded]
    faces = faces.copy()
    starts = np.cumsum(counts) - counts
    quad = counts[bad] == 4
    q = flat[starts[bad[quad], None] + np.arange(4)]
    other = np.stack([q[:, [0, 1, 3]], q[:, [1, 2, 3]]], axis=1)  # (k, 2, 3)
    turns = _turns_with(vertices, other.reshape(-1, 3), np.repeat(normal[quad], 2, axis=0))
    ok = turns.reshape(-1, 2).all(axis=1)
    faces[first[bad[quad][ok], None] + np.arange(2)] = other[ok]
    resplit = int(ok.sum())
    for p, n in zip(bad[~quad], normal[~quad], strict=True):  # 5+ corners, non-convex: rare
        ring = flat[starts[p] : starts[p] + counts[p]]
        tri = _ear_clip(vertices[ring], n)
        if tri is not None and _turns_with(vertices, ring[tri], n[None]).all():
            faces[first[p] : first[p] + ntri[p]] = ring[tri]
            resplit += 1
    return faces, resplit


def _normals(vertices: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Twice the vector areas (k, 3) of triangles (k, 3): :math:`(b - a) \\times (c - a)`."""
    a = vertices[tri[:, 0]]
    u, v = vertices[tri[:, 1]] - a, vertices[tri[:, 2]] - a
    out = np.empty_like(u)
    out[:, 0] = u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1]
    out[:, 1] = u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2]
    out[:, 2] = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    return out


def _turns_with(vertices: np.ndarray, tri: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Whether each triangle (k, 3) turns the way of its polygon's normal (k, 3)."""
    return np.einsum("ij,ij->i", _normals(vertices, tri), normal) > 0


def _ear_clip(ring: np.ndarray, normal: np.ndarray) -> np.ndarray | None:
    """Ear-clipping triangles (k - 2, 3) of one polygon (k, 3) as corner numbers, or None
    when the polygon has no ear at some step (it intersects itself). By mapbox_earcut
    (the ``[fast]`` extra: a 40,000-corner CAD cap in milliseconds) when installed and
    its triangles are k - 2, else by :func:`_clip_ears` (minutes at that size)."""
    e1 = np.cross(normal, [1.0, 0.0, 0.0])
    if np.linalg.norm(e1) < 1e-3 * np.linalg.norm(normal):
        e1 = np.cross(normal, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal / np.linalg.norm(normal), e1)
    P = np.column_stack([(ring - ring[0]) @ e1, (ring - ring[0]) @ e2])  # counterclockwise
    try:
        import mapbox_earcut
    except ImportError:
        return _clip_ears(P)
    tri = mapbox_earcut.triangulate_float64(P, np.array([len(P)], dtype=np.uint32))
    if tri.size != 3 * (len(P) - 2):  # it drops degenerate ears: not k - 2 rows
        return _clip_ears(P)
    return tri.astype(np.int64).reshape(-1, 3)


def _clip_ears(P: np.ndarray) -> np.ndarray | None:
    """:func:`_ear_clip` of the counterclockwise plane polygon P (k, 2) in Python: the scan
    goes on from each ear it clips (a restart at corner 0 made a zig-zag cap cubic)."""
    left = list(range(len(P)))
    out: list[tuple[int, ...]] = []
    j, misses = 0, 0
    while len(left) > 3:
        j %= len(left)
        a, b, c = left[j - 1], left[j], left[(j + 1) % len(left)]
        if _is_ear(P, a, b, c, left):
            out.append((a, b, c))
            del left[j]
            misses = 0
            continue
        misses += 1
        if misses > len(left):  # a full turn without an ear
            return None
        j += 1
    out.append(tuple(left))
    return np.asarray(out, dtype=np.int64)


def _cross2(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _is_ear(P: np.ndarray, a: int, b: int, c: int, left: list[int]) -> bool:
    """Whether corner b, between a and c, is convex and its triangle holds no other corner."""
    if _cross2(P[b] - P[a], P[c] - P[b]) <= 0:
        return False
    others = P[[i for i in left if i not in (a, b, c)]]
    inside = (
        (_cross2(P[b] - P[a], others - P[a]) >= 0)
        & (_cross2(P[c] - P[b], others - P[b]) >= 0)
        & (_cross2(P[a] - P[c], others - P[c]) >= 0)
    )
    return not inside.any()
