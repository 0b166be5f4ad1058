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
from numbers import Integral, Real
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from ..errors import FvfError, ParameterError
from ..mesh.convert import takes_mesh
from ..mesh.trimesh import TriMesh
from ._deps import INSTALL_HINT, MissingExtraError, NoDisplayError, RenderBackendWarning

if TYPE_CHECKING:
    from .overlay import PanelOverlay
    from .scene import Scene

__all__ = [
    "BACKENDS",
    "MAX_SIZE",
    "RenderInfo",
    "available_backends",
    "check_render_options",
    "polyscope_status",
    "render",
    "view",
]

#: Every backend, best first.
BACKENDS = ("polyscope-egl", "matplotlib")

#: Largest picture side in pixels (a 8192 x 8192 RGBA image is 256 MiB; larger ones
#: exhaust the memory or the OpenGL limits of the renderers).
MAX_SIZE = 8192

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
    path : Path
        The PNG written.
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

    path: Path
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


@takes_mesh
def render(
    mesh: TriMesh,
    path: str | Path,
    *,
    function: npt.ArrayLike | None = None,
    field: Any = None,
    singularities: tuple | None = None,
    streamlines: list | None = None,
    texture: Any = None,
    arrow_scale: float | None = None,
    cmap: str = "viridis",
    clim: tuple[float, float] | str | None = None,
    view: Any = None,
    size: tuple[int, int] = (800, 600),
    title: str | None = None,
    backend: str = "auto",
    max_arrows: int | None = None,
    colorbar_label: str | None = None,
    n: int = 1,
    arrow_spacing: float | None = None,
    field_labels: list | tuple | None = None,
    arrow_color: tuple | None = None,
) -> RenderInfo:
    """Render a mesh with a function, fields, singularities, streamlines or a texture.

    Parameters
    ----------
    mesh : TriMesh
    path : str or Path
        Output PNG.
    function : array_like (n,) or (m,), optional
        Vertex or face scalars, drawn with ``cmap`` and a labelled colorbar.
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
    arrow_scale : float, optional
        Absolute arrow scale: an arrow is ``arrow_scale · |v_t|`` long in mesh units
        (pass the same value to compare magnitudes across pictures). Default: the robust
        longest arrow is 0.8 of the arrow spacing.
    cmap : str
        A matplotlib colormap name.
    clim : (float, float) or {"robust", "symmetric", "full"}, optional
        Colormap limits. Default ``"robust"``: the area-weighted 1st and 99th percentiles,
        moved back to the min / max when nothing lies far beyond them
        (:func:`fvf.viz.colors.robust_limits`); ``"symmetric"``: ``±`` the robust maximum
        of ``|f|``; ``"full"``: min and max. Clipped values show as triangles on the
        colorbar.
    view : View, tuple, dict, or a list of them, optional
        Camera (:class:`fvf.viz.View`; default a three-quarter view with the up axis
        detected, :func:`fvf.viz.camera.detect_up_axis`). A list draws one panel per view
        side by side, e.g. :func:`fvf.viz.two_sides` for both halves of a closed surface.
    size : (int, int)
        (width, height) of the PNG in pixels (all panels together), each in [64,
        :data:`MAX_SIZE`] (height from 48).
    title : str, optional
        Drawn above the picture.
    backend : {"auto", "polyscope-egl", "matplotlib"}
        ``"auto"``: the first of :func:`available_backends`.
    max_arrows : int, optional
        At most about this many arrows per panel (>= 1; the spacing grows to fit).
    colorbar_label : str, optional
        Label of the colorbar (default "value").
    n : int
        Directions per face of ``field``: 1 draws arrows; N ≥ 2 draws the N directions
        (the representative turned by 2πk/N about the face normal,
        :func:`fvf.viz.arrows.direction_set`) as N strokes from the centroid, each half an
        arrow long.
    arrow_spacing : float, optional
        Pixels between arrows (default :func:`fvf.viz.overlay.default_spacing`: 1/22 of
        the panel's smaller side, 14 to 40 px; 1.5 times that with several fields, whose
        arrows interleave). Glyph sizes follow it.
    field_labels : list of str, optional
        Names of the fields in the legend.
    arrow_color : (r, g, b), optional
        Colour of the first field's arrows instead of the automatic contrasting one.

    Returns
    -------
    RenderInfo
        ``n_arrows`` counts the glyphs' faces over all panels; ``extra["panels"]`` the
        number of panels, ``extra["arrow_spacing"]`` the spacing in pixels,
        ``extra["arrow_colors"]`` the fields' colours, ``extra["capped_arrows"]`` the
        arrows drawn shorter than their length (longer than 1.3 spacings).

    Raises
    ------
    MissingExtraError
        matplotlib (or polyscope for ``backend="polyscope-egl"``) is not installed.
    ParameterError
        A bad option: size out of range, non-finite or empty ``clim``, ``max_arrows`` < 1,
        a non-positive or non-finite ``arrow_scale``, an unknown backend.
    FvfError
        Bad inputs (shapes, unknown colormap), or the requested polyscope backend cannot
        start.
    OutputWriteError
        The PNG could not be written (a file already at ``path`` is unchanged).
    """
    from .compose import compose, has_legend, layout
    from .overlay import panel_overlay
    from .scene import build_scene

    t0 = time.perf_counter()
    if backend not in ("auto", *BACKENDS):
        raise ParameterError(
            f"backend must be 'auto' or one of {', '.join(BACKENDS)}; got {backend!r}"
        )
    width, height = check_render_options(size, clim, max_arrows, arrow_scale)
    scene = build_scene(
        mesh,
        function=function,
        field=field,
        singularities=singularities,
        streamlines=streamlines,
        texture=texture,
        arrow_scale=arrow_scale,
        max_arrows=max_arrows,
        cmap=cmap,
        clim=clim,
        view=view,
        colorbar_label=colorbar_label,
        n=n,
        arrow_spacing=arrow_spacing,
        field_labels=field_labels,
        arrow_color=arrow_color,
    )
    lay = layout(
        width, height, title, scene.colorbar is not None, has_legend(scene), len(scene.frames)
    )
    pw, ph = lay.panel_width, lay.panel_height
    if pw < 32 or ph < 32:
        raise FvfError(f"size {size!r} leaves panels of {pw} x {ph} pixels; make it larger")
    overlays: list[PanelOverlay] = []
    for frame, v in zip(scene.frames, scene.views, strict=True):
        first = overlays[0] if overlays else None
        spacing_mesh = None if first is None else first.spacing / first.pixel_scale
        overlays.append(panel_overlay(scene, frame, v.zoom, pw, ph, spacing_mesh))
    used, fallback, images = _draw_panels(scene, overlays, pw, ph, backend)
    path = Path(path)
    compose(images, scene, path, width, height, title)
    return _render_info(path, used, fallback, (width, height), t0, scene, overlays)


