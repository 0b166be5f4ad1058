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

import numpy.typing as npt

from ..errors import FvfError
from ..mesh.trimesh import TriMesh
from ._deps import INSTALL_HINT, MissingExtraError, NoDisplayError, RenderBackendWarning
from .camera import View

__all__ = ["BACKENDS", "RenderInfo", "available_backends", "polyscope_status", "render", "view"]

#: Every backend, best first.
BACKENDS = ("polyscope-egl", "matplotlib")

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
_STATUS: dict = {}


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
        What was drawn (arrows at most ``max_arrows``).
    clim : tuple of float or None
        Colormap limits of ``function``.
    fallback : str or None
        Why the preferred backend was not used, when ``backend="auto"`` fell back.
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


def render(
    mesh: TriMesh,
    path: str | Path,
    *,
    function: npt.ArrayLike | None = None,
    field: npt.ArrayLike | None = None,
    singularities: tuple | None = None,
    streamlines: list | None = None,
    texture: npt.ArrayLike | None = None,
    arrow_scale: float | None = None,
    cmap: str = "viridis",
    clim: tuple[float, float] | None = None,
    view: View | tuple | dict | None = None,
    size: tuple[int, int] = (800, 600),
    title: str | None = None,
    backend: str = "auto",
    max_arrows: int | None = 1500,
    colorbar_label: str | None = None,
    n: int = 1,
) -> RenderInfo:
    """Render a mesh with a function, a field, singularities, streamlines or a texture.

    Parameters
    ----------
    mesh : TriMesh
    path : str or Path
        Output PNG.
    function : array_like (n,) or (m,), optional
        Vertex or face scalars, drawn with ``cmap`` and a colorbar.
    field : array_like (m, 3), optional
        Per-face tangent vectors, drawn as arrows from the face centroids built in each
        face's own basis (:func:`fvf.viz.arrow_segments`), so they lie in the face planes.
    singularities : (ndarray (k, 3), ndarray (k,)), optional
        Positions and indices (e.g. :func:`fvf.singularity_positions` and
        :func:`fvf.singularities`), drawn as markers coloured by index
        (:func:`fvf.viz.scene.index_color`) with a legend.
    streamlines : list of ndarray (p_i, 3), optional
        Polylines on the surface (:func:`fvf.viz.tracing`).
    texture : array_like (n,) or (m,), optional
        A grey texture such as :func:`fvf.viz.lic_texture`, with limits at its 1st and
        99th percentiles; with ``function`` too, it darkens the colormap's colours.
    arrow_scale : float, optional
        Absolute arrow scale: an arrow is ``arrow_scale · |v_t|`` long in mesh units.
        Default :func:`fvf.viz.arrows.default_arrow_scale`: the longest arrow is one
        mean edge length.
    cmap : str
        A matplotlib colormap name.
    clim : (float, float), optional
        Colormap limits (default: the function's min and max).
    view : View or (azimuth, elevation[, up[, zoom]]) or dict, optional
        Camera (:class:`fvf.viz.View`; default a three-quarter view, y up).
    size : (int, int)
        (width, height) of the PNG in pixels.
    title : str, optional
        Drawn above the picture.
    backend : {"auto", "polyscope-egl", "matplotlib"}
        ``"auto"``: the first of :func:`available_backends`.
    max_arrows : int or None
        Draw arrows at about this many faces spread evenly over the surface
        (:func:`fvf.viz.arrows.spread_faces`); None draws one per face.
    n : int
        Symmetry order of ``field``: 1 draws arrows; N ≥ 2 draws the N directions of each
        chosen face as strokes from its centroid (``field`` holds one representative per
        face, :mod:`fvf.design.nfields`), half an arrow long, so a cross field shows
        crosses. Singularity markers are coloured by index, fractions included
        (±1/4 …), with a legend.
    colorbar_label : str, optional
        Label of the colorbar.

    Returns
    -------
    RenderInfo

    Raises
    ------
    MissingExtraError
        matplotlib (or polyscope for ``backend="polyscope-egl"``) is not installed.
    FvfError
        Bad inputs (shapes, unknown backend or colormap), or the requested polyscope
        backend cannot start.
    """
    from .compose import compose, layout
    from .scene import build_scene

    t0 = time.perf_counter()
    if backend not in ("auto", *BACKENDS):
        raise FvfError(f"backend must be 'auto' or one of {', '.join(BACKENDS)}; got {backend!r}")
    width, height = (int(s) for s in size)
    if width < 64 or height < 48:
        raise FvfError(f"size must be at least (64, 48) pixels; got {size!r}")
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
    )
    sw, sh = layout(width, height, title, scene.colorbar is not None)
    fallback = None
    image = None
    if backend in ("auto", "polyscope-egl"):
        reason = polyscope_status()
        if reason is None:
            from .ps_backend import draw_polyscope

            try:
                image = draw_polyscope(scene, sw, sh)
                used = "polyscope-egl"
            except MissingExtraError:
                raise
            except Exception as exc:  # polyscope's own errors: fall back (unless asked for it)
                if backend == "polyscope-egl":
                    raise
                reason = f"polyscope failed: {type(exc).__name__}: {exc}"
                _STATUS["polyscope"] = reason
        if image is None:
            if backend == "polyscope-egl":
                raise FvfError(f"backend 'polyscope-egl' is not available: {reason}")
            if importlib.util.find_spec("polyscope") is not None and "disabled" not in reason:
                _warn_once(reason)
            fallback = reason
    if image is None:
        from .mpl_backend import draw_matplotlib

        image = draw_matplotlib(scene, sw, sh)
        used = "matplotlib"
    path = Path(path)
    compose(image, scene, path, width, height, title)
    return RenderInfo(
        path=path,
        backend=used,
        size=(width, height),
        seconds=time.perf_counter() - t0,
        arrow_scale=scene.arrow_scale,
        n_arrows=0 if scene.arrows is None else len(scene.arrows),
        n_streamlines=len(scene.lines),
        n_singularities=0 if scene.markers is None else len(scene.markers),
        clim=None if scene.colorbar is None else tuple(scene.colorbar["clim"]),
        fallback=fallback,
    )


def view(mesh: TriMesh, **kwargs) -> None:
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
