r"""An independent judge of quad meshes: is ``(Vq, Q)`` a valid quad mesh of ``(V, F)``?

Written with numpy and scipy only, sharing no code with fvf (not ``fvf.quad_quality`` nor
``fvf.param.quadfolds``), so that it can judge fvf's quad mesher and its peers alike.

:func:`check` returns a :class:`Verdict`; the mesh is valid when every one of these holds:

- ``pure_quads``: ``Q`` is an integer array (k, 4), k ≥ 1, and ``Vq`` finite (n, 3);
- ``indices``: every index in ``[0, n)``;
- ``no_degenerate``: no quad repeats a corner index or puts two corners at one point;
- ``edge_manifold``: every undirected edge is used by one or two quads;
- ``vertex_manifold``: the quads at each vertex form one fan (joined across edges);
- ``oriented``: no directed edge is used twice (so each interior edge is traversed once
  each way);
- ``euler``: :math:`\chi = V - E + F` (over used vertices) equals the input's;
- ``components``: as many connected components as the input;
- ``boundary_loops``: as many boundary loops as the input;
- ``no_folds``: no folded quad. A quad is folded when neither diagonal splits it into two
  triangles whose normals both have a positive dot product with the input's normal at the
  input point closest to the quad's centre, found exactly (:meth:`SurfaceDistance.normal`;
  a flipped quad and a bow tie are folded; a simple non-convex quad is not);
- ``hausdorff``: the two-sided Hausdorff distance between the surfaces (quads split along
  a diagonal), measured from points covering each surface (:func:`cover`: vertices, edge
  points and a grid of spacing at most a quarter quad edge) exactly to the nearest
  triangles of the other, is at most one mean quad edge.

:func:`metrics` adds the quality numbers of a benchmark: irregular vertices, corner
angles, and the coverage of the input's sharp edges by quad edges.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import chain

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

__all__ = ["Verdict", "Topology", "topology", "check", "metrics", "SurfaceDistance", "cover"]

CHECKS = (
    "pure_quads",
    "indices",
    "no_degenerate",
    "edge_manifold",
    "vertex_manifold",
    "oriented",
    "euler",
    "components",
    "boundary_loops",
    "no_folds",
    "hausdorff",
)


@dataclass
class Topology:
    """Connectivity facts of a polygon mesh with faces of one size (triangles or quads)."""

    n_used: int  # vertices used by a face
    n_edges: int
    n_faces: int
    chi: int
    components: int
    boundary_loops: int
    edge_uses_max: int  # the most faces on one undirected edge
    duplicated_directed: int  # directed edges used more than once
    pinched_vertices: int  # vertices whose faces form more than one fan
    valence: np.ndarray  # int64 (n,), undirected edges at each vertex
    on_boundary: np.ndarray  # bool (n,)


@dataclass
class Verdict:
    """What :func:`check` found. ``valid`` is the conjunction of ``checks``; ``reasons``
    says in words which ones failed."""

    valid: bool
    checks: dict[str, bool]
    reasons: list[str]
    n_quads: int = 0
    n_vertices: int = 0
    n_unreferenced: int = 0
    chi: int | None = None
    chi_input: int | None = None
    components: int | None = None
    components_input: int | None = None
    boundary_loops: int | None = None
    boundary_loops_input: int | None = None
    n_folded: int = 0
    folded: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    mean_edge: float = float("nan")
    hausdorff: float = float("nan")  # absolute
    hausdorff_rel: float = float("nan")  # over the mean quad edge

    def summary(self) -> str:
        return "valid" if self.valid else "; ".join(self.reasons)


# ---------------------------------------------------------------------------- topology
def _graph_components(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    A = coo_matrix((np.ones(a.size), (a, b)), shape=(n, n))
    return connected_components(A, directed=False)[1]


def topology(n_vertices: int, P: np.ndarray) -> Topology:
    """Topology of faces ``P`` int (m, k) over ``n_vertices`` vertices (valid indices)."""
    m, k = P.shape
    nxt = np.roll(np.arange(k), -1)
    D = np.stack([P, P[:, nxt]], -1).reshape(-1, 2)  # directed edges, corner-major
    U = np.sort(D, axis=1)
    uE, inv, uses = np.unique(U, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    dup = np.unique(D, axis=0, return_counts=True)[1]
    used = np.zeros(n_vertices, bool)
    used[P.ravel()] = True
    lab = _graph_components(n_vertices, uE[:, 0], uE[:, 1])
    bnd = uE[uses == 1]
    on_b = np.zeros(n_vertices, bool)
    on_b[bnd.ravel()] = True
    loops = 0
    if bnd.size:
        bl = _graph_components(n_vertices, bnd[:, 0], bnd[:, 1])
        loops = np.unique(bl[on_b]).size
    return Topology(
        n_used=int(used.sum()),
        n_edges=int(uE.shape[0]),
        n_faces=m,
        chi=int(used.sum() - uE.shape[0] + m),
        components=int(np.unique(lab[used]).size),
        boundary_loops=int(loops),
        edge_uses_max=int(uses.max()) if uses.size else 0,
        duplicated_directed=int((dup > 1).sum()),
        pinched_vertices=_pinched(n_vertices, P, inv, uses),
        valence=np.bincount(uE.ravel(), minlength=n_vertices),
        on_boundary=on_b,
    )


def _pinched(n: int, P: np.ndarray, edge_of: np.ndarray, uses: np.ndarray) -> int:
    """Vertices whose face corners fall into more than one fan (corners joined when
    their faces share an edge at that vertex)."""
    m, k = P.shape
    c = np.arange(m * k)  # corner id = face * k + slot; edge slot s runs corner s -> s+1
    nxt = (c // k) * k + (c % k + 1) % k
    order = np.argsort(edge_of, kind="stable")
    e_sorted = edge_of[order]
    first = np.r_[True, e_sorted[1:] != e_sorted[:-1]]
    start = np.flatnonzero(first)
    pair = start[uses[e_sorted[start]] == 2]
    h1, h2 = order[pair], order[pair + 1]  # the two half-edges (as corner slots) of an edge
    # join the corners at the same vertex: tail of one with head of the other (or tails
    # together when the faces disagree in orientation)
    a_tail, a_head = h1, nxt[h1]
    b_tail, b_head = h2, nxt[h2]
    same = P.ravel()[a_tail] == P.ravel()[b_tail]
    j1 = np.where(same, b_tail, b_head)
    j2 = np.where(same, b_head, b_tail)
    lab = _graph_components(m * k, np.r_[a_tail, a_head], np.r_[j1, j2])
    vert_fan = np.unique(np.stack([P.ravel(), lab], 1), axis=0)
    fans = np.bincount(vert_fan[:, 0], minlength=n)
    return int((fans > 1).sum())


# ---------------------------------------------------------------------------- distances
def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (k, 3) arrays (np.cross without its overhead)."""
    out = np.empty_like(a)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def _point_segment(P: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
    AB = B - A
    t = np.einsum("ij,ij->i", P - A, AB) / np.maximum(np.einsum("ij,ij->i", AB, AB), 1e-300)
    t = np.clip(t, 0.0, 1.0)
    return np.linalg.norm(P - (A + t[:, None] * AB), axis=1)


def _point_triangle(P: np.ndarray, A: np.ndarray, B: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Exact distance of points P (k, 3) to triangles (A, B, C) (k, 3 each), degenerate
    triangles included (then the distance to their edges)."""
    n = _cross(B - A, C - A)
    nn = np.einsum("ij,ij->i", n, n)
    ok = nn > 1e-30 * np.maximum(np.einsum("ij,ij->i", B - A, B - A), 1e-300) ** 2
    d = np.minimum(_point_segment(P, A, B), _point_segment(P, B, C))
    d = np.minimum(d, _point_segment(P, C, A))
    s = np.where(ok, np.einsum("ij,ij->i", P - A, n) / np.where(ok, nn, 1.0), 0.0)
    X = P - s[:, None] * n  # projection onto the plane
    inside = ok.copy()
    for U, W in ((A, B), (B, C), (C, A)):
        inside &= np.einsum("ij,ij->i", _cross(W - U, X - U), n) >= 0
    plane = np.abs(s) * np.sqrt(nn)
    return np.where(inside, np.minimum(plane, d), d)


class SurfaceDistance:
    """Distances to a triangle surface ``(V, T)``: a k-d tree of points covering every
    triangle (:func:`cover`, spacing ``h``) picks candidate triangles, then the exact
    point-triangle distance decides. The result is exact when the closest triangle is
    among the candidates, and otherwise too large by at most about 1.2 h."""

    def __init__(self, V: np.ndarray, T: np.ndarray, h: float):
        self.V, self.T, self.h = V, T, h
        self.points, owner = cover(V, T, h)
        self.tree, self.owner = cKDTree(self.points), owner
        self.cross = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
        self.scale = float(np.ptp(V, axis=0).max()) or 1.0

    def _candidates(self, P: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """(distances (p, k), triangles (p, k)) of the k candidate triangles per point."""
        k = min(k, self.owner.size)
        _, idx = self.tree.query(P, k=k)
        cand = self.owner[idx.reshape(P.shape[0], k)]
        rows = np.repeat(np.arange(P.shape[0]), k)
        tri = self.T[cand.ravel()]
        d = _point_triangle(P[rows], self.V[tri[:, 0]], self.V[tri[:, 1]], self.V[tri[:, 2]])
        return d.reshape(P.shape[0], k), cand

    def distance(self, P: np.ndarray, k: int = 4) -> np.ndarray:
        """Distance (p,) of points P (p, 3) to the surface."""
        return self._candidates(P, k)[0].min(axis=1)

    def normal(self, P: np.ndarray) -> np.ndarray:
        """Unit normal (p, 3) of the surface at the point closest to each of P (p, 3): the
        area-weighted mean over the triangles tied for closest (an edge or a vertex),
        so that zero-area triangles and sharp edges give a defined normal.

        Exact: the closest triangle is at most as far as the nearest cover point (d_c) and
        has a cover point within its distance plus the cover's gap (< 2 h), so every
        triangle owning a cover point within d_c + 2 h is a candidate. (The k nearest
        cover points are not enough: next to a large triangle, the cover points of a
        small far one can be nearer than any of the large one's.)"""
        d_c, _ = self.tree.query(P)
        near = self.tree.query_ball_point(P, d_c + 2.0 * self.h)
        counts = np.fromiter((len(n) for n in near), np.int64, len(near))
        rows = np.repeat(np.arange(P.shape[0]), counts)
        points = np.fromiter(chain.from_iterable(near), np.int64, int(counts.sum()))
        pairs = np.unique(np.stack([rows, self.owner[points]], 1), axis=0)
        rows, cand = pairs[:, 0], pairs[:, 1]
        tri = self.T[cand]
        d = _point_triangle(P[rows], self.V[tri[:, 0]], self.V[tri[:, 1]], self.V[tri[:, 2]])
        best = np.full(P.shape[0], np.inf)
        np.minimum.at(best, rows, d)
        tie = d <= best[rows] + 1e-9 * self.scale
        N = np.stack(
            [np.bincount(rows[tie], self.cross[cand[tie], k], P.shape[0]) for k in range(3)], 1
        )
        return N / np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-300)


def cover(V: np.ndarray, T: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Points within about 1.2 h of every point of the triangles ``T``, each triangle's own
    points within that of all of its points: per triangle its corners, points every h
    along its sides, and the points inside it of a grid of step h laid in its own frame
    (x along its longest edge, so slivers cost their length over h, not its square).
    Returns (points (p, 3), owning triangle int64 (p,)); a vertex or a side shared by
    several triangles is sampled once per triangle."""
    m = T.shape[0]
    C = V[T]  # (m, 3, 3)
    lengths = np.linalg.norm(C[:, [1, 2, 0]] - C, axis=2)
    r = np.argmax(lengths, axis=1)
    rows = np.arange(m)[:, None]
    C = C[rows, (r[:, None] + np.arange(3)) % 3]  # corner 0 -> 1 is the longest edge
    L = lengths[np.arange(m), r]
    ex = (C[:, 1] - C[:, 0]) / np.maximum(L, 1e-300)[:, None]
    w = C[:, 2] - C[:, 0]
    cx = np.einsum("ij,ij->i", w, ex)
    ey = w - cx[:, None] * ex
    H = np.linalg.norm(ey, axis=1)
    ey /= np.maximum(H, 1e-300)[:, None]
    nx = np.ceil(L / h).astype(np.int64)
    ny = np.where(H > 0, np.ceil(H / h), 0).astype(np.int64)
    cnt = nx * ny
    tri = np.repeat(np.arange(m), cnt)
    k = np.arange(tri.size) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    x = (k // ny[tri] + 0.5) / nx[tri] * L[tri]
    y = (k % ny[tri] + 0.5) / ny[tri] * H[tri]
    inside = (y * cx[tri] <= x * H[tri]) & (y * (L - cx)[tri] <= (L[tri] - x) * H[tri])
    tri, x, y = tri[inside], x[inside], y[inside]
    grid = C[tri, 0] + x[:, None] * ex[tri] + y[:, None] * ey[tri]
    # every side of every triangle, owned by that triangle (a side shared by two triangles
    # is sampled twice): a sliver's grid row misses its tips, and the points of a side
    # owned by the neighbour alone left parts of it more than 2 h from any point it owns
    E = np.stack([T, np.roll(T, -1, axis=1)], -1).reshape(-1, 2)  # (3m, 2) sides
    ne = np.ceil(np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1) / h).astype(np.int64)
    ne = np.maximum(ne - 1, 0)
    eid = np.repeat(np.arange(E.shape[0]), ne)  # points strictly inside, every <= h
    t = (np.arange(eid.size) - np.repeat(np.cumsum(ne) - ne, ne) + 1.0) / (ne[eid] + 1.0)
    on_edges = V[E[eid, 0]] + t[:, None] * (V[E[eid, 1]] - V[E[eid, 0]])
    pts = np.concatenate([V[T.ravel()], on_edges, grid])
    own = np.concatenate([np.arange(3 * m) // 3, eid // 3, tri])
    return pts, own


def _split(Q: np.ndarray) -> np.ndarray:
    """Two triangles per quad along the 0-2 diagonal, (2k, 3)."""
    return np.concatenate([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]])


# ---------------------------------------------------------------------------- the verdict
def _shape_ok(Vq, Q) -> tuple[bool, str]:
    Vq, Q = np.asarray(Vq), np.asarray(Q)
    if Q.ndim != 2 or Q.shape[1] != 4 or Q.shape[0] == 0:
        return False, f"not a (k, 4) quad array: shape {Q.shape}"
    if not np.issubdtype(Q.dtype, np.integer):
        return False, f"quad indices of dtype {Q.dtype}"
    if Vq.ndim != 2 or Vq.shape[1] != 3 or not np.isfinite(Vq).all():
        return False, f"vertices not finite (n, 3): shape {Vq.shape}"
    return True, ""


def check(V, F, Vq, Q, *, n_samples: int = 20_000) -> Verdict:
    """Judge the quad mesh ``(Vq, Q)`` against the triangle mesh ``(V, F)``.

    Parameters
    ----------
    V : float (n, 3); F : int (m, 3)
        The input surface (welded; open, several parts allowed).
    Vq : float (k, 3); Q : int (q, 4)
        The quad mesh to judge.
    n_samples : int
        About how many points cover each surface (:func:`cover`) for the Hausdorff
        distance; more where needed for a spacing of at most a quarter quad edge.

    Returns
    -------
    Verdict
    """
    checks = dict.fromkeys(CHECKS, False)
    ok, why = _shape_ok(Vq, Q)
    if not ok:
        return Verdict(False, checks, [why])
    V, F = np.asarray(V, np.float64), np.asarray(F, np.int64)
    Vq, Q = np.asarray(Vq, np.float64), np.asarray(Q, np.int64)
    checks["pure_quads"] = True
    reasons: list[str] = []
    n = Vq.shape[0]
    if Q.min() < 0 or Q.max() >= n:
        return Verdict(False, checks, [f"quad indices outside [0, {n})"], n_quads=Q.shape[0])
    checks["indices"] = True
    v = Verdict(False, checks, reasons, n_quads=Q.shape[0], n_vertices=n)
    _check_topology(v, V, F, Vq, Q)
    _check_geometry(v, V, F, Vq, Q, n_samples)
    v.valid = all(checks.values())
    return v


def _check_topology(v: Verdict, V, F, Vq, Q) -> None:
    checks, reasons = v.checks, v.reasons
    S = np.sort(Q, axis=1)
    rep = (S[:, 1:] == S[:, :-1]).any(axis=1)
    scale = float(np.ptp(V, axis=0).max()) or 1.0
    edge = np.linalg.norm(Vq[np.roll(Q, -1, axis=1)] - Vq[Q], axis=2)
    coinc = (
        (edge <= 1e-12 * scale).any(axis=1)
        | (np.linalg.norm(Vq[Q[:, 0]] - Vq[Q[:, 2]], axis=1) <= 1e-12 * scale)
        | (np.linalg.norm(Vq[Q[:, 1]] - Vq[Q[:, 3]], axis=1) <= 1e-12 * scale)
    )
    checks["no_degenerate"] = not (rep | coinc).any()
    if not checks["no_degenerate"]:
        reasons.append(f"{int((rep | coinc).sum())} degenerate quads (repeated corner)")
    t, ti = topology(Vq.shape[0], Q), topology(V.shape[0], F)
    v.n_unreferenced = Vq.shape[0] - t.n_used
    checks["edge_manifold"] = t.edge_uses_max <= 2
    if not checks["edge_manifold"]:
        reasons.append(f"an edge is used by {t.edge_uses_max} quads")
    checks["vertex_manifold"] = t.pinched_vertices == 0
    if t.pinched_vertices:
        reasons.append(f"{t.pinched_vertices} pinched vertices (several fans)")
    checks["oriented"] = t.duplicated_directed == 0
    if t.duplicated_directed:
        reasons.append(f"{t.duplicated_directed} directed edges used twice (orientation)")
    v.chi, v.chi_input = t.chi, ti.chi
    v.components, v.components_input = t.components, ti.components
    v.boundary_loops, v.boundary_loops_input = t.boundary_loops, ti.boundary_loops
    for key, got, want in (
        ("euler", t.chi, ti.chi),
        ("components", t.components, ti.components),
        ("boundary_loops", t.boundary_loops, ti.boundary_loops),
    ):
        checks[key] = got == want
        if got != want:
            reasons.append(f"{key.replace('_', ' ')} {got} != input's {want}")


def _spacing(V: np.ndarray, T: np.ndarray, n: int, h_max: float) -> float:
    area = 0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1)
    h = min(float(np.sqrt(2.0 * area.sum() / n)), h_max)
    return h if h > 0 else 1e-3 * max(float(np.ptp(V, axis=0).max()), 1e-300)


def _check_geometry(v: Verdict, V, F, Vq, Q, n_samples: int) -> None:
    checks, reasons = v.checks, v.reasons
    v.mean_edge = float(np.linalg.norm(Vq[np.roll(Q, -1, axis=1)] - Vq[Q], axis=2).mean())
    T = _split(Q)
    h_max = 0.25 * v.mean_edge
    to_input = SurfaceDistance(V, F, _spacing(V, F, n_samples, h_max))
    P = Vq[Q]
    nrm = to_input.normal(P.mean(axis=1))

    def positive(i: int, j: int, k: int) -> np.ndarray:
        c = np.cross(P[:, j] - P[:, i], P[:, k] - P[:, i])
        return np.einsum("ij,ij->i", c, nrm) > 0

    split02 = positive(0, 1, 2) & positive(0, 2, 3)
    split13 = positive(1, 2, 3) & positive(1, 3, 0)
    folded = np.flatnonzero(~(split02 | split13))
    v.folded, v.n_folded = folded, int(folded.size)
    checks["no_folds"] = folded.size == 0
    if folded.size:
        reasons.append(f"{folded.size} folded quads")
    to_quads = SurfaceDistance(Vq, T, _spacing(Vq, T, n_samples, h_max))
    d_out = to_input.distance(to_quads.points)
    d_in = to_quads.distance(to_input.points)
    v.hausdorff = float(max(d_out.max(), d_in.max()))
    v.hausdorff_rel = v.hausdorff / v.mean_edge if v.mean_edge > 0 else float("inf")
    checks["hausdorff"] = v.hausdorff_rel <= 1.0
    if not checks["hausdorff"]:
        reasons.append(f"Hausdorff {v.hausdorff_rel:.2f} quad edges (> 1)")


# ---------------------------------------------------------------------------- quality
def metrics(V, F, Vq, Q, *, sharp_degrees: float = 30.0) -> dict[str, float]:
    """Quality of a quad mesh (any quad mesh with valid indices).

    Returns
    -------
    dict
        ``irregular``: fraction of used vertices that are irregular (interior valence ≠ 4,
        boundary valence ∉ {2, 3}); ``angle_median``, ``angle_p95``: |corner angle − 90°|
        in degrees over all corners; ``feature_coverage``: fraction of the length of the
        input's sharp edges (dihedral angle > ``sharp_degrees``) lying within a quarter of
        the mean quad edge of some quad edge (NaN without sharp edges); ``sharp_length``.
    """
    V, F = np.asarray(V, np.float64), np.asarray(F, np.int64)
    Vq, Q = np.asarray(Vq, np.float64), np.asarray(Q, np.int64)
    t = topology(Vq.shape[0], Q)
    used = np.zeros(Vq.shape[0], bool)
    used[Q.ravel()] = True
    interior_bad = ~t.on_boundary & (t.valence != 4)
    boundary_bad = t.on_boundary & ~np.isin(t.valence, (2, 3))
    irregular = float(((interior_bad | boundary_bad) & used).sum() / max(used.sum(), 1))
    P = Vq[Q]
    a = np.roll(P, 1, axis=1) - P
    b = np.roll(P, -1, axis=1) - P
    cos = np.einsum("ijk,ijk->ij", a, b) / np.maximum(
        np.linalg.norm(a, axis=2) * np.linalg.norm(b, axis=2), 1e-300
    )
    dev = np.abs(np.degrees(np.arccos(np.clip(cos, -1, 1))) - 90.0).ravel()
    h = float(np.linalg.norm(b, axis=2).mean())
    cover, length = _feature_coverage(V, F, Vq, Q, 0.25 * h, sharp_degrees)
    return {
        "irregular": irregular,
        "angle_median": float(np.median(dev)),
        "angle_p95": float(np.percentile(dev, 95)),
        "feature_coverage": cover,
        "sharp_length": length,
    }


def sharp_edges(V: np.ndarray, F: np.ndarray, degrees: float = 30.0) -> np.ndarray:
    """Interior edges (e, 2) whose two faces' normals differ by more than ``degrees``."""
    D = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    face = np.tile(np.arange(F.shape[0]), 3)
    U = np.sort(D, axis=1)
    uE, inv, cnt = np.unique(U, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    order = np.argsort(inv, kind="stable")
    first = np.r_[True, inv[order][1:] != inv[order][:-1]]
    start = np.flatnonzero(first)
    two = start[cnt[inv[order][start]] == 2]
    f1, f2 = face[order[two]], face[order[two + 1]]
    N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N /= np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-300)
    cos = np.einsum("ij,ij->i", N[f1], N[f2])
    return uE[inv[order[two]]][cos < np.cos(np.radians(degrees))]


def _feature_coverage(V, F, Vq, Q, tol: float, degrees: float) -> tuple[float, float]:
    E = sharp_edges(V, F, degrees)
    if E.shape[0] == 0:
        return float("nan"), 0.0
    A, B = V[E[:, 0]], V[E[:, 1]]
    L = np.linalg.norm(B - A, axis=1)
    k = np.maximum(np.ceil(L / (0.5 * tol)).astype(np.int64), 1)  # samples per edge
    eid = np.repeat(np.arange(E.shape[0]), k)
    pos = (np.arange(eid.size) - np.repeat(np.cumsum(k) - k, k) + 0.5) / k[eid]
    S = A[eid] + pos[:, None] * (B - A)[eid]
    QE = np.unique(np.sort(np.stack([Q, np.roll(Q, -1, axis=1)], -1).reshape(-1, 2), 1), axis=0)
    qa, qb = Vq[QE[:, 0]], Vq[QE[:, 1]]
    ql = np.linalg.norm(qb - qa, axis=1)
    kq = np.maximum(np.ceil(ql / (0.5 * tol)).astype(np.int64), 1)
    qid = np.repeat(np.arange(QE.shape[0]), kq)
    qpos = (np.arange(qid.size) - np.repeat(np.cumsum(kq) - kq, kq) + 0.5) / kq[qid]
    tree = cKDTree(qa[qid] + qpos[:, None] * (qb - qa)[qid])
    kk = min(8, qid.size)
    _, idx = tree.query(S, k=kk)
    cand = qid[idx.reshape(S.shape[0], kk)]
    rows = np.repeat(np.arange(S.shape[0]), kk)
    d = _point_segment(S[rows], qa[cand.ravel()], qb[cand.ravel()]).reshape(-1, kk).min(1)
    w = (L / k)[eid]  # length each sample stands for
    return float(w[d <= tol].sum() / w.sum()), float(L.sum())
