r"""What :func:`fvf.numerics.expm.expm_action` learns about an explicit operator A: whether
it is :math:`W`-skew (:math:`WA + A^\top W = 0`), the bound :math:`R \ge \|K\|_W` of its
skew part (:func:`skew_bound`, the radius of the Chebyshev series) and
:class:`PreparedOperator`, which caches both for many calls.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import ExpmInputError
from .expm_inputs import check_operator, check_weights, norm_inf

__all__ = ["skew_bound", "PreparedOperator", "SKEW_RTOL"]

#: Relative size of W A + (W A)ᵀ below which a sparse A counts as W-skew.
SKEW_RTOL = 1e-12


class _SkewParts:
    """A's W-skew part K = ½(A − W⁻¹AᵀW), its row-scaled modulus |S| (S = W^{1/2} K W^{-1/2})
    and whether A is W-skew, for an explicit A.

    Operators on a mesh's 1-ring are structurally symmetric: then Aᵀ is a permutation of
    A's stored values (found once by one transposition of indices), and each of these is a
    few passes over A's values instead of sparse sums and products (60–500 products' time
    each on flow operators). Other patterns use sparse algebra.
    """

    def __init__(self, A: Any, w: np.ndarray | None) -> None:
        M = sp.csr_array(A, dtype=np.float64)
        M.sum_duplicates()  # canonical: sorted indices, no duplicates
        self.M = M
        self.w = np.ones(M.shape[0]) if w is None else w
        n, nnz = M.shape[0], M.nnz
        self.rows = np.repeat(np.arange(n), np.diff(M.indptr))
        T = sp.csr_array((np.arange(1, nnz + 1, dtype=np.float64), M.indices, M.indptr), (n, n))
        T = T.T.tocsr()
        T.sort_indices()
        same = np.array_equal(T.indptr, M.indptr) and np.array_equal(T.indices, M.indices)
        self.perm = T.data.astype(np.int64) - 1 if same else None  # data of Aᵀ = data[perm]

    def skew_data(self) -> sp.csr_array:
        """K on A's pattern (or on the union pattern when A is not structurally symmetric)."""
        M, w = self.M, self.w
        if self.perm is not None:
            data = 0.5 * (M.data - (w[M.indices] / w[self.rows]) * M.data[self.perm])
            return sp.csr_array((data, M.indices, M.indptr), shape=M.shape)
        W, Winv = sp.diags_array(w), sp.diags_array(1.0 / w)
        return sp.csr_array(0.5 * (M - Winv @ M.T @ W))

    def is_skew(self) -> bool:
        """|WA + (WA)ᵀ| ≤ SKEW_RTOL |WA| entrywise in the max norm."""
        M, w = self.M, self.w
        if M.nnz == 0:
            return True
        WA = w[self.rows] * M.data
        scale = float(np.abs(WA).max())
        if self.perm is not None:
            return bool(float(np.abs(WA + WA[self.perm]).max()) <= SKEW_RTOL * scale)
        WAs = sp.csr_array((WA, M.indices, M.indptr), shape=M.shape)
        sym = sp.csr_array(WAs + WAs.T)
        return bool(sym.nnz == 0 or float(abs(sym).max()) <= SKEW_RTOL * scale)

    def abs_scaled(self) -> sp.csr_array:
        """|S| = |K| with entries scaled by √(w_i / w_j): symmetric, non-negative."""
        K = self.skew_data()
        rows = np.repeat(np.arange(K.shape[0]), np.diff(K.indptr))
        data = np.abs(K.data) * np.sqrt(self.w[rows] / self.w[K.indices])
        return sp.csr_array((data, K.indices, K.indptr), shape=K.shape)


