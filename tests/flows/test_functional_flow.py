"""Functional flows Φ_{v,t} = exp(−t D^V_v) (§3.4–3.5): Lemmas 11–13 and growth warnings."""

import numpy as np
import pytest

import fvf
from conftest import load_shared, random_tangent_field, rel, smooth_functions
from fvf import chapter as ch
from fvf.flows.functional import hotspots


@pytest.fixture(scope="module")
def sphere():
    return fvf.jittered_sphere(3, 0.3, seed=2)


def _rotation_z(mesh):
    return mesh.project_tangent(np.cross([0.0, 0.0, 1.0], mesh.face_centroids))


def test_lemma11_group_and_generator(sphere):
    v = _rotation_z(sphere)
    f, _, _ = smooth_functions(sphere)
    phi = fvf.FunctionalFlow(sphere, v, tol=1e-13)  # identities to the action's accuracy
    assert np.array_equal(phi(f, 0.0), f)  # Φ_0 = I
    assert rel(phi(phi(f, 0.3), 0.4), phi(f, 0.7)) < 1e-12  # Φ_t Φ_s = Φ_{t+s}
    assert rel(phi(phi(f, 0.5), -0.5), f) < 1e-12  # inverse
    D = ch.D_V(sphere, v)
    h = 1e-4
    deriv = (phi(f, h) - phi(f, -h)) / (2 * h)
    assert rel(deriv, -(D @ f)) < 1e-7  # dΦ/dt at 0 = −D^V_v (central difference, O(h²))
    assert rel(D @ phi(f, 0.6), phi(D @ f, 0.6)) < 1e-12  # D Φ_t = Φ_t D


def test_times_array_matches_scalars(sphere):
    v = _rotation_z(sphere)
    f, g, _ = smooth_functions(sphere)
    phi = fvf.FunctionalFlow(sphere, v, tol=1e-13)
    times = np.array([0.4, -0.2, 0.0, 0.1, -0.7])
    out = phi(f, times)
    assert out.shape == (5, sphere.n_vertices)
    for k, t in enumerate(times):
        assert rel(out[k], phi(f, t)) < 1e-12
    block = phi(np.stack([f, g], axis=1), times)
    assert block.shape == (5, sphere.n_vertices, 2)
    assert rel(block[:, :, 1], phi(g, times)) < 1e-12
    assert rel(ch.flow(sphere, v, f, times, tol=1e-13), out) < 1e-14


def test_divergence_free_flow_keeps_norm(closed):
    """A_V D^V_v is skew for v = J grad g, so ‖Φ_t f‖_{A_V} = ‖f‖_{A_V} (CHAPTER.md facts)."""
    f, g, _ = smooth_functions(closed)
    v = fvf.rotate(closed, fvf.gradient(closed, g))
    v /= np.sqrt((closed.face_areas * (v * v).sum(1)).sum() / closed.total_area)  # unit RMS
    phi = fvf.FunctionalFlow(closed, v)
    t = 0.2 * np.sqrt(closed.total_area)
    n0, n1 = phi.norm(f), phi.norm(phi(f, t))
    assert abs(n1 - n0) <= 1e-10 * n0
    assert max(phi.growth_rate) < 1e-8 * np.abs(ch.D_V(closed, v)).max()


def _lion_setup(name):
    return fvf.examples.compressible_case(load_shared(name))


def test_growth_warning_fires_on_lion():
    """docs/chapter.md facts: on lion-00 the flow of grad x blows up by t = 0.1; the call
    that grows it warns, once, naming where div v is largest."""
    mesh, v, f0 = _lion_setup("lion-00.off")
    phi = fvf.FunctionalFlow(mesh, v)
    assert phi.growth_bound(0.1) > 1e10
    with pytest.warns(fvf.FlowGrowthWarning, match="grew a function's A_V-norm") as rec:
        ft = phi(f0, 0.05)
    assert len(rec) == 1
    assert np.abs(ft).max() > 1e3 * np.abs(f0).max()  # and it really does blow up
    assert phi.stats["growth"][0] == pytest.approx(phi.norm(ft) / phi.norm(f0), rel=1e-12)
    msg = str(rec[0].message)
    assert rec[0].filename == __file__  # the warning points at the user's line
    assert "at vertices [" in msg and "in faces [" in msg
    worst, faces = hotspots(mesh, fvf.div(mesh) @ v.ravel())
    assert f"in faces {fvf.errors.format_indices(faces)}" in msg
    # the named faces are exactly those around the named vertices
    assert np.array_equal(faces, np.flatnonzero(np.isin(mesh.faces, worst).any(axis=1)))
    assert phi.stats["method"] == "iom"  # not skew: the Krylov method
    # the series, asked for, sees its terms grow (the operator is far from skew) and
    # gives way to the Krylov method, with a warning and the same answer
    cheb = fvf.FunctionalFlow(mesh, v, method="chebyshev", growth_limit=np.inf)
    with pytest.warns(fvf.KrylovFallbackWarning, match="terms grew"):
        out = cheb(f0, 0.05)
    assert rel(out, ft) < 1e-9 and cheb.stats["wasted_matvecs"] > 0
    assert set(worst) <= set(mesh.faces[faces].ravel())


