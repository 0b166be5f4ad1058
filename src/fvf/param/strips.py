r"""Thin strips between parallel features: one quad across, stretched.

A CAD part's thin wall ends in a rim, a fin in a top face, a flange in a short band: a
**strip** of surface between two parallel feature curves narrower than a quad edge.
Both curves are integer iso-lines of the parameterization (:func:`fvf.param.seams.feature_rows`),
so the strip is an integer number of quads wide; a strip of width $w < h/2$ rounds to zero
quads, its triangles collapse in uv and no quad mesh can be pulled back. QuadWild's patches
get at least one subdivision across a side for the same reason.

Here such a strip is made **one quad across** by an anisotropic frame: on a face of a
feature patch (a connected set of faces not separated by features) whose extent along
the frame axis $X$, between features parallel to $Y$ on both sides, is $w_X$, the target
gradient is lengthened to

$$|\nabla u| = \max\!\big(a / h,\; 1 / w_X\big) \quad\text{when } w_X\,a < \tfrac{3}{4} h,$$

($a$ the frame's scale, :mod:`fvf.param.frame_field`) and likewise along $Y$, so that the
real solution already puts the two features about one unit apart and rounding keeps them
there. The quads of the strip have aspect $h : w$; the faces beside it keep theirs.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..mesh.geometry import segment_counts, segment_points
from ..mesh.trimesh import TriMesh

__all__ = [
    "STRIP_WIDTH",
    "feature_patches",
    "strip_widths",
    "strip_scale",
    "has_thin_strips",
]

#: A strip narrower than this many (local) quad edges is stretched to one quad across.
STRIP_WIDTH = 0.75
#: A feature counts as a strip's side when it is within this angle of the frame axis.
PARALLEL_DEGREES = 20.0
#: Feature samples per quad edge.
SAMPLES_PER_EDGE = 8
#: :func:`has_thin_strips` looks for strips up to this many times wider than a stretched
#: one (the fitted frame scale shortens quads by up to about this factor).
STRIP_SLACK = 2.0


def feature_patches(mesh: TriMesh, features: np.ndarray) -> np.ndarray:
    """Label of each face's patch, int64 (m,): faces joined across edges that are not
    features (and not boundary edges)."""
    ef = mesh.edge_faces
    keep = np.asarray((ef >= 0).all(axis=1))
    keep[np.asarray(features, dtype=np.int64)] = False
    m = mesh.n_faces
    G = sp.coo_array((np.ones(int(keep.sum())), (ef[keep, 0], ef[keep, 1])), shape=(m, m))
    return connected_components(G, directed=False)[1].astype(np.int64)


def _feature_samples(
    mesh: TriMesh, edges: np.ndarray, step: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points about ``step`` apart along the feature ``edges`` (int64 (k,), into
    ``mesh.edges``), float64 (p, 3); the feature edge of each, int64 (p,); and its unit
    tangent, float64 (p, 3)."""
    a, b = mesh.vertices[mesh.edges[edges, 0]], mesh.vertices[mesh.edges[edges, 1]]
    pts = segment_points(a, b, step, centred=True, max_count=4096)[0]
    length = np.linalg.norm(b - a, axis=1)
    edge = np.repeat(np.arange(edges.size), segment_counts(length, step, 4096))
    return pts, edge, ((b - a) / length[:, None])[edge]


