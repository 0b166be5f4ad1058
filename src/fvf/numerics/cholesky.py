"""Sparse positive definite factorizations, real symmetric and complex Hermitian: one family.

One entrance, :func:`factor_hermitian`, factors a sparse Hermitian (complex) or symmetric
(real) positive definite matrix K once and returns a :class:`HermitianFactor` whose
``solve`` applies K⁻¹ to one or many right-hand sides. Four backends:

``"cholmod"``
    CHOLMOD's supernodal Cholesky through scikit-sparse (``sksparse.cholmod``), complex
    arithmetic, CHOLMOD's own fill-reducing ordering. Optional extra ``[fast]``.
``"cvxopt"``
    CHOLMOD's supernodal Cholesky bundled in the ``cvxopt`` wheel (``cvxopt.cholmod``),
    real or complex arithmetic, CHOLMOD's AMD ordering. Optional extra ``[fast]``; CVXOPT
    is GPL-3.0 licensed (fvf does not ship it: installing the extra is your choice).
``"cholespy"``
    CHOLMOD bundled in the ``cholespy`` wheel (real arithmetic only): a complex K is
    factored through its real (2n, 2n) form ``[[Re, −Im], [Im, Re]]`` on interleaved
    ``[Re z0, Im z0, Re z1, …]`` unknowns. Optional extra ``[fast]``.
``"scipy"``
    SuperLU (``scipy.sparse.linalg.splu``) in symmetric mode with diagonal pivots after a
    nested-dissection ordering (:func:`fvf.numerics.ordering.nested_dissection`) from
    :data:`ND_MIN` unknowns on (minimum degree below): :class:`SPDFactor`, the factor
    :func:`superlu_factor` returns (with its pivots checked positive). Always available;
    stores both L and U, so it needs about twice the memory of a Cholesky factor.

``backend="auto"`` takes the first of ``"cholmod"``, ``"cholespy"``, ``"cvxopt"``,
``"scipy"`` that imports, except that cvxopt comes before cholespy for a complex K and
for a factor used for a few right-hand sides only (``solves="few"``). Measured
(``python benchmarks/bench_cholesky.py``, one BLAS thread): on the real dual-graph
Laplacians of the shared meshes (6k–86k unknowns) cvxopt factors 2.5–3.3× faster than
cholespy (whose simplicial factorization after a METIS ordering costs about 5 µs per
unknown), but solves one right-hand side at a time, 4 ms each at 20k unknowns against
cholespy's 0.7 ms in blocks; on the complex connection Laplacians cvxopt factors 7–9×
faster and its solves cost 0.7–1.5× cholespy's (which solves the real form of twice the
size).

Failures
--------
What a backend raises when it cannot factor K — cvxopt's ``ArithmeticError``, cholespy's
``ValueError("Matrix is not positive definite!")`` or ``RuntimeError("Failed to resize
matrix arrays!")`` (and the warning CHOLMOD prints on standard output before it, which
:func:`fvf.numerics.c_output.backend_output_captured` keeps off the terminal),
scikit-sparse's ``CholmodError``, SuperLU's ``RuntimeError("Factor is exactly singular")``
— never reaches the caller: a requested backend raises
:class:`~fvf.errors.FactorizationError` with the backend's reason; under
``backend="auto"`` the next available backend is tried (with a
:class:`~fvf.errors.FactorizationFallbackWarning`), straight to SuperLU once a Cholesky
backend has found K not positive definite (the others would find it too), and
:class:`~fvf.errors.FactorizationError` lists every reason when none succeeds.

Memory: the backends copy K only into their own input format (cvxopt and cholespy: its
lower triangle, freed before the factorization returns), and a failed backend's partial
factor is released before the next one starts.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Literal

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import (
    FactorizationError,
    FactorizationFallbackWarning,
    FvfError,
    MissingExtraError,
    ParameterError,
    user_stacklevel,
)
from .c_output import backend_output_captured
from .ordering import nested_dissection

__all__ = [
    "BACKENDS",
    "HermitianFactor",
    "SPDFactor",
    "factor_hermitian",
    "superlu_factor",
    "available_backends",
    "symmetric_splu",
    "ND_MIN",
]

Backend = Literal["auto", "cholmod", "cvxopt", "cholespy", "scipy"]
Ordering = Literal["auto", "mmd", "nd"]
#: Accepted values of ``backend``.
BACKENDS: tuple[str, ...] = ("auto", "cholmod", "cvxopt", "cholespy", "scipy")
#: The scipy backend orders by nested dissection from this many unknowns on.
ND_MIN = 30_000
#: The backends that compute a Cholesky factor (they stop at K's first non-positive pivot).
_CHOLESKY = ("cholmod", "cvxopt", "cholespy")


def _has(module: str) -> bool:
    try:
        __import__(module)
    except Exception:  # noqa: BLE001 (ImportError, or a binary built for another numpy)
        return False
    return True


def available_backends() -> tuple[Backend, ...]:
    """The backends that import here, fastest first for a factor solved many times
    (``"scipy"`` always last)."""
    out: list[Backend] = []
    if _has("sksparse.cholmod"):
        out.append("cholmod")
    if _has("cholespy"):
        out.append("cholespy")
    if _has("cvxopt.cholmod"):
        out.append("cvxopt")
    return (*out, "scipy")


def _auto(solves: Literal["few", "many"], is_complex: bool = False) -> Backend:
    """The backend ``"auto"`` means: the fastest available for ``solves`` on a complex or
    real K. cholespy factors a complex K through its real form of twice the size, so for
    a complex K cvxopt is faster whatever the number of solves (module docstring)."""
    order = available_backends()
    if "cvxopt" in order and order[0] != "cholmod" and (solves == "few" or is_complex):
        return "cvxopt"
    return order[0]


# ---------------------------------------------------------------------------- the factors
class HermitianFactor:
    """A factorization of a Hermitian positive definite K; ``solve`` applies K⁻¹.

    Parameters
    ----------
    backend : str
        The backend's name.
    solve : callable or None
        B (n,) or (n, p) of K's dtype -> K⁻¹ B; None in subclasses that override
        ``_apply``.
    shape : tuple of int
    is_complex : bool

    Attributes
    ----------
    backend : str
        ``"cholmod"``, ``"cvxopt"``, ``"cholespy"`` or ``"scipy"``.
    complex : bool
        True when K was complex.
    shape : tuple of int
    """

    def __init__(
        self,
        backend: str,
        solve: Callable[[np.ndarray], np.ndarray] | None,
        shape: tuple[int, int],
        is_complex: bool,
    ) -> None:
        self.backend = backend
        self._solve = solve
        self.shape = shape
        self.complex = is_complex

    def solve(self, B: np.ndarray) -> np.ndarray:
        """K⁻¹ B for B of shape (n,) or (n, p); complex128 if K is complex, else float64."""
        return self._apply(np.asarray(B, dtype=np.complex128 if self.complex else np.float64))

    def _apply(self, B: np.ndarray) -> np.ndarray:
        assert self._solve is not None
        return self._solve(B)


class SPDFactor(HermitianFactor):
    """The SuperLU member of the family: symmetric mode (diagonal pivots only) on K or on
    its symmetric permutation ``K[perm][:, perm]`` by a nested-dissection order
    (:func:`~fvf.numerics.ordering.nested_dissection`). Made by :func:`superlu_factor` (and
    by ``factor_hermitian(K, "scipy")``).

    Parameters
    ----------
    lu : scipy.sparse.linalg.SuperLU
    perm : ndarray of int64 (n,) or None
    ordering : {"mmd", "nd"}
    is_complex : bool
        Whether K is complex (solves then return complex128).

    Attributes
    ----------
    lu : scipy.sparse.linalg.SuperLU
        The factorization (of the permuted matrix when ``perm`` is not None).
    perm : ndarray of int64 (n,) or None
        The symmetric permutation applied before SuperLU.
    ordering : {"mmd", "nd"}
        The fill-reducing ordering used.
    """

    def __init__(
        self, lu: spla.SuperLU, perm: np.ndarray | None, ordering: str, is_complex: bool = False
    ) -> None:
        super().__init__("scipy", None, lu.shape, is_complex)
        self.lu = lu
        self.perm = perm
        self.ordering = ordering

    @property
    def pivots(self) -> np.ndarray:
        """Diagonal of U (n,): all positive for a positive definite K."""
        return self.lu.U.diagonal()

    @property
    def nnz(self) -> int:
        """Entries of the factors L and U."""
        return int(self.lu.L.nnz + self.lu.U.nnz)

    def _apply(self, B: np.ndarray) -> np.ndarray:
        if self.perm is None:
            return self.lu.solve(B)
        X = np.empty(B.shape, dtype=B.dtype)
        X[self.perm] = self.lu.solve(np.asfortranarray(B[self.perm]))
        return X


# ---------------------------------------------------------------------------- SuperLU
def symmetric_splu(
    K: sp.sparray | sp.spmatrix, ordering: Ordering = "auto"
) -> tuple[spla.SuperLU, np.ndarray | None]:
    """SuperLU of a symmetric positive definite K with diagonal pivots (symmetric mode),
    after a fill-reducing ordering: ``"nd"`` nested dissection
    (:func:`fvf.numerics.ordering.nested_dissection`), ``"mmd"`` SuperLU's minimum degree
    on AᵀA + A, ``"auto"`` nested dissection from :data:`ND_MIN` unknowns on.

    Returns (lu, perm): ``lu`` factors ``K[perm][:, perm]`` (K itself when perm is None).
    SuperLU's own ``RuntimeError`` (e.g. an exactly singular K) is passed on; see
    :func:`superlu_factor` for the typed error.
    """
    if ordering == "auto":
        ordering = "nd" if K.shape[0] >= ND_MIN else "mmd"
    perm, spec = None, "MMD_AT_PLUS_A"
    if ordering == "nd":
        perm = nested_dissection(K)
        K = sp.csr_array(K)[perm][:, perm]
        spec = "NATURAL"
    lu = spla.splu(
        sp.csc_matrix(K),
        permc_spec=spec,
        diag_pivot_thresh=0.0,
        options=dict(SymmetricMode=True),
    )
    return lu, perm


def superlu_factor(
    K: sp.sparray | sp.spmatrix, ordering: Ordering = "auto", *, check: bool = True
) -> SPDFactor:
    """SuperLU in symmetric mode of a symmetric (or Hermitian) positive definite K.

    Parameters
    ----------
    K : sparse (n, n), float64 or complex128
    ordering : {"auto", "mmd", "nd"}
        Fill-reducing ordering (:func:`symmetric_splu`).
    check : bool
        Also require every pivot to be finite with a positive real part (K positive
        definite); without it an indefinite but nonsingular K is factored too.

    Returns
    -------
    SPDFactor

    Raises
    ------
    ParameterError
        Unknown ordering.
    FactorizationError
        SuperLU found K (exactly) singular; with ``check``, a pivot is not positive.
    """
    if ordering not in ("auto", "mmd", "nd"):
        raise ParameterError(f"ordering must be one of ('auto', 'mmd', 'nd'); got {ordering!r}")
    if ordering == "auto":
        ordering = "nd" if K.shape[0] >= ND_MIN else "mmd"
    is_complex = bool(np.iscomplexobj(K.data) if sp.issparse(K) else np.iscomplexobj(K))
    try:
        lu, perm = symmetric_splu(K, ordering)
    except RuntimeError as exc:
        raise _failure("scipy", K.shape[0], is_complex, exc) from exc
    fac = SPDFactor(lu, perm, ordering, is_complex)
    if check:
        piv = fac.pivots.real
        if not np.all(np.isfinite(piv)) or np.any(piv <= 0):
            raise FactorizationError(
                f"the SuperLU factorization of the {K.shape[0]} x {K.shape[0]} matrix has "
                f"non-positive pivots ({int(np.count_nonzero(~(piv > 0)))} of them): it is "
                "not positive definite (or too ill-conditioned)"
            )
    return fac


# ---------------------------------------------------------------------------- backends
def _lower(K: sp.sparray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """int32 rows, cols and float64 values of the lower triangle of a real K."""
    L = sp.coo_array(sp.tril(K))
    return L.row.astype(np.int32), L.col.astype(np.int32), np.ascontiguousarray(L.data, float)


def _real_lower(K: sp.sparray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lower triangle of the real form of a Hermitian K, built without the full form.

    An entry x + iy below the diagonal gives four real entries (all below the diagonal);
    a diagonal entry x (real) gives (2r, 2r) and (2r+1, 2r+1) = x (and (2r+1, 2r) = 0).
    """
    C = sp.coo_array(sp.tril(K, k=-1))
    r, c = C.row.astype(np.int32), C.col.astype(np.int32)
    x, y = C.data.real, C.data.imag
    d = K.diagonal().real
    i = np.arange(d.size, dtype=np.int32)
    rows = np.concatenate([2 * r, 2 * r, 2 * r + 1, 2 * r + 1, 2 * i, 2 * i + 1])
    cols = np.concatenate([2 * c, 2 * c + 1, 2 * c, 2 * c + 1, 2 * i, 2 * i + 1])
    data = np.concatenate([x, -y, y, x, d, d])
    return rows, cols, data


