"""The picture around the rendered panels: title, colorbar and legend.

Layout: a title band on top (when there is a title), the panels side by side below it,
and a side column on the right holding the colorbar (labelled, with extension triangles
when the colour range clips values) and the legend (singularity indices with their
colours and counts, and the labels of the fields drawn).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..io.atomic import atomic_path
from ..io.picturefile import PICTURE_FORMATS, picture_format
from ._deps import require
from .colors import index_color, index_label
from .scene import NO_DATA_COLOR, Scene

__all__ = ["FORMATS", "Layout", "compose", "has_colorbar", "layout", "marker_label"]

#: The picture formats, by the output's suffix (:mod:`fvf.io.picturefile`).
FORMATS = PICTURE_FORMATS

TITLE_HEIGHT = 34
COLORBAR_WIDTH = 100
LEGEND_WIDTH = 124
PANEL_GAP = 6


class Layout:
    """Pixel sizes of a picture's parts (see :func:`layout`)."""

    def __init__(self, width, height, title, colorbar, legend, panels):
        self.width, self.height = width, height
        self.title = TITLE_HEIGHT if title else 0
        if legend:  # True: the default width; a number: the pixels the legend needs
            self.side = LEGEND_WIDTH if legend is True else max(LEGEND_WIDTH, int(legend))
        else:
            self.side = COLORBAR_WIDTH if colorbar else 0
        self.panels = max(1, int(panels))
        self.scene_width = width - self.side
        self.scene_height = height - self.title
        self.gap = PANEL_GAP if self.panels > 1 else 0
        self.panel_width = (self.scene_width - self.gap * (self.panels - 1)) // self.panels
        self.panel_height = self.scene_height


def has_legend(scene: Scene) -> bool:
    """Whether the picture gets a legend: singularities, labelled fields, or NaN values
    of the function ("no data")."""
    return (
        scene.markers is not None or any(f.label for f in scene.fields) or scene.no_data is not None
    )


