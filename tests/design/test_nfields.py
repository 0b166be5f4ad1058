"""N-direction fields: power representation, smoothest N-fields, N-indices, cut graph, combing."""

from __future__ import annotations

import numpy as np
import pytest

import fvf
from conftest import load_shared
from fvf.design import nfields as nf

N_VALUES = (1, 2, 4, 6)


def rounded_cube(subdivisions: int = 4, p: float = 8.0) -> fvf.TriMesh:
    """An icosphere pushed onto the superellipsoid |x|^p + |y|^p + |z|^p = 1 (a rounded cube).

    The sphere is turned first so that no symmetry axis of the cube passes through a face
    centre (there a symmetric mesh forces the cross field to vanish on a whole face).
    """
    s = fvf.icosphere(subdivisions)
    a, b, c = 0.3, -0.2, 0.5  # a fixed generic rotation (about x, then y, then z)
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    Rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    V = s.vertices @ (Rz @ Ry @ Rx).T
    X = V / np.sum(np.abs(V) ** p, axis=1, keepdims=True) ** (1 / p)
    return fvf.TriMesh(X, s.faces)


def random_field(mesh, seed=0):
    rng = np.random.default_rng(seed)
    return mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3)))


# ---------------------------------------------------------------------------- representation
@pytest.mark.parametrize("n", N_VALUES)
def test_power_round_trip_and_rotation_invariance(n):
    mesh = fvf.icosphere(1)
    u = random_field(mesh)
    w = fvf.to_power(mesh, u, n)
    assert w.dtype == np.complex128 and w.shape == (mesh.n_faces,)
    np.testing.assert_allclose(np.abs(w), np.linalg.norm(u, axis=1), rtol=1e-12)
    # every representative of the set has the same power
    for k, r in enumerate(nf.all_directions(mesh, u, n)):
        np.testing.assert_allclose(fvf.to_power(mesh, r, n), w, atol=1e-12, err_msg=str(k))
    back = fvf.from_power(mesh, w, n)
    np.testing.assert_allclose(fvf.to_power(mesh, back, n), w, atol=1e-12)
    # the principal root is one of the N directions of u
    d = nf.all_directions(mesh, u, n)
    err = np.min(np.linalg.norm(d - back[None], axis=2), axis=0)
    assert err.max() < 1e-12 * np.abs(u).max() * 10


def test_power_n1_is_to_complex():
    mesh = fvf.icosphere(1)
    u = random_field(mesh)
    np.testing.assert_array_equal(fvf.to_power(mesh, u, 1), mesh.to_complex(u))


def test_all_directions_are_rotations():
    mesh = fvf.icosphere(1)
    u = random_field(mesh)
    d = nf.all_directions(mesh, u, 4)
    np.testing.assert_allclose(d[1], np.cross(mesh.face_normals, u), atol=1e-14)
    np.testing.assert_allclose(d[2], -u, atol=1e-14)


@pytest.mark.parametrize("bad", [0, -1, 2.5, "4", True, None])
def test_bad_direction_count(bad):
    mesh = fvf.icosphere(0)
    u = random_field(mesh)
    for call in (
        lambda: fvf.to_power(mesh, u, bad),
        lambda: fvf.smoothest_fields(mesh, 1, n=bad),
        lambda: fvf.singularities(mesh, u, n=bad),
        lambda: fvf.period_jumps(mesh, u, bad),
    ):
        with pytest.raises(fvf.DirectionCountError, match="integer >= 1"):
            call()


def test_integral_float_direction_count_accepted():
    mesh = fvf.icosphere(1)
    u = random_field(mesh)
    np.testing.assert_array_equal(fvf.to_power(mesh, u, 4.0), fvf.to_power(mesh, u, 4))


def test_from_power_bad_shape():
    mesh = fvf.icosphere(0)
    with pytest.raises(fvf.FieldShapeError):
        fvf.from_power(mesh, np.ones(3), 4)
    with pytest.raises(fvf.FieldShapeError, match="NaN"):
        fvf.from_power(mesh, np.full(mesh.n_faces, np.nan + 0j), 4)


