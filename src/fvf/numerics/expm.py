"""The action of the matrix exponential, exp(t A) B, by a Chebyshev series or adaptive
Krylov time stepping.

:func:`expm_action` computes exp(t_j A) B for many times t_j (any sign and order) and many
right-hand sides B (n, p) in one pass, without forming exp(A). It is built for the
functional flows of :mod:`fvf.flow`, Φ_{v,t} f = exp(−t D^V_v) f: A = −D^V_v is sparse
with about 7 non-zeros per row and, for divergence-free fields v = J grad g, skew-adjoint
in the A_V inner product ⟨x, y⟩ = xᵀ [A_V] y (CHAPTER.md, "Facts we measured"). Its
spectrum lies near the imaginary axis, in the strip |Im z| ≤ R of a bound R of the norm
of its A_V-skew part (:func:`skew_bound`), whatever the field.

Chebyshev series (``method="chebyshev"``; ``"auto"`` from R·max|t| ≥ a threshold)
------------------------------------------------------------------------------
exp(tA) = J₀(Rt) I + 2 Σ_{k≥1} J_k(Rt) P_k(A/R) (Jacobi–Anger), with the real three-term
recurrence P_{k+1} = 2(A/R)P_k + P_{k−1}: one product and no inner products per term, all
times and columns from the same terms, a stop on the measured last terms near the degree
that is a rigorous bound in the A_V norm for skew-adjoint A (:func:`chebyshev_degree`), and a
fallback to the Krylov method when the terms grow (non-normal or real spectra). It needs
more products than Krylov (R·|t| + O(|Rt|^{1/3} + log 1/tol), R ≥ the spectral radius;
for long flows of blocks of an operator not declared skew, R is 1.02× a Lanczos estimate
of ‖K‖_W instead, see :func:`_bound`) but runs close to the time of its products; see
:func:`_run_chebyshev`.

Krylov time stepping (``method="krylov"``)
------------------------------------------
Saad 1992; Gallopoulos & Saad 1992; Hochbruck & Lubich 1997; the step control of
Expokit-type integrators. Each sign of t is one sweep over the sorted |t_j|. A step
starts from the current state y and builds a basis u_0 = y/‖y‖, u_1, … of the Krylov
space K_m(A, y) with A U_m = U_m H_m + h_m u_m e_mᵀ, in the inner product
⟨x, y⟩_W = xᵀ diag(w) y of ``inner``.

* Skew-adjoint A (W A + Aᵀ W = 0): H_m is tridiagonal with zero diagonal and the basis
  comes from a three-term recurrence — one product and three vector passes per basis
  vector, whatever m. The vectors are stored unnormalized (y_j = ν_j u_j, which saves a
  pass) and the p columns of B run simultaneous recurrences, so each product is one
  sparse product on an (n, p) block. exp(s H_m) e_1 is exact and cheap for any s: with
  D = diag(iᵏ), D⁻¹ H_m D = −i T_m, T_m symmetric tridiagonal with zero diagonal, whose
  eigen-decomposition is an SVD of a bidiagonal matrix of half the size (see
  :class:`_SkewExp`); with numba, the Chebyshev series of H_m itself, compiled, makes an
  error check 1.6–4.8× cheaper (m = 50–110, :class:`_SkewExpSeries`).
* Otherwise: incomplete orthogonalization (each vector is W-orthogonalized against the
  last :data:`IOM_WINDOW` ones, so a basis vector costs O(n) work, not O(n m)); H_m is
  banded Hessenberg and its small exponentials are dense (scipy.linalg.expm). The Krylov
  relation holds exactly whatever the window (Koskela 2015; Vo & Sidje 2017).
* y(τ₀ + s) ≈ ‖y‖ U_m exp(s H_m) e_1 for every s of the step: all requested times inside
  a step come from the same basis (dense output; one GEMM for all of them).
* A posteriori error control. The Krylov solution solves the ODE up to the residual
  r(s) = ‖y‖ h_m [exp(s H_m) e_1]_{m−1} u_m, so its error at s is
  ∫_0^s exp((s − σ)A) r(σ) dσ. In the skew case exp(sA) is W-unitary and the error is at
  most ∫_0^s |r(σ)| dσ; otherwise the propagator is bounded by e^{μ(s − σ)}, μ the
  logarithmic norm of H_m (an estimate of A's). The integral is a quadrature on a grid
  of s (small-matrix work only). With ``norm="max"`` (default) the estimate is also
  scaled by (max|u_m| / ‖u_m‖_W) / (max|y| / ‖y‖_W): the error lies mostly along u_m,
  which on graded meshes concentrates where the cells are small, so a W-norm estimate
  alone can be 100× optimistic in the max norm.
* Step control. The basis grows until the whole remaining interval meets the budget
  SAFETY · tol · s / T (relative error per unit time, T the longest |t|), so errors add
  up to at most tol at the end; when the basis reaches m_max the step is cut to the
  longest s within budget and a new basis starts at y(τ₀ + s). The error stalls until
  m ≈ |s|·ρ(A) (ρ estimated by twice the mean Lanczos coefficient) and then falls
  superlinearly; checks start there and follow the observed decay, spaced by the cost of
  a check relative to a product.

With numba installed (``pip install 'fvf[fast]'``), :mod:`fvf.numerics._kernels` fuses each
product of the series and of the three-term recurrence with the vector work around it
(axpy, scaled copy, weighted norm and inner products), does the bound's power steps in one
call (each one pass over A), compiles the Bessel recurrences and the columns' norms, and
runs one column's whole Lanczos step (vectors, error checks, check schedule) in one call:
right after a kernel run every numpy call costs 3–5× its warm time. For a given method,
the results and product counts are those of the numpy/scipy path (``FVF_NUMBA=0``) to
round-off; "auto" may choose differently on the two paths (:func:`choose_method`).

Products are counted per column (``info["matvecs"]``; a product on an (n, p) block counts
p) and per operator call (``info["block_matvecs"]``). Basis storage (Krylov bases and the
series' terms) is reused between calls (see :data:`WORKSPACE_KEEP`,
:func:`clear_workspace`). Calls may run in several threads at once: each thread keeps
its own storage, and numba's kernels release the GIL (tested; on a 2-core machine two
threads gave 0.7–1.5× the throughput of one, the products being memory-bound).

``method="auto"`` (:func:`choose_method`) uses :func:`scipy.sparse.linalg.expm_multiply`
(Al-Mohy & Higham 2011) only for tiny matrices, the Chebyshev series for long times and
the Krylov method otherwise. When ``skew`` is not given, the
three-term recurrence is tried first and H_m is checked on the fly (⟨A u_j, u_j⟩_W and
h_{j−1,j} + h_{j,j−1} must vanish); a non-skew operator then costs one or two wasted
products before the general method takes over. Small dense work (SVDs, m × m
exponentials) is best run with single-threaded BLAS (``threadpoolctl``).
"""

from __future__ import annotations

import functools
import math
import threading
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import (  # noqa: F401 (re-exported)
    ExpmInputError,
    FlowOverflowError,
    FvfWarning,
    KrylovFallbackWarning,
    ParameterError,
)
from . import _kernels

_AXPY = sla.get_blas_funcs("axpy", dtype=np.float64)  # y += a x in place
_GEMM = sla.get_blas_funcs("gemm", dtype=np.float64)


def _add_product(acc: np.ndarray, C: np.ndarray, F: np.ndarray) -> None:
    """acc += C @ F in place by one GEMM with β = 1 (no temporary and no second pass
    over acc; 0.8x the time of ``acc += C @ F`` for (16, 64) @ (64, 3k)).

    acc (T, N) and F (m, N) C-contiguous, C (T, m): on the transposes, which BLAS sees
    as Fortran-ordered, acc.T += F.T @ C.T.
    """
    if F.shape[0] == 0:
        return
    res = _GEMM(1.0, F.T, C.T, 1.0, acc.T, overwrite_c=True)
    if not np.shares_memory(res, acc):  # pragma: no cover - acc not contiguous
        acc += res.T


try:  # in-place y += A x kernels (scipy's own CSR kernels, no temporary arrays)
    from scipy.sparse import _sparsetools as _st

    _CSR_MATVEC = _st.csr_matvec
    _CSR_MATVECS = _st.csr_matvecs
    _CSC_MATVEC = _st.csc_matvec
    _probe = (np.array([0, 1], np.int32), np.array([0], np.int32), np.array([2.0]))
    _y = np.zeros(2)
    _CSR_MATVEC(1, 1, *_probe, np.ones(1), _y[:1])  # the signatures this module relies on
    _CSR_MATVECS(1, 1, 1, *_probe, np.ones(1), _y[1:])
    _CSC_MATVEC(1, 1, *_probe, np.ones(1), _y[:1])
    if _y.tolist() != [4.0, 2.0]:  # pragma: no cover
        raise TypeError("unexpected kernel semantics")
    del _probe, _y
except (ImportError, AttributeError, TypeError, ValueError):  # pragma: no cover - other scipy
    _CSR_MATVEC = _CSR_MATVECS = _CSC_MATVEC = None

__all__ = [
    "expm_action",
    "clear_workspace",
    "choose_method",
    "skew_bound",
    "chebyshev_degree",
    "check_options",
    "as_times",
    "ExpmvCounter",
    "METHODS",
]

Method = Literal["auto", "krylov", "chebyshev", "expm_multiply"]
METHODS = ("auto", "krylov", "chebyshev", "expm_multiply")

#: Below this many rows ``method="auto"`` uses expm_multiply (a Krylov basis would be
#: most of the space anyway).
SMALL_N = 32
#: Default caps on the Krylov basis size per step (three-term recurrence, general case).
M_MAX_SKEW = 128
M_MAX_IOM = 100
#: Vectors each new basis vector is orthogonalized against in the non-skew case.
IOM_WINDOW = 4
#: The general method places its checks by the Chebyshev degree (as Lanczos does) when
#: Σ|h_jj| + Σ|h_{j,j+1} + h_{j+1,j}| ≤ IOM_IMAGINARY·Σβ_j: a spectrum along the
#: imaginary axis (see _iom_steps).
IOM_IMAGINARY = 1.0
#: Default cap on the memory of the Krylov bases (bytes); columns are processed in groups
#: so that a basis of the needed size fits.
MAX_MEMORY = 2**32
_GRID = 64  # quadrature points for the error integral over a step
_UNIT_GRID = np.linspace(0.0, 1.0, _GRID + 1)
#: From these sizes on, weighted norms use one fused einsum pass instead of a product into a
#: temporary and a BLAS dot (measured crossovers: ~10k entries for vectors, n = 100k for
#: blocks of 8 columns).
_STREAM_N = 10_000  # vectors: n
_STREAM_BLOCK = 2**19  # blocks (n, p), p > 1: n·p
#: Rounding floor of the error estimates, per unit time and per unit of ‖H_m‖: an estimate
#: below NOISE·‖H_m‖·t is noise, so tolerances below it are met at that level instead.
NOISE = 16 * np.finfo(float).eps
SAFETY = 0.5  # the error estimates aim at SAFETY·tol
#: Cap on the bytes of the Chebyshev terms kept for one GEMM into the outputs.
CHEB_MEMORY = 2**28
#: ``method="auto"`` uses the Chebyshev series from this R·max|t| on (R =
#: :func:`skew_bound`) for blocks (p > 1) not declared skew, and for one column declared
#: skew on the numpy/scipy path below :data:`CHEB_SKEW_MIN_N`.
CHEB_MIN_TAU = 20.0
#: The same for one column (one or several times) not declared skew, with numba's kernels.
#: Between R·t = 20 and 30 the compiled IOM took 0.97–1.04x the series' time for one time
#: (flows of grad y on spot at 6k, 23k and 94k faces and on bob at 10k) and 0.78–0.98x for
#: 16 times, with 25–30 % fewer products; at R·t = 43–55 the series was 1.05–1.14x faster
#: (docs/notes.md, session 12).
CHEB_MIN_TAU_COLUMN = 30.0
#: The same without numba's kernels, where IOM's vector work is numpy calls: IOM took
#: 1.25–1.96x the series' time from R·t ≈ 3 on at 6k–10k faces (1.06–1.2x at 94k from
#: R·t ≈ 8), and tied with it below R·t ≈ 3 (session 12).
CHEB_MIN_TAU_COLUMN_NUMPY = 4.0
#: For one column not declared skew, "auto" takes the Krylov method at Gershgorin's bound
#: (the power steps' first: two products with |A|) when it gives R·max|t| below this
#: multiple of the threshold. On flows of J grad y and grad y Gershgorin's bound was
#: 1.43–1.69× ‖K‖_W and the steps took R to 1.08–1.2× (spot at 6k and 23k faces, bob,
#: faust, nefertiti, bunny; session 12), so below that multiple the steps would mostly
#: end under the threshold too, after 2–6 more products, and near it the two methods tie.
CHEB_GERSHGORIN_EXCESS = 1.4
#: For a block of p > 1 columns declared skew it uses it at every R·max|t|: a term costs
#: 0.4–1.1 column products per column with the block kernels, and the series took 0.5–0.95×
#: Lanczos' time for 2–8 columns of J grad y at 0.1–3 edge lengths on spot, 6k faces.
#: Not for other operators: on upwind generators, whose spectra are far from imaginary,
#: the series gave way to Krylov after 32+ terms a column, 1.4–2× the time.
#: ``method="auto"`` with ``skew=True``, one right-hand side and one time, on the
#: numpy/scipy path (``fvf.numerics._kernels.ENABLED`` false): Lanczos from this n on, the series
#: below it (where Lanczos' per-call work costs more than the series' extra products:
#: the series was 0.8x Lanczos' time at 6k faces; crossover between 23k and 94k). With
#: numba's kernels Lanczos is used from :data:`SMALL_N` on (0.88-0.91x the series' time
#: at 6k faces, 0.98x at 23k; session 7).
CHEB_SKEW_MIN_N = 20_000
#: The Chebyshev series gives up (for the Krylov method) once its rounding estimate,
#: NOISE·√k·max|c_k|‖y_k‖/‖B‖, exceeds CHEB_GROWTH·tol.
CHEB_GROWTH = 1e3
#: Power steps of the bound R that :func:`expm_action` computes (:func:`skew_bound`).
CHEB_BOUND_ITERATIONS = 8
#: For an operator not declared skew, from this max|t| × columns × Gershgorin's R on,
#: R is the Lanczos estimate of ‖K‖_W times 1 + CHEB_ESTIMATE_MARGIN instead of the
#: rigorous bound (:func:`_skew_norm_estimate`): ~10 % fewer terms per column, for 20–40
#: products a call (:func:`_bound`).
CHEB_ESTIMATE_MIN_SPAN = 400.0
CHEB_ESTIMATE_MARGIN = 0.02
#: Steps of that Lanczos estimate at most, and its convergence test (relative change of
#: the largest Ritz value over two steps).
CHEB_ESTIMATE_STEPS = 30
CHEB_ESTIMATE_RTOL = 1e-3
#: The Chebyshev series measures its terms at every CHEB_CHECK_EVERY-th step (a check costs
#: a few vector passes; terms that grow are caught at most this many products later).
CHEB_CHECK_EVERY = 32
#: It also measures term CHEB_EARLY_CHECK if that comes before the a-priori degree (where
#: it may stop; R·max|t| ≳ 4.5 at tol 1e-10) and gives up if ‖y_k‖/‖B‖ exceeds
#: CHEB_EARLY_GROWTH there: a spectrum far from the imaginary axis (diffusion, upwind
#: generators), whose terms grow from the start. At term 16 flows of J grad y and grad y
#: gave 0.7–1.6 in the W-norm (spot, bob, faust; smooth and random data) and up to 35 on
#: lion-00, whose flow grows by 1e14; diffusion and upwind generators 2.1e3–1.6e9 on the
#: same meshes and data (session 12). They used to run 32 or more terms before giving
#: way.
CHEB_EARLY_CHECK = 16
CHEB_EARLY_GROWTH = 1e3


_NONFINITE = (
    "the Krylov recurrence produced inf/NaN: A (a LinearOperator?) returned non-finite "
    "values, or the solution overflowed"
)


#: Bytes of basis storage (Krylov bases, the Chebyshev series' terms) kept between calls
#: (per thread) so that repeated calls do not pay the operating system for fresh pages
#: (first-touch page faults cost up to half a sparse product per basis vector).
#: :func:`clear_workspace` releases it.
WORKSPACE_KEEP = 2**30
_LOCAL = threading.local()


def _basis_storage(size: int) -> np.ndarray:
    """Uninitialized flat float64 storage of at least ``size``, from the per-thread cache
    when it is large enough (give it back with :func:`_keep_storage`)."""
    buf = getattr(_LOCAL, "buf", None)
    if buf is not None and buf.size >= size:
        _LOCAL.buf = None  # taken: a nested call allocates its own
        return buf
    return np.empty(size)


def _keep_storage(buf: np.ndarray) -> None:
    """Keep flat basis storage for the next call if it is small enough and the largest."""
    cur = getattr(_LOCAL, "buf", None)
    if buf.nbytes <= WORKSPACE_KEEP and (cur is None or cur.size < buf.size):
        _LOCAL.buf = buf


def clear_workspace() -> None:
    """Release the basis storage :func:`expm_action` keeps between calls."""
    _LOCAL.buf = None


class _NotSkew(Exception):
    """Internal: H_m is visibly not skew tridiagonal (the operator is not skew-adjoint)."""