def _render_info(
    path: Path,
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


def check_render_options(
    size: Any, clim: Any, max_arrows: Any, arrow_scale: Any
) -> tuple[int, int]:
    """Check :func:`render`'s numeric options; returns (width, height).

    Raises
    ------
    ParameterError
        Naming the option, its value and the allowed range.
    """
    try:
        width, height = size
    except (TypeError, ValueError):
        raise ParameterError(f"size must be (width, height) in pixels; got {size!r}") from None
    for name, value, low in (("width", width, 64), ("height", height, 48)):
        if not (isinstance(value, Integral) and low <= int(value) <= MAX_SIZE):
            raise ParameterError(
                f"size: the {name} must be an integer in [{low}, {MAX_SIZE}] pixels; got {value!r}"
            )
    if isinstance(clim, str):
        if clim not in ("robust", "symmetric", "full"):
            raise ParameterError(
                f"clim must be 'robust', 'symmetric', 'full' or (low, high); got {clim!r}"
            )
    elif clim is not None:
        try:
            lo, hi = (float(c) for c in clim)
        except (TypeError, ValueError):
            raise ParameterError(f"clim must be two numbers (low, high); got {clim!r}") from None
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise ParameterError(f"clim must be two finite numbers with low < high; got {clim!r}")
    if max_arrows is not None and not (isinstance(max_arrows, Integral) and int(max_arrows) >= 1):
        raise ParameterError(
            f"max_arrows must be a positive integer (or None: no cap); got {max_arrows!r}"
        )
    if arrow_scale is not None and not (
        isinstance(arrow_scale, Real) and 0 < float(arrow_scale) < np.inf
    ):
        raise ParameterError(f"arrow_scale must be a positive finite number; got {arrow_scale!r}")
    return int(width), int(height)


@takes_mesh
def view(mesh: TriMesh, **kwargs: Any) -> None:
    """Open polyscope's interactive window on a mesh (the same options as :func:`render`).

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
    kwargs.pop("backend", None)
    size = kwargs.pop("size", (1024, 768))
    kwargs.pop("title", None)
    scene = build_scene(mesh, **kwargs)
    try:
        if _STATE.get("mode") != "window":
            ps.init()
            _STATE["mode"] = "window"
        populate(ps, scene)
        place_camera(ps, scene, *size)
        ps.show()
    except RuntimeError as exc:
        raise NoDisplayError(f"polyscope could not open a window: {exc}") from exc
