"""Shape correspondence: descriptors, the functional-map fit with the D_{J grad f}
orientation term, ZoomOut, fvf.match, fvf.symmetry_map and map evaluation.

Known answers on generated shapes (identity, permutation, rigid and bent copies, a mirror
image, an exactly symmetric shape), dense references for every reduced operator, the
typed errors of bad input, and, marked slow, the camel-gallop frames of
``../shared/meshes/correspondence`` against their ground-truth maps.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.spatial import cKDTree

import fvf
from conftest import SHARED_MESHES, rel, shared_mesh_path
from corpus import REFLECT, blob, mirror_image, mirror_index
from fvf.design.symmetric import consistency_residual, map_consistent_field
from fvf.mesh.prepared import prepare_mesh
from fvf.spectral import (
    FunctionalMapEnergy,
    descriptor_operators,
    farthest_point_samples,
    geodesic_distances,
    hks_times,
    matching_descriptors,
    nearest_rows,
    orientation_agreement,
    orientation_operators,
    wks_energies,
)
from fvf.spectral.evaluation import cumulative_error_curve


def bent(mesh: fvf.TriMesh, radius: float = 10.0) -> fvf.TriMesh:
    """The shape rolled around a cylinder of the given radius along x (y the radial
    direction), then moved rigidly: near-isometric (faces stretch 2.6 % on average at
    radius 10), exactly isometric for an infinite radius."""
    X = mesh.vertices
    r = radius + X[:, 1]
    Y = np.stack([r * np.sin(X[:, 0] / radius), r * np.cos(X[:, 0] / radius) - radius, X[:, 2]], 1)
    q, _ = np.linalg.qr(np.random.default_rng(3).standard_normal((3, 3)))
    q *= np.sign(np.linalg.det(q))
    return fvf.TriMesh(Y @ q.T + [1.0, -2.0, 0.5], mesh.faces)


@pytest.fixture(scope="module")
def shape():
    return blob()


@pytest.fixture(scope="module")
def sym_shape():
    return blob(symmetric=True)


@pytest.fixture(scope="module")
def basis(shape):
    return fvf.SpectralBasis(shape, 30)


def _geo_error(mesh_1, p2p, truth):
    return fvf.mean_geodesic_error(mesh_1, p2p, truth)


# ---------------------------------------------------------------------------- descriptors
def test_descriptors_are_dense_kernel_diagonals_and_columns(basis):
    """HKS/WKS equal the diagonal and landmark columns of Φ diag(g) Φᵀ (dense reference)."""
    lam, phi = basis.eigenvalues[1:], basis.eigenvectors[:, 1:]  # λ_0 = 0 is left out
    t = hks_times(lam, 5)
    for s, ts in enumerate(t):
        g = np.exp(-lam * ts) / np.exp(-lam * ts).sum()
        K = phi @ np.diag(g) @ phi.T
        h = fvf.heat_kernel_signature(basis, t)
        assert rel(h[:, s], np.diag(K)) < 1e-12
        lm = fvf.heat_kernel_signature(basis, t, landmarks=[7, 100])
        assert lm.shape == (basis.mesh.n_vertices, 10)
        assert rel(lm[:, s], K[:, 7]) < 1e-12 and rel(lm[:, 5 + s], K[:, 100]) < 1e-12
    e, sigma = wks_energies(lam, 8)
    w = np.exp(-((e[3] - np.log(lam)) ** 2) / (2 * sigma**2))
    K = phi @ np.diag(w / w.sum()) @ phi.T
    assert rel(fvf.wave_kernel_signature(basis, e, sigma)[:, 3], np.diag(K)) < 1e-12
    lm = fvf.wave_kernel_signature(basis, e, sigma, landmarks=[5])
    assert rel(lm[:, 3], K[:, 5]) < 1e-12


def test_descriptors_are_intrinsic(shape, basis):
    """Same on a rigidly moved, vertex-permuted copy (eigenvectors up to sign: the
    signatures only use squares and products at the same point); up to the eigensolver's
    tolerance (residual 1e-8; measured 4e-5 relative)."""
    perm = np.random.default_rng(1).permutation(shape.n_vertices)
    moved = bent(fvf.TriMesh(shape.vertices[perm], np.argsort(perm)[shape.faces]), 1e12)
    b2 = fvf.SpectralBasis(moved, 30)
    e, sigma = wks_energies(basis.eigenvalues, 20)
    assert (
        rel(
            fvf.wave_kernel_signature(b2, e, sigma),
            fvf.wave_kernel_signature(basis, e, sigma)[perm],
        )
        < 1e-3
    )
    t = hks_times(basis.eigenvalues, 10)
    assert rel(fvf.heat_kernel_signature(b2, t), fvf.heat_kernel_signature(basis, t)[perm]) < 1e-3


# ---------------------------------------------------------------------------- operators and energy
def test_reduced_operators_match_fvf_operators(basis, rng):
    """P_j = Φᵀ[A_V] D^V_{J grad f_j} Φ (skew on a closed mesh), X_j = Φᵀ[A_V][f_j]Φ."""
    mesh = basis.mesh
    F = rng.standard_normal((mesh.n_vertices, 3))
    P = orientation_operators(basis, F)
    X = descriptor_operators(basis, F)
    for j in range(3):
        v = fvf.rotate(mesh, fvf.gradient(mesh, F[:, j]))
        assert rel(P[j], basis.reduce(fvf.D_V(mesh, v))) < 1e-12
        assert np.abs(P[j] + P[j].T).max() < 1e-10 * np.abs(P[j]).max()
        assert rel(X[j], basis.reduce(sp.diags_array(F[:, j]))) < 1e-12


def test_energy_gradient_hessian_and_solvers(shape, basis):
    mesh = shape
    d = fvf.wave_kernel_signature(basis, *wks_energies(basis.eigenvalues, 6))
    b = basis.truncate(8)
    E = FunctionalMapEnergy.from_descriptors(b, b, d, d[:, ::-1], w_orth=0.0)
    rng = np.random.default_rng(0)
    C = rng.standard_normal((8, 8))
    dC = rng.standard_normal((8, 8))
    eps = 1e-6
    fd = (E.value(C + eps * dC) - E.value(C - eps * dC)) / (2 * eps)
    assert abs(fd - (E.gradient(C) * dC).sum()) < 1e-6 * abs(fd)
    H, bvec = E.hessian()
    c = C.ravel()
    assert rel(H @ c - bvec, E.gradient(C).ravel()) < 1e-10  # the normal equations
    C_direct = E.minimize("direct")
    assert np.abs(E.gradient(C_direct)[:, 1:]).max() < 1e-9 * np.abs(H).max()
    C_lbfgs = E.minimize("lbfgs")
    assert rel(C_lbfgs, C_direct) < 1e-5
    assert mesh.n_vertices == basis.mesh.n_vertices


def test_orthogonality_term_direct_and_lbfgs_agree(basis):
    """With w_orth > 0, "direct" runs L-BFGS on ½xᵀHx − bᵀx plus the orthogonality term
    from the normal equations; "lbfgs" on the operator terms themselves. Both must stop
    where E's own gradient (``E.gradient``, the operator form) vanishes, at one C."""
    d = fvf.wave_kernel_signature(basis, *wks_energies(basis.eigenvalues, 6))
    b = basis.truncate(10)
    E = FunctionalMapEnergy.from_descriptors(b, b, d, d[:, ::-1], w_orth=1.0)
    C_direct, C_lbfgs = E.minimize("direct"), E.minimize("lbfgs")
    g0 = np.abs(E.gradient(np.eye(10))[:, 1:]).max()
    for C in (C_direct, C_lbfgs):  # measured 1.2e-7 and 3.2e-8 g0
        assert np.abs(E.gradient(C)[:, 1:]).max() < 1e-6 * g0
    assert rel(C_direct, C_lbfgs) < 1e-5
    assert E.value(C_direct) <= E.value(C_lbfgs) * (1 + 1e-9)
    quadratic = FunctionalMapEnergy.from_descriptors(b, b, d, d[:, ::-1], w_orth=0.0)
    assert rel(C_direct, quadratic.minimize("direct")) > 1e-3  # the term is not idle


