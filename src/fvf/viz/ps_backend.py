"""The polyscope backend: OpenGL through EGL without a display (headless), or a window.

polyscope keeps one global state per process: :func:`init_headless` starts it once
(``ps.init("openGL3_egl")``), each picture removes the previous structures, registers
the mesh, colours, arrows (a tangent vector quantity in the faces' own bases),
streamlines (a curve network) and markers (a point cloud), places the camera with the
same frame as the matplotlib backend, and reads the frame buffer.
"""

from __future__ import annotations

import contextlib
import os
import sys

import numpy as np

from ._deps import require
from .scene import Scene, index_color, shade

__all__ = ["init_headless", "draw_polyscope", "populate"]

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
    except Exception as exc:  # polyscope raises RuntimeError, or others from its bindings
        _STATE["error"] = f"{type(exc).__name__}: {exc}"
        raise
    _STATE["mode"] = "headless"
    return ps


def populate(ps, scene: Scene) -> None:
    """Register the scene's mesh, colours, arrows, streamlines and markers in polyscope."""
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
    colors = np.clip(scene.colors * shade(scene, N)[:, None], 0.0, 1.0)
    s.add_color_quantity("colors", colors, defined_on=scene.colors_on, enabled=True)
    radius = 0.003
    if scene.arrows is not None and len(scene.arrows):
        # arrows in the faces' own bases (mesh.face_bases), only at the chosen faces
        a = np.zeros((mesh.n_faces, 2))
        d = scene.arrows[:, 1] - scene.arrows[:, 0]
        B = mesh.face_bases
        a[scene.arrow_faces] = np.einsum("kij,kj->ki", B[scene.arrow_faces], d)
        s.add_tangent_vector_quantity(
            "field",
            a,
            B[:, 0],
            B[:, 1],
            defined_on="faces",
            vectortype="ambient",
            enabled=True,
            color=scene.line_color,
            radius=radius,
        )
    if scene.lines:
        nodes = np.concatenate(scene.lines)
        starts = np.cumsum([0] + [len(x) for x in scene.lines[:-1]])
        edges = np.concatenate(
            [
                np.stack([np.arange(k, k + len(x) - 1), np.arange(k + 1, k + len(x))], axis=1)
                for k, x in zip(starts, scene.lines, strict=True)
            ]
        )
        ps.register_curve_network(
            "streamlines",
            nodes,
            edges,
            radius=0.7 * radius,
            color=scene.line_color,
            material="flat",
        )
    if scene.strokes is not None and len(scene.strokes):
        k = len(scene.strokes)
        ps.register_curve_network(
            "directions",
            scene.strokes.reshape(-1, 3),
            np.arange(2 * k).reshape(k, 2),
            radius=radius,
            color=scene.line_color,
            material="flat",
        )
    if scene.markers is not None and len(scene.markers):
        pc = ps.register_point_cloud("singularities", scene.markers, radius=0.014, material="clay")
        cols = np.array([index_color(i) for i in scene.marker_indices])
        pc.add_color_quantity("index", cols, enabled=True)


def place_camera(ps, scene: Scene, width: int, height: int) -> None:
    """Look at the mesh along the scene's camera frame, fitting it in the picture."""
    back = scene.frame[2]
    X = scene.mesh.vertices
    q = X @ scene.frame.T
    lo, hi = q.min(0), q.max(0)
    centre = scene.frame.T @ (0.5 * (lo + hi))
    fov = np.radians(ps.get_vertical_fov_degrees())
    tan_v = np.tan(fov / 2)
    tan_h = tan_v * width / height
    half = 0.5 * (hi - lo) * 1.08 / scene.view.zoom
    dist = max(half[1] / tan_v, half[0] / tan_h) + 0.4 * half[2]
    ps.set_up_dir(f"{scene.view.up}_up")
    ps.look_at(centre + dist * back, centre)


def draw_polyscope(scene: Scene, width: int, height: int) -> np.ndarray:
    """Render a scene headless to an RGB image, uint8 (height, width, 3)."""
    ps = init_headless()
    ps.set_window_size(int(width), int(height))
    populate(ps, scene)
    place_camera(ps, scene, width, height)
    buf = np.asarray(ps.screenshot_to_buffer(transparent_bg=False))
    ps.remove_all_structures()
    img = buf[:, :, :3]
    if img.shape[:2] != (height, width):  # some drivers round the buffer size
        from PIL import Image

        img = np.asarray(Image.fromarray(img).resize((width, height)))
    return np.ascontiguousarray(img)
