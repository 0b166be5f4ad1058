"""Laplace–Beltrami eigenpairs: the k smallest solutions of W φ = λ [M] φ.

W is a sparse symmetric positive semidefinite stiffness matrix (n, n), for instance
:func:`fvf.stiffness`, whose kernel is spanned by the constants on each connected
component, and ``mass`` (n,) is a positive lumped mass, for instance
:attr:`TriMesh.vertex_areas`. :func:`smallest_eigenpairs` returns the k smallest
eigenvalues and an [M]-orthonormal eigenbasis.

Method (``method="auto"``)
--------------------------
For n > :data:`DENSE_MAX` the default is a *block shift-invert Krylov–Schur* iteration
(``method="krylov"``):

1. Shift. σ = −10⁻⁸ · mean(diag W / mass) (a tiny negative number relative to the
   spectrum's scale), so K = W − σ[M] is symmetric positive definite although W has the
   constants in its kernel.
2. Factor K once with SuperLU in symmetric mode: the fill-reducing minimum-degree
   ordering of Kᵀ + K (``permc_spec="MMD_AT_PLUS_A"``), diagonal pivots only
   (``diag_pivot_thresh=0``), which is stable for a positive definite K. On meshes it
   has about half the fill of the COLAMD ordering that a plain
   ``scipy.sparse.linalg.eigsh(..., sigma=σ)`` call uses, so every solve is cheaper.
   All diagonal pivots must come out positive; otherwise K is not positive definite
   and the factorization counts as failed.
3. Iterate on T = [M]^½ K⁻¹ [M]^½ (symmetric; its largest eigenvalues θ = 1/(λ − σ)
   are the wanted ones) with a block Krylov–Schur method (Stewart 2002;
   :mod:`fvf.numerics.krylov_schur`): block
   Lanczos steps build an orthonormal basis of up to k + min(max(k, 100), ...) vectors,
   then Rayleigh–Ritz and a thick restart keeps the k + (basis − k)/2 best Ritz vectors.
   Each step solves with one block of b right-hand sides (b = clamp(k/16, 6, 8), at
   least the number of connected components + 2), which SuperLU does about twice as
   fast per column as single solves. Every new block is orthogonalized against the last
   two blocks (the Lanczos recurrence), then once more against the whole basis (full
   re-orthogonalization, repeated while a column loses half its norm), then
   orthonormalized by Cholesky QR twice: matrix–matrix (BLAS-3) work instead of
   ARPACK's matrix–vector work. The residual of every Ritz pair in the original
   problem is computed exactly from the Krylov relation (one sparse product per
   block), every 24 new vectors, so the iteration stops as soon as every wanted pair
   meets ``tol / 2``.
4. Inertia check. Block Krylov methods can miss copies of an eigenvalue whose
   multiplicity exceeds the block size b (symmetric meshes, identical components);
   they then find about b copies of it. So when some computed eigenvalue occurs at
   least b − 1 times (to a relative 10⁻⁶), the number of negative pivots of an
   LDLᵀ-type factorization of W − τ[M] (Sylvester's law of inertia; one more
   factorization) is compared with the number of computed eigenvalues below τ, τ in
   the widest gap of the top half of the computed spectrum. If eigenvalues were
   missed, the iteration is rerun with a larger block and a
   :class:`SpectralFallbackWarning` is emitted.
5. Eigenvalues are the Rayleigh quotients φᵀWφ of the returned [M]-normalized vectors,
   and every relative residual is checked directly against ``tol``.

The dense work is many small matrix products; with a threaded BLAS on a busy or small
machine, limiting BLAS to one thread (``threadpoolctl.threadpool_limits(1)``) can make
the solver much faster.

For n ≤ :data:`DENSE_MAX` (and for k ≥ n/3 up to n = :data:`DENSE_K_MAX_N`), dense
:func:`scipy.linalg.eigh` of [M]^-½ W [M]^-½ is used instead (``method="dense"``).
``method="eigsh"`` is the plain reference path: :func:`scipy.sparse.linalg.eigsh` in
shift-invert mode with the same σ and a seeded start vector.

Fallback
--------
If the chosen method fails — the factorization is singular or not positive definite,
the iteration does not converge within ``maxiter`` restarts, or the final residual check
fails — the next method of the chain ``krylov → eigsh → dense`` is used (dense only for
n ≤ :data:`DENSE_FALLBACK_MAX`), and a :class:`SpectralFallbackWarning` says what failed
and what was used instead. Nothing is printed. If the chain is exhausted,
:class:`SpectralSolveError` is raised with every failure's reason.

Residual measure and sign convention
------------------------------------
Every returned pair has the relative residual of :func:`eigen_residuals` at most ``tol``,
and its eigenvector the sign convention of :mod:`fvf.numerics.eigenpairs` (the entry of
largest magnitude positive), both applied by
:func:`~fvf.numerics.eigenpairs.normalized_eigenpairs`. Vectors of a multiple eigenvalue
are one [M]-orthonormal basis of the eigenspace, which depends on ``seed``; with the same
inputs and seed the output is identical from call to call.

Randomness is seeded only (``numpy.random.default_rng(seed)``): the start block of the
Krylov iteration and the start vector of the eigsh path.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.csgraph  # noqa: F401  (sp.csgraph)
import scipy.sparse.linalg as spla

from ..errors import (  # noqa: F401 (re-exported)
    FactorizationError,
    FvfError,
    FvfWarning,
    SpectralFallbackWarning,
    SpectralInputError,
    SpectralSolveError,
)
from .cholesky import (  # noqa: F401 (ND_MIN re-exported)
    ND_MIN,
    SPDFactor,
    available_backends,
    factor_hermitian,
    superlu_factor,
)
from .eigenpairs import eigen_residuals, normalized_eigenpairs, spectral_norm_bound
from .krylov_schur import CHECK_EVERY, block_krylov_schur, block_size  # noqa: F401 (re-exported)
from .progress import ProgressCallback, make_progress

__all__ = [
    "smallest_eigenpairs",
    "eigen_residuals",
    "spectral_norm_bound",
    "default_shift",
    "count_eigenvalues_below",
    "factor_spd",
    "SPDFactor",
    "METHODS",
    "ORDERINGS",
    "DENSE_MAX",
]

METHODS = ("auto", "krylov", "eigsh", "dense")
DENSE_MAX = 500  # auto uses dense eigh up to this many vertices
DENSE_K_MAX_N = 8000  # ... and also when 3k >= n, up to this many vertices
DENSE_FALLBACK_MAX = 8000  # the fallback chain ends with dense eigh up to this size
SHIFT_FACTOR = 1e-8  # sigma = -SHIFT_FACTOR * mean(diag W / mass)

Method = Literal["auto", "krylov", "eigsh", "dense"]
Ordering = Literal["auto", "mmd", "nd"]
ORDERINGS = ("auto", "mmd", "nd")


#: A method of the chain failed (the message says why): the next one is tried. Every
#: method reports failure with this typed error (a factorization's FactorizationError is
#: one too), so nothing untyped reaches the caller when the chain is exhausted.
_MethodFailed = SpectralSolveError


# ------------------------------------------------------------------------ public helpers
def default_shift(W: sp.sparray | sp.spmatrix, mass: npt.ArrayLike) -> float:
    """σ = −10⁻⁸ · mean(diag W / mass): the negative shift of the shift-invert methods.

    Small against every nonzero eigenvalue of interest and large enough that
    K = W − σ[M] is numerically positive definite (its condition number is about
    10⁸ · max/mean of diag W / mass).

    Returns
    -------
    float
        A negative number (−1e-8 if diag W is zero).
    """
    d = sp.csr_array(W).diagonal() / np.asarray(mass, dtype=np.float64)
    scale = float(np.mean(np.abs(d))) if d.size else 0.0
    if not np.isfinite(scale) or scale <= 0.0:
        scale = 1.0
    return -SHIFT_FACTOR * scale


# --------------------------------------------------------------------------- validation
def _validate(
    W: Any, mass: Any, k: Any, tol: Any, method: Any, ordering: Any = "auto"
) -> tuple[sp.csr_array, np.ndarray, int]:
    if method not in METHODS:
        raise SpectralInputError(f"method must be one of {METHODS}; got {method!r}")
    if ordering not in ORDERINGS:
        raise SpectralInputError(f"ordering must be one of {ORDERINGS}; got {ordering!r}")
    if not sp.issparse(W):
        W = np.asarray(W)
        if W.ndim != 2:
            raise SpectralInputError(f"W must be a 2-D (n, n) matrix; got shape {W.shape}")
    if W.ndim != 2 or W.shape[0] != W.shape[1]:
        raise SpectralInputError(f"W must be square (n, n); got shape {W.shape}")
    if sp.issparse(W) and not np.issubdtype(W.dtype, np.number):
        raise SpectralInputError(f"W must have a real numeric dtype; got {W.dtype}")
    if np.iscomplexobj(W):
        raise SpectralInputError("W must be real; got a complex matrix")
    W = sp.csr_array(W, dtype=np.float64)
    n = W.shape[0]
    m = np.asarray(mass)
    if m.shape != (n,):
        raise SpectralInputError(f"mass must have shape ({n},) to match W; got {m.shape}")
    if np.iscomplexobj(m) or not np.issubdtype(m.dtype, np.number):
        raise SpectralInputError(f"mass must be real; got dtype {m.dtype}")
    m = m.astype(np.float64)
    if not np.all(np.isfinite(W.data)):
        raise SpectralInputError("W contains NaN or inf entries")
    bad = np.flatnonzero(~np.isfinite(m) | (m <= 0))
    if bad.size:
        from ..errors import format_indices

        raise SpectralInputError(
            f"mass must be finite and positive; bad entries at {format_indices(bad)} "
            "(remove unreferenced vertices or degenerate faces first)"
        )
    if isinstance(k, bool) or not isinstance(k, int | np.integer):
        raise SpectralInputError(f"k must be an integer; got {k!r}")
    k = int(k)
    if not 1 <= k < n:
        raise SpectralInputError(f"k must satisfy 1 <= k < n = {n}; got k = {k}")
    if not (isinstance(tol, float | int) and np.isfinite(tol) and 0 < tol < 1):
        raise SpectralInputError(f"tol must be a number in (0, 1); got {tol!r}")
    asym = abs(W - W.T)
    scale = abs(W).max() if W.nnz else 0.0
    if asym.nnz and asym.max() > 1e-10 * scale:
        raise SpectralInputError(
            f"W must be symmetric; max |W - W^T| = {asym.max():.3g} (max |W| = {scale:.3g})"
        )
    return W, m, k


# ------------------------------------------------------------------------------- public
def smallest_eigenpairs(
    W: sp.sparray | sp.spmatrix | npt.ArrayLike,
    mass: npt.ArrayLike,
    k: int,
    *,
    tol: float = 1e-8,
    seed: int = 0,
    method: Method = "auto",
    maxiter: int | None = None,
    ordering: Ordering = "auto",
    progress: bool | ProgressCallback | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The k smallest eigenpairs of W φ = λ [M] φ.

    Parameters
    ----------
    W : sparse array or matrix, shape (n, n)
        Symmetric positive semidefinite stiffness matrix, e.g. :func:`fvf.stiffness`.
    mass : array_like of float, shape (n,)
        Positive diagonal of the lumped mass matrix, e.g. ``mesh.vertex_areas``.
    k : int
        Number of eigenpairs, ``1 <= k < n``.
    tol : float
        Bound on each pair's relative residual (see :func:`eigen_residuals`).
    seed : int
        Seed of the random start block / vector.
    method : {"auto", "krylov", "eigsh", "dense"}
        ``"auto"``: dense for n ≤ :data:`DENSE_MAX` (or 3k ≥ n, n ≤ 8000), else
        ``"krylov"`` (block shift-invert Krylov–Schur on a symmetric-mode SuperLU
        factorization). ``"eigsh"``: plain shift-invert ``scipy.sparse.linalg.eigsh``.
        ``"dense"``: :func:`scipy.linalg.eigh`.
    maxiter : int, optional
        Maximum number of restarts of the ``"krylov"`` iteration (default 60); exceeding
        it triggers the fallback. The other methods ignore it.
    ordering : {"auto", "mmd", "nd"}
        Fill-reducing ordering of the ``"krylov"`` method's factorization (see
        :func:`factor_spd`); "auto" uses nested dissection from :data:`ND_MIN` unknowns.
    progress : None, bool or callable
        ``True`` for a tqdm bar, or a callback ``(stage, done, total)``
        (:mod:`fvf.numerics.progress`): ``"factor"`` (0, then 1 of 1) and ``"iterate"``
        (eigenpairs converged of k) for the ``"krylov"`` method.

    Returns
    -------
    evals : numpy.ndarray of float64, shape (k,)
        Eigenvalues in ascending order.
    evecs : numpy.ndarray of float64, shape (n, k)
        [M]-orthonormal eigenvectors (ΦᵀMΦ = I), column i for ``evals[i]``; each with
        its entry of largest magnitude positive.

    Raises
    ------
    SpectralInputError
        Bad shapes, k, tol or method; non-finite W or mass; mass ≤ 0; asymmetric W.
    SpectralSolveError
        Every method of the fallback chain failed.

    Warns
    -----
    SpectralFallbackWarning
        The requested (or automatically chosen) method failed and another one was used.
    """
    W, m, k = _validate(W, mass, k, tol, method, ordering)
    report = make_progress(progress)
    n = W.shape[0]
    if method == "auto":
        small = n <= DENSE_MAX or (3 * k >= n and n <= DENSE_K_MAX_N)
        method = "dense" if small else "krylov"
    chain = {"krylov": ["krylov", "eigsh"], "eigsh": ["eigsh"], "dense": ["dense"]}[method]
    if n <= DENSE_FALLBACK_MAX and chain[-1] != "dense":
        chain.append("dense")
    solvers: dict[str, Callable[..., tuple[np.ndarray, np.ndarray]]] = {
        "krylov": _solve_krylov,
        "eigsh": _solve_eigsh,
        "dense": _solve_dense,
    }
    failures: list[str] = []
    for i, name in enumerate(chain):
        try:
            options = {"report": report} if name == "krylov" else {}
            lam, X = solvers[name](
                W, m, k, tol=tol, seed=seed, maxiter=maxiter, ordering=ordering, **options
            )
            lam, X, res = normalized_eigenpairs(W, m, X)
            if not np.all(res <= tol):
                worst = int(np.argmax(res))
                raise SpectralSolveError(
                    f"residual check failed: pair {worst} has relative residual "
                    f"{res[worst]:.3g} > tol = {tol:.3g}"
                )
        except (RuntimeError, np.linalg.LinAlgError, ValueError) as exc:
            if isinstance(exc, FvfError) and not isinstance(exc, SpectralSolveError):
                raise  # bad input: no method can do better
            failures.append(f"{name}: {type(exc).__name__}: {exc}")
            if i + 1 < len(chain):
                warnings.warn(
                    f"smallest_eigenpairs: method {name!r} failed ({exc}); "
                    f"falling back to {chain[i + 1]!r}",
                    SpectralFallbackWarning,
                    stacklevel=2,
                )
            continue
        return lam, X
    raise SpectralSolveError(
        "smallest_eigenpairs: every method failed:\n  " + "\n  ".join(failures)
    )


