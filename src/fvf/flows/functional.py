r"""Functional flows :math:`\Phi_{v,t} = e^{-tD^V_v}` applied to functions (chapter §3.4–3.5).

:math:`f(t) = \Phi_{v,t} f_0` solves :math:`\dot f = -D^V_v f` (docs/chapter.md, eq. (43)):
the function is carried along the flow of v. The exponential is never formed; its action
is computed by :func:`fvf.numerics.expm_action` in the :math:`A_V` inner product, all
requested times and columns in one pass.

Growth. For rotated gradients :math:`v = J\nabla g` on a closed mesh,
:math:`[A_V] D^V_v` is skew-symmetric and the flow keeps the :math:`A_V`-norm exactly. For
other fields the discrete flow can grow a function's norm by many orders of magnitude on
fine or irregular meshes (docs/chapter.md, "Facts we measured"). Every call measures the
growth it produced, :math:`\max_j \|f(t_j)\|_{A_V} / \|f_0\|_{A_V}` (free: the outputs
are there), and warns (:class:`~fvf.errors.FlowGrowthWarning`, once per call) when it
exceeds ``growth_limit``, naming where the discrete divergence of v is largest. A bound
valid for every :math:`f_0`, :math:`e^{\mu t}` with :math:`\mu` the logarithmic norm, is
:attr:`FunctionalFlow.growth_rate` — an eigensolve, computed only when asked for.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from functools import cached_property

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from ..calculus import div
from ..errors import (
    FlowGrowthWarning,
    FlowOverflowError,
    format_indices,
    user_stacklevel,
)
from ..mesh.convert import takes_mesh
from ..mesh.inputs import (
    TangentPolicy,
    as_face_field,
    as_growth_limit,
    as_vertex_function,
    max_row_norm,
)
from ..mesh.trimesh import TriMesh
from ..numerics.expm import MAX_PRODUCTS, PreparedOperator, as_times, check_options, expm_action
from ..numerics.progress import ProgressCallback, fraction_reporter, make_progress
from ..operators.directional import D_V

__all__ = ["FunctionalFlow", "GROWTH_LIMIT", "hotspots", "observed_growth"]

#: Default limit on a flow's growth of the A_V-norm above which it warns.
GROWTH_LIMIT = 100.0


@takes_mesh
def hotspots(mesh: TriMesh, score: np.ndarray, count: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` vertices of largest ``score`` (n,) and the faces around them.

    Returns (vertices (≤ count,) int64, by decreasing score; faces (k,) int64, sorted):
    where a growth warning points the user to.
    """
    worst = np.argsort(score, kind="stable")[-count:][::-1]
    faces = np.flatnonzero(np.isin(mesh.faces, worst).any(axis=1))
    return worst.astype(np.int64), faces.astype(np.int64)


def observed_growth(weights: np.ndarray, f0: np.ndarray, out: np.ndarray) -> tuple[float, float]:
    """How much a flow grew its functions: (A_V-norm ratio, max-norm ratio), each the
    largest over times and columns of ‖f(t_j)‖ / ‖f_0‖ (0 when f_0 = 0).

    The continuous transport keeps the max norm (a maximum principle) and, for
    divergence-free fields, the L2 norm; either ratio far above 1 is the discrete flow's
    own growth.

    Parameters
    ----------
    weights : (n,) float64
        The inner product's weights (A_V).
    f0 : (n,) or (n, k) float64
    out : (T, n) or (T, n, k) float64
        The flowed values.
    """
    f0 = f0.reshape(f0.shape[0], -1)
    out = out.reshape(out.shape[0], out.shape[1], -1)
    scale = np.abs(f0).max() if f0.size else 0.0
    if scale == 0 or out.size == 0:
        return 0.0, 0.0
    g0, gt = f0 / scale, out / scale
    n0 = np.sqrt(weights @ g0**2)  # (k,)
    nt = np.sqrt(np.einsum("i,tij->tj", weights, gt**2))  # (T, k)
    m0 = np.abs(g0).max(axis=0)  # (k,)
    mt = np.abs(gt).max(axis=1)  # (T, k)
    live = n0 > 0
    if not live.any():
        return 0.0, 0.0
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        return float((nt[:, live] / n0[live]).max()), float((mt[:, live] / m0[live]).max())


