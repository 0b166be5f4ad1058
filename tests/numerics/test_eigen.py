"""The Laplace–Beltrami eigensolver :mod:`fvf.eigen` (all seeded, BLAS on one thread)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import fvf
from conftest import load_shared
from fvf import calculus
from fvf.errors import FvfError, FvfWarning
from fvf.numerics import eigen
from fvf.numerics.eigen import (
    SpectralFallbackWarning,
    SpectralInputError,
    SpectralSolveError,
    count_eigenvalues_below,
    eigen_residuals,
    smallest_eigenpairs,
    spectral_norm_bound,
)

# l(l+1) with multiplicity 2l+1, l = 0..4: the first 25 eigenvalues of the unit sphere.
SPHERE_25 = np.concatenate([np.full(2 * l + 1, l * (l + 1.0)) for l in range(5)])


@pytest.fixture(autouse=True)
def one_blas_thread():
    """OpenBLAS threading makes the small dense work of the solver much slower here."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover
        yield
        return
    with threadpool_limits(1):
        yield


def problem(mesh):
    return calculus.stiffness(mesh), np.asarray(mesh.vertex_areas)


def m_gram(X, mass, Y=None):
    Y = X if Y is None else Y
    return X.T @ (mass[:, None] * Y)


def test_icosphere_converges_to_sphere_spectrum():
    """Eigenvalues → l(l+1) (multiplicity 2l+1) at rate ~h² in the mean edge length."""
    h, err = [], []
    for level in (3, 4, 5):
        mesh = fvf.icosphere(level)
        W, mass = problem(mesh)
        lam, X = smallest_eigenpairs(W, mass, 25)
        assert lam.shape == (25,) and X.shape == (mesh.n_vertices, 25)
        assert lam.dtype == np.float64 and X.dtype == np.float64
        assert abs(lam[0]) < 1e-10
        rel = np.abs(lam[1:] - SPHERE_25[1:]) / SPHERE_25[1:]
        assert rel.max() < 0.03  # each eigenvalue lands in its l-cluster
        h.append(mesh.mean_edge_length)
        err.append(np.abs(lam - SPHERE_25).max())
    rate = np.polyfit(np.log(h), np.log(err), 1)[0]
    # measured: 1.97 (levels 3→4), 1.99 (4→5)
    assert 1.85 < rate < 2.2, rate
    # the clusters are separated: the largest gap inside a cluster is far below the
    # smallest gap between clusters
    inner = max(np.ptp(lam[SPHERE_25 == v]) for v in np.unique(SPHERE_25))
    between = np.min(np.diff([lam[SPHERE_25 == v].mean() for v in np.unique(SPHERE_25)]))
    assert inner < 0.02 * between


def test_orthonormal_and_residuals():
    mesh = fvf.jittered_sphere(4, 0.3, seed=3)
    W, mass = problem(mesh)
    for tol in (1e-8, 1e-11):
        lam, X = smallest_eigenpairs(W, mass, 30, tol=tol, method="krylov")
        assert np.all(np.diff(lam) >= 0)
        assert np.abs(m_gram(X, mass) - np.eye(30)).max() <= 1e-10
        res = eigen_residuals(W, mass, lam, X)
        assert res.shape == (30,)
        assert np.all(res <= tol)


def test_eigen_residuals_definition():
    mesh = fvf.torus(16, 8)
    W, mass = problem(mesh)
    rng = np.random.default_rng(0)
    X = rng.standard_normal((mesh.n_vertices, 3))
    lam = np.array([0.5, 1.0, -2.0])
    nu = spectral_norm_bound(W, mass)
    Wd = W.toarray()
    A = Wd / np.sqrt(np.outer(mass, mass))
    assert nu >= np.linalg.eigvalsh(A).max() * (1 - 1e-12)
    R = Wd @ X - (mass[:, None] * X) * lam
    expected = np.sqrt((R**2 / mass[:, None]).sum(0)) / (
        (np.abs(lam) + nu) * np.sqrt((mass[:, None] * X**2).sum(0))
    )
    np.testing.assert_allclose(eigen_residuals(W, mass, lam, X), expected, rtol=1e-12)


