"""The polyscope backend: OpenGL through EGL without a display (headless), or a window.

polyscope keeps one global state per process: :func:`init_headless` starts it once
(``ps.init("openGL3_egl")``) unless the caller's program already did, and each panel
registers the mesh and its colours, the glyphs of :mod:`fvf.viz.overlay` (flat arrows
and strokes in the faces' planes, lifted a little along the normals, over a slightly
larger halo), streamlines (a curve network) and markers (a coloured sphere in front of a
black one), all sized in pixels of the picture, places the camera with the same frame as
the matplotlib backend, and reads the frame buffer.

The caller's own polyscope scene is left as it was: fvf's structures have names of their
own (:data:`PREFIX`) and are the only ones removed; while a panel is drawn, every other
structure is cut away by a slice plane the panel's structures ignore; the camera, window
size, background colour and scene extents are restored afterwards (:data:`SETTINGS`).
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from typing import Any

import numpy as np

from ..mesh.trimesh import TriMesh
from ._deps import require
from .overlay import PanelOverlay
from .scene import Scene, shade

#: Chains of sharp edges (:func:`fvf.param.features.sharp_edges` at its default crease
#: angle) at least this fraction of the bounding box's diagonal long split the shading's
#: vertex normals (:func:`shading_corners`): a CAD part's edges stay crisp, while the
#: short creases of a coarse organic mesh (152 of Spot's edges bend by more than 35°,
#: 8 of them in chains that long) and a scan's noise are shaded smoothly.
SHADING_CHAIN = 0.02
#: Chains of edges bending by more than this many degrees split them too, even where
#: the faces beside them bend (a quad mesh's rim on a coarse cylinder, whose quads bend
#: by 7° each, which sharp_edges takes for a rough surface: 48 of 132 rim edges kept).
SHADING_FOLD = 75.0

__all__ = [
    "PREFIX",
    "SETTINGS",
    "init_headless",
    "draw_polyscope",
    "place_camera",
    "populate",
    "remove_ours",
    "shading_corners",
]

_STATE: dict = {}

#: Start of the names of the structures fvf registers.
PREFIX = "fvf: "

#: The view settings a panel changes, as (getter, setter) of polyscope: saved before
#: drawing and restored after (those a polyscope version lacks are skipped).
SETTINGS = (
    ("get_window_size", "set_window_size"),
    ("get_view_projection_mode", "set_view_projection_mode"),
    ("get_vertical_fov_degrees", "set_vertical_fov_degrees"),
    ("get_camera_view_matrix", "set_camera_view_matrix"),
    ("get_view_center", "set_view_center_raw"),
    ("get_background_color", "set_background_color"),
    ("get_length_scale", "set_length_scale"),
    ("get_bounding_box", "set_bounding_box"),
)

#: How to find and remove a structure of each kind fvf registers.
_KINDS = {
    "surface": ("has_surface_mesh", "remove_surface_mesh"),
    "points": ("has_point_cloud", "remove_point_cloud"),
    "curves": ("has_curve_network", "remove_curve_network"),
}


#: Narrowest line polyscope draws, pixels: its thinner tubes, supersampled only twice, fall
#: apart into dashes (a dense quad wireframe on a body scan, 0.9 px wide, lost every
#: other edge); the overlay's thinner widths still hold for the antialiased matplotlib
#: backend.
LINE_MIN_PX = 1.3


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

    A polyscope the caller's program started headless is used as it is (its
    antialiasing too); one started with a window is refused (the caller falls back).
    Raises whatever polyscope raises when EGL cannot start.
    """
    ps = require("polyscope")
    if _STATE.get("mode") == "headless":
        return ps
    if "error" in _STATE:
        raise RuntimeError(_STATE["error"])
    try:
        if not _running(ps):
            ps.set_allow_headless_backends(True)
            ps.set_verbosity(0)
            ps.set_use_prefs_file(False)  # no .polyscope.ini in the user's working directory
            with _quiet():
                ps.init("openGL3_egl")
            ps.set_SSAA_factor(2)  # antialiased glyph edges
        elif not ps.is_headless():
            raise RuntimeError("polyscope already runs with a window in this process")
    except Exception as exc:  # polyscope raises RuntimeError, or others from its bindings
        _STATE["error"] = f"{type(exc).__name__}: {exc}"
        raise
    _STATE["mode"] = "headless"
    return ps


def _running(ps: Any) -> bool:
    """Whether polyscope was started already (by the caller's program)."""
    started = getattr(ps, "is_initialized", None)
    return bool(started()) if started is not None else False


def _name(ps: Any, kind: str, base: str) -> str:
    """A free name for one of fvf's structures (the caller's are never replaced)."""
    has = getattr(ps, _KINDS[kind][0])
    name = PREFIX + base
    while has(name):
        name += "'"
    _STATE.setdefault("ours", []).append((kind, name))
    return name


def remove_ours(ps: Any) -> None:
    """Remove the structures fvf registered, and only those."""
    for kind, name in _STATE.pop("ours", []):
        has, remove = (getattr(ps, f) for f in _KINDS[kind])
        if has(name):
            remove(name)


