"""Ideal (inviscid, incompressible) fluid on a surface by vorticity transport.

The Euler equations on a surface in vorticity form, the setting of Azencot, Weißmann,
Ovsjanikov, Wardetzky and Ben-Chen (2014), "Functional fluids on surfaces": the vorticity
ω is carried by the velocity it induces,

    ∂ω/∂t + ⟨u, ∇ω⟩ = 0,    u = J grad ψ,    Δψ = ω   (ψ the stream function),

with J the rotation by +π/2, so that curl u = Δψ = ω. Discretely Δ = −L
(L = :func:`fvf.laplacian`). The Poisson problem W ψ = −[A_V] ω is solved with the
stiffness matrix W: ψ has zero A_V-mean on each closed component, and ψ = 0 on the boundary
of a mesh with boundary (free-slip walls: u is tangent to the boundary). ω is transported
by D^V_u (eq. 36): dω/dt = −D^V_{u(ω)} ω.

Conservation. For u = J grad ψ (closed mesh, or ψ = 0 on the boundary), [A_V] D^V_u is
skew-symmetric. So the enstrophy Z = ∫ω² = ωᵀ[A_V]ω is conserved, and so is the energy
E = ½∫|u|² = ½ ψᵀ W ψ = −½ ψᵀ[A_V]ω:

    dE/dt = ψᵀ[A_V] D^V_u ω = −ωᵀ[A_V] D^V_u ψ = −Σ_t A_F(t) ω̄_t ⟨J∇ψ, ∇ψ⟩_t = 0,

with ω̄_t the mean of ω over face t. E and Z are both quadratic invariants, and the
implicit midpoint rule conserves quadratic invariants exactly:

    ω_{k+1} = ω_k − h D^V_{u(ω_{k+½})} ω_{k+½},    ω_{k+½} = ½(ω_k + ω_{k+1}).

The rule is nonlinear in ω_{k+½}. It is solved to a relative residual ``tol`` by a
preconditioned fixed-point iteration: the preconditioner is a sparse LU of
I + h/2 D^V_{u*} at a recent velocity u*, and the iteration uses Anderson acceleration.
E and Z are then conserved up to ``tol`` per step. The circulation ∫ω is conserved too.

``method="spectral"`` is the Galerkin version in k Laplace–Beltrami eigenfunctions, the
reduced functional representation of Azencot et al.: ω = Φc, ψ = −Φ Λ⁻¹ c, and the reduced
operators D̂_{J grad φ_i} are precomputed once as a k x k x k tensor. The same implicit
midpoint rule then runs on k coefficients. It conserves E = ½ Σ c_i²/λ_i and Z = |c|²
exactly for the truncated system, since each D̂ is skew.
"""

from __future__ import annotations

import numbers
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from ..calculus import gradient, rotate, stiffness
from ..errors import (
    FieldShapeError,
    FluidSolveError,  # noqa: F401 (re-exported)
    ParameterError,
)
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_count, as_positive, as_vertex_function
from ..mesh.trimesh import TriMesh
from ..numerics.progress import ProgressCallback, make_progress
from ..numerics.summary import html_repr, short_repr
from ..operators.directional import D_V

__all__ = [
    "FluidResult",
    "StreamFunctionSolver",
    "ideal_fluid",
    "fluid_time_step",
    "stream_velocity",
    "METHODS",
    "register_fluid_method",
    "extrapolate_midpoint",
    "midpoint_not_converged",
]

#: Options of SuperLU for structurally symmetric 1-ring matrices: minimum degree ordering
#: on A + Aᵀ and no pivoting (the stiffness matrix is SPD; I + h/2 D^V_u has the positive
#: definite symmetric part [A_V] after scaling).
_SYMMETRIC_LU = {
    "permc_spec": "MMD_AT_PLUS_A",
    "diag_pivot_thresh": 0.0,
    "options": {"SymmetricMode": True},
}
_ANDERSON_DEPTH = 4
#: Refactor the preconditioner (once per step) when an iteration reduces the residual by
#: less than this factor.
_REFACTOR_RATIO = 0.1


