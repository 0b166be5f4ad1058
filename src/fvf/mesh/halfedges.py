"""The sorted half-edge pass behind :class:`~fvf.TriMesh`'s connectivity (chapter §3.1).

One sort of the 3m half-edges by undirected edge gives every connectivity fact that
``TriMesh`` validates and caches: the unique edges (the sorted run boundaries), the
faces on each side of every edge, edges in more than two faces (runs longer than two),
inconsistent orientation (a run of two half-edges running the same way), and the twin of
every interior half-edge (its neighbour in the run). The twins give the fans of faces
around each vertex without a graph search, and the sorted edges give the 1-ring sparsity
pattern of the vertex operators (Lemma 8) without another pass over the faces.

The repairs (:mod:`fvf.mesh.repair`) and the report of ``fvf info``
(:mod:`fvf.mesh.diagnostics`) read broken meshes through the same pass: edges in more
than two faces are runs longer than two, and :func:`corner_fans` joins corners across the
two-face edges whatever their orientation.

Half-edge ``h = 3t + i`` is the edge opposite corner ``i`` of face ``t``: it runs from
``F[t, i+1]`` to ``F[t, i+2]`` (indices mod 3), so half-edges and corners share their
indices.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

__all__ = [
    "EdgeRuns",
    "sort_halfedges",
    "misoriented_edges",
    "faces_of_edges",
    "edge_pairs",
    "edge_corners",
    "vertex_fans",
    "corner_fans",
    "OneRing",
    "one_ring",
    "assembly_slots",
]

#: Step from half-edge (or corner) ``3t + i`` to ``3t + i + 1`` and ``3t + i - 1`` (mod 3
#: within the face), indexed by ``i``.
_NEXT_STEP = np.array([1, 1, -2])
_PREV_STEP = np.array([2, -1, -1])

_INT64_BITS = 63  # usable bits of a non-negative int64


class EdgeRuns(NamedTuple):
    """Half-edges sorted by undirected edge, then by direction.

    Attributes
    ----------
    halfedges : int64 (3m,)
        Half-edge indices ``3t + i`` in sorted order: the half-edges of one edge are
        consecutive (a run), the edges in ``edges`` order, and within a run the
        half-edges running from the smaller to the larger vertex come first.
    backward : bool (3m,)
        In sorted order: the half-edge runs from the larger to the smaller vertex.
    starts : int64 (E,)
        Position in the sorted order of each edge's first half-edge.
    counts : int64 (E,)
        Number of half-edges (faces) of each edge.
    edges : int64 (E, 2)
        The undirected edges ``(i, j)``, ``i < j``, sorted.
    """

    halfedges: np.ndarray
    backward: np.ndarray
    starts: np.ndarray
    counts: np.ndarray
    edges: np.ndarray


def _packs(key_bound: int, size: int) -> bool:
    """Whether keys below ``key_bound`` and positions below ``size`` fit in one int64."""
    return max(key_bound - 1, 1).bit_length() + max(size - 1, 1).bit_length() <= _INT64_BITS


def _sort_with_ids(key: np.ndarray, key_bound: int) -> tuple[np.ndarray, np.ndarray]:
    """Sort non-negative int64 ``key`` (< key_bound), returning (sorted keys, argsort).

    When the key and the position fit in 63 bits together, the position is packed into
    the low bits and the values are sorted (numpy's vectorized sort of plain integers is
    several times faster than its argsort); otherwise a stable argsort. Either way equal
    keys keep their input order. ``key`` is overwritten.
    """
    size = key.size
    id_bits = max(size - 1, 1).bit_length()
    if _packs(key_bound, size):
        key <<= id_bits
        key |= np.arange(size, dtype=np.int64)
        key.sort()
        ids = key & ((1 << id_bits) - 1)
        key >>= id_bits
        return key, ids
    ids = np.argsort(key, kind="stable")
    return key[ids], ids


def sort_halfedges(faces: np.ndarray, n_vertices: int) -> EdgeRuns:
    """Sort the half-edges of ``faces`` by undirected edge (one sort, no ``np.unique``).

    Parameters
    ----------
    faces : int64 (m, 3)
        Valid vertex indices in ``[0, n_vertices)``. A face that repeats a vertex (only
        the repairs see such faces) gives a loop edge ``(i, i)`` and two half-edges of
        one face on its other edge.
    n_vertices : int

    Returns
    -------
    EdgeRuns
    """
    n = max(int(n_vertices), 1)
    tail = faces[:, [1, 2, 0]].ravel()  # half-edge 3t + i runs F[t, i+1] -> F[t, i+2]
    head = faces[:, [2, 0, 1]].ravel()
    lo = np.minimum(tail, head)
    backward = tail > head
    np.maximum(tail, head, out=head)
    hi = head
    del tail, head
    if _packs(2 * n * n, lo.size):  # one sort of (lo, hi, direction) with the positions
        key = lo * n
        key += hi
        key <<= 1
        key |= backward  # forward half-edges first within an edge's run
        del lo, hi, backward
        key, order = _sort_with_ids(key, 2 * n * n)
    else:  # two stable sorts, least significant first: (hi, direction), then lo
        key = hi * 2
        key |= backward
        _, order = _sort_with_ids(key, 2 * n)
        _, by_lo = _sort_with_ids(lo.take(order), n)
        order = order.take(by_lo)
        key = lo.take(order) * n
        key += hi.take(order)
        key <<= 1
        key |= backward.take(order)
        del lo, hi, backward, by_lo
    backward = (key & 1).astype(bool)
    key >>= 1
    size = key.size
    new = np.empty(size, dtype=bool)
    new[:1] = True
    np.not_equal(key[1:], key[:-1], out=new[1:])
    starts = np.flatnonzero(new)
    del new
    counts = np.diff(starts, append=size)
    lo, hi = np.divmod(key[starts], n)
    return EdgeRuns(order, backward, starts, counts, np.stack([lo, hi], axis=1))


def misoriented_edges(runs: EdgeRuns) -> np.ndarray:
    """Edges of two faces that traverse them in the same direction, int64 (k,)."""
    two = np.flatnonzero(runs.counts == 2)
    p = runs.starts[two]
    return two[runs.backward[p] == runs.backward[p + 1]]


def faces_of_edges(runs: EdgeRuns, edges: np.ndarray) -> np.ndarray:
    """Sorted faces that contain one of ``edges`` (indices into ``runs.edges``), int64 (k,)."""
    marked = np.zeros(runs.counts.size, dtype=bool)
    marked[edges] = True
    return np.unique(runs.halfedges[np.repeat(marked, runs.counts)] // 3)


def edge_pairs(runs: EdgeRuns) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The two half-edges of every edge in exactly two faces, in any orientation.

    Returns
    -------
    first, second : int64 (k,)
        Half-edges ``3t + i`` of the two faces, ``first`` running from the smaller to the
        larger vertex unless both run the other way; edges in ``runs.edges`` order.
    same : bool (k,)
        The two faces traverse the edge in the same direction (inconsistent orientation).
    """
    p = runs.starts[runs.counts == 2]
    h = runs.halfedges
    return h[p], h[p + 1], runs.backward[p] == runs.backward[p + 1]


