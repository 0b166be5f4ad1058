"""Explicit, opt-in mesh repairs; each returns the index map it applied. Nothing is silent."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["remove_unreferenced_vertices"]


def remove_unreferenced_vertices(
    vertices: npt.ArrayLike, faces: npt.ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Drop vertices that no face uses, keeping the order of the others.

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)

    Returns
    -------
    vertices : float64 (n', 3)
    faces : int64 (m, 3)
        Re-indexed into the kept vertices.
    kept : int64 (n',)
        ``kept[i]`` is the original index of new vertex i (so ``f_old[kept]`` restricts a
        function to the new mesh).
    """
    V = np.asarray(vertices, dtype=float)
    F = np.asarray(faces, dtype=np.int64)
    used = np.zeros(V.shape[0], dtype=bool)
    used[F.ravel()] = True
    kept = np.flatnonzero(used)
    new_index = np.full(V.shape[0], -1, dtype=np.int64)
    new_index[kept] = np.arange(kept.size)
    return V[kept], new_index[F], kept
