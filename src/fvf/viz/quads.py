"""Pictures of parameterizations and quad meshes, drawn with :func:`fvf.viz.render`.

- :func:`render_quads`: a quad mesh shaded, its edges as a wireframe on top (thinner as
  the quads get denser on screen), and its irregular vertices marked and named by valence,
  in the colours of the cross-field index ``(4 − valence) / 4`` they come from (valence 3:
  +1/4 yellow, valence 5: −1/4 sky blue, :func:`fvf.viz.index_color`).
- :func:`render_checkerboard`: a triangle mesh textured by the checkerboard of a
  per-corner parameterization, uv (m, 3, 2): each triangle is subdivided on its own (so
  seams stay seams) and each small triangle coloured by the parity of ⌊u⌋ + ⌊v⌋ at its
  centre.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import FvfError
from ..mesh.convert import takes_mesh
from ..mesh.trimesh import TriMesh
from .backends import RenderInfo, render

__all__ = ["render_quads", "render_checkerboard", "quad_wireframe"]


def quad_wireframe(vertices: np.ndarray, quads: np.ndarray) -> list[np.ndarray]:
    """The unique edges of a quad mesh as 2-point polylines (list of (2, 3) arrays)."""
    e = np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2)
    e = np.unique(np.sort(e, axis=1), axis=0)
    return list(vertices[e])


def render_quads(
    vertices: npt.ArrayLike, quads: npt.ArrayLike, path: str | Path, **kwargs: Any
) -> RenderInfo:
    """Render a quad mesh: shading, wireframe, irregular vertices by valence.

    Parameters
    ----------
    vertices : array_like (k, 3) float
    quads : array_like (q, 4) int
    path : str or Path
        Output picture (PNG, PDF or SVG by the suffix).
    **kwargs
        Passed to :func:`fvf.viz.render` (``style`` or its options: ``view``, ``up``,
        ``size``, ``dpi``, ``title``, ``backend``).
    """
    V = np.asarray(vertices, dtype=np.float64)
    Q = np.asarray(quads, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] != 3 or Q.ndim != 2 or Q.shape[1] != 4:
        raise FvfError(f"need vertices (k, 3) and quads (q, 4); got {V.shape}, {Q.shape}")
    tris = np.concatenate([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]])
    mesh = TriMesh(V, tris)
    e = np.unique(np.sort(np.stack([Q, np.roll(Q, -1, axis=1)], 2).reshape(-1, 2), 1), axis=0)
    valence = np.bincount(e.ravel(), minlength=V.shape[0])
    irr = np.flatnonzero((valence != 4) & (valence > 0))
    sing = (V[irr], (4 - valence[irr]) / 4.0) if irr.size else None
    return render(
        mesh,
        path,
        streamlines=quad_wireframe(V, Q),
        singularities=sing,
        singularity_kind="valence",
        **kwargs,
    )


@takes_mesh
def render_checkerboard(
    mesh: TriMesh,
    uv: npt.ArrayLike,
    path: str | Path,
    subdivisions: int = 3,
    **kwargs: Any,
) -> RenderInfo:
    """Render the checkerboard of a parameterization uv (m, 3, 2) on the mesh.

    Parameters
    ----------
    mesh : TriMesh
    uv : array_like (m, 3, 2)
    path : str or Path
        Output picture (PNG, PDF or SVG by the suffix).
    subdivisions : int
        Each triangle is split into 4^subdivisions for the texture.
    **kwargs
        Passed to :func:`fvf.viz.render`.
    """
    T = np.asarray(uv, dtype=np.float64)
    if T.shape != (mesh.n_faces, 3, 2):
        raise FvfError(f"uv must have shape ({mesh.n_faces}, 3, 2); got {T.shape}")
    k = 2 ** int(subdivisions)
    i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
    keep = i + j <= k
    bary = np.stack([k - i[keep] - j[keep], i[keep], j[keep]], axis=1) / k  # (p, 3)
    index = -np.ones((k + 1, k + 1), dtype=np.int64)
    index[i[keep], j[keep]] = np.arange(keep.sum())
    tris: list[list[int]] = []
    for a in range(k):  # the k² sub-triangles of the reference triangle
        for b in range(k - a):
            tris.append([index[a, b], index[a + 1, b], index[a, b + 1]])
            if a + b + 1 < k:
                tris.append([index[a + 1, b], index[a + 1, b + 1], index[a, b + 1]])
    small = np.array(tris)
    X = mesh.vertices[mesh.faces]  # (m, 3, 3)
    P = np.einsum("pc,mcd->mpd", bary, X)  # (m, p, 3)
    W = np.einsum("pc,mcd->mpd", bary, T)  # (m, p, 2)
    p = bary.shape[0]
    faces = (small[None] + p * np.arange(mesh.n_faces)[:, None, None]).reshape(-1, 3)
    centre = W.reshape(-1, 2)[faces].mean(axis=1)
    checker = (np.floor(centre).sum(axis=1) % 2).astype(float)
    soup = TriMesh(P.reshape(-1, 3), faces)
    return render(soup, path, texture=0.35 + 0.5 * checker, **kwargs)