def test_growth_warning_is_silent_where_the_norm_barely_changes(sphere):
    """The warning reports growth that happened: a compressible flow that changes the
    norm by a fraction of a percent is silent however loose e^{μt} is."""
    v = fvf.gradient(sphere, sphere.vertices[:, 2])
    phi = fvf.FunctionalFlow(sphere, v, growth_limit=1.5)
    f0 = 1.0 + 0.1 * sphere.vertices[:, 0]
    phi(f0, 0.01)  # FvfWarning is an error in this suite: none may fire
    assert max(abs(g - 1) for g in phi.stats["growth"]) < 0.05 and phi.growth_bound(0.01) > 1


def test_series_on_a_compressible_field_matches_the_dense_exponential(sphere):
    """A field that is not skew: the series, asked for, runs with R = skew_bound (above
    the norm of the skew part) and checks itself a posteriori against the dense
    exponential's answer."""
    import scipy.linalg

    mesh = sphere
    v = fvf.gradient(mesh, mesh.vertices[:, 2] + 0.3 * mesh.vertices[:, 0] ** 2)
    v /= np.linalg.norm(v, axis=1).max()
    phi = fvf.FunctionalFlow(mesh, v, growth_limit=np.inf, method="chebyshev")
    w = mesh.vertex_areas
    s = np.sqrt(w)
    S = s[:, None] * phi.operator.toarray() / s[None, :]
    exact = float(np.linalg.norm(0.5 * (S - S.T), 2))
    R = phi.skew_norm
    assert exact <= R <= 1.3 * exact
    f0 = np.sin(2 * mesh.vertices[:, 0]) + mesh.vertices[:, 1]
    t = 40 / R
    ft = phi(f0, t)
    assert phi.stats["method"] == "chebyshev" and phi.stats["skew_bound"] == pytest.approx(R)
    ref = scipy.linalg.expm(-t * phi.operator.toarray()) @ f0
    assert np.abs(ft - ref).max() <= 1e-10 * np.abs(ref).max()


def test_growth_warning_silent_on_regular_sphere():
    mesh, v, f0 = _lion_setup("sphere_s2.off")
    ft = fvf.flow(mesh, v, f0, 0.1)  # FvfWarning is an error in this suite: none may fire
    assert np.abs(ft).max() <= 1.01 * np.abs(f0).max()


def test_growth_bound_holds(sphere, rng):
    """‖Φ_t f‖ ≤ e^{μ t} ‖f‖ for random fields and functions (μ from Lanczos)."""
    v = random_tangent_field(sphere, rng)
    phi = fvf.FunctionalFlow(sphere, v, growth_limit=np.inf)
    for t in (0.05, -0.05):
        f = rng.standard_normal(sphere.n_vertices)
        assert phi.norm(phi(f, t)) <= phi.growth_bound(t) * phi.norm(f) * (1 + 1e-6)


def test_lemma13_commuting_flows(sphere, rng):
    """Φ_v Φ_w = Φ_w Φ_v when D^V_{[v,w]} = 0 (w ∥ v); they differ when the bracket is not 0."""
    v = _rotation_z(sphere)
    f, _, _ = smooth_functions(sphere)
    w = 2.5 * v
    assert abs(ch.bracket_V(sphere, v, w)).max() < 1e-12 * abs(ch.D_V(sphere, v)).max() ** 2
    a = fvf.flow(sphere, v, fvf.flow(sphere, w, f, 0.3), 0.2)
    b = fvf.flow(sphere, w, fvf.flow(sphere, v, f, 0.2), 0.3)
    assert rel(a, b) < 1e-12
    u = sphere.project_tangent(np.cross([1.0, 0.0, 0.0], sphere.face_centroids))
    a = fvf.flow(sphere, v, fvf.flow(sphere, u, f, 0.3), 0.2)
    b = fvf.flow(sphere, u, fvf.flow(sphere, v, f, 0.2), 0.3)
    assert rel(a, b) > 1e-3


