r"""Quality of a quad mesh against the triangle mesh it was made from.

Measures (all vectorized):

- **irregular vertices**: valence ≠ 4 (≠ 3 on the boundary), with their valence
  histogram;
- **corner angles**: |θ − 90°| over all quad corners (median, 95th percentile), θ the 3D
  angle between the two edges at the corner;
- **area distortion**: the coefficient of variation std(A_q)/mean(A_q) of the quad areas
  (each quad split along its shorter diagonal) and the 95th percentile of |log(A_q/Ā)|;
- **alignment**: the angle between each quad edge and the nearest direction of the target
  cross field on the input triangle nearest its midpoint (mean and 95th percentile, °);
- **one-sided Hausdorff distances** (as fractions of the input's bounding-box diagonal):
  input → quads and quads → input, measured between dense samples of both surfaces
  (vertices, edge points and face points; exact to the sampling step);
- **topology**: closed, manifold, Euler characteristic;
- **folded quads**: quads whose normal faces away from the input surface
  (:func:`fvf.param.quad_folds.folded_quads`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from ..errors import ParameterError
from ..mesh.convert import takes_mesh
from ..mesh.geometry import segment_points
from ..mesh.trimesh import TriMesh
from .quad_folds import folded_quads
from .seamless import SeamlessParameterization

__all__ = ["QuadQuality", "quad_quality", "quad_topology", "quad_boundary_vertices", "quad_edges"]


@dataclass(frozen=True)
class QuadQuality:
    """Quality measures of a quad mesh (see the module docstring)."""

    n_vertices: int
    n_quads: int
    n_irregular: int
    irregular_fraction: float
    valences: dict
    angle_deviation_median: float
    angle_deviation_p95: float
    area_cv: float
    area_log_p95: float
    alignment_mean: float | None
    alignment_p95: float | None
    hausdorff_to_input: float
    hausdorff_from_input: float
    closed: bool
    manifold: bool
    euler_characteristic: int
    n_folded: int
    flipped_uv: int | None = None
    curl_residual: float | None = None
    rounded_residual: float | None = None

    def as_dict(self) -> dict:
        """The measures as a plain dict (JSON-friendly)."""
        return asdict(self)


def quad_edges(quads: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """The undirected edges of a quad mesh, int64 (e, 2) with the smaller vertex first, in
    lexicographic order, and how many quads use each, int64 (e,) (1 on a boundary)."""
    Q = np.asarray(quads, dtype=np.int64)
    e = np.sort(np.stack([Q, np.roll(Q, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    edges, uses = np.unique(e, axis=0, return_counts=True)
    return edges, uses


def quad_topology(n_vertices: int, quads: np.ndarray) -> tuple[bool, bool, int, np.ndarray]:
    """(closed, manifold, χ, valence (k,)) of a quad mesh from its connectivity."""
    Q = np.asarray(quads, dtype=np.int64)
    e = np.stack([Q, np.roll(Q, -1, axis=1)], axis=2).reshape(-1, 2)
    ue, cnt = quad_edges(Q)
    directed = np.unique(e, axis=0).shape[0] == e.shape[0]
    closed = bool(np.all(cnt == 2))
    manifold = bool(np.all(cnt <= 2) and directed)
    valence = np.bincount(ue.ravel(), minlength=n_vertices)
    chi = int(n_vertices - ue.shape[0] + Q.shape[0])
    return closed, manifold, chi, valence


def quad_boundary_vertices(quads: np.ndarray) -> np.ndarray:
    """Sorted vertices on boundary edges (edges of one quad) of a quad mesh, int64 (b,)."""
    edges, uses = quad_edges(quads)
    return np.unique(edges[uses == 1])


def _corner_angles(V: np.ndarray, Q: np.ndarray) -> np.ndarray:
    a = V[np.roll(Q, -1, axis=1)] - V[Q]
    b = V[np.roll(Q, 1, axis=1)] - V[Q]
    cos = np.einsum("qkd,qkd->qk", a, b)
    sin = np.linalg.norm(np.cross(a, b), axis=2)
    return np.degrees(np.arctan2(sin, cos))


def corner_distortion(V: np.ndarray, Q: np.ndarray) -> float:
    """The 95th percentile of |corner angle − 90°| over the quads' corners, degrees
    (:attr:`QuadQuality.angle_deviation_p95`): V float64 (n, 3), Q int64 (q, 4)."""
    return float(np.percentile(np.abs(_corner_angles(V, Q) - 90.0), 95))


def _quad_areas(V: np.ndarray, Q: np.ndarray) -> np.ndarray:
    p0, p1, p2, p3 = (V[Q[:, i]] for i in range(4))
    a1 = 0.5 * (
        np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)
        + np.linalg.norm(np.cross(p2 - p0, p3 - p0), axis=1)
    )
    a2 = 0.5 * (
        np.linalg.norm(np.cross(p2 - p1, p3 - p1), axis=1)
        + np.linalg.norm(np.cross(p3 - p1, p0 - p1), axis=1)
    )
    return np.minimum(a1, a2)


#: Sampling step of both surfaces for Hausdorff distances, in quad edges. The distances are
#: within about this much of the exact ones (the quad mesh's gate asks for at most one edge);
#: a step of a quarter of the input's edges instead, on a 750k-face input to 20,000 quads,
#: sampled 2 × 10⁷ points for 33 s and moved the distance by 0.01 edges.
HAUSDORFF_STEP = 0.25
#: Triangle sides sampled per :func:`segment_points` call in :func:`surface_samples`.
SIDE_CHUNK = 500_000


#: Query points per k-d tree call of :func:`farthest` (its distances and indices: 16 MB).
QUERY_CHUNK = 1_000_000


def sampled_hausdorff(
    mesh: TriMesh, V: np.ndarray, Q: np.ndarray, edge: float
) -> tuple[float, float]:
    """The two one-sided Hausdorff distances between the quads (V float64 (k, 3), Q int64
    (q, 4), split into triangles) and ``mesh``, both sampled every :data:`HAUSDORFF_STEP`
    × ``edge``: (quads to input, input to quads), floats."""
    step = HAUSDORFF_STEP * edge
    quad_pts = surface_samples(V, np.concatenate([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]]), step)
    in_pts = surface_samples(mesh.vertices, mesh.faces, step)
    return farthest(in_pts, quad_pts), farthest(quad_pts, in_pts)  # one tree at a time


def farthest(x: np.ndarray, y: np.ndarray) -> float:
    """max over y of the distance to the nearest point of x (both float64 (·, 3)), the
    queries in chunks of :data:`QUERY_CHUNK` (at 750k input faces each side had about 10⁷
    samples: their distances and indices at once were 0.3 GB)."""
    tree = cKDTree(x)
    return max(
        float(tree.query(y[lo : lo + QUERY_CHUNK])[0].max()) for lo in range(0, len(y), QUERY_CHUNK)
    )


def surface_samples(V: np.ndarray, T: np.ndarray, step: float) -> np.ndarray:
    """Points on triangles T (k, 3) about ``step`` apart, float64 (p, 3).

    The vertices, points along every triangle side every ``step``, and per triangle a
    barycentric grid whose level follows its area (√(2A) / step, at most 64), so that a
    long thin triangle is sampled along its length without a dense grid over its
    (small) area. Exact to the sampling step for Hausdorff distances.
    """
    P = V[T]  # (k, 3, 3)
    a, b = P.reshape(-1, 3), np.roll(P, -1, axis=1).reshape(-1, 3)
    longer = np.linalg.norm(b - a, axis=1) > step  # a shorter side's only point is a vertex
    a, b = a[longer], b[longer]
    out = [V]
    for lo in range(0, a.shape[0], SIDE_CHUNK):  # its temporaries are 5 × the points
        out.append(segment_points(a[lo : lo + SIDE_CHUNK], b[lo : lo + SIDE_CHUNK], step)[0])
    del a, b
    area = 0.5 * np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
    k = np.clip(np.ceil(np.sqrt(2.0 * area) / step).astype(np.int64), 1, 64)
    for level in np.unique(k[k > 1]):  # a loop over a few subdivision levels
        sel = P[k == level]
        i, j = np.meshgrid(np.arange(1, level), np.arange(1, level), indexing="ij")
        keep = (i + j) < level
        w = np.stack([1.0 - (i[keep] + j[keep]) / level, i[keep] / level, j[keep] / level], 1)
        out.append(np.einsum("sc,tcd->tsd", w, sel).reshape(-1, 3))
    return np.concatenate(out)


def _alignment(mesh: TriMesh, V: np.ndarray, Q: np.ndarray, field: np.ndarray) -> np.ndarray:
    """Angle (°) between each quad edge and the nearest direction of the cross field."""
    e0, e1 = V[Q], V[np.roll(Q, -1, axis=1)]
    mid = (0.5 * (e0 + e1)).reshape(-1, 3)
    d = (e1 - e0).reshape(-1, 3)
    _, face = cKDTree(mesh.face_centroids).query(mid)
    N = mesh.face_normals[face]
    d = d - np.einsum("kd,kd->k", d, N)[:, None] * N
    u = field[face] / np.linalg.norm(field[face], axis=1, keepdims=True)
    w = np.cross(N, u)
    ang = np.arctan2(np.einsum("kd,kd->k", d, w), np.einsum("kd,kd->k", d, u))
    r = np.mod(ang, np.pi / 2)
    return np.degrees(np.minimum(r, np.pi / 2 - r))


@takes_mesh
def quad_quality(
    mesh: TriMesh,
    vertices: npt.ArrayLike,
    quads: npt.ArrayLike,
    *,
    field: npt.ArrayLike | None = None,
    parameterization: SeamlessParameterization | None = None,
) -> QuadQuality:
    """Quality report of a quad mesh made from ``mesh`` (module docstring).

    Parameters
    ----------
    mesh : TriMesh
        The input triangle mesh.
    vertices : array_like (k, 3) float
    quads : array_like (q, 4) int
    field : array_like (m, 3), optional
        Target cross field (one representative per input face) for the alignment error;
        default: the parameterization's field if given.
    parameterization : SeamlessParameterization, optional
        Adds the flipped-uv count and the fit residuals before and after rounding.

    Returns
    -------
    QuadQuality
        ``n_folded`` counts the quads folded in 3D (normal against the input surface's at
        the quad; :func:`fvf.param.quad_folds.folded_quads`).
    """
    return measured_quality(mesh, vertices, quads, field, parameterization)


def measured_quality(
    mesh: TriMesh,
    vertices: npt.ArrayLike,
    quads: npt.ArrayLike,
    field: npt.ArrayLike | None,
    parameterization: SeamlessParameterization | None,
    gate: tuple[tuple[float, float], int] | None = None,
) -> QuadQuality:
    """:func:`quad_quality`; with ``gate`` = ((quads to input, input to quads) Hausdorff
    distances in the mesh's units, folded quads) as the validity gate measured them
    (:attr:`fvf.param.quad_validity.QuadValidity.one_sided`), those are not measured again
    (on a 750k-triangle input, 10 s)."""
    V = np.asarray(vertices, dtype=np.float64)
    Q = np.asarray(quads, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] != 3 or Q.ndim != 2 or Q.shape[1] != 4 or Q.shape[0] == 0:
        raise ParameterError(
            f"vertices must be (k, 3) and quads (q, 4) with q > 0; got {V.shape} and {Q.shape}"
        )
    if Q.min() < 0 or Q.max() >= V.shape[0]:
        raise ParameterError("quads index vertices out of range")
    closed, manifold, chi, valence = quad_topology(V.shape[0], Q)
    used = np.zeros(V.shape[0], dtype=bool)
    used[Q.ravel()] = True
    on_boundary = np.zeros(V.shape[0], dtype=bool)
    on_boundary[quad_boundary_vertices(Q)] = True
    irr = used & (valence != np.where(on_boundary, 3, 4))  # regular: 4 inside, 3 on the rim
    vals, counts = np.unique(valence[irr], return_counts=True)
    dev = np.abs(_corner_angles(V, Q) - 90.0).ravel()
    area = _quad_areas(V, Q)
    logs = np.abs(np.log(np.maximum(area, 1e-300) / area.mean()))
    diag = float(np.linalg.norm(mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0)))
    sides = sampled_hausdorff(mesh, V, Q, float(np.sqrt(area.mean()))) if gate is None else gate[0]
    h_to, h_from = (d / diag for d in sides)
    if field is None and parameterization is not None:
        field = parameterization.field
    align_mean = align_p95 = None
    if field is not None:
        al = _alignment(mesh, V, Q, np.asarray(field, dtype=np.float64))
        align_mean, align_p95 = float(al.mean()), float(np.percentile(al, 95))
    p = parameterization
    return QuadQuality(
        n_vertices=int(used.sum()),
        n_quads=int(Q.shape[0]),
        n_irregular=int(irr.sum()),
        irregular_fraction=float(irr.sum() / max(used.sum(), 1)),
        valences={int(v): int(c) for v, c in zip(vals, counts, strict=True)},
        angle_deviation_median=float(np.median(dev)),
        angle_deviation_p95=float(np.percentile(dev, 95)),
        area_cv=float(area.std() / area.mean()),
        area_log_p95=float(np.percentile(logs, 95)),
        alignment_mean=align_mean,
        alignment_p95=align_p95,
        hausdorff_to_input=h_to,
        hausdorff_from_input=h_from,
        closed=closed,
        manifold=manifold,
        euler_characteristic=chi,
        n_folded=int(folded_quads(mesh, V, Q).size) if gate is None else int(gate[1]),
        flipped_uv=None if p is None else int(p.n_flipped),
        curl_residual=None if p is None else float(p.residual_real),
        rounded_residual=None if p is None else float(p.residual),
    )
