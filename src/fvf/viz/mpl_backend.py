"""The matplotlib (Agg) backend: an orthographic, flat-shaded, depth-sorted picture.

Faces are projected with the camera frame, back faces of closed meshes are culled, the
rest are drawn far to near (painter's algorithm) with a colour scaled by a Lambert
term, so the shape reads. Arrows, strokes, streamlines and markers are drawn on top,
keeping only the parts that are not hidden: a face-id buffer (the faces drawn again with
their ids as colours, without antialiasing) gives the surface depth seen at each pixel.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ._deps import require
from .overlay import PanelOverlay, fit
from .scene import Scene, shade

__all__ = ["draw_matplotlib", "projection"]

#: Pixel coordinates (k, 2) and depth (k,) of 3-D points (k, 3): :func:`projection`.
Project = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
#: Whether 3-D surface points (k, 3) are seen, bool (k,): :func:`_visibility`.
Visible = Callable[[np.ndarray], np.ndarray]


def projection(
    scene: Scene, width: int, height: int, frame: np.ndarray | None = None, zoom: float = 1.0
) -> Project:
    """Pixel coordinates (x right, y up) and depth (larger is nearer) of 3-D points.

    Returns a function ``P (k, 3) -> (xy (k, 2), depth (k,))`` fitting the whole mesh in
    a ``width`` x ``height`` panel (:func:`fvf.viz.overlay.fit`). ``frame`` defaults to
    the scene's first.
    """
    R = scene.frame if frame is None else frame
    centre, s = fit(scene.mesh.vertices, R, zoom, width, height)

    def project(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = np.asarray(P, float).reshape(-1, 3) @ R.T
        xy = (q[:, :2] - centre) * s + np.array([width, height]) / 2.0
        return xy, q[:, 2]

    return project


def _figure(width: int, height: int, background: Any) -> tuple[Any, Any, Any]:
    require("matplotlib")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width / 100.0, height / 100.0), dpi=100, facecolor=background)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    ax.set_xlim(0, width)
    ax.set_ylim(0, height)
    ax.set_axis_off()
    ax.set_facecolor(background)
    return fig, canvas, ax


def _rgb(canvas: Any) -> np.ndarray:
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()


def _points(px: Any) -> Any:
    """Pixels to points at 100 dpi (a number or an array of them)."""
    return 0.72 * px


def draw_matplotlib(
    scene: Scene,
    width: int,
    height: int,
    frame: np.ndarray | None = None,
    zoom: float = 1.0,
    overlay: PanelOverlay | None = None,
) -> np.ndarray:
    """Render one panel of a scene to an RGB image, uint8 (height, width, 3), white ground.

    ``frame`` and ``zoom`` default to the scene's first view; ``overlay`` (arrows,
    markers, line width: :func:`fvf.viz.overlay.panel_overlay`) is computed when omitted.
    """
    require("matplotlib")
    from matplotlib.collections import PolyCollection

    from .overlay import panel_overlay

    frame = scene.frame if frame is None else frame
    if overlay is None:
        overlay = panel_overlay(scene, frame, zoom, width, height)
    mesh = scene.mesh
    X, F = mesh.vertices, mesh.faces
    project = projection(scene, width, height, frame, zoom)
    xy, depth = project(X)
    back = frame[2]
    N = mesh.face_normals
    facing = N @ back
    faces = np.flatnonzero(facing > 0) if mesh.is_closed else np.arange(mesh.n_faces)
    face_depth = depth[F].mean(1)
    order = faces[np.argsort(face_depth[faces], kind="stable")]  # far to near
    polys = xy[F[order]]
    base = scene.colors[F[order]].mean(1) if scene.colors_on == "vertices" else scene.colors[order]
    face_rgb = np.clip(base * shade(scene, N[order], frame)[:, None], 0.0, 1.0)

    fig, canvas, ax = _figure(width, height, "white")
    ax.add_collection(
        PolyCollection(polys, facecolors=face_rgb, edgecolors=face_rgb, linewidths=0.3)
    )
    if not (overlay.glyphs or scene.lines or scene.markers is not None):
        return _rgb(canvas)
    tol = max(1.5 * mesh.mean_edge_length, 3.0 / overlay.pixel_scale)
    visible = _visibility(polys, order, face_depth, width, height, tol, project)
    if scene.lines:
        _draw_lines(ax, scene, overlay, project, visible)
    _draw_glyphs(ax, overlay, project, visible)
    if scene.markers is not None and len(scene.markers):
        _draw_markers(ax, scene.markers, overlay, project, visible)
    return _rgb(canvas)


def _draw_lines(
    ax: Any, scene: Scene, overlay: PanelOverlay, project: Project, visible: Visible
) -> None:
    """The streamlines' segments whose both ends are seen."""
    from matplotlib.collections import LineCollection

    segs: list[np.ndarray] = []
    for line in scene.lines:
        p, _ = project(line)
        ok = visible(line)
        keep = ok[:-1] & ok[1:]
        segs.extend(np.stack([p[:-1][keep], p[1:][keep]], axis=1))
    if segs:
        ax.add_collection(
            LineCollection(segs, colors=[scene.line_color], linewidths=_points(overlay.line_width))
        )


