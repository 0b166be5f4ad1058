"""Pictures of parameterizations and quad meshes, drawn with :func:`fvf.viz.render`.

- :func:`render_quads`: a quad mesh shaded, its edges as a wireframe on top (thinner as
  the quads get denser on screen), and its irregular vertices (valence other than 4
  inside, other than 3 on the boundary) marked and named by valence, in the colours of
  the cross-field index ``(4 − valence) / 4`` they come from (valence 3: +1/4 yellow,
  valence 5: −1/4 sky blue, :func:`fvf.viz.index_color`).
- :func:`render_checkerboard`: a triangle mesh textured by the checkerboard of a
  per-corner parameterization, uv (m, 3, 2): each triangle is subdivided on its own (so
  seams stay seams) and each small triangle coloured by the parity of ⌊u⌋ + ⌊v⌋ at its
  centre.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import DuplicateVertexWarning, FvfError
from ..mesh.convert import takes_mesh
from ..mesh.trimesh import TriMesh
from ..param.quality import quad_boundary_vertices, quad_edges
from .backends import RenderInfo, render

__all__ = ["render_quads", "render_checkerboard", "quad_wireframe"]


def quad_wireframe(vertices: np.ndarray, quads: np.ndarray) -> list[np.ndarray]:
    """The unique edges of a quad mesh as 2-point polylines (list of (2, 3) arrays)."""
    return list(vertices[quad_edges(quads)[0]])


def _shading_mesh(V: np.ndarray, Q: np.ndarray) -> TriMesh:
    """The quads as triangles for shading: each split along the diagonal whose smaller
    half has the larger area, triangles of zero area left out (a valid quad mesh may have
    a quad with three collinear corners), vertices no triangle uses dropped."""

    def areas(T: np.ndarray) -> np.ndarray:
        P = V[T]
        return np.linalg.norm(
            np.cross(P[..., 1, :] - P[..., 0, :], P[..., 2, :] - P[..., 0, :]), axis=-1
        )

    split02 = np.stack([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]], axis=1)  # (q, 2, 3)
    split13 = np.stack([Q[:, [0, 1, 3]], Q[:, [1, 2, 3]]], axis=1)
    better = areas(split13).min(axis=1) > areas(split02).min(axis=1)
    tris = np.where(better[:, None, None], split13, split02).reshape(-1, 3)
    tris = tris[areas(tris) > 1e-12 * max(float(np.ptp(V, axis=0).max()), 1e-300) ** 2]
    tris = _without_fins(tris)
    used, F = np.unique(tris, return_inverse=True)
    return TriMesh(V[used], F.reshape(-1, 3))


def _without_fins(tris: np.ndarray) -> np.ndarray:
    """Triangles (t, 3) without the fins: a triangle present once each way round (the
    halves of a doublet's two quads, which share two edges, split along the same
    diagonal) bounds nothing and would put that diagonal in four triangles."""
    key = np.sort(tris, axis=1)
    # even permutations of the sorted corners keep the orientation: parity 0 or 1
    odd = (
        (tris[:, 0] == key[:, 1]) & (tris[:, 1] == key[:, 0])
        | ((tris[:, 0] == key[:, 0]) & (tris[:, 1] == key[:, 2]))
        | ((tris[:, 0] == key[:, 2]) & (tris[:, 1] == key[:, 1]))
    )
    _, inverse = np.unique(key, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    ways = np.zeros((inverse.max() + 1 if inverse.size else 0, 2), dtype=bool)
    ways[inverse, odd.astype(np.int64)] = True
    fin: np.ndarray = np.all(ways, axis=1)
    return tris[~fin[inverse]]


def render_quads(
    vertices: npt.ArrayLike, quads: npt.ArrayLike, path: str | Path, **kwargs: Any
) -> RenderInfo:
    """Render a quad mesh: shading, wireframe, irregular vertices by valence (an
    interior vertex of valence other than 4, a boundary vertex of valence other than 3).

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
    mesh = _shading_mesh(V, Q)
    edges = quad_edges(Q)[0]
    valence = np.bincount(edges.ravel(), minlength=V.shape[0])
    regular = np.full(V.shape[0], 4)
    regular[quad_boundary_vertices(Q)] = 3  # on the boundary: 3; 2 marks a corner
    irr = np.flatnonzero((valence != regular) & (valence > 0))
    sing = (V[irr], (4 - valence[irr]) / 4.0) if irr.size else None
    return render(
        mesh,
        path,
        streamlines=list(V[edges]),  # the wireframe
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
        Kept for compatibility and unused: each triangle is cut exactly along the integer
        lines of u and v that cross it, so the squares have straight edges (they were
        4^subdivisions sub-triangles coloured one by one, with jagged edges).
    **kwargs
        Passed to :func:`fvf.viz.render`.
    """
    T = np.asarray(uv, dtype=np.float64)
    if T.shape != (mesh.n_faces, 3, 2):
        raise FvfError(f"uv must have shape ({mesh.n_faces}, 3, 2); got {T.shape}")
    X, W = mesh.vertices[mesh.faces], T
    for axis in (0, 1):
        X, W = _cut_at_integers(X, W, axis)
    e = X - np.roll(X, 1, axis=1)  # drop the slivers of a corner on a line: no area
    area2 = np.linalg.norm(np.cross(e[:, 0], e[:, 1]), axis=1)
    keep = area2 > 1e-10 * (e * e).sum(2).max(1)
    X, W = X[keep], W[keep]
    checker = (np.floor(W.mean(axis=1)).sum(axis=1) % 2).astype(float)
    k = X.shape[0]
    with warnings.catch_warnings():  # a soup by construction: one piece per triangle
        warnings.simplefilter("ignore", DuplicateVertexWarning)
        soup = TriMesh(X.reshape(-1, 3), np.arange(3 * k).reshape(k, 3))
    return render(soup, path, texture=0.35 + 0.5 * checker, **kwargs)


def _cut_at_integers(X: np.ndarray, W: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """Triangles (t, 3, 3) with uv (t, 3, 2) cut along every line ``uv[axis] = integer``
    that crosses them, so each piece lies in one square of the checkerboard and its
    edges are straight: one cut per round for every triangle still crossed."""
    done_X, done_W = [], []
    for _ in range(100_000):  # each round cuts every crossed triangle once
        f = W[..., axis]
        line = np.floor(f.min(axis=1)) + 1.0
        crossed = line < f.max(axis=1)
        done_X.append(X[~crossed])
        done_W.append(W[~crossed])
        if not crossed.any():
            break
        X, W, s = X[crossed], W[crossed], f[crossed] - line[crossed, None]  # (c, 3)
        neg = s < 0
        # the lone corner: the one on its own side of the line
        lone = np.where(neg.sum(1) == 1, np.argmax(neg, axis=1), np.argmax(~neg, axis=1))
        order = (lone[:, None] + np.arange(3)[None]) % 3  # (l, p, q) keeps the orientation
        rows = np.arange(X.shape[0])[:, None]
        X, W, s = X[rows, order], W[rows, order], s[rows, order]
        t1 = (s[:, 0] / (s[:, 0] - s[:, 1]))[:, None]
        t2 = (s[:, 0] / (s[:, 0] - s[:, 2]))[:, None]
        xe1, xe2 = X[:, 0] + t1 * (X[:, 1] - X[:, 0]), X[:, 0] + t2 * (X[:, 2] - X[:, 0])
        we1, we2 = W[:, 0] + t1 * (W[:, 1] - W[:, 0]), W[:, 0] + t2 * (W[:, 2] - W[:, 0])
        X = np.concatenate(
            [
                np.stack(c, 1)
                for c in ((X[:, 0], xe1, xe2), (xe1, X[:, 1], X[:, 2]), (xe1, X[:, 2], xe2))
            ]
        )
        W = np.concatenate(
            [
                np.stack(c, 1)
                for c in ((W[:, 0], we1, we2), (we1, W[:, 1], W[:, 2]), (we1, W[:, 2], we2))
            ]
        )
    return np.concatenate(done_X), np.concatenate(done_W)
