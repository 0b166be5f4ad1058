"""Hermitian factorization backends, LOBPCG on one factorization, progress reporting."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import fvf
from fvf.numerics.cholesky import available_backends, factor_hermitian
from fvf.numerics.inverse_iteration import inverse_iteration
from fvf.numerics.progress import make_progress


def _system(n=4):
    mesh = fvf.torus(24, 12)
    L = fvf.connection_laplacian(mesh, n=n)
    return mesh, sp.csr_array(L + sp.diags_array(0.1 * mesh.face_areas))


@pytest.mark.parametrize("backend", available_backends())
def test_backends_solve_complex_and_real(backend):
    mesh, K = _system()
    rng = np.random.default_rng(0)
    b = rng.standard_normal((mesh.n_faces, 3)) + 1j * rng.standard_normal((mesh.n_faces, 3))
    fac = factor_hermitian(K, backend)
    assert fac.backend == backend and fac.complex
    x = fac.solve(b)
    assert np.abs(K @ x - b).max() < 1e-9 * np.abs(b).max()
    np.testing.assert_allclose(fac.solve(b[:, 0]), x[:, 0], rtol=1e-10, atol=1e-12)
    R = sp.csr_array(fvf.real_connection_laplacian(mesh) + sp.eye_array(2 * mesh.n_faces))
    y = factor_hermitian(R, backend).solve(np.ones(2 * mesh.n_faces))
    assert y.dtype == np.float64 and np.abs(R @ y - 1).max() < 1e-9


def test_backend_errors():
    _, K = _system()
    with pytest.raises(fvf.ParameterError, match="backend"):
        factor_hermitian(K, "bogus")
    for name in ("cholmod", "cvxopt", "cholespy"):
        if name not in available_backends():
            with pytest.raises(fvf.MissingExtraError, match="fast"):
                factor_hermitian(K, name)
    assert available_backends()[-1] == "scipy"
    with pytest.raises(fvf.ParameterError, match="solves"):
        factor_hermitian(K, "auto", solves="some")


def test_auto_backend_follows_the_number_of_solves():
    """A factor for a few right-hand sides, or of a complex K, prefers the fastest
    factorization (cvxopt's supernodal CHOLMOD); a real one for many solves the fastest
    solves (cholespy's blocked solves of real systems)."""
    mesh, K = _system()
    R = sp.csr_array(fvf.real_connection_laplacian(mesh) + sp.eye_array(2 * mesh.n_faces))
    order = available_backends()
    fast = "cvxopt" if "cvxopt" in order and order[0] != "cholmod" else order[0]
    assert factor_hermitian(R, "auto", solves="many").backend == order[0]
    assert factor_hermitian(R, "auto", solves="few").backend == fast
    assert factor_hermitian(K, "auto", solves="many").backend == fast  # complex


def test_lobpcg_on_one_factorization_matches_dense():
    mesh = fvf.torus(24, 12)
    L = fvf.connection_laplacian(mesh, n=4)
    A = mesh.face_areas
    lam, X = inverse_iteration(L, A, 3, backend="scipy")
    dense = np.linalg.eigvalsh((L.toarray() / np.sqrt(A)[:, None]) / np.sqrt(A)[None, :])[:3]
    np.testing.assert_allclose(lam, dense, rtol=1e-8)
    G = X.conj().T @ (A[:, None] * X)
    np.testing.assert_allclose(G, np.eye(3), atol=1e-8)
    with pytest.raises(fvf.SpectralSolveError, match="did not converge"):
        inverse_iteration(L, A, 3, backend="scipy", maxiter=2, tol=1e-14)


def test_lobpcg_real_pencil_and_block_sizes_agree_with_dense():
    """float64 L (the cotan stiffness W = [A_V] L, lumped mass): default block k and a
    block of k + 2 give the dense pencil's lowest eigenvalues and [m]-orthonormal vectors."""
    mesh = fvf.jittered_sphere(3, 0.3, seed=1)
    m = mesh.vertex_areas
    L = sp.csr_array(sp.diags_array(m) @ fvf.laplacian(mesh))  # symmetric, real
    L = sp.csr_array(0.5 * (L + L.T))
    s = 1.0 / np.sqrt(m)
    dense = np.linalg.eigvalsh(s[:, None] * L.toarray() * s[None, :])[:4]
    for block in (None, 6):
        lam, X = inverse_iteration(L, m, 4, block=block, backend="scipy")
        assert X.dtype == np.float64
        np.testing.assert_allclose(lam, dense, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(X.T @ (m[:, None] * X), np.eye(4), atol=1e-8)
        np.testing.assert_allclose(X.T @ (L @ X), np.diag(lam), atol=1e-8 * lam.max())


def test_progress_options():
    seen = []
    cb = make_progress(lambda s, d, t: seen.append((s, d, t)))
    cb("factor", 1, 1)
    assert seen == [("factor", 1, 1)]
    make_progress(None)("x", 0, 1)
    make_progress(True)("iterate", 1, 2)  # a tqdm bar, or silent without tqdm
    with pytest.raises(fvf.ParameterError, match="progress"):
        make_progress(3)
