"""fvf.numerics._kernels: the fused numba kernels of the exponential action, against dense algebra
and against the numpy/scipy path they replace (``FVF_NUMBA=0`` / ``ENABLED = False``)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import fvf
import fvf.numerics.expm
from fvf.numerics import _kernels
from fvf.numerics.expm import expm_action

pytest.importorskip("numba")
if not _kernels.ENABLED:  # pragma: no cover - FVF_NUMBA=0 in the environment
    pytest.skip("the fused kernels are disabled (FVF_NUMBA=0)", allow_module_level=True)


def _random_csr(n: int, rng, index_dtype) -> sp.csr_array:
    A = sp.random_array((n, n), density=0.1, random_state=rng, format="csr") + sp.eye_array(n)
    A = sp.csr_array(A)
    A.indptr, A.indices = A.indptr.astype(index_dtype), A.indices.astype(index_dtype)
    return A


def _fused(A: sp.csr_array):
    csr = _kernels.csr_views(A.indptr, A.indices, A.data)
    assert csr is not None
    return csr


@pytest.mark.parametrize("index_dtype", [np.int32, np.int64])
@pytest.mark.parametrize("p", [1, 3, 7, 8, 15])  # (8, 4, 2, 1 columns a pass; > 8: one)
@pytest.mark.parametrize("terms", [1, 2, 5])
def test_term_run_matches_dense(rng, index_dtype, p, terms):
    """term_run's terms (the rows of Y swapping roles) against dense algebra."""
    n = 40
    A = _random_csr(n, rng, index_dtype)
    Ad = A.toarray()
    Y0, O = rng.standard_normal((2, n, p)), rng.standard_normal((n, p))
    coef = rng.standard_normal(2 * terms)[::2]  # a strided view
    for cur in (0, 1):
        Y, out = Y0.copy(), O.copy()
        _kernels.term_run(_fused(A), Y.reshape(2, -1), cur, out.reshape(-1), coef, p)
        ref, ref_out = Y0.copy(), O.copy()
        for t in range(terms):
            src, dst = (cur + t) % 2, (cur + t + 1) % 2
            ref[dst] = ref[dst] + Ad @ ref[src]
            ref_out += coef[t] * ref[dst]
        np.testing.assert_allclose(Y, ref, rtol=1e-13, atol=1e-12)
        np.testing.assert_allclose(out, ref_out, rtol=1e-13, atol=1e-12)
        if p == 1:  # with the norms of the last term measured in its pass
            w = rng.uniform(0.5, 2.0, n)
            Y, out, s2 = Y0.copy(), O.copy(), np.full((2, 1), np.nan)
            _kernels.term_run(_fused(A), Y.reshape(2, -1), cur, out.ravel(), coef, 1, w, s2)
            last = ref[(cur + terms) % 2]
            want = [np.sum(w * last[:, 0] ** 2), np.abs(last).max()]
            np.testing.assert_allclose(s2[:, 0], want, rtol=1e-13)


@pytest.mark.parametrize("index_dtype", [np.int32, np.int64])
@pytest.mark.parametrize("p", [1, 3])
@pytest.mark.parametrize("norms", [0, 1, 2])
def test_term_combine_matches_dense(rng, index_dtype, p, norms):
    n = 40
    A = _random_csr(n, rng, index_dtype)
    X, P = rng.standard_normal((n, p)), rng.standard_normal((n, p))
    c, w = rng.standard_normal(p), rng.uniform(0.5, 2.0, n)
    y, s2 = np.full((n, p), np.nan), np.full((3, p), np.nan)
    _kernels.term_combine(_fused(A), X.ravel(), P.ravel(), c, y.reshape(-1), w, s2, p, norms)
    ref = P * c + A.toarray() @ X
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-13)
    want = np.zeros((3, p))
    if norms:
        want[0] = np.einsum("i,iq,iq->q", w, ref, ref)
    if norms == 2:
        want[1] = np.einsum("i,iq,iq->q", w, ref, X)
        want[2] = np.einsum("i,iq,iq->q", w, ref, P)
    np.testing.assert_allclose(s2, want, rtol=1e-12, atol=1e-12)


def test_abs_stats_match_numpy_and_flag_non_finite(rng):
    A = _random_csr(30, rng, np.int32)
    A.data -= 0.5  # both signs
    dense = np.abs(A.toarray())
    got = _kernels.abs_stats(_fused(A))
    want = (dense.sum(axis=1).max(), np.diag(dense).max(), dense.max())
    np.testing.assert_allclose(got, want, rtol=1e-14)
    A.data[7] = np.inf
    assert all(np.isnan(_kernels.abs_stats(_fused(A))))