def test_mirror_image_needs_the_orientation_term(sym_shape):
    """mesh_2 = the mirror image of an exactly symmetric shape. Its vertex j sits where
    vertex sym(j) of mesh 1 is, so p2p = sym is the orientation-preserving map and
    p2p = identity the orientation-reversing one: the same descriptors, commutativity and
    Laplacian energies, told apart only by the D_{J grad f} term."""
    S, M = sym_shape, mirror_image(sym_shape)
    sym, ident = mirror_index(S), np.arange(S.n_vertices)
    b1, b2 = fvf.SpectralBasis(S, 20), fvf.SpectralBasis(M, 20)
    d1, d2 = matching_descriptors(b1, b2, n_descriptors=20)
    C_sym = fvf.functional_map_from_p2p(sym, b1, b2)
    C_id = fvf.functional_map_from_p2p(ident, b1, b2)
    kw = dict(w_orth=0.0)
    blind = FunctionalMapEnergy.from_descriptors(b1, b2, d1, d2, orientation=None, **kw)
    aware = FunctionalMapEnergy.from_descriptors(b1, b2, d1, d2, **kw)
    q, _ = np.linalg.qr(np.random.default_rng(0).standard_normal((20, 20)))
    scale = blind.value(q)  # a generic orthogonal map
    # both are exact maps between isometric meshes: every blind term vanishes for both
    assert blind.value(C_sym) < 1e-12 * scale and blind.value(C_id) < 1e-12 * scale
    assert aware.value(C_sym) < 1e-12 * scale
    assert aware.value(C_id) > 0.1 * scale  # measured 0.5
    # the whole pipeline, both ways
    p = fvf.match(S, M, k=40, k_fit=15)
    assert np.mean(p == sym) > 0.99 and orientation_agreement(S, M, p) > 0.99
    p = fvf.match(S, M, k=40, k_fit=15, orientation="reversing")
    assert np.mean(p == ident) > 0.99 and orientation_agreement(S, M, p) < -0.99


