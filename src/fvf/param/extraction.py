r"""Quad extraction from an integer-seamless parameterization (after Ebke et al. 2013, QEx).

Input: per-corner coordinates uv (m, 3, 2) whose transitions across every edge are a
rotation by k·90° plus an integer translation. The quad mesh is the integer grid pulled
back to the surface:

1. **Vertices** are the integer points of the uv triangles, identified across faces by a
   canonical key: (face, point) inside a face, (edge, point in the chart of the edge's
   first face) on an edge, the mesh vertex at a corner.
2. **Rays**: at each vertex the unit directions ±∂u, ±∂v leaving it, each owned by exactly
   one face (half-open sectors: a ray along an edge belongs to the face on its left); a
   regular vertex has 4 rays, a cone of index k/4 has 4 − k.
3. **Edges**: every ray is traced for one unit of uv through the triangles, changing chart
   by the edge transitions, until it reaches the next integer point (a vectorized walk,
   all rays at once).
4. **Faces**: at the end of a ray the reverse ray is the opposite half-edge; the next
   half-edge of a face is the ray just clockwise of it at that vertex (the quad lies to
   the left). Quads are the cycles of that permutation.

The result is checked: every half-edge has an opposite, every cycle has four half-edges,
and V − E + F = χ. Anything else raises :class:`fvf.QuadExtractionError` naming the
triangles where it went wrong.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..errors import QuadExtractionError, format_indices
from ..mesh.convert import takes_mesh
from ..mesh.trimesh import TriMesh
from ..numerics.summary import html_repr, short_repr
from .seams import ROTATIONS

__all__ = ["QuadMesh", "extract_quads", "edge_transitions"]

#: Distance (in uv units) below which a point counts as lying on a triangle edge.
ON_EDGE_TOL = 1e-7
#: uv coordinates closer than this to an integer are snapped to it before extraction.
SNAP_TOL = 1e-6
#: Walks longer than this many triangle crossings are treated as lost.
MAX_STEPS = 10_000

DIRS = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])


@dataclass(frozen=True)
class QuadMesh:
    """A quad mesh extracted from a parameterization.

    Attributes
    ----------
    vertices : float64 (k, 3)
    quads : int64 (q, 4)
        Counter-clockwise about the input's outward normal.
    vertex_face : int64 (k,)
        Input triangle containing each quad vertex.
    vertex_uv : float64 (k, 2)
        Integer uv of each quad vertex in the chart of ``vertex_face``.
    valence : int64 (k,)
    quad_faces : int64 (q, 4)
        Input triangle in which each quad corner's outgoing edge starts.
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    vertices: np.ndarray
    quads: np.ndarray
    vertex_face: np.ndarray
    vertex_uv: np.ndarray
    valence: np.ndarray
    quad_faces: np.ndarray