@pytest.mark.parametrize("skew", [True, False])
def test_power_bound_matches_the_numpy_steps(rng, skew):
    """The compiled steps (both products of a step from one pass) give what the Python
    loop over scipy's products of fvf.numerics.expm._AbsCsr gives: the bound and the products
    spent, for a fixed number of steps and for the early stop."""
    from fvf.numerics.expm import _AbsCsr, _FusedAbs, _skew_bound

    A = _random_csr(50, rng, np.int64)
    A.data -= 0.5
    if skew:  # zero diagonal, |A| symmetric: one product a step
        A = sp.csr_array(sp.triu(A, 1) - sp.triu(A, 1).T)
    w = rng.uniform(0.5, 2.0, 50)
    per_step = 1 if skew else 2
    gershgorin = _skew_bound(_AbsCsr.of(A), w, 0, np.inf, skew)[0]
    cases = [  # iterations, span, floor, handoff, first floor; the products spent
        (0, np.inf, 0.0, np.inf, 0.0, per_step),
        (4, np.inf, 0.0, np.inf, 0.0, 5 * per_step),
        (20, 3.0, 0.0, np.inf, 0.0, None),  # the early stop (fewer than 21 steps)
        (20, np.inf, 2 * gershgorin, np.inf, 0.0, per_step),  # below the floor at once
        (20, 3.0, 0.0, 2.9 * gershgorin, 0.0, per_step),  # handed off at Gershgorin's bound
        (20, 3.0, 0.0, 3.1 * gershgorin, 0.0, None),
        (4, np.inf, 0.0, np.inf, 1.01 * gershgorin, per_step),  # below the first floor
        (4, np.inf, 0.0, np.inf, 0.99 * gershgorin, 5 * per_step),  # (later bounds: free)
    ]
    for iterations, span, floor, handoff, first, spent in cases:
        args = (w, iterations, span, skew, floor, handoff, first)
        ref = _skew_bound(_AbsCsr.of(A), *args)
        got = _skew_bound(_FusedAbs.of(A), *args)
        assert got[1] == ref[1] and got[1] % per_step == 0
        assert got[0] == pytest.approx(ref[0], rel=1e-13)
        if spent is None:
            assert per_step < ref[1] < 21 * per_step
        else:
            assert ref[1] == spent


def test_tridiag_top_is_the_largest_eigenvalue(rng):
    """The Sturm bisection of the skew Lanczos estimate against LAPACK, on random
    off-diagonals (with zeros, which split the matrix) and the trivial cases."""
    import scipy.linalg as sla

    top = _kernels._jit(_kernels._tridiag_top)
    for m in (1, 2, 5, 30):
        for _ in range(20):
            beta = rng.uniform(0.0, 3.0, m) * (rng.random(m) > 0.2)
            ref = sla.eigvalsh_tridiagonal(np.zeros(m + 1), beta)[-1]
            assert top(beta, m) == pytest.approx(ref, rel=1e-12, abs=1e-300)
            assert top(np.append(beta, 9.0), m) == pytest.approx(ref, rel=1e-12)  # (prefix)
    assert top(np.zeros(3), 3) == 0.0


@pytest.mark.parametrize("kind", ["skew", "grad"])
def test_skew_norm_estimate_is_the_same_on_both_paths(kind):
    """The compiled Lanczos steps (A q and Aᵀ W q from one pass over the rows) give the
    numpy loop's θ and steps, and θ ≤ ‖K‖_W within 1e-3 of it (eigsh of KᵀK)."""
    import scipy.sparse.linalg as spla

    mesh, A = _flow_operator(kind)
    w = mesh.vertex_areas
    fused = fvf.numerics.expm._FusedAbs.of(A)
    got = fvf.numerics.expm._skew_norm_estimate(A, w, fused)
    ref = fvf.numerics.expm._skew_norm_estimate(A, w, None)
    assert got[1:] == ref[1:] and got[2]
    assert got[0] == pytest.approx(ref[0], rel=1e-11)
    s = np.sqrt(w)
    S = sp.diags_array(s) @ A @ sp.diags_array(1 / s)
    K = ((S - S.T) / 2).tocsr()
    exact = float(np.sqrt(spla.eigsh((K.T @ K).tocsr(), k=1, which="LA", tol=1e-12)[0][0]))
    assert (1 - 1e-3) * exact <= got[0] <= exact * (1 + 1e-12)
    for steps in (1, 3):  # a cap before convergence: reported as not converged
        a = _kernels.skew_lanczos(fused.csr, w, _unit(A.shape[0], w), steps, 1e-3)
        assert a[1:] == (steps, False)


def _unit(n, w):
    q = np.random.default_rng(20261122).standard_normal(n)
    return q / np.sqrt(q @ (w * q))


@pytest.mark.parametrize("kind", ["skew", "grad"])
def test_skew_bound_is_the_same_on_both_paths(monkeypatch, kind):
    mesh, A = _flow_operator(kind)
    w = mesh.vertex_areas
    R1 = fvf.numerics.expm.skew_bound(A, inner=w)
    monkeypatch.setattr(_kernels, "ENABLED", False)
    R0 = fvf.numerics.expm.skew_bound(A, inner=w)
    assert R1 == pytest.approx(R0, rel=1e-12)


def test_csr_views_share_memory_and_refuse_what_they_cannot_read(monkeypatch):
    A = sp.csr_array(sp.eye_array(5))
    ip, ix, data = _kernels.csr_views(A.indptr, A.indices, A.data)
    assert ip.dtype.kind == ix.dtype.kind == "u"
    assert np.shares_memory(ip, A.indptr) and np.shares_memory(ix, A.indices)
    assert data is A.data
    assert _kernels.csr_views(A.indptr.astype(float), A.indices, A.data) is None
    assert _kernels.csr_views(A.indptr, np.repeat(A.indices, 2)[::2], A.data) is None  # strided
    assert _kernels.csr_views(A.indptr, A.indices, A.data.astype(np.float32)) is None
    assert _kernels.csr_views(A.indptr, A.indices, np.repeat(A.data, 2)[::2]) is None
    monkeypatch.setattr(_kernels, "ENABLED", False)
    assert _kernels.csr_views(A.indptr, A.indices, A.data) is None


