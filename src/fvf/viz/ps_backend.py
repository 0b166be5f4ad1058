"""The polyscope backend: OpenGL through EGL without a display (headless), or a window.

polyscope keeps one global state per process: :func:`init_headless` starts it once
(``ps.init("openGL3_egl")``), each panel removes the previous structures, registers
the mesh and its colours, the glyphs of :mod:`fvf.viz.overlay` (flat arrows and strokes
in the faces' planes, lifted a little along the normals, over a slightly larger halo),
streamlines (a curve network) and markers (a coloured sphere in front of a black one),
all sized in pixels of the picture, places the camera with the same frame as the
matplotlib backend, and reads the frame buffer.
"""

from __future__ import annotations

import contextlib
import os
import sys
from typing import Any

import numpy as np

from ._deps import require
from .overlay import PanelOverlay
from .scene import Scene, shade

__all__ = ["init_headless", "draw_polyscope", "place_camera", "populate"]

_STATE: dict = {}


@contextlib.contextmanager
def _quiet():
    """Silence polyscope's start-up lines (printed by C++ straight to file descriptor 1)."""
    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError):  # no real stdout (e.g. captured): nothing to silence
        yield
        return
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def init_headless():
    """Start polyscope headless through EGL once per process; returns the module.

    Raises whatever polyscope raises when EGL cannot start (the caller falls back).
    """
    ps = require("polyscope")
    if _STATE.get("mode") == "headless":
        return ps
    if "error" in _STATE:
        raise RuntimeError(_STATE["error"])
    try:
        ps.set_allow_headless_backends(True)
        ps.set_verbosity(0)
        ps.set_use_prefs_file(False)  # no .polyscope.ini in the user's working directory
        with _quiet():
            ps.init("openGL3_egl")
        ps.set_SSAA_factor(2)  # antialiased glyph edges
    except Exception as exc:  # polyscope raises RuntimeError, or others from its bindings
        _STATE["error"] = f"{type(exc).__name__}: {exc}"
        raise
    _STATE["mode"] = "headless"
    return ps


def _glyph_mesh(ps: Any, name: str, polys: np.ndarray, triangles: np.ndarray, color: tuple) -> None:
    """Register flat polygons (k, p, 3), triangulated alike, as one unlit surface mesh."""
    k, p = polys.shape[:2]
    faces = (np.arange(k)[:, None, None] * p + triangles[None]).reshape(-1, 3)
    ps.register_surface_mesh(
        name,
        polys.reshape(-1, 3),
        faces,
        color=tuple(color),
        material="flat",
        edge_width=0.0,
        smooth_shade=False,
        back_face_policy="identical",
    )


