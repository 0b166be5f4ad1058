"""Fused sparse kernels for the recurrences of :mod:`fvf.numerics.expm` (optional: numba).

scipy's CSR kernel only does y += A x, so every term of a three-term recurrence pays one
or two more passes over its vectors (a scaled copy, an axpy into the output, a norm), each
1/6–1/4 of a product on large meshes. With numba installed (``pip install 'fvf[fast]'``)
these kernels do the product and that extra work in the same pass over the rows:

- :func:`term_run`: y ← y + A x, then out ← out + c y, for a run of terms with x and y
  (the two rows of one array) swapping roles: the Chebyshev terms for one time, with
  ‖y‖_W and max|y| of the last when asked;
- :func:`term_chain`: y_{k+1} ← y_{k−1} + A y_k for a run of terms kept side by side (the
  Chebyshev terms for several times);
- :func:`term_combine`: y ← diag(c) prev + A x, with the W-norms of its p columns and their
  W-inner products with x and prev when asked (a Lanczos vector of a block and its skew
  check); :func:`lanczos_run`: a run of Lanczos vectors of one column with their norms
  and skew checks, in one call;
- :func:`col_norms`: W- and max-norms of the columns of a stack of blocks in one pass;
- :func:`power_bound`: the Collatz–Wielandt steps of the bound R in one call, both
  products with |A| of a step from one pass; :func:`abs_stats`: ‖A‖_∞, max|a_ii|,
  max|a_ij| in one pass;
- :func:`iom_run`: a run of vectors of the general (incomplete orthogonalization) Krylov
  method for one column, the inner products taken in the product's pass; and for its
  error checks :func:`hess_mu` (the logarithmic norm of the small Hessenberg H_m, by
  bisection on banded Cholesky factors), :func:`hess_profile` and :func:`hess_expv`
  (exp(s H_m) e_1 on the check's grid and off it, by Taylor's series on the band);
- :func:`bessel_rows`: Miller's recurrence for the series' coefficients, and
  :func:`chebyshev_degree` from it;
  :func:`skew_chebyshev_basis`: the same series' vectors for the small skew tridiagonal
  matrices of Lanczos, and :func:`skew_series`: their exponentials and the error
  integrals of Lanczos' step control (instead of an SVD each), each in one call.

Vectors are flat C-contiguous float64 arrays of n·p entries, column q of row i at i·p + q.
The index arrays are unsigned views of the matrix's own (see :func:`csr_views`): an
unsigned index needs no negative-index branch, which is what makes a numba CSR loop as
fast as scipy's C++ one (20–30 % slower with signed indices, measured at 6k–1.5M faces).

Set ``FVF_NUMBA=0`` in the environment to use the numpy/scipy path even where numba is
installed; :data:`ENABLED` says which is in use.
"""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Callable

import numpy as np

#: True when the fused kernels are compiled with numba and used by :mod:`fvf.numerics.expm`.
#: numba itself is imported, and each kernel compiled (or loaded from numba's disk cache),
#: on first use: ``import fvf`` does not pay numba's 0.3 s import.
ENABLED = os.environ.get("FVF_NUMBA", "1").strip().lower() not in ("0", "false", "no", "off")
ENABLED = ENABLED and importlib.util.find_spec("numba") is not None

_COMPILED: dict[Callable, Callable] = {}


#: Functions that kernels call: compiled first and bound to their module names, so that
#: the kernels calling them compile against (and cache with) the compiled versions.
_HELPERS = (
    "_block_rows",
    "_block_width",
    "_miller_start",
    "_series_top",
    "_miller",
    "_power_step",
    "_power_stops",
    "_tridiag_top",
    "_lanczos_run",
    "_cheb_degree",
    "_skew_chebyshev_basis",
    "_skew_series",
    "_band_norm1",
    "_hess_expv",
    "_hess_taylor",
    "_hess_below",
    "_hess_mu",
)


def _jit(fn: Callable) -> Callable:
    """The numba-compiled ``fn`` (compiled, or loaded from the disk cache, once)."""
    if hasattr(fn, "py_func"):  # a helper, bound to its compiled form already
        return fn
    out = _COMPILED.get(fn)
    if out is None:
        from numba import njit  # pragma: no cover - depends on the environment

        names = globals()
        for name in _HELPERS:
            if not hasattr(names[name], "py_func"):  # not yet a numba dispatcher
                names[name] = njit(cache=True, nogil=True)(names[name])
        helper = fn.__name__ in _HELPERS
        out = names[fn.__name__] if helper else njit(cache=True, nogil=True)(fn)
        _COMPILED[fn] = out
    return out


__all__ = [
    "ENABLED",
    "csr_views",
    "term_run",
    "term_chain",
    "term_combine",
    "lanczos_run",
    "lanczos_step",
    "abs_stats",
    "col_norms",
    "power_bound",
    "bessel_rows",
    "chebyshev_degree",
    "skew_chebyshev_basis",
    "skew_series",
    "iom_run",
    "hess_mu",
    "hess_profile",
    "hess_expv",
]


_NO_W, _NO_NORMS = np.zeros(1), np.zeros((2, 1))  # (not read)
_EMPTY = np.zeros(0)

#: An incomplete-orthogonalization vector takes its W-norm as ‖y‖² − Σ h_i² (the window
#: is orthonormal) when that is at least this fraction of ‖y‖²: the difference's own
#: rounding is then at most ~100 ε of β², and subtracting and scaling are one pass (else:
#: the norm of the subtracted vector, and a third pass). fvf.numerics.expm._iom_vector follows
#: the same rule.
IOM_PYTHAGORAS = 1e-2
#: ... for windows of at most 4 vectors. The next vector's product pass also takes the
#: W-norm² of the vector it multiplies, which is rescaled (with β and the inner products)
#: if that is more than IOM_UNIT from 1: the next norms assume a unit window, an error e
#: in it comes back as e·Σh_i²/β² (up to 99×), and for −L (Σh_i²/β² ≈ 10) the norms
#: reached 46 after 60 vectors without this check.
IOM_UNIT = 1e-13


