r"""Removing flipped uv triangles after rounding: local and global stiffening.

After integer rounding the Poisson fit

.. math::

    \min_y \sum_t w_t A_t \bigl(|\nabla s - X|^2 + |\nabla t - Y|^2\bigr)

may leave some uv triangles flipped (det(∇s, ∇t) ≤ 0), typically around cones placed
close together. Bommes et al. (2009, §6) stiffen the fit where it is distorted — the
weight w_t of a face grows with its distortion |σ₁ − 1| + |σ₂ − 1| (σ the singular values
of (∇s, ∇t) against the frame, at most :data:`DISTORTION_CAP` per round), and ×
:data:`FLIP_BOOST` on flipped faces and their edge neighbours — and solve again.
:func:`repair_folds` does this on two levels per round:

1. **local** (:func:`local_repair`): the integers stay as rounded (every real solution is
   then seamless) and only the real unknowns of a region around the flipped faces (a few
   face rings) are solved for, the rest held fixed: a small sparse system;
2. **integer moves** (:func:`integer_moves`), when folds remain: single integer unknowns
   move by ±1 while that lowers the flip count; with the real unknowns re-solved exactly,
   each move changes the fit by a fixed sparse column, so a candidate costs an update of
   the faces it touches;
3. **global**, when folds remain: the weighted fit is factored again and the integers
   are rounded again (:class:`fvf.param.rounding.MixedIntegerSolver`), so that the
   rounding itself can move away from the folds.

The solution with the fewest flips seen is kept (ties: the first).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

from ..mesh.trimesh import TriMesh
from ..numerics.cholesky import Backend, factor_hermitian
from .rounding import MixedIntegerSolver

__all__ = [
    "flip_count",
    "flipped_faces",
    "face_distortion",
    "local_repair",
    "integer_moves",
    "repair_folds",
]

#: Largest distortion added to a face's weight per round (Bommes et al. 2009).
DISTORTION_CAP = 5.0
#: Extra factor on the weights of flipped faces and their edge neighbours per round.
FLIP_BOOST = 4.0
#: Entries of a response column below this fraction of its largest are dropped.
RESPONSE_RTOL = 1e-2
#: Integer unknowns tried per sweep of :func:`integer_moves`: those responding most at
#: the flipped faces.
SEARCH_CANDIDATES = 24


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


def stiffen(mesh: TriMesh, w: np.ndarray, fit: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bommes et al.'s weight update, float64 (m,): w + min(distortion, cap), then ×
    :data:`FLIP_BOOST` on flipped faces and their edge neighbours."""
    w = w + np.minimum(face_distortion(fit, b), DISTORTION_CAP)
    w[_dilate(mesh, flipped_faces(fit), 1)] *= FLIP_BOOST
    return w


def local_repair(
    mesh: TriMesh,
    K: sp.csr_array,
    real: np.ndarray,
    y: np.ndarray,
    b: np.ndarray,
    w: np.ndarray,
    *,
    rounds: int = 3,
    rings: int = 4,
    backend: Backend = "auto",
) -> tuple[np.ndarray, np.ndarray]:
    """Local stiffening rounds with the integers fixed (step 1 of the module docstring).

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
    w : float64 (m,)
        Face weights to start from (updated by :func:`stiffen` each round).
    rounds : int
        Rounds at most; round i solves within ``rings * (i + 1)`` face rings of the flips.

    Returns
    -------
    y : float64 (p,)
        The solution with the fewest flips seen (the integers unchanged).
    w : float64 (m,)
        The final face weights.
    """
    is_real = np.zeros(K.shape[1], dtype=bool)
    is_real[real] = True
    Kc = K.tocsc()
    best, best_y = flip_count(K @ y), y
    for it in range(rounds):  # a few stiffening rounds
        fit = K @ y
        flips = flipped_faces(fit)
        if not flips.any():
            break
        w = stiffen(mesh, w, fit, b)
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
        y = y.copy()
        y[free] = factor_hermitian(sp.csr_array(H), backend).solve(Kf.T @ (sw * rhs_rows))
        count = flip_count(K @ y)
        if count < best:
            best, best_y = count, y
    return best_y, w


def _responses(solver: MixedIntegerSolver, K: sp.csr_array) -> sp.csc_array:
    """Sparse (4m, k): the change of K y per unit step of each integer unknown, with the
    real unknowns re-solved (K_i − K_r H_rr⁻¹ H_ri), entries below RESPONSE_RTOL of the
    column's largest dropped."""
    Kc = sp.csc_array(K)
    Ki, Kr = Kc[:, solver.integer], Kc[:, solver.real_idx]
    k = solver.integer.size
    chunk = 64
    out = []
    for lo in range(0, k, chunk):  # a few blocks of integer columns
        cols = np.arange(lo, min(lo + chunk, k))
        R = Ki[:, cols].toarray() - Kr @ solver.fac.solve(solver.Hri[:, cols].toarray())
        R[np.abs(R) < RESPONSE_RTOL * np.abs(R).max(axis=0, keepdims=True)] = 0.0
        out.append(sp.csc_array(R))
    return sp.hstack(out).tocsc()