# ----------------------------------------------------------------------- product counter
class ExpmvCounter(spla.LinearOperator):
    """A LinearOperator that wraps A and counts its products, column by column.

    Use it to count the products of any method that accepts a LinearOperator, e.g.
    ``expm_multiply(ExpmvCounter(A), b, traceA=A.diagonal().sum())``.

    Parameters
    ----------
    A : sparse array/matrix, ndarray or LinearOperator, shape (n, n)

    Attributes
    ----------
    matvecs : int
        Columns multiplied by A (a product with an (n, p) block counts p).
    rmatvecs : int
        Columns multiplied by Aᵀ (norm estimators use them).
    calls : int
        Calls of A or Aᵀ (a block product counts 1).
    log : list of (str, int)
        ("A" or "AT", number of columns) per call, in order.
    """

    def __init__(self, A: Any) -> None:
        self.A = A
        self.matvecs = 0
        self.rmatvecs = 0
        self.calls = 0
        self.log: list[tuple[str, int]] = []
        super().__init__(dtype=np.dtype(getattr(A, "dtype", np.float64)), shape=A.shape)

    def _record(self, kind: str, cols: int) -> None:
        self.calls += 1
        self.log.append((kind, cols))
        if kind == "A":
            self.matvecs += cols
        else:
            self.rmatvecs += cols

    def _matvec(self, x: np.ndarray) -> np.ndarray:
        self._record("A", 1)
        return self.A @ x

    def _matmat(self, X: np.ndarray) -> np.ndarray:
        self._record("A", X.shape[1])
        return self.A @ X

    def _rmatvec(self, x: np.ndarray) -> np.ndarray:
        self._record("AT", 1)
        return self.A.T @ x

    def _rmatmat(self, X: np.ndarray) -> np.ndarray:
        self._record("AT", X.shape[1])
        return self.A.T @ X

    def _adjoint(self) -> spla.LinearOperator:
        return _CounterAdjoint(self)

    @property
    def products(self) -> int:
        """All columns multiplied by A or Aᵀ."""
        return self.matvecs + self.rmatvecs

    def reset(self) -> None:
        """Set the counts back to zero."""
        self.matvecs = self.rmatvecs = self.calls = 0
        self.log.clear()


class _CounterAdjoint(spla.LinearOperator):
    """The transpose of an :class:`ExpmvCounter`, counting into its parent."""

    def __init__(self, parent: ExpmvCounter) -> None:
        self.parent = parent
        super().__init__(dtype=parent.dtype, shape=parent.shape[::-1])

    def _matvec(self, x):
        return self.parent._rmatvec(x)

    def _matmat(self, X):
        return self.parent._rmatmat(X)

    def _rmatvec(self, x):
        return self.parent._matvec(x)

    def _rmatmat(self, X):
        return self.parent._matmat(X)

    def _adjoint(self):
        return self.parent


# ------------------------------------------------------------------------ the operator
class _Operator:
    """y += A x for x, y of shape (n,) or (n, p), counting products."""

    def __init__(self, A: Any, n: int, scale: float = 1.0) -> None:
        """The operator scale·A (a scaled copy of a sparse or dense A's values)."""
        self.n = n
        self.matvecs = 0
        self.calls = 0
        self.csr = None  # (indptr, indices, data) of scale·A, for scipy's in-place kernels
        self.fused = None  # the same with unsigned index views, for fvf.numerics._kernels (numba)
        self.A = A if scale == 1.0 or sp.issparse(A) else scale * A
        if sp.issparse(A):
            C = A.tocsr() if A.format != "csr" else A
            data = C.data.astype(np.float64, copy=False)
            self.csr = (C.indptr, C.indices, data * scale if scale != 1.0 else data)
            self.nnz = C.nnz
            self.fused = _kernels.csr_views(*self.csr)
        elif isinstance(A, np.ndarray):
            self.nnz = A.size
        else:
            self.nnz = None  # LinearOperator: cost unknown

    def kernel(self, cols: int) -> Callable[[np.ndarray, np.ndarray], None]:
        """``f(x, y)``: y += A x on flat C-contiguous x, y of n·cols entries, with no
        checks and no counting (the caller records them with :meth:`count`)."""
        if self.csr is None or _CSR_MATVEC is None:
            shape = (self.n,) if cols == 1 else (self.n, cols)
            return lambda x, y: self._product(x.reshape(shape), y.reshape(shape))
        indptr, indices, data = self.csr
        if cols == 1:  # the vector kernel is ~2x faster than the 1-column one
            return functools.partial(_CSR_MATVEC, self.n, self.n, indptr, indices, data)
        return functools.partial(_CSR_MATVECS, self.n, self.n, cols, indptr, indices, data)

    def count(self, calls: int, cols: int) -> None:
        """Record ``calls`` products on ``cols`` columns made through :meth:`kernel`."""
        self.calls += calls
        self.matvecs += calls * cols

    def accumulate(self, x: np.ndarray, y: np.ndarray) -> None:
        """y += A x (x, y C-contiguous, same shape (n,) or (n, p)), counted."""
        self.count(1, 1 if x.ndim == 1 else x.shape[1])
        self._product(x, y)

    def _product(self, x: np.ndarray, y: np.ndarray) -> None:
        """y += A x, not counted."""
        cols = 1 if x.ndim == 1 else x.shape[1]
        if self.csr is not None and _CSR_MATVEC is not None:
            indptr, indices, data = self.csr
            if cols == 1:
                _CSR_MATVEC(self.n, self.n, indptr, indices, data, x.reshape(-1), y.reshape(-1))
            else:
                n = self.n
                _CSR_MATVECS(n, n, cols, indptr, indices, data, x.ravel(), y.reshape(-1))
            return
        if self.csr is not None:  # pragma: no cover - other scipy versions
            indptr, indices, data = self.csr
            y += sp.csr_array((data, indices, indptr), shape=(self.n, self.n)) @ x
        elif isinstance(self.A, np.ndarray):
            y += self.A @ x
        elif x.ndim == 1:
            y += np.asarray(self.A.matvec(x)).reshape(y.shape)
        else:
            y += np.asarray(self.A.matmat(x)).reshape(y.shape)

    def product_cost(self, cols: int) -> float:
        """Rough wall time of one product on ``cols`` columns (seconds; for scheduling)."""
        if self.nnz is None:
            return 1.0  # unknown operator: assume products dominate everything
        return 3e-6 + 1.3e-9 * self.nnz * (cols if cols == 1 else 0.75 * cols)


# ---------------------------------------------------------------------- small matrices
class _SkewExp:
    """exp(s H) e_1 for skew tridiagonal H (H[j+1, j] = β_j = −H[j, j+1]), any s, for p
    columns at once (one H per column).

    With D = diag(iᵏ), D⁻¹ H D = −i T, T symmetric tridiagonal with zero diagonal and
    off-diagonal β. T couples even and odd indices only: T = P [[0, B], [Bᵀ, 0]] Pᵀ with
    the lower bidiagonal B (ceil(m/2) × floor(m/2)), B[i, i] = β_{2i}, B[i+1, i] = β_{2i+1}.
    With B = U Σ Vᵀ (an SVD of half the size, cheaper than an eigensolve of T):

        [exp(s H) e_1]_{2i}   = (−1)^i Σ_l U[i, l] U[0, l] cos(s σ_l)
        [exp(s H) e_1]_{2i+1} = (−1)^i Σ_l V[i, l] U[0, l] sin(s σ_l)

    (σ padded with zeros to ceil(m/2) for the cosines).

    Parameters
    ----------
    beta : ndarray (m − 1, p)
        The off-diagonals, one column per right-hand side.
    """

    def __init__(self, beta: np.ndarray) -> None:
        m = beta.shape[0] + 1
        p = beta.shape[1]
        self.m, self.p = m, p
        ke, ko = (m + 1) // 2, m // 2
        self.ko = ko
        if m == 1:
            self.sig_e = np.zeros((p, 1))
            self.Ge = np.ones((p, 1, 1))
            return
        Bm = np.zeros((p, ke, ko))
        i = np.arange(ko)
        Bm[:, i, i] = beta[0::2].T
        j = np.arange(beta[1::2].shape[0])
        Bm[:, j + 1, j] = beta[1::2].T
        U, sig, Vt = np.linalg.svd(Bm)  # batched over the columns
        self.sig_e = np.zeros((p, ke))
        self.sig_e[:, :ko] = sig
        sign_e = np.where(np.arange(ke) % 2 == 0, 1.0, -1.0)
        sign_o = np.where(np.arange(ko) % 2 == 0, 1.0, -1.0)
        self.Ge = U * U[:, :1, :] * sign_e[:, None]  # (p, ke, ke): [c, i, l]
        self.sig_o = sig
        self.Go = np.swapaxes(Vt, 1, 2) * U[:, :1, :ko] * sign_o[:, None]  # (p, ko, ko)

    def e1(self, s: np.ndarray) -> np.ndarray:
        """[exp(s H) e_1] for the times s (K,): (p, K, m)."""
        out = np.empty((self.p, s.size, self.m))
        cos = np.cos(self.sig_e[:, None, :] * s[:, None])  # (p, K, ke)
        out[:, :, 0::2] = np.matmul(cos, np.swapaxes(self.Ge, 1, 2))
        if self.ko:
            sin = np.sin(self.sig_o[:, None, :] * s[:, None])
            out[:, :, 1::2] = np.matmul(sin, np.swapaxes(self.Go, 1, 2))
        return out

    def last(self, s: np.ndarray) -> np.ndarray:
        """[exp(s H) e_1]_{m−1} for the times s (K,): (p, K)."""
        if (self.m - 1) % 2 == 0:
            trig, G = np.cos(self.sig_e[:, None, :] * s[:, None]), self.Ge[:, -1, :]
        else:
            trig, G = np.sin(self.sig_o[:, None, :] * s[:, None]), self.Go[:, -1, :]
        return np.matmul(trig, G[:, :, None])[:, :, 0]

    def residual_integral(self, hi: float, bl: np.ndarray, sign: float) -> np.ndarray:
        """∫_0^{s_g} |bl_c [exp(sign·σ H_c) e_1]_{m−1}| dσ on :func:`_grid` (hi), by the
        cumulative trapezoid rule: (p, _GRID + 1), for bl (p,)."""
        return _cumtrapz(np.abs(bl[:, None] * self.last(sign * _grid(hi))), hi)


class _SkewExpSeries:
    """:class:`_SkewExp`'s values by the Chebyshev series in H/r, r = 2 max β ≥ ‖H‖
    (Gershgorin), with the vectors and coefficients compiled (numba):

        exp(s H) e_1 = J₀(rs) e_1 + 2 Σ_{k≥1} J_k(rs) P_k(H/r) e_1,

    P_k the real three-term recurrence of :func:`_run_chebyshev` (‖P_k(H/r)‖ ≤ 1), summed
    to the order x + 12 x^{1/3} + 60, x = r·max|s| (the tail is far below round-off). The
    vectors, the coefficients, the sums and the error integral each take one compiled
    call (:func:`~._kernels.skew_chebyshev_basis`, :func:`~._kernels.skew_series`):
    an error check costs ~80 µs inside a call at 6k faces, where with numpy between the
    kernels it cost 270–340 µs (each numpy call 3–5× its warm time right after a kernel
    has streamed the basis through the caches), and with the SVD of :class:`_SkewExp`
    160–540 µs (m = 50–110).

    Parameters
    ----------
    beta : ndarray (m − 1, p)
        The off-diagonals, one column per right-hand side.
    """

    def __init__(self, beta: np.ndarray) -> None:
        self.m, self.p = beta.shape[0] + 1, beta.shape[1]
        self.beta = beta
        r = 2.0 * beta.max(axis=0) if beta.shape[0] else np.zeros(self.p)
        self.r = np.where(r > 0, r, 1.0)  # (p,) (H = 0: any r; the even P_k are e_1)
        self.P: np.ndarray | None = None  # (p, K + 1, m)
        self.x_top = -1.0

    def _basis(self, s_top: float) -> np.ndarray:
        """P_k(H_c/r_c) e_1 (p, K + 1, m) to the order that times up to |s| = s_top need."""
        top = s_top * float(self.r.max())
        if self.P is None or top > self.x_top:
            self.use_basis(
                _kernels.skew_chebyshev_basis(self.beta, self.r, _degree_top(top)), s_top
            )
        return self.P

    def use_basis(self, P: np.ndarray, s_top: float) -> None:
        """Take the vectors P (p, K + 1, m), computed to the order that times up to
        |s| = s_top need (as :meth:`_basis` computes them)."""
        self.P, self.x_top = P, s_top * float(self.r.max())

    def e1(self, s: np.ndarray) -> np.ndarray:
        """[exp(s H) e_1] for the times s (K,): (p, K, m)."""
        P = self._basis(float(np.abs(s).max()) if s.size else 0.0)
        return _kernels.skew_series(P, self.r, s, _BESSEL_TINY)[0]

    def residual_integral(self, hi: float, bl: np.ndarray, sign: float) -> np.ndarray:
        """:meth:`_SkewExp.residual_integral`, in one compiled call (from the last entries
        of the vectors only)."""
        P = self._basis(hi)[:, :, -1:]
        return _kernels.skew_series(P, self.r, sign * _grid(hi), _BESSEL_TINY, bl)[1]


def _skew_exp(beta: np.ndarray) -> _SkewExp | _SkewExpSeries:
    """exp(s H) e_1 for Lanczos' skew tridiagonal H: compiled series with numba, else SVD."""
    return _SkewExpSeries(beta) if _kernels.ENABLED else _SkewExp(beta)


def _grid(hi: float) -> np.ndarray:
    """The error checks' quadrature grid on [0, hi]: (_GRID + 1,) uniform, s[-1] = hi."""
    return _UNIT_GRID * hi


def _cumtrapz(y: np.ndarray, hi: float) -> np.ndarray:
    """Cumulative trapezoid ∫_0^{s_k} y along the last axis of y (..., _GRID + 1), on
    :func:`_grid` (hi)."""
    out = np.empty_like(y)
    out[..., 0] = 0.0
    np.cumsum(y[..., 1:] + y[..., :-1], axis=-1, out=out[..., 1:])
    out[..., 1:] *= 0.5 * hi / _GRID
    return out


# ------------------------------------------------------------------------ the driver
def as_times(t: Any) -> tuple[np.ndarray, bool]:
    """Validated times: (t as a float64 array (T,), whether t was a scalar); raises
    :class:`ExpmInputError` for non-numeric, 2-D or non-finite t."""
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


def _check_operator(A: Any, finite: bool = True) -> tuple[Any, int]:
    """(A as CSR, ndarray or LinearOperator, n) or :class:`ExpmInputError`. ``finite``:
    also check a sparse A's entries (:func:`_check_finite`; expm_action defers it to
    ‖A‖_∞, which is not finite exactly when some entry is not or a row sum overflows)."""
    if sp.issparse(A):
        if A.ndim != 2 or A.shape[0] != A.shape[1]:
            raise ExpmInputError(f"A must be square (n, n); got shape {A.shape}")
        if np.iscomplexobj(A.data):
            raise ExpmInputError("A must be real; complex operators are not supported")
        C = A.tocsr() if A.format != "csr" else A
        if finite:
            _check_finite(C)
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


def _check_finite(C: Any) -> None:
    """Raise :class:`ExpmInputError` if the sparse C has an entry that is inf or NaN."""
    if not np.isfinite(C.data).all():
        raise ExpmInputError("A has non-finite entries (inf or NaN)")


#: Largest max|t| · ‖A‖_∞ accepted (beyond ~1/eps the steps underflow relative to t).
MAX_SPAN = 1e15
#: An explicit A with ‖A‖_∞ outside this range is run as A/‖A‖_∞ for the times t·‖A‖_∞
#: (the same exponentials): the squared norms of products with entries ~1e-162 underflow,
#: and A·1e-162 at t·1e162 came out 37 % off without a warning (a review's finding).
SCALE_RANGE = (1e-100, 1e100)


@dataclass(frozen=True)
class _AbsCsr:
    """|A| of an explicit (sparse or dense) A as CSR arrays, with |diag A|: what ‖A‖_∞ and
    the bound R read, built once per call. Duplicate entries are kept: |a| + |b| ≥ |a + b|,
    so both stay upper bounds (the diagonal sums them first, which only loosens R)."""

    n: int
    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray  # (nnz,) |a_ij|
    diag: np.ndarray  # (n,) |a_ii|

    @classmethod
    def of(cls, A: Any) -> _AbsCsr:
        M = A.tocsr() if sp.issparse(A) else sp.csr_array(A)  # the caller's A is untouched
        return cls(M.shape[0], M.indptr, M.indices, np.abs(M.data), np.abs(M.diagonal()))

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """|A| x (x (n,) float64)."""
        y = np.zeros(self.n)
        if _CSR_MATVEC is not None:
            _CSR_MATVEC(self.n, self.n, self.indptr, self.indices, self.data, x, y)
        else:  # pragma: no cover - other scipy versions
            y = self._csr() @ x
        return y

    def rmatvec(self, x: np.ndarray) -> np.ndarray:
        """|A|ᵀ x (x (n,) float64): the CSR arrays of |A| are the CSC arrays of |A|ᵀ."""
        y = np.zeros(self.n)
        if _CSC_MATVEC is not None:
            _CSC_MATVEC(self.n, self.n, self.indptr, self.indices, self.data, x, y)
        else:  # pragma: no cover - other scipy versions
            y = self._csr().T @ x
        return y

    def _csr(self) -> sp.csr_array:  # pragma: no cover - other scipy versions
        return sp.csr_array((self.data, self.indices, self.indptr), shape=(self.n, self.n))

    def norm_inf(self) -> float:
        return float(self.matvec(np.ones(self.n)).max()) if self.n else 0.0

    def diag_max(self) -> tuple[float, float]:
        """max |a_ii| and max |a_ij| (for the skew test of :func:`_skew_bound`)."""
        return float(self.diag.max(initial=0.0)), float(self.data.max(initial=0.0))

    def step(
        self, d: np.ndarray, s: np.ndarray, inv_s: np.ndarray, sym: bool
    ) -> tuple[np.ndarray, float, float]:
        """(M d, max (M d)/d, max M d) for :func:`_skew_bound`: M = P (``sym``) or
        ½(P + Pᵀ) − |diag A|, P = diag(s)|A|diag(1/s)."""
        Md = self.matvec(d * inv_s)
        Md *= s
        if not sym:
            Md += self.rmatvec(d * s) * inv_s
            Md *= 0.5
            Md -= self.diag * d
        return Md, float(np.max(Md / d)), float(Md.max())


