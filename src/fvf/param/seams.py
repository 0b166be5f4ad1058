r"""Transition functions across the cut: which cut-mesh coordinates are tied to which.

On the cut mesh (:class:`fvf.param.cutmesh.CutMesh`) every corner belongs to a *wedge*
(a cut-mesh vertex) carrying coordinates uv_w ∈ ℝ². A cut edge e with faces s, t and
period jump p_e ties the wedges of its two sides by the transition

.. math::

    \mathrm{uv}_{w_s} = R^{q_e}\, \mathrm{uv}_{w_t} + c_e, \qquad q_e = -p_e \bmod 4,

R the rotation by π/2 and c_e ∈ ℝ² a translation shared by both end points (Kälberer et
al. 2007, §4; Bommes et al. 2009, eq. 3). Along a *chain* of the cut graph (a path through
non-singular vertices of cut degree 2) the transition is constant, so each chain carries
one translation c_j.

This module expresses every wedge through free variables,

.. math::

    \mathrm{uv}_w = R^{k_w}\, \mathrm{uv}_{\mathrm{root}(w)} + \sum_j T_{wj}\, c_j ,

with one root wedge per mesh vertex (a spanning forest of the transitions around each
vertex, walked level by level), and returns the linear conditions left over by the arcs
closing each vertex's cycle of wedges. Those conditions only involve chain translations
and the positions of singular vertices (for a singular vertex the cycle's rotation is not
the identity and pins uv_root to a fixed point of the affine holonomy).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components

from ..mesh.trimesh import TriMesh
from ..numerics.summary import html_repr, short_repr
from .cutmesh import CutMesh

__all__ = ["SeamSystem", "ROTATIONS", "rotation_blocks", "seam_system", "feature_rows"]

#: R^q for q = 0..3, R the counter-clockwise rotation by π/2 (integer 2 × 2 matrices).
ROTATIONS = np.array(
    [[[1, 0], [0, 1]], [[0, -1], [1, 0]], [[-1, 0], [0, -1]], [[0, 1], [-1, 0]]], dtype=np.int64
)


@dataclass(frozen=True)
class SeamSystem:
    """Wedge coordinates as a linear image of free variables, plus the closing conditions.

    Attributes
    ----------
    P : csr (2W, 2R + 2C)
        uv (wedge-major, [u0, v0, u1, v1, …]) = P @ y with y = [root uv (2R), chain c (2C)].
    closing : csr (k, 2R + 2C)
        Rows that must vanish: closing @ y = 0 (integer coefficients).
    root_of_vertex : int64 (n,)
        Root index (into the R roots) of each mesh vertex.
    n_roots, n_chains : int
    edge_q : int64 (E,)
        Rotation exponent q of each cut edge, oriented as ``edge_sides`` (0 off the cut).
    edge_sides : int64 (E, 2)
        (s, t) faces of each edge with uv_s = R^q uv_t + c (s, t swapped where a chain
        needed it); ``mesh.edge_faces`` off the cut.
    edge_chain : int64 (E,)
        Chain of each cut edge (−1 off the cut).
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    P: sp.csr_array
    closing: sp.csr_array
    root_of_vertex: np.ndarray
    n_roots: int
    n_chains: int
    edge_q: np.ndarray
    edge_sides: np.ndarray
    edge_chain: np.ndarray


def rotation_blocks(q: np.ndarray) -> sp.csr_array:
    """Block-diagonal sparse (2k, 2k) matrix of R^{q_i} (q int (k,))."""
    q = np.asarray(q, dtype=np.int64) % 4
    k = q.size
    R = ROTATIONS[q]  # (k, 2, 2)
    base = 2 * np.arange(k)
    rows = np.repeat(base, 4) + np.tile([0, 0, 1, 1], k)
    cols = np.repeat(base, 4) + np.tile([0, 1, 0, 1], k)
    data = R.reshape(-1)
    keep = data != 0
    return sp.csr_array((data[keep].astype(float), (rows[keep], cols[keep])), shape=(2 * k, 2 * k))


