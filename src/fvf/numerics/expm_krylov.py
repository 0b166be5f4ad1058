r"""Krylov time stepping for :math:`e^{tA}B` (``method="krylov"`` of
:func:`fvf.numerics.expm.expm_action`), and small dense exponentials.

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
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla

from ..errors import FlowOverflowError
from .expm_inputs import BASIS_MEMORY, CountedOperator, ExpmJob, signed_sweeps, weighted_norms

__all__ = ["dense_expm_action", "run_krylov", "M_MAX", "IOM_WINDOW", "SAFETY", "EIG_COND_MAX"]

#: Largest Krylov basis per step (fewer when :data:`~fvf.numerics.expm_inputs.BASIS_MEMORY`
#: would be exceeded).
M_MAX = 100
#: Vectors each new Krylov vector is orthogonalized against (operators that are not skew).
IOM_WINDOW = 4
#: The Krylov error estimates aim at SAFETY · tol.
SAFETY = 0.05
#: Quadrature points of the error integral over a Krylov step.
_GRID = 32


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
        beta = weighted_norms(Y, self.w)
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
        h = weighted_norms(Wj, self.w)
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


def run_krylov(op: CountedOperator, job: ExpmJob) -> None:
    """Adaptive Krylov time stepping: one sweep per sign of t over the sorted |t|.

    Parameters
    ----------
    op : CountedOperator
        The products with A.
    job : ExpmJob
        The call; ``job.out`` and ``job.info`` are filled.
    """
    B2, times, out, info, w, skew = job.B2, job.times, job.out, job.info, job.w, job.skew
    info["method"] = "lanczos" if skew else "iom"
    n, p = B2.shape
    m_want = M_MAX if job.m_max is None else int(job.m_max)
    m_want = max(1, min(m_want, n))
    group = max(1, min(p, int(BASIS_MEMORY // (8 * n * (m_want + 1)))))
    m_cap = max(1, min(m_want, int(BASIS_MEMORY // (8 * n * group)) - 1))
    out[times == 0] = B2
    plus, minus = times[times > 0], -times[times < 0]
    total = (plus.max() if plus.size else 0.0) + (minus.max() if minus.size else 0.0)
    done = 0.0
    for sign, order in signed_sweeps(times):
        taus = sign * times[order]
        signed = _Signed(op, sign)
        for c0 in range(0, p, group):
            cols = slice(c0, min(p, c0 + group))
            basis = _Basis(n, cols.stop - cols.start, m_cap, w, skew)
            Y, now, T, k = B2[:, cols], 0.0, float(taus[-1]), 0
            while k < taus.size:
                s, smalls, beta, est = _krylov_step(
                    signed, basis, Y, T - now, T, job.tol, job.maxnorm, m_cap
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
                if job.progress is not None and c0 == 0:
                    done += end - now
                    job.progress(min(done / total, 1.0))
                now, k = end, inside


class _Signed:
    """sign · A as an operator, counting into the caller's counter."""

    def __init__(self, op: CountedOperator, sign: float) -> None:
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