def _cholmod(K: sp.sparray, is_complex: bool) -> HermitianFactor:
    from sksparse.cholmod import cholesky

    fac = cholesky(sp.csc_matrix(K))

    def solve(B):
        return np.asarray(fac(B))

    return HermitianFactor("cholmod", solve, K.shape, is_complex)


def _cvxopt(K: sp.sparray, is_complex: bool) -> HermitianFactor:
    import cvxopt
    from cvxopt import cholmod

    dtype = np.complex128 if is_complex else np.float64
    L = sp.coo_array(sp.tril(K))
    A = cvxopt.spmatrix(
        cvxopt.matrix(np.ascontiguousarray(L.data, dtype)),
        cvxopt.matrix(L.row.astype(np.int64)),
        cvxopt.matrix(L.col.astype(np.int64)),
        size=K.shape,
        tc="z" if is_complex else "d",
    )
    del L
    fac = cholmod.symbolic(A, uplo="L")
    cholmod.numeric(A, fac)  # ArithmeticError(column) when K is not positive definite
    del A

    def solve(B):
        X = cvxopt.matrix(np.asfortranarray(B.reshape(B.shape[0], -1)))
        cholmod.solve(fac, X)
        return np.array(X, dtype=dtype).reshape(B.shape)

    return HermitianFactor("cvxopt", solve, K.shape, is_complex)