class _FusedAbs:
    """What :class:`_AbsCsr` gives, from A's own CSR arrays by fvf.numerics._kernels (numba): no
    copy of |A|, the statistics in one pass; :func:`_skew_bound`'s power steps in one
    call (:func:`~._kernels.power_bound`: each step one pass over the rows)."""

    def __init__(self, csr: tuple[np.ndarray, np.ndarray, np.ndarray], n: int) -> None:
        self.csr, self.n = csr, n
        self._norm, dmax, amax = _kernels.abs_stats(csr)
        self._diag = (dmax, amax)

    @classmethod
    def of(cls, A: Any) -> _FusedAbs | None:
        """For a sparse A whose CSR arrays the kernels read; None otherwise."""
        if not sp.issparse(A):
            return None
        C = A.tocsr() if A.format != "csr" else A
        csr = _kernels.csr_views(C.indptr, C.indices, C.data)
        return None if csr is None else cls(csr, C.shape[0])

    def norm_inf(self) -> float:
        return self._norm

    def diag_max(self) -> tuple[float, float]:
        return self._diag


def _abs_of(A: Any) -> _AbsCsr | _FusedAbs:
    """|A| of an explicit A for ‖A‖_∞ and the bound R: read from A's own arrays by the
    fused kernels where they apply, else built as :class:`_AbsCsr`."""
    return _FusedAbs.of(A) or _AbsCsr.of(A)


def _norm_inf(A: Any, absA: _AbsCsr | _FusedAbs | None = None) -> float:
    """‖A‖_∞ of a sparse or dense A (from ``absA`` = |A| when given); for a LinearOperator
    its ``norm_inf`` attribute (an upper bound, e.g.
    :class:`fvf.flows.field_transport.TransportOperator`'s) or 0 (unknown)."""
    if absA is not None:
        return absA.norm_inf()
    if sp.issparse(A):
        return _norm_inf(A, _abs_of(A)) if A.nnz else 0.0
    if isinstance(A, np.ndarray):
        return float(np.abs(A).sum(axis=1).max()) if A.size else 0.0
    bound = getattr(A, "norm_inf", 0.0)
    return float(bound) if isinstance(bound, (int, float)) else 0.0


def check_options(method: str, tol: float) -> tuple[str, float]:
    """Validated ``(method, tol)`` of :func:`expm_action` (also for the objects that store
    them for later calls, e.g. :class:`fvf.FunctionalFlow`); raises :class:`ExpmInputError`."""
    if not isinstance(tol, int | float | np.floating) or not 0 < float(tol) < 1:
        raise ExpmInputError(f"tol must be a number in (0, 1); got {tol!r}")
    if method not in METHODS:
        raise ExpmInputError(f"method must be one of {METHODS}; got {method!r}")
    return method, float(tol)


def choose_method(
    A: Any,
    t: float | npt.ArrayLike,
    n_rhs: int = 1,
    *,
    skew: bool | None = None,
    inner: npt.ArrayLike | None = None,
    skew_norm: float | None = None,
    tol: float = 1e-10,
) -> Literal["krylov", "chebyshev", "expm_multiply"]:
    """The method ``expm_action(..., method="auto")`` uses for these inputs.

    * n < :data:`SMALL_N`, or every t is 0: ``"expm_multiply"`` (nothing to win).
    * ``skew=True`` with several times, or with one right-hand side and one time (with
      numba's kernels; without them from n = :data:`CHEB_SKEW_MIN_N` on): ``"krylov"``
      (Lanczos, which also keeps the norm to round-off). It needs 1.2–1.4× fewer vectors
      than the series; with one right-hand side it was 0.88–0.91× the series' time at
      6k faces, 0.92× at 94k and 0.83× at 1.5M, for 16 times 0.8× (6k–23k faces),
      every output being a combination of all the vectors. Without the kernels its
      per-call work (small dense exponentials for the step control, Python work per
      vector) made it slower than the series below ~20k vertices (1.25× at 6k); on
      blocks of 8 the series was 1.2–1.5× faster at every size.
    * A explicit (sparse or dense) and R·max|t| at least :data:`CHEB_MIN_TAU` (blocks,
      and one column declared skew on the numpy path below :data:`CHEB_SKEW_MIN_N`),
      :data:`CHEB_MIN_TAU_COLUMN` (one column not declared skew, numba's kernels) or
      :data:`CHEB_MIN_TAU_COLUMN_NUMPY` (the same without them), R the bound
      ``skew_norm`` or :func:`skew_bound`, or any R·max|t| > 0 for a block (``n_rhs`` > 1)
      with ``skew=True``: ``"chebyshev"``. For one column not declared skew and no
      ``skew_norm``, Gershgorin's bound G (the first power step) decides alone when
      G·max|t| < :data:`CHEB_GERSHGORIN_EXCESS` × the threshold: ``"krylov"``, even where
      the further steps would have brought R·max|t| above it. A term costs one product and
      one vector copy (none for one time), against three vector passes per basis vector
      for the three-term Krylov recurrence and, for the general one, one more pass over
      the last four vectors with numba (about twenty without), plus the step control; it
      needs more products (R·|t| + O(|Rt|^{1/3} + log 1/tol), with R 1.02–1.2× ‖K‖_W)
      but runs close to the time of its products
      (``benchmarks/bench_expmv.py``, docs/flows.md). If its series fails its checks
      (strongly non-normal A, real spectra), the Krylov method takes over. Not below
      its rounding floor: when NOISE·√(R·max|t| + 30) > SAFETY·tol (tol ≲ 1e-13), its
      own rounding estimate would fail the check at the end.
    * otherwise ``"krylov"``. Measured on flows of unit-speed fields on spot meshes (6k,
      94k and 1.5M faces; ``benchmarks/bench_expmv.py``, tol 1e-10), the Krylov method
      needs 1.5–3.5× fewer products than expm_multiply at t = 0.1 mean edge lengths and
      1.7–4.8× at 1: its Taylor steps scale with |t|·‖A‖₁ and its norm estimates spend
      products with Aᵀ.

    Parameters
    ----------
    A : sparse array/matrix, ndarray or LinearOperator, shape (n, n)
    t : float or array_like (T,)
    n_rhs : int
        Number of right-hand sides (real columns of B: a complex column counts twice).
    skew : bool or None
        Whether A is skew-adjoint in the inner product of the call (None: unknown).
    inner : array_like (n,), optional
        Weights of the inner product (for the bound R).
    skew_norm : float, optional
        An upper bound R of ‖K‖_W (see :func:`skew_bound`); computed when needed.
    tol : float
        The tolerance of the call.

    Returns
    -------
    {"krylov", "chebyshev", "expm_multiply"}
    """
    Aop, _ = _check_operator(A)
    times, _ = as_times(t)
    w = None if inner is None else np.asarray(inner, dtype=float)
    return _choose(Aop, times, skew_norm, w, n_rhs, skew=skew, tol=float(tol))[0]


def _choose(
    Aop: Any,
    times: np.ndarray,
    skew_norm: float | None,
    w: np.ndarray | None,
    p: int = 1,
    info: dict | None = None,
    skew: bool | None = None,
    absA: _AbsCsr | _FusedAbs | None = None,
    tol: float = 1e-10,
) -> tuple[str, float | None]:
    """(method of "auto", the bound R if it was computed or given); ``absA``: |A| if the
    caller has it."""
    n = Aop.shape[0]
    if n < SMALL_N or not np.any(times != 0):
        return "expm_multiply", skew_norm
    mags = np.abs(times[times != 0])
    several = mags.size > 1 and bool(mags.min() != mags.max())  # distinct |t| > 0
    lanczos_min_n = SMALL_N if _kernels.ENABLED else CHEB_SKEW_MIN_N
    if skew is True and (several or (p == 1 and n >= lanczos_min_n)):
        return "krylov", skew_norm  # Lanczos: fewer vectors, faster there (docstring)
    if isinstance(Aop, spla.LinearOperator) and skew_norm is None:
        return "krylov", None
    top = float(mags.max())
    min_tau = _min_tau(p, skew)
    if skew_norm is None:  # (below min_tau / top the series is out: no more steps)
        # one column not declared skew: out at Gershgorin's bound, the first of the power
        # steps (two products with |A|), if it is below CHEB_GERSHGORIN_EXCESS × min_tau
        first = CHEB_GERSHGORIN_EXCESS * min_tau / top if p == 1 and skew is not True else 0.0
        spent: dict = {} if info is None else info
        R = _bound(Aop, w, times, p, spent, absA, skew, floor=min_tau / top, first_floor=first)
        if R < first and spent["bound_products"] == 2:  # (it stopped there)
            return "krylov", R
    else:
        R = float(skew_norm)
    tau = R * top
    if R > 0 and tau >= min_tau and NOISE * math.sqrt(tau + 30.0) <= SAFETY * tol:
        return "chebyshev", R
    return "krylov", R


def _min_tau(p: int, skew: bool | None) -> float:
    """The R·max|t| from which "auto" takes the series, for p real columns (docstring of
    :func:`choose_method`)."""
    if skew is True:
        return 0.0 if p > 1 else CHEB_MIN_TAU  # (one skew column: the numpy path only)
    if p > 1:
        return CHEB_MIN_TAU
    return CHEB_MIN_TAU_COLUMN if _kernels.ENABLED else CHEB_MIN_TAU_COLUMN_NUMPY


def _bound(
    Aop: Any,
    w: np.ndarray | None,
    times: np.ndarray,
    p: int,
    info: dict | None,
    absA: _AbsCsr | _FusedAbs | None = None,
    skew: bool | None = None,
    floor: float = 0.0,
    first_floor: float = 0.0,
) -> float:
    """The series' radius R for this call; records the products spent on it in
    ``info["bound_products"]``. ``floor``, ``first_floor``: see :func:`_skew_bound`.

    * ``skew=True``, or max|t| × columns × Gershgorin's bound ≤ CHEB_ESTIMATE_MIN_SPAN:
      :func:`skew_bound` with power steps while they pay for themselves on this call
      (one product per step for ``skew=True``), none once the bound is below ``floor``
      (R·max|t| below the threshold of :func:`_min_tau` rules the series out whatever
      the steps give; see :func:`_skew_bound`).
    * otherwise (long flows of blocks, not declared skew): (1 + CHEB_ESTIMATE_MARGIN)·θ,
      θ ≤ ‖K‖_W the Lanczos estimate (:func:`_skew_norm_estimate`), capped by
      Gershgorin's bound; the rigorous bound if θ did not converge. Not a bound, but the
      series' stop for such A is a posteriori (an R below ‖K‖_W costs terms or hands
      the call to Krylov, it cannot make the answer wrong). On spot with 8 columns at 10
      edge lengths R goes from 1.15–1.18× ‖K‖_W to 1.02× and the products (estimate
      included) fall by 5–8 % (6k–94k faces) and 7.5 % (1.5M: 1,358 → 1,256).
    """
    span = float(np.abs(times).max()) * max(p, 1) if times.size else 0.0
    absA = _abs_of(Aop) if absA is None else absA
    handoff = math.inf if skew is True else CHEB_ESTIMATE_MIN_SPAN
    R, products = _skew_bound(
        absA, w, CHEB_BOUND_ITERATIONS, span, skew is True, floor, handoff, first_floor
    )
    if R >= floor and span * R > handoff:  # (then the steps stopped at Gershgorin's R)
        estimate, spent = _estimated_radius(Aop, w, absA)
        products += spent
        if estimate is not None:
            R = min(R, estimate)
        else:  # (not seen on flow operators) the rigorous bound after all
            R, steps = _skew_bound(absA, w, CHEB_BOUND_ITERATIONS, span, False, floor)
            products += steps
    if info is not None:
        info["bound_products"] = products
    return R


def _estimated_radius(
    Aop: Any, w: np.ndarray | None, absA: _AbsCsr | _FusedAbs | None = None
) -> tuple[float | None, int]:
    """(R = (1 + CHEB_ESTIMATE_MARGIN)·θ, or None if θ did not converge; the products
    spent): the series' radius from :func:`_skew_norm_estimate`, for operators not
    declared skew (:func:`_bound`, and ``fvf.FunctionalFlow`` once per field)."""
    theta, spent, converged = _skew_norm_estimate(Aop, w, absA)
    return ((1.0 + CHEB_ESTIMATE_MARGIN) * theta if converged else None), spent


def _skew_norm_estimate(
    Aop: Any, w: np.ndarray | None, absA: _AbsCsr | _FusedAbs | None = None
) -> tuple[float, int, bool]:
    """(θ, products with A and Aᵀ spent, whether θ converged): the largest Ritz value of
    Lanczos on K = ½(A − A*), A* = W⁻¹AᵀW the W-adjoint, from a fixed random start.

    K is W-skew, so K q_j = β_j q_{j+1} − β_{j−1} q_{j−1} and the projection of K is
    tridiagonal with zero diagonal; its eigenvalues are ±i times those of the symmetric
    tridiagonal with off-diagonal β. θ ≤ ‖K‖_W always (a compression of K); on flow
    operators the top of K's spectrum is well separated and θ is within 1e-3 of ‖K‖_W
    after 15–20 steps (spot, 6k to 1.5M faces; docs/notes.md, session 9). Converged:
    θ moved by at most CHEB_ESTIMATE_RTOL relative over the last two steps, or the
    basis spans an invariant subspace (θ exact).

    Not a bound: R from θ serves only operators not declared skew, whose series' stop is
    a posteriori anyway (:func:`_run_chebyshev`). An R below ‖K‖_W makes the terms grow,
    which costs terms or hands the call to the Krylov method; it cannot make the answer
    wrong.

    With ``absA`` from the fused kernels (:class:`_FusedAbs`, which holds A's CSR arrays),
    the steps run in one compiled call (:func:`~._kernels.skew_lanczos`, one pass over
    the rows a step for both products).
    """
    n = Aop.shape[0]
    q = np.random.default_rng(20261122).standard_normal(n)
    q /= math.sqrt(q @ (q if w is None else w * q))
    if isinstance(absA, _FusedAbs):
        ones = np.ones(n) if w is None else w
        theta, taken, converged = _kernels.skew_lanczos(
            absA.csr, ones, q, CHEB_ESTIMATE_STEPS, CHEB_ESTIMATE_RTOL
        )
        return theta, 2 * taken, converged
    AT = Aop.T
    q_prev = np.zeros(n)
    beta_prev = 0.0
    betas: list[float] = []
    thetas = [0.0, 0.0]
    for _ in range(CHEB_ESTIMATE_STEPS):
        adj = AT @ (q if w is None else w * q)  # Aᵀ W q, (n,)
        r = Aop @ q
        r -= adj if w is None else adj / w  # A q − A* q
        r *= 0.5
        r += beta_prev * q_prev  # K q_j + β_{j−1} q_{j−1} = β_j q_{j+1}
        beta = math.sqrt(r @ (r if w is None else w * r))
        betas.append(beta)
        top = sla.eigvalsh_tridiagonal(
            np.zeros(len(betas) + 1),
            np.asarray(betas),
            select="i",
            select_range=(len(betas), len(betas)),
        )[0]
        thetas.append(float(top))
        if not math.isfinite(beta) or beta <= 1e-14 * max(thetas[-1], 1e-300):
            return thetas[-1], 2 * len(betas), math.isfinite(beta)
        if thetas[-1] - thetas[-3] <= CHEB_ESTIMATE_RTOL * thetas[-1] and len(betas) >= 4:
            return thetas[-1], 2 * len(betas), True
        q_prev, q, beta_prev = q, r / beta, beta
    return thetas[-1], 2 * len(betas), False


