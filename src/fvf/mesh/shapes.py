"""Generated meshes with known geometry: spheres (regular and jittered), tori, disks.

Used by the tests' convergence studies and by examples; all randomness is seeded.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial import Delaunay

from .trimesh import TriMesh

__all__ = ["icosphere", "jittered_sphere", "torus", "disk", "midpoint_subdivision"]


def _icosahedron() -> tuple[np.ndarray, np.ndarray]:
    p = (1.0 + np.sqrt(5.0)) / 2.0
    X = np.array(
        [
            [-1, p, 0],
            [1, p, 0],
            [-1, -p, 0],
            [1, -p, 0],
            [0, -1, p],
            [0, 1, p],
            [0, -1, -p],
            [0, 1, -p],
            [p, 0, -1],
            [p, 0, 1],
            [-p, 0, -1],
            [-p, 0, 1],
        ],
        dtype=float,
    )
    F = np.array(
        [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ],
        dtype=np.int64,
    )
    return X / np.linalg.norm(X, axis=1)[:, None], F


def midpoint_subdivision(
    vertices: npt.ArrayLike, faces: npt.ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """One 1-to-4 midpoint subdivision of raw arrays (the same surface, 4x the faces).

    Parameters
    ----------
    vertices : array_like (n, 3) float
    faces : array_like (m, 3) int

    Returns
    -------
    vertices : float64 (n + E, 3)
        The old vertices first (same order), then one midpoint per edge (E edges).
    faces : int64 (4m, 3)
        Blocks of m: the children at corners 0, 1, 2 of every face, then the middle ones;
        fine face j comes from face j mod m, with the parent's orientation.
    """
    X = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    n = X.shape[0]
    a = F[:, [1, 2, 0]].ravel()  # edge opposite corner i: (v_{i+1}, v_{i+2})
    b = F[:, [2, 0, 1]].ravel()
    key = np.minimum(a, b) * n + np.maximum(a, b)
    uniq, inv = np.unique(key, return_inverse=True)
    mid = 0.5 * (X[uniq // n] + X[uniq % n])  # (E, 3)
    e = n + inv.reshape(-1, 3)  # (m, 3) new vertex opposite each corner
    F2 = np.concatenate(
        [
            np.stack([F[:, 0], e[:, 2], e[:, 1]], axis=1),
            np.stack([F[:, 1], e[:, 0], e[:, 2]], axis=1),
            np.stack([F[:, 2], e[:, 1], e[:, 0]], axis=1),
            e,
        ]
    )
    return np.concatenate([X, mid]), F2


def icosphere(subdivisions: int = 3, radius: float = 1.0) -> TriMesh:
    """Regular icosphere: 10·4^k + 2 vertices, 20·4^k faces, outward normals.

    Parameters
    ----------
    subdivisions : int
        k >= 0 midpoint subdivisions of the icosahedron.
    radius : float
    """
    X, F = _icosahedron()
    for _ in range(int(subdivisions)):
        n = X.shape[0]
        X, F = midpoint_subdivision(X, F)
        X[n:] /= np.linalg.norm(X[n:], axis=1)[:, None]  # midpoints pushed to the sphere
    return TriMesh(radius * X, F)


def jittered_sphere(subdivisions: int = 3, jitter: float = 0.3, seed: int = 0) -> TriMesh:
    """Irregular unit sphere: an icosphere whose vertices are moved tangentially at random.

    Each vertex moves by up to ``jitter`` times the local edge length in a random tangent
    direction, then returns to the sphere; the triangulation stays valid for
    ``jitter < 0.5`` while angles and areas become irregular at every level of refinement.
    """
    base = icosphere(subdivisions)
    rng = np.random.default_rng(seed)
    X = base.vertices.copy()
    step = rng.uniform(-1.0, 1.0, X.shape)
    step -= np.einsum("ij,ij->i", step, X)[:, None] * X
    X += jitter * base.mean_edge_length * step
    return TriMesh(X / np.linalg.norm(X, axis=1)[:, None], base.faces)


def torus(n_major: int = 48, n_minor: int = 24, R: float = 1.0, r: float = 0.4) -> TriMesh:
    """Torus of revolution about the z axis, (n_major x n_minor) grid split into triangles.

    X(u, w) = ((R + r cos w) cos u, (R + r cos w) sin u, r sin w).
    """
    u = 2 * np.pi * np.arange(n_major) / n_major
    w = 2 * np.pi * np.arange(n_minor) / n_minor
    U, W = np.meshgrid(u, w, indexing="ij")
    X = np.stack(
        [(R + r * np.cos(W)) * np.cos(U), (R + r * np.cos(W)) * np.sin(U), r * np.sin(W)], -1
    ).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_major), np.arange(n_minor), indexing="ij")
    a = i * n_minor + j
    b = ((i + 1) % n_major) * n_minor + j
    c = ((i + 1) % n_major) * n_minor + (j + 1) % n_minor
    d = i * n_minor + (j + 1) % n_minor
    F = np.concatenate(
        [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    )
    return TriMesh(X, F)


def disk(n_rings: int = 8, n_sectors: int = 6) -> TriMesh:
    """Flat unit disk in the z = 0 plane (a mesh with one boundary loop), normals +z."""
    pts = [np.zeros((1, 3))]
    for k in range(1, n_rings + 1):
        s = n_sectors * k
        a = 2 * np.pi * np.arange(s) / s
        pts.append(np.stack([k / n_rings * np.cos(a), k / n_rings * np.sin(a), 0 * a], 1))
    X = np.concatenate(pts)
    F = Delaunay(X[:, :2]).simplices.astype(np.int64)
    P = X[F]
    flip = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])[:, 2] < 0
    F[flip] = F[flip][:, ::-1]
    return TriMesh(X, F)