# ------------------------------------------------------------------------------ dense
def _solve_dense(W, m, k, *, tol, seed, maxiter, ordering=None):
    """Dense eigh of [M]^-½ W [M]^-½ (deterministic; tol, seed, maxiter unused)."""
    s = 1.0 / np.sqrt(m)
    A = (W.toarray() * s[:, None]) * s[None, :]
    A = 0.5 * (A + A.T)
    lam, Y = sla.eigh(A, subset_by_index=[0, k - 1], driver="evr")
    return lam, Y * s[:, None]


# ------------------------------------------------------------------------------ eigsh
def _solve_eigsh(W, m, k, *, tol, seed, maxiter, ordering=None):
    sigma = default_shift(W, m)
    rng = np.random.default_rng(seed)
    v0 = rng.standard_normal(W.shape[0])
    M = sp.diags_array(m).tocsc()
    try:
        # ARPACK's tol bounds ‖T y − θ y‖ / |θ| for the shift-inverted operator, which
        # maps to roughly the same relative residual here; ask for 1000x more.
        lam, X = spla.eigsh(W.tocsc(), k, M=M, sigma=sigma, which="LM", v0=v0, tol=1e-3 * tol)
    except spla.ArpackNoConvergence as exc:
        raise SpectralSolveError(f"ARPACK did not converge: {exc}") from exc
    return lam, X