# ---------------------------------------------------------------------------- fvf.match
def test_match_identity_and_permutation(shape):
    assert np.array_equal(fvf.match(shape, shape, k=40, k_fit=15), np.arange(shape.n_vertices))
    perm = np.random.default_rng(0).permutation(shape.n_vertices)
    p = fvf.match(shape, (shape.vertices[perm], np.argsort(perm)[shape.faces]), k=40, k_fit=15)
    assert p.dtype == np.int64 and np.array_equal(p, perm)


def test_match_near_isometric_bend(shape):
    """A bent, moved copy: the identity is the truth; measured mean error 0.009."""
    p = fvf.match(shape, bent(shape), k=40, k_fit=15)
    assert _geo_error(shape, p, np.arange(shape.n_vertices)) < 0.02
    assert orientation_agreement(shape, shape, p) > 0.95


def test_match_with_landmarks_breaks_the_symmetry(sym_shape):
    """Without the orientation term the mirror pair is ambiguous; three landmarks of the
    reversing map (the identity) decide it."""
    S, M = sym_shape, mirror_image(sym_shape)
    lm = np.array([[10, 10], [200, 200], [400, 400]])
    p = fvf.match(S, M, k=40, k_fit=15, orientation=None, landmarks=lm)
    assert np.mean(p == np.arange(S.n_vertices)) > 0.99


def test_match_result_and_conversions(shape):
    res = fvf.match_result(shape, shape, k=30, k_fit=10)
    assert isinstance(res, fvf.MatchResult)
    assert res.C_12.shape == (30, 30) and res.C_fit.shape == (10, 10)
    assert rel(res.C_12, np.diag(np.diag(res.C_12))) < 1e-8  # identity up to signs
    b = res.basis_1
    assert np.array_equal(
        fvf.p2p_from_functional_map(np.eye(30), b, b), np.arange(b.mesh.n_vertices)
    )
    assert np.array_equal(
        fvf.p2p_from_functional_map(np.eye(30), b, b, adjoint=True), np.arange(b.mesh.n_vertices)
    )
    assert (
        rel(fvf.functional_map_from_p2p(np.arange(b.mesh.n_vertices), b, b, 12), np.eye(12)) < 1e-10
    )
    C, p = fvf.zoomout(np.eye(10), b, b, 30, step=4)
    assert np.array_equal(p, np.arange(b.mesh.n_vertices)) and rel(C, np.eye(30)) < 1e-10
    C, p = fvf.zoomout(np.eye(10), b, b, 30, step=4, samples=200)
    assert np.array_equal(p, np.arange(b.mesh.n_vertices))


