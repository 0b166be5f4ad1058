"""Functional vector field operators, their duals, brackets and ad_v (§3.2–§4.4)."""

import numpy as np
import pytest
import scipy.sparse as sp

import fvf
from conftest import random_tangent_field, rel, smooth_functions
from fvf import chapter as ch


def _pattern(A) -> set:
    A = sp.coo_array(A)
    keep = A.data != 0
    return set(zip(A.row[keep].tolist(), A.col[keep].tolist(), strict=False))


def _one_ring(mesh) -> set:
    E = mesh.edges
    n = mesh.n_vertices
    return (
        set(zip(range(n), range(n), strict=False))
        | set(map(tuple, E.tolist()))
        | set(map(tuple, E[:, ::-1].tolist()))
    )


def test_D_F_definition_and_lemma8(closed, rng):
    """(35) D^F_v = [v]•ᵀ grad; Lemma 8: row t only touches the vertices of face t."""
    v = random_tangent_field(closed, rng)
    DF = ch.D_F(closed, v)
    assert DF.shape == (closed.n_faces, closed.n_vertices)
    assert rel(DF, fvf.calculus.field_inner(closed, v) @ ch.grad(closed)) < 1e-14
    A = sp.coo_array(DF)
    assert np.all(np.any(closed.faces[A.row] == A.col[:, None], axis=1))


def test_D_V_definition_and_lemma8(closed, rng):
    """(36) D^V_v = I_V^F D^F_v; Lemma 8: D^V_v(i, j) ≠ 0 only for i = j or (i, j) ∈ E."""
    v = random_tangent_field(closed, rng)
    DV = ch.D_V(closed, v)
    assert rel(DV, ch.I_VF(closed) @ ch.D_F(closed, v)) < 1e-13
    if closed.n_vertices < 6000:
        assert _pattern(DV) <= _one_ring(closed)
    # a PL directional derivative kills constants
    assert np.abs(DV @ np.ones(closed.n_vertices)).max() < 1e-12 * abs(DV).max()


def test_lemma9_field_from_operator(closed, rng):
    """(40) D^F_v X = v for tangent v, to round-off.

    The sum Σ_i ⟨v, ∇φ_i⟩ x_i cancels terms of size |v| |∇φ_i| |x_i|, so the round-off
    bound per face is eps times that (large on tiny faces far from the origin).
    """
    v = random_tangent_field(closed, rng)
    err = np.abs(ch.extract_field(closed, ch.D_F(closed, v)) - v).max(axis=1)
    g = np.linalg.norm(fvf.calculus.hat_gradients(closed), axis=2)  # (m, 3)
    x = np.linalg.norm(closed.vertices[closed.faces], axis=2)  # (m, 3)
    scale = np.linalg.norm(v, axis=1) * (g * x).sum(axis=1)
    assert (err <= 1e-14 * scale).all()


def test_duals(closed, rng):
    """(37–38) D̄^F_f v = D^F_v f and D̄^V_f v = D^V_v f; (53) for both D̃ duals."""
    v = random_tangent_field(closed, rng)
    f = rng.standard_normal(closed.n_vertices)
    ff = rng.standard_normal(closed.n_faces)
    assert rel(ch.Dbar_F(closed, f) @ v.ravel(), ch.D_F(closed, v) @ f) < 1e-13
    assert rel(ch.Dbar_V(closed, f) @ v.ravel(), ch.D_V(closed, v) @ f) < 1e-13
    assert rel(ch.Dtilde_dual_F(closed, ff) @ v.ravel(), ch.Dtilde_F(closed, v) @ ff) < 1e-12
    assert rel(ch.Dtilde_dual_V(closed, f) @ v.ravel(), ch.Dtilde_V(closed, v) @ f) < 1e-12
    assert ch.Dbar_F(closed, f).shape == (closed.n_faces, 3 * closed.n_faces)
    assert ch.Dbar_V(closed, f).shape == (closed.n_vertices, 3 * closed.n_faces)


