"""The inputs of :func:`fvf.numerics.expm.expm_action`: validation, the call's work
(:class:`ExpmJob`), product counting and the norms every method measures with.

Shared by the dispatcher (:mod:`fvf.numerics.expm`) and its three methods
(:mod:`.expm_chebyshev`, :mod:`.expm_krylov`, :mod:`.expm_multiply`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import ExpmInputError
from .summary import html_repr, short_repr

__all__ = [
    "as_times",
    "check_options",
    "check_operator",
    "check_block",
    "check_weights",
    "check_flags",
    "ExpmJob",
    "signed_sweeps",
    "ExpmvCounter",
    "CountedOperator",
    "weighted_norms",
    "norm_inf",
    "METHODS",
    "BASIS_MEMORY",
]

#: The methods of :func:`~fvf.numerics.expm.expm_action`.
METHODS = ("auto", "krylov", "chebyshev", "expm_multiply")
#: Bytes of a Krylov basis or of the series' buffered terms.
BASIS_MEMORY = 2**30


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


def check_operator(A: Any) -> tuple[Any, int]:
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


def check_block(B: Any, n: int) -> tuple[np.ndarray, np.ndarray, bool]:
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


def check_weights(inner: Any, n: int) -> np.ndarray | None:
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


def check_flags(m_max: Any, norm: Any, skew: Any, skew_norm: Any, max_products: Any) -> None:
    """Check the keyword options of :func:`~fvf.numerics.expm.expm_action`.

    Raises
    ------
    ExpmInputError
        ``m_max`` not a positive integer, ``norm`` not "max" or "inner", ``skew`` not
        None/True/False, ``skew_norm`` not a finite number > 0, ``max_products`` not > 0.
    """
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


# ---------------------------------------------------------------------------- the work
@dataclass
class ExpmJob:
    """One call of :func:`~fvf.numerics.expm.expm_action` as its methods see it.

    Attributes
    ----------
    B2 : ndarray float64 (n, p)
        The real block (complex columns split into real and imaginary parts).
    times : ndarray float64 (T,)
        The times, any sign and order.
    out : ndarray float64 (T, n, p)
        Filled in place: ``out[j] = exp(times[j] A) B2``.
    info : dict
        The statistics returned with ``return_info`` (filled in place).
    tol : float
        Target relative error of every column.
    w : ndarray float64 (n,) or None
        Weights of the inner product, scaled to max 1 (None: all ones).
    skew : bool
        Whether A is W-skew.
    maxnorm : bool
        Whether the error is also controlled in the max norm.
    m_max : int or None
        Largest Krylov basis per step (None: the Krylov method's default).
    progress : callable or None
        Called with the fraction done (0..1).
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    B2: np.ndarray
    times: np.ndarray
    out: np.ndarray
    info: dict
    tol: float
    w: np.ndarray | None
    skew: bool
    maxnorm: bool
    m_max: int | None = None
    progress: Callable[[float], Any] | None = None


def signed_sweeps(times: np.ndarray) -> list[tuple[float, np.ndarray]]:
    """The sweeps of a time-stepping method: (+1, indices of the positive times by
    increasing t), then (−1, indices of the negative times by increasing |t|); a sign
    without times is left out. Zero times belong to neither."""
    sweeps = []
    for sign in (1.0, -1.0):
        pick = np.flatnonzero(sign * times > 0)
        if pick.size:
            sweeps.append((sign, pick[np.argsort(sign * times[pick], kind="stable")]))
    return sweeps


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


class CountedOperator:
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


# ---------------------------------------------------------------------------- norms
def weighted_norms(X: np.ndarray, w: np.ndarray | None) -> np.ndarray:
    """W-norms of the columns of X (n, p): (p,)."""
    if X.shape[1] == 1:  # one column: BLAS dots (a three-operand einsum is 5x slower)
        x = X[:, 0]
        return np.array([math.sqrt(float(np.dot(x if w is None else w * x, x)))])
    if w is None:
        return np.sqrt(np.einsum("ij,ij->j", X, X))
    return np.sqrt(np.einsum("i,ij,ij->j", w, X, X))


def norm_inf(A: Any) -> float:
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