# ------------------------------------------------------------------------------ krylov
def factor_spd(K: sp.sparray | sp.spmatrix, ordering: Ordering = "auto") -> SPDFactor:
    """Symmetric-mode SuperLU factorization of a symmetric positive definite K.

    Parameters
    ----------
    K : sparse (n, n)
        Symmetric positive definite.
    ordering : {"auto", "mmd", "nd"}
        Fill-reducing ordering: SuperLU's minimum degree on Kᵀ + K ("mmd"), or nested
        dissection (:func:`fvf.numerics.ordering.nested_dissection`, "nd"). "auto": "nd" from
        :data:`ND_MIN` unknowns on. Measured (one thread, ACAP energy E_B of the spot mesh,
        ~26 entries per row): at 47k unknowns mmd 5.9 s vs nd 1.0 s + 3.8 s; at 187k
        unknowns nd 3.5 s + 12 s (78M factor entries) while mmd did not finish in 300 s.

    Returns
    -------
    SPDFactor
        The SuperLU member of the factorization family (:mod:`fvf.numerics.cholesky`).

    Raises
    ------
    SpectralInputError
        Unknown ordering.
    FactorizationError
        SuperLU found K singular, or a pivot is not positive (K is not positive definite).
    """
    return superlu_factor(K, _checked_ordering(ordering))


