"""fvf.numerics.expm: exp(tA)B by the Chebyshev series and Krylov time stepping, against
dense exponentials (scipy.linalg.expm) and scipy's expm_multiply."""

from __future__ import annotations

import threading
import warnings

import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.special import jv

import fvf
from fvf.errors import ExpmInputError, FlowOverflowError, FvfError, KrylovFallbackWarning
from fvf.numerics import expm as E
from fvf.numerics import expm_chebyshev as C
from fvf.numerics.expm import ExpmvCounter, chebyshev_degree, expm_action, skew_bound

TOL = 1e-10
METHODS = ("krylov", "chebyshev", "auto")


# ------------------------------------------------------------------------------ fixtures
def _flow_operator(mesh, kind: str):
    """A = −D^V_v for a unit-speed field: "skew" (J grad g) or "grad" (compressible)."""
    X = mesh.vertices
    u = fvf.gradient(mesh, X[:, 2] + 0.4 * X[:, 0] * X[:, 1])
    if kind == "skew":
        u = fvf.rotate(mesh, u)
    return -fvf.D_V(mesh, u / np.linalg.norm(u, axis=1).max())


def _f0(mesh, k: int = 1):
    X = mesh.vertices
    cols = [np.sin(3 * X[:, 0]) + X[:, 1], np.cos(2 * X[:, 1]) * X[:, 2], X[:, 0] ** 2 - X[:, 2]]
    return cols[0] if k == 1 else np.stack(cols[:k], axis=1)


MESHES = {"ico2": lambda: fvf.icosphere(2), "jit2": lambda: fvf.jittered_sphere(2, 0.35, seed=1)}


@pytest.fixture(params=list(MESHES))
def mesh(request):
    return MESHES[request.param]()


def wnorm(x, w):
    x = np.asarray(x)
    return float(np.sqrt(np.einsum("i,i...->...", w, x * x).sum()))


def wrel(x, ref, w) -> float:
    return wnorm(x - ref, w) / wnorm(ref, w)


def maxrel(x, ref) -> float:
    return float(np.abs(x - ref).max() / np.abs(ref).max())


def dense_exp(A, B, times):
    Ad = A.toarray() if sp.issparse(A) else np.asarray(A)
    return np.stack([la.expm(t * Ad) @ B for t in np.atleast_1d(times)])


# ---------------------------------------------------------------- agreement with scipy
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("L", [0.1, 1.0, 10.0, 40.0])
def test_skew_flow_matches_dense_expm(mesh, L, method):
    """J grad g flows (A_V-skew), from a fraction of an edge to 40 edge lengths."""
    A = _flow_operator(mesh, "skew")
    w = mesh.vertex_areas
    b = _f0(mesh)
    t = L * mesh.mean_edge_length
    x, info = expm_action(A, b, [t, -t], inner=w, method=method, return_info=True)
    ref = dense_exp(A, b, [t, -t])
    assert info["skew"] is True
    for k in range(2):
        assert maxrel(x[k], ref[k]) <= TOL and wrel(x[k], ref[k], w) <= TOL
        assert abs(wnorm(x[k], w) / wnorm(b, w) - 1) < 1e-13  # kept to round-off


@pytest.mark.parametrize("L", [0.1, 1.0, 10.0])
def test_compressible_flow_matches_dense_expm(mesh, L):
    A = _flow_operator(mesh, "grad")
    w = mesh.vertex_areas
    b = _f0(mesh)
    t = L * mesh.mean_edge_length
    x, info = expm_action(A, b, [t, -0.5 * t], inner=w, return_info=True)
    assert info["method"] == "iom" and info["skew"] is False
    ref = dense_exp(A, b, [t, -0.5 * t])
    assert maxrel(x, ref) <= TOL


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_operators_against_dense(seed):
    """Random sparse non-normal operators, and random W-skew ones (W random)."""
    rng = np.random.default_rng(seed)
    n = 120
    M = sp.random_array((n, n), density=0.05, random_state=rng, format="csr")
    M = M - 0.5 * sp.diags_array(np.asarray(abs(M).sum(axis=1)).ravel())
    b = rng.standard_normal(n)
    t = np.array([0.3, 2.0, -1.0])
    assert maxrel(expm_action(M, b, t), dense_exp(M, b, t)) <= TOL
    w = rng.uniform(0.5, 3.0, n)
    K = M - M.T
    S = (sp.diags_array(1 / w) @ K).tocsr()  # W S + Sᵀ W = K + Kᵀ = 0
    x, info = expm_action(S, b, t * 5, inner=w, return_info=True)
    assert info["skew"] is True
    assert maxrel(x, dense_exp(S, b, t * 5)) <= TOL


