"""Vector-field design (fvf.design): constraints, optimality, smoothness, inputs."""

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

import fvf
from conftest import random_tangent_field
from fvf.design.connection import (
    connection_energy,
    connection_laplacian,
    smoothest_fields,
)
from fvf.design.constrained import (
    SOFT_WEIGHT,
    ConflictingConstraintError,
    ConstraintError,
    ConstraintIndexError,
    NormalDirectionError,
    PointLocationError,
    UnconstrainedComponentWarning,
    ZeroDirectionError,
    closest_faces,
    constraint_targets,
    design_field,
    locate_points,
)
from fvf.design.nfields import to_power


@pytest.fixture(autouse=True)
def _one_blas_thread():
    with threadpool_limits(1):
        yield


def constraints(mesh, rng, k=5):
    faces = rng.choice(mesh.n_faces, size=k, replace=False)
    return faces, rng.standard_normal((k, 3))


def unit_projection(mesh, faces, d):
    N = mesh.face_normals[faces]
    p = d - np.einsum("ij,ij->i", d, N)[:, None] * N
    return p / np.linalg.norm(p, axis=1)[:, None]


def l2(mesh, u):
    return float(np.sqrt(np.sum(mesh.face_areas * np.einsum("ij,ij->i", u, u))))


# ---------------------------------------------------------------------------- hard
def test_hard_constraints_are_exact_and_optimal(closed, rng):
    """z_c = τ_c to round-off, and E(u) ≤ E(u + δ) for every δ vanishing on the constraints:
    the cross term 2 Re⟨δ, L z⟩ vanishes (L z = 0 on the free faces)."""
    faces, d = constraints(closed, rng)
    u = design_field(closed, faces, d, hard=True)
    assert np.abs(u[faces] - unit_projection(closed, faces, d)).max() < 1e-12
    assert np.abs(np.einsum("ij,ij->i", u, closed.face_normals)).max() < 1e-12
    L = connection_laplacian(closed)
    z = closed.to_complex(u)
    free = np.setdiff1d(np.arange(closed.n_faces), faces)
    Lz = L @ z
    assert np.abs(Lz[free]).max() <= 1e-9 * np.abs(L).max() * np.abs(z).max()
    e = connection_energy(closed, u)
    for eps in (1e-3, 1.0):
        delta = random_tangent_field(closed, rng)
        delta[faces] = 0
        assert connection_energy(closed, u + eps * delta) >= e
        gain = connection_energy(closed, u + eps * delta) - e
        assert np.isclose(gain, eps**2 * connection_energy(closed, delta), rtol=1e-6)


def test_hard_magnitudes_when_not_normalized(rng):
    mesh = fvf.icosphere(3)
    faces, d = constraints(mesh, rng)
    u = design_field(mesh, faces, d, hard=True, normalize=False)
    N = mesh.face_normals[faces]
    assert np.abs(u[faces] - (d - np.einsum("ij,ij->i", d, N)[:, None] * N)).max() < 1e-12


# ---------------------------------------------------------------------------- smoothness
@pytest.mark.parametrize("hard", [False, True])
def test_designed_field_is_smooth(closed, rng, hard):
    """Rayleigh quotient of the design ≪ that of a random field meeting the same
    constraints (measured ratio 0.03 on the 320-face icosphere, ≤ 2e-3 from 5k faces)."""
    faces, d = constraints(closed, rng)
    u = design_field(closed, faces, d, hard=hard)
    noise = random_tangent_field(closed, rng)
    noise[faces] = u[faces]
    q_design = connection_energy(closed, u) / l2(closed, u) ** 2
    q_noise = connection_energy(closed, noise) / l2(closed, noise) ** 2
    assert q_design < 0.05 * q_noise


@pytest.mark.parametrize("kind", ["knoppel", "singer_wu"])
@pytest.mark.parametrize("hard", [False, True])
def test_single_constraint_on_flat_disk_gives_constant_field(kind, hard):
    mesh = fvf.disk(6, 6)
    u = design_field(mesh, [17], [[0.3, -2.0, 0.7]], hard=hard, kind=kind)
    target = np.array([0.3, -2.0, 0.0]) / np.hypot(0.3, 2.0)
    assert np.abs(u - target).max() < 1e-10


