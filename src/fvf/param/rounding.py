r"""Integer conditions of a seamless parameterization: lattice of admissible integers, rounding.

The integer unknowns z (chain translations and singular-vertex positions, see
:mod:`fvf.param.seams`) must satisfy the closing conditions C z = 0 (integer C). Gaussian
elimination with unit pivots writes the solutions as z = N w with an integer matrix N and
free integers w, so that *every* integer w gives integer z satisfying C z = 0: rounding w
keeps the parameterization seamless exactly. Rows without a unit pivot (a condition such
as 2 z₁ = z₂) are reported; the parameterization then keeps those few unknowns real.

:class:`MixedIntegerSolver` rounds the free integers greedily, each batch followed by a
re-solve of the remaining unknowns (the adaptive rounding of Bommes et al. 2009, §5).
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Iterator

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..numerics.cholesky import Backend, HermitianFactor, factor_hermitian

__all__ = ["integer_lattice", "MixedIntegerSolver", "greedy_round"]


def integer_lattice(C: npt.ArrayLike, prefer: np.ndarray | None = None) -> np.ndarray:
    """An integer basis N of the lattice {z ∈ ℤ^p : C z = 0}: z = N w, w ∈ ℤ^f.

    Unit pivots first: a ±1 entry of the sparsest remaining row (Markowitz; ties: the
    first row), the first such column among the ``prefer`` columns if it has one, is
    eliminated from every other row (Gauss–Jordan), which keeps N integer and sparse. The
    rows are kept sparse (:class:`_SparseRows`: the seams' conditions have 2–3 entries;
    a dense elimination of the 2,500 × 2,800 conditions of a gear with its features as
    iso-lines took 0.9 s). The rows left without a unit entry (parity conditions such as
    2 z₁ = z₂ + z₃, met at cones of index ±1/4) are solved exactly by integer column
    reduction (:func:`_integer_kernel`).

    Parameters
    ----------
    C : float64 (k, p), dense or sparse
        Integer-valued constraint matrix.
    prefer : bool (p,), optional
        Columns to eliminate first (the chain translations).

    Returns
    -------
    N : float64 (p, f)
        Integer matrix whose columns span the lattice: z = N w satisfies C z = 0 and is
        integer for every integer w, and every such z has that form.
    """
    rows = sp.csr_array(C, dtype=np.float64, copy=True)
    rows.sum_duplicates()  # (a csr input may hold an entry twice: its sum is meant)
    A = _SparseRows(rows, prefer)
    pivots: list[tuple[int, int]] = []
    while (pivot := A.next_pivot()) is not None:
        A.eliminate(*pivot)
        pivots.append(pivot)
    p = A.shape[1]
    pcols = np.array([c for _, c in pivots], dtype=np.int64)
    free = np.setdiff1d(np.arange(p), pcols)
    where = np.full(p, -1, dtype=np.int64)
    where[free] = np.arange(free.size)
    N = np.zeros((p, free.size))
    N[free, np.arange(free.size)] = 1.0
    N[pcols] = -A.dense([r for r, _ in pivots], where)  # x_c = -(row r on the free columns)
    left = np.flatnonzero(A.active)  # rows without a unit pivot
    if left.size:
        N = N @ _integer_kernel(np.round(A.dense(left.tolist(), where)).astype(np.int64))
    return np.round(N)


class _SparseRows:
    """The rows of an integer matrix as dicts {column: value} with the rows of each column,
    for :func:`integer_lattice`'s pivoting: heaps of (non-zeros, row) of the rows with a
    unit entry among the preferred columns and anywhere, validated when popped."""

    def __init__(self, C: sp.csr_array, prefer: np.ndarray | None):
        k, p = C.shape
        self.shape = (k, p)
        self.pref = np.ones(p, dtype=bool) if prefer is None else np.asarray(prefer, bool)
        self.rows: list[dict[int, float]] = [{} for _ in range(k)]
        self.cols: list[set[int]] = [set() for _ in range(p)]
        for r in range(k):  # a loop over the conditions, each with a few entries
            lo, hi = C.indptr[r], C.indptr[r + 1]
            for j, v in zip(C.indices[lo:hi].tolist(), C.data[lo:hi].tolist(), strict=True):
                if abs(v) > 0.5:
                    self.rows[r][j] = v
                    self.cols[j].add(r)
        self.active = np.ones(k, dtype=bool)  # rows with entries and not yet a pivot
        self.first = np.full((2, k), -1, dtype=np.int64)  # unit column: preferred, any
        self.heaps: tuple[list, list] = ([], [])
        for r in range(k):
            self._refresh(r)

    def _refresh(self, r: int) -> None:
        row = self.rows[r]
        if not row:
            self.active[r] = False
            return
        units = [j for j, v in row.items() if abs(abs(v) - 1.0) < 1e-9]
        preferred = [j for j in units if self.pref[j]]
        for kind, cand in enumerate((preferred, units)):
            self.first[kind, r] = min(cand) if cand else -1
            if cand:
                heapq.heappush(self.heaps[kind], (len(row), r))

    def next_pivot(self) -> tuple[int, int] | None:
        """(row, column) of the next unit pivot, or None when no active row has one."""
        for kind, heap in enumerate(self.heaps):
            while heap:
                nnz, r = heap[0]
                if self.active[r] and self.first[kind, r] >= 0 and nnz == len(self.rows[r]):
                    return r, int(self.first[kind, r])
                heapq.heappop(heap)  # stale: the row changed or was used
        return None

    def eliminate(self, r: int, c: int) -> None:
        """Scale row r to 1 at column c and subtract it from every other row there."""
        pivot = self.rows[r]
        scale = pivot[c]
        for j in pivot:
            pivot[j] /= scale
        self.active[r] = False
        for o in sorted(self.cols[c] - {r}):  # the rows with an entry in column c
            row, factor = self.rows[o], self.rows[o][c]
            for j, v in pivot.items():
                x = row.get(j, 0.0) - factor * v
                if abs(x) > 0.5:
                    row[j] = x
                    self.cols[j].add(o)
                else:
                    row.pop(j, None)
                    self.cols[j].discard(o)
            if self.active[o]:
                self._refresh(o)

    def dense(self, rows: list[int], where: np.ndarray) -> np.ndarray:
        """float64 (len(rows), where.max() + 1): the ``rows`` on the columns j with
        ``where[j] >= 0``, at ``where[j]`` (after the elimination a row holds no other
        pivot column than its own, which is left out)."""
        out = np.zeros((len(rows), int(where.max(initial=-1)) + 1))
        for i, r in enumerate(rows):  # a loop over rows of a few entries each
            for j, v in self.rows[r].items():
                if where[j] >= 0:
                    out[i, where[j]] = v
        return out


def _integer_kernel(C: np.ndarray) -> np.ndarray:
    """Basis of {w ∈ ℤ^f : C w = 0} by unimodular column operations, float64 (f, f − rank).

    Column-style Hermite reduction of [C; I] (Cohen 1993, Alg. 2.4.10): each row of C is
    reduced to one non-zero entry by Euclid steps on the columns; the identity block
    records the operations, and its columns beyond the rank span the integer kernel.
    """
    k, f = C.shape
    M = np.vstack([C, np.eye(f, dtype=np.int64)]).astype(np.int64)
    col = 0
    for i in range(k):
        while col < f:
            js = col + np.flatnonzero(M[i, col:] != 0)
            if js.size == 0:
                break
            j = js[np.argmin(np.abs(M[i, js]))]
            M[:, [col, j]] = M[:, [j, col]]
            rest = col + 1 + np.flatnonzero(M[i, col + 1 :] != 0)
            if rest.size == 0:
                col += 1
                break
            q = M[i, rest] // M[i, col]
            M[:, rest] -= np.outer(M[:, col], q)
        if np.abs(M).max() > 2**40:
            raise OverflowError("integer kernel entries grew too large")
    return M[k:, col:].astype(np.float64)


#: Float64 entries of the solve block H_rr⁻¹ H_ri held at once (memory bound, 200 MB).
SCHUR_BLOCK_ENTRIES = 25_000_000
#: Right-hand sides a block's solve passes to the backend at once (:func:`solved_columns`):
#: 4 (or a multiple), the columns CHOLMOD's triangular solves take together, so that every
#: column's arithmetic is that of the whole block's solve. The backend copies the right-hand
#: sides twice (column-major in, column-major out): with the whole 33-column block of a
#: 750k-unknown fit that was 0.8 GB on top of the factor.
SOLVE_COLUMNS = 4


def solved_columns(fac: HermitianFactor, B: sp.sparray) -> Iterator[tuple[slice, np.ndarray]]:
    """K⁻¹ B by groups of :data:`SOLVE_COLUMNS` columns, float64.

    Parameters
    ----------
    fac : HermitianFactor
        The factor of K (n, n), real.
    B : sparse (n, c)
        Right-hand sides (sliced by columns: csc is cheapest).

    Yields
    ------
    cols : slice
        The columns of B solved.
    X : float64 (n, len(cols))
        K⁻¹ B[:, cols].
    """
    for lo in range(0, B.shape[1], SOLVE_COLUMNS):  # a few groups per block
        cols = slice(lo, min(lo + SOLVE_COLUMNS, B.shape[1]))
        yield cols, fac.solve(B[:, cols].toarray())


class MixedIntegerSolver:
    """Minimize ½ yᵀH y − gᵀy with y[integer] ∈ ℤ, for several right-hand sides g.

    The real unknowns are eliminated once: one sparse Cholesky factorization of their
    block H_rr (:func:`fvf.numerics.cholesky.factor_hermitian`) and, in column blocks, the
    solves Z = H_rr⁻¹ H_ri that give the dense Schur complement S = H_ii − H_riᵀ Z of the
    k integer unknowns (k is a few per cone: memory O(nnz(factor) + k²)). Z is not kept;
    the real unknowns of a given integer vector cost one more solve. Greedy rounding then
    works on the k × k system alone (:meth:`rounded`).

    Parameters
    ----------
    H : sparse (p, p)
        Symmetric positive definite.
    integer : int64 (k,)
        Unknowns to round.
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
        Factorization of H_rr.
    progress : callable, optional
        Called as ``progress(done, total)`` while the Schur complement is built.
    """

    def __init__(
        self,
        H: sp.csr_array,
        integer: np.ndarray,
        backend: Backend = "auto",
        progress: Callable[[int, int], None] | None = None,
    ):
        H = sp.csr_array(H)
        p = H.shape[0]
        self.p = p
        self.integer = np.asarray(integer, dtype=np.int64)
        self.real_idx = np.setdiff1d(np.arange(p), self.integer)
        Hr = H[self.real_idx]
        self.Hri = sp.csc_array(Hr[:, self.integer])
        self.Hrr = sp.csr_array(Hr[:, self.real_idx])
        self.fac = factor_hermitian(self.Hrr, backend)
        k = self.integer.size
        S = H[self.integer][:, self.integer].toarray()
        chunk = max(1, min(k, SCHUR_BLOCK_ENTRIES // max(self.real_idx.size, 1)))
        for lo in range(0, k, chunk):  # a few blocks of integer columns
            cols = np.arange(lo, min(lo + chunk, k))
            for part, Zc in solved_columns(self.fac, self.Hri[:, cols]):
                S[:, cols[part]] -= self.Hri.T @ Zc
            if progress is not None:
                progress(int(cols[-1]) + 1, k)
        self.S = 0.5 * (S + S.T)

    def release(self) -> None:
        """Free the factorization and the matrices; the solver cannot solve afterwards
        (``integer``, ``real_idx`` and ``S`` stay)."""
        del self.fac, self.Hrr, self.Hri

    def reduced(self, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(H_rr⁻¹ g_r, g_i − H_riᵀ H_rr⁻¹ g_r): the real part at w = 0, the reduced rhs."""
        yr0 = self.fac.solve(g[self.real_idx])
        return yr0, g[self.integer] - self.Hri.T @ yr0

    def assemble(self, yr0: np.ndarray, w: np.ndarray) -> np.ndarray:
        """The full y (p,) with y[integer] = w and the real unknowns minimizing for that w."""
        y = np.empty(self.p)
        y[self.integer] = w
        y[self.real_idx] = yr0 - (self.fac.solve(self.Hri @ w) if w.size else 0.0)
        return y

    def real(self, g: np.ndarray) -> np.ndarray:
        """The real minimizer (no rounding), float64 (p,)."""
        yr0, r = self.reduced(g)
        w = np.linalg.solve(self.S, r) if self.integer.size else np.zeros(0)
        return self.assemble(yr0, w)

    def rounded(self, g: np.ndarray, batch: float = 0.05) -> np.ndarray:
        """Greedy rounding (Bommes et al. 2009, §5): y (p,) with y[integer] ∈ ℤ.

        Repeatedly fixes the unknowns closest to an integer (a ``batch`` fraction of those
        left, at least one) and re-solves the others; ``batch=1`` is direct rounding. See
        :func:`greedy_round` for the k × k part.
        """
        yr0, r = self.reduced(g)
        return self.assemble(yr0, greedy_round(self.S, r, batch))


