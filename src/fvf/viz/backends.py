"""Backend choice and the two entry points: :func:`render` (to a PNG) and :func:`view`.

``"polyscope-egl"``: polyscope's OpenGL renderer started headless through EGL (no display
needed, but the EGL libraries must be installed: Debian ``libegl1 libegl-mesa0
libgl1-mesa-dri``). ``"matplotlib"``: the Agg renderer of :mod:`fvf.viz.mpl_backend`,
which runs everywhere matplotlib does. ``backend="auto"`` takes the first of
:func:`available_backends`; if polyscope is installed but cannot start, it falls back to
matplotlib with one :class:`~fvf.viz.RenderBackendWarning` per process.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from ..errors import FvfError, ParameterError
from ..mesh.convert import takes_mesh
from ..mesh.nfield import FROM_FIELD, FromField, NField, fields_order
from ..mesh.trimesh import TriMesh
from ._deps import INSTALL_HINT, MissingExtraError, NoDisplayError, RenderBackendWarning
from .style import BACKENDS, MAX_SIZE, RenderStyle, as_style, check_render_options

if TYPE_CHECKING:
    from .overlay import PanelOverlay
    from .scene import Scene

__all__ = [
    "BACKENDS",
    "MAX_SIZE",
    "RenderInfo",
    "RenderStyle",
    "available_backends",
    "check_render_options",
    "polyscope_status",
    "render",
    "view",
]

_PROBE = (
    "import polyscope as ps\n"
    "ps.set_allow_headless_backends(True)\n"
    "ps.set_verbosity(0)\n"
    "ps.set_use_prefs_file(False)\n"
    "ps.init('openGL3_egl')\n"
    "ps.set_window_size(64, 48)\n"
    "b = ps.screenshot_to_buffer(transparent_bg=False)\n"
    "assert b.shape[2] == 4\n"
)
_STATUS: dict[str, Any] = {}


@dataclass
class RenderInfo:
    """What :func:`render` did.

    Attributes
    ----------
    path : Path or None
        The picture written; None when :func:`render` was given no path (then ``png``
        holds it, and a notebook shows it: ``_repr_png_``).
    backend : str
        ``"polyscope-egl"`` or ``"matplotlib"``.
    size : tuple of int
        (width, height) in pixels.
    seconds : float
        Wall time.
    arrow_scale : float or None
        Mesh units per unit of |v| of the arrows drawn (None without a field).
    n_arrows, n_streamlines, n_singularities : int
        What was drawn (faces with arrows or strokes, summed over the panels).
    clim : tuple of float or None
        Colormap limits of ``function``.
    fallback : str or None
        Why the preferred backend was not used, when ``backend="auto"`` fell back.
    extra : dict
        Panels, arrow spacing (pixels), arrow colours, capped arrows, the up axis used.
    """

    path: Path | None
    backend: str
    size: tuple[int, int]
    seconds: float = 0.0
    arrow_scale: float | None = None
    n_arrows: int = 0
    n_streamlines: int = 0
    n_singularities: int = 0
    clim: tuple[float, float] | None = None
    fallback: str | None = None
    extra: dict = field(default_factory=dict)
    png: bytes | None = field(default=None, repr=False)

    def _repr_png_(self) -> bytes | None:
        """The picture, for Jupyter, when :func:`render` kept it in memory (no path)."""
        return self.png


def polyscope_status() -> str | None:
    """None if headless polyscope works here, else the reason it does not (cached).

    The first call starts polyscope in a subprocess (about 2 s), so a driver that crashes
    or hangs cannot take the caller down. ``FVF_VIZ_BACKEND=matplotlib`` in the
    environment disables polyscope.
    """
    if os.environ.get("FVF_VIZ_BACKEND", "").lower() == "matplotlib":
        return "disabled by FVF_VIZ_BACKEND=matplotlib"  # not cached: the setting may change
    if "polyscope" in _STATUS:
        return _STATUS["polyscope"]
    reason: str | None
    if importlib.util.find_spec("polyscope") is None:
        reason = f"polyscope is not installed ({INSTALL_HINT})"
    else:
        try:
            r = subprocess.run(
                [sys.executable, "-c", _PROBE], capture_output=True, text=True, timeout=120
            )
            lines = (r.stderr or r.stdout).strip().splitlines()
            reason = (
                None
                if r.returncode == 0
                else (
                    f"polyscope could not start EGL (exit {r.returncode}): "
                    f"{lines[-1] if lines else 'no message'}"
                )
            )
        except (OSError, subprocess.TimeoutExpired) as exc:
            reason = f"polyscope could not start EGL: {exc}"
    _STATUS["polyscope"] = reason
    return reason


def available_backends() -> list[str]:
    """The backends that work here, best first: a subset of ``["polyscope-egl", "matplotlib"]``."""
    out = []
    if importlib.util.find_spec("matplotlib") is not None:
        if polyscope_status() is None:
            out.append("polyscope-egl")
        out.append("matplotlib")
    return out


def _warn_once(reason: str) -> None:
    if not _STATUS.get("warned"):
        _STATUS["warned"] = True
        warnings.warn(
            f"rendering with matplotlib instead of polyscope: {reason}",
            RenderBackendWarning,
            stacklevel=3,
        )


def _field_magnitude(what: str, field: Any, style: RenderStyle | None, options: dict) -> Any:
    """``function="magnitude"`` of :func:`render`: |u| per face, float64 (m,), and the
    colorbar label ``|field|`` unless one is given (``options`` updated in place)."""
    if what != "magnitude" or field is None:
        raise ParameterError(
            f'function must be an array or "magnitude" (with a field); got {what!r}'
            + (" without a field" if what == "magnitude" else "")
        )
    first = field[0] if isinstance(field, list | tuple) else field
    if "colorbar_label" not in options and (style is None or style.colorbar_label is None):
        options["colorbar_label"] = "|field|"
    return np.linalg.norm(np.asarray(first, dtype=np.float64), axis=-1)


@takes_mesh
def render(
    mesh: TriMesh,
    path: str | Path | None = None,
    *,
    function: npt.ArrayLike | None = None,
    field: Any = None,
    singularities: tuple | None = None,
    streamlines: list | None = None,
    texture: Any = None,
    n: int | FromField = FROM_FIELD,
    field_labels: list | tuple | None = None,
    singularity_kind: str = "index",
    style: RenderStyle | None = None,
    **options: Any,
) -> RenderInfo:
    """Render a mesh with a function, fields, singularities, streamlines or a texture.

    The arguments are what is drawn; how it looks is ``style``
    (:class:`fvf.viz.RenderStyle`: colours, glyph sizes, camera, picture size, title,
    backend). Appearance keywords (``cmap=``, ``size=``, ``view=``, ...) are the same
    options one at a time: they replace those of ``style`` (default
    ``RenderStyle()``), so ``render(mesh, path, function=f, cmap="magma")`` and
    ``render(mesh, path, function=f, style=RenderStyle(cmap="magma"))`` draw the same.

    Parameters
    ----------
    mesh : TriMesh
    path : str or Path, optional
        Output picture: PNG, or PDF / SVG by the suffix (``.pdf``, ``.svg``: title,
        colorbar and legend as vector graphics, the rendered surface as an image).
        Without a path the PNG is kept in memory (``RenderInfo.png``), and the returned
        :class:`RenderInfo` shows it in a notebook.
    function : array_like (n,) or (m,), or "magnitude", optional
        Vertex or face scalars, drawn with ``style.cmap`` and a labelled colorbar. NaN
        marks missing values, drawn in light grey (:data:`fvf.viz.scene.NO_DATA_COLOR`)
        and named in the legend (``style.nan_label``). ``"magnitude"``: the length of
        ``field`` (its first one, for a list) per face, labelled ``|field|`` — an N-field
        is drawn as unit crosses, so this is how its magnitude is seen.
    field : array_like (m, 3) or list of them, optional
        Per-face tangent vectors, drawn as flat arrows in the faces' planes
        (:mod:`fvf.viz.overlay`), about one per ``arrow_spacing`` pixels, each field in
        its own colour chosen to contrast with the surface's colours
        (:func:`fvf.viz.colors.contrast_color`); name them with ``field_labels``.
    singularities : (ndarray (k, 3), ndarray (k,)), optional
        Positions and indices (e.g. :func:`fvf.singularity_positions` and
        :func:`fvf.singularities`; indices may be fractions k/N), drawn as discs coloured
        by index (:func:`fvf.viz.colors.index_color`) with a legend giving each index's
        colour and count.
    streamlines : list of ndarray (p_i, 3), optional
        Polylines on the surface (:func:`fvf.viz.streamlines`).
    texture : array_like (n,) or (m,), or LicTexture, optional
        A grey texture: a :class:`fvf.viz.LicTexture` (:func:`fvf.viz.surface_lic`,
        drawn on its own finer canvas) or values per vertex / face, histogram-equalized.
        With ``function`` too, it darkens the colormap's colours.
    n : int, optional
        Directions per face of ``field`` (default: the ``n`` of an :class:`fvf.NField`
        ``field``, else 1): 1 draws arrows; N ≥ 2 draws the N directions
        (the representative turned by 2πk/N about the face normal,
        :func:`fvf.viz.arrows.direction_set`) as N strokes from the centroid, each half an
        arrow long.
    field_labels : list of str, optional
        Names of the fields in the legend, one per field.
    singularity_kind : {"index", "valence"}
        How the legend names the ``singularities``: ``"index"`` (``index +1/4``, of a
        field) or ``"valence"`` (``valence 3``: vertices of a quad mesh, given with the
        cross-field index ``(4 − valence) / 4`` so both pictures share colours).
    style : RenderStyle, optional
        The appearance; default ``RenderStyle()``.
    **options
        Options of :class:`fvf.viz.RenderStyle` (``cmap``, ``clim``, ``colorbar_label``,
        ``arrow_color``, ``arrow_scale``, ``arrow_spacing``, ``max_arrows``, ``view``,
        ``up``, ``size``, ``dpi``, ``title``, ``backend``, ``colorbar``, ``nan_label``),
        replacing those of ``style``.

    Returns
    -------
    RenderInfo
        ``n_arrows`` counts the glyphs' faces over all panels; ``extra["panels"]`` the
        number of panels, ``extra["arrow_spacing"]`` the spacing in pixels,
        ``extra["arrow_colors"]`` the fields' colours, ``extra["capped_arrows"]`` the
        arrows drawn shorter than their length (longer than 1.3 spacings),
        ``extra["up"]`` the up axis of the first panel.

    Raises
    ------
    MissingExtraError
        matplotlib (or polyscope for ``backend="polyscope-egl"``) is not installed.
    ParameterError
        A bad option: size out of range, non-finite or empty ``clim``, ``max_arrows`` < 1,
        a non-positive or non-finite ``arrow_scale``, an unknown backend or up axis.
    TypeError
        A keyword that is neither data nor an option of :class:`fvf.viz.RenderStyle`.
    FvfError
        Bad inputs (shapes, unknown colormap), or the requested polyscope backend cannot
        start.
    OutputWriteError
        The PNG could not be written (a file already at ``path`` is unchanged).

    Notes
    -----
    With polyscope, the picture is drawn in polyscope's global scene: structures
    registered there by the caller are hidden while it draws and left as they were, and
    the camera, window size, background colour and scene extents are restored afterwards
    (the ground plane stays off: polyscope cannot report its mode).
    """
    from .compose import compose, has_colorbar, layout, legend_width
    from .scene import build_scene

    t0 = time.perf_counter()
    fields = field if isinstance(field, list | tuple) else [field]
    if n is FROM_FIELD or any(isinstance(f, NField) for f in fields):
        n = fields_order(field, n)  # else the scene checks the n given
    if isinstance(function, str):
        function = _field_magnitude(function, field, style, options)
    style = as_style(style, options, "render")
    scene = build_scene(
        mesh,
        style=style,
        function=function,
        field=field,
        singularities=singularities,
        streamlines=streamlines,
        texture=texture,
        n=n,
        field_labels=field_labels,
        singularity_kind=singularity_kind,
    )
    width, height = style.width, style.height
    side = legend_width(scene, width)
    lay = layout(width, height, style.title, has_colorbar(scene), side, len(scene.frames))
    pw, ph = lay.panel_width, lay.panel_height
    if pw < 32 or ph < 32:
        raise FvfError(f"size {style.size!r} leaves panels of {pw} x {ph} pixels; make it larger")
    overlays = _overlays(scene, pw, ph)
    used, fallback, images = _draw_panels(scene, overlays, pw, ph, style.backend)
    if path is not None:
        out = Path(path)
        compose(images, scene, out, width, height, style.title, int(style.dpi))
        return _render_info(out, used, fallback, (width, height), t0, scene, overlays)
    import tempfile

    with tempfile.TemporaryDirectory() as folder:  # no path: the PNG kept in memory
        out = Path(folder) / "render.png"
        compose(images, scene, out, width, height, style.title, int(style.dpi))
        info = _render_info(None, used, fallback, (width, height), t0, scene, overlays)
        info.png = out.read_bytes()
    return info


def _overlays(scene: Scene, pw: int, ph: int) -> list[PanelOverlay]:
    """The glyphs of every panel, all at the first panel's arrow scale."""
    from .overlay import panel_overlay

    overlays: list[PanelOverlay] = []
    for frame, v in zip(scene.frames, scene.views, strict=True):
        first = overlays[0] if overlays else None
        spacing_mesh = None if first is None else first.spacing / first.pixel_scale
        overlays.append(panel_overlay(scene, frame, v.zoom, pw, ph, spacing_mesh))
    return overlays