def _spy(monkeypatch) -> dict:
    """Count the products of the fused kernels (an agreement test must run them)."""
    calls = {"n": 0}  # products done by the kernels (term_run: one per coefficient)
    kernels = ("term_run", "term_chain", "term_combine", "lanczos_run", "lanczos_step", "iom_run")
    for name in kernels:
        real = getattr(_kernels, name)

        def wrapped(*args, _real=real, _name=name):
            out = _real(*args)
            # term_run: one product per coefficient; term_chain: ``count``; lanczos_run:
            # the vectors it finished; lanczos_step: the products it reports;
            # term_combine: one
            if _name == "term_run":
                calls["n"] += len(args[4])
            elif _name == "term_chain":
                calls["n"] += args[3]
            elif _name == "lanczos_run":
                calls["n"] += int(args[9][1]) - args[5]
            elif _name == "lanczos_step":
                calls["n"] += int(out[1][6])
            elif _name == "iom_run":
                calls["n"] += int(args[7][1]) - args[4]
            else:
                calls["n"] += 1
            return out

        monkeypatch.setattr(_kernels, name, wrapped)
    return calls


def _flow_operator(kind: str):
    mesh = fvf.mesh.builtin.spot()
    grad = fvf.gradient(mesh, mesh.vertices[:, 1])
    v = fvf.rotate(mesh, grad) if kind == "skew" else grad
    v = v / np.linalg.norm(v, axis=1).max()
    A = (-fvf.D_V(mesh, v, tangent="ignore")).tocsr()
    return mesh, A


CASES = [  # (field, p, number of times, method that runs)
    ("skew", 1, 1, "chebyshev"),
    ("skew", 1, 1, "lanczos"),
    ("skew", 4, 1, "chebyshev"),
    ("skew", 1, 5, "lanczos"),
    ("grad", 1, 1, "chebyshev"),
    ("grad", 1, 5, "chebyshev"),
    ("grad", 3, 1, "chebyshev"),
    ("grad", 1, 1, "iom"),
    ("grad", 1, 5, "iom"),
]


@pytest.mark.parametrize(("kind", "p", "T", "expected"), CASES)
def test_fused_and_scipy_paths_agree(monkeypatch, rng, kind, p, T, expected):
    """The same result (to round-off, far below tol) with the same products, for every
    recurrence that uses a fused kernel: the series for one and several times and blocks,
    Lanczos for one column."""
    mesh, A = _flow_operator(kind)
    w = mesh.vertex_areas
    B = rng.standard_normal((A.shape[0], p)) if p > 1 else rng.standard_normal(A.shape[0])
    t = 10 * mesh.mean_edge_length * (np.linspace(-1, 1, T) if T > 1 else 1.0)
    skew = True if kind == "skew" else None
    method = "chebyshev" if expected == "chebyshev" else "krylov"  # ("auto" depends on numba)
    kw = dict(inner=w, skew=skew, tol=1e-10, method=method, return_info=True)
    calls = _spy(monkeypatch)
    x1, i1 = expm_action(A, B, t, **kw)
    assert calls["n"] >= i1["block_matvecs"] - 10  # all terms but the first and the bound's
    monkeypatch.setattr(_kernels, "ENABLED", False)
    calls["n"] = 0
    x0, i0 = expm_action(A, B, t, **kw)
    assert calls["n"] == 0
    assert i1["method"] == i0["method"] == expected
    assert i1["matvecs"] == i0["matvecs"]
    assert np.abs(x1 - x0).max() <= 1e-12 * np.abs(x0).max()


def test_fused_lanczos_block_and_euclidean_agree(monkeypatch, rng):
    """Lanczos on a block (the block kernel with per-column coefficients) and with no
    weights (the kernel's norms then use unit weights)."""
    _, A = _flow_operator("skew")
    n = A.shape[0]
    w = fvf.mesh.builtin.spot().vertex_areas
    S = sp.diags_array(np.sqrt(w)) @ A @ sp.diags_array(1 / np.sqrt(w))  # Euclidean-skew
    B = rng.standard_normal((n, 3))
    t = np.array([0.01, 0.03, 0.05])
    for op, inner in ((A, w), (sp.csr_array(S), None)):
        kw = dict(inner=inner, skew=True, method="krylov", tol=1e-10, return_info=True)
        with monkeypatch.context() as mp:
            calls = _spy(mp)
            x1, i1 = expm_action(op, B, t, **kw)
            assert calls["n"] == i1["block_matvecs"]
            mp.setattr(_kernels, "ENABLED", False)
            x0, i0 = expm_action(op, B, t, **kw)
            assert calls["n"] == i1["block_matvecs"]
        assert i1["method"] == i0["method"] == "lanczos"
        assert i1["matvecs"] == i0["matvecs"]
        assert np.abs(x1 - x0).max() <= 1e-12 * np.abs(x0).max()


