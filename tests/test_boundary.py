"""What the closed-surface identities become on meshes with boundary (docs/boundary.md).

Every statement of ``docs/boundary.md`` is tested here on a flat disk, a flat annulus (two
boundary loops), a flat square (four corners), a curved grid with a needle face, and the
shared woody and camelhead (each one boundary loop).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

import fvf
from conftest import load_shared, smooth_functions
from corpus import annulus, sliver, square
from fvf.flows.fluid import StreamFunctionSolver, stream_velocity

GENERATED = {
    "disk": lambda: fvf.disk(6, 6),
    "annulus": lambda: annulus(4, 32),
    "square": lambda: square(8),
    "sliver": sliver,
}
SHARED = ["woody.obj", "camelhead.off"]
FLAT = ["disk", "annulus", "square"]
_MESHES: dict = {}


def mesh_of(name: str) -> fvf.TriMesh:
    if name not in _MESHES:
        _MESHES[name] = GENERATED[name]() if name in GENERATED else load_shared(name)
    return _MESHES[name]


@pytest.fixture(params=list(GENERATED) + SHARED)
def mesh(request) -> fvf.TriMesh:
    return mesh_of(request.param)


@pytest.fixture(params=["disk", "annulus", "woody.obj"])
def small_mesh(request) -> fvf.TriMesh:
    return mesh_of(request.param)


def interior(mesh) -> np.ndarray:
    return np.setdiff1d(np.arange(mesh.n_vertices), mesh.boundary_vertices)


def loop_labels(mesh) -> np.ndarray:
    """Boundary loop of each boundary vertex (n,), -1 inside."""
    be = mesh.edges[mesh.boundary_edges]
    n = mesh.n_vertices
    g = sp.coo_array((np.ones(len(be)), (be[:, 0], be[:, 1])), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    out = np.full(n, -1)
    out[mesh.boundary_vertices] = lab[mesh.boundary_vertices]
    return out


def stream_constant_on_loops(mesh) -> np.ndarray:
    """A smooth PL function, overwritten by one constant per boundary loop."""
    _, g, _ = smooth_functions(mesh)
    lab = loop_labels(mesh)
    b = mesh.boundary_vertices
    g = g.copy()
    g[b] = 0.7 * lab[b] - 0.2
    return g


def boundary_edge_geometry(mesh):
    """Boundary edges (b, 2), their face, and the outward in-plane normals scaled by |e|."""
    be = mesh.edges[mesh.boundary_edges]
    face = mesh.edge_faces[mesh.boundary_edges].max(axis=1)
    ev = mesh.vertices[be[:, 1]] - mesh.vertices[be[:, 0]]
    n = np.cross(ev, mesh.face_normals[face])  # |n| = |e|, in the face plane
    mid = 0.5 * (mesh.vertices[be[:, 0]] + mesh.vertices[be[:, 1]])
    n *= np.sign(((mid - mesh.face_centroids[face]) * n).sum(1))[:, None]
    return be, face, n


def round_off_scale(mesh, v) -> np.ndarray:
    """Σ_t A_F(t) |⟨v, ∇φ_i⟩| / A_V(i) per vertex (n,): the size of the terms whose sum is
    (div v)_i, hence of its round-off (large at needle faces: camelhead's 0.55°)."""
    return abs(fvf.div(mesh)) @ np.abs(np.asarray(v).ravel())


def rel(a, b) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


# ---------------------------------------------------------------------------- calculus
def test_integration_by_parts_is_exact(mesh):
    """Lemma 7 (31) holds on every mesh: div is the negative adjoint of grad, so the
    boundary term of the smooth identity lives inside div at boundary vertices."""
    rng = np.random.default_rng(1)
    u = mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3)))
    f = rng.standard_normal(mesh.n_vertices)
    lhs = mesh.face_areas @ (u * fvf.gradient(mesh, f)).sum(1)
    rhs = mesh.vertex_areas @ (fvf.divergence(mesh, u) * f)
    assert abs(lhs + rhs) <= 1e-12 * (abs(lhs) + abs(rhs))


@pytest.mark.parametrize("name", FLAT)
def test_weak_divergence_at_the_boundary_is_the_boundary_flux(name):
    """A constant field on a flat mesh: zero divergence inside, and at a boundary vertex
    (div v)_i = −(flux of v out through the boundary half-edges at i) / A_V(i)."""
    mesh = mesh_of(name)
    a = np.array([0.8, -0.3, 0.0])
    d = fvf.divergence(mesh, np.tile(a, (mesh.n_faces, 1)))
    be, _, n = boundary_edge_geometry(mesh)
    half_flux = 0.5 * n @ a  # out through each half of each boundary edge
    out = np.bincount(be.ravel(), np.repeat(half_flux, 2), minlength=mesh.n_vertices)
    np.testing.assert_allclose(d * mesh.vertex_areas, -out, atol=1e-13)
    assert np.abs(d[interior(mesh)]).max() <= 1e-13
    assert np.abs(d[mesh.boundary_vertices]).max() > 0.1