def orientation_sheets(runs: EdgeRuns, n_faces: int) -> tuple[np.ndarray, np.ndarray]:
    """The two orientations of every face on the double cover of the edge-manifold faces.

    Nodes (face, kept) and (face, flipped); each interior edge joins the nodes of equal
    parity (the same flip when its faces traverse it in opposite directions, different
    flips otherwise), and one ``connected_components`` call splits every orientable
    component into its two sheets. A component is non-orientable exactly when a face's
    two nodes land on one sheet.

    Returns
    -------
    sheet : int64 (2 m,)
        Sheet label of node (face t, kept) at t and of (face t, flipped) at m + t.
    component : int64 (m,)
        Per face, the smaller of its two sheet labels (one label per component).
    """
    m = n_faces
    ha, hb, same = edge_pairs(runs)  # same direction: different flips needed
    ta, tb = ha // 3, hb // 3
    r = np.concatenate([ta, ta + m])
    k = np.concatenate([np.where(same, tb + m, tb), np.where(same, tb, tb + m)])
    g = sp.coo_array((np.ones(r.size), (r, k)), shape=(2 * m, 2 * m))
    _, sheet = connected_components(g, directed=False)
    sheet = sheet.astype(np.int64)
    return sheet, np.minimum(sheet[:m], sheet[m:])


def edge_corners(runs: EdgeRuns) -> np.ndarray:
    """The half-edge (= opposite corner) of each edge on each side, int64 (E, 2); -1 if none.

    Side 0 runs from ``edges[e, 0]`` to ``edges[e, 1]``, side 1 the other way. Needs
    every edge in at most two faces, traversed in opposite directions when in two.
    """
    h, n_edges = runs.halfedges, runs.edges.shape[0]
    if 2 * n_edges == h.size:  # closed: every run is (forward, backward)
        return h.reshape(n_edges, 2)
    out = np.full((n_edges, 2), -1, dtype=np.int64)
    edge = np.repeat(np.arange(n_edges), runs.counts)
    out.ravel()[2 * edge + runs.backward] = h
    return out