def _checked_ordering(ordering: Any) -> Ordering:
    if ordering not in ORDERINGS:
        raise SpectralInputError(f"ordering must be one of {ORDERINGS}; got {ordering!r}")
    return ordering


def _fast_factor(K: sp.csc_array, seed: int | None) -> Any:
    """K's Cholesky factor by a fast backend of :mod:`fvf.numerics.cholesky` (CHOLMOD,
    cholespy: about half the time and the memory of the symmetric-mode SuperLU factor), or
    None when none is installed or K proved not positive definite (a solve that misses
    its own right-hand side: CHOLMOD stops at the first non-positive pivot)."""
    fast = [b for b in available_backends() if b != "scipy"]
    if not fast:
        return None
    try:
        fac = factor_hermitian(K, backend=fast[0])
    except FactorizationError:  # the backend's failure, typed: use SuperLU instead
        return None
    b = np.random.default_rng(seed).standard_normal(K.shape[0])
    x = fac.solve(b)
    res = np.linalg.norm(K @ x - b) / np.linalg.norm(b)
    if not (np.isfinite(x).all() and res <= 1e-8):
        return None
    return fac


class _Refined:
    """Solves with one step of iterative refinement, x + K⁻¹(b − Kx): for tolerances near
    round-off, where the Krylov relation's residual estimates assume exact solves."""

    def __init__(self, fac: Any, K: sp.csc_array) -> None:
        self.fac, self.K = fac, K

    def solve(self, B: np.ndarray) -> np.ndarray:
        X = self.fac.solve(B)
        return X + self.fac.solve(B - self.K @ X)