def strip_widths(
    mesh: TriMesh, features: np.ndarray, axes: np.ndarray, radius: float
) -> np.ndarray:
    """Width of each face's patch along each frame axis, float64 (m, 2) (inf: unbounded).

    Parameters
    ----------
    mesh : TriMesh
    features : int (k,)
        Feature edges, indices into ``mesh.edges``.
    axes : float64 (m, 2, 3)
        Per face the unit frame axes X and Y as ambient vectors.
    radius : float
        Features farther from the face's centroid are not looked at.

    Returns
    -------
    float64 (m, 2)
        Column k: the distance between the nearest features of the face's patch on either
        side along axis k that run within :data:`PARALLEL_DEGREES` of the other axis
        (each measured to the feature edge's line, perpendicular to it);
        ``inf`` where one side has none within ``radius``.
    """
    e = np.asarray(features, dtype=np.int64)
    m = mesh.n_faces
    out = np.full((m, 2), np.inf)
    if e.size == 0:
        return out
    patch = feature_patches(mesh, e)
    pts, edge, tangent = _feature_samples(mesh, e, radius / SAMPLES_PER_EDGE)
    ef = mesh.edge_faces[e][edge]
    sides = np.where(ef >= 0, patch[np.maximum(ef, 0)], -1)  # (p, 2) patches beside
    centroid = mesh.face_centroids
    pairs = cKDTree(centroid).sparse_distance_matrix(cKDTree(pts), radius, output_type="ndarray")
    f, s = pairs["i"].astype(np.int64), pairs["j"].astype(np.int64)
    same = (sides[s, 0] == patch[f]) | (sides[s, 1] == patch[f])
    f, s = f[same], s[same]
    cos_parallel = np.cos(np.radians(PARALLEL_DEGREES))
    for k in (0, 1):
        along = np.abs(np.einsum("pd,pd->p", tangent[s], axes[f, 1 - k])) >= cos_parallel
        fk, sk = f[along], s[along]
        t = tangent[sk]
        normal = axes[fk, k] - np.einsum("pd,pd->p", axes[fk, k], t)[:, None] * t
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
        offset = np.einsum("pd,pd->p", pts[sk] - centroid[fk], normal)  # to the feature's line
        ahead = np.full(m, np.inf)
        behind = np.full(m, np.inf)
        np.minimum.at(ahead, fk[offset > 0], offset[offset > 0])
        np.minimum.at(behind, fk[offset <= 0], -offset[offset <= 0])
        out[:, k] = ahead + behind
    return out


def strip_scale(widths: np.ndarray, h: float, scale: np.ndarray) -> np.ndarray:
    """The frame scales (a, b) with the thin strips stretched to one quad, float64 (m, 2).

    ``scale`` (m, 2) is the frame's scale (quads of edge h / scale); where a face's
    :func:`strip_widths` w (m, 2) times its scale is below :data:`STRIP_WIDTH` h, the
    scale becomes h / w (the strip one quad across).
    """
    thin = widths * scale < STRIP_WIDTH * h
    return np.where(thin, np.maximum(scale, h / np.where(thin, widths, 1.0)), scale)


def has_thin_strips(mesh: TriMesh, features: np.ndarray, h: float) -> bool:
    r"""Whether stretching thin strips (:func:`strip_scale`) can change anything, decided
    before any cross field exists.

    The field is held along the features, so beside them its axes are the nearest
    feature's tangent $t$ and $n_f \times t$. :func:`strip_widths` with those axes is
    asked for a strip narrower than :data:`STRIP_SLACK` · :data:`STRIP_WIDTH` · h (the
    slack covers the frame's own scale). Without one, an attempt with thin strips would be
    the attempt without them (:func:`fvf.quad_mesh` skips it).

    Parameters
    ----------
    mesh : TriMesh
    features : int (k,)
        Feature edges, indices into ``mesh.edges``.
    h : float
        The quad edge length.

    Returns
    -------
    bool
    """
    e = np.asarray(features, dtype=np.int64)
    if e.size == 0:
        return False
    limit = STRIP_SLACK * STRIP_WIDTH * h
    pts, _, tangent = _feature_samples(mesh, e, h / SAMPLES_PER_EDGE)
    near = cKDTree(pts).query(mesh.face_centroids, distance_upper_bound=limit)[1]
    faces = np.flatnonzero(near < pts.shape[0])
    if faces.size == 0:
        return False
    n = mesh.face_normals[faces]
    t = tangent[near[faces]]
    t = t - np.einsum("kd,kd->k", t, n)[:, None] * n
    norm = np.linalg.norm(t, axis=1)
    ok = norm > 1e-12  # a feature along the face's normal gives it no axis
    X = np.zeros((mesh.n_faces, 3))
    X[faces[ok]] = t[ok] / norm[ok, None]
    axes = np.stack([X, np.cross(mesh.face_normals, X)], axis=1)
    return bool((strip_widths(mesh, e, axes, limit) < limit).any())