def test_unconstrained_design_is_the_smoothest_unit_field():
    mesh = fvf.torus(24, 12)
    u = design_field(mesh)
    lam, U = smoothest_fields(mesh, 1)
    assert np.abs(u - U[0]).max() < 1e-10
    assert abs(l2(mesh, u) - 1) < 1e-12
    # λ from the dense generalized eigensolver is accurate to ~ε·λ_max (LAPACK's backward
    # error), and z*Lz to the same: here λ_max ≈ 3.7e5 ≈ 7e5·λ_0, so 1e-10·λ_0 was below
    # round-off (it failed on another CPU by 1.7e-10·λ_0; docs/notes.md, "Eigenvalues are
    # accurate to ε·λ_max")
    L = connection_laplacian(mesh)
    top = np.abs(L).sum(axis=1).max() / mesh.face_areas.min()  # Gershgorin: ≥ λ_max
    assert abs(connection_energy(mesh, u) - lam[0]) < 8 * np.finfo(float).eps * top


def test_a_degenerate_smoothest_eigenspace_gives_its_most_uniform_member():
    """The regular tetrahedron's smoothest vector fields span three complex dimensions
    (λ = 1 three times); a basis member the solver returns can vanish on a face (one did,
    1e-6 of the longest). design_field returns a member of the eigenspace (its energy is
    λ_0) with no face shorter than 0.3 of the longest (the eigenbasis' best has 0.68)."""
    X = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    tet = fvf.TriMesh(X, np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]]))
    lam, _ = smoothest_fields(tet, 3)
    assert np.allclose(lam, lam[0], rtol=1e-10)  # the case is degenerate
    u = design_field(tet)
    length = np.linalg.norm(u, axis=1)
    assert length.min() > 0.3 * length.max()
    assert abs(l2(tet, u) - 1) < 1e-12
    assert abs(connection_energy(tet, u) - lam[0]) < 1e-10


@pytest.mark.parametrize("n", [1, 4])
def test_every_part_of_a_mesh_of_several_gets_its_own_smoothest_field(n):
    """The lowest eigenfield of a mesh of several parts lives on one part (zero on the
    others: a CAD file of two solids got no field on one). Each part gets its own: the
    field on a part is that part's smoothest field (as design_field of it alone, up to a
    rotation and the scale), each part's share of Σ A|u|² is its share of the area, every
    part's indices sum to its χ, and a lone face gets a unit direction."""
    torus, ball = fvf.torus(24, 12), fvf.icosphere(2)
    X = np.array([[9.0, 0, 0], [10, 0, 0], [9, 1, 0]])
    V = np.concatenate([torus.vertices, 2.0 * ball.vertices + [6.0, 0, 0], X])
    F = np.concatenate(
        [torus.faces, ball.faces + torus.n_vertices, np.array([[0, 1, 2]]) + len(V) - 3]
    )
    mesh = fvf.TriMesh(V, F)
    u = design_field(mesh, n=n)
    A, m0, m1 = mesh.face_areas, torus.n_faces, torus.n_faces + ball.n_faces
    parts = [slice(0, m0), slice(m0, m1), slice(m1, None)]
    for part in parts:
        share = (A[part] * (np.linalg.norm(u[part], axis=1) ** 2)).sum()
        assert abs(share - A[part].sum() / A.sum()) < 1e-10
    alone = design_field(torus, n=n)
    z, w = to_power(torus, u[parts[0]], n), to_power(torus, alone, n)
    a = torus.face_areas
    cos = abs(np.vdot(w, a * z)) / np.sqrt(np.vdot(z, a * z).real * np.vdot(w, a * w).real)
    assert abs(cos - 1) < 1e-8  # the same field up to a rotation and the scale
    verts, idx = fvf.singularities(mesh, u)
    on_ball = (verts >= torus.n_vertices) & (verts < torus.n_vertices + ball.n_vertices)
    assert idx[~on_ball].sum() == 0 and idx[on_ball].sum() == 2  # χ: torus 0, ball 2


# ---------------------------------------------------------------------------- soft
def test_soft_constraints_tighten_with_weight(rng):
    """Soft error decreases monotonically with the weight, and the soft solution tends
    to the hard one (error ~ 1/w)."""
    mesh = fvf.jittered_sphere(3, 0.3, seed=4)
    faces, d = constraints(mesh, rng)
    hard = design_field(mesh, faces, d, hard=True)
    target = unit_projection(mesh, faces, d)
    L = connection_laplacian(mesh)
    base = L.diagonal().real[faces] / mesh.face_areas[faces]
    errs, gaps = [], []
    for scale in (1.0, 1e2, 1e4, 1e6):
        u = design_field(mesh, faces, d, weights=scale * base)
        errs.append(np.abs(u[faces] - target).max())
        gaps.append(np.abs(u - hard).max())
    assert all(b < a for a, b in zip(errs, errs[1:], strict=False))
    assert errs[-1] < 1e-5 and gaps[-1] < 1e-5
    assert 50 < errs[1] / errs[2] < 200  # ~ 1/w
    default = design_field(mesh, faces, d)
    assert np.allclose(default, design_field(mesh, faces, d, weights=SOFT_WEIGHT * base))
    assert np.abs(default[faces] - target).max() < 0.02


