"""Discrete calculus (§3.1): exact identities, structure, and agreement with libigl."""

import numpy as np
import pytest
import scipy.sparse as sp

import fvf
from conftest import random_tangent_field, rel, smooth_functions
from fvf import chapter as ch

igl = pytest.importorskip("igl")


def test_areas_partition_the_surface(closed):
    AF, AV = ch.A_F(closed), ch.A_V(closed)
    assert AF.shape == (closed.n_faces,) and AV.shape == (closed.n_vertices,)
    assert (AF > 0).all() and (AV > 0).all()
    assert abs(AV.sum() - AF.sum()) <= 1e-12 * AF.sum()
    # barycentric: a third of each adjacent face
    ref = np.zeros(closed.n_vertices)
    np.add.at(ref, closed.faces.ravel(), np.repeat(AF / 3, 3))
    assert np.allclose(AV, ref, rtol=1e-14, atol=0)


def test_grad_of_coordinates_is_tangent_projection(closed):
    """grad x_k on face t is the tangent part of e_k: the exact basis of Lemma 9."""
    G = ch.grad(closed)
    assert G.shape == (3 * closed.n_faces, closed.n_vertices)
    assert np.diff(G.indptr).max() == 3 and np.diff(G.indptr).min() == 3
    N = closed.face_normals
    for k in range(3):
        gk = (G @ closed.vertices[:, k]).reshape(-1, 3)
        ek = np.eye(3)[k] - N[:, k : k + 1] * N
        assert np.abs(gk - ek).max() < 1e-9
    assert np.abs(G @ np.ones(closed.n_vertices)).max() < 1e-9 / closed.mean_edge_length


def test_div_J_grad_vanishes(closed):
    """§3.1.1: div(J grad f) = 0 exactly on a closed mesh."""
    f, _, _ = smooth_functions(closed)
    Jg = ch.J(closed) @ (ch.grad(closed) @ f)
    d = ch.div(closed) @ Jg
    scale = abs(ch.div(closed)).max() * np.abs(Jg).max()
    assert np.abs(d).max() <= 1e-13 * scale


def test_div_J_grad_on_boundary_meshes_vanishes_inside_only(with_boundary):
    """With boundary, div J grad f = 0 at interior vertices; boundary vertices carry flux."""
    mesh = with_boundary
    X = mesh.vertices
    f = X[:, 0] ** 2 + X[:, 1]
    d = ch.div(mesh) @ (ch.J(mesh) @ (ch.grad(mesh) @ f))
    scale = abs(ch.div(mesh)).max() * np.abs(ch.grad(mesh) @ f).max()
    interior = np.setdiff1d(np.arange(mesh.n_vertices), mesh.boundary_vertices)
    assert np.abs(d[interior]).max() <= 1e-12 * scale
    assert np.abs(d[mesh.boundary_vertices]).max() > 1e-6 * scale


@pytest.mark.parametrize("boundary", [False, True])
def test_integration_by_parts(boundary, closed, rng):
    """Lemma 7 (31): ⟨v, grad f⟩ + ⟨div v, f⟩ = 0 exactly, also with boundary."""
    mesh = fvf.disk(6, 6) if boundary else closed
    v = random_tangent_field(mesh, rng)
    f = rng.standard_normal(mesh.n_vertices)
    a = v.ravel() @ (fvf.face_mass(mesh) @ (ch.grad(mesh) @ f))
    b = (ch.div(mesh) @ v.ravel()) @ (mesh.vertex_areas * f)
    assert abs(a + b) <= 1e-12 * (abs(a) + abs(b))


def test_laplacian_structure(closed, rng):
    L = ch.L(closed)
    AL = sp.diags_array(closed.vertex_areas) @ L
    assert rel(AL, AL.T) < 1e-13  # self-adjoint in the A_V inner product
    assert rel(L, -(ch.div(closed) @ ch.grad(closed))) < 1e-12
    assert np.abs(L @ np.ones(closed.n_vertices)).max() < 1e-10 * abs(L).max()
    f = rng.standard_normal(closed.n_vertices)
    assert f @ (AL @ f) > 0
    assert L.nnz == closed.n_vertices + 2 * closed.n_edges  # 1-ring


