r"""Is a quad mesh a valid remeshing of a triangle mesh? The gate of :func:`fvf.quad_mesh`.

A quad mesh :math:`(V_q, Q)` made from a triangle mesh :math:`M` is **valid** when

1. every face is a quad of four distinct vertices at four distinct points (sides and
   diagonals longer than :data:`COINCIDENT` of the input's extent), every vertex is used;
2. it is a 2-manifold: every undirected edge bounds one or two quads, and the quads
   around every vertex form a single fan (corners linked across shared edges);
3. it is consistently oriented: no directed edge appears twice;
4. it has :math:`M`'s topology: per connected component the Euler characteristic
   :math:`\chi = |V| - |E| + |Q|` and the number of boundary loops, and the number of
   components;
5. no quad is folded against the surface under it
   (:func:`fvf.param.quad_folds.folded_quads`);
6. the two surfaces lie within one quad edge of each other (two-sided Hausdorff distance
   of dense samples, relative to the mean quad edge length).

Every check is a count on the connectivity or a vectorized distance; none reads the
mesher's own bookkeeping.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..errors import format_indices
from ..mesh.trimesh import TriMesh
from ..numerics.summary import html_repr, short_repr
from .quad_folds import folded_quads
from .quality import sampled_hausdorff

__all__ = [
    "QuadValidity",
    "check_quad_mesh",
    "quad_components",
    "quad_vertex_fans",
    "topology_signature",
]

#: The two-sided Hausdorff distance allowed, in mean quad edge lengths.
HAUSDORFF_EDGES = 1.0
#: Two corners of a quad at most this far apart (× the input's largest extent) are one
#: point: the quad is degenerate (as the independent checker judges it).
COINCIDENT = 1e-12


@dataclass(frozen=True)
class QuadValidity:
    """Verdict of :func:`check_quad_mesh`.

    Attributes
    ----------
    valid : bool
    problems : tuple of str
        One sentence per failed check, naming the offending quads or vertices.
    folded : int64 (k,)
        Folded quads.
    hausdorff : float
        Two-sided Hausdorff distance in mean quad edge lengths (``nan`` if not measured).
    one_sided : tuple of float
        The sampled one-sided Hausdorff distances (quads to input, input to quads), in the
        mesh's units (``nan`` if not measured).
    """

    valid: bool
    problems: tuple[str, ...]
    folded: np.ndarray
    hausdorff: float
    one_sided: tuple[float, float] = (np.nan, np.nan)

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    def __str__(self) -> str:
        return "valid" if self.valid else "; ".join(self.problems)


def _invalid(*problems: str) -> QuadValidity:
    return QuadValidity(False, tuple(problems), np.empty(0, np.int64), np.nan)


def _edges(Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Directed edges (4k, 2), their undirected ids (4k,) and the undirected edges."""
    d = np.stack([Q, np.roll(Q, -1, axis=1)], axis=2).reshape(-1, 2)
    und, inv = np.unique(np.sort(d, axis=1), axis=0, return_inverse=True)
    return d, inv.ravel(), und


def quad_components(n_vertices: int, Q: np.ndarray) -> tuple[int, np.ndarray]:
    """Connected components of a quad mesh: (count, label per vertex, int64 (n,))."""
    rows = np.repeat(Q[:, 0], 3)
    cols = Q[:, 1:].ravel()
    A = sp.coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n_vertices, n_vertices))
    count, label = connected_components(A, directed=False)
    return int(count), label.astype(np.int64)


def quad_vertex_fans(n_vertices: int, quads: np.ndarray) -> np.ndarray:
    """Number of fans of quads at each vertex, int64 (n,): 1 at a manifold vertex, 0 at
    a vertex of no quad, 2 or more where quads meet only at their corners (a pinch)."""
    Q = np.asarray(quads, dtype=np.int64)
    if Q.shape[0] == 0:
        return np.zeros(n_vertices, dtype=np.int64)
    d, inv, _ = _edges(Q)
    return _fans(n_vertices, Q, d, inv)


