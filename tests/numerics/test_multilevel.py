"""The multilevel ACAP eigensolver (fvf.multilevel) against the direct path."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import fvf
import fvf.design.commuting as commuting
from fvf.design.commuting import acap_energy_matrix, acap_fields
from fvf.errors import ParameterError
from fvf.numerics.eigen import (
    SpectralFallbackWarning,
    SpectralInputError,
    SpectralSolveError,
    eigen_residuals,
    smallest_eigenpairs,
)
from fvf.numerics.multilevel import (
    AggregationHierarchy,
    face_field_eigenpairs,
    multilevel_eigenpairs,
)

LAM = 1e-2
K = 4


def _field(mesh: fvf.TriMesh) -> np.ndarray:
    """The benchmark field: v = J grad y, unit L2 norm."""
    v = fvf.rotate(mesh, fvf.gradient(mesh, mesh.vertices[:, 1]))
    return v / np.sqrt(mesh.face_areas @ (v * v).sum(1))


@pytest.fixture(scope="module")
def spot():
    """The spot mesh (5,856 faces: quad-derived, with near-right triangle pairs)."""
    mesh = fvf.mesh.builtin.spot()
    E = acap_energy_matrix(mesh, _field(mesh), LAM)
    mass = np.repeat(mesh.face_areas, 2)
    lam_d, X_d = smallest_eigenpairs(E, mass, K)
    return mesh, E, mass, lam_d, X_d


def _sin_angles(X: np.ndarray, Y: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Sines of the principal angles between span X and span Y in the mass inner product."""
    s = np.sqrt(mass)[:, None]
    return np.sin(sla.subspace_angles(X * s, Y * s))


def test_agrees_with_direct_on_spot(spot):
    mesh, E, mass, lam_d, X_d = spot
    info: dict = {}
    lam, X = face_field_eigenpairs(mesh, E, K, info=info)
    assert len(info["levels"]) >= 2  # a real hierarchy, not just the dense coarse solve
    np.testing.assert_allclose(lam, lam_d, rtol=1e-8)
    assert _sin_angles(X, X_d, mass).max() < 1e-4
    assert np.all(info["spectral_residuals"] <= 1e-3)
    res = eigen_residuals(E, mass, lam, X)
    assert np.all(res <= 1e-8)
    np.testing.assert_allclose(X.T @ (mass[:, None] * X), np.eye(K), atol=1e-10)
    # sign convention of smallest_eigenpairs: the largest-magnitude entry is positive
    idx = np.argmax(np.abs(X), axis=0)
    assert np.all(X[idx, np.arange(K)] > 0)


def test_tighter_tolerances_give_closer_agreement(spot):
    mesh, E, mass, lam_d, X_d = spot
    info: dict = {}
    lam, X = face_field_eigenpairs(mesh, E, K, tol=1e-12, rtol=1e-6, info=info)
    assert np.all(info["spectral_residuals"] <= 1e-6)
    res = eigen_residuals(E, mass, lam, X)
    assert np.all(res <= 1e-12)
    np.testing.assert_allclose(lam, lam_d, rtol=1e-11)
    assert _sin_angles(X, X_d, mass).max() < 1e-7


def test_acap_fields_solver_keyword(spot):
    mesh, *_ = spot
    v = _field(mesh)
    a = acap_fields(mesh, v, LAM, K, solver="direct")
    b = acap_fields(mesh, v, LAM, K, solver="multilevel")
    assert b.shape == a.shape == (K, mesh.n_faces, 3)
    area = np.repeat(mesh.face_areas, 3)
    A = a.reshape(K, -1).T
    B = b.reshape(K, -1).T
    assert _sin_angles(A, B, area).max() < 1e-4
    # tangent and unit L2 norm
    assert np.abs(np.einsum("kti,ti->kt", b, mesh.face_normals)).max() < 1e-12
    np.testing.assert_allclose(np.einsum("kti,kti,t->k", b, b, mesh.face_areas), 1.0)


def test_auto_switches_at_threshold(spot, monkeypatch):
    mesh, *_ = spot
    v = _field(mesh)
    calls = []
    import fvf.numerics.multilevel as ml

    real = ml.face_field_eigenpairs

    def spy(*args, **kw):
        calls.append(1)
        return real(*args, **kw)

    monkeypatch.setattr(ml, "face_field_eigenpairs", spy)
    acap_fields(mesh, v, LAM, 2)
    assert not calls  # 5.9k faces: direct
    monkeypatch.setattr(commuting, "ACAP_MULTILEVEL_MIN_FACES", 1000)
    acap_fields(mesh, v, LAM, 2)
    assert calls == [1]


def test_auto_falls_back_to_direct_with_warning(spot, monkeypatch):
    mesh, *_ = spot
    v = _field(mesh)
    import fvf.numerics.multilevel as ml

    def broken(*args, **kw):
        raise SpectralSolveError("forced failure")

    monkeypatch.setattr(ml, "face_field_eigenpairs", broken)
    monkeypatch.setattr(commuting, "ACAP_MULTILEVEL_MIN_FACES", 1000)
    with pytest.warns(SpectralFallbackWarning, match="forced failure"):
        out = acap_fields(mesh, v, LAM, 2)
    ref = acap_fields(mesh, v, LAM, 2, solver="direct")
    np.testing.assert_allclose(out, ref)
    with pytest.raises(SpectralSolveError, match="forced failure"):
        acap_fields(mesh, v, LAM, 2, solver="multilevel")

    # a failed coarse Cholesky (LinAlgError) falls back the same way
    def singular(*args, **kw):
        raise np.linalg.LinAlgError("coarse matrix not positive definite")

    monkeypatch.setattr(ml, "face_field_eigenpairs", singular)
    with pytest.warns(SpectralFallbackWarning, match="not positive definite"):
        np.testing.assert_allclose(acap_fields(mesh, v, LAM, 2), ref)
    # beyond what the direct solver can hold, "auto" says so instead of trying
    monkeypatch.setattr(commuting, "ACAP_DIRECT_MAX_FACES", 1000)
    with pytest.raises(SpectralSolveError, match="tens of GB.*Fix: a larger lam"):
        acap_fields(mesh, v, LAM, 2)