def _draw_glyphs(ax: Any, overlay: PanelOverlay, project: Project, visible: Visible) -> None:
    """The glyphs whose face is seen, each over its halo."""
    from matplotlib.collections import PolyCollection

    for g in overlay.glyphs:
        ok = visible(g.anchors)
        if not ok.any():
            continue
        for polys_3d, color, z in ((g.halo, g.halo_color, 3), (g.polygons, g.color, 4)):
            k, p = polys_3d[ok].shape[:2]
            pts, _ = project(polys_3d[ok].reshape(-1, 3))
            ax.add_collection(
                PolyCollection(
                    # matplotlib takes a (k, p, 2) array (its fast path); its stubs say Sequence
                    pts.reshape(k, p, 2),  # type: ignore[arg-type]
                    facecolors=[color],
                    edgecolors=[color],
                    linewidths=_points(0.3),
                    zorder=z,
                )
            )


def _draw_markers(
    ax: Any, markers: np.ndarray, overlay: PanelOverlay, project: Project, visible: Visible
) -> None:
    """The singularities that are seen, as discs coloured by index with a black rim."""
    ok = visible(markers)
    p, _ = project(markers[ok])
    radii = overlay.marker_radii
    r_px = (overlay.marker_radius if radii is None else radii[ok]) * overlay.pixel_scale
    ax.scatter(
        p[:, 0],
        p[:, 1],
        s=_points(2 * r_px) ** 2,
        c=overlay.marker_colors[ok] if overlay.marker_colors is not None else None,
        edgecolors="black",
        linewidths=_points(np.maximum(1.0, 0.18 * r_px)),
        zorder=5,
    )


def _visibility(polys, order, face_depth, width, height, tol, project):
    """A test ``P (k, 3) -> bool (k,)``: is each surface point seen (not hidden)?"""
    from matplotlib.collections import PolyCollection

    ids = np.arange(1, order.size + 1)
    rgb = np.stack([(ids >> 16) & 255, (ids >> 8) & 255, ids & 255], axis=1) / 255.0
    fig, canvas, ax = _figure(width, height, "black")
    ax.add_collection(PolyCollection(polys, facecolors=rgb, edgecolors="none", antialiased=False))
    buf = _rgb(canvas).astype(np.int64)
    idbuf = (buf[:, :, 0] << 16) | (buf[:, :, 1] << 8) | buf[:, :, 2]  # 0: background
    seen_depth = np.concatenate([[-np.inf], face_depth[order]])

    def visible(P: np.ndarray) -> np.ndarray:
        p, d = project(P)
        col = np.clip(np.floor(p[:, 0]).astype(int), 0, width - 1)
        row = np.clip(np.floor(height - p[:, 1]).astype(int), 0, height - 1)
        best = np.full(P.shape[0] if np.ndim(P) == 2 else 1, -np.inf)
        for dr in (-1, 0, 1):  # the nearest surface among the 3x3 neighbours
            for dc in (-1, 0, 1):
                r = np.clip(row + dr, 0, height - 1)
                c = np.clip(col + dc, 0, width - 1)
                best = np.maximum(best, seen_depth[np.minimum(idbuf[r, c], order.size)])
        return d >= best - tol

    return visible
