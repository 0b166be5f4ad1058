r"""The action of the matrix exponential: :math:`e^{t_j A} B` for many times and columns.

:func:`expm_action` computes :math:`X_j = e^{t_j A} B` for times :math:`t_j` of any sign and
order and a block :math:`B \in \mathbb{R}^{n \times p}`, without forming :math:`e^{A}`. It
is built for the functional flows :math:`\Phi_{v,t} f = e^{-t D^V_v} f`
(docs/chapter.md, eq. (42)): :math:`A = -D^V_v` is sparse with about 7 non-zeros per row
and, for divergence-free fields :math:`v = J\nabla g` on a closed mesh, skew-adjoint in the
inner product :math:`\langle x, y\rangle_W = x^\top W y`, :math:`W = [A_V]`.

Three methods, one entrance:

Chebyshev series (``method="chebyshev"``)
    For a :math:`W`-skew :math:`A` whose norm is at most :math:`R`
    (:func:`skew_bound`), the Jacobi–Anger expansion

    .. math::

        e^{tA} = J_0(Rt)\,I + 2\sum_{k\ge1} J_k(Rt)\,P_k(A/R), \qquad
        P_{k+1}(X) = 2X P_k(X) + P_{k-1}(X),\ P_0 = I,\ P_1 = X,

    is a real three-term recurrence (Tal-Ezer & Kosloff 1984): one product per term, no
    inner products, every time of either sign from the same terms. Since
    :math:`\|P_k(A/R)\|_W \le 1`, truncating after :math:`K` terms errs by at most
    :math:`2\sum_{k>K}|J_k(Rt)|\,\|B\|_W`: the degree is chosen a priori
    (:func:`chebyshev_degree`), about :math:`R|t| + O((R|t|)^{1/3} + \log 1/\mathrm{tol})`.
    For an operator that is not :math:`W`-skew the series is checked a posteriori and gives
    way to the Krylov method (with :class:`~fvf.errors.KrylovFallbackWarning`) when its
    terms grow.

Krylov time stepping (``method="krylov"``)
    Saad 1992; Hochbruck & Lubich 1997; the step control of Expokit. A step from the state
    :math:`y` builds a basis :math:`u_0 = y/\|y\|_W, u_1, \dots` of the Krylov space with
    :math:`A U_m = U_m H_m + h_{m,m-1} u_m e_m^\top`:

    - :math:`W`-skew :math:`A` (Lanczos): :math:`H_m` is tridiagonal with zero diagonal and
      :math:`h_{j,j+1} = -h_{j+1,j}`; one product and one norm per vector. Writing
      :math:`D = \mathrm{diag}(i^k)`, :math:`D^{-1} H_m D = -iT_m` with :math:`T_m` real
      symmetric tridiagonal, so :math:`e^{sH_m}e_1` is exact for every :math:`s` from one
      tridiagonal eigen-decomposition.
    - otherwise: incomplete orthogonalization against the last :data:`IOM_WINDOW` vectors
      (Koskela 2015; Vo & Sidje 2017); :math:`H_m` is banded Hessenberg and its small
      exponentials are dense.

    :math:`y(\tau_0 + s) \approx \|y\|_W U_m e^{sH_m}e_1` for every time inside the step
    (dense output: one GEMM for all of them). The residual
    :math:`r(\sigma) = \|y\|_W h_{m,m-1} [e^{\sigma H_m}e_1]_{m-1} u_m` bounds the error by
    :math:`\int_0^s e^{\mu(s-\sigma)}|r(\sigma)|\,d\sigma` (:math:`\mu = 0` for skew
    :math:`A`, else the logarithmic norm of :math:`H_m`). The basis grows until the whole
    remaining interval meets the budget :math:`\mathrm{tol}\cdot s/T`; at :data:`M_MAX`
    vectors the step is cut to the longest :math:`s` within budget.

``method="expm_multiply"``
    :func:`scipy.sparse.linalg.expm_multiply` (Al-Mohy & Higham 2011), chained over the
    sorted times of each sign.

``method="auto"`` (:func:`choose_method`) runs the series for skew operators once
:math:`R\max|t| \ge` :data:`SERIES_MIN_TAU` and the Krylov method otherwise: the series'
products are cheaper (no inner products, no basis to keep), Lanczos needs fewer of them on
short times.

Work is bounded: a call whose estimated number of products exceeds ``max_products``
(:data:`MAX_PRODUCTS` by default) raises :class:`~fvf.errors.FlowOverflowError` before
starting, with the estimate and what to do.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import ExpmInputError, FlowOverflowError, KrylovFallbackWarning

__all__ = [
    "expm_action",
    "skew_bound",
    "chebyshev_degree",
    "choose_method",
    "check_options",
    "as_times",
    "ExpmvCounter",
    "PreparedOperator",
    "dense_expm_action",
    "METHODS",
    "MAX_PRODUCTS",
]

Method = Literal["auto", "krylov", "chebyshev", "expm_multiply"]
#: The methods of :func:`expm_action`.
METHODS = ("auto", "krylov", "chebyshev", "expm_multiply")

#: Largest Krylov basis per step (fewer when :data:`BASIS_MEMORY` would be exceeded).
M_MAX = 100
#: Vectors each new Krylov vector is orthogonalized against (operators that are not skew).
IOM_WINDOW = 4
#: ``auto`` runs the Chebyshev series for skew operators from R · max|t| ≥ this.
SERIES_MIN_TAU = 40.0
#: Default cap on the products of one call (columns × products); beyond it the call is
#: refused before it starts. About 5 ms each at 750k vertices, 2 µs at 200.
MAX_PRODUCTS = 200_000
#: Bytes of a Krylov basis or of the series' buffered terms.
BASIS_MEMORY = 2**30
#: The Krylov error estimates aim at SAFETY · tol.
SAFETY = 0.05
#: The series' a-priori bound aims at SERIES_SAFETY · tol (each decade costs ~2 terms).
SERIES_SAFETY = 1e-2
#: Largest max|t| · ‖A‖_∞ accepted (beyond ~1/eps the steps underflow relative to t).
MAX_SPAN = 1e15
#: Quadrature points of the error integral over a Krylov step.
_GRID = 32
#: Relative size of W A + (W A)ᵀ below which a sparse A counts as W-skew.
SKEW_RTOL = 1e-12


# ---------------------------------------------------------------------------- inputs
def as_times(t: Any) -> tuple[np.ndarray, bool]:
    """Validated times: (float64 array (T,), whether ``t`` was a scalar).

    Raises
    ------
    ExpmInputError
        Non-numeric, 2-D or non-finite ``t``.
    """
    try:
        times = np.asarray(t, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ExpmInputError(f"t must be a real scalar or 1-D array; got {t!r}") from exc
    if times.ndim > 1:
        raise ExpmInputError(f"t must be a scalar or a 1-D array; got shape {times.shape}")
    if not np.isfinite(times).all():
        bad = np.flatnonzero(~np.isfinite(np.atleast_1d(times)))
        raise ExpmInputError(f"t must be finite; non-finite entries at {bad[:8].tolist()}")
    return np.atleast_1d(times), times.ndim == 0


def check_options(method: str, tol: float) -> tuple[str, float]:
    """Validated ``(method, tol)`` of :func:`expm_action`.

    Raises
    ------
    ExpmInputError
        ``method`` not one of :data:`METHODS`, or ``tol`` not in (0, 1).
    """
    if method not in METHODS:
        raise ExpmInputError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
    if isinstance(tol, bool) or not isinstance(tol, int | float | np.floating):
        raise ExpmInputError(f"tol must be a number in (0, 1); got {tol!r}")
    if not 0 < tol < 1:
        raise ExpmInputError(f"tol must be in (0, 1); got {tol!r}")
    return method, float(tol)


def _check_operator(A: Any) -> tuple[Any, int]:
    """(A as CSR, float64 ndarray or LinearOperator; n), or :class:`ExpmInputError`."""
    if sp.issparse(A):
        if A.ndim != 2 or A.shape[0] != A.shape[1]:
            raise ExpmInputError(f"A must be square (n, n); got shape {A.shape}")
        if np.iscomplexobj(A.data):
            raise ExpmInputError("A must be real; complex operators are not supported")
        C = sp.csr_array(A, dtype=np.float64)
        if not np.isfinite(C.data).all():
            raise ExpmInputError("A has non-finite entries (inf or NaN)")
        return C, A.shape[0]
    if isinstance(A, spla.LinearOperator):
        if len(A.shape) != 2 or A.shape[0] != A.shape[1]:
            raise ExpmInputError(f"A must be square (n, n); got shape {A.shape}")
        if np.issubdtype(np.dtype(A.dtype), np.complexfloating):
            raise ExpmInputError("A must be real; complex operators are not supported")
        return A, A.shape[0]
    try:
        M = np.asarray(A)
    except (TypeError, ValueError) as exc:
        raise ExpmInputError("A must be a sparse matrix, an ndarray or a LinearOperator") from exc
    if M.ndim != 2 or M.shape[0] != M.shape[1]:
        raise ExpmInputError(f"A must be square (n, n); got shape {M.shape}")
    if np.iscomplexobj(M):
        raise ExpmInputError("A must be real; complex operators are not supported")
    if not (np.issubdtype(M.dtype, np.number) or M.dtype == bool) or not np.isfinite(M).all():
        raise ExpmInputError("A has non-finite or non-numeric entries")
    return M.astype(np.float64, copy=False), M.shape[0]


def _check_block(B: Any, n: int) -> tuple[np.ndarray, np.ndarray, bool]:
    """(B as given, real float64 (n, p) block, complex?): complex B is split into real and
    imaginary columns, which share the products."""
    try:
        Barr = np.asarray(B)
    except (TypeError, ValueError) as exc:
        raise ExpmInputError("B must be an array of shape (n,) or (n, p)") from exc
    if Barr.ndim not in (1, 2) or Barr.shape[0] != n:
        raise ExpmInputError(f"B must have shape ({n},) or ({n}, p); got {Barr.shape}")
    if not (np.issubdtype(Barr.dtype, np.number) or Barr.dtype == bool):
        raise ExpmInputError(f"B must be numeric; got dtype {Barr.dtype}")
    if not np.isfinite(Barr).all():
        rows = np.flatnonzero(~np.isfinite(Barr.reshape(n, -1)).all(axis=1))
        raise ExpmInputError(f"B has non-finite entries in rows {rows[:8].tolist()}")
    B2 = Barr.reshape(n, -1) if Barr.ndim == 1 or n else Barr.reshape(0, Barr.shape[-1])
    is_complex = np.iscomplexobj(Barr)
    if is_complex:
        B2 = np.hstack([B2.real, B2.imag])
    return Barr, np.ascontiguousarray(B2, dtype=np.float64), is_complex


def _check_weights(inner: Any, n: int) -> np.ndarray | None:
    """Positive weights scaled to max 1 (only ratios matter), or None for all ones."""
    if inner is None:
        return None
    w = np.asarray(inner, dtype=float)
    if w.shape != (n,):
        raise ExpmInputError(f"inner must be a weight vector of shape ({n},); got {w.shape}")
    if n == 0:
        return None
    if not (np.isfinite(w).all() and (w > 0).all()):
        bad = np.flatnonzero(~(np.isfinite(w) & (w > 0)))
        raise ExpmInputError(
            f"inner weights must be finite and > 0; bad entries at {bad[:8].tolist()}"
        )
    hi = float(w.max())
    return None if float(w.min()) == hi else w / hi


# ---------------------------------------------------------------------------- counting
class ExpmvCounter(spla.LinearOperator):
    """A LinearOperator that wraps A and counts its products, column by column.

    Use it to count the products of any method that accepts a LinearOperator, e.g.
    ``expm_multiply(ExpmvCounter(A), b, traceA=A.diagonal().sum())``.

    Attributes
    ----------
    matvecs, rmatvecs : int
        Columns multiplied by A and by Aᵀ (a product with an (n, p) block counts p).
    """

    def __init__(self, A: Any) -> None:
        self.A = A
        self.matvecs = 0
        self.rmatvecs = 0
        super().__init__(dtype=np.dtype(getattr(A, "dtype", np.float64)), shape=A.shape)

    def _matvec(self, x: np.ndarray) -> np.ndarray:
        self.matvecs += 1
        return self.A @ x

    def _matmat(self, X: np.ndarray) -> np.ndarray:
        self.matvecs += X.shape[1]
        return self.A @ X

    def _rmatvec(self, x: np.ndarray) -> np.ndarray:
        self.rmatvecs += 1
        return self.A.T @ x

    def _rmatmat(self, X: np.ndarray) -> np.ndarray:
        self.rmatvecs += X.shape[1]
        return self.A.T @ X

    def _adjoint(self) -> spla.LinearOperator:
        return spla.LinearOperator(
            self.shape[::-1], matvec=self._rmatvec, rmatvec=self._matvec, dtype=self.dtype
        )

    @property
    def products(self) -> int:
        """All columns multiplied by A or Aᵀ."""
        return self.matvecs + self.rmatvecs


class _Counted:
    """``op(X)`` = A @ X for X (n, p), counting column products and calls."""

    def __init__(self, A: Any) -> None:
        self.A = A
        self.matvecs = 0
        self.calls = 0

    def __call__(self, X: np.ndarray) -> np.ndarray:
        self.matvecs += X.shape[1]
        self.calls += 1
        Y = self.A @ X
        return np.asarray(Y, dtype=np.float64).reshape(X.shape)


# ---------------------------------------------------------------------------- the bound R
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
    A, n = _check_operator(A)
    if isinstance(A, spla.LinearOperator):
        raise ExpmInputError("skew_bound needs an explicit (sparse or dense) A")
    bound, products = _power_bound(_SkewParts(A, _check_weights(inner, n)), steps)
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
        A, n = _check_operator(A)
        if isinstance(A, spla.LinearOperator):
            raise ExpmInputError("PreparedOperator needs an explicit (sparse or dense) A")
        self.n = n
        self.weights = _check_weights(inner, n)
        norm = _norm_inf(A)
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


def _is_skew(A: Any, w: np.ndarray | None) -> bool:
    """Whether an explicit A is W-skew to round-off (False for a LinearOperator)."""
    if isinstance(A, spla.LinearOperator):
        return False
    return _SkewParts(A, w).is_skew()


# ---------------------------------------------------------------------------- Bessel
def _bessel_table(taus: np.ndarray, kmax: int) -> np.ndarray:
    """J_k(τ_j) for k = 0..kmax, (T, kmax + 1), by Miller's backward recurrence.

    J_{k−1}(x) = (2k/x) J_k(x) − J_{k+1}(x) from an order above the turning point,
    normalized by J_0 + 2 Σ J_{2k} = 1, rescaled when it grows; J_k(−x) = (−1)^k J_k(x).
    Exact to about 1e-15 (relative to 1) for every order and argument.
    """
    x = np.abs(np.asarray(taus, dtype=float))
    T = x.size
    out = np.zeros((T, kmax + 1))
    tiny = x < 1e-300
    out[tiny, 0] = 1.0
    live = np.flatnonzero(~tiny)
    if live.size:
        xs = x[live]
        start = int(max(kmax, xs.max()) + 20 + 2 * np.sqrt(max(kmax, xs.max()))) + 10
        start += start % 2
        jp1 = np.zeros(xs.size)
        jk = np.full(xs.size, 1e-300)
        norm = np.zeros(xs.size)
        for k in range(start, 0, -1):
            jm1 = (2.0 * k / xs) * jk - jp1
            if k - 1 <= kmax:
                out[live, k - 1] = jm1
            if (k - 1) % 2 == 0:
                norm += (1.0 if k - 1 == 0 else 2.0) * jm1
            jp1, jk = jk, jm1
            big = np.abs(jk) > 1e250
            if big.any():
                scale = np.where(big, 1e-250, 1.0)
                jp1 *= scale
                jk *= scale
                norm *= scale
                out[live, k - 1 :] *= scale[:, None]
        out[live] /= norm[:, None]
    odd = np.arange(kmax + 1) % 2 == 1
    neg = np.asarray(taus) < 0
    out[np.ix_(neg, odd)] *= -1.0
    return out


def chebyshev_degree(tau: float, tol: float) -> int:
    r"""Smallest K with :math:`2\sum_{k>K} |J_k(\tau)| \le \mathrm{tol}`: the degree of the
    Chebyshev series of :math:`e^{\tau X}` for :math:`\|X\|_W \le 1`, X W-skew."""
    tau = abs(float(tau))
    top = int(tau + 10 * tau ** (1 / 3) + 60)
    J = np.abs(_bessel_table(np.array([tau]), top)[0])
    tail = 2.0 * np.cumsum(J[::-1])[::-1]  # tail[k] = 2 Σ_{j ≥ k} |J_j|
    above = np.flatnonzero(tail > tol)
    return int(above[-1]) if above.size else 0


# ---------------------------------------------------------------------------- dispatch
def choose_method(
    n: int, times: np.ndarray, skew: bool, radius: float | None
) -> Literal["chebyshev", "krylov"]:
    """The method of ``method="auto"``: the series for W-skew operators once
    R · max|t| ≥ :data:`SERIES_MIN_TAU`, the Krylov method otherwise."""
    span = float(np.abs(times).max()) if times.size else 0.0
    if skew and radius is not None and radius * span >= SERIES_MIN_TAU and n > 2:
        return "chebyshev"
    return "krylov"


def _product_estimate(method: str, radius: float, span: float, p: int, tol: float) -> float:
    """Products a call will take, estimated before it starts (the work budget)."""
    tau = radius * span
    terms = tau + 10.0 * tau ** (1.0 / 3.0) + math.log10(1.0 / tol) + 10.0
    if method == "expm_multiply":
        terms *= 2.0  # its Taylor steps take about twice the series' products
    return p * terms


def expm_action(
    A: Any,
    B: npt.ArrayLike,
    t: float | npt.ArrayLike,
    *,
    tol: float = 1e-10,
    inner: npt.ArrayLike | None = None,
    skew: bool | None = None,
    method: str = "auto",
    norm: Literal["max", "inner"] = "max",
    m_max: int | None = None,
    skew_norm: float | None = None,
    max_products: float = MAX_PRODUCTS,
    progress: Callable[[float], Any] | None = None,
    return_info: bool = False,
) -> np.ndarray | tuple[np.ndarray, dict[str, Any]]:
    r""":math:`e^{t_j A} B` for one or many times :math:`t_j` and right-hand sides.

    Parameters
    ----------
    A : sparse array/matrix, ndarray or LinearOperator, shape (n, n), real
        The generator; for a functional flow, :math:`A = -D^V_v`.
    B : array_like, shape (n,) or (n, p)
        Initial value(s), real or complex (complex B is split into real and imaginary
        columns, which share the products).
    t : float or array_like, shape (T,)
        Times, any sign and order (repeats and zeros allowed).
    tol : float
        Target relative error of every output column, 0 < tol < 1: in the norm of
        ``inner`` and, with ``norm="max"`` (default), in the max norm too.
    inner : array_like, shape (n,), optional
        Positive weights of the inner product :math:`\langle x,y\rangle = x^\top W y` (for
        flows, the vertex areas :math:`A_V`). Default: all ones.
    skew : bool or None
        Whether A is W-skew (:math:`WA + A^\top W = 0`; true for :math:`A = \pm D^V_v`,
        :math:`v = J\nabla g`, on a closed mesh with :math:`W = A_V`). None: decided from
        the entries of an explicit A (a LinearOperator counts as not skew). True on an
        explicit A that is not skew warns (:class:`~fvf.errors.KrylovFallbackWarning`) and
        is ignored.
    method : {"auto", "krylov", "chebyshev", "expm_multiply"}
        See the module docstring; "auto" follows :func:`choose_method`.
    norm : {"max", "inner"}
        Norm(s) of the error control (see ``tol``).
    m_max : int, optional
        Largest Krylov basis per step (default :data:`M_MAX`, less when the basis would
        exceed :data:`BASIS_MEMORY` bytes).
    skew_norm : float, optional
        For the series: an upper bound R of the W-norm of A's skew part (default
        :func:`skew_bound`). A LinearOperator needs it for ``method="chebyshev"``.
    max_products : float
        Refuse (:class:`~fvf.errors.FlowOverflowError`) a call estimated to take more
        column products than this (default :data:`MAX_PRODUCTS`); ``inf`` lifts the cap.
    progress : callable, optional
        Called with the fraction done (0..1) as the work advances.
    return_info : bool
        Also return a dict of statistics.

    Returns
    -------
    X : ndarray, float64 (complex128 for complex B)
        ``B.shape`` for a scalar t, ``(T,) + B.shape`` for an array of times;
        ``X[j] = exp(t_j A) B``.
    info : dict, only with ``return_info``
        ``method`` ("chebyshev", "lanczos", "iom", "expm_multiply", or "zero" for A = 0);
        ``matvecs`` (column products with A); ``block_matvecs`` (operator calls);
        ``steps`` (Krylov bases built); ``basis_sizes`` (their sizes; the number of terms
        for the series); ``error_estimate`` (largest relative error estimate; None for
        expm_multiply); ``skew`` (what was used); ``skew_bound`` (R, for the series);
        ``bound_products`` (products with |A| spent on R, not in ``matvecs``);
        ``wasted_matvecs`` (products of a series that gave way, included in
        ``matvecs``); ``estimated_matvecs`` (the work estimate checked against
        ``max_products``).

    Raises
    ------
    ExpmInputError
        Non-square, complex or non-numeric A; B of the wrong shape; non-finite A, B, t or
        weights; weights ≤ 0; tol outside (0, 1); unknown method, norm or skew value;
        m_max < 1; skew_norm not a finite number > 0.
    FlowOverflowError
        (also a FloatingPointError) The result overflowed to inf/NaN; or
        max|t| · ‖A‖_∞ exceeds :data:`MAX_SPAN`; or the estimated work exceeds
        ``max_products`` (the message gives the estimate).

    Warns
    -----
    KrylovFallbackWarning
        ``skew=True`` for an A that is not skew, or ``method="chebyshev"`` whose series
        failed its checks (the Krylov method was used).

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> from fvf.numerics import expm_action
    >>> A = sp.diags_array([np.ones(49), -np.ones(49)], offsets=[1, -1])  # skew
    >>> b = np.sin(np.linspace(0, 3, 50))
    >>> x = expm_action(A, b, [0.5, -1.0, 2.0])
    >>> x.shape, bool(np.allclose(np.linalg.norm(x, axis=1), np.linalg.norm(b)))
    ((3, 50), True)
    """
    if isinstance(A, PreparedOperator):
        if inner is not None:
            raise ExpmInputError("a PreparedOperator carries its inner product; pass inner=None")
        prepared: PreparedOperator | None = A
    else:
        A, n = _check_operator(A)
        prepared = None if isinstance(A, spla.LinearOperator) else PreparedOperator(A, inner)
    n = prepared.n if prepared is not None else A.shape[0]
    w = prepared.weights if prepared is not None else _check_weights(inner, n)
    times, scalar = as_times(t)
    method, tol = check_options(method, tol)
    _check_flags(m_max, norm, skew, skew_norm, max_products)
    Barr, B2, is_complex = _check_block(B, n)
    p = B2.shape[1]
    info: dict[str, Any] = {
        "method": None,
        "matvecs": 0,
        "block_matvecs": 0,
        "steps": 0,
        "basis_sizes": [],
        "error_estimate": 0.0,
        "skew": skew,
        "skew_bound": None,
        "bound_products": 0,
        "wasted_matvecs": 0,
        "estimated_matvecs": 0.0,
    }
    out = np.zeros((times.size, n, p))
    a_norm = prepared.norm_inf if prepared is not None else _norm_inf(A)
    if n and p and times.size and not a_norm == 0.0:
        if prepared is not None:
            A, times = prepared.A, times * prepared.scale
            skew_norm = None if skew_norm is None else skew_norm / prepared.scale
        skew = _settle_skew(prepared, skew, times, a_norm, info)
        method, radius = _decide(A, prepared, times, skew, skew_norm, method, info)
        _check_work(method, radius, times, p, tol, max_products, n, info)
        _run(A, B2, times, out, info, method, radius, tol, w, skew, norm, m_max, progress)
    elif n and p:
        out[:] = B2  # A = 0 (or no times): exp(tA) = I
        info["method"] = "zero"
    if not np.isfinite(out).all():
        raise FlowOverflowError(
            "the exponential overflowed to inf/NaN: the solution grows beyond floating "
            "point at these times (shorten t, or use a flow that cannot grow)"
        )
    if info["skew"] and info["method"] in ("chebyshev", "lanczos"):
        _restore_norms(out, B2, w, tol)
    res = out[:, :, : p // 2] + 1j * out[:, :, p // 2 :] if is_complex else out
    res = res.reshape((times.size,) + Barr.shape)
    if scalar:
        res = res[0]
    if progress is not None:
        progress(1.0)
    return (res, info) if return_info else res


def _restore_norms(out: np.ndarray, B2: np.ndarray, w: np.ndarray | None, tol: float) -> None:
    """For a W-skew A, e^{tA} is W-unitary: scale each output column to its initial W-norm
    where it is already within tol of it (so norms are kept to round-off, and the answer
    moves by less than tol)."""
    b = _wnorm(B2, w)  # (p,)
    for X in out:  # (n, p) per time
        x = _wnorm(X, w)
        ratio = np.divide(b, x, out=np.ones_like(b), where=x > 0)
        ratio[np.abs(ratio - 1.0) > tol] = 1.0
        X *= ratio


def _check_flags(m_max: Any, norm: Any, skew: Any, skew_norm: Any, max_products: Any) -> None:
    if m_max is not None and (isinstance(m_max, bool) or int(m_max) != m_max or m_max < 1):
        raise ExpmInputError(f"m_max must be a positive integer; got {m_max!r}")
    if norm not in ("max", "inner"):
        raise ExpmInputError(f"norm must be 'max' or 'inner'; got {norm!r}")
    if skew not in (None, True, False):
        raise ExpmInputError(f"skew must be None, True or False; got {skew!r}")
    if skew_norm is not None and not (
        isinstance(skew_norm, int | float | np.floating)
        and math.isfinite(skew_norm)
        and skew_norm > 0
    ):
        raise ExpmInputError(f"skew_norm must be a finite number > 0; got {skew_norm!r}")
    if not (isinstance(max_products, int | float | np.floating) and max_products > 0):
        raise ExpmInputError(f"max_products must be a number > 0; got {max_products!r}")


def _norm_inf(A: Any) -> float:
    """‖A‖_∞ of an explicit A (max absolute row sum); for a LinearOperator its
    ``norm_inf`` attribute when it has one (an upper bound), else NaN (unknown)."""
    if isinstance(A, spla.LinearOperator):
        bound = getattr(A, "norm_inf", None)
        return float(bound) if isinstance(bound, int | float) else math.nan
    if sp.issparse(A):
        if A.nnz == 0:
            return 0.0
        return float(np.max(abs(A) @ np.ones(A.shape[1])))
    return float(np.abs(A).sum(axis=1).max()) if A.size else 0.0


def _settle_skew(
    prepared: PreparedOperator | None,
    skew: bool | None,
    times: np.ndarray,
    a_norm: float,
    info: dict,
) -> bool:
    """Refuse out-of-reach spans and settle whether A is W-skew (measured for an explicit
    A; as declared for a LinearOperator)."""
    if math.isfinite(a_norm):
        span = float(np.abs(times).max()) * a_norm
        if not span <= MAX_SPAN:
            raise FlowOverflowError(
                f"max|t| x ||A||_inf = {span:.3g} exceeds {MAX_SPAN:.0e}: the exponential "
                "needs so many steps that each underflows relative to t. Shorten t or "
                "rescale A (for a flow, a field of speed s for time t moves s*t)."
            )
    if prepared is None:
        result = bool(skew)
    elif skew is False:
        result = False
    else:
        result = prepared.is_skew
        if skew is True and not result:
            warnings.warn(
                "skew=True but A is not skew-adjoint in the given inner product; used the "
                "general method",
                KrylovFallbackWarning,
                stacklevel=3,
            )
    info["skew"] = result
    return result


def _decide(
    A: Any,
    prepared: PreparedOperator | None,
    times: np.ndarray,
    skew: bool,
    skew_norm: float | None,
    method: str,
    info: dict,
) -> tuple[str, float]:
    """The method to run and the radius R it uses (the series' bound, or the work scale)."""
    span = float(np.abs(times).max())
    if skew_norm is not None:
        radius = float(skew_norm)
    elif prepared is not None and (method == "chebyshev" or (method == "auto" and skew)):
        if method == "auto" and prepared.gershgorin * span < SERIES_MIN_TAU:
            radius = prepared.gershgorin  # no power steps: the series is out of the question
        else:
            radius, info["bound_products"] = prepared.bound()
    elif prepared is not None:
        radius = prepared.norm_inf
    else:
        if method == "chebyshev":
            raise ExpmInputError(
                "method='chebyshev' on a LinearOperator needs skew_norm (a bound of the "
                "norm of its skew-adjoint part)"
            )
        radius = _norm_inf(A)  # its norm_inf when it has one, else NaN (no work estimate)
    if method == "auto":
        method = choose_method(A.shape[0], times, skew, radius)
    if method == "chebyshev" and radius == 0.0:
        method = "krylov"  # A is W-symmetric: no strip to expand in
    return method, radius


def _check_work(
    method: str,
    radius: float,
    times: np.ndarray,
    p: int,
    tol: float,
    max_products: float,
    n: int,
    info: dict,
) -> None:
    """Refuse a call whose estimated products exceed ``max_products``."""
    if not math.isfinite(radius):
        return  # a LinearOperator without a known norm: no estimate
    span = float(np.abs(times).max())
    est = _product_estimate(method, radius, span, p, tol)
    info["estimated_matvecs"] = est
    if est > max_products:
        raise FlowOverflowError(
            f"this exponential needs about {est:.3g} products with the {n} x {n} operator "
            f"(norm scale {radius:.3g} x max|t| {span:.3g}; {p} column(s)), more than "
            f"max_products={max_products:.3g}. Shorten t, flow fewer columns, use "
            "method='upwind' (a flow with a maximum principle), or raise max_products "
            "(and pass progress= to follow it)."
        )


def _run(
    A: Any,
    B2: np.ndarray,
    times: np.ndarray,
    out: np.ndarray,
    info: dict,
    method: str,
    radius: float,
    tol: float,
    w: np.ndarray | None,
    skew: bool,
    norm: str,
    m_max: int | None,
    progress: Callable[[float], Any] | None,
) -> None:
    op = _Counted(A)
    with np.errstate(over="ignore", invalid="ignore"):
        if method == "expm_multiply":
            _run_expm_multiply(A, B2, times, out, info)
            return
        if method == "chebyshev":
            info["skew_bound"] = radius
            done = _run_chebyshev(op, B2, times, out, info, tol, w, norm == "max", radius, skew)
            if done:
                _count(op, info)
                return
            info["wasted_matvecs"] = op.matvecs
            warnings.warn(
                "the Chebyshev series' terms grew (the operator is far from skew); used "
                "the Krylov method",
                KrylovFallbackWarning,
                stacklevel=3,
            )
        _run_krylov(op, B2, times, out, info, tol, w, skew, norm == "max", m_max, progress)
    _count(op, info)


def _count(op: _Counted, info: dict) -> None:
    info["matvecs"] = op.matvecs
    info["block_matvecs"] = op.calls


def _run_expm_multiply(
    A: Any, B2: np.ndarray, times: np.ndarray, out: np.ndarray, info: dict
) -> None:
    """scipy's expm_multiply chained over the sorted times of each sign, counted."""
    info["method"] = "expm_multiply"
    info["error_estimate"] = None
    counter = ExpmvCounter(A)
    trace = getattr(A, "trace", None)  # a LinearOperator may know its exact trace
    if hasattr(A, "diagonal"):
        trace = float(A.diagonal().sum())
    trace = trace if isinstance(trace, int | float) else None
    for sign in (1.0, -1.0):
        pick = np.flatnonzero(sign * times > 0)
        order = pick[np.argsort(sign * times[pick], kind="stable")]
        current, now = B2, 0.0
        op = counter if sign > 0 else -counter
        for i in order:
            dt = sign * times[i] - now
            if dt > 0:
                current = spla.expm_multiply(
                    op * dt, current, traceA=None if trace is None else sign * trace * dt
                )
                now = sign * times[i]
            out[i] = current
    out[times == 0] = B2
    info["matvecs"] = counter.products
    info["block_matvecs"] = counter.products


# ---------------------------------------------------------------------------- the series
def _wnorm(X: np.ndarray, w: np.ndarray | None) -> np.ndarray:
    """W-norms of the columns of X (n, p): (p,)."""
    if X.shape[1] == 1:  # one column: BLAS dots (a three-operand einsum is 5x slower)
        x = X[:, 0]
        return np.array([math.sqrt(float(np.dot(x if w is None else w * x, x)))])
    if w is None:
        return np.sqrt(np.einsum("ij,ij->j", X, X))
    return np.sqrt(np.einsum("i,ij,ij->j", w, X, X))


def _series_tol(tol: float, w: np.ndarray | None, B2: np.ndarray, maxnorm: bool) -> np.ndarray:
    """Per-column tolerance on the W-norm of the truncation error that meets ``tol``
    relative to the column's W-norm and, with ``maxnorm``, to its max norm
    (max|x| ≤ ‖x‖_W / √min w)."""
    target = SERIES_SAFETY * tol * np.ones(B2.shape[1])
    if maxnorm and B2.shape[0]:
        wmin = 1.0 if w is None else float(w.min())
        ratio = np.abs(B2).max(axis=0) * math.sqrt(wmin) / np.maximum(_wnorm(B2, w), 1e-300)
        target *= np.minimum(1.0, ratio)
    return target


def _run_chebyshev(
    op: _Counted,
    B2: np.ndarray,
    times: np.ndarray,
    out: np.ndarray,
    info: dict,
    tol: float,
    w: np.ndarray | None,
    maxnorm: bool,
    R: float,
    skew: bool,
) -> bool:
    r"""The Jacobi–Anger series of all times at once; False when it must give way.

    Skew A: the degree K is a priori (:func:`chebyshev_degree` at the per-column target
    of :func:`_series_tol`). Otherwise the series runs to the a-priori degree of a skew
    operator of the same R and checks a posteriori that its last terms fall below the
    target (their W-norms times 2|J_k|); terms growing past 1e3 ‖B‖ abandon it.
    """
    info["method"] = "chebyshev"
    n, p = B2.shape
    taus = R * times
    target = _series_tol(tol, w, B2, maxnorm)
    K = chebyshev_degree(float(np.abs(taus).max()), float(target.min()))
    extra = 0 if skew else 8 + K // 4  # room for the a-posteriori stop
    coef = _bessel_table(taus, K + extra)  # (T, K+extra+1)
    coef[:, 1:] *= 2.0
    flat = out.reshape(times.size, n * p)
    flat[:] = coef[:, :1] * B2.reshape(1, -1)
    bnorm = np.maximum(_wnorm(B2, w), 1e-300)
    prev, cur = B2, op(B2) / R
    chunk = max(1, min(32, int(BASIS_MEMORY // 16 // max(8 * n * p, 1))))
    buf = np.empty((chunk, n * p))
    filled, k0, k = 0, 1, 1
    quiet = 0
    while True:
        buf[filled] = cur.reshape(-1)
        filled += 1
        if filled == chunk or k == K + extra:
            flat += coef[:, k0 : k0 + filled] @ buf[:filled]
            k0, filled = k0 + filled, 0
        if not skew:
            size = _wnorm(cur, w) / bnorm
            if not np.isfinite(size).all() or size.max() > 1e3:
                return False
            quiet = quiet + 1 if (np.abs(coef[:, k]).max() * size <= target).all() else 0
            if k >= K and quiet >= 4:
                break
            if k == K + extra:
                return False
        elif k == K:
            break
        nxt = op(cur)
        nxt *= 2.0 / R
        nxt += prev
        prev, cur = cur, nxt
        k += 1
    if filled:
        flat += coef[:, k0 : k0 + filled] @ buf[:filled]
    info["basis_sizes"] = [k]
    info["error_estimate"] = float(target.max() / SERIES_SAFETY)
    return True


# ---------------------------------------------------------------------------- small dense
#: Largest condition number of an eigenvector basis used for exp(sM) = V e^{sΛ} V⁻¹.
EIG_COND_MAX = 1e6


def dense_expm_action(M: npt.ArrayLike, b: npt.ArrayLike, times: npt.ArrayLike) -> np.ndarray:
    r""":math:`e^{t_j M} b` for a small dense M (k, k) and many times: (T, k).

    With a well-conditioned eigenbasis (:math:`\kappa(V) \le` :data:`EIG_COND_MAX`),
    :math:`e^{tM}b = V e^{t\Lambda} V^{-1} b` for every t at O(k²) each, whatever |t|;
    otherwise ``scipy.linalg.expm`` per time (scaling and squaring: O(k³ log|t|)). Real M
    and b give a real result.

    Parameters
    ----------
    M : array_like (k, k), real
    b : array_like (k,), real
    times : array_like (T,)

    Returns
    -------
    ndarray float64 (T, k)
    """
    M = np.asarray(M, dtype=float)
    b = np.asarray(b, dtype=float)
    times = np.atleast_1d(np.asarray(times, dtype=float))
    k = M.shape[0]
    if k == 0 or times.size == 0:
        return np.zeros((times.size, k))
    lam, V = np.linalg.eig(M)
    cond = np.linalg.cond(V)
    if np.isfinite(cond) and cond <= EIG_COND_MAX and times.size > 1:
        coef = np.linalg.solve(V, b.astype(complex))  # (k,)
        with np.errstate(over="ignore", invalid="ignore"):
            E = np.exp(np.outer(times, lam)) * coef  # (T, k)
            return (E @ V.T).real
    return np.stack([sla.expm(s * M) @ b for s in times])


# ---------------------------------------------------------------------------- Krylov
class _SmallExp:
    r"""The small exponentials of a step: :math:`e^{sH}e_1` for any s, per column.

    Skew H (tridiagonal, zero diagonal, :math:`h_{j,j+1} = -h_{j+1,j}`): from the
    eigen-decomposition of the real symmetric :math:`T` with :math:`D^{-1}HD = -iT`,
    :math:`D = \mathrm{diag}(i^k)`. General H: ``scipy.linalg.expm`` of the dense m × m
    matrix, stepped along a grid.
    """

    def __init__(self, H: np.ndarray, skew: bool) -> None:
        self.H = H  # (m, m)
        self.m = H.shape[0]
        self.skew = skew
        if skew:
            off = np.diag(H, -1)
            if self.m == 1:
                self.lam, self.V = np.zeros(1), np.ones((1, 1))
            else:
                self.lam, self.V = sla.eigh_tridiagonal(np.zeros(self.m), off)
            self.phase = (1j) ** np.arange(self.m)
            sym = np.zeros(1)
        else:
            sym = np.linalg.eigvalsh(0.5 * (H + H.T))
        self.mu = max(float(sym.max()), 0.0)  # logarithmic norm of H (0 for skew)

    def at(self, s: np.ndarray) -> np.ndarray:
        """:math:`e^{s_g H}e_1` for the times s (G,): (G, m)."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        if self.skew:
            E = np.exp(-1j * np.outer(s, self.lam)) * self.V[0]  # (G, m)
            return ((E @ self.V.T) * self.phase).real
        e1 = np.zeros(self.m)
        e1[0] = 1.0
        return dense_expm_action(self.H, e1, s)

    def on_grid(self, hi: float) -> np.ndarray:
        """:math:`e^{s H}e_1` on the uniform grid s = 0, hi/G, …, hi: (G + 1, m)."""
        s = np.linspace(0.0, hi, _GRID + 1)
        if self.skew:
            return self.at(s)
        step = sla.expm((hi / _GRID) * self.H)
        out = np.empty((_GRID + 1, self.m))
        out[0] = 0.0
        out[0, 0] = 1.0
        for g in range(_GRID):
            out[g + 1] = step @ out[g]
        return out


def _step_errors(small: _SmallExp, h_next: float, hi: float) -> np.ndarray:
    r"""Error bound of the step's solution at the grid times s_g ∈ [0, hi], relative to
    ‖y‖_W: :math:`\int_0^{s} e^{\mu(s-\sigma)} h_{m,m-1}|[e^{\sigma H}e_1]_{m-1}|d\sigma`."""
    c = small.on_grid(hi)
    r = h_next * np.abs(c[:, -1])  # (G + 1,)
    s = np.linspace(0.0, hi, _GRID + 1)
    with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
        decay = np.exp(-small.mu * s)  # (underflows where the step would grow past reach)
        integrand = r * decay
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (integrand[1:] + integrand[:-1]))])
        cum *= hi / _GRID
        err = cum / decay
    return np.where(np.isnan(err), np.inf, err)


class _Basis:
    """One Krylov basis of a step for p columns at once: U (m_max + 1, n, p), the
    per-column Hessenberg matrices H (p, m_max + 1, m_max), in the W inner product."""

    def __init__(self, n: int, p: int, m_cap: int, w: np.ndarray | None, skew: bool):
        self.U = np.empty((m_cap + 1, n, p))
        self.H = np.zeros((p, m_cap + 1, m_cap + 1))
        self.w = w
        self.skew = skew
        self.m = 0
        self.exact = np.zeros(p, dtype=bool)  # invariant subspace reached (h = 0)

    def start(self, Y: np.ndarray) -> np.ndarray:
        beta = _wnorm(Y, self.w)
        self.U[0] = Y / np.where(beta > 0, beta, 1.0)
        self.H[:] = 0.0
        self.m = 0
        self.exact = beta == 0
        self.top = np.full(Y.shape[1], 1e-300)  # largest |h| so far (breakdown scale)
        return beta

    def extend(self, op: Callable[[np.ndarray], np.ndarray]) -> None:
        """Add one vector to every column's basis (Lanczos for skew, else IOM)."""
        j = self.m
        Wj = op(self.U[j])
        if self.skew:
            if j > 0:
                Wj += self.H[:, j, j - 1] * self.U[j - 1]
        else:  # W-orthogonalize against the window (classical Gram-Schmidt: two GEMVs)
            lo = max(0, j - IOM_WINDOW + 1)
            win = self.U[lo : j + 1]  # (k, n, p)
            if Wj.shape[1] == 1:
                y = Wj[:, 0] if self.w is None else self.w * Wj[:, 0]
                hs = win[:, :, 0] @ y  # (k,)
                Wj[:, 0] -= hs @ win[:, :, 0]
                hs = hs[:, None]
            else:
                wW = Wj if self.w is None else self.w[:, None] * Wj
                hs = np.einsum("kij,ij->kj", win, wW)  # (k, p)
                Wj -= np.einsum("kij,kj->ij", win, hs)
            self.H[:, lo : j + 1, j] = hs.T
            self.top = np.maximum(self.top, np.abs(hs).max(axis=0))
        h = _wnorm(Wj, self.w)
        self.exact |= h <= 1e-14 * self.top
        h[self.exact] = 0.0
        self.top = np.maximum(self.top, h)
        self.H[:, j + 1, j] = h
        if self.skew:
            self.H[:, j, j + 1] = -h
        np.divide(Wj, np.where(h > 0, h, 1.0), out=self.U[j + 1])
        self.m = j + 1

    def small(self, c: int) -> tuple[_SmallExp, float]:
        """Column c's small exponential of H_m and h_{m,m−1}."""
        m = self.m
        return _SmallExp(self.H[c, :m, :m], self.skew), float(self.H[c, m, m - 1])


def _max_factor(basis: _Basis, Y: np.ndarray, beta: np.ndarray, maxnorm: bool) -> np.ndarray:
    """Scale of the error in the max norm relative to the W norm, per column: the error
    lies mostly along u_m, which on graded meshes concentrates where cells are small."""
    if not maxnorm:
        return np.ones(Y.shape[1])
    um = np.abs(basis.U[basis.m]).max(axis=0)
    ym = np.maximum(np.abs(Y).max(axis=0), 1e-300)
    return np.maximum(1.0, um / (ym / np.where(beta > 0, beta, 1.0)))


def _krylov_step(
    op: Callable[[np.ndarray], np.ndarray],
    basis: _Basis,
    Y: np.ndarray,
    rem: float,
    T: float,
    tol: float,
    maxnorm: bool,
    m_cap: int,
) -> tuple[float, list[_SmallExp], np.ndarray, float]:
    """Grow one basis from Y until the interval ``rem`` meets the budget SAFETY·tol·s/T
    (or the basis is full, then cut the step). Returns (step s, small exponentials per
    column, ‖Y‖_W per column, largest relative error estimate)."""
    beta = basis.start(Y)
    p = Y.shape[1]
    next_check = 8
    while True:
        basis.extend(op)
        m = basis.m
        if m < next_check and m < m_cap and not basis.exact.all():
            continue

        factor = _max_factor(basis, Y, beta, maxnorm)
        errs = np.zeros((p, _GRID + 1))
        smalls = []
        for c in range(p):
            small, h_next = basis.small(c)
            smalls.append(small)
            if not basis.exact[c] and beta[c] > 0:
                errs[c] = factor[c] * _step_errors(small, h_next, rem)
        budget = SAFETY * tol * np.linspace(0.0, rem, _GRID + 1) / T
        worst = errs.max(axis=0)
        if worst[-1] <= budget[-1] or basis.exact.all():
            return rem, smalls, beta, float(worst[-1] / max(budget[-1], 1e-300) * tol * SAFETY)
        if m >= m_cap:
            return _cut_step(basis, smalls, beta, factor, rem, T, tol)
        # the error stalls until m ≈ τ = ρ·s (ρ ≈ twice the mean subdiagonal of H, the
        # extent of the spectrum the basis sees), then falls like the Chebyshev series'
        # tail: the next check goes near that series' degree
        rho = 2.0 * float(np.diagonal(basis.H[:, 1 : m + 1, :m], axis1=1, axis2=2).mean())
        tau = rho * rem
        next_check = max(m + max(2, m // 8), min(int(tau + 4.0 * tau ** (1 / 3) + 6), m_cap))


def _cut_step(
    basis: _Basis,
    smalls: list[_SmallExp],
    beta: np.ndarray,
    factor: np.ndarray,
    rem: float,
    T: float,
    tol: float,
) -> tuple[float, list[_SmallExp], np.ndarray, float]:
    """The longest step within budget of a full basis: the grid over [0, hi] is searched
    with hi = rem, rem/G, rem/G², … until a grid time meets SAFETY·tol·s/T."""
    hi = rem
    while hi > rem * 1e-12:
        errs = np.zeros(_GRID + 1)
        for c, small in enumerate(smalls):
            if not basis.exact[c] and beta[c] > 0:
                h_next = float(basis.H[c, basis.m, basis.m - 1])
                errs = np.maximum(errs, factor[c] * _step_errors(small, h_next, hi))
        budget = SAFETY * tol * np.linspace(0.0, hi, _GRID + 1) / T
        ok = np.flatnonzero(errs[1:] <= budget[1:])
        if ok.size:
            g = int(ok[-1]) + 1
            return hi * g / _GRID, smalls, beta, float(errs[g] / budget[g] * tol * SAFETY)
        hi /= _GRID
    raise FlowOverflowError(
        f"the Krylov method could not meet tol on a step of {hi:.3g} of this flow (basis of "
        f"{basis.m} vectors): the solution grows or oscillates faster than floating point "
        "can follow. Raise tol or m_max, or shorten t."
    )


def _run_krylov(
    op: _Counted,
    B2: np.ndarray,
    times: np.ndarray,
    out: np.ndarray,
    info: dict,
    tol: float,
    w: np.ndarray | None,
    skew: bool,
    maxnorm: bool,
    m_max: int | None,
    progress: Callable[[float], Any] | None,
) -> None:
    """Adaptive Krylov time stepping: one sweep per sign of t over the sorted |t|."""
    info["method"] = "lanczos" if skew else "iom"
    n, p = B2.shape
    m_want = M_MAX if m_max is None else int(m_max)
    m_want = max(1, min(m_want, n))
    group = max(1, min(p, int(BASIS_MEMORY // (8 * n * (m_want + 1)))))
    m_cap = max(1, min(m_want, int(BASIS_MEMORY // (8 * n * group)) - 1))
    out[times == 0] = B2
    plus, minus = times[times > 0], -times[times < 0]
    total = (plus.max() if plus.size else 0.0) + (minus.max() if minus.size else 0.0)
    done = 0.0
    for sign in (1.0, -1.0):
        pick = np.flatnonzero(sign * times > 0)
        if pick.size == 0:
            continue
        order = pick[np.argsort(sign * times[pick], kind="stable")]
        taus = sign * times[order]
        signed = _Signed(op, sign)
        for c0 in range(0, p, group):
            cols = slice(c0, min(p, c0 + group))
            basis = _Basis(n, cols.stop - cols.start, m_cap, w, skew)
            Y, now, T, k = B2[:, cols], 0.0, float(taus[-1]), 0
            while k < taus.size:
                s, smalls, beta, est = _krylov_step(
                    signed, basis, Y, T - now, T, tol, maxnorm, m_cap
                )
                info["steps"] += 1
                info["basis_sizes"].append(basis.m)
                info["error_estimate"] = max(info["error_estimate"], est)
                end = now + s if now + s < T else T
                inside = k + int(np.searchsorted(taus[k:], end, side="right"))
                if inside > k:
                    out[order[k:inside], :, cols] = _combine(
                        basis, smalls, beta, taus[k:inside] - now
                    )
                if inside < taus.size:
                    Y = _combine(basis, smalls, beta, np.array([end - now]))[0]
                if progress is not None and c0 == 0:
                    done += end - now
                    progress(min(done / total, 1.0))
                now, k = end, inside


class _Signed:
    """sign · A as an operator, counting into the caller's counter."""

    def __init__(self, op: _Counted, sign: float) -> None:
        self.op = op
        self.sign = sign

    def __call__(self, X: np.ndarray) -> np.ndarray:
        Y = self.op(X)
        if self.sign < 0:
            Y *= -1.0
        return Y


def _combine(basis: _Basis, smalls: list[_SmallExp], beta: np.ndarray, s: np.ndarray) -> np.ndarray:
    """y(τ₀ + s_k) = ‖y‖_W U_m e^{s_k H_m} e_1 for the times s (K,), per column: (K, n, p),
    one GEMM per column."""
    m = basis.m
    n, p = basis.U.shape[1], basis.U.shape[2]
    Y = np.empty((s.size, n, p))
    for c in range(p):
        coef = beta[c] * smalls[c].at(s)  # (K, m)
        Y[:, :, c] = coef @ basis.U[:m, :, c]
    return Y
