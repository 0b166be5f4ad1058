"""Ideal fluid on surfaces (fvf.fluid): energy and enstrophy over hundreds of steps."""

import numpy as np
import pytest
import scipy.sparse as sp

import fvf
from conftest import load_shared, rel
from fvf.flows.fluid import (
    StreamFunctionSolver,
    fluid_time_step,
    ideal_fluid,
    stream_velocity,
)

# Stated tolerance: relative drift of E and Z over 200 steps (measured 9e-15 to 5e-13 for
# the midpoint rule at tol=1e-13, 2e-15 to 2e-12 for the spectral one; docs/flows.md).
DRIFT = 1e-11


def vortices(mesh):
    """Three Gaussian vortices of mixed sign at extreme points of the shape."""
    X = mesh.vertices - mesh.vertices.mean(0)
    X = X / np.linalg.norm(X, axis=1).max()
    centres = X[np.argmax(X[:, 2])], X[np.argmin(X[:, 0])], X[np.argmax(X[:, 1])]
    return sum(
        w * np.exp(-10 * ((X - c) ** 2).sum(1))
        for w, c in zip((1.0, -1.0, 0.7), centres, strict=True)
    )


def check_conservation(mesh, res, omega0):
    d = res.drift()
    assert d["energy"] < DRIFT and d["enstrophy"] < DRIFT, d
    a = mesh.vertex_areas
    circulation = a @ res.vorticity.T
    assert np.abs(circulation - a @ omega0).max() < 1e-10 * np.sqrt(a @ omega0**2 * a.sum())
    moved = np.abs(res.vorticity[-1] - res.vorticity[0]).max() / np.abs(omega0).max()
    assert moved > 0.3  # the vortices did move: the test is not trivially satisfied


def test_midpoint_conserves_energy_and_enstrophy_on_a_sphere():
    mesh = fvf.icosphere(3)
    omega0 = vortices(mesh)
    res = ideal_fluid(mesh, omega0, fluid_time_step(mesh, omega0, 0.5), 200, save_every=50)
    assert res.vorticity.shape == (5, mesh.n_vertices) and res.energy.shape == (201,)
    assert np.allclose(res.times, res.times[1] * np.arange(5))
    check_conservation(mesh, res, omega0)


def test_midpoint_conserves_energy_and_enstrophy_on_bunny():
    mesh = load_shared("bunny-lowres.off")
    omega0 = vortices(mesh)
    res = ideal_fluid(mesh, omega0, fluid_time_step(mesh, omega0, 0.5), 200, save_every=200)
    check_conservation(mesh, res, omega0)
    assert res.iterations.max() <= 15


@pytest.mark.parametrize("name", ["spot.obj", "bunny-lowres.off"])
def test_spectral_conserves_energy_and_enstrophy(name):
    mesh = load_shared(name)
    omega0 = vortices(mesh)
    res = ideal_fluid(
        mesh, omega0, fluid_time_step(mesh, omega0, 0.5), 300, method="spectral", k=64
    )
    d = res.drift()
    assert d["energy"] < DRIFT and d["enstrophy"] < DRIFT, d
    moved = np.abs(res.vorticity[-1] - res.vorticity[0]).max() / np.abs(res.vorticity[0]).max()
    assert moved > 0.3


def test_fluid_with_walls_on_a_disk():
    """ψ = 0 on the boundary: free-slip walls; E and Z conserved as on closed meshes."""
    mesh = fvf.disk(8, 6)
    X = mesh.vertices
    omega0 = np.exp(-20 * ((X[:, :2] - [0.3, 0.0]) ** 2).sum(1)) - np.exp(
        -20 * ((X[:, :2] + [0.3, 0.2]) ** 2).sum(1)
    )
    res = ideal_fluid(mesh, omega0, fluid_time_step(mesh, omega0, 0.5), 200, save_every=200)
    d = res.drift()
    assert d["energy"] < DRIFT and d["enstrophy"] < DRIFT, d
    assert np.abs(res.stream[:, mesh.boundary_vertices]).max() == 0.0
    with pytest.raises(ValueError, match="closed mesh"):
        ideal_fluid(mesh, omega0, 0.1, 1, method="spectral")