class StreamFunctionSolver:
    """ψ from ω: the Poisson problem W ψ = −[A_V] ω, with a pre-factored stiffness matrix.

    On closed components one vertex per component is pinned and the solution is shifted
    to zero A_V-mean. The A_V-mean of ω is ignored there: no velocity field has one, since
    ∫Δψ = 0. Boundary vertices get ψ = 0.

    Parameters
    ----------
    mesh : TriMesh

    Examples
    --------
    >>> import numpy as np, fvf
    >>> from fvf.flows.fluid import StreamFunctionSolver
    >>> mesh = fvf.icosphere(3)
    >>> z = mesh.vertices[:, 2]  # Δz = −2z on the unit sphere (l = 1)
    >>> psi = StreamFunctionSolver(mesh)(-2 * z)
    >>> bool(np.abs(psi - z).max() < 0.02)
    True
    """

    @takes_mesh
    def __init__(self, mesh: TriMesh) -> None:
        self.mesh = mesh
        labels = mesh.vertex_components
        if mesh.is_closed:
            closed = np.unique(labels)
        else:
            closed = np.setdiff1d(labels, labels[mesh.boundary_vertices])
        fixed = np.zeros(mesh.n_vertices, dtype=bool)
        fixed[mesh.boundary_vertices] = True
        for c in closed:  # pin one vertex of each closed component
            fixed[np.flatnonzero(labels == c)[0]] = True
        self._closed = [np.flatnonzero(labels == c) for c in closed]
        self._free = np.flatnonzero(~fixed)
        W = stiffness(mesh)
        self._lu = sla.splu(W[self._free][:, self._free].tocsc(), **_SYMMETRIC_LU)

    def _remove_means(self, f: np.ndarray) -> np.ndarray:
        a = self.mesh.vertex_areas
        f = f.copy()
        for on in self._closed:
            f[on] -= (a[on] @ f[on]) / a[on].sum()
        return f

    def __call__(self, omega: npt.ArrayLike) -> np.ndarray:
        """ψ (n,): Δψ = ω minus its mean on closed components, ψ = 0 on the boundary."""
        omega = as_vertex_function(self.mesh, omega, "omega")
        rhs = -self.mesh.vertex_areas * self._remove_means(omega)
        psi = np.zeros(self.mesh.n_vertices)
        psi[self._free] = self._lu.solve(rhs[self._free])
        return self._remove_means(psi)


@takes_mesh
def stream_velocity(mesh: TriMesh, psi: npt.ArrayLike) -> np.ndarray:
    """u = J grad ψ: the divergence-free velocity of a stream function, (m, 3)."""
    return rotate(mesh, gradient(mesh, psi))


class _Anderson:
    """Anderson acceleration of x ← x + d(x): least squares in the A_V-norm, depth m."""

    def __init__(self, weights: np.ndarray, depth: int) -> None:
        self.w = np.sqrt(weights)
        self.depth = int(depth)
        self.xs: list[np.ndarray] = []
        self.ds: list[np.ndarray] = []

    def __call__(self, x: np.ndarray, d: np.ndarray) -> np.ndarray:
        if self.depth <= 0:
            return x + d
        self.xs = [*self.xs[-self.depth :], x]
        self.ds = [*self.ds[-self.depth :], d]
        if len(self.xs) == 1:
            return x + d
        dD = np.diff(np.stack(self.ds, 1), axis=1)
        dX = np.diff(np.stack(self.xs, 1), axis=1)
        gamma = np.linalg.lstsq(self.w[:, None] * dD, self.w * d, rcond=None)[0]
        return x + d - (dX + dD) @ gamma


def extrapolate_midpoint(mids: list[np.ndarray], current: np.ndarray) -> np.ndarray:
    """Predict the next midpoint from the previous ones (newest first); O(h³) with three.

    The start of the midpoint iteration of every method of :func:`ideal_fluid`.
    """
    if len(mids) >= 3:
        return 3.0 * mids[0] - 3.0 * mids[1] + mids[2]
    if len(mids) == 2:
        return 2.0 * mids[0] - mids[1]
    return current


def midpoint_not_converged(tol: float, max_iterations: int, step: int, res: float) -> RuntimeError:
    """The :class:`FluidSolveError` of a midpoint iteration that stopped at residual ``res``."""
    return FluidSolveError(
        f"the implicit midpoint iteration did not reach tol={tol:g} in {max_iterations} "
        f"iterations at step {step} (residual {res:.3g}); use a shorter dt or a larger tol."
    )


