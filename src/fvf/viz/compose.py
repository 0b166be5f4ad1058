"""The picture around the rendered scene: title, colorbar and singularity legend."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._deps import require
from .scene import Scene, index_color, index_label

__all__ = ["layout", "compose"]

TITLE_HEIGHT = 34
COLORBAR_WIDTH = 96


def layout(width: int, height: int, title: str | None, colorbar: bool) -> tuple[int, int]:
    """Size (width, height) in pixels left for the 3-D scene."""
    return width - (COLORBAR_WIDTH if colorbar else 0), height - (TITLE_HEIGHT if title else 0)


def compose(
    image: np.ndarray, scene: Scene, path: str | Path, width: int, height: int, title: str | None
) -> None:
    """Write ``image`` (the scene) with title, colorbar and legend as a PNG of the given size."""
    require("matplotlib")
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    sw, sh = layout(width, height, title, scene.colorbar is not None)
    fig = Figure(figsize=(width / 100.0, height / 100.0), dpi=100, facecolor="white")
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.0, 0.0, sw / width, sh / height))
    ax.set_xlim(0, sw)
    ax.set_ylim(0, sh)
    # pixels copied as they are (no resampling): the scene fills the axes' rectangle
    fig.figimage(np.ascontiguousarray(image[:sh, :sw]), xo=0, yo=0, origin="upper", zorder=0)
    ax.set_axis_off()
    if title:
        fig.text(
            0.5,
            1.0 - 0.5 * TITLE_HEIGHT / height,
            title,
            ha="center",
            va="center",
            fontsize=12 if width >= 600 else 9,
        )
    if scene.colorbar is not None:
        cb = scene.colorbar
        cax = fig.add_axes(((sw + 14) / width, 0.12 * sh / height, 16 / width, 0.76 * sh / height))
        sm = ScalarMappable(Normalize(*cb["clim"]), matplotlib.colormaps[cb["cmap"]])
        bar = fig.colorbar(sm, cax=cax)
        bar.ax.tick_params(labelsize=8)
        if cb.get("label"):
            bar.set_label(cb["label"], fontsize=9)
    if scene.markers is not None and len(scene.markers):
        kinds, counts = np.unique(scene.marker_indices, return_counts=True)
        handles = [
            Line2D(
                [],
                [],
                marker="o",
                linestyle="none",
                markersize=8,
                markerfacecolor=index_color(k),
                markeredgecolor="black",
                label=f"index {index_label(k)} ({c})",
            )
            for k, c in zip(kinds, counts, strict=True)
        ]
        ax.legend(handles=handles, loc="lower left", fontsize=8, frameon=True)
        ax.set_zorder(2)  # above the scene image (a figure-level artist drawn after the axes)
    fig.savefig(str(path), dpi=100, facecolor="white", pil_kwargs={"compress_level": 3})