def test_linearity_over_pc_functions(closed, rng):
    """(39): D^F_{[g]v} = [g] D^F_v holds; the same for D^V fails (it averages)."""
    v = random_tangent_field(closed, rng)
    g = rng.uniform(0.5, 2.0, closed.n_faces)
    gv = g[:, None] * v
    assert rel(ch.D_F(closed, gv), fvf.calculus.diag(g) @ ch.D_F(closed, v)) < 1e-14
    lhs = ch.D_V(closed, gv)
    rhs = fvf.calculus.diag(ch.I_VF(closed) @ g) @ ch.D_V(closed, v)
    assert rel(lhs, rhs) > 1e-3


def test_dtilde_definitions(closed, rng):
    """(52) literally, from div, [v]•, I_V^F and I_F^V."""
    v = random_tangent_field(closed, rng)
    D = ch.div(closed)
    divv = sp.diags_array(D @ v.ravel())
    P = fvf.calculus.field_product(closed, v)
    assert rel(ch.Dtilde_F(closed, v), D @ P - divv @ ch.I_VF(closed)) < 1e-12
    assert rel(ch.Dtilde_V(closed, v), D @ P @ ch.I_FV(closed) - divv) < 1e-12


def test_dtilde_equals_D_for_divergence_free(closed):
    """Smoothly D̃_v = D_v; discretely, for v = J grad g, D̃^V_v f and D^V_v f are both consistent."""
    f, g, _ = smooth_functions(closed)
    v = fvf.rotate(closed, fvf.gradient(closed, g))
    assert (
        np.abs(ch.div(closed) @ v.ravel()).max()
        < 1e-12 * abs(ch.div(closed)).max() * np.abs(v).max()
    )
    # The A_V-adjoint of D^V_v is −(D̃^V_v + [div v]) (docs/chapter.md); for div v = 0 it is
    # −D̃^V_v.
    AD = sp.diags_array(closed.vertex_areas) @ ch.D_V(closed, v)
    ADt = sp.diags_array(closed.vertex_areas) @ ch.Dtilde_V(closed, v)
    assert rel(AD.T, -ADt) < 1e-11
    assert rel(AD, -AD.T) < 1e-11  # skew: norm-preserving flows


def test_adjoint_of_D_V(closed, rng):
    """docs/chapter.md, 'Facts we measured': the A_V-adjoint of D^V_v is −(D̃^V_v + [div v])."""
    v = random_tangent_field(closed, rng)
    A = sp.diags_array(closed.vertex_areas)
    lhs = (A @ ch.D_V(closed, v)).T
    rhs = -A @ (ch.Dtilde_V(closed, v) + sp.diags_array(ch.div(closed) @ v.ravel()))
    assert rel(lhs, rhs) < 1e-11


def test_vertex_bracket_is_commutator_with_2ring(closed, rng):
    """(46) D^V_{[v,w]} = D^V_v D^V_w − D^V_w D^V_v; it reaches the 2-ring, not beyond."""
    v, w = random_tangent_field(closed, rng), random_tangent_field(closed, rng)
    Bv = ch.bracket_V(closed, v, w)
    Dv, Dw = ch.D_V(closed, v), ch.D_V(closed, w)
    assert rel(Bv, Dv @ Dw - Dw @ Dv) < 1e-14
    if closed.n_vertices < 6000:
        pat = _pattern(Bv)
        one = _one_ring(closed)
        indptr, indices, _ = closed.vertex_pattern
        ones = np.ones(indices.size)
        Adj = sp.csr_array((ones, indices, indptr), shape=(closed.n_vertices,) * 2)
        two = _pattern(Adj @ Adj)
        assert pat <= two
        assert len(pat - one) > 0  # genuinely wider than a functional vector field


def test_mixed_bracket_definition_lemma14_lemma16(closed, rng):
    """(54) as composed; Lemma 14 (55) form; Lemma 16: 1-ring sparsity."""
    v, w = random_tangent_field(closed, rng), random_tangent_field(closed, rng)
    BF = ch.bracket_F(closed, v, w)
    comp = ch.Dtilde_F(closed, v) @ ch.D_F(closed, w) - ch.Dtilde_F(closed, w) @ ch.D_F(closed, v)
    assert rel(BF, comp) < 1e-11
    D = ch.div(closed)
    lemma14 = (
        D @ ch.B(closed, v, w) @ ch.grad(closed)
        - sp.diags_array(D @ v.ravel()) @ ch.D_V(closed, w)
        + sp.diags_array(D @ w.ravel()) @ ch.D_V(closed, v)
    )
    assert rel(comp, lemma14) < 1e-11
    if closed.n_vertices < 6000:
        assert _pattern(comp) <= _one_ring(closed)
    # antisymmetry and constants in the kernel
    assert rel(ch.bracket_F(closed, w, v), -BF) < 1e-14
    assert np.abs(BF @ np.ones(closed.n_vertices)).max() < 1e-10 * abs(BF).max()