def test_the_exact_identities_behind_conservation(rng):
    """[A_V] D^V_{J grad ψ} is skew and ψᵀ[A_V] D^V_{J grad ψ} ω = 0, on real meshes."""
    for mesh in (load_shared("lion-00.off"), fvf.disk(6, 6)):
        omega = rng.standard_normal(mesh.n_vertices)
        psi = StreamFunctionSolver(mesh)(omega)
        D = fvf.D_V(mesh, stream_velocity(mesh, psi))
        AD = sp.diags_array(mesh.vertex_areas) @ D
        assert abs(AD + AD.T).max() < 1e-12 * abs(AD).max()
        scale = np.abs(psi).max() * np.abs(AD).sum() * np.abs(omega).max()
        assert abs(psi @ (AD @ omega)) < 1e-14 * scale


def test_stream_function_inverts_the_laplacian():
    mesh = fvf.icosphere(3)
    z = mesh.vertices[:, 2]
    psi = StreamFunctionSolver(mesh)(z + 3.0)  # the mean is ignored
    assert rel(-fvf.laplacian(mesh) @ psi, z - (mesh.vertex_areas @ z) / mesh.total_area) < 1e-10
    assert abs(mesh.vertex_areas @ psi) < 1e-14


def test_laplace_eigenfunctions_are_steady():
    """ω ∝ ψ makes ⟨J∇ψ, ∇ω⟩ = 0 on every face: an eigenfunction of L does not move."""
    mesh = fvf.jittered_sphere(2, 0.3, seed=3)
    basis = fvf.SpectralBasis(mesh, 6)
    omega0 = basis.eigenvectors[:, 4] + 0.2
    res = ideal_fluid(mesh, omega0, 0.3, 20)
    assert rel(res.vorticity[-1], omega0) < 1e-7
    assert res.iterations.max() <= 2


def test_midpoint_and_spectral_agree_on_smooth_flows():
    """Both discretize the same equations. For ω_0 in the span of 36 eigenfunctions, the
    Galerkin result matches the full one projected onto the span (measured 2.5% of the
    change after 20 steps; the part of the full result outside the span is 10%)."""
    mesh = fvf.icosphere(4)
    basis = fvf.SpectralBasis(mesh, 36)
    rng = np.random.default_rng(5)
    omega0 = basis.reconstruct(rng.standard_normal(36) / (1 + basis.eigenvalues))
    dt = fluid_time_step(mesh, omega0, 0.5)
    full = ideal_fluid(mesh, omega0, dt, 20, save_every=20)
    reduced = ideal_fluid(mesh, omega0, dt, 20, method="spectral", basis=basis, save_every=20)
    projected = basis.reconstruct(basis.project(full.vorticity[-1]))
    change = np.linalg.norm(full.vorticity[-1] - omega0)
    assert np.linalg.norm(projected - reduced.vorticity[-1]) < 0.04 * change


def test_errors():
    mesh = fvf.icosphere(1)
    omega = mesh.vertices[:, 2]
    with pytest.raises(ValueError, match="midpoint"):
        ideal_fluid(mesh, omega, 0.1, 1, method="rk4")
    with pytest.raises(ValueError, match="dt"):
        ideal_fluid(mesh, omega, 0.0, 1)
    with pytest.raises(fvf.FieldShapeError):
        ideal_fluid(mesh, omega[:-1], 0.1, 1)
    with pytest.raises(RuntimeError, match="shorter dt"):
        ideal_fluid(mesh, omega, 50.0, 3, max_iterations=2)


def test_the_spectral_methods_are_registered_with_their_dispatchers():
    """fvf.spectral implements the spectral flow and fluid; fvf.flows only dispatches."""
    from fvf.flows import dispatch, fluid

    mesh = fvf.icosphere(2)
    v = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    flow = fvf.TransportFlow(mesh, v, "spectral", k=9)
    assert isinstance(flow.basis, fvf.SpectralBasis) and flow.basis.k == 9
    f0 = mesh.vertices[:, 0]
    np.testing.assert_allclose(flow(f0, 0.5), flow.basis.reduced_flow(v, f0, 0.5))
    for register in (dispatch.register_flow_method, fluid.register_fluid_method):
        with pytest.raises(ValueError):
            register("chapter" if register is dispatch.register_flow_method else "midpoint", None)
