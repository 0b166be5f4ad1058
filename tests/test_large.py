"""Slow: the exact identities on the larger shared meshes (20k to 750k faces).

Run with ``pytest -m slow`` (the third job of .ci/run).
"""

import numpy as np
import pytest

import fvf
from conftest import load_shared, random_tangent_field, rel, smooth_functions
from fvf import chapter as ch

pytestmark = pytest.mark.slow

LARGE = [
    "rocker-arm.obj",
    "camelhead.off",
    "stanford-bunny.obj",
    "armadillo.obj",
    "nefertiti.obj",
    "armadillo_loop1.ply",
    "armadillo_750k.ply",
]


@pytest.fixture(scope="module", params=LARGE)
def large(request):
    return load_shared(request.param)


def test_identities_on_large_meshes(large, rng):
    mesh = large
    v, w = random_tangent_field(mesh, rng), random_tangent_field(mesh, rng)
    f, g, _ = smooth_functions(mesh)
    # Lemma 7
    a = v.ravel() @ (fvf.face_mass(mesh) @ (ch.grad(mesh) @ f))
    b = (ch.div(mesh) @ v.ravel()) @ (mesh.vertex_areas * f)
    assert abs(a + b) <= 1e-11 * (abs(a) + abs(b))
    # div J grad = 0 away from the boundary
    d = ch.div(mesh) @ (ch.J(mesh) @ (ch.grad(mesh) @ f))
    inside = np.setdiff1d(np.arange(mesh.n_vertices), mesh.boundary_vertices)
    scale = abs(ch.div(mesh)).max() * np.abs(ch.grad(mesh) @ f).max()
    assert np.abs(d[inside]).max() <= 1e-12 * scale
    # (36), duals, (54) = Lemma 14 assembly, ad (62)
    assert rel(ch.D_V(mesh, v), ch.I_VF(mesh) @ ch.D_F(mesh, v)) < 1e-12
    assert rel(ch.Dbar_V(mesh, f) @ v.ravel(), ch.D_V(mesh, v) @ f) < 1e-12
    comp = ch.Dtilde_F(mesh, v) @ ch.D_F(mesh, w) - ch.Dtilde_F(mesh, w) @ ch.D_F(mesh, v)
    assert rel(ch.bracket_F(mesh, v, w), comp) < 1e-10
    u = (ch.ad(mesh, v) @ w.ravel()).reshape(-1, 3)
    assert rel(u, comp @ mesh.vertices) < 1e-9
    # divergence-free flows keep the norm (on closed meshes: J grad g has boundary flux)
    if not mesh.is_closed:
        return
    J = fvf.rotate(mesh, fvf.gradient(mesh, g))
    J *= mesh.mean_edge_length / np.abs(J).max()
    phi = fvf.FunctionalFlow(mesh, J)
    assert abs(phi.norm(phi(f, 20.0)) - phi.norm(f)) <= 1e-10 * phi.norm(f)


def test_million_faces_smoke():
    """Every operator builds on a 1.5M-face mesh (spot subdivided four times)."""
    mesh = fvf.mesh.builtin.spot()
    X, F = mesh.vertices, mesh.faces
    for _ in range(4):
        n = X.shape[0]
        a, b = F[:, [1, 2, 0]].ravel(), F[:, [2, 0, 1]].ravel()
        key = np.minimum(a, b) * n + np.maximum(a, b)
        uniq, inv = np.unique(key, return_inverse=True)
        X = np.vstack([X, 0.5 * (X[uniq // n] + X[uniq % n])])
        e = n + inv.reshape(-1, 3)
        F = np.vstack(
            [
                np.stack([F[:, 0], e[:, 2], e[:, 1]], 1),
                np.stack([F[:, 1], e[:, 0], e[:, 2]], 1),
                np.stack([F[:, 2], e[:, 1], e[:, 0]], 1),
                e,
            ]
        )
    big = fvf.TriMesh(X, F)
    assert big.n_faces == 5856 * 256 and big.euler_characteristic == 2
    v = fvf.rotate(big, fvf.gradient(big, X[:, 1]))
    w = fvf.gradient(big, X[:, 0])
    L = fvf.laplacian(big)
    assert np.abs(L @ np.ones(big.n_vertices)).max() < 1e-9 * abs(L).max()
    BF = fvf.bracket_F(big, v, w)
    assert BF.nnz == L.nnz
    assert np.isfinite(fvf.commutator_field(big, v, w)).all()