@dataclass
class FluidResult:
    """Output of :func:`ideal_fluid`.

    Attributes
    ----------
    mesh : TriMesh
    times : float64 (S,)
        Times of the saved frames (every ``save_every`` steps; first and last included).
    vorticity : float64 (S, n)
        ω at those times.
    stream : float64 (S, n)
        ψ at those times (u = J grad ψ, see :meth:`velocity`).
    energy, enstrophy : float64 (steps + 1,)
        E = ½∫|u|² = ½ψᵀWψ and Z = ∫ω² = ωᵀ[A_V]ω after every step. For
        ``"spectral"``, E = ½Σc_i²/λ_i and Z = |c|² in the coefficients.
    iterations : int64 (steps,)
        Fixed-point iterations of each step.
    method : str
    info : dict
        ``"factorizations"`` (midpoint: sparse LUs of the preconditioner); ``"basis"`` and
        ``"coefficients"`` (spectral).
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    mesh: TriMesh
    times: np.ndarray
    vorticity: np.ndarray
    stream: np.ndarray
    energy: np.ndarray
    enstrophy: np.ndarray
    iterations: np.ndarray
    method: str = "midpoint"
    info: dict = field(default_factory=dict)

    def velocity(self, frame: int = -1) -> np.ndarray:
        """u = J grad ψ of a saved frame, (m, 3)."""
        return stream_velocity(self.mesh, self.stream[frame])

    def drift(self) -> dict[str, float]:
        """Largest relative deviation of E and Z from their initial values."""
        return {
            "energy": float(np.abs(self.energy / self.energy[0] - 1).max()),
            "enstrophy": float(np.abs(self.enstrophy / self.enstrophy[0] - 1).max()),
        }


#: The methods of :func:`ideal_fluid`, the full mesh's first (the default).
METHODS = ("midpoint", "spectral")

#: The most work one :func:`ideal_fluid` call accepts: steps × unknowns (vertices for
#: ``"midpoint"``, basis functions for ``"spectral"``). 10¹¹ is about a day of midpoint
#: steps; longer runs are made in pieces, each starting from the last frame of the
#: previous one.
MAX_FLUID_WORK = 10**11

#: The most memory the kept frames of one :func:`ideal_fluid` call may take (bytes).
MAX_FLUID_FRAME_BYTES = 2**34

#: The methods of :data:`METHODS` implemented in a layer above this one (a layer never
#: imports upward, docs/architecture.md), by name: a function
#: ``run(mesh, omega, dt, steps, k, basis, tol, max_iterations, save_every, report)`` of
#: the checked arguments of :func:`ideal_fluid` (``report`` its progress callback) that
#: returns a :class:`FluidResult`.
_REGISTERED: dict[str, Callable[..., FluidResult]] = {}


def register_fluid_method(name: str, run: Callable[..., FluidResult]) -> None:
    """Implement the method ``name`` of :func:`ideal_fluid` from a layer above this one.

    :mod:`fvf.spectral.reduced_flows` registers ``"spectral"`` when :mod:`fvf.spectral`
    is imported (``import fvf`` imports it).

    Parameters
    ----------
    name : str
        One of :data:`METHODS` but ``"midpoint"``, which this module implements.
    run : callable
        ``run(mesh, omega, dt, steps, k, basis, tol, max_iterations, save_every, report)``:
        the arguments of :func:`ideal_fluid`, checked (``omega`` float64 (n,), ``report``
        a progress callback ``(stage, done, total)``), returning a :class:`FluidResult`.
    """
    if name not in METHODS or name == "midpoint":
        raise ValueError(f"{name!r} is not a fluid method that ideal_fluid leaves to a layer above")
    _REGISTERED[name] = run


@takes_mesh
def fluid_time_step(mesh: TriMesh, omega0: npt.ArrayLike, courant: float = 0.5) -> float:
    """A step length for a Courant number: c · mean edge length / max |u(ω_0)|.

    Raises
    ------
    FieldShapeError
        Wrong shape or non-finite ω_0, or an ω_0 that induces no velocity (zero, or
        constant on closed components): the fluid is at rest and every step is exact.
    ParameterError
        A non-positive or non-finite Courant number.
    """
    if not (np.isfinite(courant) and courant > 0):
        raise ParameterError(f"courant must be a positive number; got {courant!r}")
    psi = StreamFunctionSolver(mesh)(omega0)
    speed = float(np.linalg.norm(stream_velocity(mesh, psi), axis=1).max())
    if not speed > 0:
        raise FieldShapeError(
            "omega0 induces no velocity (it is zero, or constant on closed components), so "
            "no Courant step exists: the fluid is at rest. Fix: pass any dt to ideal_fluid."
        )
    return courant * mesh.mean_edge_length / speed


def _basis_size(basis: Any, k: int) -> int:
    size = getattr(basis, "k", None)
    return int(size) if isinstance(size, numbers.Integral) else int(k)


def _check_work(unknowns: int, steps: int, save_every: int) -> None:
    """Refuse a run beyond :data:`MAX_FLUID_WORK` or :data:`MAX_FLUID_FRAME_BYTES`
    before it starts (``ideal_fluid(steps=10**9)`` would otherwise run for years)."""
    frames = (steps // save_every + 1) * unknowns * 8
    if steps * unknowns > MAX_FLUID_WORK or frames > MAX_FLUID_FRAME_BYTES:
        raise ParameterError(
            f"steps={steps} on {unknowns} unknowns is {steps * unknowns:.3g} step-unknowns "
            f"and {frames / 2**30:.3g} GiB of frames, beyond what one call runs "
            f"(MAX_FLUID_WORK = {MAX_FLUID_WORK:.0e}, MAX_FLUID_FRAME_BYTES = "
            f"{MAX_FLUID_FRAME_BYTES / 2**30:.0f} GiB). Fix: fewer steps, a larger "
            "save_every, or run in pieces, each from the last frame of the one before"
        )


def _area_norm(a: np.ndarray, x: np.ndarray) -> float:
    """The A_V-norm √(xᵀ[A_V]x) of x (n,), scaled so that |x| up to the float64 limit
    cannot overflow; a (n,) the vertex areas."""
    big = float(np.abs(x).max())
    if not 0.0 < big < np.inf:
        return big
    y = x / big
    return big * float(np.sqrt(a @ (y * y)))


def _time_step(dt: object) -> float:
    """``dt`` as a finite nonzero float, else :class:`fvf.ParameterError`."""
    step = float(dt) if isinstance(dt, numbers.Real) and not isinstance(dt, bool) else np.nan
    if not (np.isfinite(step) and step != 0.0):
        raise ParameterError(f"dt must be a finite nonzero number; got {dt!r}")
    return step


@takes_mesh
def ideal_fluid(
    mesh: TriMesh,
    omega0: npt.ArrayLike,
    dt: float,
    steps: int,
    *,
    method: str = "midpoint",
    k: int = 64,
    basis: Any = None,
    tol: float = 1e-13,
    max_iterations: int = 50,
    save_every: int = 1,
    progress: bool | ProgressCallback | None = None,
) -> FluidResult:
    """Evolve an ideal fluid on a surface from its vorticity (Azencot et al. 2014).

    Parameters
    ----------
    mesh : TriMesh
        A closed mesh (ψ of zero mean) or a mesh with boundary (ψ = 0 there: free-slip
        walls).
    omega0 : array_like (n,)
        Initial vorticity. On a closed component its A_V-mean induces no velocity and is
        carried along unchanged.
    dt : float
        Step length; :func:`fluid_time_step` picks one from a Courant number (0.5 is a good
        default: about 7 iterations per step).
    steps : int
        Number of steps, >= 0 (an integer: 2.5 is refused).
    method : {"midpoint", "spectral"}
        ``"midpoint"``: the implicit midpoint rule on the full mesh (see the module
        docstring). ``"spectral"``: the same rule for the Galerkin system in ``k``
        Laplace–Beltrami eigenfunctions, or in a given ``basis`` (:class:`fvf.SpectralBasis`);
        ω_0 is projected onto their span. Closed meshes only.
    tol : float
        Relative residual (A_V-norm) at which the midpoint equation counts as solved. E and
        Z drift by about this much per step.
    max_iterations : int
        Iterations per step before giving up, >= 1 (:class:`FluidSolveError`, a
        :class:`RuntimeError` and :class:`~fvf.errors.FvfError`; also raised at once when
        the iterate overflows because dt is far above the Courant limit).
    save_every : int
        Keep every ``save_every``-th frame (>= 1).
    progress : None, bool or callable
        ``True`` for a tqdm bar, or a callback ``(stage, done, total)``
        (:mod:`fvf.numerics.progress`; stage ``"steps"``).

    Returns
    -------
    FluidResult
        Frames, and the energy, enstrophy and iteration count after every step.

    Raises
    ------
    ParameterError
        A non-integer or negative ``steps``, ``save_every`` or ``max_iterations`` < 1,
        ``tol`` not a positive number, ``dt`` zero or not finite, an unknown method; a
        run beyond :data:`MAX_FLUID_WORK` (steps × vertices, or × basis size) or whose
        frames exceed :data:`MAX_FLUID_FRAME_BYTES`, refused before it starts.
    FluidSolveError
        A step did not converge in ``max_iterations`` iterations.
        Measured drift over 200 steps is below 1e-11 relative for both (``docs/flows.md``).

    Examples
    --------
    >>> import numpy as np, fvf
    >>> from fvf.flows.fluid import ideal_fluid, fluid_time_step
    >>> mesh = fvf.icosphere(2)
    >>> X = mesh.vertices
    >>> omega0 = np.exp(-8 * ((X - [0, 0, 1]) ** 2).sum(1)) - X[:, 0] ** 2
    >>> res = ideal_fluid(mesh, omega0, fluid_time_step(mesh, omega0), steps=20)
    >>> d = res.drift()
    >>> bool(d["energy"] < 1e-11 and d["enstrophy"] < 1e-11)
    True
    """
    if method not in METHODS:
        raise ParameterError(f"unknown fluid method {method!r}; choose 'midpoint' or 'spectral'")
    omega = as_vertex_function(mesh, omega0, "omega0")
    steps, save_every = as_count(steps, "steps"), as_count(save_every, "save_every", 1)
    max_iterations, tol = as_count(max_iterations, "max_iterations", 1), as_positive(tol, "tol")
    k = as_count(k, "k", 2) if basis is None else k
    dt = _time_step(dt)
    _check_work(
        mesh.n_vertices if method == "midpoint" else _basis_size(basis, k), steps, save_every
    )
    report = make_progress(progress)
    if method != "midpoint":  # registered from a layer above: "spectral"
        run = _REGISTERED.get(method)
        if run is None:
            raise ParameterError(
                f"fluid method {method!r} lives in fvf.spectral; import fvf (or fvf.spectral)"
            )
        return run(mesh, omega, dt, steps, k, basis, tol, max_iterations, save_every, report)

    solve_psi = StreamFunctionSolver(mesh)
    a = mesh.vertex_areas
    W = stiffness(mesh)
    eye = sp.eye_array(mesh.n_vertices, format="csc")
    h2 = 0.5 * dt
    info = {"factorizations": 0}

    def norm(x: np.ndarray) -> float:
        return _area_norm(a, x)

    psi = solve_psi(omega)
    energy, enstrophy = [0.5 * psi @ (W @ psi)], [a @ omega**2]
    frames, streams, times, iters = [omega], [psi], [0.0], []
    lu = None
    mids: list[np.ndarray] = []
    for step in range(1, steps + 1):
        x = extrapolate_midpoint(mids, omega)  # predicted ω_{k+½}
        scale = max(norm(omega), 1e-300)
        accel, previous, fresh = _Anderson(a, _ANDERSON_DEPTH), np.inf, False
        it = 0
        while True:
            it += 1
            psi_x = solve_psi(x)
            D = D_V(mesh, stream_velocity(mesh, psi_x), tangent="ignore")
            r = omega - x - h2 * (D @ x)  # residual of the midpoint equation
            res = norm(r) / scale
            if res <= tol:
                break
            if it == max_iterations:
                raise midpoint_not_converged(tol, max_iterations, step, res)
            if not np.isfinite(res):  # the iterate blew up: dt far above the Courant limit
                raise midpoint_not_converged(tol, max_iterations, step, res)
            if lu is None or (res > _REFACTOR_RATIO * previous and not fresh):
                try:
                    lu = sla.splu((eye + h2 * D).tocsc(), **_SYMMETRIC_LU)
                except RuntimeError as exc:  # "Factor is exactly singular"
                    raise midpoint_not_converged(tol, max_iterations, step, res) from exc
                info["factorizations"] += 1
                accel, fresh = _Anderson(a, _ANDERSON_DEPTH), True
            previous = res
            x = accel(x, lu.solve(r))
            if not np.isfinite(x).all():
                raise midpoint_not_converged(tol, max_iterations, step, np.inf)
        iters.append(it)
        mids = [x, *mids[:2]]
        omega = 2.0 * x - omega
        psi = 2.0 * psi_x - psi  # ψ is linear in ω
        energy.append(0.5 * psi @ (W @ psi))
        enstrophy.append(a @ omega**2)
        report("steps", step, steps)
        if step % save_every == 0 or step == steps:
            frames.append(omega)
            streams.append(psi)
            times.append(step * dt)
    return FluidResult(
        mesh,
        np.array(times),
        np.array(frames),
        np.array(streams),
        np.array(energy),
        np.array(enstrophy),
        np.array(iters, dtype=np.int64),
        "midpoint",
        info,
    )
