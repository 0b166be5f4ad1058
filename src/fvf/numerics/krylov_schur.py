"""Block Krylov–Schur iteration for the largest eigenpairs of a symmetric positive
definite operator T (Stewart 2002): the iteration of the ``"krylov"`` method of
:func:`fvf.numerics.eigen.smallest_eigenpairs`, where T = [M]^½ K⁻¹ [M]^½.

Block Lanczos steps build an orthonormal basis; every new block is orthogonalized
against the last two blocks (the Lanczos recurrence), then once more against the whole
basis (full re-orthogonalization, repeated while a column loses half its norm), then
orthonormalized by Cholesky QR twice (:func:`_orth_block`): matrix–matrix (BLAS-3) work.
Rayleigh–Ritz and a thick restart keep the best Ritz vectors; the residual of every Ritz
pair in the original problem is computed exactly from the Krylov relation every
:data:`CHECK_EVERY` new vectors.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.linalg as sla

from ..errors import SpectralSolveError
from .progress import ProgressCallback

__all__ = ["block_krylov_schur", "block_size", "CHECK_EVERY"]

#: Ritz residuals are checked every ~this many new basis vectors.
CHECK_EVERY = 24
#: A Gram-Schmidt pass whose coefficients are all below this is skipped.
_ORTH_SKIP = 1e-13


def block_size(n: int, k: int) -> int:
    """The default block size b = clamp(k/16, 6, 8), at most n/8 (at least 1)."""
    return int(max(1, min(max(6, k // 16), 8, n // 8)))


def _orth_block(
    Q: np.ndarray, j: int, Y: np.ndarray, rng: np.random.Generator, local_from: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Orthogonalize rows Y (b, n) against Q[:j], then orthonormalize them.

    A local pass against Q[local_from:j] (the rows the Lanczos recurrence couples to),
    then one full classical Gram–Schmidt pass against Q[:j], repeated while a column
    loses more than half its norm (Daniel–Gragg–Kaufman–Stewart criterion), then
    Cholesky QR twice. Returns C (j, b), Qn (b, n) orthonormal rows and R (b, b) with
    Y_in = Q[:j]ᵀ C + Qnᵀ R. Rank-deficient directions are replaced by random ones
    orthogonal to everything (their rows of R are zero).
    """
    b, n = Y.shape
    C = np.zeros((j, b))
    norm0 = np.sqrt(np.einsum("ij,ij->i", Y, Y))
    if j > 0:
        if local_from > 0:
            L = Q[local_from:j]
            Cl = L @ Y.T
            Y = Y - Cl.T @ L
            C[local_from:j] += Cl
        before = np.sqrt(np.einsum("ij,ij->i", Y, Y))
        Qj = Q[:j]
        for _ in range(3):
            Cf = Qj @ Y.T
            if np.abs(Cf).max() <= _ORTH_SKIP * before.min():
                break  # already orthogonal to working precision: skip the update
            Y = Y - Cf.T @ Qj
            C += Cf
            after = np.sqrt(np.einsum("ij,ij->i", Y, Y))
            if np.all(after >= 0.5 * before):
                break
            before = after
    scale = max(float(norm0.max()), np.finfo(float).tiny)
    G = Y @ Y.T
    d = np.sqrt(np.maximum(np.diag(G), 0.0))
    if d.min() > 1e-6 * scale:
        try:
            R1 = sla.cholesky(G, lower=False)
            Q1 = sla.solve_triangular(R1, np.eye(b), lower=False).T @ Y
            R2 = sla.cholesky(Q1 @ Q1.T, lower=False)
            Qn = sla.solve_triangular(R2, np.eye(b), lower=False).T @ Q1
            return C, Qn, R2 @ R1
        except np.linalg.LinAlgError:
            pass
    # rank-revealing path
    Qf, R, piv = sla.qr(Y.T, mode="economic", pivoting=True)
    rank = int(np.sum(np.abs(np.diag(R)) > 1e-10 * scale))
    Rfull = np.zeros((b, b))
    Rfull[:, piv] = R
    Rfull[rank:] = 0.0
    Qn = np.ascontiguousarray(Qf.T)
    if rank < b:
        Zt = rng.standard_normal((b - rank, n))
        Good = np.vstack([Q[:j], Qn[:rank]])
        for _ in range(2):
            Zt -= (Good @ Zt.T).T @ Good
        Qz, _ = np.linalg.qr(Zt.T)
        Qn = np.vstack([Qn[:rank], Qz.T])
    return C, Qn, Rfull


