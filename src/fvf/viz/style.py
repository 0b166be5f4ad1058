"""How a picture looks, apart from what it shows: :class:`RenderStyle`.

:func:`fvf.viz.render` takes the data to draw (mesh, function, fields, singularities,
streamlines, texture) as arguments and everything about their appearance (colours,
glyph sizes, camera, picture size, title, backend) as one frozen :class:`RenderStyle`,
so one style serves many pictures. The appearance keywords ``render`` always took
(``cmap=``, ``size=``, ``view=``, ...) still work: :func:`as_style` folds them into the
style given (or the default one) with :func:`dataclasses.replace`.

Every option is checked when the style is made, so a bad option fails before any work
(:func:`check_render_options`).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from numbers import Integral, Real
from typing import Any

import numpy as np

from ..errors import FvfError, ParameterError
from .camera import UP_AXES, as_views

__all__ = [
    "BACKENDS",
    "MAX_SIZE",
    "STYLE_OPTIONS",
    "RenderStyle",
    "as_style",
    "check_render_options",
]

#: Every backend, best first.
BACKENDS = ("polyscope-egl", "matplotlib")

#: Largest picture side in pixels (a 8192 x 8192 RGBA image is 256 MiB; larger ones
#: exhaust the memory or the OpenGL limits of the renderers).
MAX_SIZE = 8192


@dataclass(frozen=True)
class RenderStyle:
    """The appearance of a picture of :func:`fvf.viz.render`: everything but the data.

    Frozen: derive variants with :func:`dataclasses.replace` (or
    ``style.replace(...)``). Every option is checked when the style is made and raises
    :class:`~fvf.ParameterError` (:class:`~fvf.FvfError` for a bad ``view``).

    Attributes
    ----------
    cmap : str
        A matplotlib colormap name for ``function``.
    clim : (float, float) or {"robust", "symmetric", "full"}, optional
        Colormap limits. Default ``"robust"``: the area-weighted 1st and 99th
        percentiles, moved back to the min / max when nothing lies far beyond them
        (:func:`fvf.viz.colors.robust_limits`); ``"symmetric"``: ``±`` the robust maximum
        of ``|f|``; ``"full"``: min and max. Clipped values show as triangles on the
        colorbar.
    colorbar_label : str, optional
        Label of the colorbar (default "value").
    arrow_color : (r, g, b), optional
        Colour of the first field's arrows instead of the automatic contrasting one.
    arrow_scale : float, optional
        Absolute arrow scale: an arrow is ``arrow_scale · |v_t|`` long in mesh units
        (pass the same value to compare magnitudes across pictures). Default: the robust
        longest arrow is 0.8 of the arrow spacing.
    arrow_spacing : float, optional
        Pixels between arrows, at least 2 (default
        :func:`fvf.viz.overlay.default_spacing`: 1/22 of the panel's smaller side, 14 to
        40 px; 1.5 times that with several fields, whose arrows interleave). Glyph sizes
        follow it.
    max_arrows : int, optional
        At most about this many arrows per panel (>= 1; the spacing grows to fit).
    view : View, tuple, dict, or a list of them, optional
        Camera (:class:`fvf.viz.View`; default a three-quarter view with the up axis
        detected, :func:`fvf.viz.camera.detect_up_axis`). A list draws one panel per view
        side by side, e.g. :func:`fvf.viz.two_sides` for both halves of a closed surface.
    up : {"x", "y", "z", "-x", "-y", "-z", "auto"}, optional
        The mesh axis that points up in the picture, for every view whose own ``up`` is
        ``"auto"`` (a view's explicit ``up`` wins). Default None (or ``"auto"``): detected
        per mesh (:func:`fvf.viz.camera.detect_up_axis`).
    size : (int, int)
        (width, height) of the picture in pixels (all panels together), width in [64,
        :data:`MAX_SIZE`], height in [48, :data:`MAX_SIZE`].
    dpi : int
        Dots per inch, in [10, 2400] (default 100): recorded in a PNG, and the page size
        of a PDF or SVG (``size / dpi`` inches). Text keeps its size relative to the
        picture whatever the dpi.
    colorbar : bool
        Draw the colorbar of ``function`` (default True; side-by-side pictures of one
        quantity draw it once).
    nan_label : str
        Legend name of the vertices or faces whose ``function`` value is NaN, drawn in
        :data:`fvf.viz.scene.NO_DATA_COLOR` (default "no data"; the error map of a
        correspondence says "no ground truth").
    title : str, optional
        Drawn above the picture.
    backend : {"auto", "polyscope-egl", "matplotlib"}
        ``"auto"``: the first of :func:`fvf.viz.available_backends`.
    """

    cmap: str = "viridis"
    clim: tuple[float, float] | str | None = None
    colorbar_label: str | None = None
    arrow_color: tuple[float, float, float] | None = None
    arrow_scale: float | None = None
    arrow_spacing: float | None = None
    max_arrows: int | None = None
    view: Any = None
    up: str | None = None
    size: tuple[int, int] = (800, 600)
    title: str | None = None
    backend: str = "auto"
    dpi: int = 100
    colorbar: bool = True
    nan_label: str = "no data"

    def __post_init__(self) -> None:
        if self.backend not in ("auto", *BACKENDS):
            raise ParameterError(
                f"backend must be 'auto' or one of {', '.join(BACKENDS)}; got {self.backend!r}"
            )
        check_render_options(self.size, self.clim, self.max_arrows, self.arrow_scale)
        if self.arrow_spacing is not None and not (
            isinstance(self.arrow_spacing, Real) and 2 <= float(self.arrow_spacing) < np.inf
        ):
            raise ParameterError(
                f"arrow_spacing must be at least 2 pixels; got {self.arrow_spacing!r}"
            )
        if self.up == "auto":
            object.__setattr__(self, "up", None)
        if self.up is not None and self.up not in UP_AXES:
            raise ParameterError(
                f"up must be one of {', '.join(UP_AXES)} (or 'auto'); got {self.up!r}"
            )
        if not (isinstance(self.dpi, Integral) and 10 <= int(self.dpi) <= 2400):
            raise ParameterError(f"dpi must be an integer in [10, 2400]; got {self.dpi!r}")
        as_views(self.view)  # raises on a bad view

    @property
    def width(self) -> int:
        """The picture's width in pixels."""
        return int(self.size[0])

    @property
    def height(self) -> int:
        """The picture's height in pixels."""
        return int(self.size[1])

    def replace(self, **changes: Any) -> RenderStyle:
        """A copy with some options changed (:func:`dataclasses.replace`)."""
        return replace(self, **changes)


#: The names of :class:`RenderStyle`'s options.
STYLE_OPTIONS = tuple(f.name for f in fields(RenderStyle))


def as_style(
    style: RenderStyle | None, options: dict[str, Any], caller: str = "render"
) -> RenderStyle:
    """``style`` (default :class:`RenderStyle`) with the appearance keywords ``options``.

    Raises
    ------
    TypeError
        A keyword that is no option of :class:`RenderStyle` (as Python does for an
        unexpected keyword argument of ``caller``).
    FvfError
        ``style`` is not a :class:`RenderStyle`, or an option is invalid.
    """
    unknown = [k for k in options if k not in STYLE_OPTIONS]
    if unknown:
        raise TypeError(f"{caller}() got an unexpected keyword argument {unknown[0]!r}")
    if style is None:
        style = RenderStyle()
    elif not isinstance(style, RenderStyle):
        raise FvfError(f"style must be a fvf.viz.RenderStyle; got {type(style).__name__}")
    return replace(style, **options) if options else style


def check_render_options(
    size: Any, clim: Any, max_arrows: Any, arrow_scale: Any
) -> tuple[int, int]:
    """Check :func:`fvf.viz.render`'s numeric options; returns (width, height).

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
