"""The spectral methods of :func:`fvf.flow` and :func:`fvf.ideal_fluid`.

Both run in the span of k Laplace–Beltrami eigenfunctions (a :class:`SpectralBasis`):
``fvf.flow(..., method="spectral")`` is the reduced flow Φ exp(−t D̂_v) Φᵀ[A_V] f
(:meth:`SpectralBasis.reduced_flow`, eq. 42 reduced), and
``fvf.ideal_fluid(..., method="spectral")`` the Galerkin fluid of Azencot et al. (2014).

Their dispatchers, :class:`fvf.flows.dispatch.TransportFlow` and
:func:`fvf.flows.fluid.ideal_fluid`, sit in :mod:`fvf.flows`, a layer below the bases that
never imports upward (docs/architecture.md). So this module registers the two methods
there when :mod:`fvf.spectral` is imported, which ``import fvf`` does.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ParameterError
from ..flows.dispatch import register_flow_method
from ..flows.fluid import (
    FluidResult,
    extrapolate_midpoint,
    midpoint_not_converged,
    register_fluid_method,
    stream_velocity,
)
from ..mesh.inputs import as_count
from ..mesh.trimesh import TriMesh
from ..numerics.progress import ProgressCallback
from .basis import SpectralBasis

#: Nothing to call here: the methods are reached through fvf.flow and fvf.ideal_fluid.
__all__: list[str] = []


#: Eigenfunctions of the reduced flow when ``k`` is not given.
DEFAULT_K = 50


class _SpectralFlow:
    """The ``"spectral"`` method of :class:`fvf.TransportFlow`: the reduced flow of one field.

    Parameters
    ----------
    mesh : TriMesh
    field : float64 (m, 3)
        The checked tangent field.
    options : dict
        ``k`` (default 50, or n - 1 on a mesh of n ≤ 50 vertices), the number of
        eigenfunctions, or ``basis``, a :class:`SpectralBasis` of ``mesh``.

    Attributes
    ----------
    basis : SpectralBasis

    Raises
    ------
    ParameterError
        ``k`` not a positive integer, or a ``basis`` built on another mesh.
    """

    def __init__(self, mesh: TriMesh, field: np.ndarray, options: dict[str, Any]) -> None:
        basis = options.get("basis")
        if basis is None:
            default = max(min(DEFAULT_K, mesh.n_vertices - 1), 1)  # a 24-vertex mesh: 23
            basis = SpectralBasis(mesh, as_count(options.get("k", default), "k", minimum=1))
        elif basis.mesh is not mesh:
            raise ParameterError(
                "basis was built on another mesh; build SpectralBasis(mesh, k) on this one"
            )
        self.basis = basis
        self.field = field

    def __call__(self, f0: np.ndarray, times: np.ndarray) -> np.ndarray:
        """f_0 float64 (n, c) at times float64 (T,) -> float64 (T, n, c)."""
        return np.stack(
            [self.basis.reduced_flow(self.field, f0[:, j], times) for j in range(f0.shape[1])],
            axis=-1,
        )


def _spectral_fluid(
    mesh: TriMesh,
    omega: np.ndarray,
    dt: float,
    steps: int,
    k: int,
    basis: SpectralBasis | None,
    tol: float,
    max_iterations: int,
    save_every: int,
    report: ProgressCallback,
) -> FluidResult:
    """``ideal_fluid(..., method="spectral")``: the implicit midpoint rule for the Galerkin
    system in k eigenfunctions (:mod:`fvf.flows.fluid`), on checked arguments.

    ω = Φc, ψ = −Φ Λ⁻¹ c; each step solves c_{k+1} = c_k − h D̂_{u(x)} x,
    x = ½(c_k + c_{k+1}), with the k x k x k tensor of D̂_{J grad φ_i} built once.
    """
    if not mesh.is_closed:
        raise ParameterError(
            "method='spectral' needs a closed mesh (the Neumann eigenfunctions give "
            "velocities through the boundary); use method='midpoint'."
        )
    if basis is None:
        basis = SpectralBasis(mesh, int(k))
    elif basis.mesh is not mesh:
        raise ParameterError("basis was built on another mesh")
    lam, Phi = basis.eigenvalues, basis.eigenvectors
    moving = np.flatnonzero(lam > 1e-10 * max(lam[-1], 1e-300))  # not the constants
    fields = np.stack([stream_velocity(mesh, Phi[:, i]) for i in moving])
    C = basis.reduced_D_many(fields)  # (p, k, k): D̂_{J grad φ_i}, each skew
    inv_lam = np.zeros_like(lam)
    inv_lam[moving] = 1.0 / lam[moving]
    eye = np.eye(basis.k)

    def matrix(x: np.ndarray) -> np.ndarray:  # I + h/2 D̂_{J grad ψ(x)}, ψ(x) = −Φ Λ⁻¹ x
        return eye + (0.5 * dt) * np.einsum("p,pjk->jk", -(inv_lam * x)[moving], C)

    c = basis.project(omega)
    energy, enstrophy = [0.5 * np.sum(c * c * inv_lam)], [c @ c]
    coeffs, times, iters = [c], [0.0], []
    mids: list[np.ndarray] = []
    for step in range(1, steps + 1):
        x = extrapolate_midpoint(mids, c)
        scale = max(float(np.linalg.norm(c)), 1e-300)
        it = 0
        while True:
            it += 1
            M = matrix(x)
            r = c - M @ x
            res = float(np.linalg.norm(r)) / scale
            if res <= tol:
                break
            if it == max_iterations:
                raise midpoint_not_converged(tol, max_iterations, step, res)
            x = x + np.linalg.solve(M, r)
        iters.append(it)
        mids = [x, *mids[:2]]
        c = 2.0 * x - c
        energy.append(0.5 * np.sum(c * c * inv_lam))
        enstrophy.append(c @ c)
        report("steps", step, steps)
        if step % save_every == 0 or step == steps:
            coeffs.append(c)
            times.append(step * dt)
    C = np.array(coeffs)
    return FluidResult(
        mesh,
        np.array(times),
        C @ Phi.T,
        (-C * inv_lam) @ Phi.T,
        np.array(energy),
        np.array(enstrophy),
        np.array(iters, dtype=np.int64),
        "spectral",
        {"basis": basis, "coefficients": coeffs},
    )


register_flow_method("spectral", _SpectralFlow)
register_fluid_method("spectral", _spectral_fluid)