def test_krylov_agrees_with_dense():
    """16 = 1+3+5+7 eigenpairs: a complete set of clusters, well separated from the 17th."""
    mesh = fvf.jittered_sphere(3, 0.3, seed=1)
    W, mass = problem(mesh)
    lam_k, X_k = smallest_eigenpairs(W, mass, 16, method="krylov")
    lam_d, X_d = smallest_eigenpairs(W, mass, 16, method="dense")
    np.testing.assert_allclose(lam_k, lam_d, rtol=1e-9, atol=1e-9)
    # same invariant subspace: all cosines of principal angles are 1
    cos = np.linalg.svd(m_gram(X_k, mass, X_d), compute_uv=False)
    assert cos.min() > 1 - 1e-9
    # individual vectors where the eigenvalue is simple enough (relative gap > 1e-3)
    gap = np.minimum(np.diff(lam_d, prepend=-np.inf), np.diff(lam_d, append=np.inf))
    simple = gap > 1e-3 * lam_d[-1]
    np.testing.assert_allclose(X_k[:, simple], X_d[:, simple], atol=1e-6)


def test_auto_uses_dense_for_tiny_meshes_and_agrees():
    mesh = fvf.torus(20, 10)  # 200 vertices
    W, mass = problem(mesh)
    lam_a, _ = smallest_eigenpairs(W, mass, 12)
    lam_k, _ = smallest_eigenpairs(W, mass, 12, method="krylov")
    np.testing.assert_allclose(lam_a, lam_k, rtol=1e-9, atol=1e-9)


def test_eigsh_method_agrees():
    mesh = load_shared("spot.obj")
    W, mass = problem(mesh)
    lam_a, X_a = smallest_eigenpairs(W, mass, 20)
    lam_e, X_e = smallest_eigenpairs(W, mass, 20, method="eigsh")
    np.testing.assert_allclose(lam_a, lam_e, rtol=1e-9, atol=1e-9)
    assert np.all(eigen_residuals(W, mass, lam_e, X_e) <= 1e-8)
    assert np.abs(m_gram(X_e, mass) - np.eye(20)).max() <= 1e-10


def test_agrees_with_libigl_formulation():
    igl = pytest.importorskip("igl")
    mesh = load_shared("spot.obj")
    V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    L = sp.csc_matrix(igl.cotmatrix(V, F))
    M = sp.csc_matrix(igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_BARYCENTRIC))
    k = 30
    v0 = np.random.default_rng(5).standard_normal(V.shape[0])
    lam_igl, _ = spla.eigsh(-L, k, M=M, sigma=-1e-6, which="LM", v0=v0)
    W, mass = problem(mesh)
    lam, X = smallest_eigenpairs(W, mass, k)
    np.testing.assert_allclose(lam, np.sort(lam_igl), rtol=1e-9, atol=1e-9)
    # also an eigenbasis of libigl's pencil
    assert np.all(eigen_residuals(-L, M.diagonal(), lam, X) <= 1e-8)