# ---------------------------------------------------------------------------- smoothest
def test_nfold_laplacian_energy_matches_power():
    """E_N(to_power(u)) is the sum over edges of w |z_s^N − r^N z_t^N|² (unit fields)."""
    mesh = fvf.jittered_sphere(2, 0.3, seed=2)
    u = random_field(mesh)
    u /= np.linalg.norm(u, axis=1)[:, None]
    pairs, r, w = fvf.design.connection.connection_pairs(mesh)
    for n in N_VALUES:
        z = fvf.to_power(mesh, u, n)
        L = fvf.connection_laplacian(mesh, n=n)
        direct = np.sum(w * np.abs(z[pairs[:, 0]] - r**n * z[pairs[:, 1]]) ** 2)
        assert np.isclose(np.vdot(z, L @ z).real, direct, rtol=1e-12)


def test_smoothest_n1_matches_arpack_and_dense():
    """n = 1 gives today's fields: the inverse iteration agrees with ARPACK and LAPACK."""
    mesh = load_shared("spot.obj")
    lam_i, U_i = fvf.smoothest_fields(mesh, 3, solver="lobpcg")
    lam_a, U_a = fvf.smoothest_fields(mesh, 3, solver="arpack")
    np.testing.assert_allclose(lam_i, lam_a, rtol=1e-9)
    # same fields up to the documented phase fix (non-degenerate spectrum on spot)
    np.testing.assert_allclose(U_i, U_a, atol=1e-5)
    small = fvf.icosphere(2)
    np.testing.assert_allclose(
        fvf.smoothest_fields(small, 2, solver="lobpcg")[0],
        fvf.smoothest_fields(small, 2, solver="dense")[0],
        rtol=1e-9,
    )


@pytest.mark.parametrize("n", (2, 4, 6))
def test_smoothest_n_field_is_eigenfield_of_nfold_laplacian(n):
    mesh = fvf.torus(24, 12)
    lam, U = fvf.smoothest_fields(mesh, 2, n=n, solver="lobpcg")
    lam_d, _ = fvf.smoothest_fields(mesh, 2, n=n, solver="dense")
    np.testing.assert_allclose(lam, lam_d, rtol=1e-8)
    L = fvf.connection_laplacian(mesh, n=n)
    A = mesh.face_areas
    for k in range(2):
        z = fvf.to_power(mesh, U[k], n)
        assert np.isclose(A @ np.abs(z) ** 2, 1.0)
        res = L @ z - lam[k] * A * z
        assert np.linalg.norm(res) <= 1e-4 * np.linalg.norm(L @ z)  # LOBPCG tol 1e-6


@pytest.mark.slow
def test_smoothest_cross_field_sphere_spectrum():
    """Cross fields on the unit sphere: spin-4 harmonics, λ = l(l+1) − 16 with l = 4 → 4."""
    mesh = fvf.icosphere(4)
    lam, _ = fvf.smoothest_fields(mesh, 1, n=4)
    assert abs(lam[0] - 4.0) < 0.01


@pytest.mark.parametrize(
    "mesh",
    [pytest.param(fvf.icosphere(3), id="sphere"), pytest.param(rounded_cube(), id="rounded-cube")],
)
def test_smoothest_cross_field_has_eight_quarter_singularities(mesh):
    _, U = fvf.smoothest_fields(mesh, 1, n=4)
    ids, ind = fvf.singularities(mesh, U[0], n=4)
    assert ind.dtype == np.float64
    np.testing.assert_array_equal(ind, np.full(8, 0.25))


def test_rounded_cube_singularities_sit_at_corners():
    mesh = rounded_cube()
    _, U = fvf.smoothest_fields(mesh, 1, n=4)
    ids, _ = fvf.singularities(mesh, U[0], n=4)
    P = mesh.vertices[ids]
    # each singularity within two edge lengths of a distinct cube corner direction
    corner = np.sign(P)
    assert len({tuple(c) for c in corner.astype(int)}) == 8
    d = np.linalg.norm(P / np.linalg.norm(P, axis=1)[:, None] - corner / np.sqrt(3), axis=1)
    assert d.max() < 3 * mesh.mean_edge_length


