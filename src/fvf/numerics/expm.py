r"""The action of the matrix exponential: :math:`e^{t_j A} B` for many times and columns.

:func:`expm_action` computes :math:`X_j = e^{t_j A} B` for times :math:`t_j` of any sign and
order and a block :math:`B \in \mathbb{R}^{n \times p}`, without forming :math:`e^{A}`. It
is built for the functional flows :math:`\Phi_{v,t} f = e^{-t D^V_v} f`
(docs/chapter.md, eq. (42)): :math:`A = -D^V_v` is sparse with about 7 non-zeros per row
and, for divergence-free fields :math:`v = J\nabla g` on a closed mesh, skew-adjoint in the
inner product :math:`\langle x, y\rangle_W = x^\top W y`, :math:`W = [A_V]`.

This module is the entrance and the dispatch; each method has its own module:

Chebyshev series (``method="chebyshev"``, :mod:`fvf.numerics.expm_chebyshev`)
    For a :math:`W`-skew :math:`A` of norm at most :math:`R`
    (:func:`~fvf.numerics.expm_skew.skew_bound`), the Jacobi–Anger expansion
    :math:`e^{tA} = J_0(Rt)\,I + 2\sum_{k\ge1} J_k(Rt)\,P_k(A/R)`: a real three-term
    recurrence, one product per term, every time from the same terms, its degree chosen a
    priori. For an operator that is not :math:`W`-skew it is checked a posteriori and
    gives way to the Krylov method (with :class:`~fvf.errors.KrylovFallbackWarning`)
    when its terms grow.

Krylov time stepping (``method="krylov"``, :mod:`fvf.numerics.expm_krylov`)
    Lanczos for :math:`W`-skew :math:`A`, incomplete orthogonalization otherwise; steps
    chosen by an a-posteriori bound of the error, dense output for every time inside a
    step.

``method="expm_multiply"`` (:mod:`fvf.numerics.expm_multiply`)
    :func:`scipy.sparse.linalg.expm_multiply` (Al-Mohy & Higham 2011), chained over the
    sorted times of each sign.

``method="auto"`` (:func:`choose_method`) runs the series for skew operators once
:math:`R\max|t| \ge` :data:`SERIES_MIN_TAU` and the Krylov method otherwise: the series'
products are cheaper (no inner products, no basis to keep), Lanczos needs fewer of them on
short times.

Work is bounded: a call whose estimated number of products exceeds ``max_products``
(:data:`MAX_PRODUCTS` by default) raises :class:`~fvf.errors.FlowOverflowError` before
starting, with the estimate and what to do. The inputs, their checks and the product
counters are in :mod:`fvf.numerics.expm_inputs`; what is learnt about an explicit operator
(skewness, the bound R) in :mod:`fvf.numerics.expm_skew`. Every name of those modules that
callers used is importable from here too.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import scipy.sparse.linalg as spla

from ..errors import ExpmInputError, FlowOverflowError, KrylovFallbackWarning
from .expm_chebyshev import SERIES_SAFETY, chebyshev_degree, run_chebyshev
from .expm_inputs import (
    BASIS_MEMORY,
    METHODS,
    CountedOperator,
    ExpmJob,
    ExpmvCounter,
    as_times,
    check_block,
    check_flags,
    check_operator,
    check_options,
    check_weights,
    norm_inf,
    weighted_norms,
)
from .expm_krylov import EIG_COND_MAX, IOM_WINDOW, M_MAX, SAFETY, dense_expm_action, run_krylov
from .expm_multiply import run_expm_multiply
from .expm_skew import SKEW_RTOL, PreparedOperator, skew_bound

__all__ = [
    "expm_action",
    "skew_bound",
    "chebyshev_degree",
    "choose_method",
    "check_options",
    "as_times",
    "ExpmvCounter",
    "PreparedOperator",
    "dense_expm_action",
    "METHODS",
    "MAX_PRODUCTS",
    # re-exported constants of the method modules
    "M_MAX",
    "IOM_WINDOW",
    "SAFETY",
    "SERIES_SAFETY",
    "BASIS_MEMORY",
    "SKEW_RTOL",
    "EIG_COND_MAX",
    "SERIES_MIN_TAU",
    "MAX_SPAN",
]

Method = Literal["auto", "krylov", "chebyshev", "expm_multiply"]
#: ``auto`` runs the Chebyshev series for skew operators from R · max|t| ≥ this.
SERIES_MIN_TAU = 40.0
#: Default cap on the products of one call (columns × products); beyond it the call is
#: refused before it starts. About 5 ms each at 750k vertices, 2 µs at 200.
MAX_PRODUCTS = 200_000
#: Largest max|t| · ‖A‖_∞ accepted (beyond ~1/eps the steps underflow relative to t).
MAX_SPAN = 1e15


def choose_method(
    n: int, times: np.ndarray, skew: bool, radius: float | None
) -> Literal["chebyshev", "krylov"]:
    """The method of ``method="auto"``: the series for W-skew operators once
    R · max|t| ≥ :data:`SERIES_MIN_TAU`, the Krylov method otherwise."""
    span = float(np.abs(times).max()) if times.size else 0.0
    if skew and radius is not None and radius * span >= SERIES_MIN_TAU and n > 2:
        return "chebyshev"
    return "krylov"


def _product_estimate(method: str, radius: float, span: float, p: int, tol: float) -> float:
    """Products a call will take, estimated before it starts (the work budget)."""
    tau = radius * span
    terms = tau + 10.0 * tau ** (1.0 / 3.0) + math.log10(1.0 / tol) + 10.0
    if method == "expm_multiply":
        terms *= 2.0  # its Taylor steps take about twice the series' products
    return p * terms


def expm_action(
    A: Any,
    B: npt.ArrayLike,
    t: float | npt.ArrayLike,
    *,
    tol: float = 1e-10,
    inner: npt.ArrayLike | None = None,
    skew: bool | None = None,
    method: str = "auto",
    norm: Literal["max", "inner"] = "max",
    m_max: int | None = None,
    skew_norm: float | None = None,
    max_products: float = MAX_PRODUCTS,
    progress: Callable[[float], Any] | None = None,
    return_info: bool = False,
) -> np.ndarray | tuple[np.ndarray, dict[str, Any]]:
    r""":math:`e^{t_j A} B` for one or many times :math:`t_j` and right-hand sides.

    Parameters
    ----------
    A : sparse array/matrix, ndarray or LinearOperator, shape (n, n), real
        The generator; for a functional flow, :math:`A = -D^V_v`.
    B : array_like, shape (n,) or (n, p)
        Initial value(s), real or complex (complex B is split into real and imaginary
        columns, which share the products).
    t : float or array_like, shape (T,)
        Times, any sign and order (repeats and zeros allowed).
    tol : float
        Target relative error of every output column, 0 < tol < 1: in the norm of
        ``inner`` and, with ``norm="max"`` (default), in the max norm too.
    inner : array_like, shape (n,), optional
        Positive weights of the inner product :math:`\langle x,y\rangle = x^\top W y` (for
        flows, the vertex areas :math:`A_V`). Default: all ones.
    skew : bool or None
        Whether A is W-skew (:math:`WA + A^\top W = 0`; true for :math:`A = \pm D^V_v`,
        :math:`v = J\nabla g`, on a closed mesh with :math:`W = A_V`). None: decided from
        the entries of an explicit A (a LinearOperator counts as not skew). True on an
        explicit A that is not skew warns (:class:`~fvf.errors.KrylovFallbackWarning`) and
        is ignored.
    method : {"auto", "krylov", "chebyshev", "expm_multiply"}
        See the module docstring; "auto" follows :func:`choose_method`.
    norm : {"max", "inner"}
        Norm(s) of the error control (see ``tol``).
    m_max : int, optional
        Largest Krylov basis per step (default :data:`M_MAX`, less when the basis would
        exceed :data:`BASIS_MEMORY` bytes).
    skew_norm : float, optional
        For the series: an upper bound R of the W-norm of A's skew part (default
        :func:`skew_bound`). A LinearOperator needs it for ``method="chebyshev"``.
    max_products : float
        Refuse (:class:`~fvf.errors.FlowOverflowError`) a call estimated to take more
        column products than this (default :data:`MAX_PRODUCTS`); ``inf`` lifts the cap.
    progress : callable, optional
        Called with the fraction done (0..1) as the work advances.
    return_info : bool
        Also return a dict of statistics.

    Returns
    -------
    X : ndarray, float64 (complex128 for complex B)
        ``B.shape`` for a scalar t, ``(T,) + B.shape`` for an array of times;
        ``X[j] = exp(t_j A) B``.
    info : dict, only with ``return_info``
        ``method`` ("chebyshev", "lanczos", "iom", "expm_multiply", or "zero" for A = 0);
        ``matvecs`` (column products with A); ``block_matvecs`` (operator calls);
        ``steps`` (Krylov bases built); ``basis_sizes`` (their sizes; the number of terms
        for the series); ``error_estimate`` (largest relative error estimate; None for
        expm_multiply); ``skew`` (what was used); ``skew_bound`` (R, for the series);
        ``bound_products`` (products with |A| spent on R, not in ``matvecs``);
        ``wasted_matvecs`` (products of a series that gave way, included in
        ``matvecs``); ``estimated_matvecs`` (the work estimate checked against
        ``max_products``).

    Raises
    ------
    ExpmInputError
        Non-square, complex or non-numeric A; B of the wrong shape; non-finite A, B, t or
        weights; weights ≤ 0; tol outside (0, 1); unknown method, norm or skew value;
        m_max < 1; skew_norm not a finite number > 0.
    FlowOverflowError
        (also a FloatingPointError) The result overflowed to inf/NaN; or
        max|t| · ‖A‖_∞ exceeds :data:`MAX_SPAN`; or the estimated work exceeds
        ``max_products`` (the message gives the estimate).

    Warns
    -----
    KrylovFallbackWarning
        ``skew=True`` for an A that is not skew, or ``method="chebyshev"`` whose series
        failed its checks (the Krylov method was used).

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> from fvf.numerics import expm_action
    >>> A = sp.diags_array([np.ones(49), -np.ones(49)], offsets=[1, -1])  # skew
    >>> b = np.sin(np.linspace(0, 3, 50))
    >>> x = expm_action(A, b, [0.5, -1.0, 2.0])
    >>> x.shape, bool(np.allclose(np.linalg.norm(x, axis=1), np.linalg.norm(b)))
    ((3, 50), True)
    """
    if isinstance(A, PreparedOperator):
        if inner is not None:
            raise ExpmInputError("a PreparedOperator carries its inner product; pass inner=None")
        prepared: PreparedOperator | None = A
    else:
        A, n = check_operator(A)
        prepared = None if isinstance(A, spla.LinearOperator) else PreparedOperator(A, inner)
    n = prepared.n if prepared is not None else A.shape[0]
    w = prepared.weights if prepared is not None else check_weights(inner, n)
    times, scalar = as_times(t)
    method, tol = check_options(method, tol)
    check_flags(m_max, norm, skew, skew_norm, max_products)
    Barr, B2, is_complex = check_block(B, n)
    p = B2.shape[1]
    info: dict[str, Any] = {
        "method": None,
        "matvecs": 0,
        "block_matvecs": 0,
        "steps": 0,
        "basis_sizes": [],
        "error_estimate": 0.0,
        "skew": skew,
        "skew_bound": None,
        "bound_products": 0,
        "wasted_matvecs": 0,
        "estimated_matvecs": 0.0,
    }
    out = np.zeros((times.size, n, p))
    a_norm = prepared.norm_inf if prepared is not None else norm_inf(A)
    if n and p and times.size and not a_norm == 0.0:
        if prepared is not None:
            A, times = prepared.A, times * prepared.scale
            skew_norm = None if skew_norm is None else skew_norm / prepared.scale
        skew = _settle_skew(prepared, skew, times, a_norm, info)
        method, radius = _decide(A, prepared, times, skew, skew_norm, method, info)
        _check_work(method, radius, times, p, tol, max_products, n, info)
        job = ExpmJob(B2, times, out, info, tol, w, skew, norm == "max", m_max, progress)
        _run(A, job, method, radius)
    elif n and p:
        out[:] = B2  # A = 0 (or no times): exp(tA) = I
        info["method"] = "zero"
    if not np.isfinite(out).all():
        raise FlowOverflowError(
            "the exponential overflowed to inf/NaN: the solution grows beyond floating "
            "point at these times (shorten t, or use a flow that cannot grow)"
        )
    if info["skew"] and info["method"] in ("chebyshev", "lanczos"):
        _restore_norms(out, B2, w, tol)
    res = out[:, :, : p // 2] + 1j * out[:, :, p // 2 :] if is_complex else out
    res = res.reshape((times.size,) + Barr.shape)
    if scalar:
        res = res[0]
    if progress is not None:
        progress(1.0)
    return (res, info) if return_info else res


def _restore_norms(out: np.ndarray, B2: np.ndarray, w: np.ndarray | None, tol: float) -> None:
    """For a W-skew A, e^{tA} is W-unitary: scale each output column to its initial W-norm
    where it is already within tol of it (so norms are kept to round-off, and the answer
    moves by less than tol)."""
    b = weighted_norms(B2, w)  # (p,)
    for X in out:  # (n, p) per time
        x = weighted_norms(X, w)
        ratio = np.divide(b, x, out=np.ones_like(b), where=x > 0)
        ratio[np.abs(ratio - 1.0) > tol] = 1.0
        X *= ratio


def _settle_skew(
    prepared: PreparedOperator | None,
    skew: bool | None,
    times: np.ndarray,
    a_norm: float,
    info: dict,
) -> bool:
    """Refuse out-of-reach spans and settle whether A is W-skew (measured for an explicit
    A; as declared for a LinearOperator)."""
    if math.isfinite(a_norm):
        span = float(np.abs(times).max()) * a_norm
        if not span <= MAX_SPAN:
            raise FlowOverflowError(
                f"max|t| x ||A||_inf = {span:.3g} exceeds {MAX_SPAN:.0e}: the exponential "
                "needs so many steps that each underflows relative to t. Shorten t or "
                "rescale A (for a flow, a field of speed s for time t moves s*t)."
            )
    if prepared is None:
        result = bool(skew)
    elif skew is False:
        result = False
    else:
        result = prepared.is_skew
        if skew is True and not result:
            warnings.warn(
                "skew=True but A is not skew-adjoint in the given inner product; used the "
                "general method",
                KrylovFallbackWarning,
                stacklevel=3,
            )
    info["skew"] = result
    return result


def _decide(
    A: Any,
    prepared: PreparedOperator | None,
    times: np.ndarray,
    skew: bool,
    skew_norm: float | None,
    method: str,
    info: dict,
) -> tuple[str, float]:
    """The method to run and the radius R it uses (the series' bound, or the work scale)."""
    span = float(np.abs(times).max())
    if skew_norm is not None:
        radius = float(skew_norm)
    elif prepared is not None and (method == "chebyshev" or (method == "auto" and skew)):
        if method == "auto" and prepared.gershgorin * span < SERIES_MIN_TAU:
            radius = prepared.gershgorin  # no power steps: the series is out of the question
        else:
            radius, info["bound_products"] = prepared.bound()
    elif prepared is not None:
        radius = prepared.norm_inf
    else:
        if method == "chebyshev":
            raise ExpmInputError(
                "method='chebyshev' on a LinearOperator needs skew_norm (a bound of the "
                "norm of its skew-adjoint part)"
            )
        radius = norm_inf(A)  # its norm_inf when it has one, else NaN (no work estimate)
    if method == "auto":
        method = choose_method(A.shape[0], times, skew, radius)
    if method == "chebyshev" and radius == 0.0:
        method = "krylov"  # A is W-symmetric: no strip to expand in
    return method, radius


def _check_work(
    method: str,
    radius: float,
    times: np.ndarray,
    p: int,
    tol: float,
    max_products: float,
    n: int,
    info: dict,
) -> None:
    """Refuse a call whose estimated products exceed ``max_products``."""
    if not math.isfinite(radius):
        return  # a LinearOperator without a known norm: no estimate
    span = float(np.abs(times).max())
    est = _product_estimate(method, radius, span, p, tol)
    info["estimated_matvecs"] = est
    if est > max_products:
        raise FlowOverflowError(
            f"this exponential needs about {est:.3g} products with the {n} x {n} operator "
            f"(norm scale {radius:.3g} x max|t| {span:.3g}; {p} column(s)), more than "
            f"max_products={max_products:.3g}. Shorten t, flow fewer columns, use "
            "method='upwind' (a flow with a maximum principle), or raise max_products "
            "(and pass progress= to follow it)."
        )


def _run(A: Any, job: ExpmJob, method: str, radius: float) -> None:
    """Run ``method`` on the job; a Chebyshev series whose terms grow gives way to the
    Krylov method (with a :class:`~fvf.errors.KrylovFallbackWarning`)."""
    op = CountedOperator(A)
    with np.errstate(over="ignore", invalid="ignore"):
        if method == "expm_multiply":
            run_expm_multiply(A, job)
            return
        if method == "chebyshev":
            job.info["skew_bound"] = radius
            if run_chebyshev(op, job, radius):
                _count(op, job.info)
                return
            job.info["wasted_matvecs"] = op.matvecs
            warnings.warn(
                "the Chebyshev series' terms grew (the operator is far from skew); used "
                "the Krylov method",
                KrylovFallbackWarning,
                stacklevel=3,
            )
        run_krylov(op, job)
    _count(op, job.info)


def _count(op: CountedOperator, info: dict) -> None:
    info["matvecs"] = op.matvecs
    info["block_matvecs"] = op.calls
