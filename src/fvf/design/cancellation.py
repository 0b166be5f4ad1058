r"""Cancelling close singularity pairs of an N-direction field.

A singularity of index +1/N closer than a length r to one of index −1/N is, at the
resolution r, no singularity at all: a quad mesh with edge length r cannot give the two
distinct vertices without folding the quads between them. :func:`cancel_close_singularities`
removes such pairs by editing the field's topology and re-solving its angles with the
topology fixed (the fixed-topology step of mixed-integer field design: Ray, Vallet, Li
& Lévy 2008, "N-symmetry direction field design"; Bommes, Zimmer & Kobbelt 2009, §3):

1. pair opposite singularities (±1/N) greedily, closest first, up to distance r (3D);
2. walk a shortest edge path v₁ → v₂ between the two and change the turning δ_e of the
   field across each path edge by ∓2π/N (in the orientation of the path). That moves 1/N
   of index from v₁ to v₂ and leaves the interior of the path unchanged
   (:func:`fvf.vertex_indices`: each edge adds its turning to one endpoint and subtracts
   it from the other);
3. rotate each face's representative by Δψ_t, minimizing

   $$\sum_e w_e\,(\tilde\delta_e + \Delta\psi_s - \Delta\psi_t)^2
   + \mu \sum_t \frac{A_t}{r^2}\,\Delta\psi_t^2 ,$$

   δ̃ the edited turnings and w_e the weights of the connection Laplacian
   (:func:`fvf.design.connection.connection_pairs`): one sparse SPD solve on the dual
   graph. The small μ fixes the constant and keeps the field where nothing changed.

The edited field's singularities are measured again by :func:`fvf.singularities`; a
cancelled pair can expose the next one, so the steps repeat a few rounds.

Two close −1/N singularities are left alone: moving 1/N of index onto one of them asks
the field to turn by 2π·2/N around one vertex, and the smooth re-solve of step 3 then
turns it by more than π/N across some edges of that vertex's ring, so that the measured
indices split into two −1/N singularities again.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from ..errors import ParameterError
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_direction_count, as_face_field
from ..mesh.trimesh import TriMesh, _cross
from ..numerics.cholesky import Backend, factor_hermitian
from .connection import connection_pairs
from .indices import singularities
from .nfields import _check_nonzero, _edge_angles

__all__ = ["cancel_close_singularities", "close_singularity_pairs", "KEEP_WEIGHT"]

#: Weight μ of keeping the original angles, relative to the smoothness term.
KEEP_WEIGHT = 1e-3
TWO_PI = 2.0 * np.pi


def close_singularity_pairs(
    mesh: TriMesh,
    vertices: np.ndarray,
    steps: np.ndarray,
    radius: float,
) -> list[tuple[int, int]]:
    """Pairs (a, b) of opposite singular vertices (±1/N) closer than ``radius``, closest
    first.

    Parameters
    ----------
    mesh : TriMesh
    vertices : int64 (s,)
        Singular vertices.
    steps : int64 (s,)
        N × their indices (non-zero integers).
    radius : float
        3D distance below which a pair is taken.

    Returns
    -------
    list of (int, int)
        Vertex pairs, disjoint; 1/N of index moves from a to b (their indices are
        opposite, ±1/N), which cancels both.
    """
    if vertices.size < 2 or radius <= 0:
        return []
    P = mesh.vertices[vertices]
    ij = cKDTree(P).query_pairs(radius, output_type="ndarray")
    if ij.size == 0:
        return []
    i, j = ij[:, 0], ij[:, 1]
    ki, kj = steps[i], steps[j]
    keep = (ki == -kj) & (np.abs(ki) == 1)
    i, j = i[keep], j[keep]
    d = np.linalg.norm(P[i] - P[j], axis=1)
    used = np.zeros(vertices.size, dtype=bool)
    pairs = []
    for a, b in zip(i[np.argsort(d, kind="stable")], j[np.argsort(d, kind="stable")], strict=True):
        if used[a] or used[b]:  # greedy matching over the few close pairs
            continue
        used[a] = used[b] = True
        pairs.append((int(vertices[a]), int(vertices[b])))
    return pairs


def _edge_paths(mesh: TriMesh, pairs: list[tuple[int, int]], limit: float) -> list[np.ndarray]:
    """Shortest vertex paths (by edge length) between the vertices of each pair.

    The searches stop at ``limit``; a pair not joined within it is searched again without.
    """
    E, X = mesh.edges, mesh.vertices
    n = mesh.n_vertices
    w = np.linalg.norm(X[E[:, 1]] - X[E[:, 0]], axis=1)
    G = sp.coo_array((w, (E[:, 0], E[:, 1])), shape=(n, n)).tocsr()
    src = np.array([a for a, _ in pairs])
    _, pred = dijkstra(G, directed=False, indices=src, return_predecessors=True, limit=limit)
    paths = []
    for row, (a, b) in enumerate(pairs):  # loop over a few singularity pairs
        if pred[row, b] < 0:
            _, full = dijkstra(G, directed=False, indices=[a], return_predecessors=True)
            pred[row] = full[0]
        path = [b]
        while path[-1] != a and path[-1] >= 0:
            path.append(int(pred[row, path[-1]]))
        paths.append(np.array(path[::-1], dtype=np.int64))
    return paths


def _edited_turnings(
    mesh: TriMesh, u: np.ndarray, n: int, pairs: list[tuple[int, int]], steps: dict, limit: float
) -> tuple[np.ndarray, np.ndarray]:
    """Interior edges and their turnings δ_e with 1/N of index moved along each pair's path."""
    interior, phi = _edge_angles(mesh, u)
    delta = phi - (TWO_PI / n) * np.rint(n * phi / TWO_PI)
    full = np.zeros(mesh.n_edges)
    full[interior] = delta
    E = mesh.edges
    nv = mesh.n_vertices
    key = E[:, 0] * nv + E[:, 1]
    for (a, _), path in zip(pairs, _edge_paths(mesh, pairs, limit), strict=True):
        s = int(np.sign(steps[a]))
        x0, x1 = path[:-1], path[1:]
        e = np.searchsorted(key, np.minimum(x0, x1) * nv + np.maximum(x0, x1))
        along = np.where(E[e, 0] == x0, 1.0, -1.0)
        full[e] -= along * s * TWO_PI / n
    return interior, full[interior]