def vertex_fans(
    faces: np.ndarray, corners: np.ndarray, n_vertices: int, max_valence: int
) -> np.ndarray:
    """Number of fans of faces around each vertex, int64 (n,).

    A fan is a maximal set of faces around a vertex connected across the vertex's
    interior edges; a manifold vertex has exactly one. The map sigma sends corner ``c``
    at vertex v to the corner at v in the face across the edge that leaves v along c's
    face (``prev(twin(prev(c)))``); its orbits are the fans: cycles for closed fans,
    chains ending at a boundary edge for open ones. Chains are counted by their ends;
    cycles by labelling each corner with the smallest corner of its orbit by pointer
    doubling (``label <- min(label, label[P]); P <- P[P]``), which needs
    ceil(log2(max_valence)) rounds. Each round is two gathers over the 3m corners.

    Parameters
    ----------
    faces : int64 (m, 3)
    corners : int64 (E, 2)
        :func:`edge_corners` (consistently oriented, every edge in at most two faces).
    n_vertices : int
    max_valence : int
        Largest number of faces at one vertex (bounds the length of every orbit).

    Returns
    -------
    int64 (n,)
        Fans per vertex; 0 for a vertex in no face.
    """
    size = faces.size
    interior = np.minimum(corners[:, 0], corners[:, 1]) >= 0
    closed = bool(interior.all())
    g1, g2 = (corners[:, 0], corners[:, 1]) if closed else corners[interior].T  # twins
    r1, r2 = g1 % 3, g2 % 3
    P = np.arange(size, dtype=np.int64)
    P[g1 + _NEXT_STEP[r1]] = g2 + _PREV_STEP[r2]
    P[g2 + _NEXT_STEP[r2]] = g1 + _PREV_STEP[r1]
    del g1, g2, r1, r2
    boundary = corners[~interior].ravel()
    boundary = boundary[boundary >= 0]
    ends = boundary + _NEXT_STEP[boundary % 3]  # corners whose leaving edge is a boundary edge
    # int32 labels halve the bytes gathered per round; take() is faster than P[P].
    step = np.arange(size, dtype=np.int32 if size <= np.iinfo(np.int32).max else np.int64)
    label = step.copy()
    label[ends] = -1  # P[end] == end: chains collapse onto their end, labelled -1
    rounds = max(int(max_valence) - 1, 0).bit_length()
    for r in range(rounds):
        np.minimum(label, label.take(P), out=label)
        if r + 1 < rounds:
            P = P.take(P)
    del P
    flat, n = faces.ravel(), int(n_vertices)
    fans = np.bincount(flat[label == step], minlength=n)  # the smallest corner of each cycle
    if not closed:
        fans += np.bincount(flat[ends], minlength=n)
    return fans


def corner_fans(faces: np.ndarray, runs: EdgeRuns) -> tuple[int, np.ndarray]:
    """Fans of any mesh: the corners at one vertex joined across the two-face edges.

    Unlike :func:`vertex_fans` this takes faces as found (before the repairs): any
    orientation, edges in more than two faces (which join nothing, so the faces on them
    fall into separate fans). Corners are matched by vertex: half-edge ``3t + i`` runs from
    corner ``3t + i + 1`` to corner ``3t + i + 2`` (mod 3 within the face), and across an
    edge its tail corner joins the corner of the other face at the same vertex. One
    ``connected_components`` call over the 3m corners labels the fans.

    Parameters
    ----------
    faces : int64 (m, 3)
    runs : EdgeRuns
        :func:`sort_halfedges` of ``faces``.

    Returns
    -------
    count : int
        Number of fans (of corners: a vertex in no face has none).
    labels : int64 (3m,)
        The fan of corner ``3t + i``.
    """
    size = faces.size
    a, b, same = edge_pairs(runs)
    a_tail, a_head = a + _NEXT_STEP[a % 3], a + _PREV_STEP[a % 3]
    b_tail, b_head = b + _NEXT_STEP[b % 3], b + _PREV_STEP[b % 3]
    rows = np.concatenate([a_tail, a_head])
    cols = np.concatenate([np.where(same, b_tail, b_head), np.where(same, b_head, b_tail)])
    graph = sp.coo_array((np.ones(rows.size), (rows, cols)), shape=(size, size))
    count, labels = connected_components(graph, directed=False)
    return int(count), labels.astype(np.int64)