def test_a_match_result_is_its_vertex_map(shape):
    """MatchResult stands for its p2p_21 wherever an array is expected (the one
    convention of match, match_result and symmetry_map); match returns that array."""
    res = fvf.match_result(shape, shape, k=30, k_fit=10)
    p = res.p2p_21
    assert np.array_equal(fvf.match(shape, shape, k=30, k_fit=10), p)
    assert np.asarray(res) is p and np.asarray(res, dtype=np.float64).dtype == np.float64
    assert res.shape == p.shape and res.dtype == np.int64 and len(res) == p.size
    assert res[3] == p[3] and np.array_equal(res[:5], p[:5]) and list(res) == list(p)
    assert np.array_equal(shape.vertices[np.asarray(res)], shape.vertices[p])
    assert (res == p).all()  # numpy compares element-wise through __array__
    with pytest.raises(ValueError):  # numpy's copy=False semantics
        np.asarray(res, dtype=np.int32, copy=False)


def test_match_full_output_is_deprecated_for_match_result(shape):
    res = fvf.match_result(shape, shape, k=30, k_fit=10)
    with pytest.warns(DeprecationWarning, match="fvf.match_result"):
        old = fvf.match(shape, shape, k=30, k_fit=10, full_output=True)
    assert isinstance(old, fvf.MatchResult)
    assert np.array_equal(old.p2p_21, res.p2p_21) and np.array_equal(old.C_12, res.C_12)
    with pytest.warns(DeprecationWarning, match="fvf.match_result"):
        p = fvf.match(shape, shape, k=30, k_fit=10, full_output=False)
    assert isinstance(p, np.ndarray) and np.array_equal(p, res.p2p_21)


def test_nearest_rows_methods_agree(rng):
    points, queries = rng.standard_normal((500, 20)), rng.standard_normal((300, 20))
    assert np.array_equal(
        nearest_rows(points, queries, method="kdtree"),
        nearest_rows(points, queries, method="brute"),
    )
    s = farthest_point_samples(points, 50)
    assert np.unique(s).size == 50


def test_match_on_a_nonmanifold_mesh_indexes_the_input(shape):
    """A small flap glued onto an edge of the surface (three faces on one edge), as in
    the camel frames: fvf.TriMesh rejects it; match repairs, drops the flap and returns a
    map of the input's vertices."""
    V, F = shape.vertices, shape.faces
    a, b = shape.edges[0]
    tip = V[[a, b]].mean(0) + 0.05 * shape.mean_edge_length
    V2 = np.vstack([V, tip])
    F2 = np.vstack([F, [[a, b, len(V)]]])
    with pytest.raises(fvf.NonManifoldError):
        fvf.TriMesh(V2, F2)
    prepared = prepare_mesh(V2, F2)
    assert prepared.mesh.n_vertices == shape.n_vertices and prepared.changed
    p = fvf.match((V2, F2), (V2, F2), k=30, k_fit=10)
    assert p.shape == (len(V2),) and p.dtype == np.int64
    assert np.array_equal(p[: len(V)], np.arange(len(V)))
    assert p[len(V)] in (a, b)  # the flap's tip stands for its nearest kept vertex


