"""Evaluating vertex maps: geodesic distances, geodesic errors, cumulative error curves.

The field's standard accuracy of a map p2p_21 (mesh 2 -> mesh 1) against a ground truth
gt_21 is the geodesic distance on mesh 1 between the predicted and the true image of each
vertex of mesh 2, divided by √(area of mesh 1) (Kim et al. 2011; Ovsjanikov et al. 2012).

Geodesic distances are approximated on the mesh, three ways:

- ``"unfolded"`` (default): shortest paths (:func:`scipy.sparse.csgraph.dijkstra`) on the
  edges plus, for each pair of triangles sharing an edge, the straight segment between
  their opposite corners when it stays inside the unfolded pair. Never below the true
  distance; a few percent above it (the paths still bend at vertices).
- ``"edges"``: shortest paths along edges only: exact for vertices joined by an edge,
  about 10 % long at a few edges' distance (zigzag paths).
- ``"heat"``: the heat method (Crane et al. 2013) with fvf's own calculus: heat
  u = (A_V + t W)⁻¹ δ_s for t = h² (h the mean edge length), the unit field
  X = −grad u / |grad u|, and φ with W φ = gradᵀ[A_F] X (the least-squares fit
  grad φ ≈ X), shifted so that φ(s) = 0. It smooths the distance near the source, and far
  from it (beyond ~30 edges) the heat underflows the solver's relative precision, so the
  direction field is noise there: use it for local distances on fine meshes.

Measured against exact polyhedral geodesics (MMP, pygeodesic) on a camel frame of the
correspondence data, from 20 random sources (``tests/spectral/test_correspondence.py``;
``docs/correspondence.md``): mean relative excess of ``"unfolded"`` +3 to +4 % within six
edges of the source and +2 % beyond; ``"edges"`` +9 to +12 % and +4 to +6 %.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph
import scipy.sparse.linalg as spla

from ..calculus import grad, stiffness
from ..errors import FieldShapeError, ParameterError, format_indices
from ..mesh.convert import MeshLike, as_mesh, takes_mesh
from ..mesh.trimesh import TriMesh
from .fmaps import check_p2p

__all__ = [
    "geodesic_distances",
    "geodesic_errors",
    "mean_geodesic_error",
    "cumulative_error_curve",
    "orientation_agreement",
    "GEODESIC_METHODS",
]

GEODESIC_METHODS = ("unfolded", "edges", "heat")

#: Sources per batch of the heat method (two sparse solves with this many right-hand sides).
HEAT_BATCH = 256


def _min_graph(n: int, rows: np.ndarray, cols: np.ndarray, w: np.ndarray) -> sp.csr_array:
    """Symmetric sparse (n, n) graph; a pair given several times keeps its smallest weight."""
    r, c = np.concatenate([rows, cols]), np.concatenate([cols, rows])
    w = np.concatenate([w, w])
    key = r * n + c
    order = np.lexsort((w, key))
    first = np.ones(order.size, dtype=bool)
    first[1:] = key[order][1:] != key[order][:-1]
    keep = order[first]
    return sp.csr_array((w[keep], (r[keep], c[keep])), shape=(n, n))


def _edge_lengths(mesh: TriMesh) -> np.ndarray:
    E = mesh.edges
    return np.linalg.norm(mesh.vertices[E[:, 0]] - mesh.vertices[E[:, 1]], axis=1)


def _edge_graph(mesh: TriMesh) -> sp.csr_array:
    """Symmetric sparse (n, n) graph of the edges, weighted by their lengths."""
    E = mesh.edges
    return mesh.cached(
        "edge_graph",
        lambda: _min_graph(mesh.n_vertices, E[:, 0], E[:, 1], _edge_lengths(mesh)),
    )


def _unfolded_diagonals(mesh: TriMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Across each interior edge (a, b): the opposite corners c, d of its two faces and
    |c d'| with d' = d rotated about ab into the plane of (a, b, c), kept when the
    segment c d' crosses ab between a and b (then it lies in the two faces).

    Returns (c (q,), d (q,), length (q,)).
    """
    X = mesh.vertices
    corners = mesh.edge_corners  # (E, 2): the corner opposite each edge on each side
    inner = (corners >= 0).all(axis=1)
    E = mesh.edges[inner]
    c, d = (mesh.faces.ravel()[corners[inner, side]] for side in (0, 1))
    a = X[E[:, 0]]
    length = np.linalg.norm(X[E[:, 1]] - a, axis=1)
    u = (X[E[:, 1]] - a) / length[:, None]

    def planar(p):  # coordinates along ab and distance from its line
        v = X[p] - a
        x = np.einsum("ij,ij->i", v, u)
        return x, np.linalg.norm(v - x[:, None] * u, axis=1)

    xc, yc = planar(c)
    xd, yd = planar(d)  # d' lies on the other side: y = −yd
    with np.errstate(invalid="ignore", divide="ignore"):
        x_cross = xc + yc / (yc + yd) * (xd - xc)
    ok = (x_cross > 0) & (x_cross < length) & (yc > 0) & (yd > 0)
    return c[ok], d[ok], np.hypot(xc - xd, yc + yd)[ok]


