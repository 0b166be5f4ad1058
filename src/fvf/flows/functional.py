"""Functional flows Φ_{v,t} = exp(−t D^V_v) applied to functions (chapter §3.4–3.5).

f(t) = Φ_{v,t} f_0 solves df/dt = −D^V_v f (eq. 43): the function is carried along the
flow of v. The exponential is never formed; its action on vectors is computed by
:func:`fvf.numerics.expm.expm_action` (a Chebyshev series in D^V_v/R, R a bound of the spectrum's
extent along the imaginary axis, or adaptive Krylov time stepping in the A_V inner
product; all requested times and all columns in one pass; ``method="expm_multiply"``
selects :func:`scipy.sparse.linalg.expm_multiply`, Al-Mohy & Higham 2011, chained over
the times).

Growth. For rotated gradients v = J grad g, [A_V] D^V_v is skew-symmetric and the flow
keeps the A_V-norm. For other fields the discrete flow can grow a function's norm by
many orders of magnitude on fine or irregular meshes (``docs/notes.md``,
CHAPTER.md "Facts we measured"). Before flowing, :class:`FunctionalFlow` estimates the
A_V-logarithmic norm μ of −D^V_v (the largest eigenvalue of its A_V-symmetric part, by
a few Lanczos steps); ‖f(t)‖_{A_V} ≤ e^{μ t} ‖f_0‖_{A_V} for every f_0 and t ≥ 0.
When this bound exceeds ``growth_limit`` (default :data:`GROWTH_LIMIT`) a
:class:`~fvf.errors.FlowGrowthWarning` says by how much and where.
"""

from __future__ import annotations

import warnings
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
from ..mesh.inputs import TangentPolicy, as_face_field, as_growth_limit, as_vertex_function
from ..mesh.trimesh import TriMesh
from ..numerics.expm import (
    _abs_of,
    _estimated_radius,
    as_times,
    check_options,
    expm_action,
    skew_bound,
)
from ..operators.directional import D_V

__all__ = ["FunctionalFlow", "GROWTH_LIMIT", "hotspots"]

#: Default bound on the estimated norm growth e^{μ|t|} above which a flow warns.
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


