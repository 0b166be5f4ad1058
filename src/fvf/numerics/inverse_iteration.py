r"""Smallest eigenpairs of a Hermitian pencil, preconditioned by one sparse factorization.

For L x = λ [m] x with L sparse Hermitian positive semidefinite and a positive diagonal
mass m, :func:`inverse_iteration` factors K = L + τ[m] once (τ > 0 a tiny shift that makes
K definite even when L is singular) and runs LOBPCG (Knyazev 2001;
``scipy.sparse.linalg.lobpcg``) with K⁻¹ as preconditioner. With an exact K⁻¹ this is
inverse power iteration (as Knöppel et al. 2013 use for the smoothest fields: one
factorization, then triangular solves) accelerated by the locally optimal three-term
recurrence, whose rate per step is about (1 − √ξ)/(1 + √ξ) with ξ = (λ_{k+1} − λ_k)/λ_{k+1}
instead of λ_k/λ_{k+1}: it matters for the clustered spectra of N-fold connection
Laplacians (e.g. λ_2/λ_1 = 1.06 for cross fields on the armadillo).

LOBPCG runs on the standard form S L S y = λ y with S = [m]^(-1/2) and x = S y, S applied
on the fly: no mass blocks and no scaled copy of L to hold, and the preconditioner is
S⁻¹ K⁻¹ S⁻¹. The block has k vectors: a slack vector makes LOBPCG wait for the (k+1)-th
pair too; on five shared meshes (n = 1 and 4) a block of k + 1 was never faster and took
1.5–4× the time at k = 1, 1.0–1.5× at k = 4, besides its blocks of memory
(``docs/nfields.md``).

The mass is rescaled to mean 1 inside, so ``tol`` bounds the residual ‖L x − λ m x‖ of
unit vectors relative to the size of L's entries, independently of the mesh's scale.
"""

from __future__ import annotations

import warnings

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SpectralSolveError
from .cholesky import Backend, factor_hermitian
from .progress import ProgressCallback, _silent

__all__ = ["inverse_iteration", "SHIFT_RTOL"]

#: τ = SHIFT_RTOL · max_i L_ii / m_i (with m rescaled to mean 1).
SHIFT_RTOL = 1e-8


def inverse_iteration(
    L: sp.sparray,
    mass: npt.ArrayLike,
    k: int,
    *,
    block: int | None = None,
    tol: float = 1e-6,
    maxiter: int = 300,
    backend: Backend = "auto",
    seed: int = 0,
    progress: ProgressCallback = _silent,
) -> tuple[np.ndarray, np.ndarray]:
    """The k smallest eigenpairs of L x = λ [m] x: LOBPCG preconditioned by (L + τ[m])⁻¹.

    Parameters
    ----------
    L : sparse (n, n), complex128 or float64
        Hermitian positive semidefinite.
    mass : array_like, float64 (n,)
        Positive diagonal mass.
    k : int
        Number of eigenpairs, 1 ≤ k, 5 k < n (smaller problems: a dense solver).
    block : int, optional
        Block size (default k; see the module docstring).
    tol : float
        Residual bound of every wanted pair (mass rescaled to mean 1; see module).
    maxiter : int
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
        Factorization (:func:`fvf.numerics.cholesky.factor_hermitian`).
    seed : int
        Seed of the random start block.
    progress : callable
        Called as ``progress(stage, done, total)`` for ``"factor"`` and ``"iterate"``.

    Returns
    -------
    lam : float64 (k,)
        Ascending eigenvalues (of the original pencil).
    X : (n, k), dtype of L
        [m]-orthonormal eigenvectors.

    Raises
    ------
    SpectralSolveError
        LOBPCG did not reach ``tol`` in ``maxiter`` steps or produced non-finite values.
    """
    m = np.asarray(mass, dtype=float)
    n = m.size
    scale = float(m.mean())
    a = m / scale
    p = min(n // 5, block if block is not None else k)
    is_complex = np.iscomplexobj(L.data)
    dtype = np.complex128 if is_complex else np.float64
    tau = SHIFT_RTOL * float(np.max(L.diagonal().real / a))
    if not tau > 0:
        tau = SHIFT_RTOL
    progress("factor", 0, 1)
    fac = factor_hermitian(sp.csr_array(L + sp.diags_array(tau * a)), backend)
    progress("factor", 1, 1)
    # LOBPCG on the standard form S L S y = λ y with S = [a]^(-1/2), x = S y: no mass
    # blocks (B X, B R, B P) to keep, and S applied on the fly (no scaled copy of L)
    s = (1.0 / np.sqrt(a))[:, None]
    count = [0]

    def apply_L(Y):
        return s * (L @ (s * Y.reshape(n, -1)))

    def precondition(R):  # (S K S)^(-1) = S^(-1) K^(-1) S^(-1); one call per LOBPCG step
        count[0] += 1
        progress("iterate", count[0], maxiter)
        return fac.solve(R.reshape(n, -1) / s) / s

    A = spla.LinearOperator((n, n), matvec=apply_L, matmat=apply_L, dtype=dtype)
    P = spla.LinearOperator((n, n), matvec=precondition, matmat=precondition, dtype=dtype)
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, p))
    if is_complex:
        X = X + 1j * rng.standard_normal((n, p))

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # checked below
        lam, Y = spla.lobpcg(A, X.astype(dtype), M=P, largest=False, tol=tol, maxiter=maxiter)
    progress("iterate", maxiter, maxiter)
    order = np.argsort(lam)[:k]
    lam, Y = np.asarray(lam[order], dtype=float), s * Y[:, order]
    if not (np.all(np.isfinite(lam)) and np.all(np.isfinite(Y))):
        raise SpectralSolveError("LOBPCG produced non-finite eigenpairs.")
    res = np.linalg.norm(L @ Y - a[:, None] * Y * lam[None, :], axis=0)
    if np.any(res > 10 * tol * np.maximum(1.0, np.linalg.norm(Y, axis=0))):
        raise SpectralSolveError(
            f"LOBPCG did not converge in {maxiter} steps (residuals {res.max():.2g} > tol "
            f"{tol:g}); e.g. a tight cluster of eigenvalues. Fix: solver='arpack'."
        )
    Y = Y / np.sqrt(scale)  # [m]-orthonormal for the original mass
    return lam / scale, Y
