"""What a picture shows, checked and turned into colours: the input of every backend.

A :class:`Scene` holds the drawn surface with per-vertex or per-face RGB colours (a
colormapped function, a grey texture, or both multiplied), the tangent fields to draw as
arrows or N-direction strokes (:class:`FieldLayer`), singularity markers, streamline
polylines, the colorbar, and one camera frame per panel. What depends on the picture's
pixels (which faces carry an arrow, glyph sizes) is computed per panel by
:mod:`fvf.viz.overlay`; backends only draw.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from ..errors import FieldShapeError, FieldValueError, FvfError
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_face_field
from ..mesh.trimesh import TriMesh
from .camera import View, as_views, camera_frame, resolve_up
from .colors import contrast_color, equalize, index_color, index_label, resolve_clim

if TYPE_CHECKING:
    from .style import RenderStyle

__all__ = [
    "DATA_DEFAULTS",
    "FieldLayer",
    "Scene",
    "SURFACE_COLOR",
    "build_scene",
    "equalize",
    "index_color",
    "index_label",
    "shade",
]

#: Colour of a surface that shows no function: light blue-grey.
SURFACE_COLOR = (0.80, 0.83, 0.88)
#: Colour of the vertices or faces whose function value is NaN ("no data", "no ground
#: truth"): a neutral light grey, outside every sequential colormap's hues, named in the
#: legend (:attr:`fvf.viz.RenderStyle.nan_label`).
NO_DATA_COLOR = (0.78, 0.78, 0.78)
#: Overlay colour when nothing else decides (kept for callers of the old name).
LINE_COLOR = (0.08, 0.08, 0.10)
#: Range of the shading factor :func:`shade` multiplies colours by.
SHADE_RANGE = (0.42, 1.0)
#: A grey texture ``g`` in [0, 1] multiplies the colours by ``TEXTURE_FLOOR + (1 − floor) g``.
TEXTURE_FLOOR = 0.4


@dataclass
class FieldLayer:
    """One tangent field to draw: arrows (``n == 1``) or N strokes per face."""

    vectors: np.ndarray  # (m, 3) per face of Scene.field_mesh
    n: int
    scale: float | None  # absolute arrow scale (mesh units per unit |v|), None: per picture
    top: float  # robust maximum of |v| (the length the default scale maps to the spacing)
    color: tuple
    label: str | None = None


@dataclass
class Scene:
    """A checked picture description (see :func:`build_scene`)."""

    mesh: TriMesh  # the drawn surface (a finer canvas when a LicTexture is shown)
    colors: np.ndarray  # (n, 3) or (m, 3) RGB in [0, 1]
    colors_on: str  # "vertices" or "faces"
    frames: list  # one (3, 3) camera frame (rows right, up, back) per panel
    views: list  # one resolved View per panel
    field_mesh: TriMesh  # the mesh the fields, markers and lines refer to
    fields: list[FieldLayer] = field(default_factory=list)
    arrow_spacing: float | None = None  # pixels between arrows (None: from the size)
    max_arrows: int | None = None
    markers: np.ndarray | None = None  # (s, 3)
    marker_indices: np.ndarray | None = None  # (s,) float: k or k/N
    lines: list[np.ndarray] = field(default_factory=list)
    line_color: tuple = LINE_COLOR
    colorbar: dict | None = None  # {"cmap", "clim", "label", "extend", "nan"}
    palette: np.ndarray | None = None  # (k, 3) colours the surface can show
    show_colorbar: bool = True  # draw the colorbar (RenderStyle.colorbar)
    no_data: str | None = None  # legend name of the NaN colour, when some value is NaN
    marker_kind: str = "index"  # "index" (k/N of a field) or "valence" (of a quad mesh)

    @property
    def frame(self) -> np.ndarray:
        """The first panel's camera frame."""
        return self.frames[0]

    @property
    def view(self) -> View:
        """The first panel's view."""
        return self.views[0]


def shade(scene: Scene, normals: np.ndarray, frame: np.ndarray | None = None) -> np.ndarray:
    """Lambert factor of unit normals (k, 3) under a light above-right of the eye, (k,).

    ``0.42 + 0.58 |⟨N, l⟩|``: both backends multiply the colours by it (polyscope draws
    them with its unlit "flat" material), so the shape reads and the colours stay close
    to the colorbar's. ``frame`` defaults to the first panel's.
    """
    right, up, back = scene.frame if frame is None else frame
    light = 0.35 * right + 0.55 * up + back
    light = light / np.linalg.norm(light)
    lo, hi = SHADE_RANGE
    return lo + (hi - lo) * np.abs(normals @ light)