def skew_bound(
    A: Any, inner: npt.ArrayLike | None = None, steps: int = 8, return_products: bool = False
) -> float | tuple[float, int]:
    r"""An upper bound :math:`R \ge \|K\|_W` of the :math:`W`-norm of :math:`A`'s skew part.

    :math:`K = \tfrac12(A - W^{-1}A^\top W)`; every eigenvalue of :math:`A`'s skew part
    lies in :math:`|\mathrm{Im}\,z| \le R`, and for a :math:`W`-skew :math:`A`
    (:math:`K = A`) the whole spectrum does. With :math:`S = W^{1/2} K W^{-1/2}`,
    :math:`\|K\|_W = \|S\|_2 \le \rho(|S|)`, and for any positive :math:`x` the
    Collatz–Wielandt bound :math:`\rho(|S|) \le \max_i (|S|x)_i / x_i` holds. Starting from
    :math:`x = 1` (Gershgorin) each power step :math:`x \leftarrow |S|x` tightens it; the
    steps stop when the bound improves by less than 1 %.

    Parameters
    ----------
    A : sparse or dense (n, n), real
    inner : array_like (n,), optional
        Positive weights of :math:`W` (default: all ones).
    steps : int
        Most power steps (each one product with |S|).
    return_products : bool
        Also return the number of products spent.

    Returns
    -------
    float
        R (0 for a W-symmetric A); with ``return_products``, (R, products).
    """
    A, n = check_operator(A)
    if isinstance(A, spla.LinearOperator):
        raise ExpmInputError("skew_bound needs an explicit (sparse or dense) A")
    bound, products = _power_bound(_SkewParts(A, check_weights(inner, n)), steps)
    return (bound, products) if return_products else bound


def _power_bound(parts: _SkewParts, steps: int) -> tuple[float, int]:
    """(Collatz–Wielandt bound of ρ(|S|) after at most ``steps`` power steps, products)."""
    absS = parts.abs_scaled()
    n = absS.shape[0]
    if absS.nnz == 0 or n == 0:
        return 0.0, 0
    x = np.ones(n)
    y = absS @ x
    bound = float(y.max())
    products = 1
    for _ in range(max(int(steps), 0)):
        if bound == 0.0:
            break
        x = np.maximum(y / bound, 1e-300)  # Collatz–Wielandt needs x > 0
        y = absS @ x
        products += 1
        new = float((y / x).max())
        improved = new < 0.99 * bound
        bound = min(bound, new)
        if not improved:
            break
    return bound, products


class PreparedOperator:
    """An explicit operator A (sparse or dense) and its inner product, with what
    :func:`expm_action` learns about it cached for the next call.

    Pass it to :func:`expm_action` in place of A to flow many right-hand sides or times
    of one operator: whether A is W-skew, its norm, the bound R of :func:`skew_bound` and
    the Gershgorin bound are each computed once (on first need).

    Parameters
    ----------
    A : sparse array/matrix or ndarray (n, n), real
    inner : array_like (n,), optional
        Positive weights of the inner product (default: all ones).

    Attributes
    ----------
    A : scipy.sparse.csr_array or ndarray (n, n)
        The operator, scaled by 1/‖A‖_∞ when ‖A‖_∞ lies outside [1e-100, 1e100]
        (``scale`` is that factor, else 1; times are multiplied by it).
    weights : ndarray (n,) or None
        The weights divided by their maximum (only ratios matter), None for all ones.
    norm_inf : float
        ‖A‖_∞ of the stored (possibly scaled) A.
    """

    def __init__(self, A: Any, inner: npt.ArrayLike | None = None) -> None:
        A, n = check_operator(A)
        if isinstance(A, spla.LinearOperator):
            raise ExpmInputError("PreparedOperator needs an explicit (sparse or dense) A")
        self.n = n
        self.weights = check_weights(inner, n)
        norm = norm_inf(A)
        self.scale = 1.0
        if math.isfinite(norm) and norm > 0 and not 1e-100 <= norm <= 1e100:
            self.scale, A, norm = norm, A * (1.0 / norm), 1.0
        self.A = A
        self.norm_inf = norm
        self._cache: dict[str, Any] = {}

    def _cached(self, key: str, build: Callable[[], Any]) -> Any:
        if key not in self._cache:
            self._cache[key] = build()
        return self._cache[key]

    @property
    def parts(self) -> _SkewParts:
        return self._cached("parts", lambda: _SkewParts(self.A, self.weights))

    @property
    def is_skew(self) -> bool:
        """Whether A is W-skew to round-off."""
        return self._cached("skew", lambda: self.parts.is_skew())

    @property
    def gershgorin(self) -> float:
        """Gershgorin's bound of the W-norm of A's skew part (no products)."""
        return self._cached("gersh", lambda: float(self.parts.abs_scaled().sum(axis=1).max()))

    def bound(self) -> tuple[float, int]:
        """(R, products spent the first time) from :func:`skew_bound` (cached)."""
        if "bound" in self._cache:
            return self._cache["bound"], 0
        R, spent = _power_bound(self.parts, 8)
        self._cache["bound"] = R
        return R, spent