def expm_action(
    A: Any,
    B: npt.ArrayLike,
    t: float | npt.ArrayLike,
    *,
    tol: float = 1e-10,
    inner: npt.ArrayLike | None = None,
    skew: bool | None = None,
    method: Method = "auto",
    norm: Literal["max", "inner"] = "max",
    m_max: int | None = None,
    max_memory: float = MAX_MEMORY,
    skew_norm: float | None = None,
    return_info: bool = False,
) -> np.ndarray | tuple[np.ndarray, dict[str, Any]]:
    """exp(t_j A) B for one or many times t_j and one or many right-hand sides.

    Parameters
    ----------
    A : sparse array/matrix, ndarray or LinearOperator, shape (n, n), real
        The generator; for a functional flow, A = −D^V_v.
    B : array_like, shape (n,) or (n, p)
        Initial value(s), real (float64) or complex (split into real and imaginary
        columns, which share the products).
    t : float or array_like, shape (T,)
        Times, any sign and order (repeats and zeros allowed); all are computed in one
        pass per sign.
    tol : float
        Target relative error of every output column, 0 < tol < 1: in the max norm and in
        the norm of ``inner`` (``norm="max"``), or in the norm of ``inner`` only
        (``norm="inner"``). Local errors are budgeted as tol × step / longest |t|, so they
        add up to tol; for non-normal A the estimates do not include the amplification
        of earlier steps' errors (see Notes). Tolerances below the rounding floor
        ~:data:`NOISE` · |t| · ‖H_m‖ are met at that floor.
    inner : array_like, shape (n,), optional
        Positive weights w of the inner product ⟨x, y⟩ = xᵀ diag(w) y (for flows, the
        vertex areas A_V). Default: all ones.
    skew : bool or None
        Whether A is skew-adjoint in that inner product (diag(w) A + Aᵀ diag(w) = 0; true
        for A = ±D^V_v with v = J grad g on a closed mesh and w = A_V). None: try the
        three-term recurrence and check it on the fly. True: use it; if the operator turns
        out not to be skew, warn (:class:`KrylovFallbackWarning`) and use the general
        method. For the Chebyshev series, True rescales each output to the norm of its
        column of B where that stays within tol (see :func:`_run_chebyshev`; the answer
        stays within tol whether or not A is skew) and bounds R with one product per
        step. False: the general method (incomplete orthogonalization).
    method : {"auto", "krylov", "chebyshev", "expm_multiply"}
        "auto" follows :func:`choose_method`. "krylov": adaptive Krylov time stepping.
        "chebyshev": the Chebyshev series in A/R (see Notes); if it fails its checks,
        warns (:class:`KrylovFallbackWarning`) and uses the Krylov method.
        "expm_multiply" chains :func:`scipy.sparse.linalg.expm_multiply` over the sorted
        times of each sign.
    norm : {"max", "inner"}
        Norm(s) of the error control (see ``tol``); "max" costs a few more products.
    m_max : int, optional
        Largest Krylov basis per step (default :data:`M_MAX_SKEW` = 128 for the
        three-term recurrence, :data:`M_MAX_IOM` = 100 otherwise); a longer time is
        split into steps. ``max_memory`` can lower it; for the general method it is at
        most n (with full orthogonalization when it can reach n).
    max_memory : float
        Cap on the bytes of a Krylov basis (default 4 GiB); columns of B are processed in
        groups that fit.
    skew_norm : float, optional
        For the Chebyshev series: an upper bound R of ‖K‖_W, the norm of A's skew-adjoint
        part in the inner product, so that A's spectrum lies in the strip |Im z| ≤ R.
        Default: :func:`skew_bound` with power steps while they pay for themselves
        (1.1–1.2× ‖K‖_W on flow operators; one product per step for ``skew=True``); for
        long flows of blocks of an operator not declared skew (max|t| × columns × R >
        :data:`CHEB_ESTIMATE_MIN_SPAN`), 1.02× a Lanczos estimate of ‖K‖_W instead,
        which the series' a-posteriori checks cover. A tighter R saves products; one
        below ‖K‖_W makes the series grow, which its checks detect (then the Krylov
        method is used).
    return_info : bool
        Also return a dict of statistics.

    Returns
    -------
    X : ndarray, float64 (complex128 if B is complex)
        ``B.shape`` for a scalar t, ``(T,) + B.shape`` for an array of times; X[j] is
        exp(t_j A) B.
    info : dict, only if ``return_info``
        ``method`` ("chebyshev", "lanczos", "iom", "expm_multiply", or "zero" for
        A = 0);
        ``matvecs``: column products with A (a product on an (n, p) block counts p; for
        expm_multiply, products with A and Aᵀ, counted through :class:`ExpmvCounter`);
        ``block_matvecs``: operator calls; ``steps``: Krylov bases built;
        ``basis_sizes``: their sizes (for "chebyshev", the number of terms);
        ``error_estimate``: the largest accumulated relative error estimate over the
        columns (None for expm_multiply); ``skew``: what was used; ``wasted_matvecs``:
        products of a failed three-term or Chebyshev attempt (included in ``matvecs``);
        ``skew_bound``: R, for "chebyshev"; ``bound_products``: products spent on R
        (with |A| for :func:`skew_bound`, with A and Aᵀ for the Lanczos estimate; not
        included in ``matvecs``).

    Raises
    ------
    ExpmInputError
        Non-square, complex or non-numeric A; B of the wrong shape; non-finite A, B, t
        or weights; weights ≤ 0; tol outside (0, 1); unknown method, norm or skew value;
        m_max < 1; skew_norm not a finite number > 0.
    FlowOverflowError
        (also a FloatingPointError) The recurrence produced inf/NaN (a LinearOperator
        returned them, or the solution overflowed), or max|t| · ‖A‖_∞ exceeds
        :data:`MAX_SPAN`.

    Warns
    -----
    KrylovFallbackWarning
        ``skew=True`` but A is not skew-adjoint, or ``method="chebyshev"`` but its series
        failed its checks.

    Notes
    -----
    The exponential of A is never formed; the work is the products, O(n) per basis
    vector (O(n · :data:`IOM_WINDOW`) in the general case) and small dense matrices. See
    the module docstring for the algorithm.

    The Chebyshev series (Tal-Ezer & Kosloff 1984; Bergamaschi & Vianello 2000): with the
    spectrum of A in the strip |Im z| ≤ R, the Jacobi–Anger expansion
    exp(tA) = J₀(Rt) I + 2 Σ_{k≥1} J_k(Rt) P_k(A/R), P_{k+1} = 2(A/R)P_k + P_{k−1}, is a
    real three-term recurrence: one product and one copy per term, no inner products
    except near the end, every time of either sign from the same terms. For W-skew A it
    is rigorous in the W norm (‖P_k(A/R)‖_W ≤ 1); for non-normal A it is checked a
    posteriori (see :func:`_run_chebyshev`). For non-normal A (compressible fields) the
    error of an early step can be amplified by the later ones beyond the solution's own
    growth; single-step solves (the default m_max covers about 100 mean edge lengths of
    unit-speed transport) are not affected.

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> from fvf.numerics.expm import expm_action
    >>> A = sp.diags_array([np.ones(49), -np.ones(49)], offsets=[1, -1])  # skew
    >>> b = np.sin(np.linspace(0, 3, 50))
    >>> x = expm_action(A, b, [0.5, -1.0, 2.0])
    >>> x.shape, bool(np.allclose(np.linalg.norm(x, axis=1), np.linalg.norm(b)))
    ((3, 50), True)
    """
    Aop, n = _check_operator(A, finite=False)  # (a sparse A's entries: from ‖A‖_∞ below)
    times, scalar = as_times(t)
    method, tol = check_options(method, tol)
    if m_max is not None and (int(m_max) != m_max or m_max < 1):
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
    if inner is None:
        w = None
    else:
        w = np.asarray(inner, dtype=float)
        if w.shape != (n,):
            raise ExpmInputError(f"inner must be a weight vector of shape ({n},); got {w.shape}")
        lo, hi = (float(w.min()), float(w.max())) if n else (1.0, 1.0)  # (NaN: both NaN)
        if not (lo > 0 and hi < math.inf):
            bad = np.flatnonzero(~(np.isfinite(w) & (w > 0)))
            raise ExpmInputError(
                f"inner weights must be finite and > 0; bad entries at {bad[:8].tolist()}"
            )
        if lo == hi == 1.0:
            w = None
        else:
            w = w / hi  # only ratios matter; keeps tiny meshes (A_V ~ 1e-18) in range

    is_complex = np.iscomplexobj(Barr)
    B2 = Barr.reshape(n, -1 if n else (Barr.shape[1] if Barr.ndim == 2 else 1))
    if is_complex:
        B2 = np.hstack([B2.real, B2.imag])
    B2 = np.ascontiguousarray(B2, dtype=np.float64)
    p = B2.shape[1]

    out = np.empty((times.size, n, p))
    info: dict[str, Any] = {
        "method": None,
        "matvecs": 0,
        "block_matvecs": 0,
        "steps": 0,
        "basis_sizes": [],
        "error_estimate": 0.0,
        "skew": skew,
        "wasted_matvecs": 0,
        "bound_products": 0,
    }
    absA = _abs_of(Aop) if sp.issparse(Aop) else None  # shared by ‖A‖_∞ and the bound R
    a_norm = _norm_inf(Aop, absA)
    if absA is not None and not math.isfinite(a_norm):
        _check_finite(Aop)  # (finite entries whose row sums overflow: the span check)
    explicit_A = absA is not None or isinstance(Aop, np.ndarray)
    if explicit_A and 0 < a_norm < math.inf and not SCALE_RANGE[0] <= a_norm <= SCALE_RANGE[1]:
        Aop = Aop * (1.0 / a_norm)  # (a copy) exp(tA) = exp((t‖A‖)(A/‖A‖))
        times = times * a_norm
        skew_norm = None if skew_norm is None else skew_norm / a_norm
        absA = _abs_of(Aop) if sp.issparse(Aop) else None
        a_norm = _norm_inf(Aop, absA)
    span = float(np.abs(times).max()) * a_norm if times.size else 0.0
    if span > MAX_SPAN:
        raise FlowOverflowError(
            f"max|t| x ||A||_inf = {span:.3g} exceeds {MAX_SPAN:.0e}: the exponential needs "
            "so many steps that each underflows relative to t. Shorten t or rescale A "
            "(for a flow, a field of speed s for time t moves s*t)."
        )
    bound = None if skew_norm is None else float(skew_norm)
    explicit = method == "chebyshev"
    if method == "auto":  # after the check above: the bound is not spent on a refusal
        method, bound = _choose(Aop, times, bound, w, p, info, skew, absA, tol)
    if n == 0 or p == 0 or times.size == 0:
        out[:] = 0.0
    elif a_norm == 0.0 and not isinstance(Aop, spla.LinearOperator):
        out[:] = B2  # A = 0: exp(tA) = I exactly
        info["method"] = "zero"
    elif method == "expm_multiply":
        _run_expm_multiply(Aop, B2, times, out, info, count=return_info)
    else:
        if method == "chebyshev":
            if bound is None:
                if isinstance(Aop, spla.LinearOperator):
                    raise ExpmInputError(
                        "method='chebyshev' on a LinearOperator needs skew_norm (a bound of "
                        "the norm of its skew-adjoint part)"
                    )
                bound = _bound(Aop, w, times, p, info, absA, skew)
            method = "krylov" if bound == 0.0 else method  # A is W-symmetric: no strip
        if method == "chebyshev":
            try:
                with np.errstate(over="ignore", invalid="ignore"):
                    _run_chebyshev(
                        Aop, n, B2, times, out, info, tol, w, norm == "max", bound, skew is True
                    )
            except _ChebyshevFailed as exc:
                if explicit:
                    warnings.warn(
                        f"method='chebyshev' failed ({exc}); used the Krylov method.",
                        KrylovFallbackWarning,
                        stacklevel=2,
                    )
                info["wasted_matvecs"] += info["matvecs"]
                method = "krylov"
        if method == "krylov":
            done, calls = info["matvecs"], info["block_matvecs"]
            with np.errstate(over="ignore", invalid="ignore"):  # inf/NaN: FlowOverflowError
                _run_krylov(
                    Aop, n, B2, times, out, info, tol, w, skew, m_max, max_memory, norm == "max"
                )
            info["matvecs"] += done
            info["block_matvecs"] += calls

    if is_complex:
        q = p // 2
        res = out[:, :, :q] + 1j * out[:, :, q:]
    else:
        res = out
    res = res.reshape((times.size,) + Barr.shape)
    if scalar:
        res = res[0]
    return (res, info) if return_info else res


def _run_expm_multiply(
    A: Any, B2: np.ndarray, times: np.ndarray, out: np.ndarray, info: dict, count: bool
) -> None:
    """Chain scipy's expm_multiply over the sorted times of each sign (as FunctionalFlow
    does); with ``count``, through an :class:`ExpmvCounter` (its LinearOperator path)."""
    info["method"] = "expm_multiply"
    info["error_estimate"] = None
    trace = getattr(A, "trace", None)  # e.g. TransportOperator's exact trace
    if hasattr(A, "diagonal"):
        trace = float(A.diagonal().sum())
    elif not isinstance(trace, float):
        trace = None
    op = ExpmvCounter(A) if count else None
    for sign in (1.0, -1.0):
        pick = np.flatnonzero(sign * times > 0)
        order = pick[np.argsort(sign * times[pick], kind="stable")]
        current, now = B2, 0.0
        for i in order:
            dt = times[i] - now
            if dt != 0.0:
                with warnings.catch_warnings():  # "trace of LinearOperator not available"
                    warnings.simplefilter("ignore", UserWarning)
                    if op is not None or isinstance(A, spla.LinearOperator):
                        tr = None if trace is None else dt * trace
                        current = spla.expm_multiply(dt * (op or A), current, traceA=tr)
                    else:
                        current = spla.expm_multiply(dt * A, current)
                info["steps"] += 1
                now = times[i]
            out[i] = current
    out[times == 0] = B2
    if op is not None:
        info["matvecs"] = op.products
        info["block_matvecs"] = op.calls


# -------------------------------------------------------------------- Chebyshev series
def skew_bound(
    A: Any, inner: npt.ArrayLike | None = None, iterations: int = CHEB_BOUND_ITERATIONS
) -> float:
    """A rigorous upper bound of ‖K‖_W, K the skew-adjoint part of A in the W inner product.

    With S = D A D⁻¹, D = diag(√w), the W-skew part of A is similar to K = (S − Sᵀ)/2;
    every eigenvalue of A, and the imaginary part of every point of A's numerical range in
    the W inner product, lies in [−‖K‖₂, ‖K‖₂]. Since K is skew-symmetric,
    ‖K‖₂ = ρ(K) ≤ ρ(|K|) ≤ ρ(M) with M = ½(|S| + |S|ᵀ) off the diagonal (|K_ij| ≤ M_ij),
    and for any positive d the Collatz–Wielandt bound ρ(M) ≤ maxᵢ (M d)ᵢ / dᵢ holds. d = 1
    gives Gershgorin's bound; each of ``iterations`` power steps d ← M d tightens it (two
    products with |A|; 2·(iterations + 1) in all). For A = −D^V_v of a unit-speed field
    on the 94k-face spot mesh: Gershgorin 1.49× ‖K‖₂ (v = J grad y) and 1.51×
    (v = grad y); after 2 steps 1.15× and 1.24×, after 4 steps 1.10× and 1.18×; the limit
    ρ(M) is 1.06× and 1.13×.

    Parameters
    ----------
    A : sparse array/matrix or ndarray, shape (n, n), real
    inner : array_like (n,), optional
        Positive weights w of the inner product (default: all ones).
    iterations : int
        Power steps (≥ 0).

    Returns
    -------
    float
        The bound (≥ 0; 0 for a diagonal A).
    """
    Aop, n = _check_operator(A)
    if isinstance(Aop, spla.LinearOperator):
        raise ExpmInputError("skew_bound needs an explicit (sparse or dense) matrix")
    w = None
    if inner is not None:
        w = np.asarray(inner, dtype=float)
        if w.shape != (n,) or not np.isfinite(w).all() or (w <= 0).any():
            raise ExpmInputError(f"inner must be {n} finite weights > 0")
    if int(iterations) != iterations or iterations < 0:
        raise ExpmInputError(f"iterations must be an integer >= 0; got {iterations!r}")
    return _skew_bound(_abs_of(Aop), w, int(iterations))[0]


def _skew_bound(
    absA: _AbsCsr | _FusedAbs,
    w: np.ndarray | None,
    iterations: int = CHEB_BOUND_ITERATIONS,
    span: float = math.inf,
    skew: bool = False,
    floor: float = 0.0,
    handoff: float = math.inf,
    first_floor: float = 0.0,
) -> tuple[float, int]:
    """(bound, products with |A| spent) from |A| (:class:`_AbsCsr`). With a finite
    ``span`` (max|t| × columns), the power steps stop early once the last two steps
    together saved fewer terms (≈ span × the bound's decrease) than the products they
    cost, once the bound is below ``floor``, at Gershgorin's bound if it is below
    ``first_floor``, or at Gershgorin's bound if span × it is more than ``handoff`` (the
    caller then estimates ‖K‖ instead, see :func:`_bound`).

    Two steps, not one: a step can gain nothing and the next one much. On spot at 375k
    faces (v = grad y) Gershgorin's bound is 1.136× the limit, one step 1.136×, two
    1.108×, eight 1.020×; stopping at the first step that did not pay left R 1.29× ‖K‖
    on a block of 8 columns at 10 edge lengths, and 1,360 products where 8 steps needed
    1,248 (docs/notes.md, session 9). A clique with one pendant vertex does it at
    every other step (the tests).

    ``skew``: A is declared W-skew-adjoint. Then S = W^½ A W^−½ is skew-symmetric, K = A,
    P = |S| is symmetric and ½(P d + Pᵀ d) = P d: one product per step instead of two
    (ρ(P) ≥ ‖S‖₂ = ‖K‖_W; the bound is raised by 1e-12 relative for the round-off in
    the symmetry of P). A diagonal above round-off (1e-12 of the largest entry)
    contradicts the declaration; then both products are used.
    """
    n = absA.n
    if n == 0:
        return 0.0, 0
    dmax, amax = absA.diag_max()
    sym = skew and dmax <= 1e-12 * amax
    per_step = 1 if sym else 2
    s = np.ones(n) if w is None else np.sqrt(w)
    inv_s = 1.0 / s
    if isinstance(absA, _FusedAbs):  # the same steps in one compiled call
        best, products = _kernels.power_bound(
            absA.csr, s, inv_s, sym, iterations, span, floor, handoff, first_floor
        )
        return max(best, 0.0) * (1.0 + 1e-12 if sym else 1.0), products
    d = np.ones(n)
    best = math.inf
    products = 0
    gain = math.inf
    for k in range(iterations + 1):
        # M d = ½(P d + Pᵀ d) − |diag| d, P = diag(s)|A|diag(1/s) (|A| with its diagonal)
        Md, bound, top = absA.step(d, s, inv_s, sym)
        products += per_step
        last, gain, best = gain, best - bound, min(best, bound)
        if _kernels._power_stops(
            k, top, last, gain, span, per_step, best, floor, first_floor, handoff
        ):
            break
        d = np.maximum(Md / top, 1e-300)  # positive, so the bound stays rigorous
    return max(best, 0.0) * (1.0 + 1e-12 if sym else 1.0), products


def chebyshev_degree(tau: float, tol: float) -> int:
    """Terms of the series exp(iτx) = J₀(τ) + 2 Σ iᵏ J_k(τ) T_k(x) needed for an error
    below ``tol`` on [−1, 1]: the smallest m ≥ |τ| with 2 Σ_{k>m} |J_k(τ)| ≤ tol."""
    tau = abs(float(tau))
    if _kernels.ENABLED:  # (one compiled call: this runs between Lanczos' kernel runs)
        return _kernels.chebyshev_degree(tau, tol, _degree_top(tau), _BESSEL_TINY)
    return _degree(np.abs(_bessel(np.array([tau]), _degree_top(tau))[0]), tau, tol)


def _degree_top(tau: float) -> int:
    """An order beyond which 2 Σ_{k>m} |J_k(τ)| is far below any tolerance (τ ≥ 0)."""
    return int(tau + 12 * tau ** (1 / 3) + 60)


def _degree(absJ: np.ndarray, tau: float, tol: float) -> int:
    """:func:`chebyshev_degree` from |J_k(τ)| for k = 0 … top, (top + 1,)."""
    return _degree_from(_tails(absJ, tau), tau, tol)


def _tails(absJ: np.ndarray, tau: float) -> np.ndarray:
    """tail[i] = 2 Σ_{k ≥ ⌊τ⌋+1+i} |J_k| from |J_k(τ)| for k = 0 … top (non-increasing)."""
    J = absJ[int(tau) + 1 :]  # |J_k| for k = ⌊τ⌋+1 … top
    tail = 2.0 * np.cumsum(J[::-1])[::-1]
    return np.append(tail, 0.0)  # (top − ⌊τ⌋ + 1,): beyond top the table holds zeros


