"""What is drawn over the surface in one panel, sized in pixels: arrows, strokes, markers.

Everything here is measured in the picture's pixels and converted to mesh units with the
panel's scale (pixels per mesh unit, :func:`fit`), so arrows, strokes, markers and
curves have the same on-screen size on a 5k-face and on a 750k-face mesh:

- the arrow spacing (default :func:`default_spacing`: 1/22 of the panel's smaller side,
  between 14 and 40 pixels) sets which faces carry an arrow (:func:`screen_spread`), the
  default arrow length (the robust longest arrow is :data:`ARROW_FILL` of the spacing) and
  the glyph's shaft, head and halo;
- singularity markers have a radius of :data:`MARKER_RADIUS` spacings (at least 4.5 px),
  but at most :data:`MARKER_GAP` of the distance to the nearest other marker (at least
  2 px), so dense irregular vertices stay apart;
- every glyph and marker is also no larger than the detail it sits on
  (:func:`feature_factors`: a cross on a finger shrinks to the finger's width);
- N-direction fields (N ≥ 2) are drawn as unit crosses (their directions, not their
  magnitudes) unless an absolute ``arrow_scale`` is given;
- a wireframe (streamlines that are all single segments, e.g. quad edges) is drawn at
  most :data:`WIRE_WIDTH` of its median on-screen edge length wide (at least 0.3 px), so
  a dense quad mesh stays a mesh and not a solid colour.

Both backends call :func:`panel_overlay` and draw the same glyphs (flat polygons in the
faces' planes), so their pictures agree.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .arrows import (
    ARROW_TRIANGLES,
    STROKE_TRIANGLES,
    arrow_glyphs,
    screen_spread,
    stroke_glyphs,
)
from .colors import index_color, outline_color
from .scene import FieldLayer, Scene

__all__ = [
    "ARROW_FILL",
    "Glyphs",
    "PanelOverlay",
    "default_spacing",
    "fit",
    "panel_overlay",
]

#: The robust longest arrow is this fraction of the arrow spacing (default scale).
ARROW_FILL = 0.8
#: Arrows are never drawn longer than this many spacings (longer ones are capped).
ARROW_CAP = 1.3
#: Glyph proportions, in spacings: shaft half-width, head half-width, head length, halo.
SHAFT, HEAD_WIDTH, HEAD_LENGTH, HALO = 0.075, 0.25, 0.38, 0.035
#: Half-width of N-direction strokes, in spacings.
STROKE = 0.07
#: Singularity marker radius, in spacings.
MARKER_RADIUS = 0.36
#: Markers are at most this fraction of the median distance to the nearest other marker.
MARKER_GAP = 0.4
#: A wireframe's line width is at most this fraction of its median on-screen edge length.
WIRE_WIDTH = 0.1
#: Margin around the mesh in a panel (1.06: 3% on each side).
MARGIN = 1.06
#: A glyph or marker of reach r stays flat on the surface when the surface within r of
#: its centre leaves the tangent plane by at most this fraction of r.
FLAT = 0.3
#: The shrink factors tried, largest first, until a glyph is flat (the last one is kept).
SHRINK = (1.0, 0.7, 0.5, 0.35, 0.25)


def feature_factors(
    points: np.ndarray, centres: np.ndarray, normals: np.ndarray, reach: np.ndarray
) -> np.ndarray:
    r"""How much each glyph shrinks to fit the detail it sits on (the local feature size).

    A flat glyph (an arrow, a cross) or a marker of reach $r$ around a point $c$ with unit
    normal $n$ fits the surface when the surface points $p$ within $r$ of $c$ stay near
    the tangent plane: $\max |\langle p - c, n \rangle| \le$ :data:`FLAT` $r$. On a
    cylinder of radius $\rho$ that holds up to $r \approx 0.55 \rho$ (the glyph spans
    the arm, not beyond). The factor is the largest of :data:`SHRINK` for which the
    shrunk glyph fits (the smallest when none does).

    Parameters
    ----------
    points : ndarray float64 (n, 3)
        Points of the surface (the mesh's vertices).
    centres, normals : ndarray float64 (k, 3)
        Each glyph's centre on the surface and unit normal there.
    reach : ndarray float64 (k,)
        Each glyph's radius (its farthest point from the centre), mesh units.

    Returns
    -------
    ndarray float64 (k,)
        Factors in :data:`SHRINK`.
    """
    from scipy.spatial import cKDTree

    k = centres.shape[0]
    out = np.full(k, SHRINK[-1])
    if k == 0 or points.shape[0] == 0:
        return np.ones(k)
    tree = cKDTree(points)
    todo = np.arange(k)
    for f in SHRINK[:-1]:
        r = f * reach[todo]
        balls = tree.query_ball_point(centres[todo], r, return_sorted=False)
        sizes = np.fromiter((len(b) for b in balls), dtype=np.int64, count=todo.size)
        owner = np.repeat(np.arange(todo.size), sizes)
        near = np.concatenate([np.asarray(b, dtype=np.int64) for b in balls])
        height = np.abs(((points[near] - centres[todo][owner]) * normals[todo][owner]).sum(1))
        worst = np.zeros(todo.size)
        np.maximum.at(worst, owner, height)
        fits = worst <= FLAT * r
        out[todo[fits]] = f
        todo = todo[~fits]
        if todo.size == 0:
            break
    return out


def default_spacing(width: int, height: int) -> float:
    """Default pixels between arrows: ``min(width, height) / 22`` clipped to [14, 40]."""
    return float(np.clip(min(width, height) / 22.0, 14.0, 40.0))


def fit(
    vertices: np.ndarray, frame: np.ndarray, zoom: float, width: int, height: int
) -> tuple[np.ndarray, float]:
    """Screen centre (mesh units, in the frame) and pixels per mesh unit of a panel.

    Orthographic: the bounding box of the projected vertices, grown by :data:`MARGIN`,
    fits the panel; ``zoom`` > 1 magnifies.
    """
    Q = vertices @ frame[:2].T
    lo, hi = Q.min(0), Q.max(0)
    ext = np.maximum(hi - lo, 1e-300) * MARGIN
    return 0.5 * (lo + hi), float(min(width / ext[0], height / ext[1]) * zoom)


@dataclass
class Glyphs:
    """Flat polygons of one field layer in one panel (mesh units, in the faces' planes)."""

    polygons: np.ndarray  # (k, p, 3)
    halo: np.ndarray  # (k, p, 3): the same grown by the halo width
    triangles: np.ndarray  # (t, 3) local corner indices of one polygon
    anchors: np.ndarray  # (k, 3): the face centroid each glyph belongs to
    normals: np.ndarray  # (k, 3)
    color: tuple
    halo_color: tuple
    lift: float  # offset along the normal that keeps the glyph above the surface
    label: str | None = None


@dataclass
class PanelOverlay:
    """Everything drawn over the surface in one panel."""

    pixel_scale: float  # pixels per mesh unit
    centre: np.ndarray  # (2,) screen centre in the frame's (right, up) coordinates
    spacing: float  # pixels between arrows
    glyphs: list[Glyphs] = field(default_factory=list)
    arrow_scale: float | None = None
    n_arrows: int = 0
    n_capped: int = 0
    marker_colors: np.ndarray | None = None  # (s, 3)
    marker_radius: float = 0.0  # mesh units: the largest of marker_radii
    marker_radii: np.ndarray | None = None  # (s,) mesh units, one per marker
    line_width: float = 1.0  # pixels


#: Faces seen more obliquely than this (cosine between normal and view) carry no glyph:
#: a flat glyph seen edge-on is a sliver.
GRAZING = 0.3


def _candidates(scene: Scene, frame: np.ndarray, v: np.ndarray) -> np.ndarray:
    mesh = scene.field_mesh
    facing = mesh.face_normals @ frame[2]
    ok = ((v * v).sum(1) > 0) & ((facing if mesh.is_closed else np.abs(facing)) > GRAZING)
    return np.flatnonzero(ok)


def layer_scale(layer: FieldLayer, spacing_mesh: float) -> float:
    """The arrow scale of a layer: its own, or the robust longest arrow filling the spacing.

    ``spacing_mesh`` is the default length of the robust longest arrow, in mesh units.
    """
    if layer.scale is not None:
        return layer.scale
    return ARROW_FILL * spacing_mesh / layer.top


def _fill(scene: Scene) -> float:
    """The default arrow length in spacings: shorter when several fields interleave."""
    return ARROW_FILL if len(scene.fields) < 2 else 0.6


def _pick_faces(scene, frame, centre, s, spacing, v, shift=0.0):
    """Faces of one field's glyphs; ``shift`` (in cells) moves the grid diagonally, so
    several fields take turns on an interleaved lattice (field i of k: i / k)."""
    mesh = scene.field_mesh
    q = mesh.face_centroids @ frame.T
    xy = (q[:, :2] - centre) * s + shift * spacing
    cand = _candidates(scene, frame, v)
    faces = screen_spread(xy, q[:, 2], cand, spacing, spacing / s)
    if scene.max_arrows is not None and faces.size > scene.max_arrows:
        wider = spacing * np.sqrt(faces.size / max(scene.max_arrows, 1)) * 1.05
        faces = screen_spread(xy, q[:, 2], cand, wider, wider / s)
    return faces


def _layer_glyphs(
    scene: Scene, layer: FieldLayer, faces: np.ndarray, scale: float, spacing_mesh: float
) -> tuple[Glyphs, int]:
    """The glyphs of one field at the chosen faces: arrows, or N strokes per face."""
    mesh = scene.field_mesh
    c, nrm = mesh.face_centroids[faces], mesh.face_normals[faces]
    u = layer.vectors[faces]  # tangent (checked by as_face_field)
    ang = 2.0 * np.pi * np.arange(layer.n) / layer.n  # as direction_set, on these faces only
    d = np.cos(ang)[:, None, None] * u[None] + np.sin(ang)[:, None, None] * np.cross(nrm, u)[None]
    if layer.n > 1 and layer.scale is None:  # N-direction fields: unit crosses by default
        d = d / np.maximum(np.linalg.norm(d[0], axis=1), 1e-300)[None, :, None]
        scale = scale * layer.top
    length = scale * np.linalg.norm(d[0], axis=1)
    cap = ARROW_CAP * spacing_mesh
    capped = int((length > cap).sum())
    factor = np.minimum(length, cap) / np.maximum(length, 1e-300)
    halo_w = HALO * spacing_mesh
    if layer.n == 1:
        vec = d[0] * (scale * factor)[:, None]
        shaft, head_w, head_l = (x * spacing_mesh for x in (SHAFT, HEAD_WIDTH, HEAD_LENGTH))
        poly = arrow_glyphs(c, vec, nrm, shaft=shaft, head_width=head_w, head_length=head_l)
        halo = arrow_glyphs(
            c, vec, nrm, shaft=shaft, head_width=head_w, head_length=head_l, outline=halo_w
        )
        tris, anchors, normals = ARROW_TRIANGLES, c, nrm
    else:  # N strokes from the centroid, each half an arrow long
        vec = (d * (0.5 * scale * factor)[None, :, None]).reshape(-1, 3)
        starts = np.tile(c, (layer.n, 1))
        normals = np.tile(nrm, (layer.n, 1))
        poly = stroke_glyphs(starts, vec, normals, STROKE * spacing_mesh)
        halo = stroke_glyphs(starts, vec, normals, STROKE * spacing_mesh, outline=halo_w)
        tris, anchors = STROKE_TRIANGLES, starts
    poly, halo = _fit_to_features(scene, poly, halo, anchors, normals, faces.size)
    lift = 0.12 * float(np.minimum(length, cap).max(initial=0.0)) + 0.5 * halo_w
    glyphs = Glyphs(
        poly,
        halo,
        tris,
        anchors,
        normals,
        layer.color,
        outline_color(layer.color),
        lift,
        layer.label,
    )
    return glyphs, capped


def _fit_to_features(scene, poly, halo, anchors, normals, k):
    """Glyphs (k faces, each with ``len(poly) // k`` polygons) shrunk about their anchors
    to the detail they sit on (:func:`feature_factors`); one factor per face."""
    if k == 0:
        return poly, halo
    per = poly.shape[0] // k
    reach = np.linalg.norm(halo - anchors[:, None], axis=2).max(1).reshape(per, k).max(0)
    f = feature_factors(scene.field_mesh.vertices, anchors[:k], normals[:k], reach)
    f = np.tile(f, per)[:, None, None]
    a = anchors[:, None]
    return a + f * (poly - a), a + f * (halo - a)


def panel_overlay(
    scene: Scene,
    frame: np.ndarray,
    zoom: float,
    width: int,
    height: int,
    spacing_mesh: float | None = None,
) -> PanelOverlay:
    """Glyphs, marker sizes and line width of one panel.

    Parameters
    ----------
    scene : Scene
    frame : ndarray (3, 3)
        The panel's camera frame.
    zoom : float
    width, height : int
        The panel's size in pixels.
    spacing_mesh : float, optional
        The arrow spacing in mesh units; default the pixel spacing at this panel's scale.
        :func:`fvf.viz.render` passes the first panel's, so every panel uses the same
        arrow scale.

    Returns
    -------
    PanelOverlay
    """
    centre, s = fit(scene.mesh.vertices, frame, zoom, width, height)
    spacing = scene.arrow_spacing or default_spacing(width, height) * (
        1.0 if len(scene.fields) < 2 else 1.5  # room for the interleaved lattices
    )
    if spacing_mesh is None:
        spacing_mesh = spacing / s
    out = PanelOverlay(pixel_scale=s, centre=centre, spacing=spacing)
    for i, layer in enumerate(scene.fields):
        shift = i / len(scene.fields)
        faces = _pick_faces(scene, frame, centre, s, spacing, layer.vectors, shift)
        scale = layer_scale(layer, spacing_mesh * _fill(scene) / ARROW_FILL)
        glyphs, capped = _layer_glyphs(scene, layer, faces, scale, spacing_mesh)
        out.glyphs.append(glyphs)
        out.n_arrows += faces.size
        out.n_capped += capped
        out.arrow_scale = scale if out.arrow_scale is None else out.arrow_scale
    if scene.markers is not None:
        assert scene.marker_indices is not None  # set together with the markers
        out.marker_colors = np.array([index_color(i) for i in scene.marker_indices]).reshape(-1, 3)
        out.marker_radii = _marker_radii(scene, max(4.5, MARKER_RADIUS * spacing), s)
        out.marker_radius = float(out.marker_radii.max(initial=0.0))
    out.line_width = _line_width(scene.lines, max(1.2, 0.08 * spacing), s)
    return out


def _marker_radii(scene: Scene, radius_px: float, s: float) -> np.ndarray:
    """Each marker's radius in mesh units: ``radius_px`` pixels, at most :data:`MARKER_GAP`
    of the distance to its nearest other marker and no larger than the detail it marks
    (:func:`feature_factors`), and not below 2 pixels."""
    from scipy.spatial import cKDTree

    markers = scene.markers
    assert markers is not None
    r = np.full(markers.shape[0], radius_px)
    if markers.shape[0] >= 2:
        dist, _ = cKDTree(markers).query(markers, k=2)
        gap = dist[:, 1] * s  # pixels
        r = np.where(gap > 0, np.minimum(r, MARKER_GAP * gap), r)
    mesh = scene.field_mesh
    _, face = cKDTree(mesh.face_centroids).query(markers)
    r = r * feature_factors(mesh.vertices, markers, mesh.face_normals[face], r / s)
    return np.maximum(r, 2.0) / s


def _line_width(lines: list[np.ndarray], width_px: float, s: float) -> float:
    """Line width in pixels: ``width_px``, thinner for a dense wireframe (all the lines
    single segments) — at most :data:`WIRE_WIDTH` of the median edge on screen."""
    if lines and all(x.shape[0] == 2 for x in lines):
        seg = np.stack(lines)  # (k, 2, 3)
        edge = float(np.median(np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1))) * s
        width_px = min(width_px, max(0.3, WIRE_WIDTH * edge))
    return width_px