def test_bessel_rows_match_scipy_and_the_python_rows(monkeypatch):
    from scipy.special import jv

    from fvf.numerics.expm import _BESSEL_TINY, _bessel_row, _cheb_coefficients, _degree_top

    # 0 and 3e-9 are below the tiny threshold (the leading terms, inside the kernel)
    x = np.array([0.0, 3e-9, 1e-7, 0.3, 2.4, 38.9, 200.0, 1500.0])
    kmax = _degree_top(float(x.max()))
    got = _kernels.bessel_rows(x, kmax, _BESSEL_TINY)
    ref = jv(np.arange(kmax + 1)[None, :], x[:, None])
    assert np.abs(got - ref).max() <= 1e-13
    rows = np.stack([_bessel_row(float(v), kmax) for v in x])
    assert np.abs(got - rows).max() <= 1e-15
    taus = np.array([-3.0, 0.5, 3.0, 40.0, 0.5, 0.0, -2e-9])  # signs, repeats, tiny
    c1 = _cheb_coefficients(taus, 90)
    monkeypatch.setattr(_kernels, "ENABLED", False)
    c0 = _cheb_coefficients(taus, 90)
    assert np.abs(c1 - c0).max() <= 1e-15


def test_chebyshev_degree_compiled_and_python_agree(monkeypatch):
    """The compiled degree (one kernel) is the numpy one exactly, tiny τ included."""
    rng = np.random.default_rng(4)
    taus = [0.0, 3e-9, 1e-3, 0.7, 12.0, 41.8, 150.0, 900.0, *rng.uniform(0, 400, 40)]
    tols = [1e-4, 5e-11, 1e-15, 0.3]
    fast = [fvf.numerics.expm.chebyshev_degree(t, tol) for t in taus for tol in tols]
    monkeypatch.setattr(_kernels, "ENABLED", False)
    slow = [fvf.numerics.expm.chebyshev_degree(t, tol) for t in taus for tol in tols]
    assert fast == slow


@pytest.mark.parametrize("m", [1, 2, 7, 40])
def test_skew_exp_series_matches_svd_and_dense(rng, m):
    """Lanczos' small exponentials by the compiled series (numba) against the SVD path and
    scipy.linalg.expm, for several columns and times of either sign and zero."""
    import scipy.linalg as la

    p = 3
    beta = rng.uniform(0.2, 3.0, (m - 1, p))
    beta[:, 2] *= 1e-3  # a nearly zero H
    s = np.array([0.0, 0.3, -1.7, 5.0, -12.0, 1e-10])
    fast = fvf.numerics.expm._SkewExpSeries(beta)
    svd = fvf.numerics.expm._SkewExp(beta)
    E = fast.e1(s)
    np.testing.assert_allclose(E, svd.e1(s), rtol=0, atol=1e-13)
    bl = np.array([0.7, 2.0, 1e-3])
    for hi in (0.0, 0.4, 5.0, 12.0):
        for sign in (1.0, -1.0):  # the compiled integral against the SVD's values
            got = fast.residual_integral(hi, bl, sign)
            assert got.shape == (p, fvf.numerics.expm._GRID + 1)
            np.testing.assert_allclose(got, svd.residual_integral(hi, bl, sign), atol=1e-13)
    for c in range(p):
        H = np.zeros((m, m))
        for j in range(m - 1):
            H[j + 1, j], H[j, j + 1] = beta[j, c], -beta[j, c]
        for g, sg in enumerate(s):
            np.testing.assert_allclose(E[c, g], la.expm(sg * H)[:, 0], rtol=0, atol=1e-13)
        # the integrand at the grid points, from expm: the trapezoid sums of its |values|
        grid = fvf.numerics.expm._grid(5.0)
        vals = [abs(bl[c] * la.expm(-g * H)[-1, 0]) for g in grid]
        ref = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(grid) * np.add(vals[1:], vals[:-1]))])
        np.testing.assert_allclose(fast.residual_integral(5.0, bl, -1.0)[c], ref, atol=1e-13)


@pytest.mark.parametrize("index_dtype", [np.int32, np.int64])
@pytest.mark.parametrize("p", [1, 3, 7, 8, 15])
def test_term_chain_matches_dense(rng, index_dtype, p):
    """term_chain's run of terms Y[f] = Y[f − 2] + A Y[f − 1] against dense algebra; the
    slots before f0 and after the run are left alone."""
    n, chunk = 40, 7
    A = _random_csr(n, rng, index_dtype)
    Y0 = rng.standard_normal((chunk, n, p))
    Y = Y0.copy()
    _kernels.term_chain(_fused(A), Y.reshape(chunk, -1), 3, 3, p)
    ref = Y0.copy()
    for f in range(3, 6):
        ref[f] = ref[f - 2] + A.toarray() @ ref[f - 1]
    np.testing.assert_allclose(Y, ref, rtol=1e-13, atol=1e-12)