@pytest.mark.parametrize("name", FLAT)
def test_laplacian_of_a_linear_function_is_the_neumann_term(name):
    """Natural (Neumann) boundary: for linear f on a flat mesh, W f = ½ Σ_e |e| ⟨∇f, n_e⟩
    over the boundary edges at each vertex, and 0 at interior vertices."""
    mesh = mesh_of(name)
    a = np.array([0.3, -0.7, 0.0])
    Wf = fvf.stiffness(mesh) @ (mesh.vertices @ a)
    be, _, n = boundary_edge_geometry(mesh)
    expected = np.bincount(be.ravel(), np.repeat(0.5 * n @ a, 2), minlength=mesh.n_vertices)
    assert rel(Wf, expected) <= 1e-12
    assert np.abs(Wf[interior(mesh)]).max() <= 1e-12 * np.abs(Wf).max()


def test_laplacian_kills_constants_and_is_symmetric(mesh):
    W = fvf.stiffness(mesh)
    assert abs(W - W.T).max() <= 1e-14 * abs(W).max()
    assert (
        np.abs(fvf.laplacian(mesh) @ np.ones(mesh.n_vertices)).max()
        <= 1e-10 * abs(fvf.laplacian(mesh)).max()
    )


def test_neumann_spectrum_of_the_square():
    """Eigenvalues of L on the unit square: the Neumann ones, 0, π², π², 2π², 4π², 4π²."""
    lam, phi = fvf.laplace_basis(square(16), 6)
    assert abs(lam[0]) <= 1e-10
    np.testing.assert_allclose(phi[:, 0], phi[0, 0])  # constant: no Dirichlet condition
    np.testing.assert_allclose(lam[1:] / np.pi**2, [1, 1, 2, 4, 4], rtol=0.015)  # h = 1/16


def test_div_J_grad_vanishes_at_interior_vertices_only(mesh):
    _, g, _ = smooth_functions(mesh)
    v = fvf.rotate(mesh, fvf.gradient(mesh, g))
    d = fvf.divergence(mesh, v)
    scale = round_off_scale(mesh, v)
    inside = interior(mesh)
    assert (np.abs(d[inside]) <= 1e-12 * scale[inside]).all()
    b = mesh.boundary_vertices
    assert np.abs(d[b]).max() >= 0.1 * scale[b].max()  # the flux through the boundary
    # With g constant on each boundary loop, J grad g is tangent to the boundary: no flux.
    gc = stream_constant_on_loops(mesh)
    v = fvf.rotate(mesh, fvf.gradient(mesh, gc))
    assert (np.abs(fvf.divergence(mesh, v)) <= 1e-12 * round_off_scale(mesh, v)).all()


# ---------------------------------------------------------------------------- operators
def test_DV_skew_exactly_for_fields_tangent_to_the_boundary(mesh):
    """[A_V] D^V_v is skew for v = J grad g iff no flux leaves through the boundary:
    g constant on each boundary loop. For a generic g it is far from skew."""
    A = fvf.vertex_mass(mesh)
    v = fvf.rotate(mesh, fvf.gradient(mesh, stream_constant_on_loops(mesh)))
    AD = A @ fvf.D_V(mesh, v)
    assert abs(AD + AD.T).max() <= 1e-12 * abs(AD).max()
    _, g, _ = smooth_functions(mesh)
    AD = A @ fvf.D_V(mesh, fvf.rotate(mesh, fvf.gradient(mesh, g)))
    assert abs(AD + AD.T).max() >= 0.1 * abs(AD).max()


def test_lemma14_holds_everywhere(mesh):
    """Eq. (54) = eq. (55): an algebraic identity, boundary or not."""
    rng = np.random.default_rng(2)
    v, w = (mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3))) for _ in range(2))
    direct = fvf.Dtilde_F(mesh, v) @ fvf.D_F(mesh, w) - fvf.Dtilde_F(mesh, w) @ fvf.D_F(mesh, v)
    B = fvf.bracket_F(mesh, v, w)
    assert abs(B - direct).max() <= 1e-12 * abs(direct).max()


