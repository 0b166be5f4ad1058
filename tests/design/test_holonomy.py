"""The face connection with smoothed holonomy (fvf.design.holonomy): exact discrete
identities, the cones it frees on a mesh whose curvature sits on 12 vertices, bad input."""

from __future__ import annotations

import numpy as np
import pytest

import fvf
from fvf.design.connection import connection_laplacian
from fvf.design.holonomy import holonomy_rotations, smoothed_angle_defects
from fvf.mesh.geometry import angle_defects
from fvf.mesh.shapes import _icosahedron, midpoint_subdivision


def flat_icosahedron(levels: int = 3) -> fvf.TriMesh:
    """The icosahedron subdivided without projection: flat faces, so the whole curvature
    (4π) sits on its 12 vertices, π/3 each, beyond the π/4 that forces a cross-field cone."""
    X, F = _icosahedron()
    for _ in range(levels):
        X, F = midpoint_subdivision(X, F)
    return fvf.TriMesh(X, F)


def test_smoothed_defects_keep_the_total_and_spread_the_spikes():
    mesh = flat_icosahedron()
    K = angle_defects(mesh)
    spikes = np.flatnonzero(np.abs(K) > 1e-9)
    assert spikes.size == 12 and np.allclose(K[spikes], np.pi / 3)
    Kt = smoothed_angle_defects(mesh, 3 * mesh.mean_edge_length)
    assert Kt.sum() == pytest.approx(4 * np.pi, abs=1e-10)  # 2πχ, χ = 2
    assert np.abs(Kt).max() < 0.2 * np.pi / 3  # no vertex keeps a fifth of a spike
    assert np.all(Kt > -1e-12)  # a heat step of positive curvature stays positive


def test_rotations_give_the_smoothed_holonomy_exactly():
    """Gᵀx = K − K̃ at every vertex (G the signed edge-vertex incidence), to round-off;
    x is a gradient (least norm); and the turned Laplacian is still Hermitian PSD."""
    mesh = fvf.jittered_sphere(3, seed=4)
    ell = 2 * mesh.mean_edge_length
    x = holonomy_rotations(mesh, ell)
    E = mesh.edges
    div = np.bincount(E[:, 1], x, mesh.n_vertices) - np.bincount(E[:, 0], x, mesh.n_vertices)
    K = angle_defects(mesh)
    np.testing.assert_allclose(div, K - smoothed_angle_defects(mesh, ell), atol=1e-10)
    L = connection_laplacian(mesh, n=4, curvature_smoothing=ell)
    assert abs(L - L.conj().T).max() == 0
    z = np.random.default_rng(0).standard_normal((mesh.n_faces, 3)) @ [1, 1j, 0]
    assert np.real(np.vdot(z, L @ z)) > 0
    assert connection_laplacian(mesh, n=4) is not L  # cached apart from the plain one


def test_rotations_are_computed_once_per_mesh_and_length():
    """The quad pipeline designs with them and measures cones with them: one computation,
    shared read-only (a new length is a new one)."""
    mesh = fvf.jittered_sphere(2, seed=2)
    ell = 2 * mesh.mean_edge_length
    x = holonomy_rotations(mesh, ell)
    assert holonomy_rotations(mesh, ell) is x and not x.flags.writeable
    assert holonomy_rotations(mesh, 2 * ell) is not x


def test_each_component_keeps_its_own_total():
    """Two disjoint spheres: the heat step and the rotations work per component (one
    grounded vertex each), so each keeps 4π and the identity holds on both."""
    a, b = fvf.jittered_sphere(2, seed=1), fvf.icosphere(2)
    X = np.vstack([a.vertices, b.vertices + [3.0, 0.0, 0.0]])
    F = np.vstack([a.faces, b.faces + a.n_vertices])
    mesh = fvf.TriMesh(X, F)
    ell = 2 * mesh.mean_edge_length
    Kt = smoothed_angle_defects(mesh, ell)
    assert Kt[: a.n_vertices].sum() == pytest.approx(4 * np.pi, abs=1e-10)
    assert Kt[a.n_vertices :].sum() == pytest.approx(4 * np.pi, abs=1e-10)
    x = holonomy_rotations(mesh, ell)
    E = mesh.edges
    div = np.bincount(E[:, 1], x, mesh.n_vertices) - np.bincount(E[:, 0], x, mesh.n_vertices)
    np.testing.assert_allclose(div, angle_defects(mesh) - Kt, atol=1e-10)