def _degree_from(tail: np.ndarray, tau: float, tol: float) -> int:
    """:func:`_degree` from the precomputed :func:`_tails` (one search per tol)."""
    i = int(np.searchsorted(-tail, -tol, side="left"))  # first i with tail[i] ≤ tol
    return int(tau) + min(i, tail.size - 1)


#: Below this |x| the Bessel recurrences would overflow in one step (2k/|x| · 1e200); the
#: leading terms of the series are exact to round-off there.
_BESSEL_TINY = 1e-8


def _bessel_row(x: float, kmax: int) -> np.ndarray:
    """J_k(x) for k = 0..kmax and one real x ≥ 0: (kmax + 1,) float64.

    :func:`_bessel_table`'s recurrence on Python floats: about 0.25 µs a step, where one
    ``scipy.special.jv`` value costs a few µs (this runs on every call of the series).
    """
    if x < _BESSEL_TINY:  # J₀ = 1 − x²/4, J₁ = x/2, J₂ = x²/8: exact to O(x³) here
        tab = np.zeros(kmax + 1)
        tab[: min(kmax, 2) + 1] = [1.0 - 0.25 * x * x, 0.5 * x, 0.125 * x * x][: kmax + 1]
        return tab
    start = int(x + 12.0 * x ** (1 / 3)) + 30  # past the turning point: J_start < 1e-20 max|J|
    inv, f_next, f = 2.0 / x, 0.0, 1e-200
    vals = []  # f_start, f_{start−1}, …, f_1
    for k in range(start, 0, -1):
        vals.append(f)
        f, f_next = k * inv * f - f_next, f
        if abs(f) > 1e200:  # rescale (entries far below underflow harmlessly)
            f, f_next = f * 1e-200, f_next * 1e-200
            vals = [v * 1e-200 for v in vals]
    vals.append(f)
    J = np.array(vals[::-1])  # f_0 … f_start
    J /= J[0] + 2.0 * J[2::2].sum()  # J₀ + 2 Σ J_{2k} = 1
    tab = np.zeros(kmax + 1)
    top = min(kmax, start)
    tab[: top + 1] = J[: top + 1]
    return tab


def _bessel_table(x: np.ndarray, kmax: int) -> np.ndarray:
    """J_k(x_j) for k = 0..kmax and real x (T,): (T, kmax + 1) float64.

    Miller's backward recurrence J_{k−1} = (2k/x) J_k − J_{k+1} from an order well past
    the turning point k ≈ |x| (where J decays superexponentially), normalized by
    J₀ + 2 Σ J_{2k} = 1; columns that grow past 1e200 are rescaled on the way. Accurate to
    a few ulps of max|J| (checked against scipy.special.jv in the tests); one vectorized
    pass for all x, where jv costs a few µs per value.
    """
    x = np.asarray(x, dtype=float)
    out = np.zeros((x.size, kmax + 1))
    a = np.abs(x)
    live = a >= _BESSEL_TINY
    for i in np.flatnonzero(~live):  # tiny |x|: the leading terms (a step would overflow)
        out[i] = _bessel_row(float(a[i]), kmax)
        out[i, 1::2] *= np.sign(x[i]) if x[i] != 0 else 1.0
    if not live.any():
        return out
    a = a[live]
    amax = float(a.max())
    inv = 2.0 / a
    tab = np.zeros((kmax + 1, a.size))  # orders beyond the start stay 0 (below 1e-20)
    f_next = np.zeros(a.size)  # f_{k+1}
    f = np.full(a.size, 1e-200)  # f_k
    even = np.zeros(a.size)  # Σ f_{2j}, j ≥ 1
    for k in range(int(amax + 12.0 * amax ** (1 / 3)) + 30, 0, -1):
        if k <= kmax:
            tab[k] = f
        if not k & 1:
            even += f
        f, f_next = (k * inv) * f - f_next, f
        if np.abs(f).max() > 1e200:
            big = np.abs(f) > 1e200
            f[big] *= 1e-200
            f_next[big] *= 1e-200
            even[big] *= 1e-200
            if k <= kmax:
                tab[k:, big] *= 1e-200
    tab[0] = f
    tab /= f + 2.0 * even
    t = tab.T
    t[x[live] < 0, 1::2] *= -1.0  # J_k(−x) = (−1)ᵏ J_k(x)
    out[live] = t
    return out


def _bessel(mags: np.ndarray, kmax: int) -> np.ndarray:
    """J_k(x_j) for k = 0..kmax and x_j ≥ 0 (mags (T,)): (T, kmax + 1) float64, a new array.

    With numba, compiled rows (:func:`~._kernels.bessel_rows`, ~5 ns a step; x below
    :data:`_BESSEL_TINY` by :func:`_bessel_row`'s series, in the kernel: the grids of the
    error checks start at 0, and that row alone in Python cost ~40 µs a check). Otherwise
    the distinct x only:
    one scalar recurrence (:func:`_bessel_row`) each, or the vectorized
    :func:`_bessel_table` when its steps (~7 µs each, one per order up to the largest
    x's) cost less than the scalar ones (~0.25 µs, one per order up to each x's own
    start; measured).
    """
    if _kernels.ENABLED:
        return _kernels.bessel_rows(mags, kmax, _BESSEL_TINY)
    if mags.size == 1:
        return _bessel_row(float(mags[0]), kmax)[None, :]
    mags, inv = np.unique(mags, return_inverse=True)
    steps = np.minimum(kmax, mags + 12.0 * np.cbrt(mags)) + 30.0  # (distinct,) per row
    if 0.25 * float(steps.sum()) <= 7.0 * float(steps.max()):
        J = np.stack([_bessel_row(float(x), kmax) for x in mags])
    else:
        J = _bessel_table(mags, kmax)
    return J[inv.ravel()]


def _cheb_coefficients(taus: np.ndarray, kmax: int) -> np.ndarray:
    """c_k(τ_j) = J_k(τ_j) (k = 0), 2 J_k(τ_j) (k ≥ 1) for k ≤ kmax: (T, kmax + 1), from
    :func:`_bessel` of |τ| (J_k(−τ) = (−1)ᵏ J_k(τ)). Raises _ChebyshevFailed on
    non-finite values (a defect, not an overflow of the series).
    """
    J = _bessel(np.abs(taus), kmax)
    J[taus < 0, 1::2] *= -1.0
    J[:, 1:] *= 2.0
    if not np.isfinite(J).all():
        raise _ChebyshevFailed("non-finite series coefficients")
    return J


def _col_norms(
    X: np.ndarray,
    w: np.ndarray | None,
    maxnorm: bool,
    tmp: np.ndarray | None = None,
    tmp_abs: np.ndarray | None = None,
) -> np.ndarray:
    """‖X[t, :, c]‖_W and max|X[t, :, c]|: (2, T, p) for X (T, n, p) (the second row ones
    when not ``maxnorm``). With numba one pass (:func:`~._kernels.col_norms`; numpy's
    calls cost 3–5× their warm time right after a kernel run); else numpy, with the
    optional temporaries of :func:`_wnorm2` and :func:`_absmax` for T = 1."""
    T, n, p = X.shape
    if _kernels.ENABLED and X.flags.c_contiguous and X.dtype == np.float64:
        return _kernels.col_norms(X.reshape(T, n * p), w, p, maxnorm)
    norms = np.ones((2, T, p))
    if T == 1:  # one time: the small-n BLAS paths of _wnorm2 (a few µs each)
        norms[0, 0] = _wnorm2(X[0], w, tmp)
    elif p == 1:  # squares and one GEMV (2x faster than einsum's 3-operand loop)
        sq = np.square(X.reshape(T, n))
        norms[0, :, 0] = sq.sum(axis=1) if w is None else sq @ w
    elif w is None:
        norms[0] = np.einsum("tnp,tnp->tp", X, X)
    else:
        norms[0] = np.einsum("tnp,n,tnp->tp", X, w, X)
    np.sqrt(norms[0], out=norms[0])
    if maxnorm:
        if T == 1:
            norms[1, 0] = _absmax(X[0], tmp_abs)
        else:
            norms[1] = np.abs(X).max(axis=1) if p == 1 else [_absmax(x) for x in X]
    return norms


def _inverse_norms(X: np.ndarray, w: np.ndarray | None, maxnorm: bool) -> np.ndarray:
    """1 / :func:`_col_norms` (0 for zero columns): (2, T, p)."""
    norms = _col_norms(X, w, maxnorm)
    return _safe_div(np.ones_like(norms), norms)


#: Coefficients past the last term that :func:`_series_tail` sums (they decay
#: super-exponentially there: ~1e-30 of the first one at R·t = 100).
_TAIL_TERMS = 64


