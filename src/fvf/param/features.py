r"""Sharp features: the edges a quad mesh of a CAD part must follow.

An interior edge e with faces s, t is **sharp** when its dihedral angle — the angle
between the face normals, :math:`\theta_e = \arccos \langle N_s, N_t \rangle` — exceeds
the crease angle (default :data:`CREASE_ANGLE` degrees, suited to CAD: a 90° edge of a
box is sharp, the facets of a cylinder tessellated with 32 sections, 11.25° apart, are
not). Users may give the feature edges themselves.

Scans have sharp edges too — noise, coarse fingers — amid other rough edges: an edge is a
feature only when the other edges of its two faces are smooth (dihedral below
:data:`SMOOTH_SIDES` × the crease angle; the CAD corpus's crease edges have at most 4°
beside them, the shared scans' 5–30°), or when they bend only about axes across it: the
rim of a tessellated hole or boss, whose wall facets meet at 7.5° (48 sections) to 30°
(OpenSCAD's default 12) along edges perpendicular to the rim. An edge f beside e bends
the surface by :math:`\theta_f` about its own direction, of which
:math:`\theta_f\,|\cos\angle(f, e)|` is a bend about an axis along e (a second, rounded
crease beside it); that part must stay below :data:`CROSS_BEND` degrees. Only chains of
such edges at least :data:`MIN_CHAIN` quad edges long count, and not those that lie within
that length of a vertex where :data:`STAR_EDGES` or more of their edges meet: a spike's
tip, whose steep sides are sharp edges about a point, smaller than the quads.

The default cross field is constrained on every face next to a feature edge to the
direction of that edge (hard constraints of :func:`fvf.design_field`; the longest
feature edge of a face wins), so that quad edges run along the features. The measure of
success is the **feature coverage** (:func:`feature_coverage`): the fraction of the
features' length within a quarter quad edge of a quad edge.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..errors import ParameterError, format_indices
from ..mesh.geometry import readonly, segment_points
from ..mesh.trimesh import TriMesh

__all__ = [
    "CREASE_ANGLE",
    "dihedral_angles",
    "sharp_edges",
    "long_chains",
    "feature_density",
    "feature_edge_ids",
    "feature_constraints",
    "feature_coverage",
    "transferred_features",
]

#: Default crease angle in degrees (an edge sharper than this is a feature).
CREASE_ANGLE = 35.0
#: A chain of sharp edges shorter than this many quad edges is no feature.
MIN_CHAIN = 2.0
#: A sharp edge is a feature only when the other edges of its two faces are flatter than
#: this fraction of the crease angle (CAD: ≤ 4° beside 90° edges; scans: 5–30°).
SMOOTH_SIDES = 1.0 / 6.0
#: ... or when the edges beside it bend about axes across it: their bend about an axis
#: along it stays below this many degrees (a tessellated cylinder's wall: 0; on the shared
#: scans at 0.5° the lion gains one feature edge of 91, the knight two of 77, none else).
CROSS_BEND = 0.5
#: A chain of sharp edges within the chain length asked of it (MIN_CHAIN quad edges) of a
#: vertex where at least this many of them meet is no feature: the tip of a scan's spike,
#: whose sides (and often the ring below them) are sharp edges about a point.
STAR_EDGES = 3
#: Sharp edges whose length in all exceeds this many times A / h (:func:`feature_density`)
#: are a texture at the quad scale — a thread, a knurl — not features: a quad mesh of edge
#: h has about 2 A / h of edges, fewer than the features would need (a cube at one quad
#: per side: exactly 2; an M8 bolt's thread at 2,000 quads: 13.7; 67 other CAD parts at
#: 2,000 quads: at most 0.67).
DENSE_FEATURES = 2.0


def dihedral_angles(mesh: TriMesh) -> np.ndarray:
    """Angle between the normals of each edge's two faces, degrees, float64 (E,); 0 on
    boundary edges. Cached on the mesh (read-only)."""

    def build() -> np.ndarray:
        ef = mesh.edge_faces
        both = (ef >= 0).all(axis=1)
        out = np.zeros(ef.shape[0])
        N = mesh.face_normals
        cos = np.einsum("kd,kd->k", N[ef[both, 0]], N[ef[both, 1]])
        out[both] = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
        return readonly(out)

    return mesh.cached("dihedral_angles", build)


def feature_density(mesh: TriMesh, edges: np.ndarray, h: float) -> float:
    r"""The feature edges' length over the surface's $A / h$, float.

    A quad mesh of edge $h$ on area $A$ has about $2A/h$ of edges, so a density $\rho$
    asks for a fraction $\rho / 2$ of them along the features; above
    :data:`DENSE_FEATURES` the features are denser than the quads can follow.

    Parameters
    ----------
    mesh : TriMesh
    edges : int (k,)
        Indices into ``mesh.edges``.
    h : float
        The quad edge length.
    """
    E = mesh.edges[np.asarray(edges, dtype=np.int64)]
    length = float(np.linalg.norm(mesh.vertices[E[:, 1]] - mesh.vertices[E[:, 0]], axis=1).sum())
    return length * h / mesh.total_area


def sharp_edges(
    mesh: TriMesh, crease_angle: float = CREASE_ANGLE, min_length: float = 0.0
) -> np.ndarray:
    """Indices into ``mesh.edges`` of the sharp edges, int64 (k,).

    With ``min_length`` > 0, only chains of sharp edges (connected through shared
    vertices) at least that long are kept: a CAD crease runs on, the creases of a scan's
    noise or of a coarse organic mesh are short and scattered. Chains within
    ``min_length`` of a vertex where :data:`STAR_EDGES` or more of their edges meet (a
    spike's tip) are dropped with them.
    """
    a = float(crease_angle)
    if not (0.0 < a < 180.0):
        raise ParameterError(f"crease_angle must be in (0, 180) degrees; got {crease_angle!r}")
    d = dihedral_angles(mesh)
    over = d > a
    bent = np.flatnonzero(over)  # the only edges the two tests below are asked about
    smooth = (_side_roughness(mesh, over, d, bent) < SMOOTH_SIDES * a) | (
        _bend_along(mesh, over, d, bent) < CROSS_BEND
    )
    return long_chains(mesh, bent[smooth], min_length)


def long_chains(mesh: TriMesh, edges: np.ndarray, min_length: float) -> np.ndarray:
    """The edges of ``edges`` (indices into ``mesh.edges``, int (k,)) in chains (joined
    through shared vertices) at least ``min_length`` long and not within that length of
    a vertex where :data:`STAR_EDGES` or more of them meet (a spike's tip), int64; all of
    them when ``min_length`` ≤ 0."""
    edges = np.asarray(edges, dtype=np.int64)
    if min_length <= 0 or edges.size == 0:
        return edges
    E = mesh.edges[edges]
    n = mesh.n_vertices
    graph = sp.coo_matrix((np.ones(edges.size), (E[:, 0], E[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    own = label[E[:, 0]]  # (k,) each edge's chain
    length = np.linalg.norm(mesh.vertices[E[:, 1]] - mesh.vertices[E[:, 0]], axis=1)
    chain = np.bincount(own, weights=length, minlength=n)
    tip = _is_tip(mesh.vertices, E, label, min_length)
    return edges[(chain[own] >= min_length) & ~tip[own]]


def _is_tip(X: np.ndarray, E: np.ndarray, label: np.ndarray, radius: float) -> np.ndarray:
    """Per chain label (n,), bool: the chain of sharp edges ``E`` int (k, 2) lies within
    ``radius`` of its vertex with the most of them (its hub), where :data:`STAR_EDGES` or
    more meet: the tip of a spike, a point at the quad scale."""
    n = X.shape[0]
    degree = np.bincount(E.ravel(), minlength=n)  # in the graph of the sharp edges
    verts = np.unique(E)
    v = verts[np.lexsort((degree[verts], label[verts]))]  # by chain, the hub last
    chain = label[v]
    last = np.r_[chain[1:] != chain[:-1], True]
    hub = np.full(n, -1, dtype=np.int64)
    hub[chain[last]] = v[last]
    far = np.linalg.norm(X[v] - X[hub[chain]], axis=1) > radius
    tip = np.zeros(n, dtype=bool)
    tip[chain[last]] = (np.bincount(chain, weights=far, minlength=n)[chain[last]] == 0) & (
        degree[v[last]] >= STAR_EDGES
    )
    return tip


def _side_roughness(
    mesh: TriMesh, sharp: np.ndarray, d: np.ndarray, edges: np.ndarray
) -> np.ndarray:
    """Per edge of ``edges`` (k,): the largest dihedral angle of the other, not
    ``sharp``, edges of its two faces (0 where there is none)."""
    fe = mesh.face_edges
    ef = mesh.edge_faces[edges]  # (k, 2)
    g = np.maximum(ef, 0)
    other = np.where(sharp[fe[g]], 0.0, d[fe[g]]).max(axis=2)  # (k, 2) per face
    return np.where(ef >= 0, other, 0.0).max(axis=1)


def _bend_along(mesh: TriMesh, sharp: np.ndarray, d: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Per edge e of ``edges`` (k,), degrees: the largest θ_f |cos∠(f, e)| over the
    other, not ``sharp``, edges f of its two faces (θ_f their dihedral angles ``d``): the
    bend beside e about an axis along e. 0 on a tessellated cylinder's rim, whose wall
    facets meet along edges perpendicular to it."""
    X, E = mesh.vertices, mesh.edges

    def tangent(i: np.ndarray) -> np.ndarray:  # unit, (..., 3)
        t = X[E[i, 1]] - X[E[i, 0]]
        return t / np.maximum(np.linalg.norm(t, axis=-1, keepdims=True), 1e-300)

    fe, ef = mesh.face_edges, mesh.edge_faces[edges]
    out = np.zeros(len(edges))
    for side in (0, 1):
        has = np.flatnonzero(ef[:, side] >= 0)
        others = fe[ef[has, side]]  # (h, 3) the edges of the face on this side
        cos = np.abs(np.einsum("kjd,kd->kj", tangent(others), tangent(edges[has])))
        bend = np.where(sharp[others], 0.0, d[others] * cos).max(axis=1)
        out[has] = np.maximum(out[has], bend)
    return out


def feature_edge_ids(mesh: TriMesh, pairs: npt.ArrayLike) -> np.ndarray:
    """Edge ids of vertex pairs ``pairs`` int (k, 2) (either order), int64 (k,).

    Raises :class:`fvf.ParameterError` naming the pairs that are not edges of the mesh.
    """
    P = np.asarray(pairs)
    if P.size == 0:
        return np.empty(0, dtype=np.int64)
    if P.ndim != 2 or P.shape[1] != 2 or not np.issubdtype(P.dtype, np.integer):
        raise ParameterError(f"feature edges must be integer vertex pairs (k, 2); got {P.shape}")
    ids = mesh.edge_ids(P)
    bad = np.flatnonzero(ids < 0)
    if bad.size:
        raise ParameterError(
            f"feature edges {format_indices(bad)} are not edges of the mesh (vertex pairs "
            "joined by a triangle side, 0-based)"
        )
    return ids


def feature_constraints(mesh: TriMesh, edges: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Faces next to feature edges and the directions they are held to.

    Parameters
    ----------
    mesh : TriMesh
    edges : int (k,)
        Indices into ``mesh.edges``.

    Returns
    -------
    faces : int64 (c,)
        Each face with a feature edge, once.
    directions : float64 (c, 3)
        The unit direction of its longest feature edge.
    """
    e = np.asarray(edges, dtype=np.int64)
    if e.size == 0:
        return np.empty(0, dtype=np.int64), np.empty((0, 3))
    ef = mesh.edge_faces[e]
    face = ef.ravel()
    edge = np.repeat(e, 2)
    keep = face >= 0
    face, edge = face[keep], edge[keep]
    d = mesh.vertices[mesh.edges[edge, 1]] - mesh.vertices[mesh.edges[edge, 0]]
    length = np.linalg.norm(d, axis=1)
    order = np.lexsort((-length, face))  # per face, the longest edge first
    face, d, length = face[order], d[order], length[order]
    first = np.concatenate([[True], face[1:] != face[:-1]])
    return face[first], d[first] / length[first, None]


def feature_coverage(
    mesh: TriMesh, edges: npt.ArrayLike, vertices: npt.ArrayLike, quads: npt.ArrayLike
) -> float:
    """Fraction of the feature length within a quarter quad edge of a quad edge.

    The features are sampled every 1/16 of the mean quad edge, the quad edges densely
    (every 1/16 as well); a feature sample is covered when a quad-edge sample lies within
    a quarter of the mean quad edge. Returns 1.0 when there is no feature.
    """
    e = np.asarray(edges, dtype=np.int64)
    if e.size == 0:
        return 1.0
    V = np.asarray(vertices, dtype=np.float64)
    Q = np.asarray(quads, dtype=np.int64)
    qa, qb = V[Q].reshape(-1, 3), V[np.roll(Q, -1, axis=1)].reshape(-1, 3)
    h = float(np.linalg.norm(qb - qa, axis=1).mean())
    quad_pts = segment_points(qa, qb, h / 16, centred=True, max_count=4096)[0]
    fa = mesh.vertices[mesh.edges[e, 0]]
    fb = mesh.vertices[mesh.edges[e, 1]]
    pts, weight = segment_points(fa, fb, h / 16, centred=True, max_count=4096)
    near = cKDTree(quad_pts).query(pts, distance_upper_bound=0.25 * h)[0] <= 0.25 * h
    return float(weight[near].sum() / weight.sum())


def transferred_features(
    mesh: TriMesh, edges: npt.ArrayLike, surface: TriMesh, crease_angle: float, spacing: float
) -> np.ndarray:
    """The sharp edges of a remeshed ``surface`` that lie on ``mesh``'s feature ``edges``.

    An edge of ``surface`` is kept when it is sharper than ``crease_angle`` and its
    midpoint lies within ``spacing / 4`` of a feature edge of ``mesh`` (so that the
    coarse facets a remeshing creates on a smooth surface are no features). The sides'
    smoothness (:func:`sharp_edges`) is not asked again: the remeshed facets of a hole's
    wall meet the rim at any angle. int64 (k,).
    """
    e = np.asarray(edges, dtype=np.int64)
    cand = np.flatnonzero(dihedral_angles(surface) > float(crease_angle))
    if e.size == 0 or cand.size == 0:
        return np.empty(0, dtype=np.int64)
    a, b = mesh.vertices[mesh.edges[e, 0]], mesh.vertices[mesh.edges[e, 1]]
    pts = segment_points(a, b, spacing / 16, centred=True, max_count=4096)[0]
    mid = surface.vertices[surface.edges[cand]].mean(axis=1)
    d = cKDTree(pts).query(mid, distance_upper_bound=0.25 * spacing)[0]
    return cand[d <= 0.25 * spacing]
