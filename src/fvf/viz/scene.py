"""What a picture shows, checked and turned into colours: the input of every backend.

A :class:`Scene` holds the mesh, per-vertex or per-face RGB colours (a colormapped
function, a grey texture, or both multiplied), arrow segments, singularity markers and
streamline polylines, and the camera frame. Backends only draw it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ..errors import FieldShapeError, FieldValueError, FvfError
from ..mesh.inputs import as_direction_count, as_face_field
from ..mesh.trimesh import TriMesh
from .arrows import arrow_segments, default_arrow_scale, spread_faces
from .camera import View, as_view, camera_frame

__all__ = ["Scene", "SURFACE_COLOR", "index_color", "index_label", "build_scene", "shade"]

#: Colour of a surface that shows no function: light blue-grey.
SURFACE_COLOR = (0.80, 0.83, 0.88)
#: Colour of arrows and streamlines over a plain surface / over a colormapped one.
LINE_COLOR = (0.08, 0.08, 0.10)
_INDEX_COLORS = {
    1: (0.86, 0.12, 0.12),
    -1: (0.10, 0.35, 0.90),
    2: (1.0, 0.55, 0.0),
    -2: (0.0, 0.75, 0.85),
}


_FRACTION_COLORS = {
    0.25: (0.98, 0.45, 0.10),
    -0.25: (0.20, 0.65, 1.00),
    0.5: (0.80, 0.10, 0.55),
    -0.5: (0.10, 0.70, 0.55),
}


def index_color(index: float) -> tuple[float, float, float]:
    """Marker colour of a singularity of the given index (+1 red, −1 blue, +2 orange,
    −2 cyan; N-field indices +1/4 amber, −1/4 sky blue, +1/2 magenta, −1/2 teal; any
    other purple)."""
    x = float(index)
    if x.is_integer():
        return _INDEX_COLORS.get(int(x), (0.55, 0.25, 0.70))
    return _FRACTION_COLORS.get(round(x, 9), (0.55, 0.25, 0.70))


def index_label(index: float) -> str:
    """The index as a signed fraction: ``+1``, ``-1/4``, ``+1/6`` …"""
    from fractions import Fraction

    f = Fraction(float(index)).limit_denominator(24)
    return f"{f.numerator:+d}" if f.denominator == 1 else f"{f.numerator:+d}/{f.denominator}"


@dataclass
class Scene:
    """A checked picture description (see :func:`build_scene`)."""

    mesh: TriMesh
    colors: np.ndarray  # (n, 3) or (m, 3) RGB in [0, 1]
    colors_on: str  # "vertices" or "faces"
    frame: np.ndarray  # (3, 3) camera frame rows right, up, back
    view: View
    arrows: np.ndarray | None = None  # (k, 2, 3)
    arrow_faces: np.ndarray | None = None  # (k,)
    arrow_scale: float | None = None
    markers: np.ndarray | None = None  # (s, 3)
    marker_indices: np.ndarray | None = None  # (s,) float: k or k/N
    strokes: np.ndarray | None = None  # (k, 2, 3): N-field strokes, no heads
    stroke_faces: np.ndarray | None = None  # (k,)
    lines: list[np.ndarray] = field(default_factory=list)
    line_color: tuple = LINE_COLOR
    colorbar: dict | None = None  # {"cmap", "clim", "label"}


def shade(scene: Scene, normals: np.ndarray) -> np.ndarray:
    """Lambert factor of unit normals (k, 3) under a light above-right of the eye, (k,).

    ``0.42 + 0.58 |⟨N, l⟩|``: both backends multiply the colours by it (polyscope draws
    them with its unlit "flat" material), so the shape reads and the colours stay close
    to the colorbar's.
    """
    right, up, back = scene.frame
    light = 0.35 * right + 0.55 * up + back
    light = light / np.linalg.norm(light)
    return 0.42 + 0.58 * np.abs(normals @ light)


def _values(mesh: TriMesh, f: npt.ArrayLike, name: str) -> tuple[np.ndarray, str]:
    a = np.asarray(f, dtype=float)
    if a.ndim == 1 and a.shape[0] == mesh.n_vertices:
        on = "vertices"
    elif a.ndim == 1 and a.shape[0] == mesh.n_faces:
        on = "faces"
    else:
        raise FieldShapeError(
            f"{name} must have one value per vertex ({mesh.n_vertices},) or per face "
            f"({mesh.n_faces},); got shape {a.shape}."
        )
    if not np.isfinite(a).all():
        bad = np.flatnonzero(~np.isfinite(a))
        raise FieldValueError(f"{name} has non-finite values at {on} {bad[:8].tolist()}.")
    return a, on


def _to_vertices(mesh: TriMesh, a: np.ndarray) -> np.ndarray:
    """Face values (m, ...) to vertex values by area-weighted averaging."""
    w = np.repeat(mesh.face_areas, 3)
    idx = mesh.faces.ravel()
    num = np.stack(
        [
            np.bincount(idx, weights=w * np.repeat(a[:, c], 3), minlength=mesh.n_vertices)
            for c in range(a.shape[1])
        ],
        axis=1,
    )
    return num / np.bincount(idx, weights=w, minlength=mesh.n_vertices)[:, None]


def build_scene(
    mesh: TriMesh,
    *,
    function: npt.ArrayLike | None = None,
    field: npt.ArrayLike | None = None,
    singularities: tuple | None = None,
    streamlines: list | None = None,
    texture: npt.ArrayLike | None = None,
    arrow_scale: float | None = None,
    max_arrows: int | None = 1500,
    cmap: str = "viridis",
    clim: tuple[float, float] | None = None,
    view: View | tuple | dict | None = None,
    colorbar_label: str | None = None,
    n: int = 1,
) -> Scene:
    """Check the inputs of :func:`fvf.viz.render` and build a :class:`Scene`."""
    from ._deps import require

    mpl = require("matplotlib")
    n = as_direction_count(n)
    if not isinstance(mesh, TriMesh):
        raise FvfError(f"mesh must be a fvf.TriMesh; got {type(mesh).__name__}")
    view = as_view(view)
    colorbar = None
    colors, on = np.tile(np.asarray(SURFACE_COLOR), (mesh.n_vertices, 1)), "vertices"
    if function is not None:
        f, on = _values(mesh, function, "function")
        lo, hi = (float(f.min()), float(f.max())) if clim is None else map(float, clim)
        if not hi > lo:
            lo, hi = lo - 0.5, hi + 0.5
        try:
            cm = mpl.colormaps[cmap]
        except KeyError as exc:
            raise FvfError(f"unknown colormap {cmap!r} (a matplotlib colormap name)") from exc
        colors = cm(np.clip((f - lo) / (hi - lo), 0.0, 1.0))[:, :3]
        colorbar = {"cmap": cmap, "clim": (lo, hi), "label": colorbar_label}
    if texture is not None:
        t, t_on = _values(mesh, texture, "texture")
        p1, p99 = np.percentile(t, [1, 99])
        g = np.clip((t - p1) / max(p99 - p1, 1e-300), 0.0, 1.0)
        if function is None:
            colors, on = np.repeat(g[:, None], 3, axis=1), t_on
        else:
            if on != t_on:  # bring both to the vertices
                colors = _to_vertices(mesh, colors) if on == "faces" else colors
                g = _to_vertices(mesh, g[:, None])[:, 0] if t_on == "faces" else g
                on = "vertices"
            colors = colors * (0.25 + 0.75 * g[:, None])
    scene = Scene(
        mesh,
        np.asarray(colors, float),
        on,
        camera_frame(view, mesh.vertices),
        view,
        colorbar=colorbar,
    )
    if field is not None:
        scale = default_arrow_scale(mesh, field) if arrow_scale is None else float(arrow_scale)
        if not scale > 0:
            raise FvfError(f"arrow_scale must be positive; got {arrow_scale!r}")
        faces = spread_faces(mesh, max_arrows)
        if n == 1:
            scene.arrows = arrow_segments(mesh, field, scale)[faces]
            scene.arrow_faces, scene.arrow_scale = faces, scale
        else:  # an N-direction field: N strokes (no heads) from each chosen centroid
            from ..design.nfields import all_directions

            u = as_face_field(mesh, field, "field")
            length = np.linalg.norm(u, axis=1)
            top = float(length.max(initial=0.0))
            u = u * (top / np.where(length > 0, length, np.inf))[:, None]  # equal strokes
            d = all_directions(mesh, u, n)[:, faces]
            c = mesh.face_centroids[faces]
            tips = c[None] + 0.5 * scale * d  # half length: a cross spans one arrow
            scene.strokes = np.stack([np.broadcast_to(c, tips.shape), tips], axis=2).reshape(
                -1, 2, 3
            )
            scene.stroke_faces = np.tile(faces, n)
            scene.arrow_scale = scale
    if singularities is not None:
        try:
            P, ind = singularities
        except (TypeError, ValueError) as exc:
            raise FvfError("singularities must be a pair (positions (k, 3), indices (k,))") from exc
        P, ind = np.asarray(P, float).reshape(-1, 3), np.asarray(ind).ravel()
        if P.shape[0] != ind.shape[0]:
            raise FieldShapeError(
                f"singularity positions ({P.shape[0]}) and indices ({ind.shape[0]}) differ"
            )
        scene.markers, scene.marker_indices = P, ind.astype(np.float64)
    if streamlines is not None:
        lines = [np.asarray(x, float).reshape(-1, 3) for x in streamlines]
        scene.lines = [x for x in lines if x.shape[0] >= 2]
    if function is not None or texture is not None:
        scene.line_color = (0.85, 0.05, 0.05)
    return scene