def test_not_converged_raises(spot):
    mesh, E, *_ = spot
    with pytest.raises(SpectralSolveError, match="did not converge"):
        face_field_eigenpairs(mesh, E, K, maxiter=2)


@pytest.mark.parametrize(
    "kw, err",
    [
        (dict(solver="cholmod"), ParameterError),
        (dict(solver=None), ParameterError),
        (dict(solver="multilevel", tol=0.0), SpectralInputError),
        (dict(solver="multilevel", tol=float("nan")), SpectralInputError),
        (dict(solver="multilevel", k=0), SpectralInputError),
        (dict(solver="multilevel", k=2.5), SpectralInputError),
        (dict(solver="multilevel", k=1000), SpectralInputError),
    ],
)
def test_bad_input_typed_errors(kw, err):
    mesh = fvf.icosphere(2)  # 320 faces
    v = _field(mesh)
    k = kw.pop("k", 2)
    with pytest.raises(err):
        acap_fields(mesh, v, LAM, k, **kw)


def test_multilevel_eigenpairs_shape_errors():
    W = sp.eye_array(40, format="csr")
    with pytest.raises(SpectralInputError):
        multilevel_eigenpairs(
            W, np.ones(39), 2, near_kernel=np.zeros((20, 2, 3)), positions=np.zeros((20, 3))
        )
    with pytest.raises(SpectralInputError):
        multilevel_eigenpairs(
            W, -np.ones(40), 2, near_kernel=np.zeros((20, 2, 3)), positions=np.zeros((20, 3))
        )
    with pytest.raises(SpectralInputError):
        AggregationHierarchy(W, np.zeros((19, 2, 3)), np.ones(40), np.zeros((19, 3)))


def _pcg_iterations(mesh, A, mass, rng) -> tuple[int, AggregationHierarchy]:
    m = mesh.n_faces
    adj = mesh.face_adjacency
    rows, cols = np.repeat(np.arange(m), 3), adj.ravel()
    G = sp.csr_array((np.ones(cols.size), (rows, cols)), shape=(m, m))
    H = AggregationHierarchy(A, mesh.face_bases, mass, mesh.face_centroids, graph=G)
    b = rng.standard_normal(A.shape[0]) * mass
    its: list[int] = []
    M = spla.LinearOperator(A.shape, matvec=H.vcycle, dtype=np.float64)
    _, info = spla.cg(A, b, M=M, rtol=1e-6, maxiter=300, callback=lambda _: its.append(1))
    assert info == 0
    return len(its), H


def test_vcycle_is_spd_and_the_pair_smoother_matters(spot, monkeypatch):
    """The V-cycle is symmetric positive definite and keeps PCG iterations low.

    On spot, whose quad diagonals carry circumcentric weights ~1000x the others, plain
    2 x 2 block Jacobi (no pairs: STRONG = inf) needs about 3x more PCG iterations.
    """
    import fvf.numerics.multilevel as ml

    mesh, E, mass, *_ = spot
    A = (E + sp.diags_array(0.2 * mass)).tocsr()
    rng = np.random.default_rng(7)
    its, H = _pcg_iterations(mesh, A, mass, rng)
    x, y = rng.standard_normal((2, A.shape[0]))
    vx, vy = H.vcycle(x).astype(float), H.vcycle(y).astype(float)
    assert abs(y @ vx - x @ vy) <= 1e-5 * abs(x @ vx)  # single-precision cycle
    assert x @ vx > 0
    monkeypatch.setattr(ml, "STRONG", np.inf)
    its_plain, _ = _pcg_iterations(mesh, A, mass, rng)
    assert its < 50
    assert its_plain > 2 * its


@pytest.mark.slow
def test_agrees_with_direct_at_94k_faces():
    """Spot refined twice (93,696 faces): ~25 s direct + ~25 s multilevel."""
    from conftest import import_benchmark

    mesh = fvf.TriMesh(*import_benchmark("bench_core").spot_level(2))
    E = acap_energy_matrix(mesh, _field(mesh), LAM)
    mass = np.repeat(mesh.face_areas, 2)
    lam_d, X_d = smallest_eigenpairs(E, mass, K)
    lam, X = face_field_eigenpairs(mesh, E, K)
    np.testing.assert_allclose(lam, lam_d, rtol=1e-8)
    assert _sin_angles(X, X_d, mass).max() < 1e-4
    assert np.all(eigen_residuals(E, mass, lam, X) <= 1e-8)


def test_integral_float_k_still_works():
    mesh = fvf.icosphere(2)
    v = _field(mesh)
    a = acap_fields(mesh, v, LAM, 2.0)
    b = acap_fields(mesh, v, LAM, 2)
    np.testing.assert_array_equal(a, b)
    with pytest.raises(SpectralInputError):
        acap_fields(mesh, v, LAM, 2.5)