def legend_width(scene: Scene, width: int) -> int:
    """Pixels the side column needs for the legend of ``scene`` in a picture ``width``
    wide (0 without a legend): its longest line measured in the legend's font, at least
    :data:`LEGEND_WIDTH`, at most a third of the picture, so no count is cut off."""
    if not has_legend(scene):
        return 0
    from matplotlib.textpath import TextPath

    fontsize = 7.0 if width < 600 else 8.0  # as _legend
    lines = [str(h.get_label()) for h in _legend_handles(scene)]
    text = max(TextPath((0, 0), s, size=fontsize).get_extents().width for s in lines)
    # the marker and the pads (handle 2 em, pad 0.3 em, borders 0.2 + 0.4 em) and a margin
    need = (text + 2.9 * fontsize) * 100.0 / 72.0 + 8.0
    return int(min(max(LEGEND_WIDTH, np.ceil(need)), width // 3))


def has_colorbar(scene: Scene) -> bool:
    """Whether the picture gets a colorbar: a function, unless it is switched off."""
    return scene.colorbar is not None and scene.show_colorbar


def marker_label(index: float, kind: str = "index") -> str:
    """Legend text of a singularity: ``index +1/4`` of a field, or ``valence 3`` of a quad
    mesh vertex (whose cross-field index is ``(4 − valence) / 4``)."""
    if kind == "valence":
        return f"valence {int(round(4 - 4 * float(index)))}"
    return f"index {index_label(index)}"


def layout(
    width: int,
    height: int,
    title: str | None,
    colorbar: bool,
    legend: bool | int = False,
    panels: int = 1,
) -> Layout:
    """Sizes of the title band, the panels and the side column, in pixels (``legend``:
    True for the default legend width, or the pixels it needs, :func:`legend_width`)."""
    return Layout(width, height, title, colorbar, legend, panels)


def _legend_handles(scene: Scene) -> list:
    from matplotlib.artist import Artist
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles: list[Artist] = []
    if scene.no_data is not None:
        handles.append(Patch(facecolor=NO_DATA_COLOR, edgecolor="0.4", label=scene.no_data))
    for f in scene.fields:
        if f.label:
            handles.append(Patch(facecolor=f.color, edgecolor="black", label=f.label))
    if scene.markers is not None:
        assert scene.marker_indices is not None  # set together with the markers
        kinds, counts = np.unique(np.round(scene.marker_indices, 9), return_counts=True)
        if kinds.size == 0:
            handles.append(Line2D([], [], linestyle="none", label="no singularities"))
        if scene.marker_kind == "valence":  # the field's colours: valence 3 is index +1/4
            kinds, counts = kinds[::-1], counts[::-1]
        for k, c in zip(kinds, counts, strict=True):
            handles.append(
                Line2D(
                    [],
                    [],
                    marker="o",
                    linestyle="none",
                    markersize=9,
                    markerfacecolor=index_color(k),
                    markeredgecolor="black",
                    label=f"{marker_label(k, scene.marker_kind)} ({c})",
                )
            )
    return handles


def _title(fig: Any, canvas: Any, lay: Layout, title: str, pt: float = 1.0) -> None:
    """The title, centred over the panels, or over the picture when wider than them, in a
    smaller font when wider than the picture (``pt``: points per point at 100 dpi)."""
    width, height = lay.width, lay.height
    fontsize = (10.0 if lay.scene_width < 600 else 12.0) * pt
    text = fig.text(
        0.5 * lay.scene_width / width,
        1.0 - 0.5 * TITLE_HEIGHT / height,
        title,
        ha="center",
        va="center",
        fontsize=fontsize,
    )
    renderer = canvas.get_renderer()
    wide = text.get_window_extent(renderer).width
    if wide > lay.scene_width - 8:  # wider than the panels: centred on the picture
        text.set_x(0.5)
    for _ in range(4):  # wider than the picture: smaller fonts (glyphs scale unevenly)
        if wide <= width - 8:
            break
        fontsize *= 0.97 * (width - 8) / wide
        text.set_fontsize(fontsize)
        wide = text.get_window_extent(renderer).width


def _colorbar(fig: Any, lay: Layout, colorbar: dict, legend: bool, pt: float = 1.0) -> None:
    """The labelled colorbar in the side column (its upper half above a legend)."""
    import matplotlib
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.ticker import ScalarFormatter

    width, small = lay.width, lay.width < 600
    x0, sh = (lay.scene_width + 10) / width, lay.scene_height / lay.height
    bottom, top = (0.50, 0.92) if legend else (0.10, 0.90)
    cax = fig.add_axes((x0 + 4 / width, bottom * sh, 14 / width, (top - bottom) * sh))
    sm = ScalarMappable(Normalize(*colorbar["clim"]), matplotlib.colormaps[colorbar["cmap"]])
    bar = fig.colorbar(sm, cax=cax, extend=colorbar.get("extend", "neither"))
    bar.ax.tick_params(
        labelsize=(7 if small else 8) * pt, length=3.5 * pt, width=0.8 * pt, pad=3.5 * pt
    )
    bar.outline.set_linewidth(0.8 * pt)
    if isinstance(bar.formatter, ScalarFormatter):  # the default of a linear norm
        bar.formatter.set_powerlimits((-3, 4))
        bar.formatter.set_useMathText(True)  # "×10^−5" above the bar, not "1e−5"
    bar.set_label(colorbar.get("label") or "value", fontsize=(8 if small else 9) * pt)


def _legend(fig: Any, lay: Layout, scene: Scene, pt: float = 1.0) -> None:
    """The legend in the side column: field labels, singularity indices (or valences), the
    colour of missing values."""
    small = lay.width < 600
    top = 0.46 if has_colorbar(scene) else 0.95
    title = None
    if scene.markers is not None:
        title = "irregular vertices" if scene.marker_kind == "valence" else "singularities"
    sh = lay.scene_height / lay.height
    lax = fig.add_axes((lay.scene_width / lay.width, 0.02, lay.side / lay.width, top * sh))
    lax.set_axis_off()
    lax.set_zorder(3)
    handles = _legend_handles(scene)
    for h in handles:
        if hasattr(h, "set_markersize"):
            h.set_markersize(h.get_markersize() * pt)
            h.set_markeredgewidth(h.get_markeredgewidth() * pt)
        else:
            h.set_linewidth(h.get_linewidth() * pt)
    lax.legend(
        handles=handles,
        loc="upper left",
        fontsize=(7 if small else 8) * pt,
        frameon=False,
        title=title,
        title_fontsize=(7 if small else 8) * pt,
        borderaxespad=0.2,
        handletextpad=0.3,
        alignment="left",
    )


def _strip(images: list[np.ndarray], lay: Layout) -> np.ndarray:
    """The panels side by side on white, a thin rule between them, uint8 (h, w, 3)."""
    strip = np.full((lay.scene_height, lay.scene_width, 3), 255, dtype=np.uint8)
    for i, im in enumerate(images):
        x = i * (lay.panel_width + lay.gap)
        h, w = min(im.shape[0], lay.scene_height), min(im.shape[1], lay.panel_width)
        strip[:h, x : x + w] = im[:h, :w, :3]
        if i:  # a thin rule between panels
            strip[int(0.1 * h) : int(0.9 * h), x - lay.gap // 2] = 215
    return strip


def compose(
    panels: list[np.ndarray] | np.ndarray,
    scene: Scene,
    path: str | Path,
    width: int,
    height: int,
    title: str | None,
    dpi: int = 100,
) -> None:
    """Write the panels with title, colorbar and legend, ``width`` x ``height`` pixels.

    The format follows the suffix of ``path`` (:data:`FORMATS`; any other suffix is
    :class:`fvf.OutputError`, checked before the picture is drawn). ``dpi``
    is recorded in a PNG and sets the page of a PDF or SVG to ``width / dpi`` inches; the
    fonts scale with it, so the picture looks the same at every dpi.
    """
    fmt = picture_format(path)
    require("matplotlib")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    images = [panels] if isinstance(panels, np.ndarray) else list(panels)
    legend = has_legend(scene)
    lay = layout(width, height, title, has_colorbar(scene), legend_width(scene, width), len(images))
    pt = 100.0 / dpi  # font points: sized for 100 dpi
    fig = Figure(figsize=(width / dpi, height / dpi), dpi=dpi, facecolor="white")
    canvas = FigureCanvasAgg(fig)
    # under everything: a colorbar's common factor ("×10^−5") reaches left over the panels
    fig.figimage(_strip(images, lay), xo=0, yo=0, origin="upper", zorder=-1)
    if title:
        _title(fig, canvas, lay, title, pt)
    if has_colorbar(scene):
        assert scene.colorbar is not None
        _colorbar(fig, lay, scene.colorbar, legend, pt)
    if legend:
        _legend(fig, lay, scene, pt)
    extra: dict[str, Any] = {"pil_kwargs": {"compress_level": 3}} if fmt == "png" else {}
    if fmt == "svg":
        extra["metadata"] = {"Date": None}  # the same picture gives the same file
    with atomic_path(path) as tmp:  # whole or not at all
        fig.savefig(str(tmp), format=fmt, dpi=dpi, facecolor="white", **extra)