# ---------------------------------------------------------------------------- symmetry
def test_symmetry_map_is_an_orientation_reversing_involution(sym_shape):
    res = fvf.symmetry_map(sym_shape, k=40, k_fit=15)
    p, ident = res.p2p, np.arange(sym_shape.n_vertices)
    assert np.mean(p == mirror_index(sym_shape)) > 0.99
    assert np.mean(p[p] == ident) > 0.99  # an involution
    assert orientation_agreement(sym_shape, sym_shape, p) < -0.99
    assert res.C.shape == (40, 40)
    assert rel(res.C @ res.C, np.eye(40)) < 0.05  # C² ≈ I in the basis


def test_symmetry_map_feeds_map_consistent_field(sym_shape):
    """A symmetric field designed from symmetry_map's functional map is its own mirror
    image (D_v C = C D_v), unlike the smoothest fields in general."""
    res = fvf.symmetry_map(sym_shape, k=40, k_fit=15)
    b = res.basis.truncate(30)
    C = res.C[:30, :30]
    v, residual = map_consistent_field(b, C, weight=10.0)
    assert residual < 1e-3
    centroids = sym_shape.face_centroids
    _, mirror_face = cKDTree(centroids).query(centroids * REFLECT)
    a = sym_shape.face_areas

    def asym(u):
        d = u[mirror_face] - u * REFLECT
        return float(np.sqrt(a @ (d * d).sum(1) / (a @ (u * u).sum(1))))

    assert asym(v) < 0.05  # measured 0.004
    _, smooth = fvf.smoothest_fields(sym_shape, 4)
    assert max(asym(s) for s in smooth) > 0.3
    assert consistency_residual(b, C, smooth[0]) > 10 * residual


# ---------------------------------------------------------------------------- evaluation
def test_geodesic_distances_on_the_sphere():
    """Great-circle distances on the unit icosphere(4): "unfolded" 2 % above on average,
    "edges" 12 %; "heat" within 5 % at mid range."""
    mesh = fvf.icosphere(4)
    src = np.array([0, 100, 1000])
    exact = np.arccos(np.clip(mesh.vertices[src] @ mesh.vertices.T, -1, 1))
    far = exact > 0.3
    for method, tol in (("unfolded", 0.02), ("edges", 0.12)):
        d = geodesic_distances(mesh, src, method=method)
        ratio = d[far] / exact[far]
        # the inscribed polyhedron's geodesics are a little shorter than great circles
        assert ratio.min() > 0.995 and ratio.mean() < 1 + tol, (method, ratio.mean())
    tet = fvf.TriMesh(
        [[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]],
        [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]],
    )  # every unfolded diagonal is also an edge: the shorter one must win
    assert rel(geodesic_distances(tet, [0])[0, 1:], np.full(3, np.sqrt(8))) < 1e-12
    heat = geodesic_distances(mesh, src, method="heat")
    mid = (exact > 0.3) & (exact < 2.5)
    assert np.abs(heat[mid] / exact[mid] - 1).mean() < 0.05
    err = fvf.geodesic_errors(mesh, np.arange(mesh.n_vertices), np.arange(mesh.n_vertices))
    assert not err.any()
    t, frac = cumulative_error_curve([0.0, 0.1, 0.2])
    assert frac[0] == pytest.approx(1 / 3) and frac[-1] == 1 and np.all(np.diff(frac) >= 0)


def test_orientation_agreement_signs():
    """+1 for the identity, −1 onto the same surface with its faces reversed, 0 when every
    image triangle is degenerate."""
    mesh = fvf.icosphere(2)
    ident = np.arange(mesh.n_vertices)
    flipped = fvf.TriMesh(mesh.vertices, mesh.faces[:, ::-1])
    assert orientation_agreement(mesh, mesh, ident) == pytest.approx(1.0, abs=1e-12)
    assert orientation_agreement(mesh, flipped, ident) == pytest.approx(-1.0, abs=1e-12)
    assert orientation_agreement(mesh, mesh, np.zeros(mesh.n_vertices, dtype=int)) == 0.0