def populate(
    ps: Any, scene: Scene, frame: np.ndarray | None = None, overlay: PanelOverlay | None = None
) -> None:
    """Register the scene's mesh, colours, glyphs, streamlines and markers in polyscope.

    ``frame`` (the panel's camera frame) defaults to the scene's first; ``overlay`` (the
    glyphs and sizes of :func:`fvf.viz.overlay.panel_overlay`) is computed for a 1024 x 768
    panel when omitted.
    """
    from .overlay import panel_overlay

    frame = scene.frame if frame is None else frame
    if overlay is None:
        overlay = panel_overlay(scene, frame, scene.view.zoom, 1024, 768)
    mesh = scene.mesh
    ps.remove_all_structures()
    ps.set_ground_plane_mode("none")
    ps.set_background_color((1.0, 1.0, 1.0))
    if scene.colors_on == "vertices":  # area-weighted vertex normals
        N = np.zeros((mesh.n_vertices, 3))
        for c in range(3):
            np.add.at(N, mesh.faces[:, c], mesh.face_normals * mesh.face_areas[:, None])
        N /= np.maximum(np.linalg.norm(N, axis=1), 1e-300)[:, None]
    else:
        N = mesh.face_normals
    s = ps.register_surface_mesh(
        "mesh", mesh.vertices, mesh.faces, edge_width=0.0, smooth_shade=False, material="flat"
    )
    colors = np.clip(scene.colors * shade(scene, N, frame)[:, None], 0.0, 1.0)
    s.add_color_quantity("colors", colors, defined_on=scene.colors_on, enabled=True)
    px = 1.0 / overlay.pixel_scale  # mesh units per pixel
    for i, g in enumerate(overlay.glyphs):
        # lifted along the normals so they stay above the surface; the halo a little less
        # (and so behind the glyph, seen from the eye)
        up = g.normals[:, None, :]
        _glyph_mesh(ps, f"halo {i}", g.halo + (g.lift - 0.5 * px) * up, g.triangles, g.halo_color)
        _glyph_mesh(ps, f"field {i}", g.polygons + g.lift * up, g.triangles, g.color)
    if scene.lines:
        nodes = np.concatenate(scene.lines)
        starts = np.cumsum([0] + [len(x) for x in scene.lines[:-1]])
        edges = np.concatenate(
            [
                np.stack([np.arange(k, k + len(x) - 1), np.arange(k + 1, k + len(x))], axis=1)
                for k, x in zip(starts, scene.lines, strict=True)
            ]
        )
        net = ps.register_curve_network(
            "streamlines", nodes, edges, color=scene.line_color, material="flat"
        )
        net.set_radius(0.5 * overlay.line_width * px, relative=False)
    if scene.markers is not None and len(scene.markers):
        # a black sphere with a smaller coloured one pushed toward the eye far enough
        # to be in front of it over its whole disc: a coloured disc with a black rim
        r = overlay.marker_radius
        inner = r - max(1.0 * px, 0.16 * r)
        pc = ps.register_point_cloud(
            "singularity rims", scene.markers, color=(0.0, 0.0, 0.0), material="flat"
        )
        pc.set_radius(r, relative=False)
        shift = 1.1 * np.sqrt(r * r - inner * inner) + px
        pc = ps.register_point_cloud(
            "singularities", scene.markers + shift * frame[2], material="flat"
        )
        pc.set_radius(inner, relative=False)
        pc.add_color_quantity("index", overlay.marker_colors, enabled=True)


def place_camera(
    ps: Any,
    scene: Scene,
    width: int,
    height: int,
    frame: np.ndarray | None = None,
    view: Any = None,
) -> None:
    """Look at the mesh along the panel's camera frame with the matplotlib backend's fit.

    The projection is orthographic, with the same centre and pixels per mesh unit as
    :func:`fvf.viz.overlay.fit`, so both backends put every point at the same pixel.
    polyscope's orthographic half-height is ``2 tan(fov/2) · length_scale``: the length
    scale is fixed (three bounding-box diagonals, which also keeps the mesh between the
    near and far clipping planes) and the field of view chosen to match.
    """
    from .overlay import fit

    frame = scene.frame if frame is None else frame
    view = scene.view if view is None else view
    X = scene.mesh.vertices
    centre2, s = fit(X, frame, view.zoom, width, height)
    depth = X @ frame[2]
    centre = frame[:2].T @ centre2 + frame[2] * 0.5 * (depth.min() + depth.max())
    length = 3.0 * float(np.linalg.norm(np.ptp(X, axis=0))) or 1.0
    ps.set_automatically_compute_scene_extents(False)
    ps.set_length_scale(length)
    ps.set_bounding_box(X.min(0), X.max(0))
    ps.set_view_projection_mode("orthographic")
    ps.set_vertical_fov_degrees(float(np.degrees(2.0 * np.arctan(height / (4.0 * s * length)))))
    ps.look_at_dir(centre + length * frame[2], centre, frame[1])


def draw_polyscope(
    scene: Scene,
    width: int,
    height: int,
    frame: np.ndarray | None = None,
    view: Any = None,
    overlay: PanelOverlay | None = None,
) -> np.ndarray:
    """Render one panel of a scene headless to an RGB image, uint8 (height, width, 3)."""
    from .overlay import panel_overlay

    frame = scene.frame if frame is None else frame
    view = scene.view if view is None else view
    if overlay is None:
        overlay = panel_overlay(scene, frame, view.zoom, width, height)
    ps = init_headless()
    ps.set_window_size(int(width), int(height))
    populate(ps, scene, frame, overlay)
    place_camera(ps, scene, width, height, frame, view)
    buf = np.asarray(ps.screenshot_to_buffer(transparent_bg=False))
    ps.remove_all_structures()
    img = buf[:, :, :3]
    if img.shape[:2] != (height, width):  # some drivers round the buffer size
        from PIL import Image

        img = np.asarray(Image.fromarray(img).resize((width, height)))
    return np.ascontiguousarray(img)