def _values(
    mesh: TriMesh, f: npt.ArrayLike, name: str, nan: bool = False
) -> tuple[np.ndarray, str]:
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
    bad = np.flatnonzero(np.isinf(a) if nan else ~np.isfinite(a))
    if bad.size:
        raise FieldValueError(f"{name} has non-finite values at {on} {bad[:8].tolist()}.")
    if nan and np.isnan(a).all():
        raise FieldValueError(f"{name} is NaN (no data) everywhere.")
    return a, on


def _areas(mesh: TriMesh, on: str) -> np.ndarray:
    return mesh.vertex_areas if on == "vertices" else mesh.face_areas


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


def _surface(mesh, function, texture, cmap, clim, colorbar_label, mpl):
    """Colours of the drawn mesh, where they live, the colorbar and the possible colours.

    NaN values of ``function`` are drawn in :data:`NO_DATA_COLOR`; the colour limits are
    those of the other values. The colorbar dict says whether there were any (``"nan"``).
    """
    from .lic import LicTexture

    colorbar = None
    lic = texture if isinstance(texture, LicTexture) else None
    drawn = mesh if lic is None else lic.mesh
    colors, on = np.tile(np.asarray(SURFACE_COLOR), (drawn.n_vertices, 1)), "vertices"
    palette = np.asarray([SURFACE_COLOR])
    if function is not None:
        f, on = _values(mesh, function, "function", nan=True)
        known = ~np.isnan(f)
        lo, hi, below, above = resolve_clim(f[known], _areas(mesh, on)[known], clim)
        try:
            cm = mpl.colormaps[cmap]
        except KeyError as exc:
            raise FvfError(f"unknown colormap {cmap!r} (a matplotlib colormap name)") from exc
        if lic is not None:  # carry the function over to the canvas
            f, on = (
                (lic.vertex_values(f), "vertices")
                if on == "vertices"
                else (
                    f[lic.parent],
                    "faces",
                )
            )
        colors = cm(np.clip((np.nan_to_num(f) - lo) / (hi - lo), 0.0, 1.0))[:, :3]
        colors[np.isnan(f)] = NO_DATA_COLOR
        if on == "vertices" and np.isnan(f).any():  # no grey blended into the colormap:
            F = drawn.faces  # a face touching a vertex without data is drawn without data
            colors = np.where(np.isnan(f)[F].any(1)[:, None], NO_DATA_COLOR, colors[F].mean(1))
            on = "faces"
        extend = {(False, False): "neither", (True, False): "min", (False, True): "max"}
        colorbar = {
            "cmap": cmap,
            "clim": (lo, hi),
            "label": colorbar_label,
            "extend": extend.get((below, above), "both"),
            "nan": bool(np.isnan(f).any()),
        }
        palette = cm(np.linspace(0.0, 1.0, 64))[:, :3]
        if colorbar["nan"]:
            palette = np.vstack([palette, NO_DATA_COLOR])
    if texture is not None:
        if lic is not None:
            g, t_on = lic.values, "vertices"
        else:
            t, t_on = _values(mesh, texture, "texture")
            g = equalize(t, _areas(mesh, t_on))
        if function is None:
            colors, on = np.repeat(g[:, None], 3, axis=1), t_on
            palette = np.linspace(0.0, 1.0, 16)[:, None].repeat(3, axis=1)
        else:
            if on != t_on:  # bring both to the vertices
                colors = _to_vertices(drawn, colors) if on == "faces" else colors
                g = _to_vertices(drawn, g[:, None])[:, 0] if t_on == "faces" else g
                on = "vertices"
            colors = colors * (TEXTURE_FLOOR + (1.0 - TEXTURE_FLOOR) * g[:, None])
            palette = np.vstack([palette, palette * TEXTURE_FLOOR])
    shades = np.linspace(*SHADE_RANGE, 4)
    palette = (palette[None] * shades[:, None, None]).reshape(-1, 3)
    return drawn, np.asarray(colors, float), on, colorbar, palette


def _field_list(field: object) -> list:
    """One field or a list of fields."""
    if field is None:
        return []
    if isinstance(field, (list, tuple)) and field and np.ndim(field[0]) == 2:
        return list(field)
    return [field]


def _layers(mesh, fields, n, arrow_scale, labels, palette, avoid, arrow_color):
    from .colors import robust_limits

    if isinstance(n, bool) or not float(n).is_integer() or int(n) < 1:
        raise FvfError(f"n (directions per face) must be a positive integer; got {n!r}")
    n = int(n)
    if labels is not None and len(labels) != len(fields):
        raise FvfError(f"field_labels has {len(labels)} names for {len(fields)} fields")
    layers: list[FieldLayer] = []
    taken = list(avoid)
    for i, f in enumerate(fields):
        v = as_face_field(mesh, f, "field")
        speed = np.sqrt((v * v).sum(1))
        top = robust_limits(speed, mesh.face_areas)[1] if speed.max(initial=0) > 0 else 1.0
        if arrow_color is not None and i == 0:
            color = tuple(float(c) for c in arrow_color)
        else:
            color = contrast_color(palette, np.asarray(taken).reshape(-1, 3))
        taken.append(color)
        scale = None if arrow_scale is None else float(arrow_scale)
        layers.append(
            FieldLayer(v, n, scale, float(top), color, None if labels is None else labels[i])
        )
    return layers


