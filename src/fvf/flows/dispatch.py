"""Flows of functions along tangent fields, with guarantees on real meshes.

Beside the chapter's flow exp(−t D^V_v) (:mod:`fvf.flow`, the default), this module offers
transport operators and time integrators whose behaviour is guaranteed for every field.
``docs/flows.md`` has the derivations and the measurements:

``"upwind"``
    exp(−t G), with G the first-order upwind finite-volume operator on the barycentric
    dual cells (:func:`upwind_operator`). −G has non-negative off-diagonal entries and
    G 1 = 0, so exp(−t G) is row-stochastic: f(t) stays within [min f_0, max f_0] on every
    mesh, for every field. It is applied by uniformization, where every term is a convex
    combination. First order; it smears.
``"skew"``
    exp(−t S), with S = ½(D^V_v + D̃^V_v) (:func:`skew_operator`): the A_V-skew part of
    D^V_v minus ½[div v]. Its flow obeys d/dt ‖f‖² = ⟨f, [div v] f⟩ exactly (A_V inner
    product), as the continuous transport does. It keeps the norm for div v = 0. For
    compressible fields the law allows growth like e^{½ max(div v) t}, and the discrete
    divergence of a smooth field reaches the thousands on real meshes, so the flow warns
    (:class:`~fvf.errors.FlowGrowthWarning`) as the chapter's does.
``"cayley"``
    Implicit midpoint (Cayley) steps (I + h/2 S) f_{k+1} = (I − h/2 S) f_k, with one
    sparse LU per step length (the integrator of Azencot et al. 2014). It keeps the
    A_V-norm exactly when div v = 0. Otherwise it obeys the discrete law
    ‖f_{k+1}‖² − ‖f_k‖² = h ⟨f_{k+½}, [div v] f_{k+½}⟩.
``"spectral"``
    The reduced flow in k Laplace–Beltrami eigenfunctions
    (:meth:`fvf.SpectralBasis.reduced_flow`). It lives with the bases in
    :mod:`fvf.spectral.reduced_flows`, a layer above this one, which registers it here
    (:func:`register_flow_method`); ``import fvf`` imports it.

Use :func:`flow` for a single call. :class:`TransportFlow` keeps the operator, the
factorizations and the work counts for several functions and times.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from ..calculus import div
from ..errors import (
    FlowGrowthWarning,
    FlowOverflowError,
    ParameterError,
    format_indices,
    user_stacklevel,
)
from ..mesh.convert import takes_mesh
from ..mesh.inputs import (
    TangentPolicy,
    as_face_field,
    as_growth_limit,
    as_positive,
    as_vertex_function,
    max_row_norm,
)
from ..mesh.trimesh import TriMesh
from ..numerics.expm import MAX_PRODUCTS, as_times, expm_action
from ..numerics.progress import fraction_reporter
from ..operators.directional import directional_derivatives
from .functional import (
    GROWTH_LIMIT,
    FunctionalFlow,
    finite_operator,
    hotspots,
    observed_growth,
)

__all__ = [
    "METHODS",
    "DEFAULT_COURANT",
    "dual_edge_fluxes",
    "upwind_operator",
    "skew_operator",
    "TransportFlow",
    "flow",
    "register_flow_method",
]

#: The flow methods of :func:`flow`, the chapter's first (the default).
METHODS = ("chapter", "upwind", "skew", "cayley", "spectral")

#: Default Courant number of the Cayley steps: h = c · mean edge length / max |v|.
DEFAULT_COURANT = 0.5

#: Largest Poisson mean q·t per uniformization chunk (e^{−q t} stays far from underflow).
_UNIFORMIZATION_CHUNK = 300.0

_OPTIONS = {
    "chapter": {"growth_limit", "expm", "tol", "max_products", "progress"},
    "upwind": {"max_products"},
    "skew": {"growth_limit", "expm", "tol", "max_products", "progress"},
    "cayley": {"growth_limit", "dt", "courant", "operator", "max_products"},
    "spectral": {"k", "basis"},
}

#: The methods this module implements itself.
_OWN = ("chapter", "upwind", "skew", "cayley")

#: The methods of :data:`METHODS` implemented in a layer above this one (a layer never
#: imports upward, docs/architecture.md), by name: ``build(mesh, field, options)`` -> a
#: flow whose call maps f_0 float64 (n, c) and times float64 (T,) to (T, n, c).
_REGISTERED: dict[str, Callable[[TriMesh, np.ndarray, dict[str, Any]], Any]] = {}


def register_flow_method(
    name: str, build: Callable[[TriMesh, np.ndarray, dict[str, Any]], Any]
) -> None:
    """Implement the flow method ``name`` of :data:`METHODS` from a layer above this one.

    :mod:`fvf.spectral.reduced_flows` registers ``"spectral"`` when :mod:`fvf.spectral` is
    imported (``import fvf`` imports it).

    Parameters
    ----------
    name : str
        One of :data:`METHODS` that this module does not implement itself.
    build : callable
        ``build(mesh, field, options)``, with the checked tangent field float64 (m, 3) and
        the method's options (a dict, names already checked), returns the flow: a callable
        ``(f0, times)`` mapping f_0 float64 (n, c) and times float64 (T,) to (T, n, c).
        Its ``basis`` attribute, if any, becomes :attr:`TransportFlow.basis`.
    """
    if name not in METHODS or name in _OWN:
        raise ValueError(f"{name!r} is not a flow method that fvf.flow leaves to a layer above")
    _REGISTERED[name] = build


# ---------------------------------------------------------------------------- operators
@takes_mesh
def dual_edge_fluxes(
    mesh: TriMesh, v: npt.ArrayLike, tangent: TangentPolicy = "project"
) -> sp.csr_array:
    """Flux of v through the barycentric dual edges: sparse (n, n), antisymmetric.

    The barycentric dual cell of vertex i is bounded, inside each face t ∋ i, by the
    segments from the midpoints of the two edges at i to the centroid of t; its area is
    A_V(i). Entry (i, j) is the flux of v from cell i into cell j through the dual edge
    of the mesh edge ij (two segments, one per face of the edge)::

        F_ij = Σ_{t ∋ i, j} (A_F(t) / 3) ⟨v(t), ∇φ_j − ∇φ_i⟩.

    (A_F(t)/3)(∇φ_j − ∇φ_i) is the normal of the segment from the midpoint of ij to the
    centroid of t, scaled by its length and pointing from i to j: it is orthogonal to the
    level line φ_i = φ_j through both points. F is antisymmetric with zero diagonal, and
    its rows sum to the weak divergence: Σ_j F_ij = A_V(i) (div v)_i (eq. 29).

    Parameters
    ----------
    mesh : TriMesh
    v : array_like (m, 3)
        Tangent field per face.
    tangent : {"project", "raise", "ignore"}
        See :func:`fvf.as_face_field`.

    Returns
    -------
    scipy.sparse.csr_array (n, n)
        On the mesh's 1-ring pattern (diagonal stored as explicit zeros).
    """
    v = as_face_field(mesh, v, "v", tangent)
    d = directional_derivatives(mesh, v)  # (m, 3): ⟨v(t), ∇φ_b⟩
    local = (mesh.face_areas / 3.0)[:, None, None] * (d[:, None, :] - d[:, :, None])
    return mesh.assemble_vertex_operator(local)


def _rows_and_diagonal(A: sp.csr_array) -> tuple[np.ndarray, np.ndarray]:
    rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
    return rows, rows == A.indices


@takes_mesh
def upwind_operator(
    mesh: TriMesh, v: npt.ArrayLike, tangent: TangentPolicy = "project"
) -> sp.csr_array:
    """G: the first-order upwind transport generator, sparse (n, n); df/dt = −G f.

    Finite volumes on the barycentric dual cells for ∂f/∂t + ⟨v, ∇f⟩ = 0, written as
    ∂f/∂t + div(f v) − f div v = 0 and integrated over cell i with the dual-edge fluxes
    F_ij of :func:`dual_edge_fluxes`, taking on each dual edge the upwind value (f_i for
    outflow F_ij > 0, f_j for inflow F_ij < 0)::

        A_V(i) df_i/dt = −Σ_j F_ij f_upwind(ij) + f_i Σ_j F_ij = −Σ_j F⁻_ij (f_i − f_j),

    F⁻_ij = max(−F_ij, 0), the inflow. So G_ij = −F⁻_ij / A_V(i) ≤ 0 for j ≠ i and
    G_ii = Σ_j F⁻_ij / A_V(i) ≥ 0: −G has non-negative off-diagonal entries and
    G 1 = 0, hence exp(−t G) is row-stochastic for t ≥ 0 and f(t) stays within
    [min f_0, max f_0] (a discrete maximum principle, on every mesh, for every field).

    Equivalently G = S + [A_V]⁻¹ L_w with S = :func:`skew_operator` (the central-flux
    scheme) and L_w the graph Laplacian of the symmetric weights w_ij = |F_ij| / 2: the
    upwind scheme is the skew one plus numerical diffusion of size O(h |v|), which makes
    it first-order (``docs/flows.md``).

    Returns
    -------
    scipy.sparse.csr_array (n, n)
        On the 1-ring pattern; rows sum to 0 (to round-off).
    """
    F = dual_edge_fluxes(mesh, v, tangent)
    rows, on_diag = _rows_and_diagonal(F)
    data = np.minimum(F.data, 0.0) / mesh.vertex_areas[rows]  # −F⁻_ij / A_V(i)
    data[on_diag] = 0.0
    data[on_diag] = -np.bincount(rows, weights=data, minlength=mesh.n_vertices)
    return sp.csr_array((data, F.indices, F.indptr), shape=F.shape)


@takes_mesh
def skew_operator(
    mesh: TriMesh, v: npt.ArrayLike, tangent: TangentPolicy = "project"
) -> sp.csr_array:
    """S = ½(D^V_v + D̃^V_v): A_V-skew part of D^V_v minus ½[div v]; df/dt = −S f.

    Continuously ⟨v, ∇f⟩ = (⟨v, ∇f⟩ + ½ f div v) − ½ f div v, the first term skew in
    L², so the transport ∂f/∂t = −⟨v, ∇f⟩ obeys d/dt ∫f² = ∫ (div v) f². Discretely,
    with the A_V-adjoint of D^V_v equal to −(D̃^V_v + [div v]) (docs/chapter.md, "Facts we
    measured")::

        S = ½(D^V_v − [A_V]⁻¹ (D^V_v)ᵀ [A_V]) − ½[div v] = ½(D^V_v + D̃^V_v),

    so [A_V] S + Sᵀ [A_V] = −[A_V]·[div v] and the flow df/dt = −S f satisfies
    d/dt ‖f‖²_{A_V} = ⟨f, [div v] f⟩_{A_V} exactly. S is also the central-flux finite
    volume scheme on the barycentric dual cells: S_ij = F_ij / (2 A_V(i)) for j ≠ i and
    S_ii = −½ (div v)_i, F from :func:`dual_edge_fluxes`. S 1 = 0. S is consistent
    (the average of two consistent operators) and equals D^V_v when div v = 0
    (v = J grad g).

    Returns
    -------
    scipy.sparse.csr_array (n, n)
        On the 1-ring pattern.
    """
    F = dual_edge_fluxes(mesh, v, tangent)
    rows, on_diag = _rows_and_diagonal(F)
    data = 0.5 * F.data / mesh.vertex_areas[rows]
    data[on_diag] = 0.0
    data[on_diag] = -np.bincount(rows, weights=data, minlength=mesh.n_vertices)
    return sp.csr_array((data, F.indices, F.indptr), shape=F.shape)


# ---------------------------------------------------------------------------- integrators
def _poisson_weights(lam: float, tol: float = 1e-18) -> np.ndarray:
    """Poisson(λ) probabilities for k = 0..K, truncated where the tail is below tol."""
    K = int(lam + 12.0 * math.sqrt(lam) + 40.0)
    k = np.arange(K + 1)
    logw = -lam + k * math.log(lam) - np.cumsum(np.log(np.maximum(k, 1)))
    w = np.exp(logw)
    tail = np.cumsum(w[::-1])[::-1]  # tail[k] = Σ_{j ≥ k} w_j (of the truncated sum)
    keep = np.flatnonzero(tail > tol * w.sum())
    return w[: keep[-1] + 1]


class _Uniformization:
    """exp(−t G) f for a generator with −G Metzler and G 1 = 0 (Jensen's method).

    With q ≥ max_i G_ii, P = I − G/q is row-stochastic (non-negative) and
    exp(−t G) = Σ_k Pois(k; q t) P^k. The truncated weights are renormalized to sum to 1,
    so every output value is a convex combination of input values (up to rounding).
    """

    def __init__(self, G: sp.csr_array) -> None:
        self.q = float(max(G.diagonal().max(), 0.0))
        n = G.shape[0]
        self.P = (sp.eye_array(n, format="csr") - G / self.q).tocsr() if self.q > 0 else None
        self.matvecs = 0

    def __call__(self, f: np.ndarray, t: float) -> np.ndarray:
        if self.P is None or t == 0.0:
            return f.copy()
        lam = self.q * t
        chunks = max(1, math.ceil(lam / _UNIFORMIZATION_CHUNK))
        w = _poisson_weights(lam / chunks)
        w = w / w.sum()
        for _ in range(chunks):
            acc, cur = w[0] * f, f
            for wk in w[1:]:
                cur = self.P @ cur
                acc += wk * cur
            self.matvecs += len(w) - 1
            f = acc
        return f


def _chain(
    f0: np.ndarray, times: np.ndarray, advance: Callable[[np.ndarray, float, float], np.ndarray]
) -> np.ndarray:
    """Evaluate a semigroup at sorted times of each sign: advance(f, now, dt) → f(now+dt)."""
    out = np.empty((times.size,) + f0.shape)
    for sign in (1.0, -1.0):
        pick = np.flatnonzero(sign * times >= 0)
        order = pick[np.argsort(sign * times[pick], kind="stable")]
        current, now = f0, 0.0
        for i in order:
            dt = times[i] - now
            if dt != 0.0:
                current = advance(current, now, dt)
                now = times[i]
            out[i] = current
    return out


def _norm(mesh: TriMesh, f: np.ndarray) -> float:
    return float(np.sqrt(np.einsum("i,i...->...", mesh.vertex_areas, f * f).sum()))


class TransportFlow:
    """Transport of functions along a tangent field v by one of :data:`METHODS`.

    Keeps the operator, factorizations and bases of one field, so flowing several
    functions or times pays for them once. ``TransportFlow(mesh, v, method="chapter")``
    behaves as :class:`fvf.FunctionalFlow`.

    Parameters
    ----------
    mesh : TriMesh
    v : array_like (m, 3)
        Tangent field per face.
    method : {"chapter", "upwind", "skew", "cayley", "spectral"}
        See :func:`flow`.
    tangent : {"project", "raise", "ignore"}
        See :func:`fvf.as_face_field`.
    **options
        Method options (see :func:`flow`); unknown names raise :class:`TypeError`.

    Attributes
    ----------
    operator : sparse (n, n) or None
        The generator (df/dt = −operator f): D^V_v, G, S, or the Cayley operator; None for
        ``"spectral"``.
    basis : SpectralBasis
        ``"spectral"`` only: the basis of the reduced flow.
    stats : dict
        Work of the last call: ``matvecs`` (column products with an n x n matrix),
        ``steps``, ``factorizations`` (sparse LU); for "chapter" and "skew" the
        statistics of :func:`fvf.numerics.expm.expm_action` (``method``, ``error_estimate`` …).

    Examples
    --------
    >>> import numpy as np, fvf
    >>> from fvf.flows.dispatch import TransportFlow
    >>> mesh = fvf.icosphere(3)
    >>> v = fvf.gradient(mesh, mesh.vertices[:, 2])  # compressible: sink at the north pole
    >>> f0 = np.sin(3 * mesh.vertices[:, 0])
    >>> ft = TransportFlow(mesh, v, method="upwind")(f0, 2.0)
    >>> bool(f0.min() <= ft.min() and ft.max() <= f0.max())  # maximum principle
    True
    """

    @takes_mesh
    def __init__(
        self,
        mesh: TriMesh,
        v: npt.ArrayLike,
        method: str = "chapter",
        *,
        tangent: TangentPolicy = "project",
        **options: Any,
    ) -> None:
        if method not in METHODS:
            raise ParameterError(
                f"unknown flow method {method!r}; choose one of {', '.join(METHODS)}"
            )
        unknown = set(options) - _OPTIONS[method]
        if unknown:
            allowed = ", ".join(sorted(_OPTIONS[method])) or "none"
            raise TypeError(
                f"method {method!r} takes no option(s) {', '.join(sorted(unknown))}; "
                f"its options: {allowed}"
            )
        self.mesh = mesh
        self.method = method
        self.field = as_face_field(mesh, v, "v", tangent)
        self.growth_limit = as_growth_limit(options.get("growth_limit", GROWTH_LIMIT))
        self.max_products = float(options.get("max_products", MAX_PRODUCTS))
        if not self.max_products > 0:
            raise ParameterError(f"max_products must be > 0; got {self.max_products!r}")
        self.stats: dict[str, Any] = {"matvecs": 0, "steps": 0, "factorizations": 0}
        self._chapter: FunctionalFlow | None = None
        self._lu: dict[float, Any] = {}
        self.operator: sp.csr_array | None = None
        if method == "chapter":
            self._chapter = FunctionalFlow(
                mesh,
                self.field,
                growth_limit=self.growth_limit,
                tangent="ignore",
                method=options.get("expm", "auto"),
                tol=options.get("tol", 1e-10),
                **{k: options[k] for k in ("max_products", "progress") if k in options},
            )
            self.operator = self._chapter.operator  # checked there (finite_operator)
        elif method == "upwind":
            self.operator = finite_operator(
                lambda: upwind_operator(mesh, self.field, tangent="ignore"), self.field
            )
            self._upwind = {1.0: _Uniformization(self.operator)}
        elif method == "skew":
            self.operator = finite_operator(
                lambda: skew_operator(mesh, self.field, tangent="ignore"), self.field
            )
            self._expm = {"method": options.get("expm", "auto"), "tol": options.get("tol", 1e-10)}
            if "max_products" in options:
                self._expm["max_products"] = options["max_products"]
            if options.get("progress") not in (None, False):  # a bad value fails here
                self._expm["progress"] = fraction_reporter(options["progress"], "flow")
        elif method == "cayley":
            kind = options.get("operator", "skew")
            if kind not in ("skew", "chapter"):
                raise ParameterError(f"cayley operator must be 'skew' or 'chapter'; got {kind!r}")
            self.cayley_operator = kind
            if kind == "chapter":
                self._chapter = FunctionalFlow(
                    mesh, self.field, growth_limit=np.inf, tangent="ignore"
                )
                self.operator = self._chapter.operator
            else:
                self.operator = finite_operator(
                    lambda: skew_operator(mesh, self.field, tangent="ignore"), self.field
                )
            speed = max_row_norm(self.field)  # no overflow for |v| ~ 1e200
            dt = options.get("dt")
            if dt is None:
                courant = as_positive(options.get("courant", DEFAULT_COURANT), "courant")
                dt = courant * mesh.mean_edge_length / speed if speed > 0 else np.inf
                mu = max(self.growth_rate)
                if mu > 0:  # h μ / 2 ≤ ½: no pole of the Cayley map near growing modes
                    dt = min(dt, 1.0 / mu)
                if not dt > 0:  # the field is so large that the step underflows
                    raise FlowOverflowError(
                        f"the Cayley step for this field (max |v| = {speed:.3g}) underflows "
                        "to 0; scale the field down (and the times up by as much)"
                    )
            self.dt = as_positive(dt, "dt", allow_inf=True)
        else:  # registered from a layer above: "spectral"
            build = _REGISTERED.get(method)
            if build is None:
                raise ParameterError(
                    f"flow method {method!r} lives in fvf.spectral; import fvf (or fvf.spectral)"
                )
            self._registered = build(mesh, self.field, options)
            if hasattr(self._registered, "basis"):
                self.basis = self._registered.basis

    # ------------------------------------------------------------------ growth
    @property
    def growth_rate(self) -> tuple[float, float]:
        """(μ₊, μ₋): ‖f(t)‖_{A_V} ≤ e^{μ₊ t}‖f_0‖ for t ≥ 0 and e^{μ₋|t|}‖f_0‖ for t < 0.

        ``"skew"`` and ``"cayley"`` with the skew operator: exactly ½ max(±div v), since
        the A_V-symmetric part of −S is ½[div v]. ``"chapter"`` (and Cayley of it): the
        Lanczos estimate of :class:`fvf.FunctionalFlow`.

        Raises
        ------
        ParameterError
            For ``"upwind"`` (it obeys the maximum principle instead: the sup-norm never
            grows) and ``"spectral"``.
        """
        if self.method in ("upwind", "spectral"):
            raise ParameterError(
                f"growth_rate is defined for the chapter, skew and cayley flows, not "
                f"{self.method!r}"
                + (" (it obeys the maximum principle instead)" if self.method == "upwind" else "")
            )
        if self._chapter is not None:
            return self._chapter.growth_rate
        dv = self._divergence
        return max(0.5 * float(dv.max()), 0.0), max(-0.5 * float(dv.min()), 0.0)

    @property
    def _divergence(self) -> np.ndarray:
        """(div v)_i = Σ_j F_ij / A_V(i) = −2 S_ii (the diagonal of S)."""
        assert self.operator is not None  # every method but "spectral" has one
        return -2.0 * self.operator.diagonal()

    def growth_bound(self, t: float) -> float:
        """Upper bound on ‖f(t)‖_{A_V} / ‖f_0‖_{A_V} (inf if the Cayley step is too long).

        For ``"cayley"``, the product over steps of (1 + hμ/2)/(1 − hμ/2) (from the
        discrete law), with the step h = dt used to reach t from 0.
        """
        mu = self.growth_rate[0] if t >= 0 else self.growth_rate[1]
        if self.method == "cayley":
            steps, h = self._steps(t)
            if h * mu / 2 >= 1:
                return np.inf
            with np.errstate(over="ignore"):
                return float(((1 + h * mu / 2) / (1 - h * mu / 2)) ** steps)
        with np.errstate(over="ignore"):
            return float(np.exp(mu * abs(t)))

    def _warn_growth(self, growth: tuple[float, float], t_extreme: float) -> None:
        """Warn once if the call grew a function's A_V-norm or max norm beyond
        ``growth_limit``."""
        if not max(growth) > self.growth_limit:
            return
        dv = div(self.mesh) @ self.field.ravel()
        score = dv if t_extreme >= 0 else -dv
        worst, faces = hotspots(self.mesh, score)
        where = (
            f" div v reaches {score.max():.3g} at vertices {format_indices(worst)}, in faces "
            f"{format_indices(faces)}."
        )
        warnings.warn(
            f"the {self.method} flow to t={t_extreme:g} grew a function's A_V-norm by "
            f"{growth[0]:.3g}x and its largest value by {growth[1]:.3g}x (limit "
            f"{self.growth_limit:g}).{where} For compressible fields "
            "use method='upwind' (bounded by [min f_0, max f_0] on every mesh); pass "
            "growth_limit=np.inf to accept it.",
            FlowGrowthWarning,
            stacklevel=user_stacklevel(),
        )

    # ------------------------------------------------------------------ helpers
    def norm(self, f: npt.ArrayLike) -> float:
        """A_V-norm (eq. 26) of a PL function (n,) (or Frobenius over columns)."""
        return _norm(self.mesh, np.asarray(f, dtype=float))

    def _steps(self, dt_total: float) -> tuple[int, float]:
        with np.errstate(over="ignore", divide="ignore"):
            ratio = abs(dt_total) / self.dt
        steps = max(1, math.ceil(ratio * (1 - 1e-12)))
        return steps, dt_total / steps

    def _cayley_lu(self, h: float) -> Any:
        lu = self._lu.get(h)
        if lu is None:
            n = self.mesh.n_vertices
            assert self.operator is not None
            M = (sp.eye_array(n, format="csc") + (0.5 * h) * self.operator).tocsc()
            lu = self._lu[h] = sla.splu(M)
            self.stats["factorizations"] += 1
        return lu

    def _advance_cayley(self, f: np.ndarray, now: float, dt: float) -> np.ndarray:
        steps, h = self._steps(dt)
        lu = self._cayley_lu(h)
        S = self.operator
        for _ in range(steps):
            f = lu.solve(f - (0.5 * h) * (S @ f))
        self.stats["steps"] += steps
        self.stats["matvecs"] += steps
        return f

    def _advance_upwind(self, f: np.ndarray, now: float, dt: float) -> np.ndarray:
        sign = 1.0 if dt > 0 else -1.0
        if sign not in self._upwind:  # backward in time: the upwind flow of −v
            G = upwind_operator(self.mesh, -self.field, tangent="ignore")
            self._upwind[sign] = _Uniformization(G)
        u = self._upwind[sign]
        before = u.matvecs
        out = u(f, abs(dt))
        self.stats["matvecs"] += u.matvecs - before
        return out

    # ------------------------------------------------------------------ call
    def __call__(self, f: npt.ArrayLike, t: float | npt.ArrayLike) -> np.ndarray:
        """f transported to time(s) t.

        Parameters
        ----------
        f : array_like (n,) or (n, k)
        t : float or array_like (T,)
            Any sign and order; arrays are computed by chaining over sorted times.

        Returns
        -------
        ndarray float64: ``f.shape`` for a scalar t, ``(T,) + f.shape`` for an array.
        """
        self.stats = {"matvecs": 0, "steps": 0, "factorizations": 0}
        if self.method == "chapter":
            assert self._chapter is not None
            out = self._chapter(f, t)
            self.stats = self._chapter.stats
            return out
        f0 = as_vertex_function(self.mesh, f, "f", columns=True)
        times, scalar = as_times(t)
        if times.size == 0:  # no times, no frames: every method returns (0,) + f.shape
            return np.empty((0,) + f0.shape)
        self._check_work(times, f0)
        if self.method == "upwind":
            out = _chain(f0, times, self._advance_upwind)
        elif self.method == "skew":
            assert self.operator is not None
            out, self.stats = expm_action(
                -self.operator,
                f0,
                times,
                inner=self.mesh.vertex_areas,
                return_info=True,
                **self._expm,
            )
        elif self.method == "cayley":
            out = _chain(f0, times, self._advance_cayley)
        else:
            out = self._registered(f0.reshape(f0.shape[0], -1), times)
            out = out.reshape((times.size,) + f0.shape)
        if not np.isfinite(out).all():
            raise FlowOverflowError(
                f"the {self.method} flow overflowed to inf/NaN; use method='upwind' (bounded "
                "by [min f_0, max f_0] on every mesh) or shorter times."
            )
        if self.method in ("skew", "cayley") and times.size:
            extreme = float(times[np.argmax(np.abs(times))])
            self._warn_growth(observed_growth(self.mesh.vertex_areas, f0, out), extreme)
        return out[0] if scalar else out

    def _check_work(self, times: np.ndarray, f0: np.ndarray) -> None:
        """Refuse an upwind or Cayley flow estimated to take more than ``max_products``
        products (the other methods bound their own work)."""
        if self.method not in ("upwind", "cayley") or times.size == 0:
            return
        plus = float(max(times.max(), 0.0))
        minus = float(max(-times.min(), 0.0))
        columns = f0.reshape(f0.shape[0], -1).shape[1]
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            if self.method == "upwind":
                rate = self._upwind[1.0].q
                work, what = rate * (plus + minus) * columns, f"rate {rate:.3g} x |t|"
            else:
                work, what = (plus + minus) / self.dt * columns, f"steps of dt={self.dt:.3g}"
        if not work <= self.max_products:
            raise FlowOverflowError(
                f"the {self.method} flow to t={max(plus, minus):g} needs about {work:.3g} "
                f"products ({what}, {columns} column(s)), more than "
                f"max_products={self.max_products:.3g}. Shorten t, flow fewer times or "
                "columns, or raise max_products."
            )


@takes_mesh
def flow(
    mesh: TriMesh,
    v: npt.ArrayLike,
    f: npt.ArrayLike,
    t: float | npt.ArrayLike,
    *,
    method: str = "chapter",
    **options: Any,
) -> np.ndarray:
    """Transport a function along v: f(t) for df/dt = −D f, by the chosen method.

    Parameters
    ----------
    mesh : TriMesh
    v : array_like (m, 3)
        Tangent field per face.
    f : array_like (n,) or (n, k)
        Function(s) at time 0.
    t : float or array_like (T,)
        Time(s), any sign and order. An empty array gives an empty result,
        shape ``(0,) + f.shape``, for every method.
    method : {"chapter", "upwind", "skew", "cayley", "spectral"}
        - ``"chapter"`` (default): exp(−t D^V_v) (eq. 42), :class:`fvf.FunctionalFlow`.
          Warns (:class:`~fvf.errors.FlowGrowthWarning`) when it may blow up. Options
          ``growth_limit``, ``expm`` and ``tol`` (the exponential action: ``expm`` is a
          ``method`` of :func:`fvf.numerics.expm.expm_action`, "auto" by default; ``tol`` its
          target relative error, 1e-10 by default).
        - ``"upwind"``: exp(−t G), G = :func:`upwind_operator`. f(t) stays within
          [min f_0, max f_0] on every mesh for every field (a convex combination of
          f_0's values); first-order accurate (smears). For t < 0 it is the upwind
          flow of −v (not the inverse of the forward flow: the scheme is diffusive).
        - ``"skew"``: exp(−t S), S = :func:`skew_operator`. d/dt ‖f‖² = ⟨f, [div v] f⟩
          exactly; norm-preserving for div v = 0. Warns when e^{½ max(div v) t} exceeds
          ``growth_limit`` (it can, on real meshes: the discrete div v is large there).
          Options ``growth_limit``, ``expm``, ``tol`` as for "chapter".
        - ``"cayley"``: implicit midpoint steps of length ≤ ``dt`` of
          ``operator="skew"`` (default) or ``"chapter"``. One sparse LU per step length;
          second order in time. The default ``dt`` is :data:`DEFAULT_COURANT` · mean edge
          length / max |v| (or pass ``courant``), capped at 1/μ (μ the growth rate),
          which keeps the Cayley map away from its pole on growing modes. Warns as
          ``"skew"`` does, with the bound ∏ (1 + hμ/2)/(1 − hμ/2). Options ``dt``,
          ``courant``, ``operator``, ``growth_limit``.
        - ``"spectral"``: the reduced flow in the first ``k`` (default 50)
          Laplace–Beltrami eigenfunctions, or in a given ``basis``
          (:class:`fvf.SpectralBasis`); f is projected onto the basis first.
    **options
        Method options as listed; others raise :class:`TypeError`. Every method but
        ``"spectral"`` also takes ``max_products`` (default
        :data:`fvf.numerics.expm.MAX_PRODUCTS`): a call estimated to take more products
        with the n x n operator is refused before it starts
        (:class:`~fvf.errors.FlowOverflowError`, naming the estimate); ``"chapter"`` and
        ``"skew"`` take ``progress`` (``True`` for a tqdm bar, or a callback
        ``(stage, done, total)``, :mod:`fvf.numerics.progress`).

    Returns
    -------
    ndarray float64
        ``f.shape`` for a scalar t; ``(T,) + f.shape`` for T times.

    Raises
    ------
    ParameterError
        Unknown method (the message lists the methods), bad times, bad options
        (``growth_limit`` below 1 or NaN, ``dt`` or ``courant`` not positive, ``k`` not
        a positive integer, an unknown ``tangent`` policy, ``max_products`` not positive).
    FlowOverflowError
        The result overflowed (also for ``"spectral"``), the field is too large for the
        method's steps, or the estimated work exceeds ``max_products``.

    Warns
    -----
    FlowGrowthWarning
        When the call grew a function's A_V-norm or its largest value by more than
        ``growth_limit`` ("chapter", "skew", "cayley").

    Examples
    --------
    >>> import numpy as np, fvf
    >>> from fvf.flows.dispatch import flow
    >>> mesh = fvf.icosphere(3)
    >>> v = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))  # rotation
    >>> f0 = mesh.vertices[:, 0]
    >>> exact = np.cos(1.0) * mesh.vertices[:, 0] + np.sin(1.0) * mesh.vertices[:, 1]
    >>> [round(float(np.abs(flow(mesh, v, f0, 1.0, method=m) - exact).max()), 2)
    ...  for m in ("chapter", "skew", "cayley", "upwind")]
    [0.01, 0.01, 0.01, 0.08]
    """
    return TransportFlow(mesh, v, method, **options)(f, t)
