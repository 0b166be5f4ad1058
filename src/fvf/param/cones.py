r"""Cancelling close pairs of opposite cones of a cross field.

A cone of index +1/4 closer than about one target edge length to a cone of index −1/4
cannot be given distinct integer positions without folding the quads between them; at the
resolution of the quad mesh the pair is noise. The same holds for two cones of index
−1/4, which are merged into one of index −1/2. This module removes such pairs by editing
the field's topology and re-smoothing it (the fixed-topology step of mixed-integer field
design, Ray et al. 2008; Bommes et al. 2009, §3):

1. pair opposite cones greedily by distance, up to ``radius``;
2. for each pair, walk a shortest edge path v₁ → v₂ and shift the turning ρ_e of the field
   across each path edge by ∓π/2 (in the orientation of the path), which moves one
   quarter turn of index from v₁ to v₂: both become regular, the interior of the path is
   unchanged;
3. find the angle corrections Δψ per face minimizing

   $$\sum_e w_e\,(\tilde\rho_e + \Delta\psi_s - \Delta\psi_t)^2
   + \mu \sum_t \frac{A_t}{h^2}\,\Delta\psi_t^2,$$

   ρ̃ the edited turnings: a weighted dual-graph Laplacian solve.

The caller re-combs the corrected angles (:func:`fvf.param.cutgraph.comb_and_cut`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

from ..design.connection import connection_pairs
from ..mesh.trimesh import TriMesh
from ..numerics.eigen import factor_spd
from .cutgraph import CutMesh

__all__ = ["close_cone_pairs", "cancel_close_cones"]

#: Weight μ of keeping the original angles, relative to the smoothness term.
KEEP_WEIGHT = 1e-3


def close_cone_pairs(mesh: TriMesh, cm: CutMesh, radius: float) -> list[tuple[int, int]]:
    """Cone pairs (a, b) closer than ``radius`` (3D distance) to merge, closest first.

    Opposite cones (±1/4) cancel; two cones of index −1/4 merge into one of −1/2 (a
    valence-6 vertex). One quarter turn of index moves from a to b.
    """
    s = cm.singular
    if s.size < 2:
        return []
    P = mesh.vertices[s]
    D = np.linalg.norm(P[:, None] - P[None], axis=2)
    k = cm.index4[s]
    opposite = (np.sign(k)[:, None] * np.sign(k)[None, :] < 0) & (
        np.abs(k)[:, None] == np.abs(k)[None, :]
    )
    negative = (k[:, None] == -1) & (k[None, :] == -1)
    i, j = np.nonzero(np.triu((opposite | negative) & (D < radius), 1))
    order = np.argsort(D[i, j], kind="stable")
    used = np.zeros(s.size, dtype=bool)
    pairs = []
    for a, b in zip(i[order], j[order], strict=True):  # loop over a few cone pairs
        if used[a] or used[b]:
            continue
        used[a] = used[b] = True
        pairs.append((int(s[a]), int(s[b])))
    return pairs


def _edge_paths(
    mesh: TriMesh, pairs: list[tuple[int, int]], limit: float = np.inf
) -> list[np.ndarray]:
    """Shortest vertex paths (by edge length) between the cones of each pair.

    The searches stop at ``limit``; a pair not joined within it is searched again without.
    """
    E, X = mesh.edges, mesh.vertices
    n = mesh.n_vertices
    w = np.linalg.norm(X[E[:, 1]] - X[E[:, 0]], axis=1)
    G = sp.coo_array((w, (E[:, 0], E[:, 1])), shape=(n, n)).tocsr()
    src = np.array([a for a, _ in pairs])
    _, pred = dijkstra(G, directed=False, indices=src, return_predecessors=True, limit=limit)
    paths = []
    for row, (a, b) in enumerate(pairs):  # loop over a few cone pairs
        if pred[row, b] < 0:
            _, full = dijkstra(G, directed=False, indices=[a], return_predecessors=True)
            pred[row] = full[0]
        path = [b]
        while path[-1] != a and path[-1] >= 0:
            path.append(int(pred[row, path[-1]]))
        paths.append(np.array(path[::-1], dtype=np.int64))
    return paths


def cancel_close_cones(
    mesh: TriMesh, phi: np.ndarray, cm: CutMesh, radius: float, h: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """Corrected face angles with the close opposite cone pairs removed (None if none).

    Parameters
    ----------
    mesh : TriMesh
    phi : float64 (m,)
        The uncombed angles that ``cm`` was built from.
    cm : CutMesh
        The combed field and its cones.
    radius : float
        Pairs closer than this (3D distance) are cancelled.
    h : float
        Length scale of the keep-the-angles term.

    Returns
    -------
    (angles, raw) or None
        Corrected uncombed angles (m,) and the edited raw jumps (E,) to pass to
        :func:`fvf.param.cutgraph.comb_and_cut`.
    """
    pairs = close_cone_pairs(mesh, cm, radius)
    if not pairs:
        return None
    rho = cm.residual.copy()
    raw = cm.raw.copy()
    E = mesh.edges
    n = mesh.n_vertices
    ekey = E[:, 0] * n + E[:, 1]
    for (a, _), path in zip(pairs, _edge_paths(mesh, pairs, 4.0 * radius), strict=True):
        s = int(np.sign(cm.index4[a]))
        x0, x1 = path[:-1], path[1:]
        e = np.searchsorted(ekey, np.minimum(x0, x1) * n + np.maximum(x0, x1))
        along = E[e, 0] == x0
        sign = np.where(along, 1, -1)
        rho[e] += sign * (-s * 0.5 * np.pi)
        raw[e] += sign * s
    pairs_f, _, w = connection_pairs(mesh, "knoppel")
    interior = np.flatnonzero((mesh.edge_faces >= 0).all(axis=1))
    s_, t_ = pairs_f[:, 0], pairs_f[:, 1]
    m = mesh.n_faces
    D = sp.csr_array(
        (
            np.concatenate([np.ones(s_.size), -np.ones(t_.size)]),
            (np.concatenate([np.arange(s_.size)] * 2), np.concatenate([s_, t_])),
        ),
        shape=(s_.size, m),
    )
    Wd = sp.diags_array(w)
    mu = KEEP_WEIGHT * mesh.face_areas / h**2
    H = (D.T @ Wd @ D + sp.diags_array(mu)).tocsr()
    dpsi = factor_spd(H).solve(-(D.T @ (w * rho[interior])))
    return phi + dpsi, raw