def _markers(singularities: tuple) -> tuple[np.ndarray, np.ndarray]:
    try:
        P, ind = singularities
    except (TypeError, ValueError) as exc:
        raise FvfError("singularities must be a pair (positions (k, 3), indices (k,))") from exc
    P, ind = np.asarray(P, float).reshape(-1, 3), np.asarray(ind, dtype=float).ravel()
    if P.shape[0] != ind.shape[0]:
        raise FieldShapeError(
            f"singularity positions ({P.shape[0]}) and indices ({ind.shape[0]}) differ"
        )
    if not (np.isfinite(P).all() and np.isfinite(ind).all()):
        raise FieldValueError("singularity positions and indices must be finite")
    return P, ind


def _marker_kind(kind: object) -> str:
    if kind not in ("index", "valence"):
        raise FvfError(f"singularity_kind must be 'index' or 'valence'; got {kind!r}")
    return str(kind)


#: The data keywords of :func:`fvf.viz.render` (what is drawn) and their defaults; every
#: other keyword is an option of :class:`fvf.viz.RenderStyle` (how it looks).
DATA_DEFAULTS: dict[str, Any] = {
    "function": None,
    "field": None,
    "singularities": None,
    "streamlines": None,
    "texture": None,
    "n": 1,
    "field_labels": None,
    "singularity_kind": "index",
}


@takes_mesh
def build_scene(mesh: TriMesh, *, style: RenderStyle | None = None, **inputs: Any) -> Scene:
    """Check the inputs of :func:`fvf.viz.render` and build a :class:`Scene`.

    Parameters
    ----------
    mesh : TriMesh
    style : RenderStyle, optional
        The appearance (default :class:`fvf.viz.RenderStyle`).
    **inputs
        The data keywords of :func:`fvf.viz.render` (:data:`DATA_DEFAULTS`: ``function``,
        ``field``, ``singularities``, ``streamlines``, ``texture``, ``n``,
        ``field_labels``, ``singularity_kind``) and appearance keywords, which replace
        those of ``style``.

    Returns
    -------
    Scene
    """
    from ._deps import require
    from .lic import LicTexture
    from .style import as_style

    data = {k: inputs.pop(k, default) for k, default in DATA_DEFAULTS.items()}
    style = as_style(style, inputs, "build_scene")
    mpl = require("matplotlib")
    if not isinstance(mesh, TriMesh):
        raise FvfError(f"mesh must be a fvf.TriMesh; got {type(mesh).__name__}")
    texture = data["texture"]
    if isinstance(texture, LicTexture) and texture.source_faces != mesh.n_faces:
        raise FieldShapeError(
            f"the LIC texture was computed on a mesh with {texture.source_faces} faces; "
            f"this one has {mesh.n_faces}"
        )
    centroid = mesh.face_areas @ mesh.face_centroids / max(mesh.total_area, 1e-300)
    views = [resolve_up(v, mesh.vertices, centroid, style.up) for v in as_views(style.view)]
    drawn, colors, on, colorbar, palette = _surface(
        mesh, data["function"], texture, style.cmap, style.clim, style.colorbar_label, mpl
    )
    scene = Scene(
        drawn,
        colors,
        on,
        [camera_frame(v, mesh.vertices) for v in views],
        views,
        mesh,
        arrow_spacing=None if style.arrow_spacing is None else float(style.arrow_spacing),
        max_arrows=style.max_arrows,
        colorbar=colorbar,
        palette=palette,
        show_colorbar=bool(style.colorbar),
        no_data=style.nan_label if colorbar is not None and colorbar["nan"] else None,
        marker_kind=_marker_kind(data["singularity_kind"]),
    )
    avoid: list = []
    if data["singularities"] is not None:
        scene.markers, scene.marker_indices = _markers(data["singularities"])
        avoid = [index_color(i) for i in np.unique(scene.marker_indices)]
    scene.fields = _layers(
        mesh,
        _field_list(data["field"]),
        data["n"],
        style.arrow_scale,
        data["field_labels"],
        palette,
        avoid,
        style.arrow_color,
    )
    if data["streamlines"] is not None:
        lines = [np.asarray(x, float).reshape(-1, 3) for x in data["streamlines"]]
        scene.lines = [x for x in lines if x.shape[0] >= 2]
        taken = avoid + [lay.color for lay in scene.fields]
        scene.line_color = contrast_color(palette, np.asarray(taken).reshape(-1, 3))
    return scene
