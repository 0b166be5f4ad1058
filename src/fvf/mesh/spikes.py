r"""Spikes of a scan: vertices far outside the ring of their neighbours.

A scanner's outliers and reconstruction errors leave single vertices, or short chains of
them, pulled far off the surface: thin cones that no quad edge or spectral basis at the
mesh's scale resolves (``fvf quad`` names them as places thinner than a quad edge). Vertex
i with neighbours :math:`N(i)` (its edges' other ends) is a **spike** when

$$ |(x_i - c_i) \cdot n_i| > \max(\rho \, r_i,\ |P_i (x_i - c_i)|), \qquad
c_i = \frac{1}{|N(i)|} \sum_{j \in N(i)} x_j, \quad
r_i = \frac{1}{|N(i)|} \sum_{j \in N(i)} |x_j - c_i|, $$

with :math:`n_i` the unit sum of the area vectors of the faces at i (a spike's axis: the
sum over its steep sides) and :math:`P_i` the projection across it: the vertex stands more
than :data:`SPIKE_RATIO` (ρ) ring radii above its ring, and more above it than aside. A
vertex of a smooth or noisy surface lies within about one ring radius of :math:`c_i`, a CAD
corner fanned to a far hole rim lies off to the side of its ring, and the tip of a
one-vertex spike stands many radii above its ring. Flattening moves every spike vertex to
its ring's centroid, in rounds (the tip first, then the vertices below it) until none is
left or :data:`SPIKE_ROUNDS` rounds have run. A needle that belongs to the part (a sharp
cone tip) is a spike by this test too: the repair is opt-in.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .halfedges import sort_halfedges

__all__ = ["SPIKE_RATIO", "SPIKE_ROUNDS", "spike_vertices", "flattened_spikes"]

#: A vertex farther than this many ring radii from its ring's centroid is a spike.
SPIKE_RATIO = 3.0
#: Rounds of flattening at most.
SPIKE_ROUNDS = 8


def _ring_matrix(n: int, faces: np.ndarray) -> sp.csr_array:
    """Row-normalized vertex adjacency (n, n): (A x)_i is the centroid of i's neighbours."""
    e = sort_halfedges(faces, n).edges
    ij = (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])
    A = sp.coo_array((np.ones(2 * len(e)), ij), shape=(n, n)).tocsr()
    return sp.diags_array(1.0 / np.maximum(A.sum(axis=1), 1.0)) @ A


def _vertex_normals(V: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit sums of the area vectors of the faces at each vertex, float64 (n, 3)."""
    a = np.cross(V[faces[:, 1]] - V[faces[:, 0]], V[faces[:, 2]] - V[faces[:, 0]])
    n = np.stack([np.bincount(faces.ravel(), np.repeat(a[:, k], 3), len(V)) for k in range(3)], 1)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


def spike_vertices(
    vertices: np.ndarray, faces: np.ndarray, ratio: float = SPIKE_RATIO
) -> np.ndarray:
    """The spike vertices of the module docstring, sorted int64 (k,).

    Parameters
    ----------
    vertices : float64 (n, 3)
    faces : int64 (m, 3)
    ratio : float
        ρ of the module docstring.
    """
    V, F = np.asarray(vertices, np.float64), np.asarray(faces, np.int64)
    return _spikes(V, F, _ring_matrix(V.shape[0], F), ratio)


def _spikes(V: np.ndarray, F: np.ndarray, R: sp.csr_array, ratio: float) -> np.ndarray:
    c = R @ V
    rows = np.repeat(np.arange(V.shape[0]), np.diff(R.indptr))
    radius = np.bincount(rows, R.data * np.linalg.norm(V[R.indices] - c[rows], axis=1), len(V))
    normal = _vertex_normals(V, F)
    off = V - c
    up = np.einsum("kd,kd->k", off, normal)
    across = np.linalg.norm(off - up[:, None] * normal, axis=1)
    spike = (np.abs(up) > np.maximum(ratio * radius, across)) & (np.diff(R.indptr) > 0)
    return np.flatnonzero(spike).astype(np.int64)


def flattened_spikes(
    vertices: np.ndarray, faces: np.ndarray, ratio: float = SPIKE_RATIO
) -> tuple[np.ndarray, np.ndarray]:
    """The vertices with every spike moved to its ring's centroid (module docstring).

    Returns
    -------
    vertices : float64 (n, 3)
        A copy; only the moved vertices differ.
    moved : int64 (k,)
        The vertices moved, sorted.
    """
    V, F = np.array(vertices, dtype=np.float64), np.asarray(faces, np.int64)
    R = _ring_matrix(V.shape[0], F)
    moved: list[np.ndarray] = []
    for _ in range(SPIKE_ROUNDS):
        spikes = _spikes(V, F, R, ratio)
        if spikes.size == 0:
            break
        V[spikes] = (R @ V)[spikes]
        moved.append(spikes)
    return V, np.unique(np.concatenate(moved)) if moved else np.zeros(0, np.int64)