@pytest.mark.parametrize("method", METHODS)
def test_array_of_times_unsorted_negative_zero_repeated(mesh, method):
    A = _flow_operator(mesh, "skew")
    b = _f0(mesh)
    times = np.array([0.7, -0.2, 0.0, 0.7, 2.5, -1.3, 0.1])
    x = expm_action(A, b, times, inner=mesh.vertex_areas, method=method)
    assert x.shape == (times.size, b.size)
    assert np.array_equal(x[2], b)
    assert np.array_equal(x[0], x[3])
    assert maxrel(x, dense_exp(A, b, times)) <= TOL


@pytest.mark.parametrize("kind", ["skew", "grad"])
def test_block_and_complex_right_hand_sides(mesh, kind):
    A = _flow_operator(mesh, kind)
    B = _f0(mesh, 3)
    times = [0.4, -0.9]
    X = expm_action(A, B, times, inner=mesh.vertex_areas)
    assert X.shape == (2,) + B.shape
    assert maxrel(X, dense_exp(A, B, times)) <= TOL
    Z = B[:, 0] + 1j * B[:, 1]
    XZ = expm_action(A, Z, 0.4, inner=mesh.vertex_areas)
    assert XZ.dtype == np.complex128
    assert np.allclose(XZ.real, X[0, :, 0], atol=1e-12) and np.allclose(XZ.imag, X[0, :, 1])


def test_semigroup(mesh):
    A = _flow_operator(mesh, "grad")
    b = _f0(mesh)
    w = mesh.vertex_areas
    one = expm_action(A, expm_action(A, b, 0.3, inner=w), 0.5, inner=w)
    assert maxrel(one, expm_action(A, b, 0.8, inner=w)) <= 10 * TOL


def test_time_stepping_with_a_small_basis(mesh):
    """m_max = 8 forces many steps; the answer stays within tol."""
    A = _flow_operator(mesh, "grad")
    b = _f0(mesh)
    t = 6 * mesh.mean_edge_length
    x, info = expm_action(A, b, t, inner=mesh.vertex_areas, m_max=8, return_info=True)
    assert info["steps"] > 3 and max(info["basis_sizes"]) <= 8
    assert maxrel(x, dense_exp(A, b, t)[0]) <= TOL


def test_expm_multiply_method_and_counts(mesh):
    A = _flow_operator(mesh, "grad")
    b = _f0(mesh)
    x, info = expm_action(A, b, [0.5, -0.2], method="expm_multiply", return_info=True)
    assert info["method"] == "expm_multiply" and info["matvecs"] > 0
    assert maxrel(x, dense_exp(A, b, [0.5, -0.2])) <= 1e-9


def test_counter_counts_columns():
    A = sp.random_array((30, 30), density=0.2, random_state=np.random.default_rng(0))
    c = ExpmvCounter(A)
    c @ np.ones(30)
    c @ np.ones((30, 4))
    c.T @ np.ones(30)
    assert (c.matvecs, c.rmatvecs, c.products) == (5, 1, 6)


def test_dense_and_linear_operator_inputs(mesh):
    A = _flow_operator(mesh, "grad")
    b = _f0(mesh)
    ref = dense_exp(A, b, 0.6)[0]
    assert maxrel(expm_action(A.toarray(), b, 0.6), ref) <= TOL
    L = spla.aslinearoperator(A)
    x, info = expm_action(L, b, 0.6, return_info=True)
    assert maxrel(x, ref) <= TOL and info["method"] == "iom"
    with pytest.raises(ExpmInputError, match="skew_norm"):
        expm_action(L, b, 0.6, method="chebyshev")


def test_skew_true_on_a_non_skew_operator_warns_and_is_right(mesh):
    A = _flow_operator(mesh, "grad")
    b = _f0(mesh)
    with pytest.warns(KrylovFallbackWarning, match="not skew-adjoint"):
        x, info = expm_action(A, b, 0.5, inner=mesh.vertex_areas, skew=True, return_info=True)
    assert info["skew"] is False and maxrel(x, dense_exp(A, b, 0.5)[0]) <= TOL


def test_skew_false_uses_the_general_method(mesh):
    A = _flow_operator(mesh, "skew")
    x, info = expm_action(A, _f0(mesh), 0.5, inner=mesh.vertex_areas, skew=False, return_info=True)
    assert info["method"] == "iom" and maxrel(x, dense_exp(A, _f0(mesh), 0.5)[0]) <= TOL