@contextlib.contextmanager
def _borrowed(ps: Any) -> Iterator[None]:
    """Draw in polyscope's global state and give it back: afterwards fvf's structures are
    removed and the view settings (:data:`SETTINGS`) restored."""
    saved = [
        (setter, getattr(ps, getter)())
        for getter, setter in SETTINGS
        if hasattr(ps, getter) and hasattr(ps, setter)
    ]
    try:
        yield
    finally:
        remove_ours(ps)
        for setter, value in saved:
            if setter in ("set_window_size", "set_bounding_box"):
                getattr(ps, setter)(*value)
            else:
                getattr(ps, setter)(value)


def _hide_the_rest(ps: Any, ours: list) -> Any:
    """A slice plane that cuts away every structure but ``ours`` (the caller's stay
    registered and enabled, but out of the picture); returns it."""
    plane = ps.add_slice_plane(f"{PREFIX}hide the rest")
    plane.set_draw_plane(False)
    plane.set_draw_widget(False)
    plane.set_pose((0.0, 0.0, 1e30), (0.0, 0.0, 1.0))  # everything lies behind it
    for structure in ours:
        structure.set_ignore_slice_plane(plane, True)
    return plane


def _glyph_mesh(ps: Any, name: str, polys: np.ndarray, triangles: np.ndarray, color: tuple) -> Any:
    """Register flat polygons (k, p, 3), triangulated alike, as one unlit surface mesh."""
    k, p = polys.shape[:2]
    faces = (np.arange(k)[:, None, None] * p + triangles[None]).reshape(-1, 3)
    return ps.register_surface_mesh(
        _name(ps, "surface", name),
        polys.reshape(-1, 3),
        faces,
        color=tuple(color),
        material="flat",
        edge_width=0.0,
        smooth_shade=False,
        back_face_policy="identical",
    )


def _surface(ps: Any, scene: Scene, frame: np.ndarray) -> Any:
    """The drawn mesh with its shaded colours (per vertex: split at sharp edges,
    :func:`shading_corners`)."""
    mesh = scene.mesh
    X, F, colors, N = mesh.vertices, mesh.faces, scene.colors, mesh.face_normals
    if scene.colors_on == "vertices":
        corner, F, N = shading_corners(mesh)
        X, colors = X[corner], colors[corner]
    s = ps.register_surface_mesh(
        _name(ps, "surface", "mesh"),
        X,
        F,
        edge_width=0.0,
        smooth_shade=False,
        material="flat",
    )
    colors = np.clip(colors * shade(scene, N, frame)[:, None], 0.0, 1.0)
    s.add_color_quantity("colors", colors, defined_on=scene.colors_on, enabled=True)
    return s


