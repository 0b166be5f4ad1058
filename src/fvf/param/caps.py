r"""Open surfaces quad-meshed as closed ones: each hole capped by a dome, the dome's quads cut off.

The seamless parameterization needs a closed surface. An open component M is closed by a
**dome** over each boundary loop :math:`P_0, \dots, P_{k-1}` (in the order M's faces
traverse it): with :math:`c` the loop's centroid, :math:`r` its mean distance to
:math:`c` and :math:`n` the mean normal of M's faces along the loop, ring :math:`j` of
:math:`R` is

.. math::

    Q_{j,i} = c + (1 - t_j)(P_i - c) + r \sin\!\big(\tfrac{\pi}{2} t_j\big)\, n,
    \qquad t_j = j / R,

closed by a fan to :math:`c + r n`. The dome leaves the loop at 57° to its plane, so the
loop is a sharp edge of the closed surface: the quad mesher's field is held along it
(:mod:`fvf.param.features`) and quad edges run beside it. The quads of the closed surface
whose centres lie on a dome are then cut off, and the remaining quad vertices put on M at
their closest points, and the vertices on the quads' boundary moved to their closest
points on M's boundary loops (:func:`snap_boundary`). The result has M's
boundary loops; :func:`fvf.param.quad_validity.check_quad_mesh` judges it against M.

A dome over a loop that winds through space (a helical ribbon's) holds many times M's area,
and meshing it fails. Such an M (or one whose domes fail) is closed instead by its
**mirror image** (:func:`doubled`): a copy of M with every face's orientation reversed,
glued to M along the boundary, :math:`\chi = 2\chi(M)` (a rectangle becomes a pillowcase
whose four corners, where M's boundary turns by 90°, are cones of index 1/2). The copy lies
on M, so the closed surface has exactly twice M's area, whatever
the loops' shape; its cotangent weights, connection and angle defects are M's on each
sheet, and the loops, where the surface folds back by 180°, are features. An interior edge
of M with both ends on the boundary (a chord: a strip one triangle wide, a triangle with
two boundary edges) would be shared by four faces of the glued surface, so each chord is
split at its midpoint first. The quads of the closed surface never cross the loops when
they are integer iso-lines; those of the copy are told apart by the sheet of the faces
under their corners off the loops (by their normal, which points against M's, where all
four lie on a loop), not by position, which both sheets share.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from ..errors import ParameterizationInputError, format_indices
from ..mesh.geometry import vertex_vector_areas
from ..mesh.trimesh import TriMesh
from ..numerics.summary import html_repr, short_repr
from .quad_folds import closest_surface_points
from .quad_validity import quad_vertex_fans
from .quality import quad_boundary_vertices

__all__ = [
    "Capped",
    "boundary_loops",
    "capped",
    "closest_on_segments",
    "cut_caps",
    "doubled",
    "snap_boundary",
    "split_pairs",
]

#: Dome height over the loop's mean radius (57.5° at the rim, a sharp feature).
DOME_HEIGHT = 1.0
#: Rounds of putting a dome's quads back around pinched vertices after the cut.
PINCH_ROUNDS = 3


@dataclass(frozen=True)
class Capped:
    """An open mesh closed by domes (module docstring).

    Attributes
    ----------
    mesh : TriMesh
        The closed mesh: the open mesh's vertices and faces first, then the domes'.
    is_cap : bool (m',)
        Faces of the domes.
    rim : int64 (k,)
        Edge ids (of ``mesh.edges``) of the boundary loops the domes close.
    mirrored : bool
        Closed by the open mesh's mirror image (:func:`doubled`), not by domes: then
        ``is_cap`` marks the copy's faces.
    chords : int64 (k, 3)
        With ``mirrored``: each chord of the open mesh split before the gluing, as its
        two ends and its midpoint (vertices of ``mesh``); else empty.
    """

    mesh: TriMesh
    is_cap: np.ndarray
    rim: np.ndarray
    mirrored: bool = False
    chords: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int64))

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter


def boundary_loops(mesh: TriMesh) -> list[np.ndarray]:
    """The boundary loops of ``mesh``, each an int64 array of vertices in the order the
    faces traverse them. Raises :class:`fvf.ParameterizationInputError` at a vertex where
    two loops touch (a pinched boundary)."""
    e = mesh.boundary_edges
    ef = mesh.edge_faces[e]
    a = np.where(ef[:, 0] >= 0, mesh.edges[e, 0], mesh.edges[e, 1])
    b = np.where(ef[:, 0] >= 0, mesh.edges[e, 1], mesh.edges[e, 0])
    count = np.bincount(a, minlength=mesh.n_vertices)
    pinched = np.flatnonzero(count > 1)
    if pinched.size:
        raise ParameterizationInputError(
            f"boundary vertices {format_indices(pinched)} are shared by two boundary loops; "
            "split them first (fvf.split_nonmanifold_vertices or fvf repair)"
        )
    nxt = np.full(mesh.n_vertices, -1, dtype=np.int64)
    nxt[a] = b
    seen = np.zeros(mesh.n_vertices, dtype=bool)
    loops = []
    for start in a:  # a loop over loops: each vertex is visited once
        if seen[start]:
            continue
        loop = [start]
        seen[start] = True
        v = nxt[start]
        while v != start:
            loop.append(v)
            seen[v] = True
            v = nxt[v]
        loops.append(np.array(loop, dtype=np.int64))
    return loops


def _dome_direction(P: np.ndarray, normals: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """The unit normal of the loop's plane (Newell's) on the side the surface along the
    loop faces (``normals``: its vertex normals, (k, 3)) and away from the mesh's
    ``centre`` — the second decides where the first cancels (the open end of a tube)."""
    n = np.cross(P, np.roll(P, -1, axis=0)).sum(axis=0)
    n = n / max(float(np.linalg.norm(n)), 1e-300)
    c = P.mean(axis=0)
    r = max(float(np.linalg.norm(P - c, axis=1).mean()), 1e-300)
    facing = float(n @ normals.sum(axis=0)) / max(
        float(np.linalg.norm(normals, axis=1).sum()), 1e-300
    )
    away = float(n @ (c - centre)) / r
    return n if facing + away >= 0 else -n


def _dome(P: np.ndarray, n: np.ndarray, spacing: float) -> tuple:
    """The rings of one dome over loop points P (k, 3): float64 ((R-1) k, 3) ring points
    (ring by ring), the apex (3,), and R."""
    c = P.mean(axis=0)
    r = float(np.linalg.norm(P - c, axis=1).mean())
    rings = max(1, int(np.ceil(r / spacing)))
    t = np.arange(1, rings)[:, None, None] / rings
    ring_pts = c + (1 - t) * (P - c) + DOME_HEIGHT * r * np.sin(0.5 * np.pi * t) * n
    apex = c + DOME_HEIGHT * r * n
    return ring_pts.reshape(-1, 3), apex, rings


#: A boundary loop whose points lie within this fraction of its length of one line is a
#: slit: it encloses no area, and no dome closes it.
SLIT_WIDTH = 1e-9


def _check_not_a_slit(loop: np.ndarray, P: np.ndarray) -> None:
    """:class:`fvf.ParameterizationInputError` when the loop's points (k, 3) lie on one
    line (:data:`SLIT_WIDTH`)."""
    length = float(np.linalg.norm(P - np.roll(P, -1, axis=0), axis=1).sum())
    spread = np.linalg.svd(P - P.mean(axis=0), compute_uv=False)
    width = spread[1] / np.sqrt(len(P)) if len(spread) > 1 else 0.0
    if width <= SLIT_WIDTH * max(length, 1e-300):
        raise ParameterizationInputError(
            f"the boundary loop through vertices {format_indices(np.sort(loop))} lies on one "
            "line: a slit of zero width (as removing a zero-area face leaves), which no quad "
            "mesh can follow. Fix: repair the file with its zero-area faces in it "
            "(fvf.repair_mesh, fvf repair: split_t_junctions closes such slits), or close "
            "it in the tool that made the file"
        )


def capped(mesh: TriMesh, spacing: float) -> Capped:
    """``mesh`` with every boundary loop closed by a dome (module docstring).

    Parameters
    ----------
    mesh : TriMesh
        One component with boundary loops.
    spacing : float
        About the length of the domes' ring steps (the quad edge length / 2 suits).
    """
    V, F = [mesh.vertices], [mesh.faces]
    offset = mesh.n_vertices
    rim = []
    vn = vertex_vector_areas(mesh)
    centre = mesh.vertices.mean(axis=0)
    for loop in boundary_loops(mesh):
        P = mesh.vertices[loop]
        _check_not_a_slit(loop, P)
        n = _dome_direction(P, vn[loop], centre)
        pts, apex, rings = _dome(P, n, spacing)
        k = loop.size
        ids = [loop] + [offset + j * k + np.arange(k) for j in range(rings - 1)]
        for A, B in zip(ids[:-1], ids[1:], strict=True):
            A1, B1 = np.roll(A, -1), np.roll(B, -1)
            F.append(np.stack([A1, A, B], axis=1))
            F.append(np.stack([A1, B, B1], axis=1))
        top = offset + (rings - 1) * k
        last = ids[-1]
        F.append(np.stack([np.roll(last, -1), last, np.full(k, top)], axis=1))
        V += [pts, apex[None]]
        offset = top + 1
        rim.append(np.stack([loop, np.roll(loop, -1)], axis=1))
    W = np.concatenate(V)
    G = np.concatenate(F).astype(np.int64)
    closed = TriMesh(W, G)
    is_cap = np.arange(G.shape[0]) >= mesh.n_faces
    return Capped(closed, is_cap, closed.edge_ids(np.concatenate(rim)))


def doubled(mesh: TriMesh) -> Capped:
    """``mesh`` closed by its mirror image (module docstring).

    Parameters
    ----------
    mesh : TriMesh
        One component with boundary loops, none pinched (else
        :class:`fvf.ParameterizationInputError`).

    Returns
    -------
    Capped
        ``mirrored=True``; ``mesh.vertices`` are the open mesh's, then the chords'
        midpoints, then the copies of the interior vertices; the faces are the open mesh's
        with its chords split, then their mirror images in the same order.
    """
    boundary_loops(mesh)  # refuses pinched loops, which the gluing would leave pinched
    V, F, chords = _split_chords(mesh)
    n, m = V.shape[0], F.shape[0]
    inside = np.ones(n, dtype=bool)
    inside[mesh.boundary_vertices] = False  # the chords' midpoints are interior
    twin = np.arange(n)
    twin[inside] = n + np.arange(int(inside.sum()))
    closed = TriMesh(np.concatenate([V, V[inside]]), np.concatenate([F, twin[F][:, ::-1]]))
    rim = closed.edge_ids(mesh.edges[mesh.boundary_edges])
    return Capped(closed, np.arange(2 * m) >= m, rim, mirrored=True, chords=chords)


def split_pairs(cap: Capped, pairs: np.ndarray) -> np.ndarray:
    """Vertex pairs (k, 2) of the open mesh as pairs of ``cap.mesh``: a chord split by
    :func:`doubled` becomes its two halves (its ends and midpoint), int64 (k', 2)."""
    P = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if cap.chords.size == 0 or P.size == 0:
        return P
    n = cap.mesh.n_vertices
    key = P.min(axis=1) * n + P.max(axis=1)
    ends = cap.chords[:, :2]
    chord_key = ends.min(axis=1) * n + ends.max(axis=1)
    order = np.argsort(chord_key)
    at = np.clip(np.searchsorted(chord_key[order], key), 0, order.size - 1)
    split = chord_key[order[at]] == key
    c = cap.chords[order[at[split]]]
    halves = np.concatenate([c[:, [0, 2]], c[:, [2, 1]]])
    return np.concatenate([P[~split], halves])


def _split_chords(mesh: TriMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``mesh``'s vertices and faces with every chord (an interior edge whose two ends lie
    on the boundary) split at its midpoint: float64 (n + k, 3), the midpoints appended,
    int64 (m', 3), each face with its orientation, and the chords as (end, end, midpoint),
    int64 (k, 3). A face (a, b, c) with the edge
    opposite a split at p becomes (a, b, p), (a, p, c); with the edges opposite b and c
    split at q and r, (a, r, q), (r, b, c), (r, c, q); with all three split, the 1-to-4
    midpoint subdivision. The midpoints are interior vertices, so no new chord appears."""
    V, F = mesh.vertices, mesh.faces
    ends = np.zeros(mesh.n_vertices, dtype=bool)
    ends[mesh.boundary_vertices] = True
    inner = (mesh.edge_faces >= 0).all(axis=1)
    chords = np.flatnonzero(inner & ends[mesh.edges].all(axis=1))
    if chords.size == 0:
        return np.asarray(V, np.float64), np.asarray(F, np.int64), np.zeros((0, 3), np.int64)
    mid = np.full(mesh.n_edges, -1, dtype=np.int64)
    mid[chords] = mesh.n_vertices + np.arange(chords.size)
    M = mid[mesh.face_edges]  # (m, 3): the midpoint opposite each corner, or -1
    count = (M >= 0).sum(axis=1)
    out = [F[count == 0]]
    one = np.flatnonzero(count == 1)
    i = np.argmax(M[one] >= 0, axis=1)
    a, b, c, p = F[one, i], F[one, (i + 1) % 3], F[one, (i + 2) % 3], M[one, i]
    out += [np.stack([a, b, p], axis=1), np.stack([a, p, c], axis=1)]
    two = np.flatnonzero(count == 2)
    k = np.argmin(M[two] >= 0, axis=1)  # the corner whose opposite edge stays
    a, b, c = F[two, k], F[two, (k + 1) % 3], F[two, (k + 2) % 3]
    q, r = M[two, (k + 1) % 3], M[two, (k + 2) % 3]
    out += [np.stack(t, axis=1) for t in ((a, r, q), (r, b, c), (r, c, q))]
    three = count == 3
    (a, b, c), (pa, pb, pc) = F[three].T, M[three].T
    out += [np.stack(t, axis=1) for t in ((a, pc, pb), (b, pa, pc), (c, pb, pa), (pa, pb, pc))]
    W = np.concatenate([V, V[mesh.edges[chords]].mean(axis=1)])
    split = np.column_stack([mesh.edges[chords], mid[chords]])
    return W, np.concatenate(out).astype(np.int64), split


def cut_caps(
    cap: Capped, vertices: np.ndarray, quads: np.ndarray, vertex_faces: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The quads of the open part (not on a dome, not on the mirror image), with their
    vertices renumbered: float64 (k', 3), int64 (q', 4), and the kept vertices' faces of
    ``cap.mesh``, int64 (k',). ``vertex_faces`` (k,) is each vertex's face of ``cap.mesh``.
    A dome's quads are those whose centres' closest faces are the dome's; the mirror
    image's, those :func:`_facing_open` puts on the copy."""
    if cap.mirrored:
        keep = _facing_open(cap, vertices, quads, vertex_faces)
    else:
        face, _ = closest_surface_points(cap.mesh, vertices[quads].mean(axis=1))
        keep = ~cap.is_cap[face]
    Q = quads[_unpinched(vertices.shape[0], quads, keep)]
    used = np.unique(Q)
    remap = np.full(vertices.shape[0], -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    return vertices[used], remap[Q], vertex_faces[used]


def _facing_open(
    cap: Capped, vertices: np.ndarray, quads: np.ndarray, vertex_faces: np.ndarray
) -> np.ndarray:
    """Whether each quad (q, 4) lies on the open sheet of a mirrored ``cap``: the sheet of
    the faces its corners off the loops lie on (no quad crosses a loop; a corner on a loop
    lies on both sheets); where they are all on the loops (or disagree), its normal (the
    cross product of its diagonals) against the open sheet's face normals at its corners
    (a face of the copy counts with its twin's normal, the opposite of its own)."""
    sheet = np.where(cap.is_cap, -1, 1)[vertex_faces[quads]]  # (q, 4)
    mesh = cap.mesh
    A, B = mesh.vertices[mesh.edges[cap.rim, 0]], mesh.vertices[mesh.edges[cap.rim, 1]]
    p, _ = closest_on_segments(A, B, vertices)
    diagonal = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    off = np.linalg.norm(p - vertices, axis=1) > RIM_TOL * diagonal
    vote = (sheet * off[quads]).sum(axis=1)
    P = vertices[quads]
    normal = np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 1])
    n = mesh.face_normals[vertex_faces[quads]] * sheet[..., None]
    facing = np.einsum("qd,qcd->q", normal, n) > 0.0
    return np.where(vote != 0, vote > 0, facing)


#: A quad vertex within this fraction of the diagonal of a loop of a mirrored surface lies
#: on it (the extraction puts such vertices on the loop's edges up to round-off).
RIM_TOL = 1e-9


def closest_on_segments(
    A: np.ndarray, B: np.ndarray, x: np.ndarray, candidates: int = 16
) -> tuple[np.ndarray, np.ndarray]:
    """The closest points to x (k, 3) on the segments A_i B_i (s, 3), among the
    ``candidates`` segments whose midpoints are nearest: float64 (k, 3) and the segment
    of each, int64 (k,)."""
    mids = 0.5 * (A + B)
    cand = cKDTree(mids).query(x, k=min(candidates, A.shape[0]))[1].reshape(x.shape[0], -1)
    a, d = A[cand], (B - A)[cand]  # (r, c, 3)
    t = np.einsum("rcd,rcd->rc", x[:, None] - a, d) / np.maximum(
        np.einsum("rcd,rcd->rc", d, d), 1e-300
    )
    p = a + np.clip(t, 0.0, 1.0)[..., None] * d
    j = np.argmin(np.einsum("rcd,rcd->rc", p - x[:, None], p - x[:, None]), axis=1)
    rows = np.arange(x.shape[0])
    return p[rows, j], cand[rows, j]


def _unpinched(n_vertices: int, quads: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """``keep`` (bool (q,)) with the dome's quads at each pinched vertex put back: where
    the kept quads meet at a vertex in several fans (two quads touching only at a corner
    across the cut), the quads around that vertex are kept too, so that it becomes an
    interior vertex; at most :data:`PINCH_ROUNDS` rounds (the validity gate judges the
    rest)."""
    for _ in range(PINCH_ROUNDS):
        pinched = np.flatnonzero(quad_vertex_fans(n_vertices, quads[keep]) > 1)
        back = ~keep & np.isin(quads, pinched).any(axis=1)
        if not back.any():
            break
        keep = keep | back
    return keep


def snap_boundary(
    mesh: TriMesh, vertices: np.ndarray, quads: np.ndarray, vertex_faces: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The quads' boundary vertices moved to their closest points on ``mesh``'s boundary.

    Returns the vertices float64 (k, 3) and the input face of each, int64 (k,). The
    quads' boundary then lies on the input's boundary loops (their edges are chords of
    them), not beside them.
    """
    rim = quad_boundary_vertices(quads)
    b = mesh.boundary_edges
    if rim.size == 0 or b.size == 0:
        return vertices, vertex_faces
    A, B = mesh.vertices[mesh.edges[b, 0]], mesh.vertices[mesh.edges[b, 1]]
    p, segment = closest_on_segments(A, B, vertices[rim])
    V = vertices.copy()
    V[rim] = p
    vf = vertex_faces.copy()
    ef = mesh.edge_faces[b[segment]]
    vf[rim] = np.where(ef[:, 0] >= 0, ef[:, 0], ef[:, 1])
    return V, vf