def test_soft_design_is_linear_in_the_targets(rng):
    mesh = fvf.icosphere(3)
    faces, d1 = constraints(mesh, rng)
    d2 = rng.standard_normal(d1.shape)
    w = rng.uniform(10, 100, faces.size)

    def solve(d):
        return design_field(mesh, faces, d, weights=w, normalize=False)

    assert np.abs(solve(d1 + 2.5 * d2) - solve(d1) - 2.5 * solve(d2)).max() < 1e-12 * (
        np.abs(solve(d1)).max()
    )


def test_duplicate_agreeing_constraints_add_weights(rng):
    mesh = fvf.icosphere(2)
    d = np.array([[1.0, 0.2, 0.3]])
    twice = design_field(mesh, [4, 4], np.repeat(d, 2, 0), weights=[10.0, 10.0])
    once = design_field(mesh, [4], d, weights=[20.0])
    assert np.abs(twice - once).max() < 1e-14
    # same direction up to scale is the same unit target
    design_field(mesh, [4, 4], np.concatenate([d, 3 * d]), hard=True)


def test_singer_wu_design(rng):
    mesh = fvf.icosphere(3)
    faces, d = constraints(mesh, rng)
    u = design_field(mesh, faces, d, hard=True, kind="singer_wu")
    assert np.abs(u[faces] - unit_projection(mesh, faces, d)).max() < 1e-12
    assert connection_energy(mesh, u, "singer_wu") < connection_energy(
        mesh, design_field(mesh, faces, d, hard=True), "singer_wu"
    ) * (1 + 1e-12)


def test_normal_component_of_directions_is_projected(rng):
    mesh = fvf.icosphere(2)
    faces, d = constraints(mesh, rng)
    N = mesh.face_normals[faces]
    tangent = d - np.einsum("ij,ij->i", d, N)[:, None] * N
    a = design_field(mesh, faces, tangent + 0.7 * N, normalize=False)
    b = design_field(mesh, faces, tangent, normalize=False)
    assert np.abs(a - b).max() < 1e-13


def test_unconstrained_component_gets_zero_field():
    a, b = fvf.icosphere(1), fvf.icosphere(1)
    mesh = fvf.TriMesh(
        np.concatenate([a.vertices, b.vertices + [3.0, 0, 0]]),
        np.concatenate([a.faces, b.faces + a.n_vertices]),
    )
    with pytest.warns(UnconstrainedComponentWarning, match=r"\[80, 81"):
        u = design_field(mesh, [3], [[0.0, 0.0, 1.0]], hard=True)
    assert np.abs(u[80:]).max() == 0 and np.abs(u[:80]).max() > 0.1


# ---------------------------------------------------------------------------- points
def test_points_are_assigned_to_their_faces(rng):
    mesh = fvf.jittered_sphere(2, 0.3, seed=5)
    faces = rng.choice(mesh.n_faces, 6, replace=False)
    bary = rng.dirichlet([2, 2, 2], size=6)
    f, pos = locate_points(mesh, faces, bary)
    assert (f == faces).all()
    assert np.allclose(pos, np.einsum("ki,kij->kj", bary, mesh.vertices[mesh.faces[faces]]))
    found, b = closest_faces(mesh, pos)
    assert (found == faces).all() and np.abs(b - bary).max() < 1e-10
    d = rng.standard_normal((6, 3))
    assert (
        np.abs(design_field(mesh, points=pos, directions=d) - design_field(mesh, faces, d)).max()
        == 0
    )


def test_closest_faces_is_exact_off_the_surface(rng):
    """Nearest point on the mesh, compared with a dense barycentric sampling."""
    mesh = fvf.jittered_sphere(1, 0.3, seed=6)
    P = 1.5 * rng.standard_normal((40, 3))
    f, b = closest_faces(mesh, P, chunk=400)  # several chunks
    q = np.einsum("ki,kij->kj", b, mesh.vertices[mesh.faces[f]])
    dist = np.linalg.norm(q - P, axis=1)
    g = np.array([(i, j, 40 - i - j) for i in range(41) for j in range(41 - i)]) / 40
    S = np.einsum("gi,tij->tgj", g, mesh.vertices[mesh.faces]).reshape(-1, 3)
    dense = np.min(np.linalg.norm(S[None] - P[:, None], axis=2), axis=1)
    assert (dist <= dense + 1e-12).all() and (dense - dist).max() < 0.01
    assert (b >= 0).all() and np.allclose(b.sum(1), 1)