def _series_tail(
    absc: np.ndarray,
    k: int,
    base: np.ndarray,
    growth: np.ndarray,
    bounded: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Estimate of the truncation error ‖Σ_{j>k} c_j y_j‖ of the Chebyshev series.

    Parameters
    ----------
    absc : ndarray (T, K)
        |c_j(τ_i)| for the T times.
    k : int
        The last term summed.
    base : ndarray (T, p)
        max(‖y_k‖, ‖y_{k−1}‖) relative to each output (the larger of its W- and max-norm
        ratios).
    growth : ndarray (p,)
        The measured growth of ‖y_j‖ per term, √(‖y_k‖ / ‖y_{k−2}‖) (over two terms:
        ‖y_j‖ can alternate between consecutive terms).
    bounded : ndarray (T, p), optional
        For a declared W-skew A (R ≥ ‖A‖_W, so ‖y_j‖_W ≤ ‖B‖_W for every j):
        ‖B‖_W / ‖X‖_W, which makes Σ_{j>k} |c_j| · bounded a rigorous bound of the W-norm
        error; the estimate is at least that.

    Returns
    -------
    estimate : ndarray (T, p)
        Σ_{j>k} |c_j| · base · g^{j−k+1}, g = max(growth, 1): the terms to come are taken
        to grow at the rate measured last, from the larger of the last two, with one
        extra factor g for a term that alternates. Non-normal A: ‖y_j‖ grows by up to
        ~1.4 per term near the end for compressible fields, while |c_j| falls by 3–10.
    decaying : ndarray (T, p) of bool
        g |c_{k+1}| ≤ ½ |c_k|: the estimated terms decay geometrically from here (the
        estimate is meaningful).

    Notes
    -----
    The previous rule took the last two summed terms, |c_k| ‖y_k‖ + |c_{k−1}| ‖y_{k−1}‖,
    relative to B. They exceed the error by |c_{k−1}| / |c_{k+1}| ≈ 10–100, and max|X|
    can be 60 max|B| for a compressible flow; this stops 1–6 terms earlier, the error
    still within the estimate (docs/notes.md, session 7).
    """
    c = absc[:, k + 1 : k + 1 + _TAIL_TERMS]  # (T, L)
    g = np.minimum(np.maximum(growth, 1.0), 10.0)  # (p,) (10^65: no overflow)
    powers = g[None, :] ** np.arange(2, c.shape[1] + 2)[:, None]  # (L, p)
    est = (c @ powers) * base  # (T, p)
    if bounded is not None:
        est = np.maximum(est, absc[:, k + 1 :].sum(axis=1)[:, None] * bounded)
    decaying = absc[:, k + 1, None] * g <= 0.5 * absc[:, k, None]
    return est, decaying


class _ChebyshevFailed(Exception):
    """Internal: the series did not converge or cancelled beyond the tolerance."""


def _run_chebyshev(
    Aop: Any,
    n: int,
    B2: np.ndarray,
    times: np.ndarray,
    out: np.ndarray,
    info: dict,
    tol: float,
    w: np.ndarray | None,
    maxnorm: bool,
    bound: float,
    keep_norm: bool = False,
) -> None:
    """Fill out (T, n, p) with exp(t_j A) B2 by the Chebyshev series in A/R (R = bound).

    ``keep_norm`` (A declared W-skew, so exp(tA) is W-unitary): every output column is
    rescaled to the W-norm of its column of B, which keeps the norm to round-off as the
    Lanczos recurrence does, wherever the error estimate plus the relative size of that
    correction is within tol. The rescaled column's error is at most that sum, whether
    or not A is skew: the correction moves X by |‖B‖ − ‖X‖| and the estimate bounds
    ‖X − exp(tA)B‖. For W-skew A the correction is at most the true error, so the sum is
    at most twice the estimate, which the stopping rule keeps near tol/2 or below.
    Elsewhere the column is left as computed (within tol, norm within tol).
    ⟨A B, B⟩_W = 0 is checked first (raises _ChebyshevFailed: the Krylov method then
    checks, warns and proceeds as for a wrong ``skew=True``).

    With A ≈ iR·x (x ∈ [−1, 1] on A's spectrum), the Jacobi–Anger expansion gives
    exp(tA) = J₀(Rt) I + 2 Σ_{k≥1} J_k(Rt) P_k(A/R), with P₀ = I, P₁ = A/R and the real
    three-term recurrence P_{k+1} = 2 (A/R) P_k + P_{k−1} (P_k(ix) = iᵏ T_k(x)). All times
    (either sign: J_k(−τ) = (−1)ᵏ J_k(τ)) and all columns share the vectors y_k = P_k B;
    the outputs are accumulated by one GEMM per chunk of 16–64 terms (for one time, each term
    at once, while it is in cache). A term costs one product and one copy. For
    W-skew-adjoint A and R ≥ ‖A‖_W,
    ‖P_k(A/R)‖_W = max|T_k| ≤ 1, so the truncation error is at most
    2 Σ_{k>m} |J_k(Rt)| ‖B‖_W. Otherwise (non-normal A) the terms may grow before they
    decay; the series is controlled a posteriori: the terms are measured at every
    :data:`CHEB_CHECK_EVERY`-th step (growth beyond what rounding allows stops the series),
    at step :data:`CHEB_EARLY_CHECK` if that comes earlier than the next (growth beyond
    :data:`CHEB_EARLY_GROWTH` there stops it: a spectrum far from the imaginary axis),
    and at every step from the a-priori degree (:func:`chebyshev_degree`) less three on.
    There the partial sums S are already the outputs to ~tol‖y‖, and their W- and max-norms
    are taken once, so that the estimates are relative to the outputs, as tol is. The
    series stops at the first m where the estimate of the truncation error
    (:func:`_series_tail`: the coefficients to come, times the larger of the last two
    ‖y‖/‖S‖, grown at the rate measured over the last two terms; for a declared W-skew A
    at least the rigorous Σ_{j>m} |c_j| ‖B‖_W/‖S‖_W) is within SAFETY·tol and decaying;
    while it is not, the next measurement is at the a-priori degree for SAFETY·tol /
    (‖y_m‖/‖S‖), less three (terms that grew by non-normality need more coefficient
    decay), or the next step. The rounding error is estimated as
    NOISE·√m·max_k |c_k| ‖y_k‖ (relative to B). Both are checked against the outputs' own
    norms at the end; raises _ChebyshevFailed if they miss tol.
    """
    p = B2.shape[1]
    T = times.size
    R = float(bound)
    taus = times * R
    tau_max = float(np.abs(taus).max())
    k_cap = int(1.5 * tau_max + 12 * tau_max ** (1 / 3) + 80)
    budget = SAFETY * tol
    # one Bessel pass gives the coefficients and the a-priori degree for W-normal A
    # (within 2 terms of where the series stops): the terms are measured at every step
    # from there on, and at every CHEB_CHECK_EVERY-th before
    coef = _cheb_coefficients(taus, _degree_top(tau_max))  # (T, K): c_k(τ_j), extended later
    row = 0.5 * np.abs(coef[int(np.argmax(np.abs(taus)))])  # |J_k(τ_max)| (k ≥ 1)
    row[0] *= 2.0
    tails = _tails(row, tau_max)
    next_check = _degree_from(tails, tau_max, budget) - 3
    absc = np.abs(coef)
    op = _Operator(Aop, n, scale=2.0 / R)
    mv = op.kernel(p)  # y += (2/R) A x on flat (n·p,) vectors
    fused = op.fused  # numba's fused kernels (fvf.numerics._kernels), or None
    s2 = np.zeros((3, p))  # norms of the last term (numba, one column)
    storage = None
    try:
        nu0, inf0 = _col_norms(B2[None], w, maxnorm)[:, 0]  # (p,) W- and max-norms of B
        inv_nu0 = _safe_div(np.ones(p), nu0)
        inv_inf0 = _safe_div(np.ones(p), inf0)
        # T = 1: each term is added to the output at once, while it is in cache, and
        # y_{k+1} overwrites y_{k−1} (two vectors, no copies); T > 1: chunks of terms, one
        # GEMM each into the T outputs, and y_{k+1} starts as a copy of y_{k−1}.
        chunk = 2
        if T > 1:
            chunk = max(3, min(int(np.clip(4 * T, 16, 64)), int(CHEB_MEMORY // (8.0 * n * p))))
        # y_{k0} … y_{k0 + filled − 1} (T > 1): the kept storage, whose pages are mapped
        # already (a fresh chunk of 64 terms faulted its pages in on every call: 16 times
        # took 1.2–1.4× as long from 171k faces on, docs/notes.md)
        storage = _basis_storage(chunk * n * p)
        buf = storage[: chunk * n * p].reshape(chunk, n, p)
        flat = buf.reshape(chunk, n * p)
        acc = out.reshape(T, n * p)
        acc[:] = 0.0
        np.copyto(buf[0], B2)
        buf[1].fill(0.0)
        mv(flat[0], flat[1])
        op.count(1, p)
        buf[1] *= 0.5  # y_1 = (A/R) B
        if keep_norm and tau_max > 0:  # ⟨A B, B⟩_W = 0 for W-skew A; Lanczos' limit per R
            diag = np.abs(_wdot(buf[1], buf[0], w)) * inv_nu0 * inv_nu0  # (p,)
            limit = max(0.1 * tol / tau_max, 1e-12)  # 0.1·tol/(max|t|·R)
            if float(diag.max()) > limit:
                raise _ChebyshevFailed(
                    f"skew=True but |<A b, b>_W| / (R ||b||^2) = {float(diag.max()):.3g}"
                )
        if T == 1:
            acc[0] += coef[0, 0] * flat[0]
            _AXPY(flat[1], acc[0], a=coef[0, 1])
        cur_i = 1  # slot of y_k
        tmp = _norm_workspace(n, p, w)
        tmp_abs = np.empty((n, p)) if maxnorm else None
        k0, start, filled, k = 0, 0, 2, 1  # T > 1: slots [start, filled) not yet added
        peak = np.ones(p)  # largest |c_k| ‖y_k‖ / ‖B‖ seen (rounding ≈ NOISE × peak)
        tail = np.full((T, p), np.inf)  # the truncation error's estimate, relative to X
        prev_k, prev2_k = -3, -3  # the last two measured k
        prev_rel = prev2_rel = np.ones(p)  # ‖y‖ / ‖B‖ there
        prev_out = None  # ‖y‖ / ‖S‖ at prev_k, (T, p)
        inv_out = None  # (2, T, p): 1 / (W-, max-norms) of the partial sums, near the end
        grow_limit = CHEB_GROWTH * tol / NOISE
        # one column, one time, numba: the term before a measurement also measures y_k
        fused_norms = fused is not None and T == 1 and p == 1
        wk = (np.ones(n) if w is None else w) if fused_norms else None
        norms_k = -1  # the k whose norms s2 holds
        while True:
            if k >= next_check or k % CHEB_CHECK_EVERY == 0 or k == CHEB_EARLY_CHECK:
                cur = buf[cur_i]
                if norms_k == k:  # (1,) ‖y_k‖_W, max|y_k| from the kernel
                    y_w, y_max = np.sqrt(s2[0, :1]), s2[1, :1].copy()
                else:  # (p,) each
                    y_w, y_max = _col_norms(cur[None], w, maxnorm, tmp, tmp_abs)[:, 0]
                rel = y_w * inv_nu0  # (p,) ‖y_k‖ / ‖B‖ (the larger of the two norms)
                if maxnorm:
                    rel = np.maximum(rel, y_max * inv_inf0)
                if not math.isfinite(float(rel.sum())):
                    raise FlowOverflowError(_NONFINITE)
                early = k == CHEB_EARLY_CHECK and k < next_check  # (not where it may stop)
                if early and float(rel.max()) > CHEB_EARLY_GROWTH:
                    raise _ChebyshevFailed(
                        f"the terms grew by {float(rel.max()):.3g} in {k} terms (a spectrum "
                        "far from the imaginary axis)"
                    )
                peak = np.maximum(peak, (absc[:, k, None] * rel).max(axis=0))
                if k >= next_check and inv_out is None:
                    # the partial sums are within ~tol·‖y‖ of the outputs from here on:
                    # their norms make the estimates relative to the outputs (as tol is),
                    # not to B (compressible flows concentrate f: max|X| up to 60 max|B|)
                    if T > 1:  # add the pending terms to the outputs
                        _add_product(acc, coef[:, k0 + start : k0 + filled], flat[start:filled])
                        start = filled
                    inv_out = _inverse_norms(out, w, maxnorm)
                rel_out = None
                if inv_out is not None:  # (T, p) ‖y_k‖ / ‖S_k‖ (the larger of the norms)
                    rel_out = y_w * inv_out[0]
                    if maxnorm:
                        rel_out = np.maximum(rel_out, y_max * inv_out[1])
                # the estimate needs the two terms before this one measured too
                ready = prev_k == k - 1 and prev2_k == k - 2 and prev_out is not None
                if ready:
                    # ‖y_j‖ may alternate between terms (by 3× for J grad g on spheres):
                    # growth over two terms, from the larger of the last two norms
                    growth = np.sqrt(_safe_div(rel, prev2_rel))  # (p,) per term
                    base = np.maximum(rel_out, prev_out)  # (T, p)
                    bounded = nu0 * inv_out[0] if keep_norm else None  # ‖B‖_W / ‖S_k‖_W
                    tail, decaying = _series_tail(absc, k, base, growth, bounded)
                if float(peak.max()) * math.sqrt(k) > grow_limit:
                    # terms this large cancel beyond tol unless the solution itself is as
                    # large (strongly non-normal A, or a real spectrum): let Krylov do it
                    raise _ChebyshevFailed(
                        f"the terms grew to {float(peak.max()):.3g} x the initial value at "
                        f"degree {k} (rounding beyond tol)"
                    )
                if k >= next_check:
                    if ready and bool(((tail <= budget) & decaying).all()):
                        break
                    # not yet (the terms grew: non-normal A): the degree for the grown
                    # terms, less three, is where to look next
                    grown = budget / max(float(rel_out.max()), 1e-300)
                    next_check = max(k + 1, _degree_from(tails, tau_max, grown) - 3)
                prev2_k, prev_k = prev_k, k
                prev2_rel, prev_rel, prev_out = prev_rel, rel, rel_out
            if k > k_cap:
                raise _ChebyshevFailed(f"no convergence after {k} terms (R·max|t| = {tau_max:.3g})")
            if k + 2 >= coef.shape[1]:
                coef = _cheb_coefficients(taus, k_cap + 2)
                absc = np.abs(coef)
            # the terms up to the next measured one, with no other work
            every = CHEB_CHECK_EVERY
            stop = min(next_check if k < next_check else k + 1, (k // every + 1) * every)
            if k < CHEB_EARLY_CHECK:
                stop = min(stop, CHEB_EARLY_CHECK)
            stop = min(stop, k_cap + 1)
            stop = max(min(stop, coef.shape[1] - 2), k + 1)
            op.count(stop - k, p)
            if T == 1:  # y_{k+1} = 2 (A/R) y_k + y_{k−1}, in the slot of y_{k−1}
                c0, out0 = coef[0], acc[0]
                if fused is not None:  # the run of terms in one call, each term's
                    # product and axpy in one pass, the last one's norms too (numba)
                    _kernels.term_run(fused, flat, cur_i, out0, c0[k + 1 : stop + 1], p, wk, s2)
                    if (stop - k) % 2:
                        cur_i = 1 - cur_i
                    k = stop
                    norms_k = k if fused_norms else -1
                    continue
                while k < stop:
                    cur_i = 1 - cur_i
                    mv(flat[1 - cur_i], flat[cur_i])
                    k += 1
                    _AXPY(flat[cur_i], out0, a=c0[k])
                continue
            while k < stop:  # T > 1: into the next slots of the chunk, y_{k+1} = y_{k−1} + …
                if filled == chunk:  # add the chunk, keep y_{k−1}, y_k in slots 0 and 1
                    _add_product(acc, coef[:, k0 + start : k0 + chunk], flat[start:])
                    np.copyto(buf[0], buf[chunk - 2])
                    np.copyto(buf[1], buf[chunk - 1])
                    k0, start, filled = k - 1, 2, 2
                run = min(stop - k, chunk - filled)
                if fused is not None:  # copy and product in one pass, the run in one call
                    _kernels.term_chain(fused, flat, filled, run, p)
                else:
                    for f in range(filled, filled + run):
                        np.copyto(buf[f], buf[f - 2])
                        mv(flat[f - 1], flat[f])  # y_{k+1} = 2 (A/R) y_k + y_{k−1}
                filled += run
                k += run
            cur_i = filled - 1
        if T > 1:
            _add_product(acc, coef[:, k0 + start : k0 + filled], flat[start:filled])
        if not np.isfinite(acc).all():
            raise FlowOverflowError(_NONFINITE)
        # the outputs' own norms decide: the rounding was relative to B, the tail to the
        # partial sums S whose norms were taken near the end
        rounding = peak * NOISE * math.sqrt(k)  # (p,)
        inv_x = _inverse_norms(out, w, maxnorm)  # (2, T, p)
        ratio = nu0 * inv_x[0]  # (T, p) ‖B_c‖_W / ‖X_jc‖_W
        s_over_x = _safe_div(inv_x, inv_out)  # (2, T, p) ‖S‖ / ‖X‖ (≈ 1)
        if maxnorm:
            rel_b = np.maximum(ratio, inf0 * inv_x[1])
            s_over_x = np.maximum(s_over_x[0], s_over_x[1])
        else:
            rel_b, s_over_x = ratio, s_over_x[0]
        err = tail * s_over_x + rounding * rel_b
        err[inv_x[0] == 0] = 0.0  # zero outputs (zero columns of B) are exact
        worst = float(err.max()) if err.size else 0.0
        if worst > tol:
            raise _ChebyshevFailed(
                f"error estimate {worst:.3g} > tol = {tol:.3g} "
                f"(rounding {float(rounding.max()):.3g})"
            )
        if keep_norm:  # rescale to ‖B_c‖_W where estimate + correction stay within tol
            fix = np.abs(ratio - 1.0)  # the correction, relative to ‖X_jc‖_W
            ok = (err + fix <= tol) & (inv_x[0] > 0)
            out *= np.where(ok, ratio, 1.0)[:, None, :]
            worst = float(np.where(ok, err + fix, err).max()) if err.size else 0.0
    finally:
        info["matvecs"] += op.matvecs
        info["block_matvecs"] += op.calls
        if storage is not None:
            _keep_storage(storage)
    info["method"] = "chebyshev"
    info["steps"] += 1
    info["basis_sizes"].append(k + 1)
    info["error_estimate"] = worst
    info["skew_bound"] = R


# ------------------------------------------------------------------------ Krylov sweeps
def _run_krylov(
    Aop: Any,
    n: int,
    B2: np.ndarray,
    times: np.ndarray,
    out: np.ndarray,
    info: dict,
    tol: float,
    w: np.ndarray | None,
    skew: bool | None,
    m_max: int | None,
    max_memory: float,
    maxnorm: bool,
) -> None:
    """Fill out (T, n, p) with exp(t_j A) B2: one sweep over the sorted |t| of each sign."""
    op = _Operator(Aop, n)
    p = B2.shape[1]
    out[times == 0] = B2
    use_skew = skew is not False
    for sign in (1.0, -1.0):
        sel = np.flatnonzero(sign * times > 0)
        if sel.size == 0:
            continue
        mags = sign * times[sel]
        in_order = sel.size == 1 or bool((np.diff(mags) > 0).all())
        if in_order:  # distinct and increasing (np.unique costs 20-70 µs a call)
            s_unique, first, inverse = mags, np.arange(sel.size), np.arange(sel.size)
        else:
            s_unique, first, inverse = np.unique(mags, return_index=True, return_inverse=True)
        slots = sel[first]  # the row of out that receives each distinct time
        in_order = in_order and int(slots[-1] - slots[0]) == slots.size - 1
        sweep = _Sweep(op, w, s_unique, sign, tol, maxnorm, out, slots, info, in_order)
        if use_skew:
            m_want = M_MAX_SKEW if m_max is None else int(m_max)
            group, m_cap = _group_size(n, p, m_want, max_memory)
            before = op.matvecs
            try:
                for c0 in range(0, p, group):
                    _lanczos_sweep(sweep, B2, slice(c0, min(p, c0 + group)), m_cap)
                info["method"] = "lanczos"
                info["skew"] = True
            except _NotSkew as exc:
                if skew is True:
                    warnings.warn(
                        f"skew=True but A is not skew-adjoint in the given inner product "
                        f"({exc}); using the general (incomplete orthogonalization) method.",
                        KrylovFallbackWarning,
                        stacklevel=3,
                    )
                info["wasted_matvecs"] += op.matvecs - before
                use_skew = False
        if not use_skew:
            # at most n vectors, all orthogonalized when the basis can span Rⁿ: beyond n
            # they are dependent, incomplete orthogonalization does not notice and the
            # combination cancels (a compressible flow on a 42-vertex sphere over 40 time
            # units came out 540× tol off with bases of 100); fully orthogonalized, the
            # basis breaks down at n and the step is exact (the tests)
            m_want = min(M_MAX_IOM if m_max is None else int(m_max), n)
            _, m_cap = _group_size(n, 1, m_want, max_memory)
            for c in range(p):
                _iom_sweep(sweep, B2, c, m_cap, IOM_WINDOW if m_cap < n else n)
            info["method"] = "iom"
            info["skew"] = False
        rep = sel != slots[inverse]  # repeated times: copy the first occurrence
        if rep.any():
            out[sel[rep]] = out[slots[inverse[rep]]]
        info["matvecs"] = op.matvecs
        info["block_matvecs"] = op.calls


def _group_size(n: int, p: int, m_want: int, max_memory: float) -> tuple[int, int]:
    """(columns per simultaneous group, basis cap) for bases within ``max_memory`` bytes.

    All p columns run together when a basis of min(m_want, 64) + 1 vectors of each fits;
    otherwise the columns are split into groups that allow it. The basis cap is then as
    large as memory allows, up to m_want.
    """
    per_vec = 8.0 * n
    m_min = min(m_want, 64)
    group = int(max(1, min(p, max_memory // (per_vec * (m_min + 1)))))
    m_cap = int(max(1, min(m_want, max_memory // (per_vec * group) - 1)))
    return group, m_cap


def _combine(V: np.ndarray, m: int, C: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Σ_j V[j, :, c] C[c, k, j] -> (K, n, p) for V (m+1, n, p), C (p, K, m); into ``out``
    (K, n, 1), C-contiguous, if given (p = 1 only).

    p = 1 is one GEMM. For p > 1 the per-column coefficients are applied with one GEMM per
    chunk of rows against all columns at once, (p·K, m) @ (m, rows·p), keeping the
    diagonal blocks c = c': p times the flops of the useful ones, but one streaming read of
    the basis (a transposed copy of it costs more on memory-bound machines).
    """
    _, n, p = V.shape
    K = C.shape[1]
    if p == 1:
        if out is not None:
            np.matmul(C[0], V[:m, :, 0], out=out[:, :, 0])
            return out
        return (C[0] @ V[:m, :, 0])[:, :, None]
    Z = V[:m].reshape(m, n * p)
    Call = C.reshape(p * K, m)
    res = np.empty((K, n, p))
    nb = max(64, int(2**19 // (p * K * p)))  # rows per chunk: ~4 MB of GEMM output
    for a in range(0, n, nb):
        b = min(n, a + nb)
        G = (Call @ Z[:, a * p : b * p]).reshape(p, K, b - a, p)
        res[:, a:b, :] = np.einsum("cknc->knc", G)
    return res


class _Lanczos:
    """The unnormalized three-term recurrence y_{j+1} = A y_j + (β_{j−1} ν_j/ν_{j−1}) y_{j−1}.

    y_j = ν_j u_j with known ν_j (no normalization pass over the vectors), so that
    y_{j+1} = ν_j β_j u_{j+1}; β_j = ‖y_{j+1}‖_W / ν_j. One instance per Krylov step, on
    the basis storage V (m_cap + 1, n, p) whose V[0] holds the start vectors. With numba,
    p = 1 runs its whole step in one compiled call (:func:`_compiled_step`; with
    :data:`_COMPILED_STEP` off, in compiled runs of vectors by :meth:`extend_to`, the
    compiled step's reference in the tests); without, on Python floats (few numpy calls
    per vector: this path is what small meshes pay).
    Every 8th vector (and the first three) it checks that H_m is skew tridiagonal.
    """

    def __init__(self, op: _Operator, w: np.ndarray | None, V: np.ndarray, limit: float) -> None:
        self.op, self.w, self.V, self.limit = op, w, V, limit
        m_cap1, n, p = V.shape
        self.p = p
        self.fused = op.fused  # numba: scaled copy, product and norm in one pass
        if self.fused is not None:
            self.wk = np.ones(n) if w is None else np.ascontiguousarray(w, dtype=np.float64)
            if p == 1:
                self.res = np.zeros(6)  # lanczos_run's status
            else:
                self.s2 = np.zeros((3, p))
                self.c = np.zeros(p)
        self.beta = np.zeros((m_cap1 - 1, p))
        self.nu = np.zeros((m_cap1, p))
        self.m = 0
        if p == 1:
            self.V1 = V[:, :, 0]
            self.bsum1 = 0.0
            x = self.V1[0]
            self.nu[0, 0] = nu0 = math.sqrt(float(np.dot(x, x if w is None else w * x)))
            if self.fused is None:  # what _extend1 uses
                self.mv = op.kernel(1)  # y += A x on vectors, counted here
                self.stream = n >= _STREAM_N
                self.tmp = None if self.stream or w is None else np.empty(n)
                self.nu1 = [nu0]
                self.b1: list[float] = []
        else:
            self.tmp = _norm_workspace(n, p, w)
            self.nu[0] = np.sqrt(_wnorm2(V[0], w, self.tmp))
            self.inv_nu = _safe_div(np.ones(p), self.nu[0])
            self.inv_nu_prev = np.zeros(p)
            self.bsum = np.zeros(p)

    def mean_beta(self) -> float:
        """Largest mean of the coefficients β over the columns (≈ half the spectral radius)."""
        top = self.bsum1 if self.p == 1 else float(np.max(self.bsum))
        return top / max(self.m, 1)

    def extend_to(self, target: int) -> None:
        """Add vectors up to ``target`` (fewer at a breakdown): for one column with numba
        one call of the compiled run (:func:`~._kernels.lanczos_run`: the Python work
        per vector was ~8 µs, a third of a product at 6k faces), else one
        :meth:`extend` each."""
        if self.p == 1 and self.fused is not None:
            j0 = self.m
            if target <= j0:
                return
            res = self.res
            nu, beta = self.nu[:, 0], self.beta[:, 0]  # (views: filled in place)
            _kernels.lanczos_run(
                self.fused, self.V1, self.wk, nu, beta, j0, target, self.bsum1, self.limit, res
            )
            # (a failed vector's product counts too)
            self.take_run(res, int(res[1]) - j0 + (int(res[0]) in (1, 2)))
            return
        while self.m < target:
            self.extend()
            if self.broken():
                return

    def take_run(self, res: np.ndarray, products: int) -> None:
        """Take the state a compiled run left for one column (res as
        :func:`~._kernels.lanczos_run` fills it: status, m, Σβ, then diag, off, scale)
        and count its products; raise for a non-finite norm or a failed skew check."""
        self.op.count(products, 1)
        self.m, self.bsum1 = int(res[1]), float(res[2])
        status = int(res[0])
        if status == 1:
            raise FlowOverflowError(_NONFINITE)
        if status == 2:
            _check_skew(float(res[3]), float(res[4]), float(res[5]), self.limit)
            raise _NotSkew("the skew check failed")  # pragma: no cover - raised above

    def extend(self) -> None:
        """Add one vector (one product with A on the block)."""
        if self.p == 1:
            self._extend1()
        else:
            self._extend_block()

    def _extend1(self) -> None:
        """One vector of one column on the numpy/scipy path (numba: :meth:`extend_to`)."""
        j, V, w, nu, b1 = self.m, self.V1, self.w, self.nu1, self.b1
        vn = V[j + 1]
        if j == 0:
            vn.fill(0.0)
        else:
            c = b1[j - 1] * nu[j] / nu[j - 1] if nu[j - 1] > 0 else 0.0
            np.multiply(V[j - 1], c, out=vn)
        self.mv(V[j], vn)
        self.op.count(1, 1)
        if w is None:
            wv = vn
            nz = math.sqrt(float(np.dot(vn, vn)))
        elif self.stream:  # large n: one read of w and vn, no temporary
            wv = None
            nz = math.sqrt(float(np.einsum("i,i,i->", w, vn, vn)))
        else:  # small n (in cache): BLAS dot beats einsum's generic loop
            wv = np.multiply(w, vn, out=self.tmp)
            nz = math.sqrt(float(np.dot(wv, vn)))
        if not math.isfinite(nz):
            raise FlowOverflowError(_NONFINITE)
        b = nz / nu[j] if nu[j] > 0 else 0.0
        if j < 3 or j % 8 == 7:

            def dot(x):
                return np.dot(wv, x) if wv is not None else np.einsum("i,i,i->", w, vn, x)

            diag = abs(float(dot(V[j]))) / (nu[j] * nu[j]) if nu[j] > 0 else 0.0
            off = 0.0
            if j and nu[j] * nu[j - 1] > 0:
                off = abs(float(dot(V[j - 1]))) / (nu[j] * nu[j - 1])
            _check_skew(diag, off, max(b, self.bsum1 / max(j, 1)), self.limit)
        if nz > 1e150 or 0.0 < nz < 1e-150:  # keep the unnormalized vectors in range
            vn *= 1.0 / nz
            nz = 1.0
        b1.append(b)
        nu.append(nz)
        self.beta[j, 0] = b
        self.nu[j + 1, 0] = nz
        self.bsum1 += b
        self.m = j + 1

    def _extend_block(self) -> None:
        j, V, w, p = self.m, self.V, self.w, self.p
        nu, beta = self.nu, self.beta
        Vn = V[j + 1]
        check = j < 3 or j % 8 == 7  # H_m's new column is checked (below)
        dots = None
        if self.fused is not None:  # numba: scaled copy, product, norms and dots in one pass
            np.copyto(self.c, self.coef if j else 0.0)
            prev = V[j - 1] if j else V[j]  # (ignored for j = 0: c = 0)
            fl = (V[j].reshape(-1), prev.reshape(-1), Vn.reshape(-1))
            s2 = self.s2
            _kernels.term_combine(
                self.fused, fl[0], fl[1], self.c, fl[2], self.wk, s2, p, 1 + check
            )
            self.op.count(1, p)
            nz = np.sqrt(s2[0])
            dots = (s2[1].copy(), s2[2].copy())  # (p,) <Vn, V[j]>_W, <Vn, V[j-1]>_W
        else:
            if j == 0:
                Vn.fill(0.0)
            else:
                np.multiply(V[j - 1], self.coef, out=Vn)
            self.op.accumulate(V[j], Vn)
            nz = np.sqrt(_wnorm2(Vn, w, self.tmp))
        lo, hi = float(nz.min()), float(nz.max())
        if not math.isfinite(hi):
            raise FlowOverflowError(_NONFINITE)
        inv_nu = self.inv_nu  # 1/ν_j (0 for a zero column)
        b = nz * inv_nu
        if check:
            if dots is None:
                dots = (_wdot(Vn, V[j], w, self.tmp), _wdot(Vn, V[j - 1], w, self.tmp) if j else 0)
            diag = np.abs(dots[0]) * inv_nu * inv_nu
            off = np.abs(dots[1]) * inv_nu * self.inv_nu_prev if j else b * 0
            scale = max(float(b.max()), float(self.bsum.max()) / max(j, 1))
            _check_skew(float(diag.max()), float(off.max()), scale, self.limit)
        if hi > 1e150 or 0.0 < lo < 1e-150:  # keep the unnormalized vectors in range
            big = (nz > 1e150) | ((nz < 1e-150) & (nz > 0))
            np.multiply(Vn, np.where(big, _safe_div(np.ones(p), nz), 1.0), out=Vn)
            nz = np.where(big, 1.0, nz)
        beta[j] = b
        nu[j + 1] = nz
        self.bsum += b
        self.coef = b * nz * inv_nu  # β_j ν_{j+1} / ν_j, for the next vector
        self.inv_nu_prev, self.inv_nu = inv_nu, _safe_div(np.ones(p), nz)
        self.m = j + 1

    def broken(self) -> bool:
        """True when every column hit an invariant subspace (β = 0): the basis is exact."""
        if self.p == 1:
            return float(self.beta[self.m - 1, 0]) == 0.0
        return bool((self.beta[self.m - 1] == 0).all())


@dataclass
class _Sweep:
    """What the steps of one sweep (one sign of t) share."""

    op: _Operator
    w: np.ndarray | None  # inner-product weights (None: Euclidean)
    s_targets: np.ndarray  # sorted distinct |t| > 0 of this sign
    sign: float
    tol: float
    maxnorm: bool  # control the max-norm error too
    out: np.ndarray  # (T, n, p): the result of expm_action
    slots: np.ndarray  # row of out for each of s_targets
    info: dict
    in_order: bool = False  # slots[k] = slots[0] + k: the outputs are consecutive rows

    @property
    def T(self) -> float:
        return float(self.s_targets[-1])

    @property
    def rate(self) -> float:
        """Allowed relative error per unit time, SAFETY·tol/T (raised to the rounding
        floor NOISE·‖H_m‖ at each check)."""
        return SAFETY * self.tol / self.T


def _lanczos_sweep(sw: _Sweep, B2: np.ndarray, cols: slice, m_cap: int) -> None:
    """Time stepping with the three-term recurrence; the columns ``cols`` run together.

    Writes exp(sign·s_k·A) B2[:, cols] to out[slots[k], :, cols].
    Raises _NotSkew when H_m visibly differs from a skew tridiagonal matrix.
    """
    n = B2.shape[0]
    p = cols.stop - cols.start
    storage = _basis_storage((m_cap + 1) * n * p)
    try:
        V = storage[: (m_cap + 1) * n * p].reshape(m_cap + 1, n, p)
        _lanczos_steps(sw, B2[:, cols], cols, m_cap, V)
    finally:
        _keep_storage(storage)


def _lanczos_steps(sw: _Sweep, Y0: np.ndarray, cols: slice, m_cap: int, V: np.ndarray) -> None:
    op, w, sign, out, slots, info = sw.op, sw.w, sw.sign, sw.out, sw.slots, sw.info
    s_targets = sw.s_targets
    rate = sw.rate
    limit = 0.1 * sw.tol / sw.T  # ignoring an entry h of H_m costs about |h|·T
    maxnorm = sw.maxnorm
    n, p = Y0.shape
    np.copyto(V[0], Y0)
    t_now, k, nt = 0.0, 0, s_targets.size
    err_total = np.zeros(p)
    while k < nt:
        tau_rem = float(s_targets[-1] - t_now)
        lz = _Lanczos(op, w, V, limit)
        if not np.isfinite(lz.nu[0]).all():
            raise FlowOverflowError(_NONFINITE)
        if not (lz.nu[0] > 0).any():
            out[slots[k:], :, cols] = 0.0
            return
        # max-norm control: the error lies mostly along u_m, so its relative max-norm is
        # the W-norm estimate times (max|u_m| / ‖u_m‖_W) / (max|y| / ‖y‖_W)
        yscale = _safe_div(lz.nu[0], _absmax(V[0])) if maxnorm else None
        last_check: tuple[int, float] | None = None
        next_check = None  # None: from the Lanczos coefficients (see below)
        compiled = lz.p == 1 and lz.fused is not None and _COMPILED_STEP
        if compiled:
            # numba: the loop below in one call (fvf.numerics._kernels.lanczos_step, the same
            # arithmetic): numpy calls between kernel runs cost 3–5× their warm time
            tau, err, m, sk = _compiled_step(lz, tau_rem, rate, yscale, sign, m_cap)
        while not compiled:
            # to the next point where a check may be due: the start of the decay at the
            # mean β so far, or the next check
            if next_check is None:
                target = max(4, math.ceil(2.0 * lz.mean_beta() * tau_rem + 3))
            else:
                target = next_check
            lz.extend_to(min(max(target, lz.m + 1), m_cap))
            m = lz.m
            if m < m_cap and not lz.broken():
                if next_check is None:
                    # The error stalls until m ≈ (spectral radius)·τ ≈ 2·mean(β)·τ (the
                    # coefficients settle near half the spectral radius), then decays:
                    # about as the Chebyshev series for that radius does (the first check
                    # passed within 1–3 vectors of its degree at 6k–94k faces, where the
                    # decay from here needed two more checks, of 15–20 products each
                    # at 6k faces)
                    rho_tau = 2.0 * lz.mean_beta() * tau_rem
                    if m < max(4, rho_tau + 3):
                        continue
                    lead = _first_check_lead(op, p)
                    next_check = min(m_cap, chebyshev_degree(rho_tau, rate * tau_rem) - lead)
                if m < next_check:
                    continue
            # error estimate over the remaining interval (relative to ‖y‖, per column)
            beta = lz.beta
            sk = _skew_exp(beta[: m - 1])
            factor = np.ones(p)
            if maxnorm:  # ≥ 1: never looser than the W-norm control
                factor = np.maximum(1.0, _safe_div(_absmax(V[m]), lz.nu[m]) * yscale)
            bl = beta[m - 1] * factor

            def integral(hi, sk=sk, bl=bl):
                return sk.residual_integral(hi, bl, sign)

            E = integral(tau_rem)
            # ‖H_m‖ ≤ 2 max β; the noise of the estimate scales with the max-norm factor
            rate_m = max(rate, NOISE * 2.0 * float(beta[:m].max()) * float(factor.max()))
            excess = float(np.max(E[:, -1])) / (rate_m * tau_rem)
            if excess <= 1.0:
                tau, err = tau_rem, E[:, -1]
                break
            if m == m_cap:
                tau, err = _cut_step(integral, tau_rem, rate_m)
                break
            first = None
            if last_check is None:  # the decay of the Chebyshev tail for the radius so far
                first = _tail_decay(2.0 * lz.mean_beta() * tau_rem, rate_m * tau_rem, excess)
            next_check, last_check = _next_check(m, excess, last_check, m_cap, op, p, False, first)
        # dense output at the targets in (t_now, t_now + tau], and the new state
        last = tau == tau_rem
        kk = np.arange(k, nt)
        if not last:
            kk = kk[s_targets[k:] <= t_now + tau]
        s_loc = s_targets[kk] - t_now if last else np.append(s_targets[kk] - t_now, tau)
        C = sk.e1(sign * s_loc)  # (p, K, m) for u_j
        nu = lz.nu
        C *= (nu[0][:, None] * _safe_div(np.ones((m, p)), nu[:m]).T)[:, None, :]  # for y_j
        if last and sw.in_order and out.shape[2] == 1 and kk.size:  # one GEMM into out
            r0 = int(slots[k])
            _combine(V, m, C, out[r0 : r0 + kk.size])
        else:
            Y = _combine(V, m, C)
            out[slots[kk], :, cols] = Y[: kk.size]
            if not last:
                np.copyto(V[0], Y[-1])
        k = int(kk[-1]) + 1 if kk.size else k
        t_now += tau
        err_total += err
        info["steps"] += 1
        info["basis_sizes"].append(m)
        info["error_estimate"] = max(info["error_estimate"], float(err_total.max()))
        if tau == tau_rem:
            break


#: Whether one column's Lanczos steps run in one compiled call with numba
#: (:func:`~._kernels.lanczos_step`); the tests turn it off to compare with the loop.
_COMPILED_STEP = True


def _compiled_step(
    lz: _Lanczos, tau_rem: float, rate: float, yscale: np.ndarray | None, sign: float, m_cap: int
) -> tuple[float, np.ndarray, int, _SkewExpSeries]:
    """:func:`_lanczos_steps`' inner loop for one column by :func:`~._kernels.lanczos_step`
    (numba): (step τ, error estimate (1,), basis size m, the small exponentials)."""
    op = lz.op
    gap, lead = _check_gap(op, 1), _first_check_lead(op, 1)
    ys = float(yscale[0]) if yscale is not None else 1.0
    nu, beta = lz.nu[:, 0], lz.beta[:, 0]  # (views: filled in place)
    P, res = _kernels.lanczos_step(
        lz.fused, lz.V1, lz.wk, nu, beta, m_cap, tau_rem, rate, lz.limit, lead, gap,
        yscale is not None, ys, sign, _UNIT_GRID, NOISE, _BESSEL_TINY,
    )  # fmt: skip
    lz.take_run(res, int(res[6]))
    m = lz.m
    sk = _SkewExpSeries(lz.beta[: m - 1])
    sk.use_basis(P, tau_rem)  # (the check's vectors: what the outputs need)
    if int(res[0]) == 0:
        return tau_rem, res[8:9].copy(), m, sk
    bl = lz.beta[m - 1] * res[10]  # the check at m_cap failed: a shorter step
    tau, err = _cut_step(lambda hi: sk.residual_integral(hi, bl, sign), tau_rem, float(res[9]))
    return tau, err, m, sk


def _next_check(
    m: int,
    excess: float,
    last_check: tuple[int, float] | None,
    m_cap: int,
    op: _Operator,
    p: int,
    dense: bool,
    first: int | None = None,
) -> tuple[int, tuple[int, float]]:
    """Basis size of the next error check, from log(error / budget) at the checks so far.

    The decay of the log-excess is extrapolated linearly from the last two checks (the
    convergence is superlinear, so this overestimates the vectors needed; a 1.3 margin on
    the rate); with one check, ``first`` vectors and a gap if given (Lanczos: the terms
    the Chebyshev series for the radius 2·mean(β) needs to lower its tail by the
    excess), else a decay of 2 per vector. Checks are at least ``_check_gap`` apart.

    ``first``: on bob (10,688 faces) the first check of one skew column at m = 47 was
    370× over budget; a decay of 2 per vector put the next check at 49 (148×), the
    linear extrapolation then at 57 (0.0012×). The tail's decay says 5 more vectors:
    at 52 the check was 2.2× over, at 53 it passes. With the gap (1 there) the next
    check is at 53: 2 checks and 53 vectors instead of 3 and 57.
    """
    x = math.log(excess) if np.isfinite(excess) else 50.0
    if last_check is not None and last_check[1] > x:
        slope = (last_check[1] - x) / (m - last_check[0])
        step = int(x / (1.3 * slope))
    elif first is not None:  # (+ a gap: one vector too many costs less than a check)
        step = first + _check_gap(op, p, m, dense)
    else:
        step = int(x / 2.0)
    return min(m_cap, m + max(_check_gap(op, p, m, dense), step, 1)), (m, x)


def _tail_decay(rho_tau: float, budget: float, excess: float) -> int:
    """Terms the Chebyshev series for the radius ρτ (``rho_tau``) needs beyond its degree
    for ``budget`` to lower its tail by ``excess`` more: where Lanczos and the general
    method check next after a first failing check (see :func:`_next_check`)."""
    return chebyshev_degree(rho_tau, budget / excess) - chebyshev_degree(rho_tau, budget)


def _wdot(
    X: np.ndarray, Y: np.ndarray, w: np.ndarray | None, tmp: np.ndarray | None = None
) -> np.ndarray:
    """W-inner products of matching columns of X and Y (n, p): (p,).

    With a temporary ``tmp`` (n, p) (small sizes, in cache): an elementwise product and a
    BLAS GEMV with w; otherwise one fused einsum pass (large, memory-bound sizes).
    """
    if w is None:
        return np.einsum("nc,nc->c", X, Y)
    if tmp is not None:
        return w @ np.multiply(X, Y, out=tmp)
    return np.einsum("n,nc,nc->c", w, X, Y)


def _norm_workspace(n: int, p: int, w: np.ndarray | None) -> np.ndarray | None:
    """The temporary (n, p) of :func:`_wdot` / :func:`_wnorm2`: for weighted norms of
    blocks small enough to stay in cache; None (one fused einsum pass) otherwise."""
    small = n < _STREAM_N if p == 1 else n * p < _STREAM_BLOCK
    return np.empty((n, p)) if w is not None and small else None


def _wnorm2(X: np.ndarray, w: np.ndarray | None, tmp: np.ndarray | None = None) -> np.ndarray:
    """Squared W-norms of the columns of X (n, p): (p,)."""
    return _wdot(X, X, w, tmp)


def _wnorm(x: np.ndarray, w: np.ndarray | None, tmp: np.ndarray | None) -> float:
    """W-norm of a vector x (n,) (``tmp`` (n,): a temporary for small n, else None)."""
    if w is None:
        return math.sqrt(float(np.dot(x, x)))
    if tmp is not None:
        return math.sqrt(float(np.dot(np.multiply(w, x, out=tmp), x)))
    return math.sqrt(float(np.einsum("i,i,i->", w, x, x)))


def _safe_div(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a / b where b > 0, else 0."""
    return np.divide(a, b, out=np.zeros(np.broadcast(a, b).shape), where=b > 0)


def _absmax(X: np.ndarray, tmp: np.ndarray | None = None) -> np.ndarray:
    """max_i |X[i, c]| for X (n, p): (p,) (``tmp``: an optional (n, p) temporary).

    numpy reduces a C-ordered (n, p) array along axis 0 with an inner loop of length p,
    5–10× slower than the same reduction over rows of 64·p entries; so the rows are
    grouped by 64 first.
    """
    n, p = X.shape
    if n == 0:
        return np.zeros(p)
    A = np.abs(X, out=tmp) if tmp is not None else np.abs(X)
    if p == 1:
        return A.max(axis=0)
    q = n // 64
    head = A[: q * 64].reshape(q, 64 * p).max(axis=0).reshape(64, p).max(axis=0) if q else None
    if q * 64 == n:
        return head
    rest = A[q * 64 :].max(axis=0)
    return rest if head is None else np.maximum(head, rest)


def _check_skew(diag: float, off: float, scale: float, limit: float) -> None:
    """Raise _NotSkew when H_m visibly differs from the skew tridiagonal it is assumed to be.

    ``diag`` = |⟨A u_j, u_j⟩_W| (0 for a W-skew-adjoint A and any unit u_j), ``off`` =
    |⟨A u_j + β_{j−1} u_{j−1}, u_{j−1}⟩_W| = |h_{j−1,j} + h_{j,j−1}| (0 up to the local
    orthogonality of consecutive Lanczos vectors, which rounding keeps at ~1e-15 even when
    global orthogonality is lost). Both are measured against ``scale``, the larger of β_j
    and the mean of the earlier β (their rounding is relative to the operator's size; near
    a breakdown β_j alone is tiny and made round-off look like a non-skew operator).
    """
    if max(diag, off) > max(limit, 1e-12 * scale):
        raise _NotSkew(f"|⟨A u, u⟩_W| = {diag:.3g}, |h_(j-1,j) + h_(j,j-1)| = {off:.3g} for unit u")


def _check_gap(op: _Operator, p: int, m: int = 48, dense: bool = False) -> int:
    """Basis vectors between error checks near convergence.

    ≈ sqrt(check cost / product cost): checks at every vector on large meshes, every few
    on small ones (an overshoot costs about gap/2 products, the checks cost/gap each).
    A check costs a small skew exponential per column (measured for m = 50–110: 100–115 µs
    by the compiled series with numba, 160–540 µs by the SVD without; one model for
    both, so that both paths take the same steps) or, for the general method (``dense``),
    μ and the grid of a Hessenberg H_m: 60–150 µs at m = 27–50 compiled (the model
    below), 230–620 µs with LAPACK and scipy's expm (again one model for both).
    """
    if dense:
        check = 3e-5 + 4e-8 * m * m
    else:
        check = 1e-4 * p
    return max(1, int(round(math.sqrt(check / op.product_cost(p)))))


def _first_check_lead(op: _Operator, p: int) -> int:
    """Vectors before the Chebyshev degree at which Lanczos checks first: 2, or 8 where a
    check costs less than a product (large meshes: the degree overshot by 4 at 1.5M
    faces)."""
    return 2 if _check_gap(op, p) > 1 else 8


def _cut_step(
    integral: Callable[[float], np.ndarray], tau_rem: float, rate: float
) -> tuple[float, np.ndarray]:
    """Largest step τ ≤ tau_rem with ∫_0^τ |r| ≤ rate·τ for every column.

    ``integral(hi)`` returns ∫_0^s |r| on :func:`_grid` (hi): (columns, _GRID + 1).
    """
    hi = tau_rem
    for _ in range(60):
        s = _grid(hi)
        E = np.atleast_2d(integral(hi))
        ok = np.all(E <= rate * s * (1 + 1e-12), axis=0)
        ok[0] = True
        bad = np.flatnonzero(~ok)
        last = (bad[0] - 1) if bad.size else _GRID
        if last >= 1:
            return float(s[last]), E[:, last]
        hi = s[1]
    raise FlowOverflowError("Krylov step size underflow")  # pragma: no cover


def _iom_sweep(sw: _Sweep, B2: np.ndarray, c: int, m_cap: int, window: int) -> None:
    """Krylov time stepping with incomplete orthogonalization, one column.

    Each new vector is W-orthogonalized (one classical Gram–Schmidt pass) against the last
    ``window`` basis vectors only, so H_m is banded and a step costs O(n · window); the
    Krylov relation A U_m = U_m H_m + h_m u_m e_mᵀ holds exactly whatever the window, and
    the residual-based error estimate stays valid (Koskela 2015; Vo & Sidje 2017).
    Writes exp(sign·s_k·A) B2[:, c] to out[slots[k], :, c].
    """
    n = B2.shape[0]
    storage = _basis_storage((m_cap + 1) * n)
    try:
        V = storage[: (m_cap + 1) * n].reshape(m_cap + 1, n)
        _iom_steps(sw, B2[:, c], c, m_cap, window, V)
    finally:
        _keep_storage(storage)


def _iom_steps(sw: _Sweep, y0: np.ndarray, c: int, m_cap: int, window: int, V: np.ndarray) -> None:
    op, w, sign, out, slots, info = sw.op, sw.w, sw.sign, sw.out, sw.slots, sw.info
    s_targets = sw.s_targets
    rate, maxnorm = sw.rate, sw.maxnorm
    n = y0.shape[0]
    y = np.array(y0, dtype=float)
    t_now, k, nt = 0.0, 0, s_targets.size
    err_total = 0.0
    wv = np.empty(n)
    tmp = wv if n < _STREAM_N else None  # the norms reuse the same temporary
    fused = op.fused if _COMPILED_IOM else None  # numba: runs of vectors in one call
    wk = (np.ones(n) if w is None else w) if fused is not None else None
    res = np.zeros(3)
    while k < nt:
        tau_rem = float(s_targets[-1] - t_now)
        beta0 = _wnorm(y, w, tmp)
        if not math.isfinite(beta0):
            raise FlowOverflowError(_NONFINITE)
        if beta0 == 0:
            out[slots[k:], :, c] = 0.0
            return
        np.multiply(y, 1.0 / beta0, out=V[0])
        H = np.zeros((m_cap + 1, m_cap))
        bsum = 0.0
        b = 1.0
        last_check: tuple[int, float] | None = None
        next_check = None
        mu = -math.inf  # μ of the last check: a lower bound of the next one's (interlacing)
        along = False  # whether the checks follow the Chebyshev degree (see below)
        m = 0
        while True:
            # to the next point where a check may be due: the next check, or before the
            # first the start of the decay (tested after every vector: the mean β moves)
            target = m_cap if next_check is None else min(max(next_check, m + 1), m_cap)
            decay = tau_rem if next_check is None else 0.0
            if fused is not None:
                res[2] = bsum
                _kernels.iom_run(fused, V, wk, H, m, target, window, res, decay)
                op.count(int(res[1]) - m, 1)
                m, bsum = int(res[1]), float(res[2])
                b = H[m, m - 1]
            else:
                while m < target:
                    m, b = _iom_vector(op, V, H, m, window, w, wv, tmp)
                    bsum += b  # (not finite: raised below)
                    if not 0 < b < math.inf or (
                        decay and m >= max(4.0, 2.0 * bsum / m * decay + 3.0)
                    ):
                        break
            if not math.isfinite(b):
                raise FlowOverflowError(_NONFINITE)
            if m < m_cap and b > 0:
                if next_check is None:
                    # the start of the decay; then, for a spectrum along the imaginary
                    # axis, the Chebyshev degree for the radius 2·mean(β), less a lead
                    # (see _lanczos_steps): on bob (10,688 faces) the checks at 27, 36, 47
                    # and 50 became 39, 47 and 49. For real spectra that degree overshoots
                    # (~√(ρτ) vectors suffice): check now. The symmetric part of H's
                    # tridiagonal tells them apart: Σ|h_jj| + Σ|h_{j,j+1} + h_{j+1,j}| is
                    # 0.008–0.32 Σβ for flows on spot and bob, 2.0–4.0 Σβ for diffusion
                    # and symmetric operators with a zero diagonal
                    rho_tau = 2.0 * bsum / m * tau_rem
                    if m < max(4, rho_tau + 3):
                        continue
                    up, down = np.diagonal(H, 1)[: m - 1], np.diagonal(H, -1)[: m - 1]
                    sym = float(np.abs(np.diagonal(H)[:m]).sum() + np.abs(up + down).sum())
                    along = sym <= IOM_IMAGINARY * bsum
                    if along:
                        lead = _first_check_lead(op, 1)
                        deg = chebyshev_degree(rho_tau, rate * tau_rem)
                        next_check = min(m_cap, max(m, deg - lead))
                    else:
                        next_check = m
                if m < next_check:
                    continue
            factor = 1.0
            if maxnorm:  # see _lanczos_steps
                factor = max(1.0, float(np.abs(V[m]).max()) / float(np.abs(V[0]).max()))
            prof = _HessenbergExp(H, m, sign, factor, window, mu)
            mu = prof.mu
            s, E = prof.errors(tau_rem)
            rate_m = max(rate, NOISE * float(np.abs(H[: m + 1, :m]).sum(axis=1).max()) * factor)
            excess = E[-1] / (rate_m * tau_rem)
            if excess <= 1.0 or b == 0:
                tau, err = tau_rem, float(E[-1])
                break
            if m == m_cap:
                tau, err = _cut_step_general(prof, tau_rem, rate_m)
                break
            first = None
            if last_check is None and along:  # the decay of the Chebyshev tail, as above
                first = _tail_decay(2.0 * bsum / m * tau_rem, rate_m * tau_rem, excess)
            next_check, last_check = _next_check(m, excess, last_check, m_cap, op, 1, True, first)
        last = tau == tau_rem
        kk = np.arange(k, nt)
        if not last:
            kk = kk[s_targets[k:] <= t_now + tau]
        s_loc = s_targets[kk] - t_now if last else np.append(s_targets[kk] - t_now, tau)
        Y = (prof.e1(s_loc) * beta0) @ V[:m]
        out[slots[kk], :, c] = Y[: kk.size]
        if not last:
            y = Y[-1].copy()
        k = int(kk[-1]) + 1 if kk.size else k
        t_now += tau
        err_total += err
        info["steps"] += 1
        info["basis_sizes"].append(m)
        info["error_estimate"] = max(info["error_estimate"], float(err_total))
        if tau == tau_rem:
            break


#: Whether the general method's runs of vectors and its checks' small exponentials are
#: compiled with numba (:func:`~._kernels.iom_run`, :func:`~._kernels.hess_profile`);
#: the tests turn it off to compare with the numpy path.
_COMPILED_IOM = True


def _iom_vector(
    op: _Operator,
    V: np.ndarray,
    H: np.ndarray,
    j: int,
    window: int,
    w: np.ndarray | None,
    wv: np.ndarray,
    tmp: np.ndarray | None,
) -> tuple[int, float]:
    """V[j + 1] and column j of H (one vector of :func:`_iom_steps`, numpy): the product,
    one classical Gram–Schmidt pass against the last ``window`` vectors, the W-norm β;
    returns (j + 1, β), V[j + 1] normalized where 0 < β < ∞.

    For windows of at most 4, β² is ‖A V[j]‖²_W − Σ h_i² where that keeps at least
    :data:`fvf.numerics._kernels.IOM_PYTHAGORAS` of ‖A V[j]‖²_W (the compiled run then subtracts
    and scales in one pass), else the norm of the subtracted vector; V[j] is first
    rescaled (with β_{j−1}) if its W-norm² is more than :data:`fvf.numerics._kernels.IOM_UNIT`
    from 1. As in :func:`~._kernels.iom_run`."""
    if j > 0 and window <= 4:
        sx = float(np.dot(V[j] if w is None else np.multiply(w, V[j], out=wv), V[j]))
        if not abs(sx - 1.0) <= _kernels.IOM_UNIT:  # (see fvf.numerics._kernels.IOM_UNIT)
            V[j] *= 1.0 / math.sqrt(sx)
            H[j, j - 1] *= math.sqrt(sx)
    vn = V[j + 1]
    vn.fill(0.0)
    op.accumulate(V[j], vn)
    lo = max(0, j + 1 - window)
    Vw = V[lo : j + 1]
    wy = vn if w is None else np.multiply(w, vn, out=wv)
    h = Vw @ wy
    su = float(np.dot(wy, vn))
    ss = su - float(np.dot(h, h)) if window <= 4 else 0.0
    vn -= h @ Vw
    H[lo : j + 1, j] = h
    pythagoras = 0.0 < ss < math.inf and ss >= _kernels.IOM_PYTHAGORAS * su
    b = math.sqrt(ss) if pythagoras else _wnorm(vn, w, tmp)
    if 0 < b < math.inf:
        vn *= 1.0 / b
    H[j + 1, j] = b
    return j + 1, b


class _HessenbergExp:
    """exp(s H_m) e_1 on grids of s, and the relative error estimate, for a Hessenberg H_m.

    The residual r(s) = h_{m,m−1} [exp(s H_m) e_1]_{m−1} is propagated with the bound
    e^{μ(s−σ)}, μ = largest eigenvalue of the symmetric part of H_m (the logarithmic norm
    of A on the Krylov space, an estimate of A's), and divided by ‖exp(s H_m) e_1‖ (the
    relative size of the solution).

    H_m has ``window`` entries above the subdiagonal per column. With numba (and
    :data:`_COMPILED_IOM`), for a banded H_m (window < m) or m ≤ 16, μ comes from
    bisection on Cholesky factors of the banded μI − S and the grid from Taylor's series
    on the band (:func:`~._kernels.hess_mu`, :func:`~._kernels.hess_profile`,
    :func:`~._kernels.hess_expv`): 60–150 µs a check at m = 27–50 on bob, where
    LAPACK's eigvalsh and scipy's expm took 230–620 µs. ``mu_below``: a lower bound of μ
    (the last check's, for a leading block of H_m).
    """

    def __init__(
        self,
        H: np.ndarray,
        m: int,
        sign: float,
        factor: float = 1.0,
        window: int | None = None,
        mu_below: float = -math.inf,
    ) -> None:
        self.H = H
        self.sign = sign
        self.window = m if window is None else min(int(window), m)
        self.h = H[m, m - 1] * factor
        self.m = m
        # (a full H_m, from fully orthogonalized bases of operators with n ≤ 100: LAPACK's
        # O(m³) is faster there than m³ per Taylor term or per Cholesky; 1.4× at m = 57)
        banded = self.window < m or m <= 16
        self.compiled = _kernels.ENABLED and _COMPILED_IOM and banded
        if self.compiled:
            self.mu = _kernels.hess_mu(H, m, sign, self.window, mu_below)
        else:
            self.Hm = sign * H[:m, :m]
            self.mu = float(np.linalg.eigvalsh(0.5 * (self.Hm + self.Hm.T))[-1])
        self._grid: tuple[float, np.ndarray] | None = None
        self._errors: np.ndarray | None = None

    def grid(self, hi: float) -> tuple[np.ndarray, np.ndarray]:
        """s = :func:`_grid` (hi) and exp(s H_m) e_1 at those s: (_GRID + 1, m)."""
        s = _grid(hi)
        if self.compiled:
            X, self._errors = _kernels.hess_profile(
                self.H, self.m, self.sign, self.window, self.h, hi, self.mu, _GRID
            )
            self._grid = (hi, X)
            return s, X
        step = sla.expm((hi / _GRID) * self.Hm)
        X = np.empty((_GRID + 1, self.m))
        X[0] = 0.0
        X[0, 0] = 1.0
        with np.errstate(over="ignore", invalid="ignore"):
            for i in range(_GRID):
                X[i + 1] = step @ X[i]
        self._grid = (hi, X)
        return s, X

    def errors(self, hi: float) -> tuple[np.ndarray, np.ndarray]:
        """(s, relative error estimate at s) on the grid of [0, hi]."""
        s, X = self.grid(hi)
        if self.compiled:
            return s, self._errors
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            r = np.abs(self.h * X[:, -1])
            E = np.exp(self.mu * s) * _cumtrapz(np.exp(-self.mu * s) * r, hi)
            big = np.abs(X).max(axis=1)  # (‖X(s)‖² overflows past 1e154: scale first)
            E = E / (np.linalg.norm(X / np.where(big > 0, big, 1.0)[:, None], axis=1) * big)
        E[~np.isfinite(E)] = np.inf
        return s, E

    def e1(self, s: np.ndarray) -> np.ndarray:
        """exp(s H_m) e_1 for the times s (K,): (K, m).

        Each time starts from the nearest point below it on the last error grid (so the
        remaining exponential has a small norm, and times on the grid cost nothing);
        equal offsets share one dense exponential (equally spaced outputs cost one).
        """
        out = np.empty((s.size, self.m))
        base0 = np.zeros(self.m)
        base0[0] = 1.0
        hi, X = self._grid if self._grid is not None else (0.0, base0[None])
        delta = hi / _GRID
        cache: dict[float, np.ndarray] = {}
        for i, si in enumerate(s):
            g = 0
            if delta > 0 and 0.0 <= si <= hi * (1 + 1e-12):
                g = min(_GRID, int(np.floor(si / delta + 1e-9)))
            d = si - g * delta
            if abs(d) <= 1e-12 * abs(si):
                out[i] = X[g]
                continue
            if self.compiled:  # (Taylor on the band: no dense exponential)
                out[i] = _kernels.hess_expv(self.H, self.m, self.sign * d, self.window, X[g])
                continue
            key = float(f"{d:.11e}")
            E = cache.get(key)
            if E is None:
                E = cache[key] = sla.expm(d * self.Hm)
            out[i] = E @ X[g]
        return out


def _cut_step_general(prof: _HessenbergExp, tau_rem: float, rate: float) -> tuple[float, float]:
    """Largest step τ ≤ tau_rem whose error estimate meets rate·τ (Hessenberg case)."""
    hi = tau_rem
    for _ in range(60):
        s, E = prof.errors(hi)
        ok = E <= rate * s * (1 + 1e-12)
        ok[0] = True
        bad = np.flatnonzero(~ok)
        last = (bad[0] - 1) if bad.size else _GRID
        if last >= 1:
            if last < _GRID:
                prof.grid(float(s[last]))  # so that e1(τ) reuses it
            return float(s[last]), float(E[last])
        hi = s[1]
    raise FlowOverflowError("Krylov step size underflow")  # pragma: no cover
