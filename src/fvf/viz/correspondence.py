"""Pictures of correspondences: transferred colours, error maps, cumulative error curves.

- :func:`render_correspondence`: mesh 1 coloured by a function, and mesh 2 coloured by the
  same function pulled back through the vertex map (f ∘ π, i.e. ``f[p2p_21]``), side by
  side: a correct map shows the same pattern on the same body parts.
- :func:`render_error_map`: per-vertex geodesic errors on mesh 2.
- :func:`plot_error_curves`: the fraction of vertices below each error threshold
  (:func:`fvf.spectral.evaluation.cumulative_error_curve`), one curve per method.
"""

from __future__ import annotations

import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from ..io.atomic import atomic_path
from ..io.picturefile import picture_format
from ..mesh.convert import MeshLike, as_mesh, takes_mesh
from ..mesh.trimesh import TriMesh
from ._deps import require
from .backends import RenderInfo, render

__all__ = [
    "coordinate_stripes",
    "render_correspondence",
    "render_error_map",
    "plot_error_curves",
    "save_image",
]


@takes_mesh
def coordinate_stripes(mesh: TriMesh, periods: float = 3.0) -> np.ndarray:
    """A striped function of the position, float64 (n,) in [−1, 1]: sin(2π periods s),
    s the coordinate along the mesh's longest bounding-box side, plus a slower wave
    across it, so that left and right, front and back look different."""
    X = mesh.vertices - mesh.vertices.min(axis=0)
    ext = X.max(axis=0)
    order = np.argsort(ext)[::-1]
    s = X[:, order[0]] / max(ext[order[0]], 1e-300)
    t = X[:, order[1]] / max(ext[order[1]], 1e-300)
    u = X[:, order[2]] / max(ext[order[2]], 1e-300)
    return 0.7 * np.sin(2 * np.pi * periods * s) + 0.3 * np.cos(np.pi * (t + 2 * u))