def _fans(n_vertices: int, Q: np.ndarray, d: np.ndarray, inv: np.ndarray) -> np.ndarray:
    """Number of corner fans at each vertex, int64 (n,): 1 at a manifold vertex."""
    k = Q.shape[0]
    corner = np.arange(4 * k)  # corner c = 4 q + i sits at Q[q, i], edge c leaves it
    nxt = 4 * (corner // 4) + (corner + 1) % 4
    order = np.argsort(inv, kind="stable")
    s = inv[order]
    pair = np.flatnonzero(s[1:] == s[:-1])
    a, b = order[pair], order[pair + 1]  # two uses of one undirected edge
    opposite = d[a, 0] == d[b, 1]  # a: x -> y, b: y -> x
    # corners at x: a's start and b's end (the corner after b); likewise at y
    i = np.concatenate([a[opposite], nxt[a[opposite]], a[~opposite], nxt[a[~opposite]]])
    j = np.concatenate([nxt[b[opposite]], b[opposite], b[~opposite], nxt[b[~opposite]]])
    G = sp.coo_matrix((np.ones(i.size), (i, j)), shape=(4 * k, 4 * k))
    _, label = connected_components(G, directed=False)
    at = Q.ravel()
    key = np.unique(np.stack([at, label], axis=1), axis=0)
    return np.bincount(key[:, 0], minlength=n_vertices)


def topology_signature(n_vertices: int, faces: np.ndarray) -> list[tuple[int, int]]:
    """Sorted (χ, boundary loops) per connected component of a polygon mesh.

    ``faces`` int (k, s), s = 3 or 4, consistently oriented and manifold.
    """
    F = np.asarray(faces, dtype=np.int64)
    d = np.sort(np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    n = max(int(n_vertices), 1)
    key, cnt = np.unique(d[:, 0] * n + d[:, 1], return_counts=True)  # the undirected edges
    und = np.stack([key // n, key % n], axis=1)
    count, label = quad_components(n_vertices, F) if F.shape[1] == 4 else _tri_labels(n_vertices, F)
    used = np.zeros(n_vertices, dtype=bool)
    used[F.ravel()] = True
    nv = np.bincount(label[used], minlength=count)
    ne = np.bincount(label[und[:, 0]], minlength=count)
    nf = np.bincount(label[F[:, 0]], minlength=count)
    bnd = und[cnt == 1]
    loops = _boundary_loops(n_vertices, bnd, label, count)
    keep = nf > 0
    return sorted(zip((nv - ne + nf)[keep].tolist(), loops[keep].tolist(), strict=True))


def _tri_labels(n_vertices: int, F: np.ndarray) -> tuple[int, np.ndarray]:
    rows = np.repeat(F[:, 0], 2)
    A = sp.coo_matrix((np.ones(rows.size), (rows, F[:, 1:].ravel())), (n_vertices,) * 2)
    count, label = connected_components(A, directed=False)
    return int(count), label.astype(np.int64)


def _boundary_loops(n: int, bnd: np.ndarray, label: np.ndarray, count: int) -> np.ndarray:
    """Boundary loops per component (each loop a cycle of boundary edges)."""
    if bnd.shape[0] == 0:
        return np.zeros(count, dtype=np.int64)
    A = sp.coo_matrix((np.ones(bnd.shape[0]), (bnd[:, 0], bnd[:, 1])), (n, n))
    _, lab = connected_components(A, directed=False)
    verts = np.unique(bnd)
    loops = np.unique(lab[verts])
    owner = np.zeros(lab.max() + 1, dtype=np.int64)
    owner[lab[verts]] = label[verts]
    return np.bincount(owner[loops], minlength=count)


def _connectivity_problems(n_vertices: int, Q: np.ndarray) -> list[str]:
    problems = []
    rep = (np.sort(Q, axis=1)[:, 1:] == np.sort(Q, axis=1)[:, :-1]).any(axis=1)
    if rep.any():
        problems.append(f"quads {format_indices(np.flatnonzero(rep))} repeat a vertex")
    used = np.zeros(n_vertices, dtype=bool)
    used[Q.ravel()] = True
    if not used.all():
        problems.append(f"vertices {format_indices(np.flatnonzero(~used))} are in no quad")
    d, inv, und = _edges(Q)
    cnt = np.bincount(inv, minlength=und.shape[0])
    if (cnt > 2).any():
        problems.append(f"edges {format_indices(np.flatnonzero(cnt > 2))} bound > 2 quads")
    key = d[:, 0] * n_vertices + d[:, 1]
    if np.unique(key).size != key.size:
        problems.append("quads are not consistently oriented (a directed edge repeats)")
    fans = _fans(n_vertices, Q, d, inv)
    bad = np.flatnonzero(used & (fans != 1))
    if bad.size:
        problems.append(f"vertices {format_indices(bad)} are not manifold (several fans)")
    return problems


def _shortest_span(V: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """The shortest side or diagonal of each quad, float64 (q,)."""
    P = V[Q]
    sides = np.linalg.norm(P - np.roll(P, -1, axis=1), axis=2).min(axis=1)
    diagonals = np.minimum(
        np.linalg.norm(P[:, 2] - P[:, 0], axis=1), np.linalg.norm(P[:, 3] - P[:, 1], axis=1)
    )
    return np.minimum(sides, diagonals)


def check_quad_mesh(
    mesh: TriMesh,
    vertices: np.ndarray,
    quads: np.ndarray,
    *,
    hausdorff: bool = True,
    signature: list[tuple[int, int]] | None = None,
    folded: np.ndarray | None = None,
) -> QuadValidity:
    """Check a quad mesh made from ``mesh`` (the module docstring's six conditions).

    Parameters
    ----------
    mesh : TriMesh
        The triangle mesh the quads remesh.
    vertices : float64 (k, 3)
    quads : int64 (q, 4)
    hausdorff : bool
        Measure condition 6 (sampling both surfaces; the costliest check).
    signature : list of (int, int), optional
        The expected (χ, boundary loops) per component (default: ``mesh``'s).
    folded : int64 (f,), optional
        The quads :func:`fvf.param.quad_folds.folded_quads` finds folded at ``vertices``,
        when already evaluated (:attr:`fvf.param.quad_folds.FoldRepair.verdict`).

    Returns
    -------
    QuadValidity
    """
    V = np.asarray(vertices, dtype=np.float64)
    Q = np.asarray(quads, dtype=np.int64)
    if Q.ndim != 2 or Q.shape[1] != 4 or Q.shape[0] == 0 or V.ndim != 2 or V.shape[1] != 3:
        return _invalid(f"not a quad mesh: vertices {V.shape}, quads {Q.shape}")
    if Q.min() < 0 or Q.max() >= V.shape[0]:
        return _invalid("quad indices out of range")
    problems = _connectivity_problems(V.shape[0], Q)
    if problems:
        return _invalid(*problems)
    scale = float(np.ptp(mesh.vertices, axis=0).max()) or 1.0
    flat = np.flatnonzero(_shortest_span(V, Q) <= COINCIDENT * scale)
    if flat.size:
        problems.append(f"quads {format_indices(flat)} put two corners at one point")
    want = signature if signature is not None else topology_signature(mesh.n_vertices, mesh.faces)
    got = topology_signature(V.shape[0], Q)
    if got != want:
        problems.append(f"topology (χ, boundary loops) per component is {got}, the input's {want}")
    if folded is None:
        folded = folded_quads(mesh, V, Q)
    if folded.size:
        problems.append(f"quads {format_indices(folded)} are folded against the surface")
    edge = float(np.linalg.norm(V[Q] - V[np.roll(Q, -1, axis=1)], axis=2).mean())
    sides = sampled_hausdorff(mesh, V, Q, edge) if hausdorff else (np.nan, np.nan)
    dist = max(sides) / edge  # in mean quad edges
    if hausdorff and not dist <= HAUSDORFF_EDGES:
        problems.append(f"the surfaces are {dist:.2f} quad edges apart (Hausdorff > 1)")
    return QuadValidity(not problems, tuple(problems), folded, float(dist), sides)
