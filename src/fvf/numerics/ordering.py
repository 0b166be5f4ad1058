"""Fill-reducing orderings of sparse symmetric matrices: graph nested dissection.

Sparse Cholesky/LU of a matrix whose graph is a surface mesh (a Laplacian, a connection
Laplacian, the ACAP energy E_B) fills in far less under a nested-dissection ordering
(George 1973) than under minimum degree when the stencil is wide: on a planar-like graph
of n nodes the factor has O(n log n) entries and costs O(n^{3/2}) flops. scipy's SuperLU
only offers minimum-degree (MMD) and COLAMD orderings, so :func:`nested_dissection`
computes one here and the factorization is run with ``permc_spec="NATURAL"`` on the
permuted matrix (:func:`fvf.numerics.eigen.factor_spd`).

Algorithm (George & Liu 1978, "automatic nested dissection", with level structures):
each connected part of the graph is split by the middle level of a breadth-first level
structure rooted at a pseudo-peripheral node (the farthest from an arbitrary start); a
level separates the levels before it from those after it, since BFS edges join adjacent
levels only. Among the levels holding the middle 40 % of the nodes the smallest one is
the separator. The two sides are ordered recursively, then the separator; parts of at
most ``leaf_size`` nodes are left in their order (SuperLU's supernodes handle those
dense-ish blocks well). All graph work is scipy.sparse.csgraph (compiled); Python runs
once per part, about n / leaf_size times. Nodes with the same closed neighbourhood (the
2 or 3 unknowns of one face in a per-face vector field system) are ordered as one node
of a quotient graph and kept together (compression; found by hashing the neighbourhoods:
a hash collision only changes which valid permutation comes out, never its validity).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse import csgraph

__all__ = ["nested_dissection", "LEAF_SIZE"]

#: Parts with at most this many nodes are not split further.
LEAF_SIZE = 64


def nested_dissection(A: sp.sparray | sp.spmatrix, leaf_size: int = LEAF_SIZE) -> np.ndarray:
    """A nested-dissection elimination order of a sparse matrix's symmetric graph.

    Parameters
    ----------
    A : sparse array or matrix, shape (n, n)
        Its pattern, symmetrized (A + Aᵀ, diagonal ignored), is the graph.
    leaf_size : int
        Parts of at most this many nodes are not split.

    Returns
    -------
    perm : ndarray of int64, shape (n,)
        A permutation of range(n): eliminate node ``perm[0]`` first. Factor
        ``A[perm][:, perm]`` in natural order.

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp, fvf
    >>> from fvf.numerics.ordering import nested_dissection
    >>> L = fvf.stiffness(fvf.icosphere(3))
    >>> p = nested_dissection(L)
    >>> bool(np.array_equal(np.sort(p), np.arange(L.shape[0])))
    True
    """
    n = A.shape[0]
    if A.shape != (n, n):
        raise ValueError(f"nested_dissection needs a square matrix; got shape {A.shape}")
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    G = sp.csr_array(A, dtype=np.float64, copy=True)
    G.data[:] = 1.0
    G = (G + G.T).tocsr()
    G.setdiag(0)
    G.eliminate_zeros()
    G.data[:] = 1.0
    group, Q = _indistinguishable(G)  # (n,) group of each node; (groups, n) indicator
    if Q is not None:
        Gq = (Q @ G @ Q.T).tocsr()  # quotient graph
        Gq.setdiag(0)
        Gq.eliminate_zeros()
        Gq.data[:] = 1.0
        order_q = np.empty(Gq.shape[0], dtype=np.int64)
        _dissect(Gq, np.arange(Gq.shape[0], dtype=np.int64), order_q, 0, max(int(leaf_size), 2))
        rank = np.empty_like(order_q)
        rank[order_q] = np.arange(order_q.size)
        return np.argsort(rank[group], kind="stable").astype(np.int64)
    out = np.empty(n, dtype=np.int64)
    _dissect(G, np.arange(n, dtype=np.int64), out, 0, max(int(leaf_size), 2))
    return out


def _indistinguishable(G: sp.csr_array) -> tuple[np.ndarray, sp.csr_array | None]:
    """Groups of nodes with equal neighbourhoods, closed (adjacent twins) or open
    (non-adjacent twins, e.g. two unknowns of one face coupled only through their
    neighbours), found by a hash of the neighbour ids: (group (n,), indicator (groups, n)),
    or (arange, None) when no two nodes share one."""
    n = G.shape[0]
    ids = np.arange(1, n + 1, dtype=np.float64)
    best: np.ndarray | None = None
    for H in (G + sp.eye_array(n, format="csr"), G):
        key = np.stack(
            [np.diff(H.indptr).astype(np.float64), H @ ids, H @ (ids * ids)], axis=1
        )  # (n, 3): degree, Σ ids, Σ ids² of the neighbourhood (exact in float64)
        _, group = np.unique(key, axis=0, return_inverse=True)
        group = group.ravel()
        if best is None or group.max() < best.max():
            best = group
    assert best is not None  # the loop ran
    k = int(best.max()) + 1 if n else 0
    if k == n:
        return np.arange(n), None
    Q = sp.csr_array((np.ones(n), (best, np.arange(n))), shape=(k, n))
    return best, Q


def _dissect(
    G: sp.csr_array, nodes: npt.NDArray[np.int64], out: np.ndarray, start: int, leaf: int
) -> int:
    """Write an order of the subgraph G (global ids ``nodes``) into out[start:]; return
    the next free position."""
    if nodes.size <= leaf:
        out[start : start + nodes.size] = nodes
        return start + nodes.size
    depth = csgraph.shortest_path(G, method="D", unweighted=True, indices=0)
    if not np.isfinite(depth).all():  # several components: order each on its own
        ncomp, label = csgraph.connected_components(G, directed=False)
        order = np.argsort(label, kind="stable")
        bounds = np.searchsorted(label[order], np.arange(ncomp + 1))
        for c in range(ncomp):
            part = order[bounds[c] : bounds[c + 1]]
            start = _dissect(G[part][:, part], nodes[part], out, start, leaf)
        return start
    # levels from a pseudo-peripheral root: the farthest node from node 0 (lowest degree)
    far = np.flatnonzero(depth == depth.max())
    root = int(far[np.argmin(np.diff(G.indptr)[far])])
    level = csgraph.shortest_path(G, method="D", unweighted=True, indices=root).astype(np.int64)
    counts = np.bincount(level)
    cum = np.cumsum(counts)
    total = cum[-1]
    middle = np.flatnonzero((cum - counts >= 0.3 * total) & (cum <= 0.7 * total))
    middle = middle[(middle > 0) & (middle < counts.size - 1)]
    if middle.size == 0:  # few, fat levels (a near-clique): the interior level nearest half
        inner = np.arange(1, counts.size - 1)
        if inner.size == 0:
            out[start : start + nodes.size] = nodes
            return start + nodes.size
        middle = inner[[np.argmin(np.abs(cum[inner] - total / 2))]]
    sep_level = middle[np.argmin(counts[middle])]
    for side in (level < sep_level, level > sep_level):
        part = np.flatnonzero(side)
        start = _dissect(G[part][:, part], nodes[part], out, start, leaf)
    sep = np.flatnonzero(level == sep_level)
    out[start : start + sep.size] = nodes[sep]
    return start + sep.size