# ---------------------------------------------------------------------------- Poincaré–Hopf
def _ph_meshes(slow=()):
    marks = {name: [pytest.mark.slow] if name in slow else [] for name in ("torus", "bob")}
    marks |= {name: [pytest.mark.slow] if name in slow else [] for name in ("3holes", "fert")}
    return [
        pytest.param(lambda: fvf.icosphere(2), 0, id="icosphere"),
        pytest.param(lambda: fvf.torus(24, 12), 1, id="torus", marks=marks["torus"]),
        pytest.param(lambda: load_shared("spot.obj"), 0, id="spot"),
        pytest.param(lambda: load_shared("bob_tri.obj"), 1, id="bob", marks=marks["bob"]),
        pytest.param(lambda: load_shared("3holes.off"), 3, id="3holes", marks=marks["3holes"]),
        pytest.param(lambda: load_shared("fertility.off"), 4, id="fertility", marks=marks["fert"]),
    ]


@pytest.mark.parametrize("make, genus", _ph_meshes())
@pytest.mark.parametrize("n", N_VALUES)
def test_poincare_hopf(make, genus, n):
    """N-indices are multiples of 1/N and sum to chi (random N-fields: every edge turns)."""
    mesh = make()
    assert mesh.genus == genus
    chi = 2 - 2 * genus
    for seed in range(2):
        ind = fvf.vertex_indices(mesh, random_field(mesh, seed=10 * n + seed), n=n)
        k = np.rint(n * ind)
        np.testing.assert_allclose(n * ind, k, atol=1e-12)
        assert int(k.sum()) == n * chi


@pytest.mark.parametrize("make, genus", _ph_meshes(slow=("torus", "bob", "3holes", "fert")))
def test_poincare_hopf_smoothest(make, genus):
    """The smoothest N-fields' singularities sum to chi; on the torus there are none."""
    mesh = make()
    chi = 2 - 2 * genus
    for n in N_VALUES if mesh.n_faces < 5000 else (4,):
        _, U = fvf.smoothest_fields(mesh, 1, n=n)
        ids, ind = fvf.singularities(mesh, U[0], n=n)
        assert int(np.rint(n * ind).sum()) == n * chi


def test_n1_indices_unchanged():
    mesh = fvf.torus(24, 12)
    u = random_field(mesh, 3)
    a = fvf.vertex_indices(mesh, u)
    b = fvf.vertex_indices(mesh, u, n=1)
    assert a.dtype == np.int64
    np.testing.assert_array_equal(a, b)


def test_index_of_cross_rotations_equal():
    """Rotating any face's representative by 2πk/N changes neither indices nor the field."""
    mesh = fvf.torus(24, 12)
    u = random_field(mesh, 4)
    rng = np.random.default_rng(5)
    k = rng.integers(0, 4, mesh.n_faces)
    d = nf.all_directions(mesh, u, 4)
    v = d[k, np.arange(mesh.n_faces)]
    np.testing.assert_array_equal(
        fvf.vertex_indices(mesh, u, n=4), fvf.vertex_indices(mesh, v, n=4)
    )


def test_boundary_vertices_have_no_index():
    mesh = fvf.disk(6, 6)
    u = random_field(mesh, 1)
    ind = fvf.vertex_indices(mesh, u, n=4)
    assert not ind[mesh.boundary_vertices].any()


def test_index_of_planar_quarter_singularity():
    """z ↦ z^{1/4}-type cross field around the disk centre: index +1/4 (and −1/4)."""
    mesh = fvf.disk(8, 6)
    c = mesh.face_centroids
    ang = np.arctan2(c[:, 1], c[:, 0])
    for k, expect in ((1, 0.25), (-1, -0.25)):
        # a cross field whose power is e^{i k θ}: directions turn by k·2π/4 per loop
        theta = k * ang / 4
        u = np.stack([np.cos(theta), np.sin(theta), 0 * theta], axis=1)
        ids, ind = fvf.singularities(mesh, u, n=4)
        assert ids.tolist() == [0] and ind.tolist() == [expect]