def csr_views(
    indptr: np.ndarray, indices: np.ndarray, data: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The ``csr`` argument of the kernels for a CSR matrix's arrays (no copy), or None.

    Parameters
    ----------
    indptr, indices : int32 or int64 (n + 1,), (nnz,)
        Row pointers and column indices (non-negative, as scipy guarantees).
    data : float64 (nnz,)

    Returns
    -------
    (uint32 or uint64 (n + 1,), uint32 or uint64 (nnz,), float64 (nnz,)): unsigned views of
    the index arrays and ``data`` itself; None when the kernels are disabled or the arrays
    are not C-contiguous signed 32- or 64-bit integers and float64 values.
    """
    if not ENABLED or data.dtype != np.float64 or not data.flags.c_contiguous:
        return None
    out = []
    for a in (indptr, indices):
        if a.dtype not in (np.int32, np.int64) or not a.flags.c_contiguous:
            return None
        out.append(a.view(np.uint32 if a.dtype == np.int32 else np.uint64))
    return out[0], out[1], data


def _term_run(indptr, indices, data, Y, cur, out, coef, w, s2, norms):  # pragma: no cover
    # one column: len(coef) terms, term t does dst ← dst + A src, out ← out + coef[t] dst
    # with src = Y[(cur + t) % 2], dst = Y[(cur + t + 1) % 2]; norms (the last term only):
    # s2[0, 0] = Σ w dst², s2[1, 0] = max |dst|. Measured at 6k faces: rows of one array
    # beat two arguments swapped through a tuple; a test inside the row loop, or the
    # block case in the same function, made every term 10–15 % slower.
    n = indptr.shape[0] - 1
    last = coef.shape[0] - 1
    for t in range(last + 1):
        src = Y[(cur + t) % 2]
        dst = Y[(cur + t + 1) % 2]
        c = coef[t]
        if norms and t == last:
            a0 = 0.0
            a1 = 0.0
            for i in range(n):
                s = dst[i]
                for k in range(indptr[i], indptr[i + 1]):
                    s += data[k] * src[indices[k]]
                dst[i] = s
                out[i] += c * s
                a0 += w[i] * s * s
                a1 = max(a1, abs(s))
            s2[0, 0] = a0
            s2[1, 0] = a1
        else:
            for i in range(n):
                s = dst[i]
                for k in range(indptr[i], indptr[i + 1]):
                    s += data[k] * src[indices[k]]
                dst[i] = s
                out[i] += c * s


def _block_rows(  # pragma: no cover - jitted (called by kernels)
    indptr, indices, data, src, init, dst, out, c, p, q0, width, add
):
    # columns q0 … q0 + width − 1 (width 1, 2, 4 or 8) of p interleaved ones:
    # dst ← init + A src, and if add, out ← out + c·dst, in one pass over A's rows.
    # The sums are scalars, and the index arithmetic is unsigned (numba checks signed
    # indices for wraparound): a loop over the columns inside the row loop, with signed
    # indices, took 1.7 products a column-term for p = 2 and 0.9 for p = 4 at 6k faces
    n = indptr.shape[0] - 1
    pu = np.uint64(p)
    one, two, three = np.uint64(1), np.uint64(2), np.uint64(3)
    if width == 8:
        four, five, six, seven = np.uint64(4), np.uint64(5), np.uint64(6), np.uint64(7)
        for i in range(n):
            b = np.uint64(i) * pu + np.uint64(q0)
            a0 = init[b]
            a1 = init[b + one]
            a2 = init[b + two]
            a3 = init[b + three]
            a4 = init[b + four]
            a5 = init[b + five]
            a6 = init[b + six]
            a7 = init[b + seven]
            for k in range(indptr[i], indptr[i + 1]):
                a = data[k]
                jb = np.uint64(indices[k]) * pu + np.uint64(q0)
                a0 += a * src[jb]
                a1 += a * src[jb + one]
                a2 += a * src[jb + two]
                a3 += a * src[jb + three]
                a4 += a * src[jb + four]
                a5 += a * src[jb + five]
                a6 += a * src[jb + six]
                a7 += a * src[jb + seven]
            dst[b] = a0
            dst[b + one] = a1
            dst[b + two] = a2
            dst[b + three] = a3
            dst[b + four] = a4
            dst[b + five] = a5
            dst[b + six] = a6
            dst[b + seven] = a7
            if add:
                out[b] += c * a0
                out[b + one] += c * a1
                out[b + two] += c * a2
                out[b + three] += c * a3
                out[b + four] += c * a4
                out[b + five] += c * a5
                out[b + six] += c * a6
                out[b + seven] += c * a7
    elif width == 4:
        for i in range(n):
            b = np.uint64(i) * pu + np.uint64(q0)
            a0 = init[b]
            a1 = init[b + one]
            a2 = init[b + two]
            a3 = init[b + three]
            for k in range(indptr[i], indptr[i + 1]):
                a = data[k]
                jb = np.uint64(indices[k]) * pu + np.uint64(q0)
                a0 += a * src[jb]
                a1 += a * src[jb + one]
                a2 += a * src[jb + two]
                a3 += a * src[jb + three]
            dst[b] = a0
            dst[b + one] = a1
            dst[b + two] = a2
            dst[b + three] = a3
            if add:
                out[b] += c * a0
                out[b + one] += c * a1
                out[b + two] += c * a2
                out[b + three] += c * a3
    elif width == 2:
        for i in range(n):
            b = np.uint64(i) * pu + np.uint64(q0)
            a0 = init[b]
            a1 = init[b + one]
            for k in range(indptr[i], indptr[i + 1]):
                a = data[k]
                jb = np.uint64(indices[k]) * pu + np.uint64(q0)
                a0 += a * src[jb]
                a1 += a * src[jb + one]
            dst[b] = a0
            dst[b + one] = a1
            if add:
                out[b] += c * a0
                out[b + one] += c * a1
    else:
        for i in range(n):
            b = np.uint64(i) * pu + np.uint64(q0)
            a0 = init[b]
            for k in range(indptr[i], indptr[i + 1]):
                a0 += data[k] * src[np.uint64(indices[k]) * pu + np.uint64(q0)]
            dst[b] = a0
            if add:
                out[b] += c * a0


def _block_width(p, q0):  # pragma: no cover - jitted (called by kernels)
    # the columns _block_rows takes from q0 on: 8, 4, 2 or 1
    r = p - q0
    return 8 if r >= 8 else (4 if r >= 4 else (2 if r >= 2 else 1))


def _term_run_block(indptr, indices, data, Y, cur, out, coef, p):  # pragma: no cover
    # _term_run for p > 1 interleaved columns (no norms): up to 8 columns 8, 4, 2 or 1 at a
    # time; more in one loop over the columns (passes of 8 over rows of 12–24 columns
    # took 1.2–1.8× its time, a review found)
    n = indptr.shape[0] - 1
    for t in range(coef.shape[0]):
        src = Y[(cur + t) % 2]
        dst = Y[(cur + t + 1) % 2]
        c = coef[t]
        if p > 8:
            for i in range(n):
                b = i * p
                for k in range(indptr[i], indptr[i + 1]):
                    a = data[k]
                    jb = indices[k] * p
                    for q in range(p):
                        dst[b + q] += a * src[jb + q]
                for q in range(p):
                    out[b + q] += c * dst[b + q]
            continue
        q0 = 0
        while q0 < p:
            width = _block_width(p, q0)
            _block_rows(indptr, indices, data, src, dst, dst, out, c, p, q0, width, True)
            q0 += width


def _term_chain(indptr, indices, data, Y, f0, count):  # pragma: no cover - jitted
    # one column: Y[f] ← Y[f − 2] + A Y[f − 1] for f = f0 … f0 + count − 1
    n = indptr.shape[0] - 1
    for f in range(f0, f0 + count):
        src = Y[f - 1]
        prev = Y[f - 2]
        dst = Y[f]
        for i in range(n):
            s = prev[i]
            for k in range(indptr[i], indptr[i + 1]):
                s += data[k] * src[indices[k]]
            dst[i] = s


def _term_chain_block(indptr, indices, data, Y, f0, count, p):  # pragma: no cover
    # _term_chain for p > 1 interleaved columns (as _term_run_block)
    n = indptr.shape[0] - 1
    for f in range(f0, f0 + count):
        src, prev, dst = Y[f - 1], Y[f - 2], Y[f]
        if p > 8:
            for i in range(n):
                b = i * p
                for q in range(p):
                    dst[b + q] = prev[b + q]
                for k in range(indptr[i], indptr[i + 1]):
                    a = data[k]
                    jb = indices[k] * p
                    for q in range(p):
                        dst[b + q] += a * src[jb + q]
            continue
        q0 = 0
        while q0 < p:
            width = _block_width(p, q0)
            _block_rows(indptr, indices, data, src, prev, dst, dst, 0.0, p, q0, width, False)
            q0 += width


def _term_combine(indptr, indices, data, x, prev, c, y, w, s2, p, norms):  # pragma: no cover
    # norms: 0 none, 1 Σ w y², 2 also Σ w y x and Σ w y prev (rows of s2); p columns
    # interleaved (Lanczos on a block; one column runs in _lanczos_run)
    n = indptr.shape[0] - 1
    s2[:] = 0.0
    for i in range(n):
        b = i * p
        for q in range(p):
            y[b + q] = c[q] * prev[b + q]
        for k in range(indptr[i], indptr[i + 1]):
            a = data[k]
            jb = indices[k] * p
            for q in range(p):
                y[b + q] += a * x[jb + q]
        if norms:
            wi = w[i]
            for q in range(p):
                ws = wi * y[b + q]
                s2[0, q] += ws * y[b + q]
                if norms == 2:
                    s2[1, q] += ws * x[b + q]
                    s2[2, q] += ws * prev[b + q]


def _lanczos_run(  # pragma: no cover - jitted
    indptr, indices, data, V, w, nu, beta, j0, j1, bsum, limit, res
):
    # Lanczos vectors j0 … j1 − 1 of one column (see lanczos_run); res[:6] = status,
    # j reached, Σβ, and for status 2: diag, off, scale
    n = indptr.shape[0] - 1
    status = 0
    j = j0
    while j < j1:
        c = 0.0
        if j > 0 and nu[j - 1] > 0:
            c = beta[j - 1] * nu[j] / nu[j - 1]
        x = V[j]
        prev = V[j - 1] if j > 0 else V[j]  # (c = 0 for j = 0)
        vn = V[j + 1]
        check = j < 3 or j % 8 == 7
        s0 = 0.0
        d1 = 0.0
        d2 = 0.0
        if check:  # (written apart: a test in the row loop slows every vector)
            for i in range(n):
                a = c * prev[i]
                for k in range(indptr[i], indptr[i + 1]):
                    a += data[k] * x[indices[k]]
                vn[i] = a
                wa = w[i] * a
                s0 += wa * a
                d1 += wa * x[i]
                d2 += wa * prev[i]
        else:
            for i in range(n):
                a = c * prev[i]
                for k in range(indptr[i], indptr[i + 1]):
                    a += data[k] * x[indices[k]]
                vn[i] = a
                s0 += w[i] * a * a
        nz = np.sqrt(s0)
        if not np.isfinite(nz):
            status = 1
            break
        b = nz / nu[j] if nu[j] > 0 else 0.0
        if check:
            diag = abs(d1) / (nu[j] * nu[j]) if nu[j] > 0 else 0.0
            off = 0.0
            if j > 0 and nu[j] * nu[j - 1] > 0:
                off = abs(d2) / (nu[j] * nu[j - 1])
            scale = max(b, bsum / max(j, 1))
            if max(diag, off) > max(limit, 1e-12 * scale):
                res[3] = diag
                res[4] = off
                res[5] = scale
                status = 2
                break
        if nz > 1e150 or (nz > 0 and nz < 1e-150):  # keep the vectors in range
            inv = 1.0 / nz
            for i in range(n):
                vn[i] *= inv
            nz = 1.0
        beta[j] = b
        nu[j + 1] = nz
        bsum += b
        j += 1
        if b == 0.0:
            status = 3
            break
    res[0] = status
    res[1] = j
    res[2] = bsum


def _abs_stats(indptr, indices, data):  # pragma: no cover - jitted
    # (each row's maximum compared once, the diagonal without a branch: 0.72× and 0.89×
    # the time of one max over all entries at 10k and 94k faces, best of 400 alternating
    # calls; the medians were equal)
    n = indptr.shape[0] - 1
    top = 0.0  # max row sum
    total = 0.0  # Σ|a|: inf or NaN when an entry is
    dmax = 0.0  # max |a_ii| (duplicates summed)
    amax = 0.0  # max |a_ij|
    for i in range(n):
        s = 0.0
        di = 0.0
        rm = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            a = abs(data[k])
            s += a
            rm = a if a > rm else rm
            di += a if indices[k] == i else 0.0
        top = s if s > top else top
        dmax = di if di > dmax else dmax
        amax = rm if rm > amax else amax
        total += s
    bad = 0.0 * total  # 0, or NaN when some entry is not finite
    return top + bad, dmax + bad, amax + bad


def _col_norms(X, w, p, maxnorm, out):  # pragma: no cover - jitted
    # out[0, r, q] = sqrt(Σ_i w_i X[r, i·p + q]²) (w_i = 1 if w is empty), out[1, r, q] =
    # max_i |X[r, i·p + q]| (1 if not maxnorm); one pass over each row of X.
    # One column: four partial sums and maxima (one accumulator chains every element
    # through the adder's latency: 5 ns an element, 4x numpy's squares and GEMV). Several:
    # the row's p columns side by side (a pass per column reads every cache line p times:
    # 8 columns at 1.5M faces were 2x slower than numpy).
    rows = X.shape[0]
    n = X.shape[1] // p if p else 0
    weighted = w.shape[0] > 0
    if p == 1:
        n4 = n - n % 4
        for r in range(rows):
            x = X[r]
            s0 = s1 = s2 = s3 = 0.0
            m0 = m1 = m2 = m3 = 0.0
            for i in range(0, n4, 4):
                a0 = x[i]
                a1 = x[i + 1]
                a2 = x[i + 2]
                a3 = x[i + 3]
                if weighted:
                    s0 += w[i] * a0 * a0
                    s1 += w[i + 1] * a1 * a1
                    s2 += w[i + 2] * a2 * a2
                    s3 += w[i + 3] * a3 * a3
                else:
                    s0 += a0 * a0
                    s1 += a1 * a1
                    s2 += a2 * a2
                    s3 += a3 * a3
                m0 = max(m0, abs(a0))
                m1 = max(m1, abs(a1))
                m2 = max(m2, abs(a2))
                m3 = max(m3, abs(a3))
            for i in range(n4, n):
                a0 = x[i]
                s0 += (w[i] if weighted else 1.0) * a0 * a0
                m0 = max(m0, abs(a0))
            out[0, r, 0] = np.sqrt((s0 + s1) + (s2 + s3))
            out[1, r, 0] = max(max(m0, m1), max(m2, m3)) if maxnorm else 1.0
        return
    sq = np.zeros(p)
    mx = np.zeros(p)
    for r in range(rows):
        x = X[r]
        sq[:] = 0.0
        mx[:] = 0.0
        for i in range(n):
            wi = w[i] if weighted else 1.0
            b = i * p
            for q in range(p):
                a = x[b + q]
                sq[q] += wi * a * a
                mx[q] = max(mx[q], abs(a))
        for q in range(p):
            out[0, r, q] = np.sqrt(sq[q])
            out[1, r, q] = mx[q] if maxnorm else 1.0


def _miller_start(x):  # pragma: no cover - jitted (called by kernels)
    # the order from which Miller's recurrence for J_k(x) starts: past the turning point
    # k ≈ x, where J_start < 1e-20 max|J| (as fvf.numerics.expm._bessel_row)
    return int(x + 12.0 * np.cbrt(x)) + 30


def _series_top(x):  # pragma: no cover - jitted (called by kernels)
    # fvf.numerics.expm._degree_top: an order beyond which 2 Σ_{k>m} |J_k(x)| is below any tol
    return int(x + 12 * x ** (1 / 3) + 60)


def _miller(x, start, tiny, buf):  # pragma: no cover - jitted (called by kernels)
    # J_k(x) = buf[k] · (returned factor) for k ≤ start, x ≥ 0: Miller's backward
    # recurrence f_{k−1} = (2k/x) f_k − f_{k+1} from f_start = 1e-200, rescaled by 1e-200
    # whenever it passes 1e200, normalized by f₀ + 2 Σ f_{2k} = 1. Below tiny a step would
    # overflow (2k/x · 1e-200): the leading terms J₀ = 1 − x²/4, J₁ = x/2, J₂ = x²/8 are
    # exact to round-off there.
    if x < tiny:
        for k in range(start + 1):
            buf[k] = 0.0
        buf[0] = 1.0 - 0.25 * x * x
        buf[1] = 0.5 * x
        buf[2] = 0.125 * x * x
        return 1.0
    inv = 2.0 / x
    f_next = 0.0
    f = 1e-200
    even = 0.0
    for k in range(start, 0, -1):
        buf[k] = f
        if k % 2 == 0:
            even += f
        f, f_next = k * inv * f - f_next, f
        if abs(f) > 1e200:
            f *= 1e-200
            f_next *= 1e-200
            even *= 1e-200
            for i in range(k, start + 1):
                buf[i] *= 1e-200
    buf[0] = f
    return 1.0 / (f + 2.0 * even)


def _bessel_rows(x, kmax, tiny, out):  # pragma: no cover - jitted
    # out[j, k] = J_k(x_j) for k ≤ min(kmax, s_j), 0 beyond (s_j = _miller_start(x_j))
    xm = 0.0
    for j in range(x.shape[0]):
        xm = max(xm, x[j])
    buf = np.empty(_miller_start(xm) + 1)
    for j in range(x.shape[0]):
        s = _miller_start(x[j])
        norm = _miller(x[j], s, tiny, buf)
        top = min(kmax, s)
        for k in range(top + 1):
            out[j, k] = buf[k] * norm
        for k in range(top + 1, kmax + 1):
            out[j, k] = 0.0


def _cheb_degree(tau, tol, top, tiny):  # pragma: no cover - jitted
    # fvf.numerics.expm._degree from the row J_k(τ), k ≤ top, in the same order of operations:
    # tail_i = 2 Σ_{k=⌊τ⌋+1+i}^{top} |J_k| summed from k = top down; the smallest i with
    # tail_i ≤ tol (tail_L = 0, L = top − ⌊τ⌋); returns ⌊τ⌋ + i
    start = _miller_start(tau)
    buf = np.empty(start + 1)
    norm = _miller(tau, start, tiny, buf)
    lo = int(tau)
    L = top - lo
    best = L
    acc = 0.0
    for i in range(L - 1, -1, -1):
        k = lo + 1 + i
        if k <= start:  # (beyond: zeros, as in the table)
            acc += abs(buf[k] * norm)
        if 2.0 * acc <= tol:
            best = i
        else:
            break
    return lo + best


def _skew_series(P, r, s, tiny, out, bl, E):  # pragma: no cover - jitted
    # out[c, g] = J₀(x) P[c, 0] + 2 Σ_{k≥1} J_k(x) P[c, k], x = r_c s_g (J_k(−x) =
    # (−1)ᵏ J_k(x)): exp(s_g H_c) e_1 when P[c, k] = P_k(H_c / r_c) e_1 (or entries of it).
    # If E has G columns: E[c, g] = ∫_0^{s_g} |bl_c out[c, σ, −1]| dσ by the cumulative
    # trapezoid rule on the uniform grid s (s_0 = 0).
    p, K1, mm = P.shape
    G = s.shape[0]
    xm = 0.0
    for c in range(p):
        for g in range(G):
            xm = max(xm, abs(r[c] * s[g]))
    buf = np.empty(_miller_start(xm) + 1)
    for c in range(p):
        for g in range(G):
            x = r[c] * s[g]
            ax = abs(x)
            start = _miller_start(ax)
            norm = _miller(ax, start, tiny, buf)
            flip = -1.0 if x < 0 else 1.0
            for i in range(mm):
                out[c, g, i] = buf[0] * norm * P[c, 0, i]
            f = 2.0 * norm
            for k in range(1, min(K1 - 1, start) + 1):
                f *= flip
                a = f * buf[k]
                for i in range(mm):
                    out[c, g, i] += a * P[c, k, i]
    if E.shape[1] == G:
        h = 0.5 * abs(s[1] - s[0]) if G > 1 else 0.0
        for c in range(p):
            E[c, 0] = 0.0
            for g in range(1, G):
                a0 = abs(bl[c] * out[c, g - 1, mm - 1])
                a1 = abs(bl[c] * out[c, g, mm - 1])
                E[c, g] = E[c, g - 1] + h * (a0 + a1)


def _skew_chebyshev_basis(beta, r, P):  # pragma: no cover - jitted
    # P[c, k] = P_k(H_c / r_c) e_1, P_0 = I, P_1 = H/r, P_{k+1} = 2 (H/r) P_k + P_{k−1},
    # H_c skew tridiagonal: (H x)_i = β_{i−1} x_{i−1} − β_i x_{i+1} (β = beta[:, c])
    p, K1, m = P.shape
    for c in range(p):
        inv = 1.0 / r[c]
        for k in range(K1):
            for i in range(m):
                P[c, k, i] = 0.0
        P[c, 0, 0] = 1.0
        for k in range(K1 - 1):
            for i in range(m):
                h = 0.0
                if i > 0:
                    h += beta[i - 1, c] * P[c, k, i - 1]
                if i < m - 1:
                    h -= beta[i, c] * P[c, k, i + 1]
                if k == 0:
                    P[c, 1, i] = inv * h
                else:
                    P[c, k + 1, i] = 2.0 * inv * h + P[c, k - 1, i]


def _lanczos_step(  # pragma: no cover - jitted
    indptr,
    indices,
    data,
    V,
    w,
    nu,
    beta,
    m_cap,
    tau,
    rate,
    limit,
    lead,
    gap,
    maxnorm,
    yscale,
    sign,
    unit,
    noise,
    tiny,
    res,
):
    # fvf.numerics.expm._lanczos_steps' loop for one column, from V[0] to the first passed error
    # check (see lanczos_step); returns the Chebyshev vectors of the last check
    m = 0
    bsum = 0.0
    products = 0
    next_check = -1
    last_m = -1
    last_x = 0.0
    G = unit.shape[0]
    s = np.empty(G)
    for g in range(G):
        s[g] = sign * (unit[g] * tau)
    r1 = np.empty(1)
    bl1 = np.empty(1)
    vals = np.empty((1, G, 1))
    E = np.empty((1, G))
    while True:
        if next_check < 0:  # the start of the decay at the mean β so far
            target = max(4, int(np.ceil(2.0 * (bsum / max(m, 1)) * tau + 3)))
        else:
            target = next_check
        target = min(max(target, m + 1), m_cap)
        _lanczos_run(indptr, indices, data, V, w, nu, beta, m, target, bsum, limit, res)
        status = int(res[0])
        j = int(res[1])
        bsum = res[2]
        products += j - m + (1 if status == 1 or status == 2 else 0)
        m = j
        res[6] = products
        res[1] = m
        if status == 1 or status == 2:
            return np.empty((1, 1, 1))
        if m < m_cap and beta[m - 1] != 0.0:
            if next_check < 0:
                rho_tau = 2.0 * (bsum / max(m, 1)) * tau
                if m < max(4.0, rho_tau + 3):
                    continue
                rt = abs(rho_tau)
                deg = _cheb_degree(rt, rate * tau, _series_top(rt), tiny)
                next_check = min(m_cap, deg - lead)
            if m < next_check:
                continue
        # the error check: exp(σ H_m) e_1 by the Chebyshev series in H_m / r
        r = 0.0
        for i in range(m - 1):
            r = max(r, beta[i])
        r = 2.0 * r if r > 0 else 1.0
        P = np.empty((1, _series_top(tau * r) + 1, m))
        r1[0] = r
        _skew_chebyshev_basis(beta[: m - 1].reshape((m - 1, 1)), r1, P)
        factor = 1.0
        if maxnorm:  # ≥ 1: never looser than the W-norm control
            amax = 0.0
            for i in range(V.shape[1]):
                amax = max(amax, abs(V[m, i]))
            factor = max(1.0, (amax / nu[m] if nu[m] > 0 else 0.0) * yscale)
        bl1[0] = beta[m - 1] * factor
        _skew_series(np.ascontiguousarray(P[:, :, m - 1 : m]), r1, s, tiny, vals, bl1, E)
        bmax = 0.0
        for i in range(m):
            bmax = max(bmax, beta[i])
        rate_m = max(rate, noise * 2.0 * bmax * factor)
        excess = E[0, G - 1] / (rate_m * tau)
        res[11] += 1
        res[7] = excess
        res[8] = E[0, G - 1]
        res[9] = rate_m
        res[10] = factor
        if excess <= 1.0:
            res[0] = 0
            return P
        if m == m_cap:
            res[0] = 4
            return P
        # the next check (fvf.numerics.expm._next_check)
        x = np.log(excess) if np.isfinite(excess) else 50.0
        if last_m >= 0 and last_x > x:
            step = int(x / (1.3 * ((last_x - x) / (m - last_m))))
        elif last_m < 0:  # the decay of the Chebyshev tail for the radius so far
            rt = abs(2.0 * (bsum / max(m, 1)) * tau)
            top = _series_top(rt)
            budget = rate_m * tau
            step = (
                gap
                + _cheb_degree(rt, budget / excess, top, tiny)
                - _cheb_degree(rt, budget, top, tiny)
            )
        else:
            step = int(x / 2.0)
        next_check = min(m_cap, m + max(gap, step, 1))
        last_m = m
        last_x = x


def _power_step(indptr, indices, data, s, inv_s, d, sym, md, g, dg):  # pragma: no cover
    # P = diag(s)|A|diag(1/s). sym: md = P d. Else md = ½(P d + Pᵀ d) − |diag A| d, with
    # Pᵀ d = diag(1/s)|A|ᵀ diag(s) d scattered from the rows into g (dg: |diag A|, summed
    # over duplicate entries). Returns (max md/d, max md).
    n = indptr.shape[0] - 1
    if not sym:
        g[:] = 0.0
        dg[:] = 0.0
    for i in range(n):
        acc = 0.0
        xi = d[i] * s[i]
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            a = abs(data[k])
            acc += a * (d[j] * inv_s[j])
            if not sym:
                g[j] += a * xi
                if j == i:
                    dg[i] += a
        md[i] = acc * s[i]
    ratio = 0.0
    top = 0.0
    for i in range(n):
        if not sym:
            md[i] = 0.5 * (md[i] + g[i] * inv_s[i]) - dg[i] * d[i]
        r = md[i] / d[i]
        if r > ratio:
            ratio = r
        if md[i] > top:
            top = md[i]
    return ratio, top


def _power_stops(  # pragma: no cover
    k, top, last, gain, span, per_step, best, floor, first_floor, handoff
):
    # whether the bound's power steps end after step k (fvf.numerics.expm._skew_bound, which
    # calls it too): no usable top, the last two steps saved fewer terms (span × the
    # bound's decrease) than they cost, the bound below floor (Gershgorin's, step 0: below
    # first_floor either), or span × it above handoff
    return (
        not top > 0
        or not np.isfinite(top)
        or (last + gain) * span < 2 * per_step
        or best < (floor if k > 0 else max(floor, first_floor))
        or best * span > handoff
    )


def _power_bound(  # pragma: no cover - jitted
    indptr, indices, data, s, inv_s, sym, steps, span, floor, first_floor, handoff, d, md, g, dg
):
    # fvf.numerics.expm._skew_bound's loop: Collatz–Wielandt steps from d while the last two
    # steps save more terms (span × the bound's decrease) than the products they cost,
    # and the bound is not below floor (the first bound: not below first_floor either);
    # at the first bound if span × it > handoff
    per_step = 1 if sym else 2
    best = np.inf
    products = 0
    gain = np.inf
    for k in range(steps + 1):
        bound, top = _power_step(indptr, indices, data, s, inv_s, d, sym, md, g, dg)
        products += per_step
        last, gain = gain, best - bound
        best = min(best, bound)
        if _power_stops(k, top, last, gain, span, per_step, best, floor, first_floor, handoff):
            break
        for i in range(d.shape[0]):
            d[i] = max(md[i] / top, 1e-300)  # positive, so the bound stays rigorous
    return best, products


def _tridiag_top(beta, m):  # pragma: no cover - jitted
    # largest eigenvalue of the symmetric tridiagonal (m + 1) × (m + 1) matrix with zero
    # diagonal and off-diagonal beta[:m], by bisection on Sturm counts (relative 1e-13)
    hi = 0.0
    for k in range(m):
        hi = max(hi, beta[k])
    hi *= 2.0
    lo = 0.0
    for _ in range(200):
        x = 0.5 * (lo + hi)
        if hi - lo <= 1e-13 * hi or x <= lo or x >= hi:
            break
        # eigenvalues below x: negative pivots of T − xI = LDLᵀ
        below = 0
        piv = -x
        if piv < 0.0:
            below += 1
        for k in range(m):
            if piv == 0.0:
                piv = -1e-300
            piv = -x - beta[k] * beta[k] / piv
            if piv < 0.0:
                below += 1
        if below == m + 1:
            hi = x
        else:
            lo = x
    return hi


def _skew_lanczos(indptr, indices, data, w, q, q_prev, r, z, beta, rtol):  # pragma: no cover
    # fvf.numerics.expm._skew_norm_estimate's loop: Lanczos on K = ½(A − W⁻¹AᵀW) from the W-unit
    # q; each step one pass over A's rows (A q gathered, Aᵀ W q scattered into z). Returns
    # (θ, steps, converged).
    n = indptr.shape[0] - 1
    beta_prev = 0.0
    older = 0.0  # θ two steps back
    old = 0.0  # θ one step back
    theta = 0.0
    for step in range(beta.shape[0]):
        for i in range(n):
            z[i] = 0.0
        for i in range(n):
            acc = 0.0
            xi = w[i] * q[i]
            for k in range(indptr[i], indptr[i + 1]):
                j = indices[k]
                acc += data[k] * q[j]
                z[j] += data[k] * xi
            r[i] = acc
        ss = 0.0
        for i in range(n):
            ri = 0.5 * (r[i] - z[i] / w[i]) + beta_prev * q_prev[i]
            r[i] = ri
            ss += w[i] * ri * ri
        b = np.sqrt(ss)
        beta[step] = b
        theta = _tridiag_top(beta, step + 1)
        if not np.isfinite(b) or b <= 1e-14 * max(theta, 1e-300):
            return theta, step + 1, np.isfinite(b)
        if step >= 3 and theta - older <= rtol * theta:
            return theta, step + 1, True
        older, old = old, theta
        for i in range(n):
            q_prev[i] = q[i]
            q[i] = r[i] / b
        beta_prev = b
    return theta, beta.shape[0], False


def _iom_run(indptr, indices, data, w, V, H, j0, j1, window, tau, res):  # pragma: no cover
    # fvf.numerics.expm._iom_steps' vectors V[j0 + 1 .. j1] (see iom_run); res: status, m, Σβ.
    # The inner products with the last (up to) four vectors are four scalars in the row
    # loop (an array there was stored and reloaded each row: 2.5 products a vector);
    # rows lo + i beyond the window read the zero row Z, which adds nothing.
    n = V.shape[1]
    Z = np.zeros(n if j0 < 3 or window < 4 else 1)  # (read only where fewer than 4 exist)
    hh = np.empty(max(window, 4))
    bsum = res[2]
    for j in range(j0, j1):
        lo = max(0, j + 1 - window)
        k = j + 1 - lo
        x = V[j]
        y = V[j + 1]
        if k <= 4:
            v0 = V[lo]
            v1 = V[lo + 1] if k > 1 else Z
            v2 = V[lo + 2] if k > 2 else Z
            v3 = V[lo + 3] if k > 3 else Z
            h0 = 0.0
            h1 = 0.0
            h2 = 0.0
            h3 = 0.0
            su = 0.0
            sx = 0.0
            for r in range(n):  # y = A x, ‖y‖²_W, h_i = ⟨y, V[lo + i]⟩_W and ‖x‖²_W
                acc = 0.0
                for idx in range(indptr[r], indptr[r + 1]):
                    acc += data[idx] * x[indices[idx]]
                y[r] = acc
                wa = w[r] * acc
                su += wa * acc
                h0 += v0[r] * wa
                h1 += v1[r] * wa
                h2 += v2[r] * wa
                h3 += v3[r] * wa
                sx += w[r] * x[r] * x[r]
            if j > 0 and window <= 4 and not abs(sx - 1.0) <= IOM_UNIT:
                # x = V[j] (the window's last) came off unit norm by Pythagoras' rounding:
                # rescale it, and y, the h_i, ‖y‖² and β_{j−1} with it (rounding would
                # compound otherwise)
                f = 1.0 / np.sqrt(sx)
                for r in range(n):
                    x[r] *= f
                    y[r] *= f
                h0 *= f if k > 1 else f * f
                h1 *= f if k > 2 else f * f
                h2 *= f if k > 3 else f * f
                h3 *= f * f
                su *= f * f
                H[j, j - 1] *= np.sqrt(sx)
            ss = su - (h0 * h0 + h1 * h1 + h2 * h2 + h3 * h3)  # (the window is orthonormal)
            scaled = window <= 4 and 0.0 < ss < np.inf and ss >= IOM_PYTHAGORAS * su
            if scaled:  # one pass: subtract and scale
                inv = 1.0 / np.sqrt(ss)
                for r in range(n):
                    y[r] = (y[r] - (h0 * v0[r] + h1 * v1[r] + h2 * v2[r] + h3 * v3[r])) * inv
            else:
                ss = 0.0
                for r in range(n):  # one classical Gram–Schmidt pass, and ‖y‖²_W
                    a = y[r] - (h0 * v0[r] + h1 * v1[r] + h2 * v2[r] + h3 * v3[r])
                    y[r] = a
                    ss += w[r] * a * a
            hh[0] = h0
            hh[1] = h1
            hh[2] = h2
            hh[3] = h3
        else:  # (wider windows: full orthogonalization of small operators)
            scaled = False
            for i in range(k):
                hh[i] = 0.0
            for r in range(n):
                acc = 0.0
                for idx in range(indptr[r], indptr[r + 1]):
                    acc += data[idx] * x[indices[idx]]
                y[r] = acc
            for i in range(k):
                vi = V[lo + i]
                d = 0.0
                for r in range(n):
                    d += vi[r] * w[r] * y[r]
                hh[i] = d
            ss = 0.0
            for r in range(n):
                a = y[r]
                for i in range(k):
                    a -= hh[i] * V[lo + i, r]
                y[r] = a
                ss += w[r] * a * a
        b = np.sqrt(ss)
        for i in range(k):
            H[lo + i, j] = hh[i]
        H[j + 1, j] = b
        res[1] = j + 1
        if not np.isfinite(b):
            res[0] = 2
            return
        bsum += b
        res[2] = bsum
        if b == 0.0:
            res[0] = 1
            return
        if not scaled:
            inv = 1.0 / b
            for r in range(n):
                y[r] *= inv
        if tau > 0.0 and j + 1 >= max(4.0, 2.0 * bsum / (j + 1) * tau + 3.0):
            break  # (the start of the decay: see iom_run)
    res[0] = 0


def _band_norm1(H, m, window):  # pragma: no cover - jitted (helper)
    # ‖H_m‖₁ of H_m = H[:m, :m], upper Hessenberg with `window` entries above the
    # subdiagonal per column
    norm = 0.0
    for j in range(m):
        col = 0.0
        for i in range(max(0, j + 1 - window), min(m, j + 2)):
            col += abs(H[i, j])
        norm = max(norm, col)
    return norm


def _hess_expv(H, m, c, window, x, out, term, tmp):  # pragma: no cover - jitted (helper)
    # out = exp(c H_m) x, H_m = H[:m, :m] upper Hessenberg with `window` entries above the
    # subdiagonal per column: Taylor's series in substeps of ‖c H_m / q‖₁ ≤ 2, each summed
    # until θ^k / k! ≤ 1e-17 (θ = ‖c H_m / q‖₁ bounds the ratio of consecutive terms);
    # beyond 4 substeps exp(c H_m) by _hess_taylor (scaling and squaring) times x: a
    # stiff H_m with c·‖H_m‖₁ = 1e5 took 8 s in substeps (a review's case)
    theta = abs(c) * _band_norm1(H, m, window)
    if theta > 8.0:  # (substeps would grow with θ: the dense exponential, squared, instead)
        P = np.empty((m, m))
        _hess_taylor(H, m, c, window, P, np.empty((m, m)), np.empty((m, m)))
        out[:m] = P @ np.ascontiguousarray(x[:m])
        return
    q = max(1, int(np.ceil(theta / 2.0)))
    theta /= q
    cs = c / q
    for i in range(m):
        out[i] = x[i]
    for _ in range(q):
        for i in range(m):
            term[i] = out[i]
        bound = 1.0
        k = 0
        while bound > 1e-17 and k < 60:
            k += 1
            f = cs / k
            for i in range(m):  # tmp = (c H / q / k) term over the band of row i
                acc = 0.0
                for l in range(max(0, i - 1), min(m, i + window)):
                    acc += H[i, l] * term[l]
                tmp[i] = f * acc
            for i in range(m):
                term[i] = tmp[i]
                out[i] += tmp[i]
            bound *= theta / k


def _hess_taylor(H, m, c, window, out, T, U):  # pragma: no cover - jitted (helper)
    # out = exp(c H_m) (m, m) for H_m as in _hess_expv: Taylor's series on c H_m / 2^q,
    # ‖·‖₁ ≤ 1/2, to θ^k/k! ≤ 1e-17, squared q times (BLAS); each term is the band of
    # H_m times the last, row by row over contiguous rows
    theta = abs(c) * _band_norm1(H, m, window)
    q = 0
    while theta > 0.5 and q < 1100:
        theta *= 0.5
        q += 1
    cs = c * 0.5**q
    out[:, :] = 0.0
    T[:, :] = 0.0
    for i in range(m):
        out[i, i] = 1.0
        T[i, i] = 1.0
    bound = 1.0
    k = 0
    while bound > 1e-17 and k < 60:
        k += 1
        f = cs / k
        for i in range(m):
            Ui = U[i]
            Ui[:] = 0.0
            for l in range(max(0, i - 1), min(m, i + window)):
                hil = H[i, l] * f
                Tl = T[l]
                for j in range(m):
                    Ui[j] += hil * Tl[j]
        out += U
        T, U = U, T
        bound *= theta / k
    for _ in range(q):
        sq = out @ out
        out[:, :] = sq


def _hess_below(H, m, sign, bw, x, L):  # pragma: no cover - jitted (helper)
    # whether x I − S is positive definite, S = ½ sign (H_m + H_mᵀ) of half-bandwidth bw:
    # its Cholesky factor in band storage L[i, j − i + bw] exists (backward stable, so
    # "yes" means x ≥ λ_max(S) up to rounding of ‖S‖)
    for i in range(m):
        for j in range(max(0, i - bw), i + 1):
            a = 0.5 * sign * (H[i, j] + H[j, i])  # S_ij (H is zero outside its band)
            a = (x - a) if i == j else -a
            for k in range(max(0, i - bw), j):
                a -= L[i, k - i + bw] * L[j, k - j + bw]
            if i == j:
                if not a > 0.0:
                    return False
                L[i, bw] = np.sqrt(a)
            else:
                L[i, j - i + bw] = a / L[j, bw]
    return True


def _hess_mu(H, m, sign, window, lo_hint):  # pragma: no cover - jitted (helper)
    # the largest eigenvalue of S = ½ sign (H_m + H_mᵀ), from above to 1e-10 × the
    # largest row sum of |S|:
    # bisection between Gershgorin's bounds (and lo_hint below, when it is one) on
    # whether x I − S is positive definite
    bw = min(max(1, window - 1), max(m - 1, 1))
    L = np.empty((m, bw + 1))  # the factor's band
    lo = np.inf
    hi = -np.inf
    scale = 0.0
    for i in range(m):
        rad = 0.0
        for j in range(max(0, i - bw), min(m, i + bw + 1)):
            if j != i:
                rad += abs(0.5 * (H[i, j] + H[j, i]))
        d = sign * H[i, i]
        lo = min(lo, d - rad)
        hi = max(hi, d + rad)
        scale = max(scale, abs(d) + rad)
    if scale == 0.0:
        return 0.0
    tol = 1e-10 * scale
    if lo_hint > lo:
        lo = min(lo_hint, hi)
        x = min(hi, lo + 1e-6 * scale)  # μ moves little between checks: try close first
        if _hess_below(H, m, sign, bw, x, L):
            hi = x
    while hi - lo > tol:
        x = 0.5 * (lo + hi)
        if x <= lo or x >= hi:
            break
        if _hess_below(H, m, sign, bw, x, L):
            hi = x
        else:
            lo = x
    return hi


def _hess_profile(H, m, sign, window, h, hi, mu, X, E, P, T, U):  # pragma: no cover
    # fvf.numerics.expm._HessenbergExp.errors(hi), compiled (see hess_profile)
    G = X.shape[0] - 1
    for i in range(m):
        X[0, i] = 0.0
    X[0, 0] = 1.0
    _hess_taylor(H, m, sign * hi / G, window, P, T, U)  # exp(δ sign H_m), δ = hi / G
    for g in range(G):
        X[g + 1] = P @ X[g]
    # E(s) = e^{μs} ∫_0^s e^{−μσ} |h X(σ)_{m−1}| dσ / ‖X(s)‖ (cumulative trapezoid)
    delta = hi / G
    acc = 0.0
    prev = abs(h * X[0, m - 1])
    E[0] = 0.0
    for g in range(1, G + 1):
        s = g * delta
        cur = np.exp(-mu * s) * abs(h * X[g, m - 1])
        acc += 0.5 * delta * (prev + cur)
        prev = cur
        big = 0.0  # ‖X(s)‖ scaled by its largest entry, as numpy's norm (no overflow)
        for i in range(m):
            big = max(big, abs(X[g, i]))
        nx = 0.0
        if big > 0.0:
            for i in range(m):
                nx += (X[g, i] / big) ** 2
        d = np.sqrt(nx) * big
        e = np.exp(mu * s) * acc / d if d > 0.0 else np.inf  # (numba raises on x / 0)
        E[g] = e if np.isfinite(e) else np.inf


def skew_lanczos(
    csr: tuple[np.ndarray, np.ndarray, np.ndarray],
    w: np.ndarray,
    q: np.ndarray,
    steps: int,
    rtol: float,
) -> tuple[float, int, bool]:
    """The steps of :func:`fvf.numerics.expm._skew_norm_estimate` in one call: Lanczos on the
    W-skew part K = ½(A − W⁻¹AᵀW) of A until its largest Ritz value θ moved by at most
    ``rtol`` relative over two steps (from the fourth step on) or the basis is invariant.

    Parameters
    ----------
    csr : (indptr, indices, data)
        A (n, n) in CSR, as :func:`csr_views` gives it.
    w : float64 (n,)
        Positive weights of the inner product.
    q : float64 (n,)
        The start, of W-norm 1; overwritten.
    steps : int
        Steps at most (≥ 1).
    rtol : float

    Returns
    -------
    (float, int, bool)
        θ (≤ ‖K‖_W), the steps taken (two products each: A and Aᵀ), whether θ converged.
    """
    n = q.shape[0]
    beta = np.zeros(int(steps))
    theta, taken, converged = _jit(_skew_lanczos)(
        csr[0], csr[1], csr[2], w, q, np.zeros(n), np.empty(n), np.empty(n), beta, float(rtol)
    )
    return float(theta), int(taken), bool(converged)


def term_run(
    csr: tuple[np.ndarray, np.ndarray, np.ndarray],
    Y: np.ndarray,
    cur: int,
    out: np.ndarray,
    coef: np.ndarray,
    p: int,
    w: np.ndarray | None = None,
    s2: np.ndarray | None = None,
) -> None:
    """len(coef) terms of a three-term recurrence and their sum, in one call: term t does
    dst ← dst + A src, then out ← out + coef[t] dst, in one pass over A's rows, with
    src = Y[(cur + t) % 2] and dst = Y[(cur + t + 1) % 2]. With ``w`` and ``s2`` (p = 1
    only), the last term also gives s2[0, 0] ← Σ_i w_i dst_i² and s2[1, 0] ← max_i |dst_i|.

    One call for a run of terms saves numba's dispatch (~2 µs a call, a tenth of a product
    at 6k faces) on every term but one.

    Parameters
    ----------
    csr : (indptr, indices, data)
        A (n, n) in CSR, as :func:`csr_views` gives it (unsigned index views, float64).
    Y : float64 (2, n·p)
        The two vectors of the recurrence (p columns interleaved), C-contiguous.
    cur : int
        The row of Y that the first term multiplies (0 or 1).
    out : float64 (n·p,)
    coef : float64 (L,)
        The coefficients of the L terms (L ≥ 1).
    p : int
    w : float64 (n,), optional
        Weights of the norm (ones for Euclidean).
    s2 : float64 (k ≥ 2, p), optional
        Output of the norms (rows 0 and 1).
    """
    if p > 1:
        _jit(_term_run_block)(csr[0], csr[1], csr[2], Y, int(cur), out, coef, int(p))
        return
    norms = w is not None and s2 is not None
    if not norms:
        w, s2 = _NO_W, _NO_NORMS
    _jit(_term_run)(csr[0], csr[1], csr[2], Y, int(cur), out, coef, w, s2, norms)


def term_chain(
    csr: tuple[np.ndarray, np.ndarray, np.ndarray], Y: np.ndarray, f0: int, count: int, p: int
) -> None:
    """Y[f] ← Y[f − 2] + A Y[f − 1] for f = f0 … f0 + count − 1, each in one pass over A's
    rows, in one call (the Chebyshev terms for several times, kept for one GEMM into
    the outputs).

    Parameters
    ----------
    csr : (indptr, indices, data)
        A (n, n) in CSR, as :func:`csr_views` gives it.
    Y : float64 (chunk, n·p)
        The terms (p columns interleaved), C-contiguous; f0 ≥ 2, f0 + count ≤ chunk.
    f0, count, p : int
    """
    if p > 1:
        _jit(_term_chain_block)(csr[0], csr[1], csr[2], Y, int(f0), int(count), int(p))
    else:
        _jit(_term_chain)(csr[0], csr[1], csr[2], Y, int(f0), int(count))


def term_combine(
    csr: tuple[np.ndarray, np.ndarray, np.ndarray],
    x: np.ndarray,
    prev: np.ndarray,
    c: np.ndarray,
    y: np.ndarray,
    w: np.ndarray,
    s2: np.ndarray,
    p: int,
    norms: int,
) -> None:
    """y ← diag(c) prev + A x (column q of prev scaled by c[q]), in one pass over A's rows,
    with weighted inner products of y when asked.

    Parameters
    ----------
    csr : (indptr, indices, data)
        As for :func:`term_run`.
    x, prev, y : float64 (n·p,)
        Flat C-contiguous vectors; y must alias neither x nor prev.
    c : float64 (p,)
    w : float64 (n,)
        Weights of the inner products (ones for Euclidean); read only when ``norms``.
    s2 : float64 (3, p)
        Output, per column q: Σ_i w_i y_iq² (``norms`` ≥ 1), Σ_i w_i y_iq x_iq and
        Σ_i w_i y_iq prev_iq (``norms`` = 2); zeros where not asked.
    p : int
    norms : int
        0, 1 or 2.
    """
    _jit(_term_combine)(csr[0], csr[1], csr[2], x, prev, c, y, w, s2, int(p), int(norms))


def lanczos_run(
    csr: tuple[np.ndarray, np.ndarray, np.ndarray],
    V: np.ndarray,
    w: np.ndarray,
    nu: np.ndarray,
    beta: np.ndarray,
    j0: int,
    j1: int,
    bsum: float,
    limit: float,
    res: np.ndarray,
) -> None:
    """Vectors j0 … j1 − 1 of fvf.numerics.expm's unnormalized Lanczos recurrence for one column,
    in one call: y_{j+1} = A y_j + c y_{j−1}, c = β_{j−1} ν_j / ν_{j−1}, in one pass over
    A's rows with ν_{j+1} = ‖y_{j+1}‖_W, β_j = ν_{j+1} / ν_j, and for j < 3 and every 8th
    vector the skew checks |⟨A u_j, u_j⟩_W| and |h_{j−1,j} + h_{j,j−1}| against
    max(limit, 1e-12 · scale) (see fvf.numerics.expm._check_skew). A vector whose norm leaves
    [1e-150, 1e150] is rescaled to norm 1.

    Parameters
    ----------
    csr : (indptr, indices, data)
        A (n, n) in CSR, as :func:`csr_views` gives it.
    V : float64 (m_cap + 1, n)
        The vectors; V[0 … j0] are given.
    w : float64 (n,)
        Weights of the inner product (ones for Euclidean).
    nu, beta : float64 (m_cap + 1,), (m_cap,)
        ν_0 … ν_{j0} and β_0 … β_{j0 − 1} given; filled on.
    j0, j1 : int
    bsum : float
        Σ β_0 … β_{j0 − 1}.
    limit : float
    res : float64 (≥ 6,)
        Output: res[0] the status (0 done; 1 a non-finite norm; 2 the skew check failed,
        with diag, off and scale in res[3:6]; 3 a breakdown β = 0), res[1] the first
        vector not finished (j1 when done), res[2] the new Σβ.
    """
    _jit(_lanczos_run)(
        csr[0], csr[1], csr[2], V, w, nu, beta, int(j0), int(j1), float(bsum), float(limit), res
    )


def lanczos_step(
    csr: tuple[np.ndarray, np.ndarray, np.ndarray],
    V: np.ndarray,
    w: np.ndarray,
    nu: np.ndarray,
    beta: np.ndarray,
    m_cap: int,
    tau: float,
    rate: float,
    limit: float,
    lead: int,
    gap: int,
    maxnorm: bool,
    yscale: float,
    sign: float,
    unit: np.ndarray,
    noise: float,
    tiny: float,
) -> tuple[np.ndarray, np.ndarray]:
    """One step of :func:`fvf.numerics.expm._lanczos_steps` for one column, in one call: the
    vectors in runs of :func:`lanczos_run`, the first check at the Chebyshev degree for
    radius 2·mean(β) less ``lead``, the error checks by :func:`skew_series` (the vectors
    of :func:`skew_chebyshev_basis` to the order τ·r needs), and the next checks as
    fvf.numerics.expm._next_check places them (at least ``gap`` apart), until a check passes
    or the basis reaches ``m_cap``. The same arithmetic as the Python loop, which
    remains for blocks and for the numpy path.

    Parameters
    ----------
    csr, V, w, limit :
        As for :func:`lanczos_run`; V (m_cap + 1, n) with V[0] the start vector.
    nu, beta : float64 (m_cap + 1,), (m_cap,)
        ν_0 given; filled.
    m_cap : int
    tau, rate : float
        The step's length and the allowed relative error per unit time.
    lead, gap : int
    maxnorm : bool
    yscale : float
        ‖y_0‖_W / max|y_0| (max-norm control).
    sign : float
        ±1, the sign of the times.
    unit : float64 (G,)
        The unit quadrature grid (fvf.numerics.expm._UNIT_GRID).
    noise, tiny : float
        fvf.numerics.expm.NOISE and fvf.numerics.expm._BESSEL_TINY.

    Returns
    -------
    P : float64 (1, K + 1, m)
        The Chebyshev vectors P_k(H_m / r) e_1 of the last check (for the outputs).
    res : float64 (12,)
        res[0] the status (0 a check passed; 4 the last check at m_cap failed; 1, 2 as
        for :func:`lanczos_run`, with res[3:6]), res[1] m, res[2] Σβ, res[6] products,
        and of the last check: res[7] its excess (estimate / budget), res[8] the error
        estimate, res[9] the rate used, res[10] the max-norm factor; res[11] the number
        of checks.
    """
    res = np.zeros(12)
    P = _jit(_lanczos_step)(
        csr[0], csr[1], csr[2], V, w, nu, beta, int(m_cap), float(tau), float(rate),
        float(limit), int(lead), int(gap), bool(maxnorm), float(yscale), float(sign), unit,
        float(noise), float(tiny), res,
    )  # fmt: skip
    return P, res


def abs_stats(csr: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple[float, float, float]:
    """(‖A‖_∞ = max_i Σ_j |a_ij|, max_i |a_ii|, max |a_ij|) in one pass over A; all three
    NaN when an entry is not finite. Duplicate entries add up, as in products.

    Parameters
    ----------
    csr : (indptr, indices, data)
        As for :func:`term_run`.
    """
    top, dmax, amax = _jit(_abs_stats)(csr[0], csr[1], csr[2])
    return float(top), float(dmax), float(amax)


def power_bound(
    csr: tuple[np.ndarray, np.ndarray, np.ndarray],
    s: np.ndarray,
    inv_s: np.ndarray,
    sym: bool,
    steps: int,
    span: float,
    floor: float = 0.0,
    handoff: float = np.inf,
    first_floor: float = 0.0,
) -> tuple[float, int]:
    """The power steps of :func:`fvf.numerics.expm._skew_bound` in one call, from d = 1, while the
    last two steps save more terms than they cost and the bound is not below ``floor``
    (nor, for the first bound, Gershgorin's, below ``first_floor``).
    With P = diag(s) |A| diag(1/s), a step is M d = P d when ``sym`` (|S| symmetric, A
    declared skew), else M d = ½(P d + Pᵀ d) − |diag A| d, both products from the same
    pass over A's rows (the transposed one scattered from the rows);
    d ← max(M d / max M d, 1e-300).

    Parameters
    ----------
    csr : (indptr, indices, data)
        A in CSR, as for :func:`term_run`.
    s, inv_s : float64 (n,)
        √w and 1/√w.
    sym : bool
    steps : int
        Steps after the first (≥ 0).
    span : float
        max|t| × columns (inf: all the steps).
    floor : float
        Stop once the bound is below this (0: no such stop).
    handoff : float
        Stop once span × the bound is more than this (inf: no such stop).
    first_floor : float
        Stop after the first step if its bound is below this (0: no such stop).

    Returns
    -------
    (float, int)
        The smallest max (M d)/d seen, and the products with |A| spent (one a step when
        ``sym``, else two).
    """
    n = s.shape[0]
    d, md, g, dg = np.ones(n), np.empty(n), np.empty(n), np.empty(n)
    best, products = _jit(_power_bound)(
        csr[0],
        csr[1],
        csr[2],
        s,
        inv_s,
        bool(sym),
        int(steps),
        float(span),
        float(floor),
        float(first_floor),
        float(handoff),
        d,
        md,
        g,
        dg,
    )
    return float(best), int(products)


def skew_chebyshev_basis(beta: np.ndarray, r: np.ndarray, kmax: int) -> np.ndarray:
    """The Chebyshev vectors P_k(H_c / r_c) e_1 of small skew tridiagonal matrices.

    Parameters
    ----------
    beta : float64 (m − 1, p)
        Column c holds the sub-diagonal β of H_c (H[j+1, j] = β_j = −H[j, j+1]).
    r : float64 (p,)
        Scales r_c > 0 (r_c ≥ ‖H_c‖ keeps every vector within norm 1).
    kmax : int

    Returns
    -------
    float64 (p, kmax + 1, m)
        P_0 = I, P_1 = H/r, P_{k+1} = 2 (H/r) P_k + P_{k−1} applied to e_1, so that
        exp(s H) e_1 = J₀(rs) e_1 + 2 Σ_{k≥1} J_k(rs) P_k(H/r) e_1 (Jacobi–Anger).
    """
    beta = np.ascontiguousarray(beta, dtype=np.float64)
    out = np.empty((beta.shape[1], int(kmax) + 1, beta.shape[0] + 1))
    _jit(_skew_chebyshev_basis)(beta, np.ascontiguousarray(r, dtype=np.float64), out)
    return out


def col_norms(X: np.ndarray, w: np.ndarray | None, p: int, maxnorm: bool) -> np.ndarray:
    """W-norms and max-norms of the columns of a stack of blocks, in one pass.

    Parameters
    ----------
    X : float64 (rows, n·p)
        C-contiguous; row r holds an (n, p) block, column q of its row i at i·p + q.
    w : float64 (n,) or None
        Weights (None: all ones).
    p : int
    maxnorm : bool
        Whether to compute the max-norms.

    Returns
    -------
    float64 (2, rows, p)
        [0] ‖X[r, :, q]‖_W; [1] max_i |X[r, i, q]| (ones when not ``maxnorm``).
    """
    out = np.empty((2, X.shape[0], int(p)))
    _jit(_col_norms)(X, _EMPTY if w is None else w, int(p), bool(maxnorm), out)
    return out


def chebyshev_degree(tau: float, tol: float, top: int, tiny: float) -> int:
    """:func:`fvf.numerics.expm.chebyshev_degree` compiled (the same arithmetic, the same result):
    the smallest m ≥ ⌊τ⌋ with 2 Σ_{k>m}^{top} |J_k(τ)| ≤ tol, for τ ≥ 0, ``top`` > τ.
    One call where the numpy form's ~10 calls cost ~30 µs, and 3–5× that right after a
    kernel has streamed a Krylov basis through the caches."""
    return int(_jit(_cheb_degree)(float(tau), float(tol), int(top), float(tiny)))


def skew_series(
    P: np.ndarray, r: np.ndarray, s: np.ndarray, tiny: float, bl: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray | None]:
    """Lanczos' small exponentials exp(s_g H_c) e_1 from :func:`skew_chebyshev_basis`, and
    the error integrals of its step control, in one call.

    Parameters
    ----------
    P : float64 (p, K + 1, mm)
        P_k(H_c / r_c) e_1 (mm = m), or some of its entries (e.g. the last, mm = 1); K
        must reach the order x + 12 x^{1/3} + 30, x = r_c·max|s| (the terms beyond are
        below round-off).
    r : float64 (p,)
        The scales r_c > 0.
    s : float64 (G,)
        Times (either sign); a uniform grid from s_0 = 0 when ``bl`` is given.
    tiny : float
        :data:`fvf.numerics.expm._BESSEL_TINY`.
    bl : float64 (p,), optional
        Weights of the integrals (β_{m−1} times the max-norm factor).

    Returns
    -------
    X : float64 (p, G, mm)
        J₀(r_c s_g) P[c, 0] + 2 Σ_{k≥1} J_k(r_c s_g) P[c, k] (Jacobi–Anger).
    E : float64 (p, G) or None
        With ``bl``: ∫_0^{s_g} |bl_c X[c, σ, −1]| dσ by the cumulative trapezoid rule.
    """
    p, _, mm = P.shape
    out = np.empty((p, s.shape[0], mm))
    E = np.empty((p, s.shape[0]) if bl is not None else (p, 0))
    _jit(_skew_series)(
        np.ascontiguousarray(P, dtype=np.float64),
        np.ascontiguousarray(r, dtype=np.float64),
        np.ascontiguousarray(s, dtype=np.float64),
        float(tiny),
        out,
        _NO_W if bl is None else np.ascontiguousarray(bl, dtype=np.float64),
        E,
    )
    return out, (E if bl is not None else None)


def bessel_rows(x: np.ndarray, kmax: int, tiny: float) -> np.ndarray:
    """J_k(x_j) for k = 0..kmax: (T, kmax + 1) float64, for x (T,) float64, each x_j ≥ 0.

    The recurrence of :func:`fvf.numerics.expm._bessel_row` (Miller's, from the order
    x + 12 x^{1/3} + 30, past the turning point), compiled: ~5 ns a step instead of
    ~0.25 µs on Python floats; below ``tiny`` (where a step would overflow) the series'
    leading terms, as there.
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    out = np.empty((x.size, int(kmax) + 1))
    _jit(_bessel_rows)(x, int(kmax), float(tiny), out)
    return out


def iom_run(
    csr: tuple[np.ndarray, np.ndarray, np.ndarray],
    V: np.ndarray,
    w: np.ndarray,
    H: np.ndarray,
    j0: int,
    j1: int,
    window: int,
    res: np.ndarray,
    tau: float = 0.0,
) -> None:
    """The vectors V[j0 + 1 .. j1] of incomplete orthogonalization
    (:func:`fvf.numerics.expm._iom_steps`) in one call: for each j, y = A V[j]; h_i = ⟨y, V[i]⟩_W
    for the last ``window`` vectors i ≤ j and ‖y‖²_W, taken in the product's pass over the
    rows; then V[j + 1] = (y − Σ h_i V[i]) / β in a second pass, with
    β² = ‖y‖²_W − Σ h_i² where that is at least :data:`IOM_PYTHAGORAS` ‖y‖²_W (else β is
    the W-norm of y − Σ h_i V[i], and the scaling a third pass). The same arithmetic as
    the numpy loop (classical Gram–Schmidt, one pass).

    Parameters
    ----------
    csr : (indptr, indices, data)
        A (n, n) in CSR, as :func:`csr_views` gives it.
    V : float64 (m_cap + 1, n), C-contiguous
        The basis; rows 0..j0 are read, rows j0 + 1..j1 written.
    w : float64 (n,)
        Positive weights of the inner product (ones for none).
    H : float64 (m_cap + 1, m_cap)
        Receives h_{i,j} and h_{j+1,j} = β of columns j0..j1 − 1.
    j0, j1 : int
        0 ≤ j0 < j1 ≤ m_cap.
    window : int
        Vectors orthogonalized against (≥ 1).
    res : float64 (3,)
        In: res[2] = Σβ so far. Out: status (0 done, 1 breakdown β = 0, 2 β not finite),
        the basis size reached, Σβ.
    tau : float
        If > 0, also stop at the first size m ≥ max(4, 2·(Σβ/m)·tau + 3), where the error
        starts to decay (the first check of :func:`fvf.numerics.expm._iom_steps`).
    """
    j0, j1, win = int(j0), int(j1), int(window)
    _jit(_iom_run)(csr[0], csr[1], csr[2], w, V, H, j0, j1, win, float(tau), res)


def hess_mu(H: np.ndarray, m: int, sign: float, window: int, lo_hint: float = -np.inf) -> float:
    """The largest eigenvalue μ of S = ½ sign (H_m + H_mᵀ), H_m = H[:m, :m] upper
    Hessenberg with ``window`` entries above the subdiagonal per column: the logarithmic
    norm of :class:`fvf.numerics.expm._HessenbergExp`'s step control.

    Bisection on whether x I − S has a Cholesky factor (banded, half-bandwidth
    max(1, window − 1); backward stable, so the answer is right up to rounding of ‖S‖),
    to 1e-10·max_i Σ_j |S_ij|, returning the upper end. LAPACK's eigvalsh took 200 µs at
    m = 50 and 890 µs at m = 80 here. ``lo_hint``: a lower bound of μ, e.g. μ of a
    leading block (H_k, k < m, interlacing), tried first with a gap of 1e-6·scale above
    it.
    """
    H = np.ascontiguousarray(H)
    return float(_jit(_hess_mu)(H, int(m), float(sign), int(window), float(lo_hint)))


def hess_profile(
    H: np.ndarray, m: int, sign: float, window: int, h: float, hi: float, mu: float, G: int
) -> tuple[np.ndarray, np.ndarray]:
    """exp(s·sign·H_m) e_1 on the grid s_g = g·hi/G and the error estimate of
    :meth:`fvf.numerics.expm._HessenbergExp.errors` there, in one call.

    exp(δ·sign·H_m), δ = hi/G, by Taylor's series on the band of H_m (each term O(m²·
    window)), scaled to ‖·‖₁ ≤ 1/2 and squared back, then G products with it.

    Returns
    -------
    X : float64 (G + 1, m)
        exp(s_g sign H_m) e_1.
    E : float64 (G + 1,)
        e^{μ s} ∫_0^s e^{−μσ} |h X(σ)_{m−1}| dσ / ‖X(s)‖ (cumulative trapezoid; inf where
        it overflows).
    """
    mm = int(m)
    X = np.empty((int(G) + 1, mm))
    E = np.empty(int(G) + 1)
    P, T, U = (np.empty((mm, mm)) for _ in range(3))  # exp(δ H_m), Taylor's terms
    H = np.ascontiguousarray(H)
    _jit(_hess_profile)(
        H, mm, float(sign), int(window), float(h), float(hi), float(mu), X, E, P, T, U
    )
    return X, E


def hess_expv(H: np.ndarray, m: int, c: float, window: int, x: np.ndarray) -> np.ndarray:
    """exp(c H_m) x: float64 (m,), for H_m = H[:m, :m] as in :func:`hess_mu` and x (m,):
    Taylor's series on the band, in substeps of ‖c H_m / q‖₁ ≤ 2, each to θ^k/k! ≤
    1e-17; for θ = |c|·‖H_m‖₁ > 8 the dense exponential of :func:`hess_profile`'s step
    (scaling and squaring) times x, whose cost grows with log θ only."""
    mm = int(m)
    out, term, tmp = np.empty(mm), np.empty(mm), np.empty(mm)
    x = np.ascontiguousarray(x, dtype=np.float64)
    _jit(_hess_expv)(np.ascontiguousarray(H), mm, float(c), int(window), x, out, term, tmp)
    return out