def _cholespy(K: sp.sparray, is_complex: bool) -> HermitianFactor:
    from cholespy import CholeskySolverD, MatrixType

    rows, cols, data = _real_lower(K) if is_complex else _lower(K)
    n = 2 * K.shape[0] if is_complex else K.shape[0]
    with backend_output_captured():  # CHOLMOD prints "not positive definite" on stdout
        try:
            fac = CholeskySolverD(n, rows, cols, data, MatrixType.COO)  # reads the lower part
        finally:
            del rows, cols, data

    def solve_real(b):
        b = np.ascontiguousarray(b, dtype=np.float64)
        x = np.empty_like(b)
        fac.solve(b, x)
        return x

    if not is_complex:
        return HermitianFactor("cholespy", solve_real, K.shape, False)

    def solve(B):
        shape = B.shape
        b = B.reshape(shape[0], -1)
        inter = np.empty((2 * shape[0], b.shape[1]))
        inter[0::2], inter[1::2] = b.real, b.imag
        x = solve_real(inter)
        return (x[0::2] + 1j * x[1::2]).reshape(shape)

    return HermitianFactor("cholespy", solve, K.shape, True)


def _superlu(K: sp.sparray, is_complex: bool) -> HermitianFactor:
    return superlu_factor(K, check=False)  # (it reads is_complex from K)


