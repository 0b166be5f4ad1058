"""Per-face tangent vectors as arrows: segments in the faces' planes, and the glyphs drawn.

An arrow of face t starts at the face's centroid c_t and ends at
``c_t + scale · (a_0 b_0 + a_1 b_1)``, where ``(b_0, b_1) = mesh.face_bases[t]`` is the
face's own orthonormal tangent frame and ``(a_0, a_1) = mesh.to_local(v)[t]`` the field's
coordinates in it. The arrow therefore lies in the face's plane (to round-off) and its
length is ``scale · |v_t|`` in the mesh's units: the scale is absolute, never normalised
per face.

Pictures choose the faces that carry an arrow in screen space (:func:`screen_spread`:
about one per ``spacing × spacing`` pixel cell of the picture, on the surface nearest the
eye), so the density is the same whatever the mesh's resolution, and draw each arrow as a
flat glyph in its face's plane (:func:`arrow_glyphs`: a shaft and a head whose sizes are
fractions of the spacing). An N-direction field (one representative per face, the others
its rotations by 2πk/N about the face normal, :func:`direction_set`) is drawn as N strokes
from the centroid (:func:`stroke_glyphs`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..errors import FvfError
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_face_field
from ..mesh.trimesh import TriMesh

__all__ = [
    "DEFAULT_ARROW_LENGTH",
    "arrow_glyphs",
    "arrow_segments",
    "default_arrow_scale",
    "direction_set",
    "screen_spread",
    "spread_faces",
    "stroke_glyphs",
]

#: With the default scale the longest arrow (the robust maximum of |v|) is this many
#: spacings long: mean edge lengths for :func:`default_arrow_scale`, the arrow spacing in
#: pictures.
DEFAULT_ARROW_LENGTH = 1.0

#: Triangles of an arrow glyph's seven corners (shaft quad, then head).
ARROW_TRIANGLES = np.array([[0, 1, 5], [0, 5, 6], [2, 3, 4]])
#: Triangles of a stroke glyph's four corners.
STROKE_TRIANGLES = np.array([[0, 1, 2], [0, 2, 3]])


@takes_mesh
def default_arrow_scale(mesh: TriMesh, field: npt.ArrayLike, spacing: float | None = None) -> float:
    """The default arrow scale: ``DEFAULT_ARROW_LENGTH · spacing / top``.

    ``top`` is the robust maximum of ``|v_t|`` (:func:`fvf.viz.colors.robust_limits` of the
    lengths weighted by face area: the true maximum unless a few faces stick out), so one
    huge vector does not shrink every other arrow to nothing.

    Parameters
    ----------
    mesh : TriMesh
    field : array_like (m, 3)
        Tangent vector per face.
    spacing : float, optional
        The length, in mesh units, of an arrow of length ``top`` (default: the mean edge
        length; pictures pass the distance between arrows).

    Returns
    -------
    float
        Mesh units per unit of ``|v|`` (1.0 for a zero field).
    """
    from .colors import robust_limits

    v = as_face_field(mesh, field, "field")
    speed = np.sqrt((v * v).sum(1))
    if not speed.max(initial=0.0) > 0:
        return 1.0
    top = robust_limits(speed, mesh.face_areas)[1]
    spacing = mesh.mean_edge_length if spacing is None else float(spacing)
    return DEFAULT_ARROW_LENGTH * spacing / top


@takes_mesh
def arrow_segments(mesh: TriMesh, field: npt.ArrayLike, scale: float | None = None) -> np.ndarray:
    """Start and end points of one arrow per face, built from the face's own basis.

    Parameters
    ----------
    mesh : TriMesh
    field : array_like (m, 3) or (3m,)
        Tangent vector per face (a normal component is projected away with a
        :class:`~fvf.errors.NonTangentFieldWarning`).
    scale : float, optional
        Arrow length per unit of ``|v|``, in mesh units (absolute). Default
        :func:`default_arrow_scale`.

    Returns
    -------
    ndarray float64 (m, 2, 3)
        ``[t, 0]`` the centroid of face t, ``[t, 1]`` the arrow's tip
        ``c_t + scale · from_local(to_local(v))[t]``.
    """
    v = as_face_field(mesh, field, "field")
    if scale is None:
        scale = default_arrow_scale(mesh, v)
    start = np.asarray(mesh.face_centroids, dtype=float)
    tip = start + float(scale) * mesh.from_local(mesh.to_local(v))
    return np.stack([start, tip], axis=1)


@takes_mesh
def direction_set(mesh: TriMesh, field: npt.ArrayLike, n: int) -> np.ndarray:
    """The N directions of an N-direction field given by one representative per face.

    Parameters
    ----------
    mesh : TriMesh
    field : array_like (m, 3)
        The representative u_t of each face (tangent).
    n : int
        Symmetry order N ≥ 1 (1 vector, 2 line, 4 cross field, ...).

    Returns
    -------
    ndarray float64 (N, m, 3)
        ``[k, t] = cos(2πk/N) u_t + sin(2πk/N) n_t × u_t``: u_t turned by 2πk/N about the
        face normal n_t (counter-clockwise seen from the normal's side), same length.
    """
    if isinstance(n, bool) or not float(n).is_integer() or int(n) < 1:
        raise FvfError(f"n (directions per face) must be a positive integer; got {n!r}")
    n = int(n)
    u = mesh.from_local(mesh.to_local(as_face_field(mesh, field, "field")))
    ju = np.cross(mesh.face_normals, u)
    ang = 2.0 * np.pi * np.arange(n) / n
    return np.cos(ang)[:, None, None] * u[None] + np.sin(ang)[:, None, None] * ju[None]


@takes_mesh
def spread_faces(mesh: TriMesh, count: int | None) -> np.ndarray:
    """About ``count`` faces spread evenly over the surface (one per grid cell).

    Centroids are binned in a grid of cubes whose side is ``sqrt(total_area / count)``
    and the first face of each occupied cube is kept, so the picked faces cover the
    surface evenly whatever the tessellation's density. Deterministic.

    Parameters
    ----------
    mesh : TriMesh
    count : int or None
        Wanted number of faces; None or ``>= m`` returns every face.

    Returns
    -------
    ndarray int64 (k,)
        Sorted face ids.
    """
    m = mesh.n_faces
    if count is None or count >= m:
        return np.arange(m)
    if count < 1:
        return np.empty(0, dtype=np.int64)
    side = np.sqrt(mesh.total_area / count)
    cells = np.floor((mesh.face_centroids - mesh.vertices.min(0)) / side).astype(np.int64)
    _, first = np.unique(cells, axis=0, return_index=True)
    return np.sort(first)


def _cell_jitter(cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
    """A deterministic point in [0.3, 0.7]² per cell (hash of the cell's integer index)."""
    z = (cx.astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15)) ^ (
        cy.astype(np.uint64) * np.uint64(0xC2B2AE3D27D4EB4F)
    )
    z = (z ^ (z >> np.uint64(29))) * np.uint64(0xBF58476D1CE4E5B9)
    z ^= z >> np.uint64(32)
    a = (z & np.uint64(0xFFFF)).astype(float) / 65535.0
    b = ((z >> np.uint64(16)) & np.uint64(0xFFFF)).astype(float) / 65535.0
    return 0.3 + 0.4 * np.stack([a, b], axis=1)


def screen_spread(
    xy: np.ndarray, depth: np.ndarray, candidates: np.ndarray, spacing: float, layer: float
) -> np.ndarray:
    """Faces to carry an arrow: about one per ``spacing × spacing`` pixel cell.

    In each cell of a square pixel grid, only faces on the surface nearest the eye count
    (depth within ``layer`` of the cell's nearest face: the others are hidden or on the
    far side); of those, the one whose centroid is nearest a jittered point of the cell
    is kept (jitter avoids moiré with the mesh's own regularity). Of two picks closer than
    0.6 spacings (large faces whose centroids miss their targets), one is dropped.

    Parameters
    ----------
    xy : ndarray float64 (m, 2)
        Face centroids in pixels.
    depth : ndarray float64 (m,)
        Their depth toward the eye (larger is nearer), in mesh units.
    candidates : ndarray int64 (k,)
        Faces that may carry an arrow (e.g. those facing the eye).
    spacing : float
        Cell side in pixels.
    layer : float
        Depth tolerance of the nearest surface, in mesh units.

    Returns
    -------
    ndarray int64 (j,)
        Sorted face ids, at most one per cell.
    """
    idx = np.asarray(candidates, dtype=np.int64)
    if idx.size == 0:
        return idx
    cell = np.floor(xy[idx] / spacing).astype(np.int64)
    shifted = cell - cell.min(0)
    key = shifted[:, 0] * (int(shifted[:, 1].max()) + 1) + shifted[:, 1]
    d = depth[idx]
    order = np.lexsort((-d, key))  # by cell, nearest first
    key_s = key[order]
    starts = np.flatnonzero(np.r_[True, key_s[1:] != key_s[:-1]])
    nearest = np.repeat(d[order][starts], np.diff(np.r_[starts, key_s.size]))
    front = order[d[order] >= nearest - layer]
    target = (cell[front] + _cell_jitter(cell[front, 0], cell[front, 1])) * spacing
    dist = ((xy[idx[front]] - target) ** 2).sum(1)
    pick = np.lexsort((dist, key[front]))
    kf = key[front][pick]
    first = pick[np.r_[True, kf[1:] != kf[:-1]]]
    chosen = idx[front[first]]
    return np.sort(chosen[_thin(xy[chosen], 0.6 * spacing)])


def _thin(xy: np.ndarray, radius: float) -> np.ndarray:
    """Keep points at least ``radius`` apart: of each closer pair the later one goes."""
    from scipy.spatial import cKDTree

    keep = np.ones(xy.shape[0], dtype=bool)
    pairs = cKDTree(xy).query_pairs(radius, output_type="ndarray")
    for i, j in pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]:  # a few pairs at most
        if keep[i] and keep[j]:
            keep[j] = False
    return keep