def _lanczos_coefficients(A, b, w, m, fused: bool, monkeypatch):
    monkeypatch.setattr(_kernels, "ENABLED", fused)
    op = fvf.numerics.expm._Operator(A, A.shape[0])
    V = np.zeros((m + 1, A.shape[0], 1))
    V[0, :, 0] = b
    lz = fvf.numerics.expm._Lanczos(op, w, V, limit=1e-9)
    lz.extend_to(m)
    return lz, V


def test_lanczos_run_matches_the_numpy_recurrence(monkeypatch, rng):
    """The compiled run of Lanczos vectors (one column) against the numpy/scipy path:
    the same β, ν and vectors, and the same stop at an exact breakdown."""
    n = 60
    S = sp.random_array((n, n), density=0.1, rng=rng, format="csr")
    w = rng.uniform(0.5, 2.0, n)
    A = sp.csr_array(sp.diags_array(1.0 / w) @ (S - S.T))  # W-skew
    b = rng.standard_normal(n)
    fast, Vf = _lanczos_coefficients(A, b, w, 30, True, monkeypatch)
    assert fast.op.fused is not None and fast.m == 30 and fast.op.matvecs == 30
    slow, Vs = _lanczos_coefficients(A, b, w, 30, False, monkeypatch)
    np.testing.assert_allclose(fast.beta, slow.beta, rtol=1e-12)
    np.testing.assert_allclose(fast.nu, slow.nu, rtol=1e-12)
    # (later vectors drift apart as rounding differences grow, as Lanczos' do: 3e-10 by 23)
    np.testing.assert_allclose(Vf[:13], Vs[:13], rtol=0, atol=1e-11 * np.abs(Vs[:13]).max())
    assert fast.mean_beta() == pytest.approx(slow.mean_beta(), rel=1e-12)
    # a rotation of the first two coordinates: the Krylov space of e_0 has dimension 2
    R = sp.csr_array(([1.0, -1.0], ([1, 0], [0, 1])), shape=(n, n))
    e0 = np.eye(n)[0]
    for fused in (True, False):
        lz, _ = _lanczos_coefficients(R, e0, None, 10, fused, monkeypatch)
        assert lz.m == 2 and lz.broken() and lz.beta[1, 0] == 0.0


def test_lanczos_run_reports_a_non_skew_operator(monkeypatch, rng):
    n = 40
    A = sp.csr_array(sp.random_array((n, n), density=0.2, rng=rng) + sp.eye_array(n))
    with pytest.raises(fvf.numerics.expm._NotSkew):
        _lanczos_coefficients(A, rng.standard_normal(n), None, 10, True, monkeypatch)


@pytest.mark.parametrize("p", [1, 3])
@pytest.mark.parametrize("weighted", [True, False])
@pytest.mark.parametrize("maxnorm", [True, False])
def test_col_norms_match_numpy(monkeypatch, rng, p, weighted, maxnorm):
    """The one-pass norms against the numpy path of fvf.numerics.expm._col_norms (one block and
    a stack of blocks)."""
    from fvf.numerics.expm import _col_norms

    n = 37
    w = rng.uniform(0.1, 2.0, n) if weighted else None
    for T in (1, 5):
        X = rng.standard_normal((T, n, p))
        X[-1, :, 0] = 0.0  # a zero column
        got = _kernels.col_norms(X.reshape(T, n * p), w, p, maxnorm)
        ref_w = np.sqrt(np.einsum("tnp,n->tp", X * X, np.ones(n) if w is None else w))
        ref_max = np.abs(X).max(axis=1) if maxnorm else np.ones((T, p))
        np.testing.assert_allclose(got[0], ref_w, rtol=1e-14)
        np.testing.assert_array_equal(got[1], ref_max)
        with monkeypatch.context() as mp:
            mp.setattr(_kernels, "ENABLED", False)
            np.testing.assert_allclose(_col_norms(X, w, maxnorm), got, rtol=1e-14)


@pytest.mark.parametrize(
    "times, norm, m_max",
    [
        ("one", "max", None),
        ("sixteen", "max", None),
        ("sixteen", "inner", None),
        ("signs", "max", None),
        ("one", "max", 20),  # capped bases: several steps, checks that fail, cut steps
        ("sixteen", "inner", 16),
    ],
)
def test_compiled_lanczos_step_is_the_python_loop(monkeypatch, times, norm, m_max):
    """fvf.numerics._kernels.lanczos_step runs the loop of fvf.numerics.expm._lanczos_steps for one column
    with the same arithmetic: the same bases, products and estimates, the same outputs."""
    mesh, A = _flow_operator("skew")
    w = mesh.vertex_areas
    b = np.cos(3 * mesh.vertices[:, 0]) + mesh.vertices[:, 2]
    h = 10 * mesh.mean_edge_length
    t = {
        "one": h,
        "sixteen": h * np.arange(1, 17) / 16,
        "signs": h * np.array([0.5, -1.0, 0.0, 1.0, -0.25]),
    }[times]
    kw = dict(inner=w, skew=True, norm=norm, m_max=m_max, method="krylov", return_info=True)
    x1, i1 = expm_action(A, b, t, **kw)
    monkeypatch.setattr(fvf.numerics.expm, "_COMPILED_STEP", False)
    x0, i0 = expm_action(A, b, t, **kw)
    assert i1["method"] == i0["method"] == "lanczos"
    assert i1["basis_sizes"] == i0["basis_sizes"] and i1["matvecs"] == i0["matvecs"]
    if m_max is not None:
        assert len(i1["basis_sizes"]) > 1  # (several steps were taken)
    assert i1["error_estimate"] == pytest.approx(i0["error_estimate"], rel=1e-9)
    assert np.abs(x1 - x0).max() <= 1e-13 * np.abs(x0).max()


