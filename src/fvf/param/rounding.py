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

import numpy as np
import scipy.sparse as sp

from ..numerics.eigen import factor_spd

__all__ = ["integer_lattice", "MixedIntegerSolver"]


def integer_lattice(C: np.ndarray, prefer: np.ndarray | None = None) -> np.ndarray:
    """An integer basis N of the lattice {z ∈ ℤ^p : C z = 0}: z = N w, w ∈ ℤ^f.

    Unit pivots first: a ±1 entry of the sparsest remaining row (Markowitz), among the
    ``prefer`` columns first, is eliminated, which keeps N integer and sparse. The rows
    left without a unit entry (parity conditions such as 2 z₁ = z₂ + z₃, met at cones of
    index ±1/4) are solved exactly by integer column reduction (:func:`_integer_kernel`).

    Parameters
    ----------
    C : float64 (k, p)
        Integer-valued constraint matrix.
    prefer : bool (p,), optional
        Columns to eliminate first (the chain translations).

    Returns
    -------
    N : float64 (p, f)
        Integer matrix whose columns span the lattice: z = N w satisfies C z = 0 and is
        integer for every integer w, and every such z has that form.
    """
    A = np.array(C, dtype=np.float64)
    k, p = A.shape
    pref = np.ones(p, dtype=bool) if prefer is None else np.asarray(prefer, dtype=bool)
    active = np.ones(k, dtype=bool)
    pivots: list[tuple[int, int]] = []
    while True:
        rows = np.flatnonzero(active)
        if rows.size == 0:
            break
        sub = A[rows]
        nz = np.abs(sub) > 0.5
        nnz = nz.sum(axis=1)
        active[rows[nnz == 0]] = False
        unit = np.abs(np.abs(sub) - 1.0) < 1e-9
        r = c = -1
        for mask in (unit & pref[None, :], unit):
            has = mask.any(axis=1)
            if has.any():
                cand = np.flatnonzero(has)
                i = cand[np.argmin(nnz[cand])]
                r, c = int(rows[i]), int(np.flatnonzero(mask[i])[0])
                break
        if r < 0:
            break
        A[r] /= A[r, c]
        others = np.flatnonzero(np.abs(A[:, c]) > 0.5)
        others = others[others != r]
        A[others] -= A[others, c][:, None] * A[r][None, :]
        pivots.append((r, c))
        active[r] = False
    pcols = np.array([c for _, c in pivots], dtype=np.int64)
    free = np.setdiff1d(np.arange(p), pcols)
    N = np.zeros((p, free.size))
    N[free, np.arange(free.size)] = 1.0
    for r, c in pivots:
        N[c] = -A[r, free]
    left = np.flatnonzero(active)
    if left.size:
        K = _integer_kernel(np.round(A[left][:, free]).astype(np.int64))
        N = N @ K
    return np.round(N)


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


#: Integer columns solved for at once when building the Schur complement (memory bound).
SCHUR_CHUNK = 64
#: Entries of a column of K Z below this fraction of its largest are dropped (local search).
RESPONSE_RTOL = 1e-2
#: Integer unknowns tried per local-search sweep: those responding most at flipped faces.
SEARCH_CANDIDATES = 24