def _render_info(
    path: Path | None,
    used: str,
    fallback: str | None,
    size: tuple[int, int],
    t0: float,
    scene: Scene,
    overlays: list[PanelOverlay],
) -> RenderInfo:
    """What :func:`render` drew (the figures of its :class:`RenderInfo`)."""
    return RenderInfo(
        path=path,
        backend=used,
        size=size,
        seconds=time.perf_counter() - t0,
        arrow_scale=overlays[0].arrow_scale,
        n_arrows=sum(o.n_arrows for o in overlays),
        n_streamlines=len(scene.lines),
        n_singularities=0 if scene.markers is None else len(scene.markers),
        clim=None if scene.colorbar is None else tuple(scene.colorbar["clim"]),
        fallback=fallback,
        extra={
            "panels": len(overlays),
            "arrow_spacing": overlays[0].spacing,
            "arrow_colors": [lay_.color for lay_ in scene.fields],
            "capped_arrows": sum(o.n_capped for o in overlays),
            "up": scene.views[0].up,
        },
    )


def _draw_panels(
    scene: Scene, overlays: list[PanelOverlay], pw: int, ph: int, backend: str
) -> tuple[str, str | None, list]:
    """Draw every panel with polyscope when it works (and is wanted), else matplotlib."""
    fallback = None
    if backend in ("auto", "polyscope-egl"):
        reason = polyscope_status()
        if reason is None:
            from .ps_backend import draw_polyscope

            try:
                images = [
                    draw_polyscope(scene, pw, ph, frame, v, o)
                    for frame, v, o in zip(scene.frames, scene.views, overlays, strict=True)
                ]
                return "polyscope-egl", None, images
            except MissingExtraError:
                raise
            except Exception as exc:  # polyscope's own errors: fall back (unless asked for it)
                if backend == "polyscope-egl":
                    raise
                reason = f"polyscope failed: {type(exc).__name__}: {exc}"
                _STATUS["polyscope"] = reason
        if backend == "polyscope-egl":
            raise FvfError(f"backend 'polyscope-egl' is not available: {reason}")
        if reason and importlib.util.find_spec("polyscope") and "disabled" not in reason:
            _warn_once(reason)
        fallback = reason
    from .mpl_backend import draw_matplotlib

    images = [
        draw_matplotlib(scene, pw, ph, frame, v.zoom, o)
        for frame, v, o in zip(scene.frames, scene.views, overlays, strict=True)
    ]
    return "matplotlib", fallback, images