def test_compiled_lanczos_step_refuses_a_non_skew_operator_as_the_loop_does(monkeypatch):
    mesh, A = _flow_operator("grad")
    b = mesh.vertices[:, 1].copy()
    t = 3 * mesh.mean_edge_length
    kw = dict(inner=mesh.vertex_areas, skew=True, method="krylov", return_info=True)
    with pytest.warns(fvf.numerics.expm.KrylovFallbackWarning):
        x1, i1 = expm_action(A, b, t, **kw)
    monkeypatch.setattr(fvf.numerics.expm, "_COMPILED_STEP", False)
    with pytest.warns(fvf.numerics.expm.KrylovFallbackWarning):
        x0, i0 = expm_action(A, b, t, **kw)
    assert i1["method"] == i0["method"] == "iom"
    assert i1["wasted_matvecs"] == i0["wasted_matvecs"] > 0
    np.testing.assert_array_equal(x1, x0)


# ------------------------------------------------------ the general Krylov method (IOM)
def _banded_hessenberg(rng, m: int, window: int) -> np.ndarray:
    """(m + 1, m) upper Hessenberg with ``window`` entries above the subdiagonal per column
    (the shape of incomplete orthogonalization's H), positive subdiagonal."""
    H = np.zeros((m + 1, m))
    for j in range(m):
        lo = max(0, j + 1 - window)
        H[lo : j + 1, j] = rng.standard_normal(j + 1 - lo)
        H[j + 1, j] = rng.uniform(0.1, 2.0)
    return H