def _corner_wedge(mesh: TriMesh, cm: CutMesh, faces: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Wedge of the corner of face ``faces[i]`` at vertex ``v[i]``."""
    j = np.argmax(mesh.faces[faces] == v[:, None], axis=1)
    return cm.wedges[faces, j]


def _orient_chains(
    mesh: TriMesh, cm: CutMesh, cut: np.ndarray, s: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Orient the cut edges consistently along chains; return (s, t, chain id per cut edge)."""
    E = mesh.edges[cut]
    k = cut.size
    deg = np.bincount(E.ravel(), minlength=mesh.n_vertices)
    chain_vertex = (deg == 2) & (cm.index4 == 0)
    # the two cut edges at each chain vertex
    ends = E.ravel()
    edge_of_end = np.repeat(np.arange(k), 2)
    sel = chain_vertex[ends]
    order = np.argsort(ends[sel], kind="stable")
    v_sorted = ends[sel][order]
    e_sorted = edge_of_end[sel][order]
    e1, e2, v = e_sorted[0::2], e_sorted[1::2], v_sorted[0::2]
    d1 = _corner_wedge(mesh, cm, s[e1], v)
    d2 = _corner_wedge(mesh, cm, s[e2], v)
    same = d1 == d2
    # doubled graph: node (e, side) = e + side * k; "same" joins equal sides, "flip" opposite
    a = np.concatenate([e1, e1 + k])
    b = np.concatenate([np.where(same, e2, e2 + k), np.where(same, e2 + k, e2)])
    G = sp.coo_array((np.ones(a.size), (a, b)), shape=(2 * k, 2 * k))
    _, lab = connected_components(G, directed=False)
    flip = lab[:k] > lab[k:]
    s2, t2 = np.where(flip, t, s), np.where(flip, s, t)
    G1 = sp.coo_array((np.ones(e1.size), (e1, e2)), shape=(k, k))
    _, chain = connected_components(G1, directed=False)
    return s2, t2, flip, chain.astype(np.int64)


def _arcs(mesh: TriMesh, cm: CutMesh) -> tuple[np.ndarray, ...]:
    """One arc per (cut edge, end point): uv[dst] = R^q uv[src] + c_chain."""
    cut = np.flatnonzero(cm.cut)
    ef = mesh.edge_faces[cut]
    s0, t0 = ef[:, 0], ef[:, 1]
    q0 = (-cm.jumps[cut]) % 4
    s, t, flip, chain = _orient_chains(mesh, cm, cut, s0, t0)
    q = np.where(flip, (-q0) % 4, q0)
    E = mesh.edges[cut]
    src = np.concatenate([_corner_wedge(mesh, cm, t, E[:, i]) for i in (0, 1)])
    dst = np.concatenate([_corner_wedge(mesh, cm, s, E[:, i]) for i in (0, 1)])
    return cut, s, t, q, chain, src, dst, np.tile(q, 2), np.tile(chain, 2)


def _forest(
    W: int, src: np.ndarray, dst: np.ndarray
) -> tuple[np.ndarray, np.ndarray, list[np.ndarray], np.ndarray]:
    """BFS spanning forest of the wedge graph; returns parent, tree arc, levels, root flag."""
    G = sp.coo_array((np.ones(src.size), (src, dst)), shape=(W, W))
    _, comp = connected_components(G, directed=False)
    # super root W linked to the smallest wedge of each component
    reps = np.unique(comp, return_index=True)[1]
    rows = np.concatenate([src, np.full(reps.size, W)])
    cols = np.concatenate([dst, reps])
    H = sp.coo_array((np.ones(rows.size), (rows, cols)), shape=(W + 1, W + 1)).tocsr()
    order, pred = breadth_first_order(H, W, directed=False, return_predecessors=True)
    parent = pred[:W].astype(np.int64)
    is_root = parent == W
    # tree arc of each non-root wedge: any arc joining it to its parent
    key_arc = np.concatenate([src * (W + 1) + dst, dst * (W + 1) + src])
    arc_id = np.concatenate([np.arange(src.size), np.arange(src.size)])
    srt = np.argsort(key_arc, kind="stable")
    child = np.flatnonzero(~is_root)
    ck = child * (W + 1) + parent[child]
    pos = np.searchsorted(key_arc[srt], ck)
    tree_arc = np.full(W, -1, dtype=np.int64)
    tree_arc[child] = arc_id[srt[pos]]
    depth = np.zeros(W, dtype=np.int64)
    levels = []
    frontier = np.flatnonzero(is_root)
    done = is_root.copy()
    rest = order[1:][~is_root[order[1:]]]
    while rest.size:
        ready = done[parent[rest]]
        level = rest[ready]
        depth[level] = depth[parent[level]] + 1
        done[level] = True
        levels.append(level)
        rest = rest[~ready]
    del frontier
    return parent, tree_arc, levels, is_root


def seam_system(mesh: TriMesh, cm: CutMesh) -> SeamSystem:
    """Express the wedge coordinates through roots and chain translations (module docstring).

    Parameters
    ----------
    mesh : TriMesh
    cm : CutMesh
        From :func:`fvf.param.cutmesh.cut_mesh`.

    Returns
    -------
    SeamSystem
    """
    W = cm.n_wedges
    cut, s, t, q_e, chain_e, src, dst, q, chain = _arcs(mesh, cm)
    n_chains = int(chain_e.max()) + 1 if chain_e.size else 0
    parent, tree_arc, levels, is_root = _forest(W, src, dst)
    roots = np.flatnonzero(is_root)
    R = roots.size
    root_index = np.full(W, -1, dtype=np.int64)
    root_index[roots] = np.arange(R)
    root_of = root_index.copy()
    k = np.zeros(W, dtype=np.int64)
    ncol = 2 * R + 2 * n_chains
    T = sp.csr_array((2 * W, ncol))  # chain part of each wedge's expression
    for level in levels:
        a = tree_arc[level]
        p = parent[level]
        forward = (src[a] == p) & (dst[a] == level)
        qa = q[a]
        root_of[level] = root_of[p]
        k[level] = np.where(forward, k[p] + qa, k[p] - qa) % 4
        rot = rotation_blocks(np.where(forward, qa, -qa))
        rows_p = np.stack([2 * p, 2 * p + 1], axis=1).ravel()
        Tp = T[rows_p]
        # forward: T_c = R^q T_p + E_chain ; backward: T_c = R^{-q} (T_p - E_chain)
        L = level.size
        Ech = sp.csr_array(
            (
                np.ones(2 * L),
                (np.arange(2 * L), (2 * R + 2 * np.repeat(chain[a], 2) + np.tile([0, 1], L))),
            ),
            shape=(2 * L, ncol),
        )
        Tc = rot @ (Tp + sp.diags_array(np.repeat(np.where(forward, 0.0, -1.0), 2)) @ Ech)
        Tc = Tc + sp.diags_array(np.repeat(np.where(forward, 1.0, 0.0), 2)) @ Ech
        rows_c = np.stack([2 * level, 2 * level + 1], axis=1).ravel()
        place = sp.csr_array((np.ones(2 * L), (rows_c, np.arange(2 * L))), shape=(2 * W, 2 * L))
        T = (T + place @ Tc).tocsr()
    Rk = rotation_blocks(k)
    place_root = sp.csr_array(
        (np.ones(2 * W), (np.arange(2 * W), (2 * np.repeat(root_of, 2) + np.tile([0, 1], W)))),
        shape=(2 * W, ncol),
    )
    P = (Rk @ place_root + T).tocsr()
    closing = _closing_rows(P, src, dst, q, chain, tree_arc, is_root, R, ncol)
    root_of_vertex = np.zeros(mesh.n_vertices, dtype=np.int64)
    root_of_vertex[mesh.faces.ravel()] = root_of[cm.wedges.ravel()]
    edge_q = np.zeros(mesh.n_edges, dtype=np.int64)
    edge_q[cut] = q_e
    sides = mesh.edge_faces.copy()
    sides[cut, 0], sides[cut, 1] = s, t
    edge_chain = np.full(mesh.n_edges, -1, dtype=np.int64)
    edge_chain[cut] = chain_e
    return SeamSystem(P, closing, root_of_vertex, R, n_chains, edge_q, sides, edge_chain)


def _closing_rows(
    P: sp.csr_array,
    src: np.ndarray,
    dst: np.ndarray,
    q: np.ndarray,
    chain: np.ndarray,
    tree_arc: np.ndarray,
    is_root: np.ndarray,
    R: int,
    ncol: int,
) -> sp.csr_array:
    """Rows of uv[dst] − R^q uv[src] − c_chain = 0 for the arcs not in the forest."""
    used = np.zeros(src.size, dtype=bool)
    used[tree_arc[~is_root]] = True
    a = np.flatnonzero(~used)
    if a.size == 0:
        return sp.csr_array((0, ncol))
    rd = np.stack([2 * dst[a], 2 * dst[a] + 1], axis=1).ravel()
    rs = np.stack([2 * src[a], 2 * src[a] + 1], axis=1).ravel()
    L = a.size
    Ech = sp.csr_array(
        (
            np.ones(2 * L),
            (np.arange(2 * L), 2 * R + 2 * np.repeat(chain[a], 2) + np.tile([0, 1], L)),
        ),
        shape=(2 * L, ncol),
    )
    C = (P[rd] - rotation_blocks(q[a]) @ P[rs] - Ech).tocsr()
    C.data[np.abs(C.data) < 1e-9] = 0.0
    C.eliminate_zeros()
    nonzero = np.diff(C.indptr) > 0
    return C[np.flatnonzero(nonzero)]


def feature_rows(
    mesh: TriMesh, cm: CutMesh, ss: SeamSystem, edges: np.ndarray, max_angle: float = 20.0
) -> tuple[sp.csr_array, np.ndarray]:
    r"""Feature edges as integer iso-lines: the conditions and the unknowns they make integer.

    A feature edge (a, b) whose direction in a face t beside it is within ``max_angle``
    degrees of the frame's X (or Y) axis should be an iso-line of v (or u): with the
    wedges w_a, w_b of t at its end points and c the constant coordinate,

    .. math::

        \mathrm{uv}_c(w_a) - \mathrm{uv}_c(w_b) = 0, \qquad \mathrm{uv}_c(w_a) \in \mathbb{Z}.

    Both are expressed in the free variables y of :func:`seam_system`: the rows are
    (P_{2 w_a + c} − P_{2 w_b + c}), and the root coordinates that P_{2 w_a + c} and
    P_{2 w_b + c} read become integer unknowns (the chain translations they read are
    integer already), so the rows join the integer closing conditions.

    Parameters
    ----------
    mesh : TriMesh
    cm : CutMesh
    ss : SeamSystem
    edges : int (k,)
        Feature edges, indices into ``mesh.edges``.
    max_angle : float
        Edges further than this from both frame axes (in degrees) are left free.

    Returns
    -------
    rows : csr (r, 2R + 2C)
        Conditions rows @ y = 0 (integer coefficients).
    columns : int64 (s,)
        Root coordinates (columns of y, < 2R) that must be integers.
    """
    e = np.asarray(edges, dtype=np.int64)
    ncol = ss.P.shape[1]
    if e.size == 0:
        return sp.csr_array((0, ncol)), np.empty(0, dtype=np.int64)
    ef = mesh.edge_faces[e]
    t = np.where(ef[:, 0] >= 0, ef[:, 0], ef[:, 1])
    a, b = mesh.edges[e, 0], mesh.edges[e, 1]
    d = mesh.vertices[b] - mesh.vertices[a]
    B = mesh.face_bases[t]  # (k, 2, 3): the frame of each face, as mesh.to_complex reads it
    rel = np.arctan2(np.einsum("kd,kd->k", d, B[:, 1]), np.einsum("kd,kd->k", d, B[:, 0]))
    rel = rel - cm.angles[t]
    along_x = np.abs(np.cos(rel)) >= np.cos(np.radians(max_angle))
    along_y = np.abs(np.sin(rel)) >= np.cos(np.radians(max_angle))
    keep = along_x | along_y
    c = np.where(along_x, 1, 0)[keep]  # along X: v is constant; along Y: u
    wa = _corner_wedge(mesh, cm, t[keep], a[keep])
    wb = _corner_wedge(mesh, cm, t[keep], b[keep])
    rows = (ss.P[2 * wa + c] - ss.P[2 * wb + c]).tocsr()
    read = (ss.P[np.concatenate([2 * wa + c, 2 * wb + c])]).tocoo()
    columns = np.unique(read.col[read.col < 2 * ss.n_roots]).astype(np.int64)
    rows.data[np.abs(rows.data) < 1e-9] = 0.0
    rows.eliminate_zeros()
    return rows[np.flatnonzero(np.diff(rows.indptr) > 0)], columns
