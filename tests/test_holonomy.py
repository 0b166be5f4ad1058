"""The face connection with smoothed holonomy (fvf.design.holonomy): exact discrete
identities, the cones it frees on a mesh whose curvature sits on 12 vertices, bad input."""

from __future__ import annotations

import numpy as np
import pytest

import fvf
from fvf.design.connection import connection_laplacian
from fvf.design.holonomy import holonomy_rotations, smoothed_angle_defects
from fvf.design.indices import _angle_defects
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
    K = _angle_defects(mesh)
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
    K = _angle_defects(mesh)
    np.testing.assert_allclose(div, K - smoothed_angle_defects(mesh, ell), atol=1e-10)
    L = connection_laplacian(mesh, n=4, curvature_smoothing=ell)
    assert abs(L - L.conj().T).max() == 0
    z = np.random.default_rng(0).standard_normal((mesh.n_faces, 3)) @ [1, 1j, 0]
    assert np.real(np.vdot(z, L @ z)) > 0
    assert connection_laplacian(mesh, n=4) is not L  # cached apart from the plain one


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
    np.testing.assert_allclose(div, _angle_defects(mesh) - Kt, atol=1e-10)


def test_smoothing_frees_the_cones_of_a_flat_icosahedron():
    """Plain connection: the smoothest cross field has a cone on each of the 12 spikes
    (12 × +1/4 and 4 × −1/4 elsewhere). Smoothed over three edges: the 8 × +1/4 of a
    sphere (where on this symmetric mesh is arbitrary: at least 4 spikes carry none)."""
    mesh = flat_icosahedron()
    spikes = np.flatnonzero(np.abs(_angle_defects(mesh)) > 1e-9)
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