def test_lemma15_B(closed, rng):
    """(57) B(v,w) = [[v]•ᵀ J w] J, and B from its definition (55)."""
    v, w = random_tangent_field(closed, rng), random_tangent_field(closed, rng)
    Bm = ch.B(closed, v, w)
    P, Q = fvf.calculus.field_product, fvf.calculus.field_inner
    assert rel(Bm, P(closed, v) @ Q(closed, w) - P(closed, w) @ Q(closed, v)) < 1e-15
    Jw = ch.J(closed) @ w.ravel()
    assert rel(Bm, fvf.calculus.diag(Q(closed, v) @ Jw, 3) @ ch.J(closed)) < 1e-12


def test_theorem1(closed):
    """(60) D^F_{[v,u]} h = −D̃^F_{J grad h} {f, g} for v = J grad f, u = J grad g."""
    f, g, h = smooth_functions(closed)
    v = fvf.rotate(closed, fvf.gradient(closed, f))
    u = fvf.rotate(closed, fvf.gradient(closed, g))
    lhs = ch.bracket_F(closed, v, u) @ h
    Jgh = fvf.rotate(closed, fvf.gradient(closed, h))
    rhs = -ch.Dtilde_F(closed, Jgh) @ ch.poisson_bracket(closed, f, g)
    assert rel(lhs, rhs) < 1e-10


def test_ad_is_bracket_on_coordinates(closed, rng):
    """(62) ad_v(w) = D^F_{[v,w]} X, in fvf's layout (3n, 3m); Lemma 17 (63) blockwise."""
    v, w = random_tangent_field(closed, rng), random_tangent_field(closed, rng)
    A = ch.ad(closed, v)
    n, m = closed.n_vertices, closed.n_faces
    assert A.shape == (3 * n, 3 * m)
    u = (A @ w.ravel()).reshape(n, 3)
    assert rel(u, ch.extract_field(closed, ch.bracket_F(closed, v, w))) < 1e-11
    # Lemma 17 in the chapter's coordinate-major blocks
    Dt = ch.Dtilde_F(closed, v)
    blocks = sp.block_diag([Dt, Dt, Dt]) - sp.vstack(
        [ch.Dtilde_dual_F(closed, v[:, k]) for k in range(3)]
    )  # rows k*n + i; columns: components of w, stacked below as coordinate-major
    w_cm = w.T.ravel()  # coordinate-major w (3m,)
    first = (sp.block_diag([Dt, Dt, Dt]) @ w_cm).reshape(3, n).T
    second = sp.vstack([ch.Dtilde_dual_F(closed, v[:, k]) for k in range(3)]) @ w.ravel()
    assert rel(first - second.reshape(3, n).T, u) < 1e-11
    assert blocks.shape == (3 * n, 3 * m)
    # v is in the kernel of ad_v
    assert np.abs(A @ v.ravel()).max() < 1e-10 * np.abs(u).max()


def test_commutator_field_matches_extraction(closed, rng):
    v, w = random_tangent_field(closed, rng), random_tangent_field(closed, rng)
    u = fvf.commutator_field(closed, v, w)
    assert u.shape == (closed.n_vertices, 3)
    X = closed.vertices
    assert rel(u, ch.bracket_F(closed, v, w) @ (X - X.mean(0))) < 1e-15  # D X = D (X - c)
    assert rel(u, ch.bracket_F(closed, v, w) @ X) < 1e-11  # the same up to cancellation


@pytest.mark.parametrize("op", ["D_F", "D_V", "Dtilde_F", "Dtilde_V"])
def test_operators_linear_in_field(op, closed, rng):
    v, w = random_tangent_field(closed, rng), random_tangent_field(closed, rng)
    f = getattr(ch, op)
    assert rel(f(closed, 2 * v - 3 * w), 2 * f(closed, v) - 3 * f(closed, w)) < 1e-12