# ---------------------------------------------------------------------------- bad input
def test_bad_input_raises_typed_errors(shape, basis):
    d = fvf.wave_kernel_signature(basis, n_energies=4)
    with pytest.raises(fvf.BasisSizeError):  # a bigger map than the bases hold
        fvf.fit_functional_map(basis, basis, d, d, k=40)
    with pytest.raises(fvf.BasisSizeError):
        fvf.p2p_from_functional_map(np.eye(31), basis, basis)
    with pytest.raises(fvf.BasisSizeError):
        fvf.zoomout(np.eye(10), basis, basis, 31)
    with pytest.raises(fvf.BasisSizeError):  # descriptors that do not correspond
        fvf.fit_functional_map(basis, basis, d, d[:, :3], k=10)
    with pytest.raises(fvf.BasisSizeError):
        matching_descriptors(basis, basis.truncate(20))
    two = (
        np.vstack([shape.vertices, shape.vertices + 10.0]),
        np.vstack([shape.faces, shape.faces + shape.n_vertices]),
    )
    with pytest.raises(fvf.DisconnectedMeshError):
        fvf.match(two, shape, k=30, k_fit=10)
    with pytest.raises(fvf.LandmarkError, match="outside"):
        fvf.match(shape, shape, k=30, k_fit=10, landmarks=[[0, 0], [1, shape.n_vertices]])
    with pytest.raises(fvf.LandmarkError, match="shape"):
        fvf.match(shape, shape, k=30, k_fit=10, landmarks=[0, 1, 2])
    with pytest.raises(fvf.LandmarkError, match="repeat"):
        fvf.heat_kernel_signature(basis, landmarks=[3, 3])
    with pytest.raises(fvf.NotEnoughEigenpairsError):
        fvf.match(fvf.icosphere(0), fvf.icosphere(0), k=20, k_fit=10)
    with pytest.raises(fvf.ParameterError):
        fvf.match(shape, shape, k=30, k_fit=40)
    with pytest.raises(fvf.ParameterError):
        fvf.match(shape, shape, k=30, weights={"w_bogus": 1.0})
    with pytest.raises(fvf.ParameterError):
        fvf.fit_functional_map(basis, basis, d, d, k=10, w_orient=-1.0)
    for cls in (
        fvf.BasisSizeError,
        fvf.DisconnectedMeshError,
        fvf.LandmarkError,
        fvf.NotEnoughEigenpairsError,
    ):
        assert issubclass(cls, fvf.CorrespondenceError) and issubclass(cls, fvf.FvfError)


# ---------------------------------------------------------------------------- camels (slow)
CAMEL_PAIRS = [(1, 3), (2, 3), (2, 4), (3, 1), (3, 2), (4, 2)]
#: Mean geodesic error (/ √area) asserted on every camel pair; measured 0.009–0.013
#: (docs/correspondence.md), pyFM's README pipeline 0.012–0.18 on the same evaluation.
CAMEL_BOUND = 0.02


def camel_pair(a: int, b: int):
    """Paths of frames b (mesh 1) and a (mesh 2), the truth p2p_21 and its valid mask.

    camel_a_to_b.txt gives, for each vertex of frame a, its vertex of frame b; the entry
    0 marks vertices without ground truth (hundreds per file, far more than vertex 0's
    true preimages), so they are left out of the evaluation.
    """
    root = shared_mesh_path("correspondence")
    truth = np.loadtxt(root / f"camel_{a}_to_{b}.txt", dtype=np.int64)
    return root / f"camel-gallop-0{b}.off", root / f"camel-gallop-0{a}.off", truth, truth != 0


@pytest.mark.slow
@pytest.mark.parametrize("pair", CAMEL_PAIRS, ids=[f"{a}to{b}" for a, b in CAMEL_PAIRS])
def test_camel_pairs_mean_geodesic_error(pair):
    path_1, path_2, truth, valid = camel_pair(*pair)
    res = fvf.match_result(path_1, path_2)
    prep = res.prepared_1
    err = fvf.mean_geodesic_error(
        prep.mesh, prep.input_to_mesh[res.p2p_21], prep.input_to_mesh[truth], valid=valid
    )
    assert err < CAMEL_BOUND, err