def test_theorem1_holds_at_interior_vertices_only(mesh):
    """D^F_[J∇f, J∇g] h = −D̃^F_{J∇h} {f, g} (eq. 60) needs div J grad = 0."""
    f, g, h = smooth_functions(mesh)
    v, u = (fvf.rotate(mesh, fvf.gradient(mesh, x)) for x in (f, g))
    lhs = fvf.bracket_F(mesh, v, u) @ h
    rhs = -fvf.Dtilde_F(mesh, fvf.rotate(mesh, fvf.gradient(mesh, h))) @ fvf.poisson_bracket(
        mesh, f, g
    )
    err = np.abs(lhs - rhs)
    b = mesh.boundary_vertices
    assert err[interior(mesh)].max() <= 1e-11 * np.abs(rhs).max()
    assert err[b].max() >= 0.01 * np.abs(rhs[b]).max()


# ---------------------------------------------------------------------------- flows
def test_chapter_flow_keeps_the_norm_for_fields_tangent_to_the_boundary(small_mesh):
    mesh = small_mesh
    v = fvf.rotate(mesh, fvf.gradient(mesh, stream_constant_on_loops(mesh)))
    v /= np.linalg.norm(v, axis=1).max()
    phi = fvf.FunctionalFlow(mesh, v)
    f0 = smooth_functions(mesh)[0]
    f1 = phi(f0, 3 * mesh.mean_edge_length)
    assert abs(phi.norm(f1) / phi.norm(f0) - 1) <= 1e-10
    assert max(phi.growth_rate) <= 1e-10 * abs(phi.operator).max()


def test_chapter_flow_can_grow_through_inflow_boundaries(small_mesh):
    """No boundary condition: at an inflow boundary vertex D^V_v averages the derivative
    over the faces downstream of it, and the flow of a divergence-free field can grow."""
    mesh = small_mesh
    _, g, _ = smooth_functions(mesh)
    v = fvf.rotate(mesh, fvf.gradient(mesh, g))
    v /= np.linalg.norm(v, axis=1).max()
    mu = fvf.FunctionalFlow(mesh, v).growth_rate
    assert min(mu) > 1e-3  # per unit time at unit top speed (woody: 0.094 and 0.11)


def test_skew_flow_energy_law_includes_the_boundary_terms(small_mesh):
    """d/dt ‖f‖² = ⟨f, [div v] f⟩: with div v at boundary vertices the boundary flux, this is
    the continuum law d/dt ∫f² = −∮ f² ⟨v, n⟩ for a divergence-free v (inflow adds)."""
    mesh = small_mesh
    _, g, _ = smooth_functions(mesh)
    v = fvf.rotate(mesh, fvf.gradient(mesh, g))
    f = smooth_functions(mesh)[0]
    S = fvf.skew_operator(mesh, v)
    a = mesh.vertex_areas
    rate = -2 * f @ (a * (S @ f))
    d = fvf.divergence(mesh, v)
    assert abs(rate - (a * d) @ (f * f)) <= 1e-12 * (np.abs(a * d) @ (f * f))
    assert abs((a * d)[interior(mesh)]).max() <= 1e-12 * np.abs(a * d).max()


def test_upwind_holds_values_where_nothing_flows_in(mesh):
    """The upwind scheme counts no flux through the mesh boundary (the exterior value is
    the vertex's own): a vertex with no inflow through its interior dual edges — a pure
    inflow boundary vertex — keeps its value, and only boundary vertices can be such."""
    _, g, _ = smooth_functions(mesh)
    v = fvf.rotate(mesh, fvf.gradient(mesh, g))
    v /= np.linalg.norm(v, axis=1).max()
    G = fvf.upwind_operator(mesh, v)
    F = fvf.dual_edge_fluxes(mesh, v)
    no_inflow = np.asarray((F < 0).sum(axis=1)).ravel() == 0
    row_zero = np.asarray(abs(G).sum(axis=1)).ravel() == 0
    np.testing.assert_array_equal(no_inflow, row_zero)
    held = np.flatnonzero(row_zero)  # camelhead's field has none
    assert np.isin(held, mesh.boundary_vertices).all()
    f0 = smooth_functions(mesh)[1]
    f1 = fvf.flow(mesh, v, f0, 5 * mesh.mean_edge_length, method="upwind")
    np.testing.assert_allclose(f1[held], f0[held], rtol=0, atol=1e-13 * np.abs(f0).max())
    assert f0.min() - 1e-12 <= f1.min() and f1.max() <= f0.max() + 1e-12


