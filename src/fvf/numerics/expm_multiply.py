"""scipy's :func:`scipy.sparse.linalg.expm_multiply` (Al-Mohy & Higham 2011: truncated
Taylor series with scaling) as ``method="expm_multiply"`` of
:func:`fvf.numerics.expm.expm_action`, chained over the sorted times of each sign and
counted like the other methods.
"""

from __future__ import annotations

from typing import Any

import scipy.sparse.linalg as spla

from .expm_inputs import ExpmJob, ExpmvCounter, signed_sweeps

__all__ = ["run_expm_multiply"]


def run_expm_multiply(A: Any, job: ExpmJob) -> None:
    """scipy's expm_multiply chained over the sorted times of each sign, counted.

    Parameters
    ----------
    A : sparse, ndarray or LinearOperator (n, n), real
    job : ExpmJob
        The call; ``job.out`` and ``job.info`` are filled (``error_estimate`` is None:
        scipy gives none).
    """
    B2, times, out, info = job.B2, job.times, job.out, job.info
    info["method"] = "expm_multiply"
    info["error_estimate"] = None
    counter = ExpmvCounter(A)
    trace = getattr(A, "trace", None)  # a LinearOperator may know its exact trace
    if hasattr(A, "diagonal"):
        trace = float(A.diagonal().sum())
    trace = trace if isinstance(trace, int | float) else None
    for sign, order in signed_sweeps(times):
        current, now = B2, 0.0
        op = counter if sign > 0 else -counter
        for i in order:
            dt = sign * times[i] - now
            if dt > 0:
                current = spla.expm_multiply(
                    op * dt, current, traceA=None if trace is None else sign * trace * dt
                )
                now = sign * times[i]
            out[i] = current
    out[times == 0] = B2
    info["matvecs"] = counter.products
    info["block_matvecs"] = counter.products