def test_zero_operator_empty_blocks_and_scalar_shapes(mesh):
    n = mesh.n_vertices
    b = _f0(mesh)
    x, info = expm_action(sp.csr_array((n, n)), b, [1.0, -2.0], return_info=True)
    assert info["method"] == "zero" and np.array_equal(x, np.stack([b, b]))
    assert expm_action(_flow_operator(mesh, "skew"), b, 0.3).shape == (n,)
    assert expm_action(_flow_operator(mesh, "skew"), np.zeros((n, 0)), [1.0]).shape == (1, n, 0)
    assert expm_action(_flow_operator(mesh, "skew"), b, []).shape == (0, n)
    assert np.array_equal(expm_action(_flow_operator(mesh, "skew"), 0 * b, 3.0), 0 * b)


def test_bad_inputs():
    mesh = fvf.icosphere(1)
    A = _flow_operator(mesh, "skew")
    n = A.shape[0]
    b = np.ones(n)
    A_inf = A.copy()
    A_inf.data[0] = np.inf
    bad = [
        dict(A=A[:, :-1], B=b, t=1.0),
        dict(A=A, B=np.ones(n + 1), t=1.0),
        dict(A=A, B=np.ones((n, 2, 2)), t=1.0),
        dict(A=A, B=np.full(n, np.nan), t=1.0),
        dict(A=A, B=b, t=np.inf),
        dict(A=A, B=b, t=np.ones((2, 2))),
        dict(A=A, B=b, t="soon"),
        dict(A=A, B=b, t=1.0, tol=0.0),
        dict(A=A, B=b, t=1.0, tol=2.0),
        dict(A=A, B=b, t=1.0, inner=-np.ones(n)),
        dict(A=A, B=b, t=1.0, inner=np.r_[np.ones(n - 1), np.nan]),
        dict(A=A, B=b, t=1.0, inner=np.ones(n - 1)),
        dict(A=A, B=b, t=1.0, method="pade"),
        dict(A=A, B=b, t=1.0, m_max=0),
        dict(A=A, B=b, t=1.0, skew="yes"),
        dict(A=A, B=b, t=1.0, norm="l2"),
        dict(A=A, B=b, t=1.0, skew_norm=-1.0),
        dict(A=A, B=b, t=1.0, max_products=0),
        dict(A=A_inf, B=b, t=1.0),
        dict(A=A_inf.toarray(), B=b, t=1.0),
        dict(A=A * 1j, B=b, t=1.0),
        dict(A=np.ones(4), B=b, t=1.0),
        dict(A=A, B=np.array(["a"] * n), t=1.0),
    ]
    for kw in bad:
        with pytest.raises(ExpmInputError) as err:
            expm_action(kw.pop("A"), kw.pop("B"), kw.pop("t"), **kw)
        assert isinstance(err.value, FvfError) and isinstance(err.value, ValueError)


# ------------------------------------------------------------------ norms, scales, limits
def test_max_norm_control_on_a_graded_mesh():
    """On a graded mesh the error concentrates on small cells: norm="max" controls it."""
    mesh = fvf.spot()
    A = _flow_operator(mesh, "skew")
    w = mesh.vertex_areas
    b = _f0(mesh)
    t = 3 * mesh.mean_edge_length
    ref = expm_action(A, b, t, inner=w, tol=1e-14, method="krylov")
    for method in ("krylov", "chebyshev"):
        x = expm_action(A, b, t, inner=w, method=method)
        assert maxrel(x, ref) <= TOL and wrel(x, ref, w) <= TOL


@pytest.mark.parametrize("kind", ["skew", "grad"])
def test_inner_weights_and_operator_scale_are_free(mesh, kind):
    A = _flow_operator(mesh, kind)
    b = _f0(mesh)
    w = mesh.vertex_areas
    x = expm_action(A, b, 0.7, inner=w)
    assert maxrel(expm_action(A, b, 0.7, inner=1e-12 * w), x) <= TOL
    assert maxrel(expm_action(A * 1e-150, b, 0.7e150, inner=w), x) <= 10 * TOL


def test_out_of_reach_span_overflow_and_the_work_budget(mesh):
    A = _flow_operator(mesh, "grad")
    b = _f0(mesh)
    with pytest.raises(FlowOverflowError, match="exceeds"):
        expm_action(A, b, 1e30)
    with pytest.raises(FlowOverflowError, match=r"needs about .* products") as err:
        expm_action(A, b, 1e6 * mesh.mean_edge_length)  # refused before any product
    assert "max_products" in str(err.value) and "upwind" in str(err.value)
    seen = []
    x = expm_action(_flow_operator(mesh, "skew"), b, 30.0, max_products=1e6, progress=seen.append)
    assert seen[-1] == 1.0 and np.isfinite(x).all()
    G = sp.diags_array(np.full(mesh.n_vertices, 800.0))  # exp(800 t) overflows at t = 1
    with pytest.raises(FlowOverflowError, match="inf/NaN"):
        expm_action(G, b, 1.0)