def test_smoothing_frees_the_cones_of_a_flat_icosahedron():
    """Plain connection: the smoothest cross field has a cone on each of the 12 spikes
    (12 × +1/4 and 4 × −1/4 elsewhere). Smoothed over three edges: the 8 × +1/4 of a
    sphere (where on this symmetric mesh is arbitrary: at least 4 spikes carry none)."""
    mesh = flat_icosahedron()
    spikes = np.flatnonzero(np.abs(angle_defects(mesh)) > 1e-9)
    u0 = fvf.smoothest_fields(mesh, 1, n=4)[1][0]
    ids0, ind0 = fvf.singularities(mesh, u0, n=4)
    assert np.isin(spikes, ids0).all() and ids0.size == 16
    u = fvf.design_field(mesh, n=4, curvature_smoothing=3 * mesh.mean_edge_length)
    ids, ind = fvf.singularities(mesh, u, n=4)
    np.testing.assert_array_equal(ind, np.full(8, 0.25))


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), "wide"])
def test_bad_smoothing_length(bad):
    with pytest.raises(fvf.ParameterError, match="curvature_smoothing"):
        fvf.design_field(fvf.icosphere(2), n=4, curvature_smoothing=bad)


def test_smoothing_needs_a_closed_mesh_and_edge_transports():
    with pytest.raises(fvf.ParameterError, match="closed mesh"):
        fvf.design_field(fvf.disk(), n=4, curvature_smoothing=0.1)
    with pytest.raises(fvf.ParameterError, match="knoppel"):
        fvf.smoothest_fields(fvf.icosphere(2), 1, "singer_wu", n=4, curvature_smoothing=0.1)


# ------------------------------------------------------- measuring against the turned connection
def random_cross_field(mesh: fvf.TriMesh, seed: int) -> np.ndarray:
    g = np.random.default_rng(seed).standard_normal((mesh.n_faces, 3))
    return mesh.project_tangent(g)


def test_zero_rotations_are_the_levi_civita_connection():
    mesh = fvf.jittered_sphere(2, seed=3)
    u = random_cross_field(mesh, 0)
    zero = np.zeros(mesh.n_edges)
    np.testing.assert_array_equal(
        fvf.vertex_indices(mesh, u, n=4, connection_rotations=zero),
        fvf.vertex_indices(mesh, u, n=4),
    )
    np.testing.assert_array_equal(
        fvf.period_jumps(mesh, u, 4, connection_rotations=zero), fvf.period_jumps(mesh, u, 4)
    )
    cut = fvf.cut_graph(mesh, u, 4, connection_rotations=zero)
    np.testing.assert_array_equal(cut.mask, fvf.cut_graph(mesh, u, 4).mask)
    np.testing.assert_array_equal(
        fvf.comb(mesh, u, 4, cut, connection_rotations=zero), fvf.comb(mesh, u, 4, cut)
    )


def test_turned_indices_sum_to_chi_and_change_only_where_the_matching_does():
    """Any rotations: the indices still sum to χ (the turnings cancel in pairs and the
    turned holonomy sums to 2πχ). A vertex's index changes only if the nearest matching
    rint(N(φ_e − x_e)/2π) changed on one of its edges."""
    mesh = fvf.jittered_sphere(3, seed=5)
    u = random_cross_field(mesh, 1)
    x = np.random.default_rng(2).uniform(-0.6, 0.6, mesh.n_edges)
    plain = fvf.vertex_indices(mesh, u, n=4)
    turned = fvf.vertex_indices(mesh, u, n=4, connection_rotations=x)
    assert turned.sum() == pytest.approx(mesh.euler_characteristic, abs=1e-12)
    changed = np.flatnonzero(
        fvf.period_jumps(mesh, u, 4) != fvf.period_jumps(mesh, u, 4, connection_rotations=x)
    )
    assert changed.size > 0 and np.any(turned != plain)  # the case is not trivial
    assert set(np.flatnonzero(turned != plain)) <= set(mesh.edges[changed].ravel())


def test_a_field_combed_for_the_turned_connection_has_no_jump_off_the_cut():
    mesh = fvf.jittered_sphere(3, seed=6)
    ell = 2 * mesh.mean_edge_length
    x = holonomy_rotations(mesh, ell)
    u = fvf.design_field(mesh, n=4, align="curvature", curvature_smoothing=ell)
    cut = fvf.cut_graph(mesh, u, 4, connection_rotations=x)
    combed = fvf.comb(mesh, u, 4, cut, connection_rotations=x)[0]
    jumps = fvf.period_jumps(mesh, combed, 4, connection_rotations=x)
    interior = (mesh.edge_faces >= 0).all(axis=1)
    assert not jumps[interior & ~cut.mask].any()
    ids = fvf.singularities(mesh, u, n=4, connection_rotations=x)[0]
    assert set(ids) <= set(cut.edges.ravel())  # the cut runs through every cone


