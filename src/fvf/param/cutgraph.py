r"""From a cross field to a combed frame on a cut mesh.

Given one representative angle φ_t per face (:mod:`fvf.param.frames`), this module

1. *combs* the field along a breadth-first dual spanning tree T* of the faces: each face's
   representative is turned by a multiple of π/2 so that it matches its tree parent after
   Levi-Civita transport;
2. measures the *period jump* p_e ∈ {−1, 0, 1, 2} of every edge e = (s, t) (``s =
   mesh.edge_faces[e, 0]``): the combed representatives satisfy
   u_s ≈ R^{p_e} (r_st u_t), R the rotation by π/2; p_e = 0 on T*;
3. measures the cross-field index of every vertex,

   $$I_v = \frac{1}{2\pi}\Big(K_v + \sum_{e \ni v} \pm \rho_e\Big) \in \tfrac14\mathbb Z,$$

   K_v the angle defect and ρ_e ∈ (−π/4, π/4] the residual turning across e (Ray et al.
   2008, "N-symmetry direction field design"; Bommes et al. 2009, §3);
4. builds the *cut graph*: the primal edges not crossed by T* form a spanning tree plus 2g
   loop edges (tree–cotree, Eppstein 2003); the cut is the 2g loops plus the smallest
   subtree joining them and the singular vertices (Kälberer et al. 2007, §4.2). Cutting
   along it leaves a topological disk on which the combed frame has no jumps;
5. numbers the *wedges*: the vertices of the cut mesh (maximal fans of corners around a
   vertex not separated by a cut edge).

Everything is vectorized; loops run over tree depths only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components

from ..design.connection import connection_pairs
from ..mesh.trimesh import TriMesh

__all__ = ["CutMesh", "comb_and_cut", "raw_jumps", "residuals_for"]

HALF_PI = 0.5 * np.pi


@dataclass(frozen=True)
class CutMesh:
    """A combed cross field on a mesh cut to a disk.

    Attributes
    ----------
    angles : float64 (m,)
        Combed representative angle ψ_t in the complex frame of each face.
    jumps : int64 (E,)
        Period jump p_e ∈ {−1, 0, 1, 2} per edge (zero off the cut).
    index4 : int64 (n,)
        Four times the cross-field index of each vertex (Σ index4 = 4χ).
    singular : int64 (S,)
        Vertices with index4 ≠ 0.
    cut : bool (E,)
        Edges of the cut graph.
    wedges : int64 (m, 3)
        Cut-mesh vertex of each corner.
    n_wedges : int
    dual_parent : int64 (m,)
        Parent face in the combing tree (−1 at the root).
    raw : int64 (E,)
        Jumps between the uncombed representatives (the field's topology).
    residual : float64 (E,)
        Turning ρ_e of the field across each edge beyond its jump.
    """

    angles: np.ndarray
    jumps: np.ndarray
    index4: np.ndarray
    singular: np.ndarray
    cut: np.ndarray
    wedges: np.ndarray
    n_wedges: int
    dual_parent: np.ndarray
    raw: np.ndarray
    residual: np.ndarray


def _wrap(a: np.ndarray, period: float) -> np.ndarray:
    """a wrapped into (−period/2, period/2]."""
    return a - period * np.round(a / period)


def _tree_levels(parent: np.ndarray, order: np.ndarray) -> list[np.ndarray]:
    """Nodes of a BFS tree grouped by depth (order is the BFS order from the root)."""
    depth = np.zeros(parent.size, dtype=np.int64)
    # BFS order lists parents before children: one pass of cumulative depths by levels
    levels = [order[:1]]
    remaining = order[1:]
    seen = np.zeros(parent.size, dtype=bool)
    seen[order[0]] = True
    while remaining.size:
        ready = seen[parent[remaining]]
        level = remaining[ready]
        depth[level] = depth[parent[level]] + 1
        seen[level] = True
        levels.append(level)
        remaining = remaining[~ready]
    return levels


def _dual_tree(mesh: TriMesh, root: int) -> tuple[np.ndarray, np.ndarray]:
    """BFS order and parents of the faces (adjacency through edges)."""
    s, t = mesh.edge_faces[:, 0], mesh.edge_faces[:, 1]
    ok = (s >= 0) & (t >= 0)
    m = mesh.n_faces
    G = sp.coo_array((np.ones(ok.sum()), (s[ok], t[ok])), shape=(m, m))
    G = (G + G.T).tocsr()
    order, pred = breadth_first_order(G, root, directed=False, return_predecessors=True)
    pred = np.where(pred < 0, -1, pred).astype(np.int64)
    return order.astype(np.int64), pred


def raw_jumps(mesh: TriMesh, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jumps between uncombed representatives: φ_s − (φ_t + arg r_st) = j_e π/2 + ρ_e.

    Returns j (E,) int64 (rounded, 0 on boundary edges) and ρ (E,) ∈ (−π/4, π/4].
    """
    pairs, r, _ = connection_pairs(mesh, "knoppel")
    interior = np.flatnonzero((mesh.edge_faces >= 0).all(axis=1))
    d = _wrap(phi[pairs[:, 0]] - phi[pairs[:, 1]] - np.angle(r), 2.0 * np.pi)
    j = np.round(d / HALF_PI)
    jumps = np.zeros(mesh.n_edges, dtype=np.int64)
    res = np.zeros(mesh.n_edges)
    jumps[interior] = j.astype(np.int64)
    res[interior] = d - j * HALF_PI
    return jumps, res


def residuals_for(mesh: TriMesh, phi: np.ndarray, jumps: np.ndarray) -> np.ndarray:
    """ρ_e = φ_s − (φ_t + arg r_st) − j_e π/2 wrapped to (−π, π], for given raw jumps."""
    pairs, r, _ = connection_pairs(mesh, "knoppel")
    interior = np.flatnonzero((mesh.edge_faces >= 0).all(axis=1))
    res = np.zeros(mesh.n_edges)
    d = phi[pairs[:, 0]] - phi[pairs[:, 1]] - np.angle(r) - jumps[interior] * HALF_PI
    res[interior] = _wrap(d, 2.0 * np.pi)
    return res


def _comb(mesh: TriMesh, raw: np.ndarray, order: np.ndarray, parent: np.ndarray) -> np.ndarray:
    """Quarter turns K_t per face making the combed jumps j_e + K_s − K_t vanish on the tree."""
    ef = mesh.edge_faces
    child = order[1:]
    adj = mesh.face_adjacency[child]
    e = mesh.face_edges[child, np.argmax(adj == parent[child][:, None], axis=1)]
    # child is t (column 1): K_t = K_s + j ; child is s: K_s = K_t − j
    step = np.where(ef[e, 1] == child, raw[e], -raw[e])
    inc = np.zeros(mesh.n_faces, dtype=np.int64)
    inc[child] = step
    K = np.zeros(mesh.n_faces, dtype=np.int64)
    for level in _tree_levels(parent, order)[1:]:
        K[level] = K[parent[level]] + inc[level]
    return K


def _index4(mesh: TriMesh, residual: np.ndarray) -> np.ndarray:
    """4 × cross-field index per vertex (angle defect plus signed residual turning)."""
    n = mesh.n_vertices
    corner_angles = _corner_angles(mesh)
    defect = 2.0 * np.pi - np.bincount(mesh.faces.ravel(), corner_angles.ravel(), minlength=n)
    E = mesh.edges
    turn = np.bincount(E[:, 0], residual, minlength=n) - np.bincount(E[:, 1], residual, minlength=n)
    total = defect + turn
    total[mesh.boundary_vertices] = 0.0
    return np.round(total / HALF_PI).astype(np.int64)


def _corner_angles(mesh: TriMesh) -> np.ndarray:
    """Interior angle at each corner, float64 (m, 3)."""
    X, F = mesh.vertices, mesh.faces
    a = X[F[:, [1, 2, 0]]] - X[F]
    b = X[F[:, [2, 0, 1]]] - X[F]
    cos = np.einsum("mij,mij->mi", a, b)
    sin = np.linalg.norm(np.cross(a, b), axis=2)
    return np.arctan2(sin, cos)


def _cut_graph(mesh: TriMesh, tree_edge: np.ndarray, singular: np.ndarray) -> np.ndarray:
    """Cut edges: the 2g cotree loops plus the subtree joining them and the singularities."""
    n, E = mesh.n_vertices, mesh.edges
    rest = np.flatnonzero(~tree_edge)
    G = sp.coo_array((np.ones(rest.size), (E[rest, 0], E[rest, 1])), shape=(n, n))
    G = (G + G.T).tocsr()
    root = int(singular[0]) if singular.size else int(E[rest[0], 0]) if rest.size else 0
    order, pred = breadth_first_order(G, root, directed=False, return_predecessors=True)
    pred = np.where(pred < 0, -1, pred).astype(np.int64)
    # primal tree edges (v, pred v) and the loops: edges of `rest` not in that tree
    lo = np.minimum(order[1:], pred[order[1:]])
    hi = np.maximum(order[1:], pred[order[1:]])
    tree_keys = np.sort(lo * n + hi)
    rest_keys = E[rest, 0] * n + E[rest, 1]
    pos = np.clip(np.searchsorted(tree_keys, rest_keys), 0, max(tree_keys.size - 1, 0))
    in_tree = tree_keys.size > 0
    is_tree = (tree_keys[pos] == rest_keys) if in_tree else np.zeros(rest.size, bool)
    loops = rest[~is_tree]
    terminal = np.zeros(n, dtype=np.int64)
    terminal[singular] = 1
    terminal[E[loops].ravel()] = 1
    total = int(terminal.sum())
    count = terminal.copy()
    levels = _tree_levels(pred, order.astype(np.int64))
    for level in levels[:0:-1]:
        np.add.at(count, pred[level], count[level])
    cut = np.zeros(mesh.n_edges, dtype=bool)
    cut[loops] = True
    child = order[1:]
    keep = (count[child] > 0) & (count[child] < total)
    if keep.any():
        ekeys = E[:, 0] * n + E[:, 1]
        sel = np.minimum(child[keep], pred[child[keep]]) * n + np.maximum(
            child[keep], pred[child[keep]]
        )
        cut[np.searchsorted(ekeys, sel)] = True
    return cut


def _wedges(mesh: TriMesh, cut: np.ndarray) -> tuple[np.ndarray, int]:
    """Label corners by cut-mesh vertex: corners joined across uncut interior edges."""
    F, E = mesh.faces, mesh.edges
    ef = mesh.edge_faces
    ok = (~cut) & (ef >= 0).all(axis=1)
    s, t = ef[ok, 0], ef[ok, 1]
    rows_l: list[np.ndarray] = []
    cols_l: list[np.ndarray] = []
    for end in (0, 1):
        v = E[ok, end]
        cs = 3 * s + np.argmax(F[s] == v[:, None], axis=1)
        ct = 3 * t + np.argmax(F[t] == v[:, None], axis=1)
        rows_l.append(cs)
        cols_l.append(ct)
    rows, cols = np.concatenate(rows_l), np.concatenate(cols_l)
    c = 3 * mesh.n_faces
    G = sp.coo_array((np.ones(rows.size), (rows, cols)), shape=(c, c))
    k, labels = connected_components(G, directed=False)
    return labels.reshape(-1, 3).astype(np.int64), int(k)


def comb_and_cut(
    mesh: TriMesh, phi: np.ndarray, root: int | None = None, raw: np.ndarray | None = None
) -> CutMesh:
    """Comb a cross field (angles φ per face) and cut the mesh to a disk through its cones.

    Parameters
    ----------
    mesh : TriMesh
        Closed or with boundary; one component.
    phi : float64 (m,)
        Representative angle per face (:func:`fvf.param.frames.cross_field_angles`).
    root : int, optional
        Root face of the combing tree (default: the face nearest the centroid).
    raw : int64 (E,), optional
        Prescribed jumps between the uncombed representatives (a field topology fixed by
        :mod:`fvf.param.cones`); default: rounded from the angles (:func:`raw_jumps`).

    Returns
    -------
    CutMesh
    """
    if root is None:
        c = mesh.face_centroids
        root = int(np.argmin(np.linalg.norm(c - c.mean(axis=0), axis=1)))
    order, parent = _dual_tree(mesh, root)
    if raw is None:
        raw, residual = raw_jumps(mesh, phi)
    else:
        residual = residuals_for(mesh, phi, raw)
    K = _comb(mesh, raw, order, parent)
    psi = phi + K * HALF_PI
    ef = mesh.edge_faces
    jumps = np.where((ef >= 0).all(axis=1), raw + K[ef[:, 0]] - K[ef[:, 1]], 0)
    jumps = ((jumps + 1) % 4) - 1  # in {−1, 0, 1, 2}
    index4 = _index4(mesh, residual)
    singular = np.flatnonzero(index4 != 0)
    tree_edge = np.zeros(mesh.n_edges, dtype=bool)
    child = order[1:]
    adj = mesh.face_adjacency[child]
    j = np.argmax(adj == parent[child][:, None], axis=1)
    tree_edge[mesh.face_edges[child, j]] = True
    tree_edge[mesh.boundary_edges] = True  # never cut along the boundary itself
    cut = _cut_graph(mesh, tree_edge, singular)
    wedges, n_wedges = _wedges(mesh, cut)
    return CutMesh(psi, jumps, index4, singular, cut, wedges, n_wedges, parent, raw, residual)