class MixedIntegerSolver:
    """Minimize ½ yᵀH y − gᵀy with y[integer] ∈ ℤ, for several right-hand sides g.

    The real unknowns are eliminated once: one sparse factorization of their block H_rr
    and, in chunks of :data:`SCHUR_CHUNK` columns, the solves Z = H_rr⁻¹ H_ri that give the
    dense Schur complement S = H_ii − H_riᵀ Z of the k integer unknowns. Z itself is not
    kept (memory O(nnz(factor) + k²)); the real unknowns of a given w cost one more solve.
    With K given (the fit matrix, H = KᵀK), the responses K_i − K_r Z of the per-face
    Jacobians to each integer unknown are kept sparse for :meth:`local_search`.

    Parameters
    ----------
    H : sparse (p, p)
        Symmetric positive definite.
    integer : int64 (k,)
        Unknowns to round.
    K : sparse (4m, p), optional
        Fit matrix (rows u_x, u_y, v_x, v_y per face); enables :meth:`local_search`.
    """

    def __init__(self, H: sp.csr_array, integer: np.ndarray, K: sp.csr_array | None = None):
        H = sp.csr_array(H)
        p = H.shape[0]
        self.p = p
        self.integer = np.asarray(integer, dtype=np.int64)
        self.real_idx = np.setdiff1d(np.arange(p), self.integer)
        Hr = H[self.real_idx]
        self.Hri = sp.csc_array(Hr[:, self.integer])
        self.fac = factor_spd(Hr[:, self.real_idx])
        k = self.integer.size
        S = H[self.integer][:, self.integer].toarray()
        response = []
        Ki: sp.csc_array | None = None
        Kr: sp.csc_array | None = None
        if K is not None:
            K = sp.csc_array(K)
            Ki, Kr = K[:, self.integer], K[:, self.real_idx]
        for lo in range(0, k, SCHUR_CHUNK):  # a few chunks of integer columns
            cols = np.arange(lo, min(lo + SCHUR_CHUNK, k))
            Zc = self.fac.solve(self.Hri[:, cols].toarray())
            S[:, cols] -= self.Hri.T @ Zc
            if Ki is not None and Kr is not None:
                R = Ki[:, cols].toarray() - Kr @ Zc
                R[np.abs(R) < RESPONSE_RTOL * np.abs(R).max(axis=0, keepdims=True)] = 0.0
                response.append(sp.csc_array(R))
        self.S = 0.5 * (S + S.T)
        self.response = sp.hstack(response).tocsc() if response else None

    def _reduced(self, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        yr0 = self.fac.solve(g[self.real_idx])
        return yr0, g[self.integer] - self.Hri.T @ yr0

    def _assemble(self, yr0: np.ndarray, w: np.ndarray) -> np.ndarray:
        y = np.empty(self.p)
        y[self.integer] = w
        y[self.real_idx] = yr0 - (self.fac.solve(self.Hri @ w) if w.size else 0.0)
        return y

    def real(self, g: np.ndarray) -> np.ndarray:
        """The real minimizer (no rounding), float64 (p,)."""
        yr0, r = self._reduced(g)
        w = np.linalg.solve(self.S, r) if self.integer.size else np.zeros(0)
        return self._assemble(yr0, w)

    def local_search(
        self,
        g: np.ndarray,
        y: np.ndarray,
        K: sp.csr_array,
        sweeps: int = 30,
    ) -> np.ndarray:
        """Move single integer unknowns by ±1 while that lowers the number of flipped faces.

        K (4m, p) maps y to √A_t (∇u, ∇v) per face (rows u_x, u_y, v_x, v_y); a face is
        flipped when that Jacobian has det ≤ 0. A move of w_i re-solves the real unknowns
        exactly, so its effect on K y is the fixed sparse column ``response[:, i]``: each
        candidate costs an update of the faces it touches. Per sweep the best move is
        taken (fewest flips, then lowest energy ½ wᵀS w − rᵀw); stops at zero flips or
        when no move helps. Needs the solver built with K.
        """
        if self.response is None:
            raise ValueError("local_search needs a MixedIntegerSolver built with K")
        yr0, r = self._reduced(g)
        w = y[self.integer].copy()
        fit = (K @ y).reshape(-1, 4)
        R = self.response

        def det(f):
            return f[:, 0] * f[:, 3] - f[:, 1] * f[:, 2]

        flipped = ~(det(fit) > 0)
        best = int(flipped.sum())
        cols = [
            (R.indices[R.indptr[i] : R.indptr[i + 1]], R.data[R.indptr[i] : R.indptr[i + 1]])
            for i in range(R.shape[1])
        ]
        for _ in range(sweeps):  # a few sweeps over a few candidate unknowns
            if best == 0:
                break
            bad_rows = np.flatnonzero(np.repeat(flipped, 4))
            strength = np.abs(R[bad_rows]).max(axis=0).toarray().ravel()
            cand = np.argsort(-strength, kind="stable")[:SEARCH_CANDIDATES]
            choice = None
            for i in cand[strength[cand] > 0]:
                rows, vals = cols[i]
                faces = np.unique(rows // 4)
                before = int(flipped[faces].sum())
                slots = np.searchsorted((faces[:, None] * 4 + np.arange(4)).ravel(), rows)
                for step in (-1.0, 1.0):
                    local = fit[faces].copy().ravel()
                    local[slots] += step * vals
                    after = int(np.count_nonzero(~(det(local.reshape(-1, 4)) > 0)))
                    score = best - before + after
                    de = step * (self.S[i] @ w - r[i]) + 0.5 * self.S[i, i]
                    if choice is None or (score, de) < (choice[0], choice[3]):
                        choice = (score, i, step, de)
            if choice is None or choice[0] >= best:
                break
            best, i, step, _ = choice
            w[i] += step
            rows, vals = cols[i]
            fit.ravel()[rows] += step * vals
            flipped = ~(det(fit) > 0)
        return self._assemble(yr0, w)

    def rounded(self, g: np.ndarray, batch: float = 0.05) -> np.ndarray:
        """Greedy rounding (Bommes et al. 2009, §5) in batches: repeatedly fix the unknowns
        closest to an integer (a ``batch`` fraction of those left, at least one) and
        re-solve the others; ``batch=1`` is direct rounding. Returns y (p,), y[integer] ∈ ℤ.
        """
        yr0, r = self._reduced(g)
        S = self.S
        k = self.integer.size
        values = np.linalg.solve(S, r) if k else np.zeros(0)
        fixed = np.zeros(k, dtype=bool)
        while not fixed.all():
            left = np.flatnonzero(~fixed)
            dist = np.abs(values[left] - np.round(values[left]))
            count = max(1, int(np.ceil(batch * left.size)))
            pick = left[np.argsort(dist, kind="stable")[:count]]
            pick = np.union1d(pick, left[dist < 1e-6])
            values[pick] = np.round(values[pick])
            fixed[pick] = True
            left = np.flatnonzero(~fixed)
            if left.size:
                done = np.flatnonzero(fixed)
                rhs = r[left] - S[np.ix_(left, done)] @ values[done]
                values[left] = np.linalg.solve(S[np.ix_(left, left)], rhs)
        return self._assemble(yr0, values)
