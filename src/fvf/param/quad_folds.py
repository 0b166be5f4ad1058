r"""Quads folded in 3D: detection, and untangling on the input surface.

The extracted quads sit at integer uv points placed on the input surface. With no uv
triangle flipped, a quad can still be folded in 3D where the surface turns by nearly
90° or more within one quad (next to a cone on a strongly curved part): its two halves
face opposite ways.

**Definition.** Quad :math:`q` with corners :math:`p_0, \dots, p_3` has the normal

.. math::

    n_q = (p_2 - p_0) \times (p_3 - p_1)

(twice its vector area; the sum of the normals of its two halves, split along either
diagonal). Its reference normal is the vector area of the input surface the quad covers,

.. math::

    N_q = \sum_f |f \cap B_q|\, N_f ,
    \qquad B_q = \{x : |x - c_q| \le \rho_q\},
    \qquad \rho_q = \tfrac12 \min(|p_2 - p_0|, |p_3 - p_1|),

over the parts of the input triangles within half the quad's shorter diagonal of its
centroid :math:`c_q = \tfrac14 \sum_k p_k` (the surface under the quad); when there is
none, the normal of the surface at the point closest to :math:`c_q`. The areas
:math:`|f \cap B_q|` are counted on dense samples of the triangles, but that of the
triangle holding the point closest to :math:`c_q` on a grid of the disk where the ball
meets its plane: on a CAD face of one 100 mm triangle the samples lie 2.3 mm apart, and a
1.5 mm quad on it would otherwise be measured against the samples of the next face across
an edge and be called folded. (Samples facing away from the
surface's side at :math:`c_q` — the summed vertex normals of the closest triangle, or its
own normal where the two disagree and it is not folded over — are left out: they are the
far wall of a part thinner than a quad.) The quad is **folded** when :math:`n_q \cdot N_q
\le 0` — it faces away from the surface at its own scale — or when neither of its diagonal
splits has both halves facing the surface (:math:`n_{012}` and :math:`n_{023}`, or
:math:`n_{123}` and :math:`n_{130}`, each with a positive dot product with :math:`N_q` and
with the normal of the input triangle closest to :math:`c_q`): a bow tie, or a quad bent
over a ridge so far that it cannot be drawn as two triangles on the surface. The verdict
(:func:`folded_quads`, the validity gate) takes that triangle's own normal, so that it is
at least as strict as a judge that does (``tests/param/quadcheck.py``); the repair's steps
take, where that triangle is folded over against both the sum of its vertices' normals
and the triangles across its edges, that sum. (A single input triangle is a harsh
reference: crumpled inputs such as the TOSCA lion have triangles folded over against
their neighbours — 137 of its 10k face away from the mean normal of their two rings — and
there a quad whose four half-triangles all agree with the surface around it, dot products
0.21–0.99, faces away from its nearest triangle; such a quad fails the verdict, and the
attempt with it. A knurled knob's 0.2 mm ledge under a 1.3 mm quad is the same case on a
CAD part. The normals of the triangles holding the corners vary at the scale of the input
triangles: on armadillo at 7724 quads 37 quads have a corner whose triangle faces away
from :math:`n_q`.)

**Repair** (:func:`untangle_quads`). Only the corners of folded quads move (the region
grows by one ring of quads when that is not enough): each step moves a free vertex a
fraction :data:`RELAX_STEP` toward the mean of its neighbours along quad edges, with the
component along the input normal removed (tangential Laplacian relaxation), and puts it
back on the input surface at the closest point. The connectivity is unchanged; the moved
vertices leave their integer uv points. All or nothing: if quads stay folded, the input
positions are kept (and :func:`warn_folded` names the quads).

Closest points are searched among the :data:`CANDIDATES` input triangles whose centroids
are nearest the query point: the exact closest point whenever its triangle is one of them
(checked against brute force in ``tests/param/test_quad_folds.py``); a result always lies on the
surface.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from itertools import chain
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..errors import FoldedQuadWarning, ParameterError, format_indices, user_stacklevel
from ..mesh.convert import takes_mesh
from ..mesh.geometry import vertex_vector_areas
from ..mesh.trimesh import TriMesh
from ..numerics.summary import html_repr, short_repr

__all__ = [
    "FoldRepair",
    "closest_surface_points",
    "folded_quads",
    "quad_normals",
    "centre_normals",
    "reference_normals",
    "surface_aabb",
    "surface_sample_tree",
    "untangle_quads",
    "warn_folded",
]

#: Which untangling passes :func:`untangle_quads` runs.
Passes = Literal["both", "first", "verdict"]

#: Input triangles (nearest centroids) searched for the closest point on the surface.
CANDIDATES = 32
#: Triangles of the nearest surface samples also searched (:func:`surface_sample_tree`).
SAMPLE_CANDIDATES = 8
#: Fraction of the way to the mean of its quad neighbours a free vertex moves per step.
RELAX_STEP = 0.5
#: Quads whose nearby surface samples :func:`reference_normals` gathers at once (the
#: samples' indices are Python lists: at 20,000 quads on 750k faces, 0.7 GB at once).
BALL_CHUNK = 2048
#: Two closest points count as tied (a point on the mid-surface of a thin wall) when their
#: distances differ by less than this fraction.
TIE = 1e-6
#: Points per side of the square grid whose points in the unit disk measure the area of
#: the triangle under a quad's centre within the quad's ball (:func:`_area_in_ball`).
DISK_GRID = 9
#: Relaxation steps per region before the region grows by one ring of quads.
STEPS_PER_RING = 10
#: Rings of quads the free region may grow by around the folded quads.
MAX_RINGS = 3
#: More folded quads than this fraction of all (and than :data:`UNTANGLE_FLOOR`) are not
#: relaxed: on the wild, OpenSCAD and shared corpora at 2,000 quads, untangling succeeded
#: from at most 4 folded quads (0.2 %), and the 7 untanglings from 2.3 % and more (46 to
#: 829 folded quads) all failed, taking 62 s of the 86 s spent untangling.
UNTANGLE_FRACTION = 0.01
#: ... so few folded quads are always relaxed (a small mesh's one folded quad).
UNTANGLE_FLOOR = 4


def closest_surface_points(
    mesh: TriMesh, points: npt.ArrayLike, tree: cKDTree | None = None, exact: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Closest points of the input surface, among the triangles nearest each query point.

    Parameters
    ----------
    mesh : TriMesh
    points : array_like, float (k, 3)
    tree : cKDTree, optional
        A tree of ``mesh.face_centroids`` (built when not given).

    Returns
    -------
    faces : int64 (k,)
        The input triangle holding each closest point.
    closest : float64 (k, 3)
        The closest point on that triangle, searched among the ``min(CANDIDATES, m)``
        triangles whose centroids are nearest each query point and the triangles of the
        :data:`SAMPLE_CANDIDATES` nearest points of a dense sampling of the surface
        (:func:`surface_sample_tree`; long thin triangles, whose centroids lie far from
        most of their points, are found through it). With ``exact``, the closest point of
        the whole surface (two walls nearly equally close, as at a quad's centre inside a
        thin wall, are told apart): libigl's AABB tree when installed
        (:func:`surface_aabb`), else also among the triangles of every sample within the
        distance found plus the sampling's widest gap. The untangling's steps use the
        search, not the tree: it keeps a moved vertex near the triangles it was on, where
        the exact closest point can lie on the far side of a part thinner than a quad
        (the 750k armadillo at 20,000 quads with the tree in the steps: 104 quad vertices
        ended up to 1.2 quad edges elsewhere, the quads 1.5 quad edges from the input).
    """
    face, point, _ = _closest(mesh, points, tree, exact)
    return face, point