@pytest.mark.slow
def test_camel_orientation_term_decides_the_hind_legs():
    """Frames 1 -> 3 without the orientation term swap the hind legs (left for right):
    the mean error is ten times the bound; with it, below the bound."""
    path_1, path_2, truth, valid = camel_pair(1, 3)
    res = fvf.match_result(path_1, path_2, orientation=None)
    prep = res.prepared_1
    err = fvf.mean_geodesic_error(
        prep.mesh, prep.input_to_mesh[res.p2p_21], prep.input_to_mesh[truth], valid=valid
    )
    assert err > 5 * CAMEL_BOUND, err


@pytest.mark.slow
def test_unfolded_geodesics_against_exact_mmp():
    """Against exact polyhedral geodesics (pygeodesic's MMP, test-only) on camel frame 3:
    "unfolded" never below, on average at most 5 % above within six edges of the source
    and 3 % beyond (measured +3.3/+4.3/+3.5 % and +2.3/+1.6 %)."""
    pg = pytest.importorskip("pygeodesic.geodesic")
    V, F = fvf.read_mesh(SHARED_MESHES / "correspondence" / "camel-gallop-03.off")
    mesh = fvf.TriMesh(V / np.sqrt(fvf.TriMesh(V, F).total_area), F)
    src = np.random.default_rng(0).choice(mesh.n_vertices, 8, replace=False)
    alg = pg.PyGeodesicAlgorithmExact(mesh.vertices, mesh.faces)
    exact = np.stack([alg.geodesicDistances(np.array([s]))[0] for s in src])
    d = geodesic_distances(mesh, src)
    h = mesh.mean_edge_length
    near, far = (exact > 0.5 * h) & (exact <= 6 * h), exact > 6 * h
    assert (d >= exact * (1 - 1e-9)).all()
    assert np.mean(d[near] / exact[near]) < 1.05 and np.mean(d[far] / exact[far]) < 1.03


# ---------------------------------------------------------------------------- doctests
@pytest.mark.parametrize(
    "module",
    ["fvf.spectral.correspondence", "fvf.spectral.descriptors", "fvf.spectral.zoomout"],
)
def test_docstring_examples(module):
    import doctest
    import importlib

    result = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0


# ---------------------------------------------------------------------------- command
def test_cli_match_and_symmetry(tmp_path, sym_shape, capsys):
    """`fvf match` and `fvf symmetry` on files: the mirror pair and the symmetric shape."""
    from fvf.cli.main import main

    S, M = sym_shape, mirror_image(sym_shape)
    a, b = tmp_path / "a.off", tmp_path / "b.off"
    fvf.write_mesh(a, S.vertices, S.faces)
    fvf.write_mesh(b, M.vertices, M.faces)
    sym = mirror_index(S)
    small = ["--k", "40", "--k-fit", "15"]
    assert main(["match", str(a), str(b), "-o", str(tmp_path / "map.npz"), *small]) == 0
    with np.load(tmp_path / "map.npz") as data:
        assert np.mean(data["p2p_21"] == sym) > 0.99 and data["C_12"].shape == (40, 40)
    # the choice and how sure it is: an exactly symmetric shape against its mirror image,
    # an exact tie that only the orientation factor breaks, 1 - 1/ρ = 0.75
    out = capsys.readouterr().out
    assert "chosen: fit of 3 distinct candidate maps, confidence 0.75" in out
    truth = tmp_path / "truth.txt"
    np.savetxt(truth, sym, fmt="%d")
    args = ["match", str(a), str(b), "-o", str(tmp_path / "m2.npz"), "--truth", str(truth)]
    assert main([*args, *small]) == 0
    with np.load(tmp_path / "m2.npz") as data:
        assert data["errors"].max() < 1e-12
    assert main(["symmetry", str(a), "-o", str(tmp_path / "sym.npz"), *small]) == 0
    with np.load(tmp_path / "sym.npz") as data:
        assert np.mean(data["p2p"] == sym) > 0.99
        basis = fvf.SpectralBasis.from_eigenpairs(
            fvf.TriMesh(data["vertices"], data["faces"]), data["eigenvalues"], data["eigenvectors"]
        )
        _, residual = map_consistent_field(basis.truncate(30), data["C"][:30, :30])
        assert residual < 1e-3
    bad = tmp_path / "l.txt"
    bad.write_text("0 1 2\n")
    assert (
        main(["match", str(a), str(b), "-o", str(tmp_path / "x.npz"), "--landmarks", str(bad)]) == 2
    )
    bad.write_text(f"0 0\n1 {S.n_vertices}\n")
    assert (
        main(["match", str(a), str(b), "-o", str(tmp_path / "x.npz"), "--landmarks", str(bad)]) == 2
    )
    assert not (tmp_path / "x.npz").exists()
    before = a.read_bytes()  # outputs onto inputs are refused before any work
    assert main(["match", str(a), str(b), "-o", str(tmp_path / "x"), "--png", str(a)]) == 2
    np.savetxt(tmp_path / "t.npz", sym, fmt="%d")
    argv = ["match", str(a), str(b), "--truth", str(tmp_path / "t.npz"), "-o", str(tmp_path / "t")]
    assert main(argv) == 2
    assert main(["symmetry", str(a), "-o", str(tmp_path / "y"), "--png", str(a)]) == 2
    assert a.read_bytes() == before and not (tmp_path / "x.npz").exists()


