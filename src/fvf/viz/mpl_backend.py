"""The matplotlib (Agg) backend: an orthographic, flat-shaded, depth-sorted picture.

Faces are projected with the camera frame, back faces of closed meshes are culled, the
rest are drawn far to near (painter's algorithm) with a colour scaled by a Lambert
term, so the shape reads. Arrows, streamlines and markers are drawn on top, keeping
only the parts that are not hidden: a face-id buffer (the faces drawn again with their
ids as colours, without antialiasing) gives the surface depth seen at each pixel.
"""

from __future__ import annotations

import numpy as np

from ._deps import require
from .scene import Scene, index_color, shade

__all__ = ["draw_matplotlib", "projection"]

_MARGIN = 1.06


def projection(scene: Scene, width: int, height: int):
    """Pixel coordinates (x right, y up) and depth (larger is nearer) of 3-D points.

    Returns a function ``P (k, 3) -> (xy (k, 2), depth (k,))`` fitting the whole mesh in
    a ``width`` x ``height`` picture with a small margin (divided by ``view.zoom``).
    """
    R = scene.frame
    Q = scene.mesh.vertices @ R.T
    lo, hi = Q[:, :2].min(0), Q[:, :2].max(0)
    centre = 0.5 * (lo + hi)
    ext = np.maximum(hi - lo, 1e-300) * _MARGIN
    s = min(width / ext[0], height / ext[1]) * scene.view.zoom

    def project(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = np.asarray(P, float).reshape(-1, 3) @ R.T
        xy = (q[:, :2] - centre) * s + np.array([width, height]) / 2.0
        return xy, q[:, 2]

    return project


def _figure(width: int, height: int, background):
    mpl = require("matplotlib")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    del mpl
    fig = Figure(figsize=(width / 100.0, height / 100.0), dpi=100, facecolor=background)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    ax.set_xlim(0, width)
    ax.set_ylim(0, height)
    ax.set_axis_off()
    ax.set_facecolor(background)
    return fig, canvas, ax


def _rgb(canvas) -> np.ndarray:
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()


def draw_matplotlib(scene: Scene, width: int, height: int) -> np.ndarray:
    """Render a scene to an RGB image, uint8 (height, width, 3), white background."""
    require("matplotlib")
    from matplotlib.collections import LineCollection, PolyCollection

    mesh = scene.mesh
    X, F = mesh.vertices, mesh.faces
    project = projection(scene, width, height)
    xy, depth = project(X)
    right, up, back = scene.frame
    N = mesh.face_normals
    facing = N @ back
    faces = np.flatnonzero(facing > 0) if mesh.is_closed else np.arange(mesh.n_faces)
    face_depth = depth[F].mean(1)
    order = faces[np.argsort(face_depth[faces], kind="stable")]  # far to near
    polys = xy[F[order]]
    # colours: flat per face, scaled by a Lambert term (scene.shade)
    base = scene.colors[F[order]].mean(1) if scene.colors_on == "vertices" else scene.colors[order]
    shade_ = shade(scene, N[order])
    face_rgb = np.clip(base * shade_[:, None], 0.0, 1.0)

    fig, canvas, ax = _figure(width, height, "white")
    ax.add_collection(
        PolyCollection(polys, facecolors=face_rgb, edgecolors=face_rgb, linewidths=0.3)
    )
    has_overlay = (
        scene.arrows is not None
        or scene.strokes is not None
        or scene.lines
        or scene.markers is not None
    )
    if has_overlay:
        visible = _visibility(
            polys, order, face_depth, width, height, mesh.mean_edge_length, project
        )
    lw = max(0.6, width / 900.0)
    if scene.lines:
        segs = []
        for line in scene.lines:
            p, _ = project(line)
            ok = visible(line)
            keep = ok[:-1] & ok[1:]
            segs.extend(np.stack([p[:-1][keep], p[1:][keep]], axis=1))
        if segs:
            ax.add_collection(LineCollection(segs, colors=[scene.line_color], linewidths=lw))
    if scene.arrows is not None and len(scene.arrows):
        A = scene.arrows
        front = (facing[scene.arrow_faces] > 0) | (not mesh.is_closed)
        ok = front & visible(A[:, 0])
        p0, _ = project(A[ok, 0])
        p1, _ = project(A[ok, 1])
        ax.quiver(
            p0[:, 0],
            p0[:, 1],
            p1[:, 0] - p0[:, 0],
            p1[:, 1] - p0[:, 1],
            angles="xy",
            scale_units="xy",
            scale=1.0,
            color=scene.line_color,
            width=0.0016,
            headwidth=4.0,
            headlength=4.5,
            headaxislength=4.0,
            minlength=0.5,
        )
    if scene.strokes is not None and len(scene.strokes):
        S = scene.strokes
        front = (facing[scene.stroke_faces] > 0) | (not mesh.is_closed)
        ok = front & visible(S[:, 0])
        p0, _ = project(S[ok, 0])
        p1, _ = project(S[ok, 1])
        ax.add_collection(
            LineCollection(np.stack([p0, p1], axis=1), colors=[scene.line_color], linewidths=lw)
        )
    if scene.markers is not None and len(scene.markers):
        ok = visible(scene.markers)
        p, _ = project(scene.markers[ok])
        cols = [index_color(i) for i in scene.marker_indices[ok]]
        ax.scatter(
            p[:, 0],
            p[:, 1],
            s=max(45.0, (width / 800.0) ** 2 * 90.0),
            c=cols,
            edgecolors="black",
            linewidths=0.8,
            zorder=5,
        )
    return _rgb(canvas)


def _visibility(polys, order, face_depth, width, height, edge, project):
    """A test ``P (k, 3) -> bool (k,)``: is each surface point seen (not hidden)?"""
    from matplotlib.collections import PolyCollection

    ids = np.arange(1, order.size + 1)
    rgb = np.stack([(ids >> 16) & 255, (ids >> 8) & 255, ids & 255], axis=1) / 255.0
    fig, canvas, ax = _figure(width, height, "black")
    ax.add_collection(PolyCollection(polys, facecolors=rgb, edgecolors="none", antialiased=False))
    buf = _rgb(canvas).astype(np.int64)
    idbuf = (buf[:, :, 0] << 16) | (buf[:, :, 1] << 8) | buf[:, :, 2]  # 0: background
    seen_depth = np.concatenate([[-np.inf], face_depth[order]])
    tol = 1.5 * edge

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