def _unfolded_graph(mesh: TriMesh) -> sp.csr_array:
    """The edge graph plus the unfolded diagonals of adjacent face pairs, (n, n)."""

    def build():
        c, d, w = _unfolded_diagonals(mesh)
        E = mesh.edges
        rows, cols = np.concatenate([E[:, 0], c]), np.concatenate([E[:, 1], d])
        return _min_graph(mesh.n_vertices, rows, cols, np.concatenate([_edge_lengths(mesh), w]))

    return mesh.cached("unfolded_graph", build)


class _HeatSolver:
    """The two factorizations of the heat method, reused for every batch of sources."""

    def __init__(self, mesh: TriMesh, time_factor: float = 1.0) -> None:
        self.mesh = mesh
        W = stiffness(mesh).tocsc()
        t = time_factor * mesh.mean_edge_length**2
        self.heat = spla.splu((sp.diags_array(mesh.vertex_areas) + t * W).tocsc())
        n = mesh.n_vertices
        # W is singular (constants); ground vertex 0 of every component-free system
        keep = np.arange(1, n)
        self.poisson = spla.splu(W[keep][:, keep].tocsc())
        self.G = grad(mesh)
        self.GtA = (self.G.T @ sp.diags_array(np.repeat(mesh.face_areas, 3))).tocsr()

    def distances(self, sources: np.ndarray) -> np.ndarray:
        """Distance fields (n, s) of the given source vertices."""
        n, m = self.mesh.n_vertices, self.mesh.n_faces
        delta = np.zeros((n, sources.size))
        delta[sources, np.arange(sources.size)] = 1.0
        u = self.heat.solve(delta)
        g = (self.G @ u).reshape(m, 3, -1)
        norm = np.linalg.norm(g, axis=1, keepdims=True)
        X = -np.divide(g, norm, out=np.zeros_like(g), where=norm > 0)
        b = self.GtA @ X.reshape(3 * m, -1)  # gradᵀ [A_F] X, (n, s)
        phi = np.zeros((n, sources.size))
        phi[1:] = self.poisson.solve(b[1:])
        phi -= phi[sources, np.arange(sources.size)][None, :]
        return phi


def _check_sources(mesh: TriMesh, sources: npt.ArrayLike, name: str) -> np.ndarray:
    s = np.atleast_1d(np.asarray(sources))
    if s.ndim != 1 or not np.issubdtype(s.dtype, np.integer):
        raise FieldShapeError(f"{name} must be integer vertex indices; got {s.dtype} {s.shape}")
    bad = np.flatnonzero((s < 0) | (s >= mesh.n_vertices))
    if bad.size:
        raise FieldShapeError(
            f"{name} at positions {format_indices(bad)} are outside [0, {mesh.n_vertices})"
        )
    return s.astype(np.int64)


@takes_mesh
def geodesic_distances(
    mesh: TriMesh, sources: npt.ArrayLike, *, method: str = "unfolded"
) -> np.ndarray:
    """Approximate geodesic distances from source vertices to every vertex.

    Parameters
    ----------
    mesh : TriMesh
    sources : array_like of int (s,)
    method : {"unfolded", "edges", "heat"}
        See the module docstring for what each approximates and how well.

    Returns
    -------
    float64 (s, n)
        Row i: distances from ``sources[i]``; ``inf`` for vertices in another component
        (graph methods).

    Raises
    ------
    FieldShapeError
        A source outside [0, n).
    ParameterError
        An unknown method.
    """
    s = _check_sources(mesh, sources, "sources")
    if method in ("unfolded", "edges"):
        graph = _unfolded_graph(mesh) if method == "unfolded" else _edge_graph(mesh)
        return csgraph.dijkstra(graph, directed=False, indices=s)
    if method != "heat":
        raise ParameterError(f"method must be one of {GEODESIC_METHODS}; got {method!r}")
    solver = mesh.cached("heat_geodesic_solver", lambda: _HeatSolver(mesh))
    out = np.empty((s.size, mesh.n_vertices))
    for start in range(0, s.size, HEAT_BATCH):
        out[start : start + HEAT_BATCH] = solver.distances(s[start : start + HEAT_BATCH]).T
    return out