@takes_mesh
def edge_transitions(mesh: TriMesh, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Chart changes across each face's edges: x_g = R^q x_f + c, g = face_adjacency[f, j].

    Returns
    -------
    q : int64 (m, 3)
    c : float64 (m, 3, 2)
        Rounded to integers.
    defect : float64 (m, 3)
        Misfit of the edge's uv under the best rotation and of c to an integer.
    """
    F = mesh.faces
    adj = mesh.face_adjacency
    m = mesh.n_faces
    f = np.repeat(np.arange(m), 3)
    j = np.tile(np.arange(3), m)
    g = adj.ravel()
    ok = g >= 0
    q = np.zeros(3 * m, dtype=np.int64)
    c = np.zeros((3 * m, 2))
    defect = np.zeros(3 * m)
    f, j, g = f[ok], j[ok], g[ok]
    a, b = F[f, (j + 1) % 3], F[f, (j + 2) % 3]
    ja = np.argmax(F[g] == a[:, None], axis=1)
    jb = np.argmax(F[g] == b[:, None], axis=1)
    A0, B0 = uv[f, (j + 1) % 3], uv[f, (j + 2) % 3]
    A1, B1 = uv[g, ja], uv[g, jb]
    err = np.stack(
        [
            np.linalg.norm(np.einsum("ij,ej->ei", ROTATIONS[k], B0 - A0) - (B1 - A1), axis=1)
            for k in range(4)
        ],
        axis=1,
    )
    k = np.argmin(err, axis=1)
    cc = A1 - np.einsum("eij,ej->ei", ROTATIONS[k], A0)
    cr = np.round(cc)
    q[ok] = k
    c[ok] = cr
    defect[ok] = err[np.arange(k.size), k] + np.abs(cc - cr).max(axis=1)
    return q.reshape(m, 3), c.reshape(m, 3, 2), defect.reshape(m, 3)


def _edge_geometry(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inward unit normals n (.., 3, 2) and offsets: d_j(x) = n_j · (x − P_{j+1})."""
    e = P[..., [2, 0, 1], :] - P[..., [1, 2, 0], :]  # edge j runs P_{j+1} → P_{j+2}
    n = np.stack([-e[..., 1], e[..., 0]], axis=-1)  # left normal = inward for ccw
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return n, P[..., [1, 2, 0], :]


def _distances(n: np.ndarray, base: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Signed distances (k, 3) of points x (k, 2) to the edge lines (inside positive)."""
    return np.einsum("kjd,kjd->kj", n, x[:, None, :] - base)


def _integer_points(uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All (face, integer point) pairs with the point in the closed uv triangle."""
    lo = np.ceil(uv.min(axis=1) - ON_EDGE_TOL).astype(np.int64)
    hi = np.floor(uv.max(axis=1) + ON_EDGE_TOL).astype(np.int64)
    nx = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0)
    ny = np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    cnt = nx * ny
    f = np.repeat(np.arange(uv.shape[0]), cnt)
    start = np.repeat(np.cumsum(cnt) - cnt, cnt)
    local = np.arange(f.size) - start
    x = np.stack([lo[f, 0] + local % nx[f], lo[f, 1] + local // nx[f]], axis=1).astype(float)
    n, base = _edge_geometry(uv[f])
    d = _distances(n, base, x)
    inside = (d >= -ON_EDGE_TOL).all(axis=1)
    return f[inside], x[inside], d[inside]


def _point_keys(
    mesh: TriMesh, f: np.ndarray, x: np.ndarray, d: np.ndarray, q: np.ndarray, c: np.ndarray
) -> np.ndarray:
    """Canonical key (kind, element, iu, iv) of integer points x in faces f, int64 (k, 4)."""
    on = np.abs(d) <= ON_EDGE_TOL
    z = on.sum(axis=1)
    keys = np.zeros((f.size, 4), dtype=np.int64)
    ix = np.round(x).astype(np.int64)
    face_pt = z == 0
    keys[face_pt] = np.column_stack([np.zeros(face_pt.sum(), np.int64), f[face_pt], ix[face_pt]])
    edge_pt = np.flatnonzero(z == 1)
    if edge_pt.size:
        j = np.argmax(on[edge_pt], axis=1)
        ff = f[edge_pt]
        e = mesh.face_edges[ff, j]
        f0 = mesh.edge_faces[e, 0]
        xe = x[edge_pt].copy()
        other = ff != f0
        if other.any():
            # x lives in ff's chart; f0 = adjacency[ff, j]: x0 = R^q x + c
            k = q[ff[other], j[other]]
            xe[other] = (
                np.einsum("eij,ej->ei", ROTATIONS[k], x[edge_pt][other]) + c[ff[other], j[other]]
            )
        keys[edge_pt] = np.column_stack(
            [np.ones(edge_pt.size, np.int64), e, np.round(xe).astype(np.int64)]
        )
    vert_pt = np.flatnonzero(z >= 2)
    if vert_pt.size:
        if (z[vert_pt] > 2).any():
            bad = f[vert_pt[z[vert_pt] > 2]]
            raise QuadExtractionError(
                f"uv triangles {format_indices(np.unique(bad))} are degenerate (zero area); "
                "the parameterization must map every triangle to a proper uv triangle"
            )
        corner = np.argmin(on[vert_pt], axis=1)  # the edge not touched is opposite it
        v = mesh.faces[f[vert_pt], corner]
        keys[vert_pt] = np.column_stack(
            [np.full(vert_pt.size, 2, np.int64), v, np.zeros((vert_pt.size, 2), np.int64)]
        )
    return keys


def _fan_positions(mesh: TriMesh) -> np.ndarray:
    """Position of each corner in the counter-clockwise fan of its vertex, int64 (m, 3).

    Pointer jumping along next(corner) = the same vertex's corner in the next face
    counter-clockwise (across the edge to P_{k+2}); position 0 is the vertex's first corner.
    """
    F, adj = mesh.faces, mesh.face_adjacency
    m = mesh.n_faces
    f = np.repeat(np.arange(m), 3)
    k = np.tile(np.arange(3), m)
    g = adj[f, (k + 1) % 3]
    v = F[f, k]
    kg = np.argmax(F[g] == v[:, None], axis=1)
    nxt = 3 * g + kg
    corner = np.arange(3 * m)
    first = np.full(mesh.n_vertices, 3 * m, dtype=np.int64)
    np.minimum.at(first, v, corner)
    is_start = first[v] == corner
    jump = np.where(is_start, corner, nxt)
    steps = np.where(is_start, 0, 1).astype(np.int64)
    for _ in range(int(np.ceil(np.log2(max(2, 3 * m)))) + 1):
        steps = steps + steps[jump]
        jump = jump[jump]
        if np.all(is_start[jump]):
            break
    valence = np.bincount(v, minlength=mesh.n_vertices)
    return ((valence[v] - steps) % valence[v]).reshape(m, 3)


def _owned(n: np.ndarray, dist: np.ndarray, dvec: np.ndarray) -> np.ndarray:
    """Does the ray (on-edge distances dist (k,3), direction dvec (k,2)) enter the face?

    Half-open rule: for each edge the point lies on, the direction must point inside, or
    run along the edge with the inside on its left.
    """
    on = np.abs(dist) <= ON_EDGE_TOL
    dn = np.einsum("kjd,kd->kj", n, dvec)
    left = np.stack([-dvec[:, 1], dvec[:, 0]], axis=1)
    ln = np.einsum("kjd,kd->kj", n, left)
    tol = 1e-9
    ok = (dn > tol) | ((np.abs(dn) <= tol) & (ln > 0))
    return np.all(ok | ~on, axis=1)


@dataclass
class _Rays:
    point: np.ndarray  # (r,)
    face: np.ndarray  # (r,)
    origin: np.ndarray  # (r, 2)
    dir: np.ndarray  # (r,) 0..3
    key: np.ndarray  # (r,) sort key within the point: fan position * 8 + angle


def _rays(
    mesh: TriMesh,
    uv: np.ndarray,
    f: np.ndarray,
    x: np.ndarray,
    d: np.ndarray,
    pid: np.ndarray,
    fanpos: np.ndarray,
) -> _Rays:
    """All owned outgoing rays of all point occurrences."""
    k = f.size
    ff = np.repeat(f, 4)
    xx = np.repeat(x, 4, axis=0)
    dd = np.repeat(d, 4, axis=0)
    di = np.tile(np.arange(4), k)
    n, _ = _edge_geometry(uv[ff])
    own = _owned(n, dd, DIRS[di])
    ff, xx, dd, di, pp = ff[own], xx[own], dd[own], di[own], np.repeat(pid, 4)[own]
    on = np.abs(dd) <= ON_EDGE_TOL
    z = on.sum(axis=1)
    P = uv[ff]
    start = np.tile([1.0, 0.0], (ff.size, 1))
    pos = np.zeros(ff.size, dtype=np.int64)
    e1 = z == 1
    j = np.argmax(on, axis=1)
    start[e1] = P[e1, (j[e1] + 2) % 3] - P[e1, (j[e1] + 1) % 3]
    e = mesh.face_edges[ff, j]
    pos[e1] = (mesh.edge_faces[e[e1], 0] != ff[e1]).astype(np.int64)
    v2 = z >= 2
    corner = np.argmin(on, axis=1)
    start[v2] = P[v2, (corner[v2] + 1) % 3] - P[v2, corner[v2]]
    pos[v2] = fanpos[ff[v2], corner[v2]]
    dv = DIRS[di]
    ang = np.arctan2(start[:, 0] * dv[:, 1] - start[:, 1] * dv[:, 0], (start * dv).sum(axis=1))
    ang = np.mod(ang, 2 * np.pi)
    ang[np.isclose(ang, 2 * np.pi)] = 0.0
    return _Rays(pp, ff, xx, di, pos * 8.0 + ang)


def _trace(
    mesh: TriMesh, uv: np.ndarray, q: np.ndarray, c: np.ndarray, rays: _Rays
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Walk each ray one unit; returns arrival face, arrival point (uv) and direction."""
    adj = mesh.face_adjacency
    r = rays.point.size
    face = rays.face.copy()
    x = rays.origin.copy()
    dvec = DIRS[rays.dir].copy()
    T = x + dvec
    entry = np.full(r, -1, dtype=np.int64)
    active = np.arange(r)
    done = np.zeros(r, dtype=bool)
    # local index in the neighbour of the shared edge
    F = mesh.faces
    for _ in range(MAX_STEPS):
        if active.size == 0:
            break
        fa = face[active]
        n, base = _edge_geometry(uv[fa])
        dT = _distances(n, base, T[active])
        arrived = (dT >= -ON_EDGE_TOL).all(axis=1)
        done[active[arrived]] = True
        act = active[~arrived]
        if act.size == 0:
            active = act
            break
        n, base, dT = n[~arrived], base[~arrived], dT[~arrived]
        dx = _distances(n, base, x[act])
        out = dT < -ON_EDGE_TOL
        out[np.arange(act.size), np.maximum(entry[act], 0)] &= entry[act] < 0
        s = np.where(out, np.clip(dx, 0, None) / np.maximum(dx - dT, 1e-300), np.inf)
        j = np.argmin(s, axis=1)
        sj = np.clip(s[np.arange(act.size), j], 0.0, 1.0)
        fa = face[act]
        g = adj[fa, j]
        if (g < 0).any():
            raise QuadExtractionError(
                f"an iso-line left the surface through a boundary edge of triangles "
                f"{format_indices(np.unique(fa[g < 0]))}"
            )
        k = q[fa, j]
        Rk = ROTATIONS[k].astype(float)
        xc = x[act] + sj[:, None] * (T[act] - x[act])
        x[act] = np.einsum("eij,ej->ei", Rk, xc) + c[fa, j]
        T[act] = np.einsum("eij,ej->ei", Rk, T[act]) + c[fa, j]
        dvec[act] = np.einsum("eij,ej->ei", Rk, dvec[act])
        # entry edge in g: the edge shared with fa
        a = F[fa, (j + 1) % 3]
        b = F[fa, (j + 2) % 3]
        Fg = F[g]
        entry[act] = 3 - np.argmax(Fg == a[:, None], axis=1) - np.argmax(Fg == b[:, None], axis=1)
        face[act] = g
        active = act
    if active.size:
        raise QuadExtractionError(
            f"{active.size} iso-lines did not reach an integer point within {MAX_STEPS} "
            f"triangles (starting in triangles {format_indices(np.unique(rays.face[active]))})"
        )
    return face, T, dvec


def _lookup(sorted_keys: np.ndarray, order: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Row index of each key row in a lexicographically sorted key table (−1 if absent)."""
    kv = keys.view([("", keys.dtype)] * keys.shape[1]).ravel()
    sv = sorted_keys.view([("", sorted_keys.dtype)] * sorted_keys.shape[1]).ravel()
    pos = np.clip(np.searchsorted(sv, kv), 0, sv.size - 1)
    hit = sv[pos] == kv
    return np.where(hit, order[pos], -1)


@takes_mesh
def extract_quads(mesh: TriMesh, uv: npt.ArrayLike) -> QuadMesh:
    """Quad mesh of the integer grid of an integer-seamless parameterization.

    Parameters
    ----------
    mesh : TriMesh
        Closed.
    uv : array_like (m, 3, 2)
        Per-corner coordinates; across every edge the two sides must differ by a rotation
        by k·90° and an integer translation, and no uv triangle may be flipped.

    Returns
    -------
    QuadMesh

    Raises
    ------
    QuadExtractionError
        Flipped or degenerate uv triangles, non-integer transitions, or a grid that does
        not close into quads (the message names the triangles).
    """
    uv = np.array(uv, dtype=np.float64)
    _check_uv(mesh, uv)
    # coordinates within round-off of a grid line are put on it: transitions map integers
    # to integers, so both sides of every edge snap alike, and iso-lines that run along
    # mesh edges become exactly collinear with them
    near = np.abs(uv - np.round(uv)) < SNAP_TOL
    uv[near] = np.round(uv[near])
    _check_uv(mesh, uv)
    q, c, defect = edge_transitions(mesh, uv)
    bad = np.flatnonzero((defect > 1e-6).any(axis=1))
    if bad.size:
        raise QuadExtractionError(
            f"the parameterization is not integer-seamless across edges of triangles "
            f"{format_indices(bad)} (transition misfit up to {defect.max():.2g}); round it "
            "first (fvf.seamless_parameterization)"
        )
    f, x, d = _integer_points(uv)
    if f.size == 0:
        raise QuadExtractionError(
            "the parameterization has no integer point: the target is too coarse; "
            "ask for more faces (a smaller edge length)"
        )
    keys = _point_keys(mesh, f, x, d, q, c)
    ukeys, first, pid = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    pid = pid.ravel()
    npts = ukeys.shape[0]
    fanpos = _fan_positions(mesh)
    rays = _rays(mesh, uv, f, x, d, pid, fanpos)
    hface, hT, hdir = _trace(mesh, uv, q, c, rays)
    # destination point of every half-edge
    n, base = _edge_geometry(uv[hface])
    dT = _distances(n, base, hT)
    dkeys = _point_keys(mesh, hface, hT, dT, q, c)
    dst = _lookup(ukeys, np.arange(npts), dkeys)
    if (dst < 0).any():
        raise QuadExtractionError(
            f"iso-lines ended at points that were not found as grid vertices (triangles "
            f"{format_indices(np.unique(hface[dst < 0]))})"
        )
    opp = _opposites(mesh, uv, rays, hface, hT, hdir, dT, dst, q, c)
    quads, quad_he = _faces(rays, opp, npts)
    # vertex positions from a representative occurrence
    fv, xv = f[first], x[first]
    P = uv[fv]
    bary = _barycentric(P, xv)
    X = np.einsum("ki,kid->kd", bary, mesh.vertices[mesh.faces[fv]])
    valence = np.bincount(rays.point, minlength=npts)
    qm = QuadMesh(X, quads, fv, xv, valence, rays.face[quad_he])
    _check_result(mesh, qm)
    return qm


def _check_uv(mesh: TriMesh, uv: np.ndarray) -> None:
    if uv.shape != (mesh.n_faces, 3, 2):
        raise QuadExtractionError(f"uv must have shape ({mesh.n_faces}, 3, 2); got {uv.shape}")
    if not np.all(np.isfinite(uv)):
        bad = np.flatnonzero(~np.isfinite(uv).all(axis=(1, 2)))
        raise QuadExtractionError(f"uv is not finite on triangles {format_indices(bad)}")
    if not mesh.is_closed:
        raise QuadExtractionError(
            f"quad extraction needs a closed mesh; boundary vertices "
            f"{format_indices(mesh.boundary_vertices)}"
        )
    a, b = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    det = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    flipped = np.flatnonzero(~(det > 1e-12))
    if flipped.size:
        raise QuadExtractionError(
            f"{flipped.size} uv triangles are flipped or degenerate (triangles "
            f"{format_indices(flipped)}); the integer grid cannot be pulled back there "
            "(cones closer than one quad edge, or features narrower than one): try another "
            "target — more quads resolve small features, fewer let close cones cancel — or "
            "a smoother cross field (align='smooth')"
        )


def _barycentric(P: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (k, 3) of x (k, 2) in uv triangles P (k, 3, 2)."""
    a, b = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    det = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    p = x - P[:, 0]
    l1 = (p[:, 0] * b[:, 1] - p[:, 1] * b[:, 0]) / det
    l2 = (a[:, 0] * p[:, 1] - a[:, 1] * p[:, 0]) / det
    bary = np.stack([1 - l1 - l2, l1, l2], axis=1)
    return np.clip(bary, 0.0, 1.0) / np.clip(bary, 0.0, 1.0).sum(axis=1, keepdims=True)


def _directions_3d(mesh: TriMesh, uv: np.ndarray, faces: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Unit 3D tangent directions of uv directions d (k, 2) in faces (k,)."""
    X = mesh.vertices[mesh.faces[faces]]
    P = uv[faces]
    E3 = np.stack([X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]], axis=2)  # (k, 3, 2)
    E2 = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2)  # (k, 2, 2)
    coef = np.linalg.solve(E2, d[..., None])[..., 0]  # d = E2 coef
    v = np.einsum("kij,kj->ki", E3, coef)
    return v / np.linalg.norm(v, axis=1, keepdims=True)


#: Weight of the faces' agreement (normal · normal, in [-1, 1]) beside the 3D direction's
#: (in [-1, 1]) when a reverse ray is chosen by direction: far below the gap between two
#: grid directions, it only decides between rays of one 3D direction on two sheets.
SHEET_TIE_BREAK = 1e-3


def _opposites(
    mesh: TriMesh,
    uv: np.ndarray,
    rays: _Rays,
    hface: np.ndarray,
    hT: np.ndarray,
    hdir: np.ndarray,
    dT: np.ndarray,
    dst: np.ndarray,
    q: np.ndarray,
    c: np.ndarray,
) -> np.ndarray:
    """For each traced ray, the ray leaving its end point back along it (−1 if none).

    Usually the reverse ray lies in the face where the trace arrived; when the half-open
    rule gives it to another face around the end point (a ray along or through a mesh
    edge or vertex), it is the ray at that point whose 3D direction is closest to the
    reverse direction; of two rays in the same 3D direction (two sheets that lie on each
    other: a surface glued to its mirror image, :func:`fvf.param.caps.doubled`), the one
    whose face faces the same way as the face the trace arrived in.
    """
    back = -hdir
    di = np.argmax(np.einsum("kd,jd->kj", back, DIRS), axis=1)
    n, _ = _edge_geometry(uv[hface])
    own = _owned(n, dT, back)
    table = np.column_stack([rays.point, rays.face, rays.dir])
    order = np.lexsort(table.T[::-1])
    out = _lookup(table[order], order, np.column_stack([dst, hface, di]))
    fix = np.flatnonzero(~own | (out < 0))
    if fix.size:
        want = _directions_3d(mesh, uv, hface[fix], back[fix])
        ray_dirs = _directions_3d(mesh, uv, rays.face, DIRS[rays.dir])
        by_point = np.argsort(rays.point, kind="stable")
        start = np.searchsorted(rays.point[by_point], dst[fix], side="left")
        stop = np.searchsorted(rays.point[by_point], dst[fix], side="right")
        normals = mesh.face_normals
        for i, (lo, hi) in enumerate(zip(start, stop, strict=True)):  # the few ambiguous rays
            cand = by_point[lo:hi]
            if cand.size:
                side = normals[rays.face[cand]] @ normals[hface[fix[i]]]
                score = ray_dirs[cand] @ want[i] + SHEET_TIE_BREAK * side
                out[fix[i]] = cand[np.argmax(score)]
    return out


def _faces(rays: _Rays, opp: np.ndarray, npts: int) -> tuple[np.ndarray, np.ndarray]:
    """Quads as cycles of next(h) = the ray clockwise of opp(h) at its start point."""
    r = rays.point.size
    bad = np.flatnonzero(opp < 0)
    if bad.size or np.any(opp[opp] != np.arange(r)):
        if not bad.size:
            bad = np.flatnonzero(opp[opp] != np.arange(r))
        raise QuadExtractionError(
            f"{bad.size} grid edges have no matching opposite edge (starting in triangles "
            f"{format_indices(np.unique(rays.face[bad]))}); the parameterization is locally "
            "degenerate there"
        )
    order = np.lexsort((rays.key, rays.point))
    pt = rays.point[order]
    first = np.searchsorted(pt, pt, side="left")
    last = np.searchsorted(pt, pt, side="right") - 1
    idx = np.arange(r)
    prev_sorted = np.where(idx == first, last, idx - 1)  # cyclic clockwise neighbour
    cw = np.empty(r, dtype=np.int64)
    cw[order] = order[prev_sorted]
    nxt = cw[opp]
    G = sp.coo_array((np.ones(r), (np.arange(r), nxt)), shape=(r, r))
    k, lab = connected_components(G, directed=True, connection="strong")
    size = np.bincount(lab, minlength=k)
    if np.any(size != 4):
        badc = np.flatnonzero(size != 4)
        inv = np.isin(lab, badc)
        raise QuadExtractionError(
            f"{badc.size} faces of the grid are not quads (sizes "
            f"{format_indices(np.unique(size[badc]))}; near triangles "
            f"{format_indices(np.unique(rays.face[inv]))}): the target is too coarse for the "
            "field's singularities, or the parameterization is degenerate there"
        )
    head = np.full(k, r, dtype=np.int64)
    np.minimum.at(head, lab, np.arange(r))
    h0 = head
    h1 = nxt[h0]
    h2 = nxt[h1]
    h3 = nxt[h2]
    he = np.stack([h0, h1, h2, h3], axis=1)
    return rays.point[he].astype(np.int64), he


def _check_result(mesh: TriMesh, qm: QuadMesh) -> None:
    V, Q = qm.vertices.shape[0], qm.quads.shape[0]
    edges = np.sort(
        np.stack([qm.quads, np.roll(qm.quads, -1, axis=1)], axis=2).reshape(-1, 2), axis=1
    )
    ue, cnt = np.unique(edges, axis=0, return_counts=True)
    chi = V - ue.shape[0] + Q
    degenerate = np.flatnonzero(
        (qm.quads[:, [0, 1, 2, 3]] == qm.quads[:, [1, 2, 3, 0]]).any(axis=1)
        | (qm.quads[:, 0] == qm.quads[:, 2])
        | (qm.quads[:, 1] == qm.quads[:, 3])
    )
    if degenerate.size or np.any(cnt != 2) or chi != mesh.euler_characteristic:
        tri = np.unique(qm.quad_faces[degenerate]) if degenerate.size else np.zeros(0, int)
        raise QuadExtractionError(
            f"the extracted quad mesh is not a closed manifold of the input's topology "
            f"(χ {chi} vs {mesh.euler_characteristic}, {int(np.sum(cnt != 2))} non-manifold "
            f"edges, {degenerate.size} quads with a repeated vertex near triangles "
            f"{format_indices(tri)}): the target is too coarse for the topology; ask for "
            "more faces"
        )