class FunctionalFlow:
    """The functional flow of a tangent field: Φ_{v,t} = exp(−t D^V_v) (eq. 42).

    Keeps D^V_v and its growth-rate estimates, so flowing many functions or times of one
    field pays for them once.

    Parameters
    ----------
    mesh : TriMesh
    v : array_like, (m, 3)
        Tangent field per face (a normal component is projected away with a warning).
    growth_limit : float
        Warn (:class:`~fvf.errors.FlowGrowthWarning`) when the estimated bound on
        ‖f(t)‖/‖f_0‖ exceeds this.
    tangent : {"project", "raise", "ignore"}
        What to do with a normal component of v (see :func:`fvf.mesh.inputs.as_face_field`).
    method : {"auto", "krylov", "chebyshev", "expm_multiply"}
        Exponential action (:func:`fvf.numerics.expm.expm_action`); "auto" uses the Chebyshev
        series for t beyond a few edge lengths, the Krylov method for shorter times and
        expm_multiply on tiny meshes (:func:`fvf.numerics.expm.choose_method`).
    tol : float
        Target relative error of the exponential action (default 1e-10).

    Attributes
    ----------
    operator : scipy.sparse.csr_array, (n, n)
        D^V_v (eq. 36).
    stats : dict
        Statistics of the last call: ``method``, ``matvecs`` (column products with
        D^V_v), ``error_estimate`` … (see :func:`fvf.numerics.expm.expm_action`).

    Notes
    -----
    No boundary condition is imposed: on a mesh with boundary the flow is that of the
    assembled D^V_v, and even a field J grad g (divergence-free inside) can grow the norm
    through boundary vertices; the growth estimate accounts for it.

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
    ) -> None:
        method, tol = check_options(method, tol)
        self.mesh = mesh
        self.field = as_face_field(mesh, v, "v", tangent)
        self.operator = D_V(mesh, self.field, tangent="ignore")
        self.growth_limit = as_growth_limit(growth_limit)
        self.method = method
        self.tol = float(tol)
        self.stats: dict = {}

    @cached_property
    def skew_norm(self) -> float:
        """Upper bound R of the norm of D^V_v's A_V-skew part (:func:`~.expm.skew_bound`):
        the spectrum lies in |Im z| ≤ R. Computed once, for the Chebyshev series."""
        return skew_bound(self.operator, self.mesh.vertex_areas)

    @cached_property
    def _series_radius(self) -> float:
        """The radius R of the Chebyshev series for a field that is not skew: 1.02× the
        Lanczos estimate θ ≤ ‖K‖ of the skew part's norm, capped by :attr:`skew_norm`
        (the bound itself if θ did not converge). That series' stop is a posteriori, so
        R need not be a bound (``fvf.numerics.expm._bound``, docs/flows.md); on spot it is 1.02×
        ‖K‖ against the bound's 1.15–1.18×, ~10 % fewer terms a call for 30–40 products
        once."""
        A = self.operator
        estimate, _ = _estimated_radius(A, self.mesh.vertex_areas, _abs_of(A))  # (±D^V_v)
        return self.skew_norm if estimate is None else min(self.skew_norm, estimate)

    @cached_property
    def is_skew(self) -> bool:
        """Whether [A_V] D^V_v is skew-symmetric to round-off (v = J grad g, closed mesh):
        the flow is then A_V-unitary and the three-term Lanczos recurrence applies."""
        return self._asymmetry <= 1e-12

    @cached_property
    def _asymmetry(self) -> float:
        """max|[A_V]D + ([A_V]D)ᵀ| / max|[A_V]D| (0 for a skew one, and for D = 0)."""
        AD = self._weighted
        scale = float(abs(AD).max()) if AD.nnz else 0.0
        asym = AD + AD.T
        return float(abs(asym).max() if asym.nnz else 0.0) / scale if scale else 0.0

    @property
    def _skew_argument(self) -> bool | None:
        """``skew`` for :func:`fvf.numerics.expm.expm_action`: True for a skew operator, False for
        one far from it (Lanczos' own check would refuse it after a product and ~0.2 ms of
        set-up: 1.1–1.2× the time of a short compressible flow at 6k–10k faces), None
        (let Lanczos check) in between."""
        if self.is_skew:
            return True
        return False if self._asymmetry > 1e-9 else None

    @cached_property
    def _weighted(self) -> sp.csr_array:
        """[A_V] D^V_v (n, n): its symmetric part decides skewness and bounds growth."""
        return (sp.diags_array(self.mesh.vertex_areas) @ self.operator).tocsr()

    @cached_property
    def _symmetric_part(self) -> sp.csr_array:
        """−½ A^{-1/2} (A D + Dᵀ A) A^{-1/2}: its spectrum bounds the A_V-norm growth."""
        s = sp.diags_array(1.0 / np.sqrt(self.mesh.vertex_areas))
        AD = self._weighted
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
        """(μ₊, μ₋): A_V-logarithmic norms of −D^V_v and +D^V_v.

        ‖Φ_{v,t} f‖ ≤ e^{μ₊ t}‖f‖ for t ≥ 0 and ≤ e^{μ₋ |t|}‖f‖ for t < 0 (A_V-norm). Both
        are 0 (to round-off) for divergence-free fields v = J grad g.
        """
        return max(self._extreme_eigenvalue(1.0), 0.0), max(self._extreme_eigenvalue(-1.0), 0.0)

    def growth_bound(self, t: float) -> float:
        """Upper bound on ‖Φ_{v,t} f‖_{A_V} / ‖f‖_{A_V} over all f (an estimate: Lanczos)."""
        mu = self.growth_rate[0] if t >= 0 else self.growth_rate[1]
        with np.errstate(over="ignore"):
            return float(np.exp(mu * abs(t)))

    def norm(self, f: npt.ArrayLike) -> float:
        """A_V-norm (eq. 26) of a PL function (n,)."""
        f = np.asarray(f, dtype=float)
        return float(np.sqrt(np.einsum("i,i...->...", self.mesh.vertex_areas, f * f).sum()))

    def _warn_growth(self, t_extreme: float) -> bool:
        """Warn if the growth bound to ``t_extreme`` exceeds growth_limit; return whether."""
        bound = self.growth_bound(t_extreme)
        if bound <= self.growth_limit:
            return False
        divv = div(self.mesh) @ self.field.ravel()
        worst, faces = hotspots(self.mesh, divv if t_extreme >= 0 else -divv)
        warnings.warn(
            f"the flow to t={t_extreme:g} may grow a function's A_V-norm by up to "
            f"{bound:.3g}x (growth rate {self.growth_rate[0 if t_extreme >= 0 else 1]:.3g} "
            f"per unit time; limit {self.growth_limit:g}). The discrete divergence of v is "
            f"largest at vertices {format_indices(worst)}, in faces "
            f"{format_indices(faces)}; the chapter's flow is not "
            "monotone for compressible fields on irregular meshes. Use a shorter time, a "
            "divergence-free field (J grad g), or a smoother/remeshed surface; pass "
            "growth_limit=np.inf to silence this.",
            FlowGrowthWarning,
            stacklevel=user_stacklevel(),
        )
        return True

    def __call__(self, f: npt.ArrayLike, t: float | npt.ArrayLike) -> np.ndarray:
        """Φ_{v,t} f for one time or an array of times.

        Parameters
        ----------
        f : array_like, (n,) or (n, k)
            PL function(s) at time 0.
        t : float or array_like (T,)
            Time(s), any sign and order; all are computed in one Krylov pass per sign
            (dense output inside each step; the semigroup Φ_{t+s} = Φ_t Φ_s, Lemma 11,
            across steps).

        Returns
        -------
        ndarray, float64
            ``f.shape`` for a scalar t; ``(T,) + f.shape`` for an array.

        Raises
        ------
        FlowOverflowError
            (also a FloatingPointError) If the flow overflowed to inf/NaN (after the
            growth warning), or |t| · ‖D^V_v‖ is out of floating-point reach.

        Warns
        -----
        FlowGrowthWarning
            When the estimated growth bound exceeds ``growth_limit``.
        """
        f0 = as_vertex_function(self.mesh, f, "f", columns=True)
        times, scalar = as_times(t)
        if times.size == 0:  # no times, no frames (as every method of fvf.flow)
            return np.empty((0,) + f0.shape)
        grows = False
        for extreme in (times.max(), times.min()):
            if extreme != 0:
                grows |= self._warn_growth(float(extreme))
        # a flow that may grow past growth_limit makes the Chebyshev terms grow as well:
        # "auto" goes straight to the Krylov method, which has no such terms
        method = "krylov" if grows and self.method == "auto" else self.method
        # the cached radius R, for operators whose "auto" always needs it: a skew operator
        # gets Lanczos for several times or large meshes, and otherwise bounds itself at
        # one product per power step
        bound = None
        if method in ("auto", "chebyshev") and not self.is_skew:
            bound = self._series_radius or None
        out, self.stats = expm_action(
            -self.operator,
            f0,
            times,
            tol=self.tol,
            inner=self.mesh.vertex_areas,
            skew=self._skew_argument,
            method=method,
            skew_norm=bound,
            return_info=True,
        )
        if not np.isfinite(out).all():
            raise FlowOverflowError(
                f"the flow overflowed (growth bound {self.growth_bound(times.max()):.3g}); "
                "use shorter times or a divergence-free field."
            )
        return out[0] if scalar else out