def arrow_glyphs(
    centres: np.ndarray,
    vectors: np.ndarray,
    normals: np.ndarray,
    *,
    shaft: float,
    head_width: float,
    head_length: float,
    outline: float = 0.0,
    pivot: str = "middle",
) -> np.ndarray:
    """Flat arrows in the faces' planes, centred on ``centres`` (or starting there).

    Parameters
    ----------
    centres : ndarray float64 (k, 3)
        Middle of each arrow (``pivot="middle"``) or its tail (``pivot="tail"``).
    vectors : ndarray float64 (k, 3)
        Tail-to-tip vector of each arrow (tangent: in the plane of ``normals``).
    normals : ndarray float64 (k, 3)
        Unit normal of each arrow's plane.
    shaft, head_width, head_length : float
        Half-width of the shaft, half-width of the head's base and the head's length, in
        mesh units. An arrow shorter than ``head_length / 0.6`` is shrunk as a whole (the
        head never takes more than 60% of the arrow).
    outline : float
        Grow the glyph by this much on every side (for a halo drawn behind it).
    pivot : {"middle", "tail"}

    Returns
    -------
    ndarray float64 (k, 7, 3)
        Corners: tail right, neck right, head right, tip, head left, neck left, tail left
        (triangles :data:`ARROW_TRIANGLES`).
    """
    length = np.linalg.norm(vectors, axis=1)
    e = np.divide(vectors, length[:, None], out=np.zeros_like(vectors), where=length[:, None] > 0)
    s = np.cross(normals, e)
    r = np.minimum(1.0, 0.6 * length / head_length) if head_length > 0 else np.ones_like(length)
    a, b, h = shaft * r, head_width * r, head_length * r
    back = 0.5 if pivot == "middle" else 0.0
    tail = centres - back * length[:, None] * e
    tip = tail + length[:, None] * e
    neck = tip - h[:, None] * e
    if outline > 0:
        sin_half = b / np.sqrt(b * b + h * h)
        tail = tail - outline * e
        tip = tip + (outline / np.maximum(sin_half, 0.2))[:, None] * e
        neck = neck - outline * e
        a, b = a + outline, b + 1.6 * outline
    A, B = a[:, None] * s, b[:, None] * s
    return np.stack([tail - A, neck - A, neck - B, tip, neck + B, neck + A, tail + A], axis=1)


def stroke_glyphs(
    starts: np.ndarray,
    vectors: np.ndarray,
    normals: np.ndarray,
    width: float,
    outline: float = 0.0,
) -> np.ndarray:
    """Flat strokes (thin rectangles) from ``starts`` along ``vectors``, in their planes.

    Parameters
    ----------
    starts, vectors, normals : ndarray float64 (k, 3)
    width : float
        Half-width in mesh units.
    outline : float
        Grow the stroke by this much on every side except the start (the strokes of one
        face meet there).

    Returns
    -------
    ndarray float64 (k, 4, 3)
        Corners (triangles :data:`STROKE_TRIANGLES`).
    """
    length = np.linalg.norm(vectors, axis=1)
    e = np.divide(vectors, length[:, None], out=np.zeros_like(vectors), where=length[:, None] > 0)
    W = (width + outline) * np.cross(normals, e)
    end = starts + vectors + outline * e
    return np.stack([starts - W, end - W, end + W, starts + W], axis=1)