def render_correspondence(
    mesh_1: MeshLike,
    mesh_2: MeshLike,
    p2p_21: npt.ArrayLike,
    path: str | Path,
    *,
    function: npt.ArrayLike | None = None,
    cmap: str = "twilight",
    size: tuple[int, int] = (1200, 520),
    view: Any = None,
    title: str | None = None,
    backend: str = "auto",
    names: tuple[str, str] = ("mesh 1", "mesh 2"),
    up: str | None = None,
    dpi: int = 100,
) -> Path:
    """Mesh 1 coloured by ``function`` beside mesh 2 coloured by ``function[p2p_21]``.

    One colorbar (on the right) serves both panels: they show one quantity.

    Parameters
    ----------
    mesh_1, mesh_2 : TriMesh or any :data:`fvf.MeshLike`
    p2p_21 : array_like of int (n_2,)
        Vertex of mesh 1 for each vertex of mesh 2.
    path : str or Path
        Output picture (written atomically): PNG, or PDF / SVG by the suffix (the
        picture as an image in the page).
    function : array_like (n_1,), optional
        Default :func:`coordinate_stripes` of mesh 1.
    cmap, size, view, title, backend, up, dpi
        As for :func:`fvf.viz.render`; ``size`` is the whole picture.
    names : (str, str)
        The panels' titles (e.g. the file names; default "mesh 1", "mesh 2").

    Returns
    -------
    pathlib.Path
    """
    from .compose import COLORBAR_WIDTH

    mesh_1, mesh_2 = as_mesh(mesh_1), as_mesh(mesh_2)
    image = require("PIL.Image", "render_correspondence")
    f1 = coordinate_stripes(mesh_1) if function is None else np.asarray(function, dtype=float)
    f2 = f1[np.asarray(p2p_21, dtype=np.int64)]
    clim = (float(np.nanmin(f1)), float(np.nanmax(f1)))
    left = max(64, (size[0] - COLORBAR_WIDTH) // 2)
    widths = (left, max(64, size[0] - left))  # the second panel holds the colorbar
    with tempfile.TemporaryDirectory() as tmp:
        parts = []
        for i, (mesh, f, name) in enumerate(((mesh_1, f1, names[0]), (mesh_2, f2, names[1]))):
            p = Path(tmp) / f"{i}.png"
            render(
                mesh,
                p,
                function=f,
                cmap=cmap,
                clim=clim,
                size=(widths[i], size[1]),
                view=view,
                up=up,
                title=name if title is None else f"{title}: {name}",
                backend=backend,
                colorbar=i == 1,
                colorbar_label="position stripes" if function is None else "function",
            )
            parts.append(image.open(p).convert("RGB"))
        canvas = image.new(
            "RGB", (sum(q.width for q in parts), max(q.height for q in parts)), "white"
        )
        canvas.paste(parts[0], (0, 0))
        canvas.paste(parts[1], (parts[0].width, 0))
        save_image(canvas, path, dpi)
    return Path(path)


def save_image(picture: Any, path: str | Path, dpi: int = 100) -> None:
    """Write a PIL image atomically: PNG (with its dpi), or a PDF / SVG page of
    ``size / dpi`` inches holding it, by the suffix of ``path``."""
    fmt = picture_format(path)
    with atomic_path(path) as out:
        if fmt == "png":
            picture.save(out, format="PNG", dpi=(dpi, dpi))
            return
        require("matplotlib")
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(figsize=(picture.width / dpi, picture.height / dpi), dpi=dpi)
        FigureCanvasAgg(fig)
        fig.figimage(np.asarray(picture), xo=0, yo=0, origin="upper")
        extra: dict[str, Any] = {"metadata": {"Date": None}} if fmt == "svg" else {}
        fig.savefig(str(out), format=fmt, dpi=dpi, **extra)


def render_error_map(
    mesh_2: MeshLike,
    errors: npt.ArrayLike,
    path: str | Path,
    *,
    clim: tuple[float, float] | None = (0.0, 0.1),
    title: str | None = "geodesic error / sqrt(area)",
    **kwargs: Any,
) -> RenderInfo:
    """Per-vertex errors (n_2,) on mesh 2 (``magma``, clipped to ``clim``); returns the
    :class:`fvf.viz.RenderInfo` of :func:`fvf.viz.render`.

    NaN errors (vertices without a ground truth) are drawn in light grey, named "no ground
    truth" in the legend, never as zero error.
    """
    mesh_2 = as_mesh(mesh_2)
    e = np.asarray(errors, dtype=float)
    if clim is not None:
        e = np.where(np.isnan(e), np.nan, np.clip(e, *clim))
    kwargs.setdefault("nan_label", "no ground truth")
    return render(
        mesh_2,
        path,
        function=e,
        cmap="magma",
        clim=clim,
        title=title,
        colorbar_label="error",
        **kwargs,
    )


def plot_error_curves(
    errors: Mapping[str, npt.ArrayLike],
    path: str | Path,
    *,
    max_error: float = 0.1,
    title: str | None = None,
    size: tuple[int, int] = (605, 440),
    dpi: int = 110,
) -> Path:
    """Cumulative error curves: for each label, the fraction of vertices with normalized
    geodesic error at most each threshold in [0, max_error]. Written atomically: PNG, or
    PDF / SVG (vector) by the suffix of ``path``; ``size`` in pixels at ``dpi``. NaN errors
    (no ground truth) are left out."""
    from ..spectral.evaluation import cumulative_error_curve

    fmt = picture_format(path)
    require("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(size[0] / dpi, size[1] / dpi), dpi=dpi)
    thresholds = np.linspace(0.0, max_error, 201)
    for label, values in errors.items():
        e = np.asarray(values, dtype=float)
        e = e[~np.isnan(e)]
        t, frac = cumulative_error_curve(e, thresholds)
        ax.plot(t, frac, label=f"{label} (mean {np.mean(e):.4f})")
    ax.set_xlabel("geodesic error / sqrt(area)")
    ax.set_ylabel("fraction of vertices")
    ax.set_xlim(0, max_error)
    ax.set_ylim(0, 1.01)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    with atomic_path(path) as out:
        fig.savefig(out, format=fmt, dpi=dpi)
    plt.close(fig)
    return Path(path)
