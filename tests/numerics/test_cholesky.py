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


# ---------------------------------------------------------------------------- failures
def _path_laplacian(n=40, dtype=float):
    """The path graph's Laplacian: symmetric, singular (constants in its kernel)."""
    L = sp.diags_array(
        [-np.ones(n - 1), np.r_[1.0, 2.0 * np.ones(n - 2), 1.0], -np.ones(n - 1)],
        offsets=[-1, 0, 1],
    )
    return sp.csr_array(L, dtype=dtype)


def _indefinite(n=40, dtype=float):
    """Symmetric, nonsingular, with both positive and negative eigenvalues."""
    return sp.csr_array(_path_laplacian(n, dtype) - 0.5 * sp.eye_array(n))


FAST = [b for b in available_backends() if b != "scipy"]


@pytest.mark.parametrize("backend", FAST)
@pytest.mark.parametrize("dtype", [float, complex])
def test_a_cholesky_backend_that_finds_k_not_positive_definite_raises_a_typed_error(backend, dtype):
    """cvxopt's ArithmeticError, cholespy's ValueError("Matrix is not positive definite!"),
    scikit-sparse's CholmodError: each reaches the caller as FactorizationError (also a
    SpectralSolveError and a RuntimeError) naming the backend; the backend's own
    exception is kept as the cause."""
    for K in (_indefinite(dtype=dtype), _path_laplacian(dtype=dtype)):
        with pytest.raises(fvf.FactorizationError, match=f"backend='{backend}'.*positive") as e:
            factor_hermitian(K, backend)
        assert isinstance(e.value, fvf.SpectralSolveError | RuntimeError | fvf.FvfError)
        assert e.value.__cause__ is not None and not isinstance(e.value.__cause__, fvf.FvfError)


@pytest.mark.parametrize("backend", FAST)
def test_a_backend_that_fails_prints_nothing(backend, capfd):
    """CHOLMOD in cholespy prints "CHOLMOD warning: not positive definite" with printf on
    descriptor 1 before raising: the typed error is all the caller sees, on both streams."""
    with pytest.raises(fvf.FactorizationError):
        factor_hermitian(_indefinite(dtype=float), backend)
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_backend_output_is_captured_and_everything_else_written_back(capfd):
    """Lines starting with the backend's name are returned; other output written to
    descriptor 1 meanwhile (another thread's, Python's buffered print) comes out intact."""
    import os

    from fvf.numerics.c_output import backend_output_captured

    with backend_output_captured() as lines:
        os.write(1, b"keep: first\nCHOLMOD warning: not positive definite. file: x\n")
        os.write(1, b"keep: second\n")
        print("keep: printed")
    assert lines == ["CHOLMOD warning: not positive definite. file: x"]
    out = capfd.readouterr().out
    assert "keep: first\nkeep: second\n" in out and "keep: printed" in out
    assert "CHOLMOD" not in out


@pytest.mark.parametrize("backend", available_backends())
def test_a_zero_matrix_raises_a_typed_error(backend):
    """No stored entries: cholespy says "Failed to resize matrix arrays!", cvxopt stops at
    column 0, SuperLU finds the factor exactly singular."""
    with pytest.raises(fvf.FactorizationError, match=f"backend='{backend}'"):
        factor_hermitian(sp.csr_array((5, 5)), backend)


def test_superlu_factors_indefinite_matrices_and_refuses_singular_ones():
    """The scipy backend (diagonal pivots) factors a nonsingular indefinite K; a singular
    K is a FactorizationError; superlu_factor's pivot check refuses the indefinite one."""
    from fvf.numerics.cholesky import SPDFactor, superlu_factor

    K = _indefinite(dtype=complex)
    fac = factor_hermitian(K, "scipy")
    assert isinstance(fac, SPDFactor) and fac.complex
    b = np.arange(K.shape[0]) + 1j
    assert np.abs(K @ fac.solve(b) - b).max() < 1e-10 * np.abs(b).max()
    with pytest.raises(fvf.FactorizationError, match="backend='scipy'.*singular"):
        factor_hermitian(_path_laplacian(), "scipy")
    with pytest.raises(fvf.FactorizationError, match="non-positive pivots"):
        superlu_factor(_indefinite())
    with pytest.raises(fvf.ParameterError, match="ordering"):
        superlu_factor(_indefinite(), "metis")


def test_auto_falls_back_to_superlu_when_k_is_not_positive_definite(monkeypatch):
    """backend="auto": a Cholesky backend that finds K not positive definite gives way to
    SuperLU straight away (the other Cholesky backends would fail the same way), with a
    FactorizationFallbackWarning naming the backend; a singular K fails everywhere."""
    import fvf.numerics.cholesky as C

    tried = []
    for name, build in list(C._BUILDERS.items()):

        def spy(K, is_complex, name=name, build=build):
            tried.append(name)
            return build(K, is_complex)

        monkeypatch.setitem(C._BUILDERS, name, spy)
    K = _indefinite()
    if FAST:
        with pytest.warns(fvf.FactorizationFallbackWarning, match="positive definite.*'scipy'"):
            fac = factor_hermitian(K, "auto")
        assert tried == [C._auto("many"), "scipy"]
    else:
        fac = factor_hermitian(K, "auto")
    assert fac.backend == "scipy"
    assert np.abs(K @ fac.solve(np.ones(K.shape[0])) - 1).max() < 1e-10
    tried.clear()
    with pytest.raises(fvf.FactorizationError, match="every factorization backend failed"):
        factor_hermitian(_path_laplacian(), "auto")  # no warning: nothing was used instead
    assert tried == ([C._auto("many")] if FAST else []) + ["scipy"]


def test_auto_tries_the_next_backend_when_one_gives_up_for_another_reason(monkeypatch):
    """A failure that is not about K (cholespy's "Failed to resize matrix arrays!", here
    forced) moves on to the next available backend, fast ones included."""
    import fvf.numerics.cholesky as C

    if len(FAST) < 1:
        pytest.skip("no fast Cholesky backend installed (extra [fast])")
    first = C._auto("many", is_complex=True)

    def gives_up(K, is_complex):
        raise RuntimeError("Failed to resize matrix arrays!")

    monkeypatch.setitem(C._BUILDERS, first, gives_up)
    _, K = _system()
    with pytest.warns(fvf.FactorizationFallbackWarning, match="Failed to resize"):
        fac = factor_hermitian(K, "auto", solves="many")
    following = [b for b in available_backends() if b != first]
    assert fac.backend == following[0]
    b = np.ones(K.shape[0], dtype=complex)
    assert np.abs(K @ fac.solve(b) - b).max() < 1e-9
    with pytest.raises(fvf.FactorizationError, match=f"backend='{first}'.*Failed to resize"):
        factor_hermitian(K, first)


@pytest.mark.parametrize("backend", ["auto", *available_backends()])
def test_an_empty_matrix_factors_to_an_empty_solve(backend):
    fac = factor_hermitian(sp.csr_array((0, 0), dtype=complex), backend)
    assert fac.solve(np.zeros((0, 3))).shape == (0, 3) and fac.complex