def test_skew_bound_is_an_upper_bound_that_tightens(mesh):
    for kind in ("skew", "grad"):
        A = _flow_operator(mesh, kind)
        w = mesh.vertex_areas
        s = np.sqrt(w)
        S = s[:, None] * A.toarray() / s[None, :]
        exact = np.linalg.norm(0.5 * (S - S.T), 2)
        R, products = skew_bound(A, w, return_products=True)
        gersh = skew_bound(A, w, steps=0)
        assert exact <= R <= gersh and R <= 1.3 * exact and products >= 2
    assert skew_bound(sp.eye_array(5)) == 0.0  # symmetric: no skew part


def test_bessel_table_and_chebyshev_degree_against_scipy():
    x = np.array([0.3, 5.0, -17.0, 300.0, 2000.0])
    tab = C._bessel_table(x, 2100)
    assert np.abs(tab - jv(np.arange(2101)[None, :], x[:, None])).max() < 1e-13
    for tau in (0.5, 10.0, 400.0):
        for tol in (1e-6, 1e-12):
            K = chebyshev_degree(tau, tol)
            k = np.arange(K + 1, K + 400)
            assert (
                2 * np.abs(jv(k, tau)).sum()
                <= tol
                < 2 * np.abs(jv(np.arange(K, K + 400), tau)).sum()
            )


def test_series_gives_way_where_its_terms_grow():
    """A real spectrum far outside the strip: the series' terms grow, it warns and the
    Krylov method answers."""
    n = 60
    rng = np.random.default_rng(4)
    A = sp.csr_array(np.triu(rng.standard_normal((n, n)), 1) * 3 + np.diag(np.linspace(0, 5, n)))
    b = rng.standard_normal(n)
    with pytest.warns(KrylovFallbackWarning, match="terms grew"):
        x, info = expm_action(A, b, 2.0, method="chebyshev", return_info=True)
    assert info["method"] == "iom" and info["wasted_matvecs"] > 0
    assert maxrel(x, dense_exp(A, b, 2.0)[0]) <= TOL


def test_threads_give_the_serial_results():
    mesh = fvf.icosphere(3)
    A = _flow_operator(mesh, "skew")
    B = _f0(mesh, 3)
    serial = [expm_action(A, B[:, c], 2.0 + c, inner=mesh.vertex_areas) for c in range(3)]
    got = [None] * 3

    def work(c):
        got[c] = expm_action(A, B[:, c], 2.0 + c, inner=mesh.vertex_areas)

    threads = [threading.Thread(target=work, args=(c,)) for c in range(3)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for c in range(3):
        assert np.array_equal(got[c], serial[c])


def test_no_warnings_on_normal_use(mesh):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for kind in ("skew", "grad"):
            expm_action(_flow_operator(mesh, kind), _f0(mesh, 2), [0.1, 3.0, -2.0])


# ------------------------------------------------------------------ tuning (perf)
@pytest.mark.perf
@pytest.mark.parametrize("kind", ["skew", "grad"])
def test_fewer_products_than_expm_multiply_at_ten_edge_lengths(kind):
    """The tuning's point: at t = 10 edge lengths on spot, several times fewer products
    than scipy's expm_multiply (skew: the series; compressible: IOM)."""
    mesh = fvf.spot()
    A = _flow_operator(mesh, kind)
    b = _f0(mesh)
    t = 10 * mesh.mean_edge_length
    _, ours = expm_action(A, b, t, inner=mesh.vertex_areas, return_info=True)
    counter = ExpmvCounter(A)
    spla.expm_multiply(counter * t, b, traceA=float(A.diagonal().sum()) * t)
    assert ours["matvecs"] + ours["bound_products"] <= counter.products / 3


@pytest.mark.perf
def test_auto_runs_the_series_from_its_threshold():
    mesh = fvf.icosphere(3)
    A = _flow_operator(mesh, "skew")
    R = skew_bound(A, mesh.vertex_areas)
    short = E.SERIES_MIN_TAU / R * 0.5
    long = E.SERIES_MIN_TAU / R * 2.0
    _, i1 = expm_action(A, _f0(mesh), short, inner=mesh.vertex_areas, return_info=True)
    _, i2 = expm_action(A, _f0(mesh), long, inner=mesh.vertex_areas, return_info=True)
    assert (i1["method"], i2["method"]) == ("lanczos", "chebyshev")
