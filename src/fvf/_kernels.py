"""Fused sparse kernels for the recurrences of :mod:`fvf.expmv` (optional: numba).

scipy's CSR kernel only does y += A x, so every term of a three-term recurrence pays one
or two more passes over its vectors (a scaled copy, an axpy into the output, a norm), each
1/6–1/4 of a product on large meshes. With numba installed (``pip install 'fvf[fast]'``)
these kernels do the product and that extra work in the same pass over the rows:

- :func:`term_accumulate`: y ← y + A x, then out ← out + c y (a Chebyshev term for one time);
- :func:`term_combine`: y ← diag(c) prev + A x, with the W-norms Σ_i w_i y_iq² of its p
  columns when asked (a Lanczos vector; a Chebyshev term for several times with c = 1).

Vectors are flat C-contiguous float64 arrays of n·p entries, column q of row i at i·p + q.
The index arrays are unsigned views of the matrix's own (see :func:`csr_views`): an
unsigned index needs no negative-index branch, which is what makes a numba CSR loop as
fast as scipy's C++ one (20–30 % slower with signed indices, measured at 6k–1.5M faces).

Set ``FVF_NUMBA=0`` in the environment to use the numpy/scipy path even where numba is
installed; :data:`ENABLED` says which is in use.
"""

from __future__ import annotations

import os

import numpy as np

try:  # pragma: no cover - depends on the environment
    if os.environ.get("FVF_NUMBA", "1").strip().lower() in ("0", "false", "no", "off"):
        raise ImportError("disabled by FVF_NUMBA")
    from numba import njit
except ImportError:  # pragma: no cover - depends on the environment
    njit = None

#: True when the fused kernels are compiled with numba and used by :mod:`fvf.expmv`.
ENABLED = njit is not None

__all__ = ["ENABLED", "csr_views", "term_accumulate", "term_combine"]


def csr_views(indptr: np.ndarray, indices: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Unsigned views (no copy) of a CSR matrix's index arrays, or None.

    Parameters
    ----------
    indptr, indices : int32 or int64 (n + 1,), (nnz,)
        Row pointers and column indices (non-negative, as scipy guarantees).

    Returns
    -------
    (uint32 or uint64 (n + 1,), uint32 or uint64 (nnz,)), or None when the kernels are
    disabled or the arrays are not C-contiguous signed 32- or 64-bit integers.
    """
    if not ENABLED:
        return None
    out = []
    for a in (indptr, indices):
        if a.dtype not in (np.int32, np.int64) or not a.flags.c_contiguous:
            return None
        out.append(a.view(np.uint32 if a.dtype == np.int32 else np.uint64))
    return out[0], out[1]


def _term_accumulate(indptr, indices, data, x, y, out, c, p):  # pragma: no cover - jitted
    n = indptr.shape[0] - 1
    if p == 1:
        for i in range(n):
            s = y[i]
            for k in range(indptr[i], indptr[i + 1]):
                s += data[k] * x[indices[k]]
            y[i] = s
            out[i] += c * s
    else:
        for i in range(n):
            b = i * p
            for k in range(indptr[i], indptr[i + 1]):
                a = data[k]
                jb = indices[k] * p
                for q in range(p):
                    y[b + q] += a * x[jb + q]
            for q in range(p):
                out[b + q] += c * y[b + q]


def _term_combine(indptr, indices, data, x, prev, c, y, w, s2, p, norms):  # pragma: no cover
    n = indptr.shape[0] - 1
    for q in range(p):
        s2[q] = 0.0
    if p == 1:
        c0 = c[0]
        acc = 0.0
        for i in range(n):
            s = c0 * prev[i]
            for k in range(indptr[i], indptr[i + 1]):
                s += data[k] * x[indices[k]]
            y[i] = s
            if norms:
                acc += w[i] * s * s
        s2[0] = acc
    else:
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
                    s2[q] += wi * y[b + q] * y[b + q]


if ENABLED:  # pragma: no cover - depends on the environment
    _term_accumulate = njit(cache=True, nogil=True)(_term_accumulate)
    _term_combine = njit(cache=True, nogil=True)(_term_combine)


def term_accumulate(
    csr: tuple[np.ndarray, np.ndarray, np.ndarray],
    x: np.ndarray,
    y: np.ndarray,
    out: np.ndarray,
    c: float,
    p: int,
) -> None:
    """y ← y + A x, then out ← out + c y, in one pass over A's rows.

    Parameters
    ----------
    csr : (indptr, indices, data)
        A (n, n) in CSR with unsigned index views (:func:`csr_views`) and float64 data.
    x, y, out : float64 (n·p,)
        Flat C-contiguous vectors (p columns interleaved); x must not alias y.
    c : float
    p : int
    """
    _term_accumulate(csr[0], csr[1], csr[2], x, y, out, float(c), int(p))


def term_combine(
    csr: tuple[np.ndarray, np.ndarray, np.ndarray],
    x: np.ndarray,
    prev: np.ndarray,
    c: np.ndarray,
    y: np.ndarray,
    w: np.ndarray,
    s2: np.ndarray,
    p: int,
    norms: bool,
) -> None:
    """y ← diag(c) prev + A x (column q of prev scaled by c[q]), in one pass over A's rows,
    and, when ``norms``, s2[q] ← Σ_i w_i y[i, q]².

    Parameters
    ----------
    csr : (indptr, indices, data)
        As for :func:`term_accumulate`.
    x, prev, y : float64 (n·p,)
        Flat C-contiguous vectors; y must alias neither x nor prev.
    c : float64 (p,)
    w : float64 (n,)
        Weights of the norms (ones for Euclidean); read only when ``norms``.
    s2 : float64 (p,)
        Output: the squared weighted column norms of y (zeros when not ``norms``).
    p : int
    norms : bool
    """
    _term_combine(csr[0], csr[1], csr[2], x, prev, c, y, w, s2, int(p), bool(norms))