def test_flow_rejects_bad_times(sphere):
    v = _rotation_z(sphere)
    f = sphere.vertices[:, 0]
    with pytest.raises(ValueError, match="finite"):
        fvf.flow(sphere, v, f, np.nan)
    with pytest.raises(ValueError, match="1-D"):
        fvf.flow(sphere, v, f, np.zeros((2, 2)))
    with pytest.raises(fvf.FieldShapeError, match="vertices"):
        fvf.flow(sphere, v, f[:-1], 0.1)


@pytest.mark.parametrize("field", ["rotation", "gradient"])
def test_krylov_action_matches_expm_multiply(field):
    """The default exponential action (Krylov, expmv.py) agrees with scipy's expm_multiply
    at the requested accuracy, for the unitary (J grad g) and a compressible case."""
    mesh = fvf.icosphere(3)
    X = mesh.vertices
    v = fvf.gradient(mesh, X[:, 2])
    if field == "rotation":
        v = fvf.rotate(mesh, v)  # J grad z: [A_V] D^V_v skew (Lemma 13)
    f = np.stack([np.sin(3 * X[:, 0]), X[:, 1] * X[:, 2]], axis=1)
    times = np.array([0.5, -0.25, 1.0])
    fast = fvf.FunctionalFlow(mesh, v)
    ref = fvf.FunctionalFlow(mesh, v, method="expm_multiply")
    assert fast.is_skew == (field == "rotation")
    out = fast(f, times)
    assert rel(out, ref(f, times)) < 1e-9
    # "auto" follows choose_method: the series for a skew operator from R·max|t| >=
    # SERIES_MIN_TAU, else Lanczos; not skew: Krylov with incomplete orthogonalization
    chosen = fvf.numerics.expm.choose_method(mesh.n_vertices, times, True, fast.skew_norm)
    assert fast.stats["method"] == ({"krylov": "lanczos"}.get(chosen, chosen) if
                                    field == "rotation" else "iom")  # fmt: skip
    assert fast.stats["wasted_matvecs"] == 0
    assert ref.stats["method"] == "expm_multiply"
    assert 0 < fast.stats["matvecs"] < ref.stats["matvecs"]


def test_flow_rejects_unknown_action():
    mesh = fvf.icosphere(1)
    with pytest.raises(fvf.numerics.expm.ExpmInputError, match="method must be one of"):
        fvf.FunctionalFlow(mesh, _rotation_z(mesh), method="pade")
    with pytest.raises(fvf.numerics.expm.ExpmInputError, match="tol"):
        fvf.FunctionalFlow(mesh, _rotation_z(mesh), tol=0.0)


def test_zero_field_flow_is_the_identity():
    mesh = fvf.icosphere(2)  # n > 64: the Lanczos growth estimate path
    f = mesh.vertices[:, 0]
    phi = fvf.FunctionalFlow(mesh, np.zeros((mesh.n_faces, 3)))
    assert phi.growth_rate == (0.0, 0.0)
    np.testing.assert_array_equal(phi(f, 1.0), f)


@pytest.mark.parametrize("method", ["chapter", "skew", "cayley"])
def test_out_of_reach_times_raise_flow_overflow(method):
    """A 1e150 field for a unit time: 1e150 edge lengths of flow is out of floating-point
    reach; the documented error (an FvfError and a FloatingPointError), not a crash."""
    mesh = fvf.icosphere(2)
    v = 1e150 * fvf.rotate(mesh, fvf.gradient(mesh, mesh.vertices[:, 2]))
    with pytest.raises(fvf.FlowOverflowError, match="t|steps"):
        fvf.flow(mesh, v, mesh.vertices[:, 0], 1.0, method=method, growth_limit=np.inf)
    assert issubclass(fvf.FlowOverflowError, FloatingPointError)