def test_deterministic_with_sign_convention():
    mesh = fvf.jittered_sphere(4, 0.3, seed=2)
    W, mass = problem(mesh)
    lam1, X1 = smallest_eigenpairs(W, mass, 20, seed=7)
    lam2, X2 = smallest_eigenpairs(W, mass, 20, seed=7)
    assert np.array_equal(lam1, lam2) and np.array_equal(X1, X2)
    idx = np.argmax(np.abs(X1), axis=0)
    assert np.all(X1[idx, np.arange(20)] > 0)
    # another seed: same eigenvalues, vectors equal where eigenvalues are simple
    lam3, X3 = smallest_eigenpairs(W, mass, 20, seed=8)
    np.testing.assert_allclose(lam1, lam3, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(X1[:, :4], X3[:, :4], atol=1e-5)


def test_disconnected_kernel_and_multiplicity_retry():
    """Four copies of a sphere: 4-dim kernel, 20-fold eigenvalues (4 x 5). The default
    block is too small; the Sylvester inertia check notices and the solver retries."""
    W1, m1 = problem(fvf.icosphere(2))
    W = sp.block_diag([W1] * 4, format="csr")
    mass = np.tile(m1, 4)
    with pytest.warns(SpectralFallbackWarning, match="inertia"):
        lam, X = smallest_eigenpairs(W, mass, 40, method="krylov")
    lam_d, _ = smallest_eigenpairs(W, mass, 40, method="dense")
    np.testing.assert_allclose(lam, lam_d, rtol=1e-9, atol=1e-9)
    assert np.abs(lam[:4]).max() < 1e-10
    # the kernel is piecewise constant: each vector is constant on each copy
    blocks = X[:, :4].reshape(4, -1, 4)
    assert np.abs(blocks - blocks.mean(axis=1, keepdims=True)).max() < 1e-8


def test_count_eigenvalues_below():
    W, mass = problem(fvf.icosphere(3))
    assert count_eigenvalues_below(W, mass, 1.0) == 1
    assert count_eigenvalues_below(W, mass, 3.0) == 4
    assert count_eigenvalues_below(W, mass, 9.0) == 9


def test_fallback_when_factorization_fails(monkeypatch):
    mesh = fvf.jittered_sphere(3, 0.3, seed=1)
    W, mass = problem(mesh)
    expected, _ = smallest_eigenpairs(W, mass, 10, method="dense")

    def broken(K, ordering="auto"):
        raise eigen._MethodFailed("factorization of W - sigma*M failed (forced in test)")

    monkeypatch.setattr(eigen, "factor_spd", broken)
    monkeypatch.setattr(eigen, "_fast_factor", lambda K, seed: None)  # (no fast backend)
    with pytest.warns(SpectralFallbackWarning, match="'krylov' failed.*falling back to 'eigsh'"):
        lam, X = smallest_eigenpairs(W, mass, 10, method="krylov")
    np.testing.assert_allclose(lam, expected, rtol=1e-9, atol=1e-9)
    assert np.all(eigen_residuals(W, mass, lam, X) <= 1e-8)
    assert issubclass(SpectralFallbackWarning, FvfWarning)


def test_fallback_on_non_convergence():
    """maxiter=0 (no restart) with a tiny basis cannot converge: eigsh takes over."""
    mesh = fvf.jittered_sphere(4, 0.3, seed=4)
    W, mass = problem(mesh)
    orig = eigen.block_krylov_schur

    def small_basis(*args, **kw):
        kw["max_basis"] = 30
        return orig(*args, **kw)

    mp = pytest.MonkeyPatch()
    mp.setattr(eigen, "block_krylov_schur", small_basis)
    try:
        with pytest.warns(SpectralFallbackWarning, match="did not converge"):
            lam, X = smallest_eigenpairs(W, mass, 20, method="krylov", maxiter=0)
    finally:
        mp.undo()
    assert np.all(eigen_residuals(W, mass, lam, X) <= 1e-8)


def test_chain_exhausted_raises(monkeypatch):
    W, mass = problem(fvf.icosphere(3))

    def fail(*args, **kw):
        raise eigen._MethodFailed("forced")

    for name in ("_solve_krylov", "_solve_eigsh", "_solve_dense"):
        monkeypatch.setattr(eigen, name, fail)
    with pytest.warns(SpectralFallbackWarning):
        with pytest.raises(SpectralSolveError, match="every method failed"):
            smallest_eigenpairs(W, mass, 5, method="krylov")


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(k=0), "k must satisfy"),
        (dict(k=642), "k must satisfy"),
        (dict(k=2.5), "k must be an integer"),
        (dict(mass="short"), "mass must have shape"),
        (dict(mass="zero"), "finite and positive"),
        (dict(mass="nan"), "finite and positive"),
        (dict(W="nan"), "NaN or inf"),
        (dict(W="rect"), "square"),
        (dict(W="asym"), "symmetric"),
        (dict(tol=0.0), "tol must be"),
        (dict(tol=float("nan")), "tol must be"),
        (dict(method="arpack"), "method must be one of"),
    ],
)
def test_bad_input(change, match):
    W, mass = problem(fvf.icosphere(3))
    args = dict(W=W, mass=mass.copy(), k=5, tol=1e-8, method="auto")
    if change.get("mass") == "short":
        change = dict(mass=mass[:-1])
    elif change.get("mass") == "zero":
        bad = mass.copy()
        bad[[3, 7]] = 0.0
        change = dict(mass=bad)
    elif change.get("mass") == "nan":
        bad = mass.copy()
        bad[0] = np.nan
        change = dict(mass=bad)
    elif change.get("W") == "nan":
        bad = W.copy()
        bad.data[0] = np.inf
        change = dict(W=bad)
    elif change.get("W") == "rect":
        change = dict(W=W[:, :-1])
    elif change.get("W") == "asym":
        bad = sp.lil_array(W)
        bad[0, 1] += 1.0
        change = dict(W=sp.csr_array(bad))
    args.update(change)
    with pytest.raises(SpectralInputError, match=match) as info:
        smallest_eigenpairs(
            args["W"], args["mass"], args["k"], tol=args["tol"], method=args["method"]
        )
    assert isinstance(info.value, FvfError) and isinstance(info.value, ValueError)


@pytest.mark.parametrize("ordering", ["mmd", "nd"])
def test_orderings_agree(ordering):
    """Both fill-reducing orderings give the same eigenpairs and the same inertia count."""
    mesh = fvf.jittered_sphere(3, 0.3, seed=4)
    W, mass = problem(mesh)
    expected, _ = smallest_eigenpairs(W, mass, 12, method="dense")
    lam, X = smallest_eigenpairs(W, mass, 12, method="krylov", ordering=ordering)
    np.testing.assert_allclose(lam, expected, rtol=1e-9, atol=1e-9)
    tau = 0.5 * (expected[3] + expected[4])  # between l = 1 and l = 2 on a sphere
    assert eigen.count_eigenvalues_below(W, mass, tau, ordering) == 4