def greedy_round(S: np.ndarray, r: np.ndarray, batch: float = 0.05) -> np.ndarray:
    """Greedy rounding of min ½ xᵀS x − rᵀx over x ∈ ℤ^k, float64 (k,) of integers.

    The minimizer of the unknowns left free, given those already fixed, is the
    conditional mean of a Gaussian with precision S: with Σ = S⁻¹, fixing a batch B to
    values v_B moves the mean by Σ_{:B} Σ_{BB}⁻¹ (v_B − μ_B) and updates
    Σ ← Σ − Σ_{:B} Σ_{BB}⁻¹ Σ_{B:}. Only the rows and columns of the unknowns still
    free are kept and updated, so that a batch costs O(k_left² |B|) and the whole
    rounding about k³/3 after the inverse (instead of a new k × k solve per batch).

    Parameters
    ----------
    S : float64 (k, k)
        Symmetric positive definite.
    r : float64 (k,)
    batch : float in (0, 1]
        Fraction of the unknowns left that is fixed per step (the closest to integers).
    """
    k = r.size
    if k == 0:
        return np.zeros(0)
    cov = np.linalg.inv(S)
    cov = 0.5 * (cov + cov.T)
    mean = cov @ r
    out = np.empty(k)
    left = np.arange(k)  # the unknowns still free: the rows and columns of cov and mean
    while left.size:
        dist = np.abs(mean - np.round(mean))
        count = max(1, int(np.ceil(batch * left.size)))
        pick = np.union1d(np.argsort(dist, kind="stable")[:count], np.flatnonzero(dist < 1e-6))
        delta = np.round(mean[pick]) - mean[pick]
        cB = cov[:, pick]
        coef = np.linalg.solve(cov[np.ix_(pick, pick)], np.column_stack([delta, cB.T]))
        mean += cB @ coef[:, 0]
        out[left[pick]] = np.round(mean[pick])
        rest = np.setdiff1d(np.arange(left.size), pick)
        cov = cov[np.ix_(rest, rest)] - cB[rest] @ coef[:, 1:][:, rest]
        mean, left = mean[rest], left[rest]
    return out