def _closest(
    mesh: TriMesh, points: npt.ArrayLike, tree: cKDTree | None, exact: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`closest_surface_points` and, with ``exact``, per point the triangle tied with
    the closest one whose normal turns most (:func:`_refine_closest`; else the closest)."""
    x = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    found = _aabb_closest(mesh, x) if exact else None  # the repair's steps stay local
    if found is not None:
        face, point = found
        return face, point, _refine_closest(mesh, x, face, point, *surface_sample_tree(mesh))
    if tree is None:
        tree = cKDTree(mesh.face_centroids)
    c = min(CANDIDATES, mesh.n_faces)
    samples, owner = surface_sample_tree(mesh)
    s = min(SAMPLE_CANDIDATES, owner.size)
    cand = np.concatenate(
        [
            tree.query(x, k=c)[1].reshape(x.shape[0], c),
            owner[samples.query(x, k=s)[1].reshape(x.shape[0], s)],
        ],
        axis=1,
    )  # (k, c + s)
    T = mesh.vertices[mesh.faces[cand]]  # (k, c + s, 3, 3)
    best = _closest_on_triangles(T, np.broadcast_to(x[:, None, :], T.shape[:2] + (3,)))
    d2 = np.einsum("kcd,kcd->kc", best - x[:, None, :], best - x[:, None, :])
    j = np.argmin(d2, axis=1)
    rows = np.arange(x.shape[0])
    face, point = cand[rows, j].astype(np.int64), best[rows, j]
    tied = _refine_closest(mesh, x, face, point, samples, owner) if exact else face
    return face, point, tied


def _aabb_closest(mesh: TriMesh, x: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The exact closest points of the surface to ``x`` (k, 3) by libigl's AABB tree
    (built once per mesh, :func:`surface_aabb`): (faces int64 (k,), points float64
    (k, 3)), or None when libigl is not installed or fails (the caller searches the
    candidates instead)."""
    built = surface_aabb(mesh)
    if built is None or x.shape[0] == 0:
        return None
    tree, V, F = built
    try:
        _, face, point = tree.squared_distance(V, F, x)
    except (RuntimeError, ValueError, TypeError):  # a binding's complaint: search instead
        return None
    return np.asarray(face, np.int64).reshape(-1), np.asarray(point, np.float64).reshape(-1, 3)


def surface_aabb(mesh: TriMesh) -> tuple[Any, np.ndarray, np.ndarray] | None:
    """libigl's axis-aligned bounding box tree of ``mesh`` (``igl.AABB``) with the
    vertices (float64 (n, 3)) and faces (int64 (m, 3)) it was built on and is queried
    with, built once and cached on the mesh; None when libigl
    (``pip install 'fvf[fast]'``) is missing or cannot build it. Exact closest points of
    5,000 points near a remeshed CSG box of 9,406 triangles take 0.11 s with it against
    0.25 s without (most of it the search for tied triangles after either:
    ``python benchmarks/bench_closest.py``)."""

    def build() -> tuple[Any, np.ndarray, np.ndarray] | None:
        try:
            import igl
        except ImportError:
            return None
        V = np.ascontiguousarray(mesh.vertices, np.float64)
        F = np.ascontiguousarray(mesh.faces, np.int64)
        try:
            tree = igl.AABB()
            tree.init(V, F)
        except (RuntimeError, ValueError, TypeError, AttributeError):
            return None
        return tree, V, F

    return mesh.cached("surface_aabb", build)


def _refine_closest(
    mesh: TriMesh,
    x: np.ndarray,
    face: np.ndarray,
    point: np.ndarray,
    samples: cKDTree,
    owner: np.ndarray,
) -> np.ndarray:
    """Replace, in place, ``face`` (k,) and ``point`` (k, 3) by the closest triangle among
    those with a sample within the found distance plus the widest sample gap (a closer
    triangle has a sample there). Returns, per query, the triangle as close to within
    :data:`TIE` (relative) whose normal turns farthest from the chosen one's, int64 (k,)
    (the chosen one where none is: a point on the mid-surface of a thin wall has both
    walls as closest points)."""
    tied = face.copy()
    radius = np.linalg.norm(point - x, axis=1) + _sample_gap(mesh)
    near = samples.query_ball_point(x, radius)
    query = np.repeat(np.arange(x.shape[0]), [len(n) for n in near])
    if query.size == 0:
        return tied
    m = np.int64(mesh.n_faces)
    key = np.unique(query * m + owner[np.concatenate(near).astype(np.int64)])  # (query, face)
    q, f = key // m, key % m
    best = _closest_on_triangles(mesh.vertices[mesh.faces[f]], x[q])
    d2 = np.einsum("kd,kd->k", best - x[q], best - x[q])
    order = np.lexsort((d2, q))
    win = order[np.unique(q[order], return_index=True)[1]]  # the nearest per query
    now = np.einsum("kd,kd->k", point - x, point - x)
    better = d2[win] < now[q[win]]
    face[q[win][better]] = f[win][better]
    point[q[win][better]] = best[win][better]
    low = np.full(x.shape[0], np.inf)
    np.minimum.at(low, q, d2)
    close = d2 <= low[q] * (1.0 + TIE) ** 2
    turn = np.einsum("kd,kd->k", mesh.face_normals[f], mesh.face_normals[face[q]])
    pick = np.lexsort((turn, ~close, q))  # per query: close ones first, most turned first
    first = pick[np.unique(q[pick], return_index=True)[1]]
    ok = close[first]
    tied[q[first][ok]] = f[first][ok]
    return tied


def _sample_gap(mesh: TriMesh) -> float:
    """The widest distance between neighbouring points of :func:`surface_sample_tree` on
    one triangle (its longest edge over its grid steps), the largest over the mesh."""
    longest, level = _sample_grid(mesh)
    return float((longest / level).max(initial=0.0))


def _sample_grid(mesh: TriMesh) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle's longest edge, float64 (m,), and the grid steps per side of its
    samples in :func:`surface_sample_tree`, int64 (m,)."""
    V, F = mesh.vertices, mesh.faces
    e = np.linalg.norm(V[F] - V[np.roll(F, -1, axis=1)], axis=2)
    step = min(float(np.median(e)), float(np.sqrt(mesh.total_area / 20_000)))
    longest = e.max(axis=1)
    return longest, np.clip(np.ceil(longest / max(step, 1e-300)).astype(np.int64), 1, 48)


def surface_sample_tree(mesh: TriMesh) -> tuple[cKDTree, np.ndarray]:
    """A k-d tree of points spread over every triangle, and the triangle of each point.

    Each triangle is sampled on a barycentric grid with ``ceil(longest edge / step)``
    steps per side (at most 48), step the smaller of the median edge and
    √(area / 20 000): a sliver gets points along its whole length, and a mesh of a few
    large triangles (a CAD box) points every ~1/140 of its size. Cached on the mesh.
    Returns (cKDTree, int64 (p,)).
    """

    def build() -> tuple[cKDTree, np.ndarray]:
        V, F = mesh.vertices, mesh.faces
        level = _sample_grid(mesh)[1]
        pts, owner = [mesh.face_centroids], [np.arange(F.shape[0])]
        for k in np.unique(level):  # a loop over a few subdivision levels
            sel = np.flatnonzero(level == k)
            i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
            keep = (i + j) <= k
            b = np.stack([1.0 - (i[keep] + j[keep]) / k, i[keep] / k, j[keep] / k], axis=1)
            P = np.einsum("sc,tcd->tsd", b, V[F[sel]])
            pts.append(P.reshape(-1, 3))
            owner.append(np.repeat(sel, b.shape[0]))
        return cKDTree(np.concatenate(pts)), np.concatenate(owner).astype(np.int64)

    return mesh.cached("surface_sample_tree", build)


def _closest_on_triangles(T: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Closest point of each triangle T[...] (..., 3 corners, 3) to x (..., 3)."""
    a, b, c = T[..., 0, :], T[..., 1, :], T[..., 2, :]
    e1, e2 = b - a, c - a
    r = x - a
    d11 = np.einsum("...d,...d->...", e1, e1)
    d12 = np.einsum("...d,...d->...", e1, e2)
    d22 = np.einsum("...d,...d->...", e2, e2)
    r1 = np.einsum("...d,...d->...", r, e1)
    r2 = np.einsum("...d,...d->...", r, e2)
    det = np.maximum(d11 * d22 - d12 * d12, 1e-300)
    s = (d22 * r1 - d12 * r2) / det
    t = (d11 * r2 - d12 * r1) / det
    inside = (s >= 0) & (t >= 0) & (s + t <= 1)
    best = a + s[..., None] * e1 + t[..., None] * e2
    dist = np.where(inside, 0.0, np.inf)  # distances compared only off the plane region
    for p, q in ((a, b), (b, c), (c, a)):  # the three edges
        e = q - p
        u = np.einsum("...d,...d->...", x - p, e) / np.maximum(
            np.einsum("...d,...d->...", e, e), 1e-300
        )
        y = p + np.clip(u, 0.0, 1.0)[..., None] * e
        dy = np.einsum("...d,...d->...", x - y, x - y)
        take = ~inside & (dy < dist)
        best = np.where(take[..., None], y, best)
        dist = np.where(take, dy, dist)
    return best


def quad_normals(vertices: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """n_q = (p_2 − p_0) × (p_3 − p_1), float64 (q, 3): twice each quad's vector area."""
    V, Q = vertices, quads
    return np.cross(V[Q[:, 2]] - V[Q[:, 0]], V[Q[:, 3]] - V[Q[:, 1]])


def centre_normals(mesh: TriMesh, points: np.ndarray, tree: cKDTree) -> np.ndarray:
    """The surface's side at each point, float64 (k, 3), unit: the sum of the area-weighted
    vertex normals of the input triangle closest to the point (smoother than that
    triangle's own normal, which on a crumpled scan may face the other way)."""
    face, _ = closest_surface_points(mesh, points, tree)
    return _vertex_sum_normals(mesh, face)


def _vertex_sum_normals(mesh: TriMesh, face: np.ndarray) -> np.ndarray:
    """Unit sums of the area-weighted vertex normals of the triangles ``face`` (k, 3)."""
    n = vertex_vector_areas(mesh)[mesh.faces[face]].sum(axis=1)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


def reference_normals(
    mesh: TriMesh,
    vertices: np.ndarray,
    quads: np.ndarray,
    tree: cKDTree,
    side: np.ndarray | None = None,
    face: np.ndarray | None = None,
) -> np.ndarray:
    """N_q of the module docstring, float64 (q, 3): the vector area of the input surface
    under each quad, on the side of the surface at its centre (not normalized); ``tree``
    holds ``mesh.face_centroids``; ``side`` (q, 3), the side at the quads' centres, and
    ``face`` (q,), the input triangle closest to them, when already known
    (:func:`_surface_at`).

    The closest triangle's share is its area within the ball (:func:`_area_in_ball`), the
    other triangles' their samples in it (:func:`surface_sample_tree`): a CAD face of
    100 mm has samples 2.3 mm apart, none of them within the ball of a 1.5 mm quad lying
    on it, which would leave that quad measured against the next face across an edge."""
    P = vertices[quads]
    c = P.mean(axis=1)
    rho = 0.5 * np.minimum(
        np.linalg.norm(P[:, 2] - P[:, 0], axis=1), np.linalg.norm(P[:, 3] - P[:, 1], axis=1)
    )
    if face is None:
        face = closest_surface_points(mesh, c, tree)[0]
    if side is None:
        side = _surface_at(mesh, c, tree, face)[0]
    samples, owner = surface_sample_tree(mesh)
    weight = mesh.face_areas / np.bincount(owner, minlength=mesh.n_faces)  # area per sample
    AN = weight[:, None] * mesh.face_normals
    own = _area_in_ball(mesh, face, c, rho)[:, None] * mesh.face_normals[face]
    out = np.empty((len(c), 3))
    for lo in range(0, len(c), BALL_CHUNK):  # the samples near a chunk of quads at a time
        at = slice(lo, lo + BALL_CHUNK)
        out[at] = _area_under(samples, owner, AN, c[at], rho[at], side[at], face[at], own[at])
    return out


def _area_in_ball(mesh: TriMesh, face: np.ndarray, c: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """Area of each triangle ``face`` (k,) within the ball of radius ``rho`` (k,) about
    ``c`` (k, 3), float64 (k,): the disk where the ball meets the triangle's plane, times
    the fraction of a fixed grid of it (:data:`DISK_GRID` points per side) inside the
    triangle."""
    T = mesh.vertices[mesh.faces[face]]  # (k, 3 corners, 3)
    n = mesh.face_normals[face]
    height = np.einsum("kd,kd->k", c - T[:, 0], n)
    centre = c - height[:, None] * n  # the disk's centre, in the plane
    r = np.sqrt(np.maximum(rho * rho - height * height, 0.0))
    e1 = T[:, 1] - T[:, 0]
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(n, e1)
    t = np.linspace(-1.0, 1.0, DISK_GRID)
    x, y = (a.ravel() for a in np.meshgrid(t, t))
    x, y = x[x * x + y * y <= 1.0], y[x * x + y * y <= 1.0]
    G = centre[:, None] + r[:, None, None] * (x[:, None] * e1[:, None] + y[:, None] * e2[:, None])
    inside = np.ones(G.shape[:2], dtype=bool)  # (k, g): on the inner side of all three edges
    for i in range(3):
        a, b = T[:, i], T[:, (i + 1) % 3]
        out = np.einsum("kd,kgd->kg", np.cross(b - a, n), G - a[:, None])
        inside &= out <= 1e-12 * np.einsum("kd,kd->k", b - a, b - a)[:, None]
    return np.pi * r * r * inside.mean(axis=1)


def _area_under(
    samples: cKDTree,
    owner: np.ndarray,
    AN: np.ndarray,
    c: np.ndarray,
    rho: np.ndarray,
    side: np.ndarray,
    face: np.ndarray,
    own: np.ndarray,
) -> np.ndarray:
    """N_q of quads centred at c (k, 3) with radii rho (k,), float64 (k, 3); AN (m, 3) the
    area vector of the surface per sample of each input triangle; ``own`` (k, 3) the area
    vector of the closest triangle ``face`` (k,) within the ball, which its samples do not
    add to."""
    near = samples.query_ball_point(c, rho)  # each quad's own radius: one large quad
    counts = np.fromiter((len(n) for n in near), np.int64, len(near))  # costs its own
    rows = np.repeat(np.arange(len(c)), counts)
    cols = owner[np.fromiter(chain.from_iterable(near), np.int64, int(counts.sum()))]
    del near
    same = np.einsum("kd,kd->k", AN[cols], side[rows]) > 0  # not the far wall of a thin part
    same &= cols != face[rows]
    rows, cols = rows[same], cols[same]
    out = np.stack(
        [np.bincount(rows, weights=AN[cols, k], minlength=len(c)) for k in range(3)], axis=1
    ).astype(np.float64)  # (no samples at all: bincount's integer zeros)
    counted = np.einsum("kd,kd->k", own, side) > 0
    out[counted] += own[counted]
    empty = np.flatnonzero((np.bincount(rows, minlength=len(c)) == 0) & ~counted)
    out[empty] = side[empty]
    return out


def _folded_over(mesh: TriMesh, face: np.ndarray, smooth: np.ndarray) -> np.ndarray:
    """bool (k,): input triangles ``face`` folded over against the surface around them —
    their normal against both ``smooth`` (their vertices' summed normals, (k, 3)) and the
    area-weighted normals of the triangles across their edges. (On a CAD part the vertex
    sums are not a reference: a vertex where a sliver of a cylinder meets a large planar
    face is dominated by that face, while the sliver's edge neighbours agree with it.)"""
    raw = mesh.face_normals[face]
    adj = mesh.face_adjacency[face]  # (k, 3), -1 on the boundary
    g = np.maximum(adj, 0)  # the neighbours' area vectors, gathered (not all m faces')
    area = np.where(adj >= 0, mesh.face_areas[g], 0.0)
    around = np.einsum("kj,kjd->kd", area, mesh.face_normals[g])
    return (np.einsum("kd,kd->k", raw, smooth) <= 0) & (np.einsum("kd,kd->k", raw, around) <= 0)


def _surface_at(
    mesh: TriMesh,
    points: np.ndarray,
    tree: cKDTree,
    face: np.ndarray | None = None,
    own: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Two normals of the surface at each point, from the closest input triangle (or the
    given ``face`` (k,)), unit (k, 3) each:

    - the side: its vertices' summed normals (:func:`centre_normals`), or its own normal
      where the two disagree and it is not folded over (:func:`_folded_over`);
    - the reference: its own normal, or (unless ``own``) its vertices' summed normals
      where it is folded over (a crumpled scan).
    """
    if face is None:
        face, _ = closest_surface_points(mesh, points, tree)
    raw = mesh.face_normals[face]
    smooth = _vertex_sum_normals(mesh, face)
    folded = _folded_over(mesh, face, smooth)
    disagree = np.einsum("kd,kd->k", raw, smooth) <= 0
    side = np.where((disagree & ~folded)[:, None], raw, smooth)
    return side, raw if own else np.where(folded[:, None], smooth, raw)


def _fold_mask(
    mesh: TriMesh, V: np.ndarray, Q: np.ndarray, tree: cKDTree, exact: bool = False
) -> np.ndarray:
    """bool (len(Q),): n_q · N_q ≤ 0, or no diagonal split whose halves both face N_q and
    the surface at the centre (module docstring); ``exact``: the surface at the centre's
    exact closest point, its own normal even where it is folded over, and folded when
    folded against either of two tied closest triangles (the verdict: at least as strict
    as a judge that takes the closest triangle's normal), else among nearby triangles
    (the repair's steps)."""
    centre = V[Q].mean(axis=1)
    if not exact:
        face = closest_surface_points(mesh, centre, tree)[0]
        return _folded_against(mesh, V, Q, tree, _surface_at(mesh, centre, tree, face), face)
    face, _, tied = _closest(mesh, centre, tree, exact=True)
    at = _surface_at(mesh, centre, tree, face, own=True)
    mask = _folded_against(mesh, V, Q, tree, at, face)
    two = np.flatnonzero(tied != face)
    if two.size:
        at = _surface_at(mesh, centre[two], tree, tied[two], own=True)
        mask[two] |= _folded_against(mesh, V, Q[two], tree, at, tied[two])
    return mask


def _folded_against(
    mesh: TriMesh,
    V: np.ndarray,
    Q: np.ndarray,
    tree: cKDTree,
    surface: tuple[np.ndarray, np.ndarray],
    face: np.ndarray,
) -> np.ndarray:
    """The test of :func:`_fold_mask` for the surface normals (side, reference) at the
    quads' centres, the input triangle ``face`` (q,) under each."""
    P = V[Q]
    side, Nc = surface
    N = reference_normals(mesh, V, Q, tree, side, face)

    def faces_up(a: int, b: int, c: int) -> np.ndarray:
        n = np.cross(P[:, b] - P[:, a], P[:, c] - P[:, a])
        return (np.einsum("qd,qd->q", n, N) > 0) & (np.einsum("qd,qd->q", n, Nc) > 0)

    split = (faces_up(0, 1, 2) & faces_up(0, 2, 3)) | (faces_up(1, 2, 3) & faces_up(1, 3, 0))
    return (np.einsum("qd,qd->q", quad_normals(V, Q), N) <= 0) | ~split


@takes_mesh
def folded_quads(mesh: TriMesh, vertices: npt.ArrayLike, quads: npt.ArrayLike) -> np.ndarray:
    """The quads folded in 3D against the input surface (module docstring).

    Parameters
    ----------
    mesh : TriMesh
        The input triangle mesh (outward-oriented).
    vertices : array_like, float (k, 3)
        Quad vertices, on or near the input surface.
    quads : array_like, int (q, 4)
        Counter-clockwise about the input's outward normal.

    Returns
    -------
    int64 (f,)
        Sorted indices of the quads whose normal
        :math:`n_q = (p_2 - p_0) \\times (p_3 - p_1)` has a non-positive dot product with
        the vector area of the input surface around the quad (:func:`reference_normals`).
    """
    V = np.asarray(vertices, dtype=np.float64)
    Q = np.asarray(quads, dtype=np.int64)
    mask = _fold_mask(mesh, V, Q, cKDTree(mesh.face_centroids), exact=True)
    return np.flatnonzero(mask).astype(np.int64)


@dataclass(frozen=True)
class FoldRepair:
    """The result of :func:`untangle_quads`.

    Attributes
    ----------
    vertices : float64 (k, 3)
        Quad vertices; those in ``moved`` relaxed and put back on the input surface.
    vertex_face : int64 (k,)
        Input triangle holding each vertex.
    folded_before : int64 (f0,)
        Quads folded on entry by the first pass's test (by :func:`folded_quads` with
        ``passes="verdict"``).
    folded : int64 (f,)
        Quads still folded (empty when the repair succeeded).
    moved : int64 (r,)
        Vertices that moved.
    displacement : float64 (r,)
        How far each moved vertex went (3D distance from its extracted position).
    steps : int
        Relaxation steps taken.
    verdict : int64 (v,) or None
        The quads :func:`folded_quads` calls folded at ``vertices``, when the repair
        evaluated it there (None when it did not: the first pass failed, ``max_steps``
        is 0, or ``passes="first"``); the validity gate takes it instead of evaluating it
        again.
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    vertices: np.ndarray
    vertex_face: np.ndarray
    folded_before: np.ndarray
    folded: np.ndarray
    moved: np.ndarray
    displacement: np.ndarray
    steps: int
    verdict: np.ndarray | None = None


def _quad_edge_adjacency(n_vertices: int, Q: np.ndarray) -> sp.csr_matrix:
    """Vertex adjacency along quad edges: symmetric 0/1 csr (k, k)."""
    i = Q.ravel()
    j = np.roll(Q, -1, axis=1).ravel()
    A = sp.coo_matrix((np.ones(2 * i.size), (np.r_[i, j], np.r_[j, i])), (n_vertices,) * 2)
    A = A.tocsr()
    A.data[:] = 1.0
    return A


def _relax_step(
    mesh: TriMesh,
    V: np.ndarray,
    vf: np.ndarray,
    A: sp.csr_matrix,
    free: np.ndarray,
    tree: cKDTree,
) -> None:
    """One tangential Laplacian step of the free vertices, projected onto the surface."""
    Af = A[free]
    mean = (Af @ V) / np.asarray(Af.sum(axis=1)).reshape(-1, 1)
    d = mean - V[free]
    N = mesh.face_normals[vf[free]]
    d -= np.einsum("kd,kd->k", d, N)[:, None] * N
    f, p = closest_surface_points(mesh, V[free] + RELAX_STEP * d, tree)
    V[free] = p
    vf[free] = f


def untangle_quads(
    mesh: TriMesh,
    vertices: npt.ArrayLike,
    quads: npt.ArrayLike,
    vertex_face: npt.ArrayLike,
    *,
    max_steps: int = STEPS_PER_RING * (MAX_RINGS + 1),
    passes: Passes = "both",
) -> FoldRepair:
    """Unfold folded quads by relaxing their corners on the input surface (module docstring).

    Parameters
    ----------
    mesh : TriMesh
        The input triangle mesh.
    vertices : array_like, float (k, 3)
        Quad vertices on the input surface (not modified).
    quads : array_like, int (q, 4)
        Counter-clockwise about the input's outward normal; unchanged by the repair.
    vertex_face : array_like, int (k,)
        Input triangle holding each vertex (:attr:`fvf.QuadMesh.vertex_face`).
    max_steps : int
        Relaxation steps at most per pass (0: detect only). The free region starts at the
        corners of the folded quads and grows by one ring of quads every
        :data:`STEPS_PER_RING` steps, at most :data:`MAX_RINGS` times. None are taken when
        more than :data:`UNTANGLE_FRACTION` of the quads (and more than
        :data:`UNTANGLE_FLOOR`) are folded: relaxing does not unfold that many.
    passes : {"both", "first", "verdict"}
        The passes to run (Notes): ``"first"`` for quads that are then put on another
        surface and judged there, ``"verdict"`` for quads already untangled on another
        surface and put on this one (the first pass's reference could move quads there
        that the verdict accepts; ``folded_before`` and ``folded`` are then the
        verdict's).

    Returns
    -------
    FoldRepair
        When quads stay folded after ``max_steps``, the input positions are returned
        unchanged with the folds found on entry (relaxing a growing region can unfold some
        quads by crushing others: a torus with its quads wound backwards ends with a third
        of them "unfolded" and the rest still folded).

    Notes
    -----
    The first pass stops when no quad is folded by the repair's reference (on a crumpled
    input, the summed vertex normals where the closest triangle is folded over). A
    second pass then relaxes the quads the verdict :func:`folded_quads` still calls
    folded (the closest triangle's own normal, or either of two tied ones), and is kept
    only when it leaves none: the quads the gate would refuse get the same repair as
    those the first pass sees.
    """
    if passes not in ("both", "first", "verdict"):
        raise ParameterError(f"passes must be 'both', 'first' or 'verdict'; got {passes!r}")
    V0 = np.asarray(vertices, dtype=np.float64)
    Q = np.asarray(quads, dtype=np.int64)
    vf0 = np.asarray(vertex_face, dtype=np.int64)
    tree = cKDTree(mesh.face_centroids)
    exact = passes == "verdict"  # the verdict's test is then the only pass's
    mask = _fold_mask(mesh, V0, Q, tree, exact=exact)
    before = np.flatnonzero(mask)
    V, vf = V0.copy(), vf0.copy()
    steps = _relax_folded(mesh, V, vf, Q, mask, tree, max_steps, exact=exact)
    after = np.flatnonzero(mask)
    verdict = after if exact else None
    if after.size:  # all or nothing: a partial untangling may have smeared a whole region
        V, vf, after = V0.copy(), vf0.copy(), before
        verdict = before if exact else None
    elif max_steps > 0 and passes == "both":  # the verdict's folds, in a second pass
        strict = _fold_mask(mesh, V, Q, tree, exact=True)
        verdict = np.flatnonzero(strict)
        W, wf = V.copy(), vf.copy()
        more = _relax_folded(mesh, W, wf, Q, strict, tree, max_steps, exact=True)
        if more and not strict.any():
            V, vf, steps, verdict = W, wf, steps + more, verdict[:0]
    disp = np.linalg.norm(V - V0, axis=1)
    moved = np.flatnonzero(disp > 0).astype(np.int64)
    return FoldRepair(V, vf, before, after, moved, disp[moved], steps, verdict)


def _relax_folded(
    mesh: TriMesh,
    V: np.ndarray,
    vf: np.ndarray,
    Q: np.ndarray,
    mask: np.ndarray,
    tree: cKDTree,
    max_steps: int,
    exact: bool,
) -> int:
    """Relax the corners of the quads ``mask`` (bool (q,), updated in place) in ``V``
    (k, 3) and ``vf`` (k,) (in place) until none is folded by :func:`_fold_mask` with
    ``exact``, the region growing by a ring of quads every :data:`STEPS_PER_RING` steps;
    the steps taken (none when too many are folded, :data:`UNTANGLE_FRACTION`)."""
    folded = int(mask.sum())
    if not folded or max_steps <= 0 or folded > max(UNTANGLE_FLOOR, UNTANGLE_FRACTION * len(Q)):
        return 0
    A = _quad_edge_adjacency(V.shape[0], Q)
    inc = sp.csr_matrix(
        (np.ones(Q.size), (Q.ravel(), np.repeat(np.arange(Q.shape[0]), 4))),
        shape=(V.shape[0], Q.shape[0]),
    )
    free = np.unique(Q[mask])
    steps = 0
    for ring in range(MAX_RINGS + 1):
        watched = np.unique(inc[free].indices)
        for _ in range(STEPS_PER_RING):
            if steps >= max_steps or not mask.any():
                break
            _relax_step(mesh, V, vf, A, free, tree)
            mask[watched] = _fold_mask(mesh, V, Q[watched], tree, exact=exact)
            steps += 1
        if steps >= max_steps or not mask.any() or ring == MAX_RINGS:
            break
        free = np.unique(Q[watched])  # one more ring of quads
    return steps


def warn_folded(repair: FoldRepair) -> None:
    """Warn with :class:`fvf.FoldedQuadWarning` naming the quads still folded, if any.

    Parameters
    ----------
    repair : FoldRepair
        The result of :func:`untangle_quads`.
    """
    if repair.folded.size:
        warnings.warn(
            FoldedQuadWarning(
                f"quads {format_indices(repair.folded)} are folded in 3D (their normal faces "
                "away from the input surface) after untangling on the surface; ask for more "
                "quads (a larger target_faces or a smaller edge_length) so that the surface "
                "turns less within one quad"
            ),
            stacklevel=user_stacklevel(),
        )
