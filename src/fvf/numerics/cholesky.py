"""Sparse Hermitian positive definite factorizations with optional fast backends.

One entrance, :func:`factor_hermitian`, factors a sparse Hermitian (complex) or symmetric
(real) positive definite matrix K once and returns a :class:`HermitianFactor` whose
``solve`` applies K⁻¹ to one or many right-hand sides. Three backends:

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
    :data:`ND_MIN` unknowns on (minimum degree below). Always available; stores both L and
    U, so it needs about twice the memory of a Cholesky factor.

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
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import MissingExtraError, ParameterError
from .ordering import nested_dissection

__all__ = [
    "BACKENDS",
    "HermitianFactor",
    "factor_hermitian",
    "available_backends",
    "symmetric_splu",
    "ND_MIN",
]

Backend = Literal["auto", "cholmod", "cvxopt", "cholespy", "scipy"]
#: Accepted values of ``backend``.
BACKENDS: tuple[str, ...] = ("auto", "cholmod", "cvxopt", "cholespy", "scipy")
#: The scipy backend orders by nested dissection from this many unknowns on.
ND_MIN = 30_000


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


class HermitianFactor:
    """A factorization of a Hermitian positive definite K; ``solve`` applies K⁻¹.

    Attributes
    ----------
    backend : str
        ``"cholmod"``, ``"cholespy"`` or ``"scipy"``.
    complex : bool
        True when K was complex.
    shape : tuple of int
    """

    def __init__(
        self,
        backend: str,
        solve: Callable[[np.ndarray], np.ndarray],
        shape: tuple[int, int],
        is_complex: bool,
    ) -> None:
        self.backend = backend
        self._solve = solve
        self.shape = shape
        self.complex = is_complex

    def solve(self, B: np.ndarray) -> np.ndarray:
        """K⁻¹ B for B of shape (n,) or (n, p); complex128 if K is complex, else float64."""
        B = np.asarray(B)
        dtype = np.complex128 if self.complex else np.float64
        return self._solve(np.asarray(B, dtype=dtype))


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
    cholmod.numeric(A, fac)  # ArithmeticError when K is not positive definite
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
    fac = CholeskySolverD(n, rows, cols, data, MatrixType.COO)  # CHOLMOD reads the lower part
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


def symmetric_splu(
    K: sp.sparray | sp.spmatrix, ordering: Literal["auto", "nd", "mmd"] = "auto"
) -> tuple[spla.SuperLU, np.ndarray | None]:
    """SuperLU of a symmetric positive definite K with diagonal pivots (symmetric mode),
    after a fill-reducing ordering: ``"nd"`` nested dissection
    (:func:`fvf.numerics.ordering.nested_dissection`), ``"mmd"`` SuperLU's minimum degree
    on AᵀA + A, ``"auto"`` nested dissection from :data:`ND_MIN` unknowns on.

    Returns (lu, perm): ``lu`` factors ``K[perm][:, perm]`` (K itself when perm is None).
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


def _superlu(K: sp.sparray, is_complex: bool) -> HermitianFactor:
    lu, perm = symmetric_splu(K)

    def solve(B):
        if perm is None:
            return lu.solve(B)
        X = np.empty(B.shape, dtype=B.dtype)
        X[perm] = lu.solve(np.asfortranarray(B[perm]))
        return X

    return HermitianFactor("scipy", solve, K.shape, is_complex)


_BUILDERS = {"cholmod": _cholmod, "cvxopt": _cvxopt, "cholespy": _cholespy, "scipy": _superlu}


def factor_hermitian(
    K: sp.sparray | sp.spmatrix,
    backend: Backend = "auto",
    solves: Literal["few", "many"] = "many",
) -> HermitianFactor:
    """Factor a sparse Hermitian (or real symmetric) positive definite matrix once.

    Parameters
    ----------
    K : sparse (n, n), complex128 or float64
        Hermitian positive definite (only its values are used; it is not checked).
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
        See the module docstring; ``"auto"`` takes the fastest one that imports.
    solves : {"few", "many"}
        How the factor will be used: a few right-hand sides (then ``"auto"`` favours the
        fastest factorization) or many (the fastest solves of a real K; for a complex K the
        fastest factorization wins either way).

    Returns
    -------
    HermitianFactor

    Raises
    ------
    ParameterError
        Unknown backend.
    MissingExtraError
        The requested backend's package is not installed (extra ``[fast]``).
    """
    if backend not in BACKENDS:
        raise ParameterError(f"backend must be one of {BACKENDS}; got {backend!r}")
    if solves not in ("few", "many"):
        raise ParameterError(f"solves must be 'few' or 'many'; got {solves!r}")
    is_complex = np.iscomplexobj(K.data) if sp.issparse(K) else np.iscomplexobj(K)
    if backend == "auto":
        backend = _auto(solves, bool(is_complex))
    elif backend != "scipy" and backend not in available_backends():
        package = {"cholmod": "scikit-sparse"}.get(backend, backend)
        raise MissingExtraError(
            f"backend={backend!r} needs {package}: pip install 'fvf[fast]' (or pip install "
            f"{package}), or use backend='scipy'."
        )
    return _BUILDERS[backend](sp.csr_array(K), bool(is_complex))