def test_locate_points_rejects_bad_barycentric():
    mesh = fvf.icosphere(1)
    with pytest.raises(PointLocationError, match=r"rows \[1\].*outside faces \[7\]"):
        locate_points(mesh, [3, 7], [[0.2, 0.3, 0.5], [1.2, -0.2, 0.0]])
    with pytest.raises(PointLocationError, match=r"do not sum to 1"):
        locate_points(mesh, [3], [[0.2, 0.3, 0.4]])
    with pytest.raises(PointLocationError, match=r"shape \(2, 3\)"):
        locate_points(mesh, [3, 4], [[0.2, 0.3, 0.5]])
    with pytest.raises(ConstraintIndexError, match=r"\[1\]"):
        locate_points(mesh, [3, 80], [[0.2, 0.3, 0.5]] * 2)


# ---------------------------------------------------------------------------- bad input
def test_bad_constraints_name_the_offenders():
    mesh = fvf.icosphere(1)  # 80 faces
    d = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])
    with pytest.raises(ConstraintIndexError, match=r"constraints \[1\].*faces\[1\] = 80"):
        design_field(mesh, [0, 80, 2], d)
    with pytest.raises(ConstraintIndexError, match=r"\[0\]"):
        design_field(mesh, [-1, 5, 2], d)
    with pytest.raises(ZeroDirectionError, match=r"constraints \[2\].*faces \[9\]"):
        design_field(mesh, [0, 1, 9], [[1.0, 0, 0], [0, 1, 0], [0, 0, 0]])
    N = mesh.face_normals
    with pytest.raises(NormalDirectionError, match=r"constraints \[1\].*faces \[5\]"):
        design_field(mesh, [0, 5], [[1.0, 2.0, 0.5], 3 * N[5] + 1e-6 * mesh.face_bases[5, 0]])
    with pytest.raises(ConflictingConstraintError, match=r"faces \[4\]"):
        design_field(mesh, [4, 0, 4], [mesh.face_bases[4, 0], d[0], mesh.face_bases[4, 1]])
    with pytest.raises(ConstraintError, match=r"shape \(3, 3\)"):
        design_field(mesh, [0, 1, 2], d[:2])
    with pytest.raises(ConstraintError, match="integer"):
        design_field(mesh, [0.0, 1.0, 2.0], d)
    with pytest.raises(ConstraintError, match=r"> 0.*\[1\]"):
        design_field(mesh, [0, 1, 2], d, weights=[1.0, -1.0, 1.0])
    with pytest.raises(ConstraintError, match=r"shape \(3,\)"):
        design_field(mesh, [0, 1, 2], d, weights=[1.0, 2.0])
    with pytest.raises(ConstraintError, match="soft"):
        design_field(mesh, [0, 1, 2], d, weights=1.0, hard=True)
    with pytest.raises(ConstraintError, match="not both"):
        design_field(mesh, [0], d[:1], points=mesh.face_centroids[:1])
    with pytest.raises(ConstraintError, match="together"):
        design_field(mesh, [0, 1, 2])
    with pytest.raises(ConstraintError, match="NaN"):
        design_field(mesh, [0], [[np.nan, 0, 0]])
    with pytest.raises(fvf.FvfError, match="kind"):
        design_field(mesh, [0], d[:1], kind="harmonic")
    for err in (
        ConstraintIndexError,
        ZeroDirectionError,
        NormalDirectionError,
        ConflictingConstraintError,
        PointLocationError,
    ):
        assert issubclass(err, ConstraintError) and issubclass(err, ValueError)


def test_constraint_targets_are_frame_coordinates(rng):
    mesh = fvf.icosphere(2)
    faces, d = constraints(mesh, rng)
    f, tau = constraint_targets(mesh, faces, d, normalize=False)
    u = mesh.project_tangent(np.zeros((mesh.n_faces, 3)))
    u[faces] = d
    assert np.allclose(tau, mesh.to_complex(mesh.project_tangent(u))[faces], atol=1e-15)
    assert np.allclose(np.abs(constraint_targets(mesh, faces, d)[1]), 1)


def test_the_smoothest_fields_of_a_triangle_soup_are_any_fields(recwarn):
    """A soup has no interior side: L = 0, and ARPACK's shift σ = -1e-8 max(L_tt/A_t) was
    0 (SuperLU: "Factor is exactly singular", raw). σ now stays below 0."""
    ball = fvf.icosphere(2)
    P = ball.vertices[ball.faces].reshape(-1, 3)
    soup = fvf.TriMesh(P, np.arange(len(P)).reshape(-1, 3))
    lam, U = smoothest_fields(soup, 1, solver="arpack")
    assert abs(lam[0]) < 1e-12 and abs(l2(soup, U[0]) - 1) < 1e-10