def test_cli_match_pictures(tmp_path, shape):
    pytest.importorskip("matplotlib")
    pytest.importorskip("PIL")
    from fvf.cli.main import main

    a = tmp_path / "a.off"
    fvf.write_mesh(a, shape.vertices, shape.faces)
    truth = tmp_path / "t.txt"
    np.savetxt(truth, np.arange(shape.n_vertices), fmt="%d")
    args = ["match", str(a), str(a), "-o", str(tmp_path / "m.npz"), "--k", "30", "--k-fit", "10"]
    assert main([*args, "--truth", str(truth), "--png", str(tmp_path / "m.png")]) == 0
    assert (tmp_path / "m.png").stat().st_size > 1000  # --png NAME writes NAME
    assert (tmp_path / "m_errors.png").stat().st_size > 1000
    from fvf import viz

    viz.plot_error_curves({"fvf": np.zeros(5)}, tmp_path / "c.png")
    assert (tmp_path / "c.png").stat().st_size > 1000


@pytest.mark.slow
def test_camel_symmetry_map():
    """Frame 3's left-right self-map: the body is reflected (x -> -x within 2 % of the
    body's width; measured 0.004 of 0.22), no leg stays on itself (each goes to its
    partner), and applying the map twice comes back within 0.02 on average (measured 0.01)."""
    path = shared_mesh_path("correspondence") / "camel-gallop-03.off"
    res = fvf.symmetry_map(path)
    mesh, p = res.prepared_1.mesh, res.p2p_21_prepared
    X = mesh.vertices
    legs = X[:, 1] < 0.25
    assert np.abs(X[~legs, 0] + X[p[~legs], 0]).mean() < 0.01
    moved = fvf.geodesic_errors(mesh, p, np.arange(p.size))
    assert np.mean(moved[legs] < 0.05) < 0.05
    assert fvf.geodesic_errors(mesh, p[p], np.arange(p.size)).mean() < 0.02


@pytest.mark.parametrize("command", ["match", "symmetry"])
def test_cli_help_shows_an_example(command, capsys):
    from fvf.cli.main import main

    assert main([command, "--help"]) == 0
    out = capsys.readouterr().out
    assert "example:" in out and f"fvf {command}" in out and "exit status" in out


def test_geodesic_errors_equal_the_distance_rows():
    """Hits cost nothing and are 0; misses are the distance from the true image."""
    mesh = fvf.icosphere(2)
    rng = np.random.default_rng(4)
    gt = rng.permutation(mesh.n_vertices)
    p = gt.copy()
    miss = rng.choice(mesh.n_vertices, 40, replace=False)
    p[miss] = rng.integers(0, mesh.n_vertices, 40)
    D = fvf.spectral.evaluation.geodesic_distances(mesh, gt)
    expect = D[np.arange(gt.size), p] / np.sqrt(mesh.total_area)
    np.testing.assert_allclose(fvf.geodesic_errors(mesh, p, gt), expect, rtol=1e-12, atol=0)
