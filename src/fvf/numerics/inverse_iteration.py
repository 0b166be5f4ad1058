r"""Smallest eigenpairs of a Hermitian pencil by block inverse iteration on one factorization.

For L z = λ [m] z with L sparse Hermitian positive semidefinite and a positive diagonal
mass m, :func:`inverse_iteration` factors K = L + τ[m] once (τ > 0 a tiny shift that makes
K definite even when L is singular) and iterates on a block of p vectors,

.. math::

    Y = K^{-1} [m] X, \qquad X \leftarrow \text{Rayleigh–Ritz}(L, [m]; \operatorname{span} Y),

the subspace iteration of Knöppel et al. (2013), who solve the smoothest-field eigenproblem
by inverse power iteration on a single factorization. Each step multiplies the error in
the wanted eigenvectors by about (λ_j + τ)/(λ_{p+1} + τ); the block p > k makes the rate
independent of near-degenerate wanted eigenvalues (a cluster inside the block converges
as a whole). While the block's largest Ritz value is below :data:`GROWTH` times the k-th
(a cluster fills the block, e.g. the nine-fold λ = 4 of cross fields on a sphere), the
block is doubled (up to :data:`MAX_BLOCK`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..errors import SpectralSolveError
from .cholesky import Backend, factor_hermitian
from .progress import ProgressCallback, _silent

__all__ = ["inverse_iteration", "SHIFT_RTOL"]

#: τ = SHIFT_RTOL · max_i L_ii / m_i.
SHIFT_RTOL = 1e-8
#: The block is widened while its largest Ritz value is below GROWTH times the k-th.
GROWTH = 3.0
#: Largest block the widening goes to.
MAX_BLOCK = 48


def _m_orthonormal(Y: np.ndarray, sq: np.ndarray) -> np.ndarray:
    """An [m]-orthonormal basis of span(Y) (dropping numerically dependent columns)."""
    U, sv, _ = np.linalg.svd(sq[:, None] * Y, full_matrices=False)
    U = U[:, sv > 1e-10 * sv[0]]
    return U / sq[:, None]


def inverse_iteration(
    L: sp.sparray,
    mass: npt.ArrayLike,
    k: int,
    *,
    block: int | None = None,
    tol: float = 1e-10,
    maxiter: int = 300,
    backend: Backend = "auto",
    seed: int = 0,
    progress: ProgressCallback = _silent,
) -> tuple[np.ndarray, np.ndarray]:
    """The k smallest eigenpairs of L x = λ [m] x by block inverse iteration.

    Parameters
    ----------
    L : sparse (n, n), complex128 or float64
        Hermitian positive semidefinite.
    mass : array_like, float64 (n,)
        Positive diagonal mass.
    k : int
        Number of eigenpairs, 1 ≤ k < n.
    block : int, optional
        Block size p (default ``k + max(2, k)``, at most n).
    tol : float
        Stop when every wanted Ritz value changed by at most ``tol · (|λ_j| + λ_p)`` in one
        step (the eigenvector error is then about √tol relative to the gap).
    maxiter : int
    backend : {"auto", "cholmod", "cholespy", "scipy"}
        Factorization backend (:func:`fvf.numerics.cholesky.factor_hermitian`).
    seed : int
        Seed of the random start block.
    progress : callable
        Called as ``progress(stage, done, total)`` for stages ``"factor"`` and
        ``"iterate"`` (:mod:`fvf.numerics.progress`).

    Returns
    -------
    lam : float64 (k,)
        Ascending eigenvalues.
    X : (n, k), dtype of L
        [m]-orthonormal eigenvectors.

    Raises
    ------
    SpectralSolveError
        No convergence in ``maxiter`` steps, or a non-finite iterate.
    """
    m = np.asarray(mass, dtype=float)
    n = m.size
    p = min(n, block if block is not None else k + max(2, k))
    is_complex = np.iscomplexobj(L.data)
    dtype = np.complex128 if is_complex else np.float64
    tau = SHIFT_RTOL * float(np.max(L.diagonal().real / m))
    if not tau > 0:
        tau = SHIFT_RTOL
    progress("factor", 0, 1)
    fac = factor_hermitian(sp.csr_array(L + sp.diags_array(tau * m)), backend)
    progress("factor", 1, 1)
    sq = np.sqrt(m)
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, p))
    if is_complex:
        X = X + 1j * rng.standard_normal((n, p))
    X = _m_orthonormal(X.astype(dtype), sq)
    previous = None
    for it in range(1, maxiter + 1):
        Y = fac.solve(m[:, None] * X)
        if not np.all(np.isfinite(Y)):
            raise SpectralSolveError("inverse iteration produced non-finite vectors.")
        Q = _m_orthonormal(Y, sq)
        H = Q.conj().T @ (L @ Q)
        lam, V = np.linalg.eigh(0.5 * (H + H.conj().T))
        X = Q @ V
        progress("iterate", it, maxiter)
        if previous is not None and lam.size >= k and previous.size == lam.size:
            scale = np.abs(lam[:k]) + abs(lam[-1])
            if np.all(np.abs(lam[:k] - previous[:k]) <= tol * scale):
                progress("iterate", maxiter, maxiter)
                return np.asarray(lam[:k], dtype=float), X[:, :k]
        previous = lam
        # a cluster filling the block converges slowly: widen the block
        slow = lam[-1] + tau < GROWTH * (lam[min(k, lam.size) - 1] + tau)
        if it >= 2 and slow and X.shape[1] < min(n - 1, MAX_BLOCK):
            extra = min(X.shape[1], min(n - 1, MAX_BLOCK) - X.shape[1])
            R = rng.standard_normal((n, extra))
            if is_complex:
                R = R + 1j * rng.standard_normal((n, extra))
            X = _m_orthonormal(np.concatenate([X, R.astype(dtype)], axis=1), sq)
    raise SpectralSolveError(
        f"inverse iteration did not converge in {maxiter} steps (k = {k}, block = {p}). "
        "Fix: a larger block or maxiter."
    )