def finite_operator(build: Callable[[], sp.sparray], field: np.ndarray) -> sp.sparray:
    """The flow's operator A (sparse) ``build()`` forms, refused with
    :class:`FlowOverflowError` when a field of finite but huge length (1e308) overflowed
    its entries to inf: the flow of s·v for time t is the flow of v for time s·t. numpy's
    overflow warnings while it forms are silenced: the error says it once."""
    with np.errstate(over="ignore", invalid="ignore"):
        A = build()
    if sp.issparse(A) and not np.isfinite(A.data).all():
        raise FlowOverflowError(
            f"the operator of this field overflows (max |v| = {max_row_norm(field):.3g}): "
            "scale the field down by s and the times up by s (the same flow)"
        )
    return A


class FunctionalFlow:
    r"""The functional flow of a tangent field: :math:`\Phi_{v,t} = e^{-tD^V_v}` (eq. 42).

    Keeps :math:`D^V_v` and what the exponential learns about it (whether it is
    :math:`A_V`-skew, the bound R of its spectrum), so flowing many functions or times of
    one field pays for them once.

    Parameters
    ----------
    mesh : TriMesh
    v : array_like, (m, 3)
        Tangent field per face (a normal component is projected away with a warning).
    growth_limit : float
        Warn (:class:`~fvf.errors.FlowGrowthWarning`) when a call grows a function's
        :math:`A_V`-norm or its largest absolute value by more than this factor (the
        continuous flow grows neither: a maximum principle); ``np.inf`` silences it.
    tangent : {"project", "raise", "ignore"}
        What to do with a normal component of v (see :func:`fvf.as_face_field`).
    method : {"auto", "krylov", "chebyshev", "expm_multiply"}
        The exponential action (:func:`fvf.numerics.expm_action`); "auto" runs the
        Chebyshev series for divergence-free fields over a few edge lengths and the
        Krylov method otherwise.
    tol : float
        Target relative error of the exponential action (default 1e-10).
    max_products : float
        Refuse a call estimated to take more products than this
        (:data:`fvf.numerics.expm.MAX_PRODUCTS` by default): a typed error says what the
        work is and how to reduce it.
    progress : None, bool or callable
        ``True`` for a tqdm bar, or a callback ``(stage, done, total)``
        (:mod:`fvf.numerics.progress`; stage ``"flow"``, done of 1000) during long calls.

    Attributes
    ----------
    operator : scipy.sparse.csr_array, (n, n)
        :math:`D^V_v` (eq. 36).
    stats : dict
        Statistics of the last call (``method``, ``matvecs``, ``error_estimate``, … of
        :func:`fvf.numerics.expm_action`) and ``growth``, the observed
        :math:`\max_j \|f(t_j)\|_{A_V}/\|f_0\|_{A_V}`.

    Notes
    -----
    No boundary condition is imposed: on a mesh with boundary the flow is that of the
    assembled :math:`D^V_v`, and even a field :math:`J\nabla g` (divergence-free inside)
    can change the norm through boundary vertices.

    Examples
    --------
    >>> import numpy as np, fvf
    >>> mesh = fvf.icosphere(2)
    >>> v = fvf.rotate(mesh, fvf.gradient(mesh, mesh.vertices[:, 2]))  # rotation about z
    >>> phi = fvf.FunctionalFlow(mesh, v)
    >>> f0 = mesh.vertices[:, 0]
    >>> f1 = phi(f0, 0.3)
    >>> bool(abs(phi.norm(f1) - phi.norm(f0)) < 1e-12)  # J grad g flows keep the norm
    True
    """

    @takes_mesh
    def __init__(
        self,
        mesh: TriMesh,
        v: npt.ArrayLike,
        *,
        growth_limit: float = GROWTH_LIMIT,
        tangent: TangentPolicy = "project",
        method: str = "auto",
        tol: float = 1e-10,
        max_products: float = MAX_PRODUCTS,
        progress: bool | ProgressCallback | None = None,
    ) -> None:
        method, tol = check_options(method, tol)
        make_progress(progress)  # a bad value fails here, not at the first call
        self.mesh = mesh
        self.field = as_face_field(mesh, v, "v", tangent)
        self.operator = finite_operator(lambda: D_V(mesh, self.field, tangent="ignore"), self.field)
        self.growth_limit = as_growth_limit(growth_limit)
        self.method = method
        self.tol = float(tol)
        self.max_products = max_products
        self.progress = progress
        self.stats: dict = {}

    @cached_property
    def generator(self) -> PreparedOperator:
        r""":math:`-D^V_v` in the :math:`A_V` inner product, with what the exponential learns
        about it (skewness, the bound R) kept between calls."""
        return PreparedOperator(-self.operator, self.mesh.vertex_areas)

    @property
    def is_skew(self) -> bool:
        r"""Whether :math:`[A_V] D^V_v` is skew-symmetric to round-off
        (:math:`v = J\nabla g` on a closed mesh): the flow is then :math:`A_V`-unitary."""
        return self.generator.is_skew

    @property
    def skew_norm(self) -> float:
        r"""Upper bound R of the :math:`A_V`-norm of :math:`D^V_v`'s skew part
        (:func:`fvf.numerics.expm.skew_bound`): the spectrum of the skew part lies in
        :math:`|\mathrm{Im}\,z| \le R`."""
        return self.generator.bound()[0] * self.generator.scale

    @cached_property
    def _symmetric_part(self) -> sp.csr_array:
        """−½ A^{-1/2} (A D + Dᵀ A) A^{-1/2}: its spectrum bounds the A_V-norm growth."""
        s = sp.diags_array(1.0 / np.sqrt(self.mesh.vertex_areas))
        AD = (sp.diags_array(self.mesh.vertex_areas) @ self.operator).tocsr()
        return (-0.5 * (s @ (AD + AD.T) @ s)).tocsr()

    def _extreme_eigenvalue(self, sign: float) -> float:
        S = sign * self._symmetric_part
        n = S.shape[0]
        if S.nnz == 0 or not np.any(S.data):
            return 0.0  # e.g. v = 0: the flow is the identity
        if n <= 64:
            return float(np.linalg.eigvalsh(S.toarray())[-1])
        try:
            lam = sla.eigsh(
                S,
                k=1,
                which="LA",
                tol=1e-4,
                return_eigenvectors=False,
                v0=np.full(n, 1.0 / np.sqrt(n)) + 1e-3 * np.arange(n) / n,
            )
            return float(lam[0])
        except sla.ArpackNoConvergence as exc:  # fall back to a guaranteed upper bound
            if exc.eigenvalues.size:
                return float(exc.eigenvalues.max())
            return float(abs(S).sum(axis=1).max())  # Gershgorin
        except sla.ArpackError:
            return float(abs(S).sum(axis=1).max())  # Gershgorin

    @cached_property
    def growth_rate(self) -> tuple[float, float]:
        r"""(μ₊, μ₋): :math:`A_V`-logarithmic norms of :math:`-D^V_v` and :math:`+D^V_v`.

        :math:`\|\Phi_{v,t} f\| \le e^{\mu_+ t}\|f\|` for t ≥ 0 and
        :math:`\le e^{\mu_- |t|}\|f\|` for t < 0, for every f. Both are 0 for skew
        operators (no eigensolve then); otherwise one ARPACK solve each, computed on first
        access only.
        """
        if self.is_skew:
            return 0.0, 0.0
        return max(self._extreme_eigenvalue(1.0), 0.0), max(self._extreme_eigenvalue(-1.0), 0.0)

    def growth_bound(self, t: float) -> float:
        r"""Upper bound on :math:`\|\Phi_{v,t} f\|_{A_V} / \|f\|_{A_V}` over all f,
        :math:`e^{\mu|t|}` (an eigensolve on first use, see :attr:`growth_rate`)."""
        mu = self.growth_rate[0] if t >= 0 else self.growth_rate[1]
        with np.errstate(over="ignore"):
            return float(np.exp(mu * abs(t)))

    def norm(self, f: npt.ArrayLike) -> float:
        """A_V-norm (eq. 26) of a PL function (n,)."""
        f = np.asarray(f, dtype=float)
        return float(np.sqrt(np.einsum("i,i...->...", self.mesh.vertex_areas, f * f).sum()))

    def _where(self, forward: bool) -> str:
        """Where the discrete divergence of v is largest (the growth's source)."""
        divv = div(self.mesh) @ self.field.ravel()
        worst, faces = hotspots(self.mesh, divv if forward else -divv)
        return (
            f"The discrete divergence of v is largest at vertices {format_indices(worst)}, "
            f"in faces {format_indices(faces)}"
        )

    def _warn_growth(self, growth: tuple[float, float], times: np.ndarray) -> None:
        if not max(growth) > self.growth_limit:
            return
        warnings.warn(
            f"the flow to t={float(np.abs(times).max()):g} grew a function's A_V-norm by "
            f"{growth[0]:.3g}x and its largest value by {growth[1]:.3g}x (limit "
            f"{self.growth_limit:g}). {self._where(times.max() > 0)}; "
            "the chapter's flow is not monotone for compressible fields on irregular "
            "meshes. Use a shorter time, a divergence-free field (J grad g), method='upwind' "
            "(bounded by [min f_0, max f_0]), or pass growth_limit=np.inf to accept it.",
            FlowGrowthWarning,
            stacklevel=user_stacklevel(),
        )

    def __call__(self, f: npt.ArrayLike, t: float | npt.ArrayLike) -> np.ndarray:
        r""":math:`\Phi_{v,t} f` for one time or an array of times.

        Parameters
        ----------
        f : array_like, (n,) or (n, k)
            PL function(s) at time 0.
        t : float or array_like (T,)
            Time(s), any sign and order, all in one pass. An empty array gives an empty
            result of shape ``(0,) + f.shape``.

        Returns
        -------
        ndarray, float64
            ``f.shape`` for a scalar t; ``(T,) + f.shape`` for an array.

        Raises
        ------
        FlowOverflowError
            (also a FloatingPointError) The flow overflowed to inf/NaN, |t| · ‖D^V_v‖ is
            out of floating-point reach, or the work exceeds ``max_products``.

        Warns
        -----
        FlowGrowthWarning
            When the call grew a function's norm beyond ``growth_limit``.
        """
        f0 = as_vertex_function(self.mesh, f, "f", columns=True)
        times, scalar = as_times(t)
        if times.size == 0:  # no times, no frames (as every method of fvf.flow)
            return np.empty((0,) + f0.shape)
        try:
            out, self.stats = expm_action(
                self.generator,
                f0,
                times,
                tol=self.tol,
                method=self.method,
                max_products=self.max_products,
                progress=fraction_reporter(self.progress, "flow"),
                return_info=True,
            )
        except FlowOverflowError as exc:
            if "overflowed" not in str(exc):
                raise
            raise FlowOverflowError(
                f"the flow overflowed to inf/NaN. {self._where(times.max() > 0)}. Use "
                "shorter times, a divergence-free field, or method='upwind'."
            ) from exc
        growth = observed_growth(self.mesh.vertex_areas, f0, out)
        self.stats["growth"] = growth
        self._warn_growth(growth, times)
        return out[0] if scalar else out
