r"""The Chebyshev series of :math:`e^{tA}B` for a :math:`W`-skew A (``method="chebyshev"``
of :func:`fvf.numerics.expm.expm_action`).

For a :math:`W`-skew :math:`A` whose norm is at most :math:`R`
(:func:`~fvf.numerics.expm_skew.skew_bound`), the Jacobi–Anger expansion

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
"""

from __future__ import annotations

import math

import numpy as np

from .expm_inputs import BASIS_MEMORY, CountedOperator, ExpmJob, weighted_norms

__all__ = ["chebyshev_degree", "run_chebyshev", "SERIES_SAFETY"]

#: The series' a-priori bound aims at SERIES_SAFETY · tol (each decade costs ~2 terms).
SERIES_SAFETY = 1e-2


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


def _series_tol(tol: float, w: np.ndarray | None, B2: np.ndarray, maxnorm: bool) -> np.ndarray:
    """Per-column tolerance on the W-norm of the truncation error that meets ``tol``
    relative to the column's W-norm and, with ``maxnorm``, to its max norm
    (max|x| ≤ ‖x‖_W / √min w)."""
    target = SERIES_SAFETY * tol * np.ones(B2.shape[1])
    if maxnorm and B2.shape[0]:
        wmin = 1.0 if w is None else float(w.min())
        ratio = np.abs(B2).max(axis=0) * math.sqrt(wmin) / np.maximum(weighted_norms(B2, w), 1e-300)
        target *= np.minimum(1.0, ratio)
    return target


def run_chebyshev(op: CountedOperator, job: ExpmJob, R: float) -> bool:
    r"""The Jacobi–Anger series of all times at once; False when it must give way.

    Skew A: the degree K is a priori (:func:`chebyshev_degree` at the per-column target
    of :func:`_series_tol`). Otherwise the series runs to the a-priori degree of a skew
    operator of the same R and checks a posteriori that its last terms fall below the
    target (their W-norms times 2|J_k|); terms growing past 1e3 ‖B‖ abandon it.

    Parameters
    ----------
    op : CountedOperator
        The products with A.
    job : ExpmJob
        The call; ``job.out`` and ``job.info`` are filled.
    R : float
        Bound of the W-norm of A's skew part (:func:`~fvf.numerics.expm_skew.skew_bound`).
    """
    B2, times, out, info, w, skew = job.B2, job.times, job.out, job.info, job.w, job.skew
    info["method"] = "chebyshev"
    n, p = B2.shape
    taus = R * times
    target = _series_tol(job.tol, w, B2, job.maxnorm)
    K = chebyshev_degree(float(np.abs(taus).max()), float(target.min()))
    extra = 0 if skew else 8 + K // 4  # room for the a-posteriori stop
    coef = _bessel_table(taus, K + extra)  # (T, K+extra+1)
    coef[:, 1:] *= 2.0
    flat = out.reshape(times.size, n * p)
    flat[:] = coef[:, :1] * B2.reshape(1, -1)
    bnorm = np.maximum(weighted_norms(B2, w), 1e-300)
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
            size = weighted_norms(cur, w) / bnorm
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