def geodesic_errors(
    mesh_1: MeshLike,
    p2p_21: npt.ArrayLike,
    gt_p2p_21: npt.ArrayLike,
    *,
    method: str = "unfolded",
    normalize: bool = True,
) -> np.ndarray:
    """Per-vertex geodesic error of a vertex map against a ground-truth map.

    Parameters
    ----------
    mesh_1 : TriMesh or any :data:`fvf.MeshLike`
        The mesh both maps land on (n_1 vertices).
    p2p_21 : array_like of int (n_2,)
        Predicted image on mesh 1 of each vertex of mesh 2.
    gt_p2p_21 : array_like of int (n_2,)
        True images (same convention).
    method : {"unfolded", "edges", "heat"}
        Geodesic approximation (:func:`geodesic_distances`).
    normalize : bool
        Divide by √(area of mesh 1), the field's standard.

    Returns
    -------
    float64 (n_2,)
        d_1(p2p_21[j], gt_p2p_21[j]) (/ √area_1): one distance field per distinct true
        image of a vertex mapped elsewhere, evaluated at the predicted one (exact hits are
        0 without one, so the identity costs nothing).

    Raises
    ------
    FieldShapeError
        Maps of different lengths or with entries outside [0, n_1).
    """
    mesh_1 = as_mesh(mesh_1)
    gt = np.asarray(gt_p2p_21)
    n2 = gt.shape[0] if gt.ndim == 1 else -1
    gt = check_p2p(gt, mesh_1.n_vertices, n2)
    p = check_p2p(p2p_21, mesh_1.n_vertices, gt.size)
    err = np.zeros(gt.size)  # exact hits: zero, no distance field needed
    miss = np.flatnonzero(p != gt)
    sources, inverse = np.unique(gt[miss], return_inverse=True)
    block = 512  # distance rows kept in memory at once
    for start in range(0, sources.size, block):
        rows = geodesic_distances(mesh_1, sources[start : start + block], method=method)
        sel = (inverse >= start) & (inverse < start + block)
        err[miss[sel]] = rows[inverse[sel] - start, p[miss[sel]]]
    if normalize:
        err /= np.sqrt(mesh_1.total_area)
    return err


def mean_geodesic_error(
    mesh_1: MeshLike,
    p2p_21: npt.ArrayLike,
    gt_p2p_21: npt.ArrayLike,
    *,
    valid: npt.ArrayLike | None = None,
    method: str = "unfolded",
) -> float:
    """Mean of :func:`geodesic_errors` (normalized by √area_1) over the valid vertices.

    Parameters
    ----------
    valid : array_like of bool (n_2,), optional
        Vertices of mesh 2 that have a ground truth (default all).
    """
    mesh_1 = as_mesh(mesh_1)
    gt = np.asarray(gt_p2p_21)
    p = np.asarray(p2p_21)
    if valid is not None:
        valid = np.asarray(valid, dtype=bool)
        if valid.shape != gt.shape:
            raise FieldShapeError(f"valid must have shape {gt.shape}; got {valid.shape}")
        gt, p = gt[valid], p[valid]
    return float(geodesic_errors(mesh_1, p, gt, method=method).mean())


def cumulative_error_curve(
    errors: npt.ArrayLike, thresholds: npt.ArrayLike | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Fraction of vertices with error at most each threshold (the correspondence curve).

    Parameters
    ----------
    errors : array_like (n,)
        Normalized geodesic errors.
    thresholds : array_like (T,), optional
        Default 101 values in [0, 0.25] (the usual range of the field's plots).

    Returns
    -------
    thresholds : float64 (T,)
    fraction : float64 (T,), non-decreasing in [0, 1]
    """
    e = np.sort(np.asarray(errors, dtype=float).ravel())
    t = np.linspace(0.0, 0.25, 101) if thresholds is None else np.asarray(thresholds, float)
    return t, np.searchsorted(e, t, side="right") / max(e.size, 1)


def orientation_agreement(mesh_1: MeshLike, mesh_2: MeshLike, p2p_21: npt.ArrayLike) -> float:
    """How much a vertex map preserves orientation: +1 preserving, −1 reversing.

    Each face (j_0, j_1, j_2) of mesh 2 is sent to the triangle (x_{i_0}, x_{i_1}, x_{i_2})
    of mesh-1 vertices, i = p2p_21[j]; its normal (x_{i_1} − x_{i_0}) × (x_{i_2} − x_{i_0})
    is compared with the area-weighted normal of mesh 1 at those vertices. The result is
    the area-weighted mean sign over the faces whose image is not degenerate (faces
    mapped onto fewer than three vertices are skipped).

    Parameters
    ----------
    mesh_1, mesh_2 : TriMesh or any :data:`fvf.MeshLike`
    p2p_21 : array_like of int (n_2,)

    Returns
    -------
    float in [−1, 1]; 0 when every image is degenerate.
    """
    mesh_1, mesh_2 = as_mesh(mesh_1), as_mesh(mesh_2)
    p = check_p2p(p2p_21, mesh_1.n_vertices, mesh_2.n_vertices)
    img = p[mesh_2.faces]  # (m_2, 3)
    X = mesh_1.vertices
    normal = np.cross(X[img[:, 1]] - X[img[:, 0]], X[img[:, 2]] - X[img[:, 0]])
    vn = np.zeros((mesh_1.n_vertices, 3))
    area_normal = mesh_1.face_areas[:, None] * mesh_1.face_normals  # (m_1, 3)
    np.add.at(vn, mesh_1.faces.ravel(), np.repeat(area_normal, 3, axis=0))
    ref = vn[img].sum(axis=1)  # (m_2, 3)
    s = np.sign(np.einsum("ij,ij->i", normal, ref))
    ok = (img[:, 0] != img[:, 1]) & (img[:, 1] != img[:, 2]) & (img[:, 2] != img[:, 0])
    w = mesh_2.face_areas * ok
    return float((w * s).sum() / w.sum()) if w.sum() > 0 else 0.0
