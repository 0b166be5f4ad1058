"""Property tests (hypothesis) on random small meshes and random fields.

Meshes: star-shaped spheres (an icosphere with random radii and a random rotation and
scale) and tori of random proportions; every identity must hold on each draw.
"""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import fvf
from conftest import rel
from fvf import chapter as ch

SETTINGS = settings(
    max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)


@st.composite
def meshes(draw):
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    scale = 10.0 ** draw(st.floats(-3, 3))
    if draw(st.booleans()):
        base = fvf.icosphere(draw(st.integers(1, 2)))
        r = rng.uniform(0.6, 1.4, base.n_vertices)
        X, F = base.vertices * r[:, None], base.faces
    else:
        R = draw(st.floats(1.0, 3.0))
        t = fvf.torus(draw(st.integers(6, 14)), draw(st.integers(4, 8)), R=R, r=0.5)
        X, F = t.vertices + rng.uniform(-0.02, 0.02, t.vertices.shape), t.faces
    Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    if np.linalg.det(Q) < 0:
        Q[:, 0] *= -1
    shift = rng.uniform(-5, 5, 3)
    mesh = fvf.TriMesh(scale * (X @ Q.T + shift), F)
    return mesh, rng


def fields(mesh, rng, k=2):
    return [mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3))) for _ in range(k)]


@SETTINGS
@given(meshes())
def test_calculus_identities(draw):
    mesh, rng = draw
    (v,) = fields(mesh, rng, 1)
    f = rng.standard_normal(mesh.n_vertices)
    a = v.ravel() @ (fvf.face_mass(mesh) @ (ch.grad(mesh) @ f))
    b = (ch.div(mesh) @ v.ravel()) @ (mesh.vertex_areas * f)
    assert abs(a + b) <= 1e-11 * (abs(a) + abs(b))
    Jg = ch.J(mesh) @ (ch.grad(mesh) @ f)
    d = ch.div(mesh) @ Jg
    assert np.abs(d).max() <= 1e-12 * abs(ch.div(mesh)).max() * np.abs(Jg).max()
    L = ch.L(mesh)
    assert np.abs(L @ np.ones(mesh.n_vertices)).max() <= 1e-11 * abs(L).max()


@SETTINGS
@given(meshes())
def test_operator_identities(draw):
    mesh, rng = draw
    v, w = fields(mesh, rng)
    f = rng.standard_normal(mesh.n_vertices)
    ff = rng.standard_normal(mesh.n_faces)
    # Lemma 9 (the coordinates are large here, so relative to |X| |grad phi|)
    g = np.linalg.norm(fvf.calculus.hat_gradients(mesh), axis=2)
    x = np.linalg.norm(mesh.vertices[mesh.faces], axis=2)
    err = np.abs(ch.extract_field(mesh, ch.D_F(mesh, v)) - v).max(axis=1)
    assert (err <= 1e-14 * np.linalg.norm(v, axis=1) * (g * x).sum(1)).all()
    # duals (37-38, 53)
    assert rel(ch.Dbar_V(mesh, f) @ v.ravel(), ch.D_V(mesh, v) @ f) < 1e-12
    assert rel(ch.Dtilde_dual_F(mesh, ff) @ v.ravel(), ch.Dtilde_F(mesh, v) @ ff) < 1e-11
    assert rel(ch.Dtilde_dual_V(mesh, f) @ v.ravel(), ch.Dtilde_V(mesh, v) @ f) < 1e-11
    # (54) = Lemma 14 assembly, and ad_v (62)
    comp = ch.Dtilde_F(mesh, v) @ ch.D_F(mesh, w) - ch.Dtilde_F(mesh, w) @ ch.D_F(mesh, v)
    assert rel(ch.bracket_F(mesh, v, w), comp) < 1e-10
    u = (ch.ad(mesh, v) @ w.ravel()).reshape(-1, 3)
    assert rel(u, comp @ mesh.vertices) < 1e-9


@SETTINGS
@given(meshes())
def test_theorem1_random(draw):
    mesh, rng = draw
    X = mesh.vertices
    c = rng.standard_normal((3, 3))
    Y = (X - X.mean(0)) / np.abs(X - X.mean(0)).max()
    f, g, h = (np.sin(Y @ c[i]) for i in range(3))
    v = fvf.rotate(mesh, fvf.gradient(mesh, f))
    u = fvf.rotate(mesh, fvf.gradient(mesh, g))
    lhs = ch.bracket_F(mesh, v, u) @ h
    rhs = -ch.Dtilde_F(mesh, fvf.rotate(mesh, fvf.gradient(mesh, h))) @ ch.poisson_bracket(
        mesh, f, g
    )
    assert rel(lhs, rhs) < 1e-9


@SETTINGS
@given(meshes(), st.floats(-2, 2))
def test_flow_semigroup_random(draw, t):
    mesh, rng = draw
    X = mesh.vertices
    g = np.sin((X - X.mean(0)) @ rng.standard_normal(3) / np.abs(X - X.mean(0)).max())
    v = fvf.rotate(mesh, fvf.gradient(mesh, g))  # divergence-free: no growth
    v *= mesh.mean_edge_length / max(np.abs(v).max(), 1e-300)  # move ~one edge per unit time
    f = rng.standard_normal(mesh.n_vertices)
    phi = fvf.FunctionalFlow(mesh, v)
    a = phi(phi(f, t), 0.5)
    assert rel(a, phi(f, t + 0.5)) < 1e-10
    assert abs(phi.norm(a) - phi.norm(f)) <= 1e-10 * phi.norm(f)