_BUILDERS = {"cholmod": _cholmod, "cvxopt": _cvxopt, "cholespy": _cholespy, "scipy": _superlu}


# ---------------------------------------------------------------------------- failures
def _not_positive_definite(exc: BaseException) -> bool:
    """Whether a backend's exception says that K is not positive definite."""
    name = type(exc).__name__
    return (
        isinstance(exc, ArithmeticError)  # cvxopt: the column where CHOLMOD stopped
        or "not positive definite" in str(exc).lower()  # cholespy
        or name == "CholmodNotPositiveDefiniteError"  # scikit-sparse
    )


def _failure(backend: str, n: int, is_complex: bool, exc: BaseException) -> FactorizationError:
    """The typed error for a backend's own exception ``exc``."""
    kind = "complex Hermitian" if is_complex else "real symmetric"
    if isinstance(exc, ArithmeticError) and exc.args and isinstance(exc.args[0], int):
        reason = f"not positive definite (CHOLMOD stopped at column {exc.args[0]})"
    elif _not_positive_definite(exc):
        reason = "not positive definite"
    else:
        reason = f"{type(exc).__name__}: {exc}"
    return FactorizationError(
        f"backend={backend!r} could not factor the {n} x {n} {kind} matrix: {reason}. "
        "It must be positive definite (a singular system, e.g. a Laplacian without "
        "constraints or a shift, is not)."
    )


