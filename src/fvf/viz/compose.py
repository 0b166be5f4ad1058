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
from ._deps import require
from .colors import index_color, index_label
from .scene import Scene

__all__ = ["Layout", "compose", "layout"]

TITLE_HEIGHT = 34
COLORBAR_WIDTH = 100
LEGEND_WIDTH = 124
PANEL_GAP = 6


class Layout:
    """Pixel sizes of a picture's parts (see :func:`layout`)."""

    def __init__(self, width, height, title, colorbar, legend, panels):
        self.width, self.height = width, height
        self.title = TITLE_HEIGHT if title else 0
        self.side = LEGEND_WIDTH if legend else (COLORBAR_WIDTH if colorbar else 0)
        self.panels = max(1, int(panels))
        self.scene_width = width - self.side
        self.scene_height = height - self.title
        self.gap = PANEL_GAP if self.panels > 1 else 0
        self.panel_width = (self.scene_width - self.gap * (self.panels - 1)) // self.panels
        self.panel_height = self.scene_height


def has_legend(scene: Scene) -> bool:
    """Whether the picture gets a legend: singularities, or labelled fields."""
    return scene.markers is not None or any(f.label for f in scene.fields)


def layout(
    width: int,
    height: int,
    title: str | None,
    colorbar: bool,
    legend: bool = False,
    panels: int = 1,
) -> Layout:
    """Sizes of the title band, the panels and the side column, in pixels."""
    return Layout(width, height, title, colorbar, legend, panels)


def _legend_handles(scene: Scene) -> list:
    from matplotlib.artist import Artist
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles: list[Artist] = []
    for f in scene.fields:
        if f.label:
            handles.append(Patch(facecolor=f.color, edgecolor="black", label=f.label))
    if scene.markers is not None:
        assert scene.marker_indices is not None  # set together with the markers
        kinds, counts = np.unique(np.round(scene.marker_indices, 9), return_counts=True)
        if kinds.size == 0:
            handles.append(Line2D([], [], linestyle="none", label="no singularities"))
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
                    label=f"index {index_label(k)} ({c})",
                )
            )
    return handles


def _title(fig: Any, canvas: Any, lay: Layout, title: str) -> None:
    """The title, centred over the panels, or over the picture when wider than them, in a
    smaller font when wider than the picture."""
    width, height = lay.width, lay.height
    fontsize = 10.0 if width < 600 else 12.0
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


def _colorbar(fig: Any, lay: Layout, colorbar: dict, legend: bool) -> None:
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
    bar.ax.tick_params(labelsize=7 if small else 8)
    if isinstance(bar.formatter, ScalarFormatter):  # the default of a linear norm
        bar.formatter.set_powerlimits((-3, 4))
    bar.set_label(colorbar.get("label") or "value", fontsize=8 if small else 9)


def _legend(fig: Any, lay: Layout, scene: Scene) -> None:
    """The legend in the side column: field labels and singularity indices."""
    small = lay.width < 600
    top = 0.46 if scene.colorbar is not None else 0.95
    sh = lay.scene_height / lay.height
    lax = fig.add_axes((lay.scene_width / lay.width, 0.02, lay.side / lay.width, top * sh))
    lax.set_axis_off()
    lax.set_zorder(3)
    lax.legend(
        handles=_legend_handles(scene),
        loc="upper left",
        fontsize=7 if small else 8,
        frameon=False,
        title="singularities" if scene.markers is not None else None,
        title_fontsize=7 if small else 8,
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
) -> None:
    """Write the panels with title, colorbar and legend as a PNG of the given size."""
    require("matplotlib")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    images = [panels] if isinstance(panels, np.ndarray) else list(panels)
    legend = has_legend(scene)
    lay = layout(width, height, title, scene.colorbar is not None, legend, len(images))
    fig = Figure(figsize=(width / 100.0, height / 100.0), dpi=100, facecolor="white")
    canvas = FigureCanvasAgg(fig)
    fig.figimage(_strip(images, lay), xo=0, yo=0, origin="upper", zorder=0)
    if title:
        _title(fig, canvas, lay, title)
    if scene.colorbar is not None:
        _colorbar(fig, lay, scene.colorbar, legend)
    if legend:
        _legend(fig, lay, scene)
    with atomic_path(path) as tmp:  # whole or not at all
        fig.savefig(
            str(tmp), format="png", dpi=100, facecolor="white", pil_kwargs={"compress_level": 3}
        )