@takes_mesh
def view(mesh: TriMesh, **kwargs: Any) -> None:
    """Open polyscope's interactive window on a mesh (the same options as :func:`render`).

    The window is ``size`` (default 1024 x 768) pixels; ``path``, ``title`` and
    ``backend`` are ignored. Structures registered in polyscope by the caller stay.

    Raises
    ------
    NoDisplayError
        No display (no ``DISPLAY`` / ``WAYLAND_DISPLAY`` on Linux); use :func:`render`.
    MissingExtraError
        polyscope is not installed.
    """
    from ._deps import require
    from .ps_backend import _STATE, place_camera, populate
    from .scene import build_scene

    if sys.platform.startswith("linux") and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        raise NoDisplayError(
            "no display to open a window on (DISPLAY and WAYLAND_DISPLAY are unset); "
            "write a picture instead: fvf.viz.render(mesh, 'out.png', ...) or `fvf render`"
        )
    ps = require("polyscope", "the interactive viewer")
    if _STATE.get("mode") == "headless":
        raise FvfError(
            "polyscope already runs headless in this process; view() needs a fresh process"
        )
    kwargs.pop("path", None)
    style = kwargs.pop("style", None)
    size = kwargs.get("size") or (style.size if isinstance(style, RenderStyle) else (1024, 768))
    scene = build_scene(mesh, style=style, **kwargs)
    try:
        if _STATE.get("mode") != "window":
            ps.init()
            _STATE["mode"] = "window"
        populate(ps, scene)
        place_camera(ps, scene, *size)
        ps.show()
    except RuntimeError as exc:
        raise NoDisplayError(f"polyscope could not open a window: {exc}") from exc