def integer_moves(
    solver: MixedIntegerSolver, K: sp.csr_array, g: np.ndarray, y: np.ndarray, sweeps: int = 30
) -> np.ndarray:
    """Move single integer unknowns by ±1 while that lowers the number of flipped faces.

    Parameters
    ----------
    solver : MixedIntegerSolver
        Of the fit whose minimizer y is (H = Kᵀ W K for face weights W).
    K : sparse (4m, p)
        y ↦ √A_t (∇s, ∇t) per face (rows s_x, s_y, t_x, t_y).
    g : float64 (p,)
        The right-hand side y was rounded for.
    y : float64 (p,)
        A rounded minimizer (y[solver.integer] integers).
    sweeps : int
        Moves at most. Per sweep the best of ±1 on the :data:`SEARCH_CANDIDATES` integer
        unknowns responding most at flipped faces is taken (fewest flips, then lowest
        energy ½ wᵀS w − rᵀw); stops at zero flips or when no move helps.

    Returns
    -------
    float64 (p,)
        The moved solution, real unknowns re-solved.
    """
    yr0, r = solver.reduced(g)
    w = y[solver.integer].copy()
    fit = (K @ y).reshape(-1, 4)
    R = _responses(solver, K)

    def det(f):
        return f[:, 0] * f[:, 3] - f[:, 1] * f[:, 2]

    flipped = ~(det(fit) > 0)
    best = int(flipped.sum())
    cols = [
        (R.indices[R.indptr[i] : R.indptr[i + 1]], R.data[R.indptr[i] : R.indptr[i + 1]])
        for i in range(R.shape[1])
    ]
    S = solver.S
    for _ in range(sweeps):  # a few sweeps over a few candidate unknowns
        if best == 0:
            break
        bad_rows = np.flatnonzero(np.repeat(flipped, 4))
        strength = np.abs(R[bad_rows]).max(axis=0).toarray().ravel()
        cand = np.argsort(-strength, kind="stable")[:SEARCH_CANDIDATES]
        choice = None
        for i in cand[strength[cand] > 0]:
            rows, vals = cols[i]
            faces = np.unique(rows // 4)
            before = int(flipped[faces].sum())
            slots = np.searchsorted((faces[:, None] * 4 + np.arange(4)).ravel(), rows)
            for step in (-1.0, 1.0):
                local = fit[faces].copy().ravel()
                local[slots] += step * vals
                after = int(np.count_nonzero(~(det(local.reshape(-1, 4)) > 0)))
                score = best - before + after
                de = step * (S[i] @ w - r[i]) + 0.5 * S[i, i]
                if choice is None or (score, de) < (choice[0], choice[3]):
                    choice = (score, i, step, de)
        if choice is None or choice[0] >= best:
            break
        best, i, step, _ = choice
        w[i] += step
        rows, vals = cols[i]
        fit.ravel()[rows] += step * vals
        flipped = ~(det(fit) > 0)
    return solver.assemble(yr0, w)


def repair_folds(
    mesh: TriMesh,
    K: sp.csr_array,
    solver: MixedIntegerSolver,
    y: np.ndarray,
    b: np.ndarray,
    *,
    rounds: int = 8,
    batch: float = 0.05,
    backend: Backend = "auto",
    progress: Callable[[str], None] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Remove flipped uv triangles: local, then global stiffening rounds (module docstring).

    Parameters
    ----------
    mesh : TriMesh
    K : sparse (4m, p)
        The fit: y ↦ √A_t (∇s, ∇t) per face (rows s_x, s_y, t_x, t_y).
    solver : MixedIntegerSolver
        Of the unweighted fit H = KᵀK (its integer unknowns are those of y).
    y : float64 (p,)
        The rounded solution.
    b : float64 (4m,)
        √A_t (X, Y) per face, the target.
    rounds : int
        Rounds at most (each: a local repair, integer moves, then a new factorization
        and rounding of the stiffened fit while flips remain).
    batch : float
        Greedy rounding batch (:meth:`MixedIntegerSolver.rounded`).
    backend : {"auto", "cholmod", "cholespy", "scipy"}
    progress : callable, optional
        Called with a message per round.

    Returns
    -------
    y : float64 (p,)
        The solution with the fewest flipped faces seen (y[integer] integers).
    weights : float64 (m,)
        The final face weights.
    """
    w = np.ones(mesh.n_faces)
    g = K.T @ b
    best, best_y = flip_count(K @ y), y

    def keep(candidate: np.ndarray) -> int:
        nonlocal best, best_y
        count = flip_count(K @ candidate)
        if count < best:
            best, best_y = count, candidate
        return count

    for it in range(rounds):  # a few stiffening rounds
        if best == 0:
            break
        if progress is not None:
            progress(f"stiffening round {it + 1}: {flip_count(K @ y)} flipped triangles")
        y, w = local_repair(mesh, K, solver.real_idx, y, b, w, backend=backend)
        if keep(y) == 0:
            break
        y = integer_moves(solver, K, g, y)
        if keep(y) == 0 or it == rounds - 1:
            break
        w = stiffen(mesh, w, K @ y, b)
        sw = np.repeat(np.sqrt(w), 4)
        Kw = sp.diags_array(sw) @ K
        solver = MixedIntegerSolver((Kw.T @ Kw).tocsr(), solver.integer, backend)
        g = Kw.T @ (sw * b)
        y = solver.rounded(g, batch=batch)
        keep(y)
    return best_y, w
