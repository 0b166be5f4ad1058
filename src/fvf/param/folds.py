r"""Removing flipped uv triangles after rounding: local stiffening with the integers fixed.

After integer rounding the Poisson fit

.. math::

    \min_y \sum_t w_t A_t \bigl(|\nabla s - X|^2 + |\nabla t - Y|^2\bigr)

may leave some uv triangles flipped (det(∇s, ∇t) ≤ 0), typically around cones placed
close together. Bommes et al. (2009, §6) stiffen the fit where it is distorted — the
weight w_t of a face grows with its distortion |σ₁ − 1| + |σ₂ − 1| (σ the singular values
of (∇s, ∇t) against the frame), more on flipped faces and their neighbours — and solve
again. Here the integers stay as rounded (every real solution is then seamless), and each
round solves only the real unknowns of a **region** around the flipped faces (faces within
a few rings, the ring count growing from round to round) with the rest held fixed: a small
sparse system instead of a new global factorization and Schur complement.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

from ..mesh.trimesh import TriMesh
from ..numerics.cholesky import Backend, factor_hermitian

__all__ = ["flip_count", "flipped_faces", "face_distortion", "repair_folds"]

#: Largest distortion added to a face's weight per round (Bommes et al. 2009).
DISTORTION_CAP = 5.0
#: Extra factor on the weights of flipped faces and their edge neighbours per round.
FLIP_BOOST = 4.0


def flipped_faces(fit: np.ndarray) -> np.ndarray:
    """bool (m,): faces whose Jacobian (∇s, ∇t) has det ≤ 0 (``fit`` (4m,) rows s_x, s_y,
    t_x, t_y, any positive per-face factor)."""
    J = fit.reshape(-1, 4)
    return ~(J[:, 0] * J[:, 3] - J[:, 1] * J[:, 2] > 0)


def flip_count(fit: np.ndarray) -> int:
    """Number of flipped faces of a fit (4m,) (:func:`flipped_faces`)."""
    return int(np.count_nonzero(flipped_faces(fit)))


def face_distortion(fit: np.ndarray, target: np.ndarray) -> np.ndarray:
    """|σ₁ − 1| + |σ₂ − 1| per face, float64 (m,), σ the singular values of J F⁻¹.

    ``fit`` and ``target`` (4m,) are √A_t (∇s, ∇t) and √A_t (X, Y) per face (the factor
    cancels).
    """
    J = fit.reshape(-1, 2, 2)
    F = target.reshape(-1, 2, 2)
    sv = np.linalg.svd(J @ np.linalg.inv(F), compute_uv=False)
    return np.abs(sv - 1.0).sum(axis=1)


def _dilate(mesh: TriMesh, mask: np.ndarray, rings: int) -> np.ndarray:
    """Faces within ``rings`` edge-adjacency steps of the faces in ``mask``, bool (m,)."""
    adj = mesh.face_adjacency
    out = mask.copy()
    for _ in range(rings):  # a few rings
        nb = adj[out]
        out[nb[nb >= 0]] = True
    return out


def repair_folds(
    mesh: TriMesh,
    K: sp.csr_array,
    real: np.ndarray,
    y: np.ndarray,
    b: np.ndarray,
    *,
    rounds: int = 8,
    rings: int = 4,
    backend: Backend = "auto",
    progress: Callable[[str], None] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Local stiffening rounds with the integers fixed (module docstring).

    Parameters
    ----------
    mesh : TriMesh
    K : sparse (4m, p)
        The fit: y ↦ √A_t (∇s, ∇t) per face (rows s_x, s_y, t_x, t_y).
    real : int64 (r,)
        The unknowns of y that may change (the real ones).
    y : float64 (p,)
        The rounded solution.
    b : float64 (4m,)
        √A_t (X, Y) per face, the target.
    rounds : int
        Stiffening rounds at most.
    rings : int
        Face rings around the flipped faces in the first round; round i uses
        ``rings * (i + 1)``.

    Returns
    -------
    y : float64 (p,)
        The repaired solution (the integers unchanged).
    weights : float64 (m,)
        The final face weights.
    """
    m = mesh.n_faces
    w = np.ones(m)
    y = y.copy()
    is_real = np.zeros(K.shape[1], dtype=bool)
    is_real[real] = True
    Kc = K.tocsc()
    for it in range(rounds):  # a few stiffening rounds
        fit = K @ y
        flips = flipped_faces(fit)
        if not flips.any():
            break
        if progress is not None:
            progress(f"stiffening round {it + 1}: {int(flips.sum())} flipped triangles")
        w = w + np.minimum(face_distortion(fit, b), DISTORTION_CAP)
        w[_dilate(mesh, flips, 1)] *= FLIP_BOOST
        region = _dilate(mesh, flips, rings * (it + 1))
        rows = (4 * np.flatnonzero(region)[:, None] + np.arange(4)).ravel()
        cols = np.unique(K[rows].indices)
        free = cols[is_real[cols]]
        Kf = Kc[:, free]
        touched = np.unique(Kf.indices)  # every row whose value the free unknowns change
        Kf = sp.csr_array(Kf)[touched]
        sw = np.repeat(w, 4)[touched]
        rhs_rows = b[touched] - (K[touched] @ y - Kf @ y[free])
        H = Kf.T @ sp.diags_array(sw) @ Kf
        y[free] = factor_hermitian(sp.csr_array(H), backend).solve(Kf.T @ (sw * rhs_rows))
    return y, w