def _build(backend: str, K: sp.csr_array, is_complex: bool) -> HermitianFactor:
    """One backend's factor, its failures raised as :class:`FactorizationError`."""
    try:
        return _BUILDERS[backend](K, is_complex)
    except FvfError:
        raise
    except (ArithmeticError, ValueError, RuntimeError) as exc:
        raise _failure(backend, K.shape[0], is_complex, exc) from exc
    except Exception as exc:  # scikit-sparse's CholmodError derives from Exception only
        if type(exc).__module__.startswith("sksparse"):
            raise _failure(backend, K.shape[0], is_complex, exc) from exc
        raise


def _build_with_fallback(first: Backend, K: sp.csr_array, is_complex: bool) -> HermitianFactor:
    """``backend="auto"``: ``first``, then the other available backends in turn (SuperLU
    right after a Cholesky backend found K not positive definite)."""
    chain = [first, *(b for b in available_backends() if b != first)]
    reasons: list[str] = []
    while chain:
        name = chain.pop(0)
        try:
            fac = _build(name, K, is_complex)
        except FactorizationError as exc:
            # keep the text only: the failed backend's frames (its partial factor) go now
            reasons.append(str(exc))
            if name in _CHOLESKY and _not_positive_definite(exc.__cause__ or exc):
                chain = [b for b in chain if b not in _CHOLESKY]
            continue
        if reasons:
            warnings.warn(
                "; ".join(reasons) + f" Used backend={name!r} instead.",
                FactorizationFallbackWarning,
                stacklevel=user_stacklevel(),
            )
        return fac
    raise FactorizationError("every factorization backend failed: " + " | ".join(reasons))


# ---------------------------------------------------------------------------- entrance
def factor_hermitian(
    K: sp.sparray | sp.spmatrix,
    backend: Backend = "auto",
    solves: Literal["few", "many"] = "many",
) -> HermitianFactor:
    """Factor a sparse Hermitian (or real symmetric) positive definite matrix once.

    Parameters
    ----------
    K : sparse (n, n), complex128 or float64
        Hermitian positive definite (only its values are used; the Cholesky backends
        find out when it is not positive definite, SuperLU only when it is singular).
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
        See the module docstring; ``"auto"`` takes the fastest one that imports and falls
        back to the next one when it fails.
    solves : {"few", "many"}
        How the factor will be used: a few right-hand sides (then ``"auto"`` favours the
        fastest factorization) or many (the fastest solves of a real K; for a complex K the
        fastest factorization wins either way).

    Returns
    -------
    HermitianFactor
        (an :class:`SPDFactor` for the scipy backend).

    Raises
    ------
    ParameterError
        Unknown backend.
    MissingExtraError
        The requested backend's package is not installed (extra ``[fast]``).
    FactorizationError
        The backend could not factor K (for ``"auto"``: none could).

    Warns
    -----
    FactorizationFallbackWarning
        ``"auto"``: a backend failed and the next one was used.
    """
    if backend not in BACKENDS:
        raise ParameterError(f"backend must be one of {BACKENDS}; got {backend!r}")
    if solves not in ("few", "many"):
        raise ParameterError(f"solves must be 'few' or 'many'; got {solves!r}")
    is_complex = bool(np.iscomplexobj(K.data) if sp.issparse(K) else np.iscomplexobj(K))
    if backend not in ("auto", "scipy") and backend not in available_backends():
        package = {"cholmod": "scikit-sparse"}.get(backend, backend)
        raise MissingExtraError(
            f"backend={backend!r} needs {package}: pip install 'fvf[fast]' (or pip install "
            f"{package}), or use backend='scipy'."
        )
    C = sp.csr_array(K)
    name = _auto(solves, is_complex) if backend == "auto" else backend
    if C.shape[0] == 0:  # nothing to factor (CHOLMOD's wrappers refuse an empty K)
        return HermitianFactor(name, np.copy, C.shape, is_complex)
    if backend == "auto":
        return _build_with_fallback(name, C, is_complex)
    return _build(name, C, is_complex)