class OneRing(NamedTuple):
    """The 1-ring CSR pattern (Lemma 8) and where each edge and vertex sits in it.

    Row i holds ``[(i, j < i) ascending, (i, i), (i, j > i) ascending]``: sorted columns.

    Attributes
    ----------
    indptr : int32 or int64 (n + 1,)
    indices : int32 or int64 (n + 2E,)
        int32 when ``n + 2E`` fits (as scipy chooses for itself).
    diagonal : int64 (n,)
        Position of ``(i, i)``.
    forward, backward : int64 (E,)
        Positions of ``(i, j)`` and ``(j, i)`` for edge ``e = (i, j)``, ``i < j``.
    """

    indptr: np.ndarray
    indices: np.ndarray
    diagonal: np.ndarray
    forward: np.ndarray
    backward: np.ndarray


def one_ring(edges: np.ndarray, n_vertices: int) -> OneRing:
    """The 1-ring pattern from sorted undirected edges (one sort of the edges by ``j``).

    Parameters
    ----------
    edges : int64 (E, 2)
        Sorted ``(i, j)``, ``i < j`` (as :attr:`EdgeRuns.edges`).
    n_vertices : int

    Returns
    -------
    OneRing
    """
    n, n_edges = int(n_vertices), edges.shape[0]
    lo, hi = np.ascontiguousarray(edges[:, 0]), np.ascontiguousarray(edges[:, 1])
    n_fwd = np.bincount(lo, minlength=n)  # entries (i, j > i) of row i
    n_bwd = np.bincount(hi, minlength=n)  # entries (i, j < i) of row i
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(n_fwd + n_bwd + 1, out=indptr[1:])
    diagonal = indptr[:-1] + n_bwd
    # Edges are sorted by (lo, hi): edge e is number e - first[lo] of row lo's j > i part.
    fwd_first = np.cumsum(n_fwd) - n_fwd
    forward = (diagonal + 1 - fwd_first)[lo] + np.arange(n_edges)
    del fwd_first, n_fwd
    # Sorted by (hi, lo) instead, edge number k of the run of hi sits at indptr[hi] + k.
    hi_sorted, by_hi = _sort_with_ids(hi.copy(), n)
    bwd_first = np.cumsum(n_bwd) - n_bwd
    backward = np.empty(n_edges, dtype=np.int64)
    backward[by_hi] = (indptr[:-1] - bwd_first)[hi_sorted] + np.arange(n_edges)
    del hi_sorted, by_hi, bwd_first, n_bwd
    index_type = np.int32 if indptr[-1] <= np.iinfo(np.int32).max else np.int64
    indices = np.empty(indptr[-1], dtype=index_type)
    indices[diagonal] = np.arange(n)
    indices[forward] = hi
    indices[backward] = lo
    return OneRing(indptr.astype(index_type), indices, diagonal, forward, backward)


def assembly_slots(faces: np.ndarray, corners: np.ndarray, ring: OneRing) -> np.ndarray:
    """Position in the 1-ring data of entry ``(faces[t, a], faces[t, b])``, int64 (m, 3, 3).

    Parameters
    ----------
    faces : int64 (m, 3)
    corners : int64 (E, 2)
        :func:`edge_corners`.
    ring : OneRing
    """
    m = faces.shape[0]
    # Per half-edge 3t + i (tail a = i+1, head b = i+2): slot of (tail, head) and (head, tail).
    tail_head = np.empty(3 * m, dtype=np.int64)
    head_tail = np.empty(3 * m, dtype=np.int64)
    for side, (th, ht) in enumerate(((ring.forward, ring.backward), (ring.backward, ring.forward))):
        c = corners[:, side]
        has = c >= 0
        c = c[has]
        tail_head[c] = th[has]
        head_tail[c] = ht[has]
    slots = np.empty((m, 9), dtype=np.int64)  # slots[t, 3a + b]
    th3, ht3 = tail_head.reshape(m, 3), head_tail.reshape(m, 3)
    for i, (a, b) in enumerate(((1, 2), (2, 0), (0, 1))):
        slots[:, 3 * a + b] = th3[:, i]
        slots[:, 3 * b + a] = ht3[:, i]
    diag = ring.diagonal[faces]
    for a in range(3):
        slots[:, 4 * a] = diag[:, a]
    return slots.reshape(m, 3, 3)
