"""Eigenpairs of W φ = λ [M] φ as fvf returns them: the residual measure, the
normalisation and the sign convention shared by :mod:`fvf.numerics.eigen` and
:mod:`fvf.numerics.multilevel`.

W is a sparse symmetric positive semidefinite stiffness matrix (n, n) and ``mass`` (n,)
a positive lumped mass [M].

Residual measure
----------------
For an eigenpair (λ, φ) the relative residual is::

    res = ‖Wφ − λ[M]φ‖_{M⁻¹} / ((|λ| + ν) · ‖φ‖_M),
    ‖r‖_{M⁻¹}² = Σ_i r_i² / mass_i,   ‖φ‖_M² = Σ_i mass_i φ_i²,
    ν = max_i Σ_j |W_ij| / sqrt(mass_i · mass_j),

which is the normwise backward error of the eigenpair of the symmetric matrix
 = [M]^-½ W [M]^-½ (with the eigenvector [M]^½ φ), except that ‖Â‖₂ is replaced by
its row-sum (Gershgorin) upper bound ν. It is computed by :func:`eigen_residuals`;
every returned pair satisfies ``res ≤ tol``.

Sign convention
---------------
Each eigenvector is multiplied by ±1 so that its entry of largest magnitude is positive
(the first such index on exact ties). Vectors of a multiple eigenvalue are one
[M]-orthonormal basis of the eigenspace, which depends on ``seed``; with the same inputs
and seed the output is identical from call to call.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..errors import SpectralInputError, SpectralSolveError

__all__ = ["spectral_norm_bound", "eigen_residuals", "normalized_eigenpairs"]


def spectral_norm_bound(W: sp.sparray | sp.spmatrix, mass: npt.ArrayLike) -> float:
    """ν = max_i Σ_j |W_ij| / sqrt(mass_i mass_j): an upper bound of ‖[M]^-½ W [M]^-½‖₂.

    Parameters
    ----------
    W : sparse array, shape (n, n)
        Symmetric stiffness matrix.
    mass : array_like of float, shape (n,)
        Positive lumped mass.

    Returns
    -------
    float
        The row-sum (Gershgorin) bound of the largest eigenvalue of W φ = λ[M]φ.
    """
    W = sp.csr_array(W)
    s = 1.0 / np.sqrt(np.asarray(mass, dtype=np.float64))
    A = abs(W)
    rows = s * (A @ s)
    return float(rows.max()) if rows.size else 0.0


def eigen_residuals(
    W: sp.sparray | sp.spmatrix,
    mass: npt.ArrayLike,
    evals: npt.ArrayLike,
    evecs: npt.ArrayLike,
) -> np.ndarray:
    """Relative residuals ‖Wφ − λ[M]φ‖_{M⁻¹} / ((|λ| + ν) ‖φ‖_M) of eigenpairs.

    ν is :func:`spectral_norm_bound` (an upper bound of the largest eigenvalue); see the
    module docstring for the meaning of this measure.

    Parameters
    ----------
    W : sparse array, shape (n, n)
    mass : array_like of float, shape (n,)
    evals : array_like of float, shape (k,)
    evecs : array_like of float, shape (n, k)

    Returns
    -------
    numpy.ndarray of float64, shape (k,)
    """
    W = sp.csr_array(W)
    m = np.asarray(mass, dtype=np.float64)
    lam = np.atleast_1d(np.asarray(evals, dtype=np.float64))
    X = np.asarray(evecs, dtype=np.float64)
    if X.ndim == 1:
        X = X[:, None]
    n = W.shape[0]
    if m.shape != (n,) or X.shape != (n, lam.size):
        raise SpectralInputError(
            f"eigen_residuals needs mass ({n},) and evecs ({n}, {lam.size}) for "
            f"{lam.size} eigenvalues and W {W.shape}; got mass {m.shape}, evecs {X.shape}"
        )
    R = W @ X - (m[:, None] * X) * lam[None, :]
    xnorm = np.sqrt(np.einsum("ij,ij->j", X, X * m[:, None]))
    return _relative(R, m, lam, spectral_norm_bound(W, m)) / xnorm


def _relative(R: np.ndarray, m: np.ndarray, lam: np.ndarray, nu: float) -> np.ndarray:
    """‖r‖_{M⁻¹} / (|λ| + ν) of the residual columns R (n, k): (k,)."""
    return np.sqrt(np.einsum("ij,ij->j", R, R / m[:, None])) / (np.abs(lam) + nu)


def normalized_eigenpairs(
    W: sp.sparray | sp.spmatrix, mass: npt.ArrayLike, X: npt.ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Approximate eigenvectors made into eigenpairs as fvf returns them.

    Each column is [M]-normalized, its eigenvalue is its Rayleigh quotient φᵀWφ, the pairs
    are sorted by ascending eigenvalue, each vector gets the sign convention of the module
    docstring, and the relative residual of :func:`eigen_residuals` is computed, sharing
    one product W @ X.

    Parameters
    ----------
    W : sparse array, shape (n, n)
        Symmetric stiffness matrix.
    mass : array_like of float, shape (n,)
        Positive lumped mass.
    X : array_like of float, shape (n, k)
        Approximate eigenvectors (any scaling and sign).

    Returns
    -------
    evals : numpy.ndarray of float64, shape (k,)
        Ascending Rayleigh quotients.
    evecs : numpy.ndarray of float64, shape (n, k)
        [M]-orthonormal columns (up to the accuracy of X), largest-magnitude entry positive.
    residuals : numpy.ndarray of float64, shape (k,)
        Relative residuals (:func:`eigen_residuals`).

    Raises
    ------
    SpectralSolveError
        X is not a finite 2-D array, or has a zero column.
    """
    W = sp.csr_array(W)
    m = np.asarray(mass, dtype=np.float64)
    V = np.asarray(X, dtype=np.float64)
    if V.ndim != 2 or not np.all(np.isfinite(V)):
        raise SpectralSolveError("non-finite eigenvectors")
    norms = np.sqrt(np.einsum("ij,ij->j", V, V * m[:, None]))
    if np.any(norms == 0):
        raise SpectralSolveError("zero eigenvector")
    V = V / norms
    WV = W @ V
    rq = np.einsum("ij,ij->j", V, WV)
    order = np.argsort(rq, kind="stable")
    lam, V, WV = rq[order], V[:, order], WV[:, order]
    idx = np.argmax(np.abs(V), axis=0)
    sign = np.where(V[idx, np.arange(V.shape[1])] < 0, -1.0, 1.0)
    V *= sign
    WV *= sign
    res = _relative(WV - (m[:, None] * V) * lam[None, :], m, lam, spectral_norm_bound(W, m))
    return np.ascontiguousarray(lam), V, res