@pytest.mark.parametrize("window", [1, 2, 4, 7, 60])
def test_iom_run_matches_the_numpy_vectors(rng, window):
    """iom_run's basis and H against fvf.numerics.expm._iom_vector (numpy, one vector a call): the
    same classical Gram–Schmidt pass, summed in another order."""
    n, m = 60, 25
    A = _random_csr(n, rng, np.int32)
    A = sp.csr_array(A - 0.7 * A.T)  # not symmetric, not skew
    w = rng.uniform(0.5, 2.0, n)
    v0 = rng.standard_normal(n)
    v0 /= np.sqrt(w @ v0**2)
    V1, H1 = np.zeros((m + 1, n)), np.zeros((m + 1, m))
    V1[0] = v0
    res = np.zeros(3)
    _kernels.iom_run(_fused(A), V1, w, H1, 0, 10, window, res)  # two runs, as the checks cut
    _kernels.iom_run(_fused(A), V1, w, H1, 10, m, window, res)
    assert res[0] == 0 and res[1] == m
    op = fvf.numerics.expm._Operator(A, n)
    V0, H0 = np.zeros((m + 1, n)), np.zeros((m + 1, m))
    V0[0] = v0
    for j in range(m):
        fvf.numerics.expm._iom_vector(op, V0, H0, j, window, w, np.empty(n), None)
    np.testing.assert_allclose(H1, H0, rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(V1, V0, rtol=1e-11, atol=1e-11)
    assert res[2] == pytest.approx(np.diag(H0, -1).sum(), rel=1e-13)
    if window >= m:  # full orthogonalization: an orthonormal basis
        G = (V1 * w) @ V1.T
        np.testing.assert_allclose(G, np.eye(m + 1), atol=1e-12)


@pytest.mark.parametrize("shift", [0.0, 1.0, 3.0, 10.0, 1e5, "laplacian"])
def test_iom_run_norms_by_pythagoras_only_where_it_is_accurate(rng, shift):
    """β² = ‖A v‖² − Σ h_i² (one pass fewer) assumes a W-orthonormal window. Its rounding
    error comes back in the next vectors as e·Σh_i²/β²: with shifts of 1–10 × the
    operator's size, or a Laplacian (Σh_i²/β² ≈ 10), unchecked norms drifted to 22–46
    (a review's finding), so the next vector's pass checks each norm and rescales the
    vector when off. With a shift 1e5 × its size ‖A v‖² is ~1e10 β²: there the kernel
    must take the explicit norm. Every vector but the last (checked by the next pass, one
    step of amplification from unit norm) has unit W-norm to 1e-12, and the Arnoldi
    relation holds to rounding, on both paths (whose bases agree where they are well
    conditioned: the larger shifts amplify the two summation orders' rounding)."""
    n, m = 80, 30
    S = _random_csr(n, rng, np.int32)
    if shift == "laplacian":
        G = abs(S + S.T)
        A = sp.csr_array(G - sp.diags_array(np.asarray(G.sum(axis=1)).ravel()))
    else:
        A = sp.csr_array(S - S.T + 0.05 * S + shift * sp.eye_array(n))
    w = rng.uniform(0.5, 2.0, n)
    V, H, res = np.zeros((m + 1, n)), np.zeros((m + 1, m)), np.zeros(3)
    V[0] = rng.standard_normal(n)
    V[0] /= np.sqrt(w @ V[0] ** 2)
    _kernels.iom_run(_fused(A), V, w, H, 0, m, 4, res)
    assert res[0] == 0 and res[1] == m
    op = fvf.numerics.expm._Operator(A, n)
    V0, H0 = np.zeros((m + 1, n)), np.zeros((m + 1, m))
    V0[0] = V[0]
    for j in range(m):
        fvf.numerics.expm._iom_vector(op, V0, H0, j, 4, w, np.empty(n), None)
    for Vk, Hk in ((V, H), (V0, H0)):
        np.testing.assert_allclose((Vk[:m] ** 2) @ w, 1.0, rtol=1e-12)
        assert abs((Vk[m] ** 2) @ w - 1.0) <= 1e-9
        scale = np.abs(Hk).max()
        np.testing.assert_allclose((A @ Vk[:m].T).T, Hk.T @ Vk, rtol=0, atol=1e-12 * scale)
    # the two summation orders' rounding grows along the basis, ~10× per 5 vectors for
    # the Laplacian: its bases were 5e-11–1.3e-10 apart, with OpenBLAS's Haswell,
    # Sandybridge or Nehalem kernels under the numpy path (session 12); shifts of 0–3
    # stayed below 1.5e-11
    if shift in (0.0, 1.0, 3.0, "laplacian"):
        atol = 1e-9 if shift == "laplacian" else 1e-10
        np.testing.assert_allclose(V0, V, rtol=0, atol=atol)


def test_iom_run_reports_breakdown_and_overflow(rng):
    """An eigenvector as the start ends the run at m = 1 with β = 0 exactly (status 1);
    an infinite entry ends it with status 2."""
    n = 30
    A = sp.csr_array(sp.diags_array(np.arange(1.0, n + 1)))
    V, H, res = np.zeros((11, n)), np.zeros((11, 10)), np.zeros(3)
    V[0, 3] = 1.0
    _kernels.iom_run(_fused(A), V, np.ones(n), H, 0, 10, 4, res)
    assert res[0] == 1 and res[1] == 1 and H[0, 0] == 4.0 and H[1, 0] == 0.0
    A.data[5] = np.inf
    V[0] = 1 / np.sqrt(n)
    res[:] = 0
    _kernels.iom_run(_fused(A), V, np.ones(n), H, 0, 10, 4, res)
    assert res[0] == 2 and res[1] == 1


@pytest.mark.parametrize("window", [1, 2, 4, 60])
def test_hess_mu_is_the_top_eigenvalue_of_the_symmetric_part(rng, window):
    """Against LAPACK, for both signs, cold and from the leading block's μ (interlacing)."""
    for m in (1, 2, 5, 30, 60):
        H = _banded_hessenberg(rng, m, window)
        scale = np.abs(H).sum(axis=1).max()
        for sign in (1.0, -1.0):
            S = sign * 0.5 * (H[:m, :m] + H[:m, :m].T)
            ref = np.linalg.eigvalsh(S)[-1]
            got = _kernels.hess_mu(H, m, sign, window)
            assert ref - 1e-13 * scale <= got <= ref + 2e-10 * scale  # from above
            if m > 1:
                below = _kernels.hess_mu(H, m - 1, sign, window)
                warm = _kernels.hess_mu(H, m, sign, window, below)
                assert ref - 1e-13 * scale <= warm <= ref + 2e-10 * scale
    assert _kernels.hess_mu(np.zeros((4, 3)), 3, 1.0, 4) == 0.0


@pytest.mark.parametrize("window", [2, 4, 40])
def test_hess_profile_and_expv_match_scipy(monkeypatch, rng, window):
    """The grid exp(s_g H_m) e_1 and the error estimate against the numpy _HessenbergExp
    (scipy's expm of one grid step, applied g times), and exp(c H_m) x for small and large
    c of either sign against scipy's expm.

    (Not against expm(s_g H_m) for each s_g: for window 40, hi = 9, where the grid grows
    to 6e4, that was 4e-10 off a 40-digit mpmath reference, the stepped grids 1e-13 and
    4e-15.)"""
    import scipy.linalg as sla

    m = 40
    H = _banded_hessenberg(rng, m, window)
    H[m, m - 1] = 0.7
    for sign, hi in ((1.0, 0.3), (-1.0, 2.0), (1.0, 9.0)):
        mu = _kernels.hess_mu(H, m, sign, window)
        X, E = _kernels.hess_profile(H, m, sign, window, 0.7, hi, mu, 64)
        monkeypatch.setattr(fvf.numerics.expm, "_COMPILED_IOM", False)
        ref = fvf.numerics.expm._HessenbergExp(H, m, sign)
        s, E0 = ref.errors(hi)
        monkeypatch.setattr(fvf.numerics.expm, "_COMPILED_IOM", True)
        X0 = ref._grid[1]
        np.testing.assert_allclose(X, X0, rtol=0, atol=1e-12 * np.abs(X0).max())
        np.testing.assert_allclose(E, E0, rtol=1e-8, atol=1e-16)  # (a relative error)
    x = rng.standard_normal(m)
    norm1 = np.abs(H[:m, :m]).sum(axis=0).max()
    for c in (1e-9, 0.05, -0.8, 6.0, -25.0):
        ref = sla.expm(c * H[:m, :m]) @ x
        got = _kernels.hess_expv(H, m, c, window, x)
        # both carry rounding of order ε·|c|·‖H‖₁ relative (amplified through the steps or
        # squarings): against a 50-digit mpmath reference at window 40, c = −25 (result
        # 5e22), ours was 2.2–2.6e-13 off and scipy's 1.8e-13 with OpenBLAS's Haswell
        # kernels, 9.0e-13 with its Sandybridge kernels; ε·|c|·‖H‖₁ = 2.0e-13 (session 12)
        scale = 16 * np.finfo(float).eps * max(1.0, abs(c) * norm1)
        np.testing.assert_allclose(got, ref, rtol=0, atol=scale * np.abs(ref).max())


@pytest.mark.parametrize(
    "times, norm, m_max",
    [
        ("one", "max", None),
        ("sixteen", "max", None),
        ("off-grid", "max", None),
        ("signs", "inner", None),
        ("one", "max", 20),  # capped bases: several steps, checks that fail, cut steps
    ],
)
def test_compiled_iom_is_the_numpy_loop(monkeypatch, times, norm, m_max):
    """With numba, the general method's vectors (iom_run) and its checks' small
    exponentials (hess_mu, hess_profile, hess_expv) are compiled; the loop around them is
    the same, so the bases, checks and outputs are those of the numpy path."""
    mesh, A = _flow_operator("grad")
    w = mesh.vertex_areas
    b = np.cos(3 * mesh.vertices[:, 0]) + mesh.vertices[:, 2]
    h = 6 * mesh.mean_edge_length
    t = {
        "one": h,
        "sixteen": h * np.arange(1, 17) / 16,
        "off-grid": h * np.array([0.013, 0.5, 0.77, 1.0]),
        "signs": h * np.array([0.5, -1.0, 0.0, 1.0, -0.25]),
    }[times]
    kw = dict(inner=w, skew=False, norm=norm, m_max=m_max, method="krylov", return_info=True)
    calls = _spy(monkeypatch)
    x1, i1 = expm_action(A, b, t, **kw)
    assert calls["n"] == i1["matvecs"]  # every vector came from the kernel
    monkeypatch.setattr(fvf.numerics.expm, "_COMPILED_IOM", False)
    x0, i0 = expm_action(A, b, t, **kw)
    assert i1["method"] == i0["method"] == "iom"
    assert i1["basis_sizes"] == i0["basis_sizes"] and i1["matvecs"] == i0["matvecs"]
    if m_max is not None:
        assert len(i1["basis_sizes"]) > 1  # (several steps were taken)
    assert i1["error_estimate"] == pytest.approx(i0["error_estimate"], rel=1e-6)
    assert np.abs(x1 - x0).max() <= 1e-12 * np.abs(x0).max()
    ref = expm_action(A, b, t, inner=w, method="expm_multiply", tol=1e-13)
    assert np.abs(x1 - ref).max() <= 1e-10 * np.abs(ref).max()


def test_hess_profile_keeps_its_norms_past_overflow(monkeypatch):
    """A grid that grows past 1e154, where ‖X‖² overflows: both paths scale the norms (they
    divided by an infinite norm and estimated an error of 0 there, accepting the step)."""
    m = 6
    H = np.zeros((m + 1, m))
    for j in range(m):
        H[j, j] = 60.0
        H[j + 1, j] = 1.0
    mu = _kernels.hess_mu(H, m, 1.0, 4)
    X, E = _kernels.hess_profile(H, m, 1.0, 4, 1.0, 7.0, mu, 64)
    assert np.abs(X).max() > 1e180 and np.isfinite(E).all()
    monkeypatch.setattr(fvf.numerics.expm, "_COMPILED_IOM", False)
    _, E0 = fvf.numerics.expm._HessenbergExp(H, m, 1.0).errors(7.0)
    assert E0[-1] > 1.0  # (it was 0)
    np.testing.assert_allclose(E[1:], E0[1:], rtol=1e-7)  # (μ to 1e-10·61: e^{δμ·7})


def test_hess_expv_squares_long_steps():
    """exp(c H_m) x for a stiff H_m and c·‖H_m‖₁ up to 4e5 (an output time inside a long
    step): by scaling and squaring, not 1e5 substeps (8 s at c = 1e5 in a review)."""
    import time

    import scipy.linalg as sla

    m = 100
    H = np.zeros((m + 1, m))
    H[np.arange(m), np.arange(m)] = -2.0
    H[np.arange(m - 1), np.arange(1, m)] = 1.0
    H[np.arange(1, m + 1), np.arange(m)] = 1.0
    x = np.random.default_rng(0).standard_normal(m)
    _kernels.hess_expv(H, m, 1.0, 4, x)  # (compiled)
    for c in (3.0, 1e3, 1e5):
        start = time.perf_counter()
        got = _kernels.hess_expv(H, m, c, 4, x)
        assert time.perf_counter() - start < 2.0
        ref = sla.expm(c * H[:m, :m]) @ x
        assert np.abs(got - ref).max() <= 1e-10 * np.abs(ref).max() + 1e-15 * np.abs(x).max()