def _solve_krylov(W, m, k, *, tol, seed, maxiter, ordering="auto", report=None):
    n = W.shape[0]
    report = report or make_progress(None)
    sigma = default_shift(W, m)
    K = (W - sigma * sp.diags_array(m)).tocsc()
    report("factor", 0, 1)
    lu = _fast_factor(K, seed) if ordering == "auto" else None
    if lu is not None and tol < 1e-9:
        lu = _Refined(lu, K)  # one step of iterative refinement: solves as exact as SuperLU's
    if lu is None:
        lu = factor_spd(K, ordering)
    sq = np.sqrt(m)
    isq = 1.0 / sq
    nu = spectral_norm_bound(W, m)
    Khat = sp.csr_array(isq[:, None] * K.multiply(isq[None, :]))  # [M]^-½ K [M]^-½
    report("factor", 1, 1)

    def apply_T(Yt: np.ndarray) -> np.ndarray:
        """(b, n) rows y -> rows of [M]^½ K⁻¹ [M]^½ y."""
        B = Yt.T * sq[:, None]  # (n, b), F-ordered
        Z = lu.solve(np.asfortranarray(B))
        return np.ascontiguousarray((Z * sq[:, None]).T)

    def apply_Khat(Yt: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray((Khat @ Yt.T).T)

    ncomp = sp.csgraph.connected_components(W, directed=False)[0]
    b = max(block_size(n, k), min(ncomp + 2, 64, n // 8))
    rng = np.random.default_rng(seed)
    for attempt in range(3):
        theta, Yt = block_krylov_schur(
            apply_T,
            apply_Khat,
            n,
            k,
            sigma=sigma,
            nu=nu,
            tol=tol,
            rng=rng,
            maxiter=60 if maxiter is None else maxiter,
            block=b,
            report=report,
        )
        lam = sigma + 1.0 / theta
        lam_sorted = np.sort(lam)
        if _largest_cluster(lam_sorted) < b - 1:
            break  # every eigenvalue found fewer times than the block size: none missed
        missed = _inertia_check(W, m, lam_sorted, ordering)
        if missed is None:
            break
        tau, found, below = missed
        if below < found:
            raise SpectralSolveError(
                f"inertia check failed: {found} computed eigenvalues but only {below} "
                f"eigenvalues of the pencil below {tau:.6g}"
            )
        if attempt == 2:
            raise SpectralSolveError(
                f"missed {below - found} eigenvalue(s) below {tau:.6g} after 3 attempts"
            )
        b_new = min(2 * b + below - found, n // 4)
        warnings.warn(
            f"smallest_eigenpairs: the Krylov iteration (block size {b}) missed "
            f"{below - found} eigenvalue(s) below {tau:.6g} (Sylvester inertia count); "
            f"retrying with block size {b_new}",
            SpectralFallbackWarning,
            stacklevel=3,
        )
        b = b_new
    return lam, Yt.T * isq[:, None]


def count_eigenvalues_below(
    W: sp.sparray | sp.spmatrix, mass: npt.ArrayLike, tau: float, ordering: Ordering = "auto"
) -> int:
    """Number of eigenvalues of W φ = λ[M]φ below ``tau`` (Sylvester's law of inertia).

    Counts the negative pivots of a symmetric-mode (diagonal-pivot) SuperLU
    factorization of W − τ[M]. ``ordering`` is the fill-reducing ordering (see
    :func:`factor_spd`).

    Returns
    -------
    int

    Raises
    ------
    SpectralInputError
        Unknown ordering.
    SpectralSolveError
        (a ``RuntimeError``; :class:`~fvf.errors.FactorizationError` when SuperLU found
        the matrix singular) SuperLU had to pivot off the diagonal or met a zero pivot:
        the count would be unreliable.
    """
    W = sp.csr_array(W)
    m = np.asarray(mass, dtype=np.float64)
    fac = superlu_factor(W - tau * sp.diags_array(m), _checked_ordering(ordering), check=False)
    if not np.array_equal(fac.lu.perm_r, fac.lu.perm_c):
        raise SpectralSolveError("off-diagonal pivoting: inertia count unavailable")
    d = fac.pivots
    if not np.all(np.isfinite(d)) or np.any(d == 0):
        raise SpectralSolveError("singular pivot: inertia count unavailable")
    return int(np.count_nonzero(d < 0))


def _largest_cluster(lam: np.ndarray, rtol: float = 1e-6) -> int:
    """Size of the largest group of (numerically) equal sorted eigenvalues."""
    if lam.size < 2:
        return lam.size
    scale = np.maximum(np.abs(lam[1:]), 1e-6 * np.abs(lam).max())
    close = np.diff(lam) <= rtol * scale
    # longest run of True in close, plus one
    edges = np.flatnonzero(np.diff(np.concatenate([[0], close.astype(np.int8), [0]])))
    runs = edges[1::2] - edges[::2]
    return int(runs.max()) + 1 if runs.size else 1


def _inertia_check(
    W: Any, m: np.ndarray, lam: np.ndarray, ordering: Ordering = "auto"
) -> tuple[float, int, int] | None:
    """Compare the computed eigenvalues below a gap τ with the inertia count there.

    τ is the midpoint of the widest relative gap (weighted up to 2x toward the top) among
    the top half of the computed eigenvalues. Returns None when the counts agree (or k < 2, or the
    count is unavailable), else (τ, computed count, true count).
    """
    k = lam.size
    if k < 2:
        return None
    lo = k // 2
    gaps = (lam[lo + 1 :] - lam[lo:-1]) / np.maximum(np.abs(lam[lo + 1 :]), 1e-300)
    # the widest relative gap of the top half, weighted toward the top
    score = gaps * (1.0 + np.arange(gaps.size) / max(gaps.size, 1))
    i = lo + int(np.argmax(score))
    if gaps[i - lo] < 1e-6:
        return None  # no usable gap: all top eigenvalues (numerically) equal
    tau = 0.5 * (lam[i] + lam[i + 1])
    found = i + 1
    try:
        below = count_eigenvalues_below(W, m, tau, ordering)
    except SpectralSolveError:
        return None
    return None if below == found else (tau, found, below)