# ---------------------------------------------------------------------------- jumps, cut, comb
def test_period_jumps_of_rotated_representatives():
    """Rotating face f's representative by k_f steps changes p_e by k_s − k_t (mod N)."""
    mesh = fvf.torus(24, 12)
    _, U = fvf.smoothest_fields(mesh, 1, n=4)
    u = U[0]
    p0 = fvf.period_jumps(mesh, u, 4)
    rng = np.random.default_rng(0)
    k = rng.integers(0, 4, mesh.n_faces)
    v = nf.all_directions(mesh, u, 4)[k, np.arange(mesh.n_faces)]
    p1 = fvf.period_jumps(mesh, v, 4)
    EF = mesh.edge_faces
    inner = (EF >= 0).all(axis=1)
    s, t = EF[inner, 0], EF[inner, 1]
    np.testing.assert_array_equal(p1[inner], np.mod(p0[inner] + k[s] - k[t], 4))
    # u is an NField with n=4: its vectors read as a vector field go in as a bare array
    assert not fvf.period_jumps(mesh, np.asarray(u), 1).any()


def test_monodromy_equals_index():
    """Around every interior vertex N·ind ≡ −Σ ±p_e (mod N)."""
    mesh = load_shared("bob_tri.obj")
    n = 4
    u = random_field(mesh, 7)
    p = fvf.period_jumps(mesh, u, n)
    E = mesh.edges
    # edge e enters the ccw walk around edges[e,0] from t into s: jump +p; around edges[e,1] −p
    mono = np.bincount(E[:, 0], weights=p, minlength=mesh.n_vertices) - np.bincount(
        E[:, 1], weights=p, minlength=mesh.n_vertices
    )
    ind = np.rint(n * fvf.vertex_indices(mesh, u, n=n)).astype(int)
    assert np.all(np.mod(ind + mono.astype(int), n) == 0)


@pytest.mark.parametrize(
    "make",
    [
        pytest.param(lambda: fvf.icosphere(3), id="sphere"),
        pytest.param(lambda: fvf.torus(24, 12), id="torus"),
        pytest.param(lambda: load_shared("3holes.off"), id="3holes", marks=pytest.mark.slow),
        pytest.param(lambda: fvf.disk(8, 6), id="disk"),
    ],
)
@pytest.mark.parametrize("n", (2, 4, 6))
def test_comb_is_smooth_on_uncut_edges(make, n):
    mesh = make()
    _, U = fvf.smoothest_fields(mesh, 1, n=n)
    u = U[0]
    cut = fvf.cut_graph(mesh, u, n)
    assert cut.mask.dtype == bool and cut.mask.shape == (mesh.n_edges,)
    np.testing.assert_array_equal(cut.edges, mesh.edges[cut.mask])
    assert not cut.mask[mesh.boundary_edges].any()
    C = fvf.comb(mesh, u, n, cut)
    assert C.shape == (n, mesh.n_faces, 3)
    for j in range(n):
        p = fvf.period_jumps(mesh, C[j], n)
        assert not p[~cut.mask].any()
    # the combed field is the same N-direction field with the same lengths
    np.testing.assert_allclose(fvf.to_power(mesh, C[0], n), fvf.to_power(mesh, u, n), atol=1e-12)
    # every singular vertex lies on the cut
    on_cut = np.zeros(mesh.n_vertices, dtype=bool)
    on_cut[cut.edges.ravel()] = True
    assert on_cut[cut.singular_vertices].all()
    # the cut surface is a disk per component: chi(cut surface) = 1
    if mesh.is_closed:
        V_cut = _cut_vertex_count(mesh, cut.mask)
        E_cut = mesh.n_edges + cut.mask.sum()
        assert V_cut - E_cut + mesh.n_faces == 1