# ---------------------------------------------------------------------------- design
@pytest.mark.parametrize("name", FLAT)
def test_design_has_a_free_boundary(name):
    """The connection energy couples faces across interior edges only: no condition at the
    boundary, so on a flat mesh the parallel (constant) field has zero energy and one
    constraint spreads to every face, boundary faces included."""
    mesh = mesh_of(name)
    energy, _ = fvf.smoothest_fields(mesh, 1)
    assert abs(energy[0]) <= 1e-10
    u = fvf.design_field(mesh, [5], [[1.0, 2.0, 0.0]], hard=True)
    np.testing.assert_allclose(
        u, np.tile([1.0, 2.0, 0.0] / np.sqrt(5), (mesh.n_faces, 1)), atol=1e-12
    )


def test_connection_couples_interior_edges_only(mesh):
    """Knöppel's energy has one term per interior edge: a boundary face has one coupling
    fewer per boundary edge (no ghost neighbour, no term pulling it along the boundary)."""
    L = fvf.connection_laplacian(mesh)
    _, face, _ = boundary_edge_geometry(mesh)
    couplings = np.diff(L.indptr) - 1  # off-diagonal entries of each face's row
    missing = np.bincount(face, minlength=mesh.n_faces)
    np.testing.assert_array_equal(couplings + missing, 3)


# ---------------------------------------------------------------------------- singularities
def test_boundary_vertices_get_no_index(mesh):
    rng = np.random.default_rng(4)
    u = mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3)))
    ind = fvf.vertex_indices(mesh, u)
    assert not ind[mesh.boundary_vertices].any()


def test_poincare_hopf_is_not_guaranteed_with_boundary():
    """Indices are summed over interior vertices only and boundary turning is not counted,
    so the sum is chi only in special cases: on the disk (chi = 1) the rotation, tangent
    to the boundary, has one +1 centre, while a constant field (crossing the boundary)
    has no singularity at all."""
    mesh = mesh_of("disk")
    rot = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    ids, ind = fvf.singularities(mesh, rot)
    assert ind.sum() == mesh.euler_characteristic == 1 and ids.tolist() == [0]
    ids, _ = fvf.singularities(mesh, np.tile([1.0, 0.3, 0.0], (mesh.n_faces, 1)))
    assert ids.size == 0


# ---------------------------------------------------------------------------- spectral, fluid
def test_killing_field_of_the_disk_is_the_rotation():
    mesh = fvf.disk(8, 6)
    energies, fields = fvf.killing_fields(mesh, 2, k=30)
    assert energies[0] < 0.5 * energies[1]  # measured 0.57 vs 1.69
    rot = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    a = mesh.face_areas
    cos = abs(a @ (fields[0] * rot).sum(1)) / np.sqrt(a @ (rot * rot).sum(1))
    assert cos > 0.999  # measured 0.99935


def test_fluid_has_free_slip_walls(small_mesh):
    """ψ = 0 on the boundary, so u = J grad ψ is tangent to every boundary edge and the
    energy and enstrophy are conserved; the spectral method refuses a boundary."""
    mesh = small_mesh
    X = mesh.vertices
    c = X[interior(mesh)[len(interior(mesh)) // 2]]
    omega = np.exp(-((X - c) ** 2).sum(1) / (0.1 * np.ptp(X, axis=0).max()) ** 2)
    psi = StreamFunctionSolver(mesh)(omega)
    assert not psi[mesh.boundary_vertices].any()
    u = stream_velocity(mesh, psi)
    _, face, n = boundary_edge_geometry(mesh)
    assert np.abs((u[face] * n).sum(1)).max() <= 1e-12 * np.abs(u).max() * np.abs(n).max()
    res = fvf.ideal_fluid(mesh, omega, fvf.fluid_time_step(mesh, omega), 5)
    assert res.drift()["energy"] <= 1e-10 and res.drift()["enstrophy"] <= 1e-10
    with pytest.raises(fvf.ParameterError, match="closed mesh"):
        fvf.ideal_fluid(mesh, omega, 0.01, 1, method="spectral", k=8)


def test_transport_keeps_a_field_along_itself(small_mesh):
    """Ad_{Φ_v,t} v = v (the generator kills v) with or without boundary."""
    mesh = small_mesh
    v = fvf.rotate(mesh, fvf.gradient(mesh, smooth_functions(mesh)[1]))
    v /= np.linalg.norm(v, axis=1).max()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = fvf.Ad(mesh, v, v, 2 * mesh.mean_edge_length)
    np.testing.assert_allclose(out, v, atol=1e-9)