def test_interpolation_adjoint_and_averages(closed, rng):
    IVF, IFV = ch.I_VF(closed), ch.I_FV(closed)
    AF, AV = closed.face_areas, closed.vertex_areas
    assert IVF.shape == (closed.n_vertices, closed.n_faces)
    assert IFV.shape == (closed.n_faces, closed.n_vertices)
    assert rel(IFV, sp.diags_array(1 / AF) @ IVF.T @ sp.diags_array(AV)) < 1e-13
    assert np.allclose(IVF @ np.ones(closed.n_faces), 1, atol=1e-13)
    assert np.allclose(IFV @ np.ones(closed.n_vertices), 1, atol=1e-15)
    g, ff = rng.standard_normal(closed.n_vertices), rng.standard_normal(closed.n_faces)
    assert np.isclose(ff @ (AF * (IFV @ g)), (IVF @ ff) @ (AV * g), rtol=1e-12)


def test_rotation_J(closed, rng):
    J = ch.J(closed)
    u = random_tangent_field(closed, rng)
    Ju = (J @ u.ravel()).reshape(-1, 3)
    assert np.abs(np.einsum("ij,ij->i", Ju, u)).max() < 1e-12
    assert np.allclose(np.linalg.norm(Ju, axis=1), np.linalg.norm(u, axis=1), rtol=1e-12)
    assert np.abs(J @ (J @ u.ravel()) + u.ravel()).max() < 1e-12
    assert np.allclose(Ju, fvf.rotate(closed, u), atol=1e-15)
    # J is the multiplication by i in the face frames; (b1, b2, N) right-handed
    assert np.allclose(closed.to_complex(Ju), 1j * closed.to_complex(u), atol=1e-12)
    B = closed.face_bases
    assert np.allclose(np.cross(B[:, 0], B[:, 1]), closed.face_normals, atol=1e-12)


def test_bullet_properties(closed, rng):
    """Properties 1–6 of [·], [·]• and [·]•ᵀ (§3.1)."""
    v, w = random_tangent_field(closed, rng), random_tangent_field(closed, rng)
    ff, gg = rng.standard_normal(closed.n_faces), rng.standard_normal(closed.n_faces)
    P, Q = fvf.calculus.field_product, fvf.calculus.field_inner
    assert np.allclose(fvf.calculus.diag(ff) @ gg, fvf.calculus.diag(gg) @ ff)  # 1
    assert rel(P(closed, v + w), P(closed, v) + P(closed, w)) < 1e-15  # 2
    assert np.allclose(Q(closed, v) @ w.ravel(), Q(closed, w) @ v.ravel())  # 3
    lhs, rhs = Q(closed, v) @ P(closed, w), fvf.calculus.diag(Q(closed, v) @ w.ravel())
    assert rel(lhs, rhs) < 1e-15  # 4
    # 5: block-diagonal outer products
    outer = (P(closed, v) @ Q(closed, w)).tocsr()[:9, :9].toarray()
    ref = np.zeros((9, 9))
    for t in range(3):
        ref[3 * t : 3 * t + 3, 3 * t : 3 * t + 3] = np.outer(v[t], w[t])
    assert np.allclose(outer, ref)
    assert np.allclose(P(closed, w) @ ff, fvf.calculus.diag(ff, 3) @ w.ravel())  # 6


def test_poisson_bracket_antisymmetric(closed):
    f, g, _ = smooth_functions(closed)
    pb = ch.poisson_bracket(closed, f, g)
    assert pb.shape == (closed.n_faces,)
    assert np.abs(pb + ch.poisson_bracket(closed, g, f)).max() <= 1e-14 * np.abs(pb).max()
    assert np.abs(ch.poisson_bracket(closed, f, f)).max() <= 1e-14 * np.abs(pb).max()


# ------------------------------------------------------------------ libigl as a peer
def _igl_face_major(G, m):
    """libigl stacks grad coordinate-major (row k*m + t); reorder to fvf's 3t + k."""
    return sp.csr_array(G)[(np.arange(3)[None, :] * m + np.arange(m)[:, None]).ravel()]


def test_agrees_with_libigl(closed):
    V, F = closed.vertices, closed.faces
    m = closed.n_faces
    assert rel(ch.grad(closed), _igl_face_major(igl.grad(V, F), m)) < 1e-12
    assert rel(fvf.stiffness(closed), -sp.csr_array(igl.cotmatrix(V, F))) < 1e-12
    M = igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_BARYCENTRIC)
    assert np.allclose(ch.A_V(closed), M.diagonal(), rtol=1e-12, atol=0)
    assert np.allclose(ch.A_F(closed), igl.doublearea(V, F) / 2, rtol=1e-12, atol=0)
    N = igl.per_face_normals(V, F, np.array([0.0, 0.0, 1.0]))
    assert np.abs(closed.face_normals - N).max() < 1e-12
    L_igl = -sp.diags_array(1 / M.diagonal()) @ sp.csr_array(igl.cotmatrix(V, F))
    assert rel(ch.L(closed), L_igl) < 1e-12