def test_factor_spd_nd_solves_and_rejects_indefinite(rng):
    mesh = fvf.jittered_sphere(3, 0.3, seed=4)
    W, mass = problem(mesh)
    K = (W + 1e-3 * sp.diags_array(mass)).tocsc()
    fac = eigen.factor_spd(K, "nd")
    assert fac.ordering == "nd" and fac.perm is not None
    B = rng.standard_normal((K.shape[0], 3))
    assert np.abs(K @ fac.solve(B) - B).max() < 1e-9 * np.abs(B).max()
    assert np.abs(K @ fac.solve(B[:, 0]) - B[:, 0]).max() < 1e-9 * np.abs(B).max()
    with pytest.raises(eigen._MethodFailed, match="non-positive pivots"):
        eigen.factor_spd((W - 10.0 * sp.diags_array(mass)).tocsc(), "nd")
    with pytest.raises(fvf.numerics.eigen.SpectralInputError, match="ordering must be one of"):
        eigen.factor_spd(K, "metis")


def test_spd_factor_solves_in_float64_and_ordering_is_validated():
    mesh = fvf.icosphere(3)
    W, mass = problem(mesh)
    K = (W + sp.diags_array(mass)).tocsc()
    b = np.arange(K.shape[0])  # integers
    for ordering in ("mmd", "nd"):
        x = eigen.factor_spd(K, ordering).solve(b)
        assert x.dtype == np.float64 and np.abs(K @ x - b).max() < 1e-9 * b.max()
    with pytest.raises(fvf.numerics.eigen.SpectralInputError, match="ordering"):
        smallest_eigenpairs(W, mass, 4, method="dense", ordering="bogus")


def test_fast_cholesky_is_used_when_installed_and_refuses_indefinite_matrices():
    """With a fast Cholesky backend (the [fast] extra) the shift-invert solves use it; a
    matrix that is not positive definite is caught by the solve's own residual, so the
    SuperLU path (with its pivot check and the fallback chain) takes over."""
    from fvf.numerics.cholesky import available_backends

    if available_backends() == ("scipy",):
        pytest.skip("no fast Cholesky backend installed (extra [fast])")
    W, mass = problem(fvf.jittered_sphere(3, 0.3, seed=1))
    K = sp.csc_array(W + 1e-3 * sp.diags_array(mass))
    fac = eigen._fast_factor(K, seed=0)
    assert fac is not None and fac.backend != "scipy"
    b = np.random.default_rng(1).standard_normal(K.shape[0])
    assert np.linalg.norm(K @ fac.solve(b) - b) <= 1e-10 * np.linalg.norm(b)
    assert eigen._fast_factor(sp.csc_array(W - 5.0 * sp.diags_array(mass)), seed=0) is None


def test_normalized_eigenpairs_is_the_shared_convention(rng):
    """fvf.numerics.eigenpairs.normalized_eigenpairs (used by smallest_eigenpairs and the
    multilevel solver): any scaling and sign of the vectors gives the returned pairs, with
    the residuals of eigen_residuals; unusable vectors are a SpectralSolveError."""
    from fvf.numerics.eigenpairs import normalized_eigenpairs

    W, mass = problem(fvf.jittered_sphere(2, 0.3, seed=1))  # distinct eigenvalues
    lam, X = smallest_eigenpairs(W, mass, 6, method="dense")
    assert np.diff(lam).min() > 1e-4 * lam[-1]
    scale = rng.uniform(0.5, 3.0, 6) * np.array([1, -1, 1, -1, -1, 1])
    order = [3, 0, 5, 1, 4, 2]
    lam2, X2, res = normalized_eigenpairs(W, mass, X[:, order] * scale[order])
    np.testing.assert_allclose(lam2, lam, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(X2, X, atol=1e-12)
    np.testing.assert_allclose(res, eigen_residuals(W, mass, lam2, X2), rtol=1e-10, atol=1e-16)
    bad = X.copy()
    bad[0, 0] = np.nan
    with pytest.raises(SpectralSolveError, match="non-finite"):
        normalized_eigenpairs(W, mass, bad)
    with pytest.raises(SpectralSolveError, match="zero eigenvector"):
        normalized_eigenpairs(W, mass, np.zeros_like(X))