def block_krylov_schur(
    apply_T: Callable[[np.ndarray], np.ndarray],
    apply_Khat: Callable[[np.ndarray], np.ndarray],
    n: int,
    nev: int,
    *,
    sigma: float,
    nu: float,
    tol: float,
    rng: np.random.Generator,
    maxiter: int = 60,
    block: int | None = None,
    max_basis: int | None = None,
    keep: int | None = None,
    report: ProgressCallback | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Largest eigenpairs of the symmetric positive definite operator T by block Krylov–Schur.

    Parameters
    ----------
    apply_T : callable
        Rows (b, n) -> rows of T applied to each, (b, n).
    apply_Khat : callable
        Rows (b, n) -> rows of T⁻¹ applied to each (used for exact residuals).
    n, nev : int
        Problem size and number of wanted eigenpairs.
    sigma, nu : float
        Shift (eigenvalue λ = σ + 1/θ) and the bound ν of the residual measure.
    tol : float
        Target relative residual.
    rng : numpy.random.Generator
        Start block.
    maxiter : int
        Maximum number of restarts.
    block, max_basis, keep : int, optional
        Block size, basis size before a restart, Ritz vectors kept at a restart.
    report : callable, optional
        ``report("iterate", converged, nev)`` after each convergence check.

    Returns
    -------
    theta : numpy.ndarray, shape (nev,)
        Largest eigenvalues of T, descending.
    Yt : numpy.ndarray, shape (nev, n)
        Orthonormal Ritz vectors as rows.

    Raises
    ------
    SpectralSolveError
        The basis cannot hold nev + b vectors (n too small), or the iteration did not
        converge within ``maxiter`` restarts.
    """
    b = block or block_size(n, nev)
    mb = max_basis or nev + max(nev, min(100, 2 * nev + 4 * b))
    mb = int(min(mb, n - 2 * b))
    if mb < nev + b:
        raise SpectralSolveError(f"Krylov basis ({mb}) too small for k = {nev}; n = {n}")
    p = keep or nev + (mb - nev) // 2
    cap = mb + 2 * b
    Q = np.empty((cap, n))
    H = np.zeros((cap, cap))
    _, Q[:b], _ = _orth_block(Q, 0, rng.standard_normal((b, n)), rng)
    j = b  # basis size; the images of Q[:j-b] under T are known
    first = 0  # start of the block expanded first after the last restart
    tol_int = 0.5 * tol
    check_every = max(1, CHECK_EVERY // b)
    rel = np.full(nev, np.inf)
    restarts = 0
    while True:
        Y = apply_T(Q[j - b : j])
        local_from = 0 if j - b == first else j - 2 * b
        C, Qn, R = _orth_block(Q, j, Y, rng, local_from)
        H[:j, j - b : j] = C
        H[j : j + b, j - b : j] = R
        Q[j : j + b] = Qn
        j += b
        s = j - b
        full = s >= mb
        if not full and (s < nev + nev // 4 + b or ((s - first) // b) % check_every):
            continue
        # Rayleigh–Ritz on the square part
        theta, S = np.linalg.eigh(0.5 * (H[:s, :s] + H[:s, :s].T))
        theta, S = theta[::-1], S[:, ::-1]
        Bres = H[s:j, :s] @ S  # residual coefficients on Q[s:j]
        # exact residual in the original problem: (Â − λ) y = −(1/θ) K̂ r, r = Q[s:j]ᵀ c
        Z = apply_Khat(Q[s:j])
        G = Z @ Z.T
        rn = np.sqrt(np.maximum(np.einsum("ij,ik,kj->j", Bres, G, Bres), 0.0))
        pos = theta > 0
        th = np.where(pos, theta, 1.0)
        lam = np.where(pos, sigma + 1.0 / th, np.inf)
        rel = np.where(pos, rn / th, np.inf) / (np.abs(lam) + nu)
        if report is not None:
            report("iterate", int(np.count_nonzero(rel[:nev] <= tol_int)), nev)
        if np.all(rel[:nev] <= tol_int):
            return theta[:nev], S[:, :nev].T @ Q[:s]
        if not full:
            continue
        if restarts == maxiter:
            break
        restarts += 1
        # thick restart: Q[:p] <- best Ritz vectors, Q[p:p+b] <- last block
        chunk = 8192
        for c0 in range(0, n, chunk):
            c1 = min(n, c0 + chunk)
            Q[:p, c0:c1] = S[:, :p].T @ Q[:s, c0:c1]
        Q[p : p + b] = Q[s:j]
        H[:] = 0.0
        H[:p, :p] = np.diag(theta[:p])
        H[p : p + b, :p] = Bres[:, :p]
        j = p + b
        first = p
    worst = float(np.max(rel[:nev]))
    raise SpectralSolveError(
        f"block Krylov-Schur did not converge in {maxiter} restarts "
        f"(worst relative residual {worst:.3g}, tol {tol:.3g})"
    )