def _reangle(
    mesh: TriMesh, interior: np.ndarray, delta: np.ndarray, radius: float, backend: Backend
) -> np.ndarray:
    """Δψ (m,) minimizing Σ w_e (δ_e + Δψ_s − Δψ_t)² + μ Σ A_t Δψ_t² / r² (module doc)."""
    _, _, w = connection_pairs(mesh, "knoppel")
    ef = mesh.edge_faces[interior]
    m, k = mesh.n_faces, interior.size
    D = sp.csr_array(
        (
            np.concatenate([np.ones(k), -np.ones(k)]),
            (np.tile(np.arange(k), 2), np.concatenate([ef[:, 0], ef[:, 1]])),
        ),
        shape=(k, m),
    )
    mu = KEEP_WEIGHT * mesh.face_areas / radius**2
    H = (D.T @ sp.diags_array(w) @ D + sp.diags_array(mu)).tocsr()
    return factor_hermitian(H, backend).solve(-(D.T @ (w * delta)))


@takes_mesh
def cancel_close_singularities(
    mesh: TriMesh,
    u: npt.ArrayLike,
    n: int = 4,
    *,
    radius: float,
    rounds: int = 3,
    backend: Backend = "auto",
) -> np.ndarray:
    """An N-field with the singularity pairs closer than ``radius`` removed (module doc).

    Parameters
    ----------
    mesh : TriMesh
    u : array_like, float (m, 3)
        One representative vector per face, non-zero on every face.
    n : int
        Symmetry order N ≥ 1.
    radius : float
        3D distance below which a +1/N, −1/N pair cancels. For a quad mesh the target
        edge length.
    rounds : int
        Pair, cancel and re-measure at most this many times.
    backend : {"auto", "cholmod", "cholespy", "scipy"}
        Sparse factorization of the dual-graph system.

    Returns
    -------
    float64 (m, 3)
        The edited field, one unit representative per face (u itself, normalized, when
        no pair is closer than ``radius``).

    Raises
    ------
    ParameterError
        radius negative or not finite, rounds < 0.
    FieldShapeError
        Wrong shape, non-finite values or a zero vector on some face.
    """
    n = as_direction_count(n)
    radius = float(radius)
    if not (np.isfinite(radius) and radius >= 0):
        raise ParameterError(f"radius must be a finite number >= 0; got {radius!r}")
    if int(rounds) != rounds or rounds < 0:
        raise ParameterError(f"rounds must be an integer >= 0; got {rounds!r}")
    u = as_face_field(mesh, u, "u")
    _check_nonzero(mesh, u, "its singularities")
    u = u / np.linalg.norm(u, axis=1, keepdims=True)
    for _ in range(int(rounds)):  # a few rounds: a cancelled pair can expose the next
        ids, ind = singularities(mesh, u, n=n)
        steps = np.rint(n * np.asarray(ind, dtype=float)).astype(np.int64)
        pairs = close_singularity_pairs(mesh, ids, steps, radius)
        if not pairs:
            break
        step_of = dict(zip(ids.tolist(), steps.tolist(), strict=True))
        interior, delta = _edited_turnings(mesh, u, n, pairs, step_of, 4.0 * radius)
        dpsi = _reangle(mesh, interior, delta, radius, backend)
        Ju = _cross(mesh.face_normals, u)
        u = np.cos(dpsi)[:, None] * u + np.sin(dpsi)[:, None] * Ju
    return u