@pytest.mark.parametrize("bad", [np.zeros(5), np.full(30, np.nan)])
def test_bad_connection_rotations(bad):
    mesh = fvf.icosphere(1)
    u = random_cross_field(mesh, 0)
    if bad.size == 30:
        bad = np.full(mesh.n_edges, np.nan)
    with pytest.raises(fvf.ParameterError, match="connection_rotations"):
        fvf.vertex_indices(mesh, u, n=4, connection_rotations=bad)
    with pytest.raises(fvf.ParameterError, match="connection_rotations"):
        fvf.period_jumps(mesh, u, 4, connection_rotations=bad)
    with pytest.raises(fvf.ParameterError, match="connection_rotations"):
        fvf.cancel_close_singularities(mesh, u, 4, radius=0.1, connection_rotations=bad)


# ------------------------------------------------------- the alignment target diffused over ℓ
def noisy_ellipsoid() -> fvf.TriMesh:
    s = fvf.icosphere(4)
    X = s.vertices * [1.6, 1.0, 0.7]
    return fvf.TriMesh(X + 0.01 * np.random.default_rng(0).standard_normal(X.shape), s.faces)


def test_align_smoothing_averages_out_the_directions_of_noise():
    """Curvature alignment on a noisy ellipsoid follows the noise: 20 cones (Σ|I| = 5).
    Diffused over one edge length the target keeps the ellipsoid's directions only: the
    8 cones of a sphere's cross field. ℓ → 0 gives back the plain design."""
    mesh = noisy_ellipsoid()
    e = mesh.mean_edge_length
    plain = fvf.design_field(mesh, n=4, align="curvature")
    assert fvf.singularities(mesh, plain, n=4)[0].size == 20
    smoothed = fvf.design_field(mesh, n=4, align="curvature", align_smoothing=e)
    ids, ind = fvf.singularities(mesh, smoothed, n=4)
    np.testing.assert_array_equal(ind, np.full(8, 0.25))
    tiny = fvf.design_field(mesh, n=4, align="curvature", align_smoothing=1e-6 * e)
    np.testing.assert_allclose(tiny, plain, atol=1e-9)


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), "wide"])
def test_bad_align_smoothing(bad):
    with pytest.raises(fvf.ParameterError, match="align_smoothing"):
        fvf.design_field(fvf.icosphere(2), n=4, align="curvature", align_smoothing=bad)


def test_align_smoothing_needs_an_alignment():
    with pytest.raises(fvf.ParameterError, match="align="):
        fvf.design_field(fvf.icosphere(2), n=4, align_smoothing=0.1)


def test_a_conformal_scale_adds_its_curvature_exactly():
    """With log_scale s the holonomy around each vertex is K̃ + L s (the curvature of
    e^{2s} g, L the cotangent stiffness), the total stays 2πχ, a constant s changes
    nothing, and each scale is cached apart."""
    from fvf.calculus import stiffness

    mesh = fvf.jittered_sphere(3, seed=4)
    ell = 2 * mesh.mean_edge_length
    s = np.random.default_rng(1).uniform(0.0, 1.5, mesh.n_vertices)
    x = holonomy_rotations(mesh, ell, s)
    E = mesh.edges
    div = np.bincount(E[:, 1], x, mesh.n_vertices) - np.bincount(E[:, 0], x, mesh.n_vertices)
    target = smoothed_angle_defects(mesh, ell) + stiffness(mesh) @ s
    np.testing.assert_allclose(div, angle_defects(mesh) - target, atol=1e-10)
    assert target.sum() == pytest.approx(4 * np.pi, abs=1e-9)
    flat = holonomy_rotations(mesh, ell, np.full(mesh.n_vertices, 0.7))
    np.testing.assert_allclose(flat, holonomy_rotations(mesh, ell), atol=1e-10)
    assert holonomy_rotations(mesh, ell, s) is x and flat is not x
    L = connection_laplacian(mesh, n=4, curvature_smoothing=ell, log_scale=s)
    assert L is not connection_laplacian(mesh, n=4, curvature_smoothing=ell)


def test_a_bad_log_scale_is_refused():
    mesh = fvf.jittered_sphere(2, seed=2)
    ell = 2 * mesh.mean_edge_length
    with pytest.raises(fvf.ParameterError, match="one value per vertex"):
        holonomy_rotations(mesh, ell, np.zeros(mesh.n_faces))
    with pytest.raises(fvf.ParameterError, match="one value per vertex"):
        holonomy_rotations(mesh, ell, np.full(mesh.n_vertices, np.nan))
    with pytest.raises(fvf.ParameterError, match="pass both"):
        connection_laplacian(mesh, n=4, log_scale=np.zeros(mesh.n_vertices))