def shading_corners(mesh: TriMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The shading's vertices: the mesh's, split where edges are sharp.

    Corners of faces around a vertex that meet across edges other than sharp ones
    (chains at least :data:`SHADING_CHAIN` of the diagonal long, of sharp edges or of
    edges bending by more than :data:`SHADING_FOLD`) share one shading vertex
    (a wedge, :func:`fvf.param.cutmesh.wedges`) whose normal is the area-weighted sum of
    their faces' normals: a CAD part's faces are shaded each with its own normal up to
    its edges, not blended with the next face along the length of its slivers.

    Parameters
    ----------
    mesh : TriMesh

    Returns
    -------
    corner : int64 (k,)
        The mesh vertex of each shading vertex.
    faces : int64 (m, 3)
        The faces on the shading vertices.
    normals : float64 (k, 3)
        Unit normal of each shading vertex.
    """
    from ..param.cutmesh import wedges
    from ..param.features import dihedral_angles, long_chains, sharp_edges

    chain = SHADING_CHAIN * float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    cut = np.zeros(mesh.n_edges, dtype=bool)
    cut[sharp_edges(mesh, min_length=chain)] = True
    cut[long_chains(mesh, np.flatnonzero(dihedral_angles(mesh) > SHADING_FOLD), chain)] = True
    if cut.any():
        W, k = wedges(mesh, cut)
        corner = np.empty(k, dtype=np.int64)
        corner[W.ravel()] = mesh.faces.ravel()
    else:  # a smooth surface: its own vertices
        W, k, corner = mesh.faces, mesh.n_vertices, np.arange(mesh.n_vertices)
    AN = mesh.face_normals * mesh.face_areas[:, None]
    idx = W.ravel()
    N = np.stack(
        [np.bincount(idx, weights=np.repeat(AN[:, d], 3), minlength=k) for d in range(3)], axis=1
    ).astype(np.float64)
    return corner, W, N / np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-300)


def _streamlines(ps: Any, lines: list[np.ndarray], color: tuple, radius: float) -> Any:
    """The polylines as one curve network of the given radius (mesh units)."""
    nodes = np.concatenate(lines)
    starts = np.cumsum([0] + [len(x) for x in lines[:-1]])
    edges = np.concatenate(
        [
            np.stack([np.arange(k, k + len(x) - 1), np.arange(k + 1, k + len(x))], axis=1)
            for k, x in zip(starts, lines, strict=True)
        ]
    )
    net = ps.register_curve_network(
        _name(ps, "curves", "streamlines"), nodes, edges, color=color, material="flat"
    )
    net.set_radius(radius, relative=False)
    return net


def _markers(ps: Any, scene: Scene, frame: np.ndarray, overlay: PanelOverlay) -> list:
    """A black sphere per singularity with a smaller coloured one pushed toward the eye far
    enough to be in front of it over its whole disc: a coloured disc with a black rim."""
    assert scene.markers is not None
    px = 1.0 / overlay.pixel_scale  # mesh units per pixel
    r = overlay.marker_radii
    if r is None:
        r = np.full(scene.markers.shape[0], overlay.marker_radius)
    inner = r - np.maximum(1.0 * px, 0.16 * r)
    rims = ps.register_point_cloud(
        _name(ps, "points", "singularity rims"),
        scene.markers,
        color=(0.0, 0.0, 0.0),
        material="flat",
    )
    _radii(rims, r)
    shift = 1.1 * np.sqrt(r * r - inner * inner) + px
    discs = ps.register_point_cloud(
        _name(ps, "points", "singularities"),
        scene.markers + shift[:, None] * frame[2],
        material="flat",
    )
    _radii(discs, inner)
    discs.add_color_quantity("index", overlay.marker_colors, enabled=True)
    return [rims, discs]


def _radii(cloud: Any, r: np.ndarray) -> None:
    """Each point's radius, mesh units (one radius when all are equal)."""
    cloud.set_radius(float(r.max(initial=0.0)), relative=False)
    if r.size and np.ptp(r) > 1e-9 * r.max():
        cloud.add_scalar_quantity("radius", r)
        cloud.set_point_radius_quantity("radius", autoscale=False)


def populate(
    ps: Any, scene: Scene, frame: np.ndarray | None = None, overlay: PanelOverlay | None = None
) -> list:
    """Register the scene's mesh, colours, glyphs, streamlines and markers in polyscope.

    ``frame`` (the panel's camera frame) defaults to the scene's first; ``overlay`` (the
    glyphs and sizes of :func:`fvf.viz.overlay.panel_overlay`) is computed for a 1024 x 768
    panel when omitted. The structures of an earlier call are removed first; the
    caller's own structures are left alone (fvf's names start with :data:`PREFIX`).
    Turns the ground plane off and the background white.

    Returns
    -------
    list
        The polyscope structures registered, the surface first. With colours per vertex
        its vertices are the shading's (:func:`shading_corners`: the mesh's, split along
        sharp edges), so a quantity added to it has one value per shading vertex.
    """
    from .overlay import panel_overlay

    frame = scene.frame if frame is None else frame
    if overlay is None:
        overlay = panel_overlay(scene, frame, scene.view.zoom, 1024, 768)
    remove_ours(ps)
    ps.set_ground_plane_mode("none")
    ps.set_background_color((1.0, 1.0, 1.0))
    made = [_surface(ps, scene, frame)]
    px = 1.0 / overlay.pixel_scale  # mesh units per pixel
    for i, g in enumerate(overlay.glyphs):
        # lifted along the normals so they stay above the surface; the halo a little less
        # (and so behind the glyph, seen from the eye)
        up = g.normals[:, None, :]
        halo = g.halo + (g.lift - 0.5 * px) * up
        made.append(_glyph_mesh(ps, f"halo {i}", halo, g.triangles, g.halo_color))
        made.append(_glyph_mesh(ps, f"field {i}", g.polygons + g.lift * up, g.triangles, g.color))
    if scene.lines:
        width = max(overlay.line_width, LINE_MIN_PX)
        made.append(_streamlines(ps, scene.lines, scene.line_color, 0.5 * width * px))
    if scene.markers is not None and len(scene.markers):
        made.extend(_markers(ps, scene, frame, overlay))
    return made


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
    """Render one panel of a scene headless to an RGB image, uint8 (height, width, 3).

    polyscope's scene is left as it was (see the module's description).
    """
    from .overlay import panel_overlay

    frame = scene.frame if frame is None else frame
    view = scene.view if view is None else view
    if overlay is None:
        overlay = panel_overlay(scene, frame, view.zoom, width, height)
    ps = init_headless()
    with _borrowed(ps):
        ps.set_window_size(int(width), int(height))
        plane = _hide_the_rest(ps, populate(ps, scene, frame, overlay))
        try:
            place_camera(ps, scene, width, height, frame, view)
            buf = np.asarray(ps.screenshot_to_buffer(transparent_bg=False))
        finally:
            ps.remove_slice_plane(plane.get_name())
    img = buf[:, :, :3]
    if img.shape[:2] != (height, width):  # some drivers round the buffer size
        from PIL import Image

        img = np.asarray(Image.fromarray(img).resize((width, height)))
    return np.ascontiguousarray(img)