def _cut_vertex_count(mesh, mask):
    """Vertices of the surface cut open along ``mask``: a vertex with c > 0 cut edges
    around it splits into c copies (closed meshes)."""
    deg = np.bincount(mesh.edges[mask].ravel(), minlength=mesh.n_vertices)
    return int(np.where(deg > 0, deg, 1).sum())


def test_comb_accepts_vertex_pairs_and_rejects_bad_cuts():
    mesh = fvf.torus(24, 12)
    _, U = fvf.smoothest_fields(mesh, 1, n=4)
    u = U[0]
    cut = fvf.cut_graph(mesh, u, 4)
    np.testing.assert_array_equal(
        fvf.comb(mesh, u, 4, cut.edges[:, ::-1]), fvf.comb(mesh, u, 4, cut)
    )
    with pytest.raises(fvf.CutGraphError, match="cannot be combed"):
        fvf.comb(mesh, u, 4, np.zeros(mesh.n_edges, dtype=bool))
    with pytest.raises(fvf.CutGraphError, match="not edges"):
        fvf.comb(mesh, u, 4, np.array([[0, mesh.n_vertices // 2]]))
    with pytest.raises(fvf.CutGraphError, match="shape"):
        fvf.comb(mesh, u, 4, np.zeros(3, dtype=bool))


def test_zero_face_is_rejected():
    mesh = fvf.icosphere(1)
    u = random_field(mesh)
    u[[3, 7]] = 0.0
    for call in (fvf.period_jumps, fvf.cut_graph, fvf.comb):
        with pytest.raises(fvf.FieldShapeError, match=r"zero at faces \[3, 7\]"):
            call(mesh, u, 4)
    with pytest.raises(fvf.FieldShapeError, match="zero"):
        fvf.singularities(mesh, u, n=4)


def test_vector_field_needs_no_cut_on_a_sphere_beyond_singularities():
    """N = 1: every jump is 0, so the cut is only the paths joining the singularities."""
    mesh = fvf.icosphere(3)
    _, U = fvf.smoothest_fields(mesh, 1)
    cut = fvf.cut_graph(mesh, U[0], 1)
    C = fvf.comb(mesh, U[0], 1, cut)
    np.testing.assert_allclose(C[0], U[0], atol=1e-15)


# ---------------------------------------------------------------------------- design
@pytest.mark.parametrize("n", (2, 4, 6))
def test_hard_constraints_met_exactly(n):
    mesh = fvf.jittered_sphere(3, 0.3, seed=3)
    rng = np.random.default_rng(n)
    faces = rng.choice(mesh.n_faces, 6, replace=False)
    d = rng.standard_normal((6, 3))
    N = mesh.face_normals[faces]
    d -= np.einsum("ij,ij->i", d, N)[:, None] * N
    u = fvf.design_field(mesh, faces, d, hard=True, n=n)
    np.testing.assert_allclose(u[faces], d / np.linalg.norm(d, axis=1)[:, None], atol=1e-14)
    # it is the minimiser: perturbing a free face's power raises the N-fold energy
    L = fvf.connection_laplacian(mesh, n=n)
    z = fvf.to_power(mesh, u, n)
    e0 = np.vdot(z, L @ z).real
    free = np.setdiff1d(np.arange(mesh.n_faces), faces)[:5]
    for t in free:
        dz = np.zeros_like(z)
        dz[t] = 1e-3 * (1 + 1j)
        assert np.vdot(z + dz, L @ (z + dz)).real > e0


def test_constraint_rotated_by_quarter_turn_is_the_same_cross():
    mesh = fvf.icosphere(2)
    f = [3]
    d = mesh.face_bases[3, 0]
    a = fvf.design_field(mesh, f, [d], hard=True, n=4)
    b = fvf.design_field(mesh, f, [mesh.face_bases[3, 1]], hard=True, n=4)
    np.testing.assert_allclose(fvf.to_power(mesh, a, 4), fvf.to_power(mesh, b, 4), atol=1e-12)
    np.testing.assert_allclose(b[3], mesh.face_bases[3, 1], atol=1e-14)  # kept as given
    # duplicates that are the same cross are accepted; different crosses conflict
    fvf.design_field(mesh, [3, 3], [d, -d], hard=True, n=4)
    fvf.design_field(mesh, [3, 3], [d, mesh.face_bases[3, 1]], hard=True, n=4)
    skew = np.cos(0.3) * d + np.sin(0.3) * mesh.face_bases[3, 1]
    with pytest.raises(fvf.ConflictingConstraintError, match=r"faces \[3\]"):
        fvf.design_field(mesh, [3, 3], [d, skew], hard=True, n=4)
    with pytest.raises(fvf.ConflictingConstraintError):  # opposite vectors differ for n = 1
        fvf.design_field(mesh, [3, 3], [d, -d], hard=True)


def test_soft_constraints_pull_with_their_weight():
    mesh = fvf.torus(24, 12)
    faces = np.array([5, 300])
    d = np.stack([mesh.face_bases[5, 0], mesh.face_bases[300, 1]])
    hard = fvf.design_field(mesh, faces, d, hard=True, n=4)
    target = fvf.to_power(mesh, hard, 4)[faces]
    gaps = []
    for w in (10.0, 100.0, 1e3, 1e4, 1e5):
        u = fvf.design_field(mesh, faces, d, weights=w, n=4)
        gaps.append(np.abs(fvf.to_power(mesh, u, 4)[faces] - target).max())
    assert all(b < a for a, b in zip(gaps, gaps[1:], strict=False))
    assert gaps[-1] < 0.01 * gaps[0]


def test_constraints_on_missing_faces_rejected():
    mesh = fvf.icosphere(1)
    with pytest.raises(fvf.ConstraintIndexError, match=r"\[1\]"):
        fvf.design_field(mesh, [0, mesh.n_faces], [[1.0, 0, 0]] * 2, n=4)


def test_user_alignment_field_and_weights():
    """Aligning to a given cross field: a strong weight reproduces it, zero weight ignores it."""
    mesh = fvf.torus(24, 12)
    _, U = fvf.smoothest_fields(mesh, 2, n=4)
    target = U[1]  # the second-smoothest cross field
    close = fvf.design_field(mesh, n=4, align=target, align_strength=1e6)
    err = np.abs(np.angle(fvf.to_power(mesh, close, 4) * np.conj(fvf.to_power(mesh, target, 4))))
    assert err.max() < 1e-3
    weights = np.zeros(mesh.n_faces)
    weights[:10] = 1.0
    partial = fvf.design_field(mesh, n=4, align=target, align_weights=weights)
    assert np.isfinite(partial).all()
    with pytest.raises(fvf.ConstraintError, match="align_weights"):
        fvf.design_field(mesh, n=4, align=target, align_weights=-np.ones(mesh.n_faces))
    with pytest.raises(fvf.ConstraintError, match="align must be"):
        fvf.design_field(mesh, n=4, align="bogus")
    with pytest.warns(fvf.UnconstrainedComponentWarning, match="zero on every face"):
        fvf.design_field(mesh, n=4, align=target, align_weights=0.0)


def test_design_progress_callback():
    mesh = fvf.torus(24, 12)
    seen = []
    fvf.design_field(mesh, n=4, align="curvature", progress=lambda s, d, t: seen.append(s))
    assert {"assemble", "solve"} <= set(seen)
    seen.clear()
    fvf.smoothest_fields(mesh, 1, n=4, solver="lobpcg", progress=lambda s, d, t: seen.append(s))
    assert {"factor", "iterate"} <= set(seen)
    with pytest.raises(fvf.ParameterError, match="progress"):
        fvf.design_field(mesh, n=4, align="curvature", progress="yes")


# ---------------------------------------------------------------------------- map consistency
def _mirror_mesh():
    """A deformed icosphere symmetric under x ↦ −x, and that mirror's vertex permutation."""
    from scipy.spatial import cKDTree

    s = fvf.icosphere(3)
    V = s.vertices
    perm = cKDTree(V).query(V * [-1, 1, 1])[1]
    x, y, z = V.T
    X = np.stack([x * (1 + 0.2 * z), 0.8 * y + 0.3 * z**2, 0.6 * z + 0.2 * y * z + 0.1 * x**2], 1)
    mesh = fvf.TriMesh(X, s.faces)
    assert np.allclose(mesh.vertices[perm], mesh.vertices * [-1, 1, 1])
    return mesh, perm


@pytest.mark.parametrize("n", (2, 4))
def test_map_consistent_nfield_is_mirror_symmetric(n):
    from fvf.design.symmetric import map_consistent_field, power_pushforward

    mesh, perm = _mirror_mesh()
    basis = fvf.SpectralBasis(mesh, 30)
    C = fvf.functional_map_from_bases(basis, basis, perm)
    v, residual = map_consistent_field(basis, C, n=n)
    src, tgt, rot, reflect = power_pushforward(mesh, perm, n)
    assert src.size == mesh.n_faces and reflect.all()  # a mirror: every face, reversed

    def inconsistency(u):
        z = fvf.to_power(mesh, u, n)
        image = rot * np.where(reflect, np.conj(z[src]), z[src])
        return np.linalg.norm(z[tgt] - image) / np.linalg.norm(z)

    _, U = fvf.smoothest_fields(mesh, 1, n=n)
    assert residual < 1e-6 and inconsistency(v) < 1e-6
    assert inconsistency(U[0]) > 0.1  # the smoothest field is not symmetric
    np.testing.assert_allclose(mesh.face_areas @ (v * v).sum(1), 1.0, rtol=1e-9)
    ids, ind = fvf.singularities(mesh, v, n=n)
    # singularities come in mirror pairs (up to which vertex of a face carries the index)
    P = mesh.vertices[ids]
    gap = np.linalg.norm(P[:, None] * [-1, 1, 1] - P[None], axis=2).min(axis=1)
    assert gap.max() < 2 * mesh.mean_edge_length
    assert np.isclose(ind.sum(), 2.0)
    # symmetric, and still smooth: its energy is close to the smoothest one's
    L = fvf.connection_laplacian(mesh, n=n)
    e = [np.vdot(fvf.to_power(mesh, w, n), L @ fvf.to_power(mesh, w, n)).real for w in (v, U[0])]
    assert e[0] < 1.5 * e[1]


def test_map_consistent_field_n_arguments():
    from fvf.design.symmetric import map_consistent_field

    mesh, perm = _mirror_mesh()
    basis = fvf.SpectralBasis(mesh, 10)
    C = fvf.functional_map_from_bases(basis, basis, perm)
    with pytest.raises(fvf.DirectionCountError):
        map_consistent_field(basis, C, n=0)
    with pytest.raises(fvf.ParameterError, match="n = 1 only"):
        map_consistent_field(basis, C, n=4, fields=np.zeros((2, mesh.n_faces, 3)))


def test_singularities_match_libigl():
    """The same cross field's singular vertices and indices (mod 4) as libigl's
    find_cross_field_singularities (an independent implementation)."""
    igl = pytest.importorskip("igl")
    mesh = load_shared("spot.obj")
    u = fvf.design_field(mesh, n=4, align="curvature")
    u = u / np.linalg.norm(u, axis=1)[:, None]
    V, F = np.ascontiguousarray(mesh.vertices), np.ascontiguousarray(mesh.faces)
    is_s, index = igl.find_cross_field_singularities(V, F, u, fvf.rotate(mesh, u))
    ids, ind = fvf.singularities(mesh, u, n=4)
    assert ids.size > 10
    np.testing.assert_array_equal(ids, np.flatnonzero(is_s))
    np.testing.assert_array_equal(np.mod(np.rint(4 * ind), 4), index[ids])
    # libigl's combing is smooth across its own cut; ours across ours: both comb the same
    # cross (the same power field)
    P1, _ = igl.comb_cross_field(V, F, u, fvf.rotate(mesh, u))
    C = fvf.comb(mesh, u, 4)
    np.testing.assert_allclose(fvf.to_power(mesh, P1, 4), fvf.to_power(mesh, C[0], 4), atol=1e-9)
