"""Singularities (indices) of tangent fields: sign conventions, Poincaré–Hopf, bad input."""

import zlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

import fvf
from conftest import CLOSED_NAMES, CLOSED_SHARED, closed_mesh, load_shared
from fvf.calculus import gradient, rotate
from fvf.design.indices import (
    ZeroFieldWarning,
    face_indices,
    face_singularities,
    singularities,
    singularity_positions,
    vertex_indices,
)
from fvf.errors import FieldShapeError, FieldValueError, NonTangentFieldWarning

# ---------------------------------------------------------------------------- helpers


def planar(fx, fy):
    """A per-face field on a flat mesh in z = 0 from two functions of the centroid."""

    def field(mesh, centre=(0.0, 0.0)):
        c = mesh.face_centroids
        x, y = c[:, 0] - centre[0], c[:, 1] - centre[1]
        return np.stack([fx(x, y), fy(x, y), 0.0 * x], axis=1)

    return field


RADIAL = planar(lambda x, y: x, lambda x, y: y)
SADDLE = planar(lambda x, y: x, lambda x, y: -y)
ZSQUARED = planar(lambda x, y: x * x - y * y, lambda x, y: 2 * x * y)
ROTATION = planar(lambda x, y: -y, lambda x, y: x)
SINK = planar(lambda x, y: -x, lambda x, y: -y)


def rotated_icosphere(k):
    """An icosphere whose vertex nearest +z is moved exactly to +z (and its antipode to -z)."""
    base = fvf.icosphere(k)
    top = int(np.argmax(base.vertices[:, 2]))
    p = base.vertices[top]
    # Rotation taking p to e_z (Rodrigues); the icosphere is centrally symmetric.
    axis = np.cross(p, [0.0, 0.0, 1.0])
    s, c = np.linalg.norm(axis), p[2]
    if s < 1e-15:
        return base, top, int(np.argmin(base.vertices[:, 2]))
    axis /= s
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    R = np.eye(3) + s * K + (1 - c) * K @ K
    mesh = fvf.TriMesh(base.vertices @ R.T, base.faces)
    return mesh, top, int(np.argmin(mesh.vertices[:, 2]))


def random_flat_mesh(rng, n=300):
    """Delaunay triangulation of random points in the unit square (z = 0), normals +z."""
    P = np.concatenate([rng.uniform(0, 1, (n, 2)), [[0, 0], [1, 0], [1, 1], [0, 1]]])
    F = Delaunay(P).simplices.astype(np.int64)
    Q = P[F]
    d = (Q[:, 1, 0] - Q[:, 0, 0]) * (Q[:, 2, 1] - Q[:, 0, 1]) - (Q[:, 1, 1] - Q[:, 0, 1]) * (
        Q[:, 2, 0] - Q[:, 0, 0]
    )
    F[d < 0] = F[d < 0][:, ::-1]
    return fvf.TriMesh(np.c_[P, np.zeros(len(P))], F)


def reference_flat_indices(mesh, u):
    """Independent winding number on a flat mesh: sort each fan by centroid angle.

    In the plane, transport is the identity, so the index is the winding of the
    field's global angle around the fan (slow Python loop; small meshes only).
    """
    ang = np.arctan2(u[:, 1], u[:, 0])
    X, C = mesh.vertices, mesh.face_centroids
    out = np.zeros(mesh.n_vertices, dtype=np.int64)
    boundary = set(mesh.boundary_vertices.tolist())
    for v in range(mesh.n_vertices):
        if v in boundary:
            continue
        fan = np.flatnonzero((mesh.faces == v).any(axis=1))
        order = np.argsort(np.arctan2(C[fan, 1] - X[v, 1], C[fan, 0] - X[v, 0]))
        a = ang[fan[order]]
        d = np.roll(a, -1) - a
        d = (d + np.pi) % (2 * np.pi) - np.pi
        out[v] = int(np.rint(d.sum() / (2 * np.pi)))
    return out


def smooth_fields(mesh, rng, k=2):
    """Generic tangent fields: gradients of random smooth functions, their rotations,
    and smooth ambient fields projected onto the faces (all per face, (m, 3))."""
    X = mesh.vertices
    X = (X - X.mean(0)) / np.abs(X - X.mean(0)).max()
    C = mesh.face_centroids
    C = (C - mesh.vertices.mean(0)) / np.abs(mesh.vertices - mesh.vertices.mean(0)).max()
    out = []
    for _ in range(k):
        f = np.sin(X @ rng.normal(0, 2.5, 3) + rng.uniform(0, 2 * np.pi))
        f += 0.5 * np.sin(X @ rng.normal(0, 4.0, 3))
        g = gradient(mesh, f)
        out += [g, rotate(mesh, g)]
        A, B = rng.normal(size=(3, 3)), rng.normal(0, 3, (3, 3))
        out.append(mesh.project_tangent(np.sin(C @ B.T + rng.uniform(0, 6, 3)) @ A.T))
    return out


# ---------------------------------------------------------------------------- planar disk


@pytest.mark.parametrize(
    ("field", "expected"),
    [(RADIAL, 1), (SINK, 1), (SADDLE, -1), (ZSQUARED, 2), (ROTATION, 1)],
    ids=["radial", "sink", "saddle", "z^2", "rotation"],
)
@pytest.mark.parametrize("shape", [(6, 8), (5, 6), (9, 7)])
def test_disk_vertex_index_signs(field, expected, shape):
    mesh = fvf.disk(*shape)
    assert np.allclose(mesh.vertices[0], 0.0)
    ids, ind = singularities(mesh, field(mesh))
    assert ids.tolist() == [0]
    assert ind.tolist() == [expected]
    assert ids.dtype == np.int64 and ind.dtype == np.int64
    full = vertex_indices(mesh, field(mesh))
    assert full.shape == (mesh.n_vertices,) and full.dtype == np.int64
    assert full[0] == expected and np.count_nonzero(full) == 1


def test_disk_index_does_not_depend_on_orientation():
    """Flipping every face (normals -z) keeps the index of a source, saddle or z^2."""
    mesh = fvf.disk(6, 8)
    flipped = fvf.TriMesh(mesh.vertices, mesh.faces[:, ::-1])
    for field, k in [(RADIAL, 1), (SADDLE, -1), (ZSQUARED, 2), (ROTATION, 1)]:
        assert singularities(flipped, field(flipped))[1].tolist() == [k]


def test_disk_constant_field_has_no_singularity():
    mesh = fvf.disk(6, 8)
    u = np.tile([0.3, -1.0, 0.0], (mesh.n_faces, 1))
    ids, ind = singularities(mesh, u)
    assert ids.size == 0 and ind.size == 0
    assert not vertex_indices(mesh, u).any()


def test_boundary_vertices_get_zero():
    """A source centred on a boundary vertex is not reported (documented convention)."""
    mesh = fvf.disk(6, 8)
    b = mesh.boundary_vertices
    centre = mesh.vertices[b[0], :2]
    ind = vertex_indices(mesh, RADIAL(mesh, centre))
    assert not ind[b].any()
    assert not ind.any()
    # The whole boundary rotates once for the field centred at the origin.
    assert vertex_indices(mesh, RADIAL(mesh)).sum() == 1


def test_flat_random_mesh_matches_independent_winding(rng):
    """Vertex indices equal a slow fan-sorting winding number on an irregular flat mesh."""
    mesh = random_flat_mesh(rng)
    c = mesh.face_centroids
    z = c[:, 0] + 1j * c[:, 1]
    roots = rng.uniform(0.2, 0.8, (4, 2)) @ [1, 1j]
    w = (z - roots[0]) * (z - roots[1]) * np.conj(z - roots[2]) * np.conj(z - roots[3]) ** 2
    fields = [w, np.conj(w), w * np.exp(1j * 5 * np.abs(z))]
    for ww in fields:
        u = np.stack([ww.real, ww.imag, 0 * ww.real], axis=1)
        ind = vertex_indices(mesh, u)
        assert np.array_equal(ind, reference_flat_indices(mesh, u))
    # Simple zeros: one singularity each, at a vertex next to the zero. (A double zero
    # may split into several vertices of total index -2, as the reference agrees.)
    roots = np.array([0.25 + 0.3j, 0.7 + 0.25j, 0.5 + 0.75j])
    w = (z - roots[0]) * (z - roots[1]) * np.conj(z - roots[2])
    ids, ind = singularities(mesh, np.stack([w.real, w.imag, 0 * w.real], axis=1))
    assert sorted(ind.tolist()) == [-1, 1, 1]
    pos = singularity_positions(mesh, ids)[:, :2] @ [1, 1j]
    for r, k in zip(roots, [1, 1, -1], strict=True):
        near = np.argmin(np.abs(pos - r))
        assert ind[near] == k
        assert abs(pos[near] - r) < 2 * mesh.mean_edge_length


# ---------------------------------------------------------------------------- vertex fields


@pytest.mark.parametrize(
    ("field", "expected"),
    [
        (lambda d: d, 1),
        (lambda d: -d, 1),
        (lambda d: d * [1, -1, 0], -1),
        (lambda d: np.stack([-d[:, 1], d[:, 0], 0 * d[:, 0]], 1), 1),
    ],
    ids=["radial", "sink", "saddle", "rotation"],
)
def test_disk_face_index_signs(field, expected):
    mesh = fvf.disk(6, 8)
    r = np.linalg.norm(mesh.face_centroids, axis=1)
    for t in np.flatnonzero(r < 0.7)[::7]:
        d = (mesh.vertices - mesh.face_centroids[t]) * [1, 1, 0]
        U = field(d)
        ids, ind = face_singularities(mesh, U)
        assert ids.tolist() == [t] and ind.tolist() == [expected]
        full = face_indices(mesh, U)
        assert full.shape == (mesh.n_faces,) and full.dtype == np.int64
        # The flattened (3n,) layout is accepted too.
        assert np.array_equal(face_indices(mesh, U.ravel()), full)


def test_face_index_ignores_normal_component_and_constant():
    mesh = fvf.disk(6, 8)
    t = 11
    d = (mesh.vertices - mesh.face_centroids[t]) * [1, 1, 0]
    lifted = d + [0, 0, 3.0]  # an out-of-plane part is projected away
    assert face_singularities(mesh, lifted)[0].tolist() == [t]
    const = np.tile([1.0, 2.0, 5.0], (mesh.n_vertices, 1))
    assert face_singularities(mesh, const)[0].size == 0


def test_sphere_face_singularities_of_rotation():
    """A vertex field rotating about an axis through two face centroids: two +1 faces."""
    mesh = fvf.icosphere(2)
    a = mesh.face_centroids[7] / np.linalg.norm(mesh.face_centroids[7])
    U = np.cross(a, mesh.vertices)
    ids, ind = face_singularities(mesh, U)
    assert ind.tolist() == [1, 1]
    P = singularity_positions(mesh, ids, kind="face")
    P /= np.linalg.norm(P, axis=1)[:, None]
    assert sorted((P @ a).round(9).tolist()) == [-1.0, 1.0]


# ---------------------------------------------------------------------------- sphere


@pytest.mark.parametrize("k", [1, 2, 3])
def test_sphere_rotation_field_has_two_poles(k):
    mesh, north, south = rotated_icosphere(k)
    assert np.allclose(mesh.vertices[north], [0, 0, 1]) and np.allclose(
        mesh.vertices[south], [0, 0, -1]
    )
    u = mesh.project_tangent(np.cross([0.0, 0.0, 1.0], mesh.face_centroids))
    ids, ind = singularities(mesh, u)
    assert ids.tolist() == sorted([north, south]) and ind.tolist() == [1, 1]
    P = singularity_positions(mesh, ids)
    assert np.allclose(np.sort(P[:, 2]), [-1.0, 1.0])
    assert np.allclose(P[:, :2], 0.0, atol=1e-12)
    # Gradient of the height: a source at the bottom, a sink at the top, both +1.
    g = gradient(mesh, mesh.vertices[:, 2])
    ids, ind = singularities(mesh, g)
    assert ids.tolist() == sorted([north, south]) and ind.tolist() == [1, 1]
    assert vertex_indices(mesh, rotate(mesh, g)).sum() == 2


def test_icosphere_poles_at_vertices():
    """fvf.icosphere(k >= 1) already has vertices at +-z (edge midpoints)."""
    mesh = fvf.icosphere(2)
    u = mesh.project_tangent(np.cross([0.0, 0.0, 1.0], mesh.face_centroids))
    ids, ind = singularities(mesh, u)
    assert ind.tolist() == [1, 1]
    assert np.allclose(np.sort(singularity_positions(mesh, ids)[:, 2]), [-1, 1])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_jittered_sphere_rotation_total_two(seed):
    mesh = fvf.jittered_sphere(3, 0.4, seed=seed)
    u = mesh.project_tangent(np.cross([0.0, 0.0, 1.0], mesh.face_centroids))
    ids, ind = singularities(mesh, u)
    assert ind.sum() == 2 and np.all(ind > 0)
    z = singularity_positions(mesh, ids)[:, 2]
    assert np.all(np.abs(z) > 0.95)
    assert (z > 0).any() and (z < 0).any()


# ---------------------------------------------------------------------------- Poincaré–Hopf


def test_closed_shared_list_has_expected_chi():
    for name, chi in CLOSED_SHARED:
        assert closed_mesh(name).euler_characteristic == chi


@pytest.mark.parametrize("name", CLOSED_NAMES)
def test_poincare_hopf_on_closed_meshes(name):
    mesh = closed_mesh(name)
    chi = dict(CLOSED_SHARED).get(name, mesh.euler_characteristic)
    assert mesh.is_closed
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    fields = smooth_fields(mesh, rng)
    # Even pure noise: the identity is exact by construction.
    fields.append(mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3))))
    for u in fields:
        ind = vertex_indices(mesh, u)
        assert ind.sum() == chi
        ids, k = singularities(mesh, u)
        assert np.all(np.diff(ids) > 0) and np.all(k != 0) and k.sum() == chi


@pytest.mark.parametrize(("n_major", "n_minor"), [(24, 12), (17, 9)])
def test_poincare_hopf_torus(n_major, n_minor):
    mesh = fvf.torus(n_major, n_minor)
    rng = np.random.default_rng(n_major)
    # The rotation about the z axis has no zero on a torus of revolution.
    u = mesh.project_tangent(np.cross([0.0, 0.0, 1.0], mesh.face_centroids))
    assert singularities(mesh, u)[0].size == 0
    for u in smooth_fields(mesh, rng):
        assert vertex_indices(mesh, u).sum() == 0


@pytest.mark.parametrize("seed", range(4))
def test_poincare_hopf_jittered_spheres(seed):
    mesh = fvf.jittered_sphere(2 + seed % 2, 0.45, seed=seed)
    for u in smooth_fields(mesh, np.random.default_rng(seed)):
        assert vertex_indices(mesh, u).sum() == 2


def test_face_indices_poincare_hopf_for_smooth_vertex_field():
    """For a vertex field smooth at the mesh scale the face indices add up to chi."""
    mesh = fvf.jittered_sphere(3, 0.3, seed=5)
    X = mesh.vertices
    U = np.stack([np.sin(2 * X[:, 1]) + X[:, 2], X[:, 0] * X[:, 2] - 0.3, np.cos(X[:, 0])], 1)
    U -= np.einsum("ij,ij->i", U, X)[:, None] * X  # tangent to the sphere
    assert face_indices(mesh, U).sum() == 2


# ---------------------------------------------------------------------------- invariance

SETTINGS = settings(
    max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)


@SETTINGS
@given(
    st.integers(0, 2**32 - 1),
    st.sampled_from(["icosphere2", "jittered2", "torus"]),
    st.floats(-np.pi, np.pi),
    st.floats(0.0, 1.0),
)
def test_index_invariant_under_rotation_and_rescaling(seed, name, phi, noise):
    mesh = closed_mesh(name)
    rng = np.random.default_rng(seed)
    u = smooth_fields(mesh, rng, 1)[rng.integers(3)]
    u = u + noise * np.abs(u).max() * mesh.project_tangent(rng.standard_normal(u.shape))
    ind = vertex_indices(mesh, u)
    assert ind.sum() == mesh.euler_characteristic
    assert np.array_equal(vertex_indices(mesh, rotate(mesh, u)), ind)  # J u
    assert np.array_equal(vertex_indices(mesh, -u), ind)
    z = mesh.to_complex(u)
    assert np.array_equal(vertex_indices(mesh, mesh.from_complex(np.exp(1j * phi) * z)), ind)
    scale = 10.0 ** rng.uniform(-3, 3, mesh.n_faces)
    assert np.array_equal(vertex_indices(mesh, scale[:, None] * u), ind)
    assert np.array_equal(vertex_indices(mesh, 1e-6 * u), ind)


@SETTINGS
@given(st.integers(0, 2**32 - 1), st.floats(-np.pi, np.pi))
def test_face_index_invariant_under_rotation_and_rescaling(seed, phi):
    mesh = fvf.disk(5, 7)
    rng = np.random.default_rng(seed)
    X = mesh.vertices
    z = X[:, 0] + 1j * X[:, 1]
    w = (z - complex(*rng.uniform(-0.6, 0.6, 2))) * np.conj(z - complex(*rng.uniform(-0.6, 0.6, 2)))
    U = np.stack([w.real, w.imag, 0 * w.real], 1)
    ind = face_indices(mesh, U)
    assert np.count_nonzero(ind) <= 2
    r = np.exp(1j * phi) * w * 10.0 ** rng.uniform(-3, 3, w.shape)
    V = np.stack([r.real, r.imag, rng.normal(size=w.shape)], 1)  # normal part: ignored
    assert np.array_equal(face_indices(mesh, V), ind)


# ---------------------------------------------------------------------------- bad input


def test_wrong_shapes_raise():
    mesh = fvf.disk(4, 6)
    with pytest.raises(FieldShapeError, match="per-face"):
        vertex_indices(mesh, np.ones((mesh.n_faces, 2)))
    with pytest.raises(FieldShapeError, match="vertex field"):
        singularities(mesh, np.ones((mesh.n_vertices, 3)))
    with pytest.raises(FieldShapeError, match="per-vertex"):
        face_indices(mesh, np.ones((mesh.n_faces, 3)))
    with pytest.raises(FieldShapeError, match="face field"):
        face_singularities(mesh, np.ones((mesh.n_faces, 3)))
    with pytest.raises(FieldShapeError):
        face_indices(mesh, np.ones((mesh.n_vertices, 2)))
    u = RADIAL(mesh)
    u[3, 0] = np.nan
    with pytest.raises(FieldValueError, match="NaN"):
        vertex_indices(mesh, u)
    U = np.ones((mesh.n_vertices, 3))
    U[2, 1] = np.inf
    with pytest.raises(FieldValueError, match="NaN or inf"):
        face_indices(mesh, U)
    with pytest.raises(ValueError, match="zero"):
        vertex_indices(mesh, RADIAL(mesh), zero="ignore")
    with pytest.raises(ValueError, match="zero"):
        face_indices(mesh, np.ones((mesh.n_vertices, 3)), zero="skip")


def test_non_tangent_field_is_projected_with_warning():
    mesh = fvf.disk(4, 6)
    u = RADIAL(mesh) + [0, 0, 1.0]
    with pytest.warns(NonTangentFieldWarning):
        ind = vertex_indices(mesh, u)
    assert ind[0] == 1
    with pytest.raises(FieldShapeError, match="normal component"):
        vertex_indices(mesh, u, tangent="raise")
    assert vertex_indices(mesh, u, tangent="ignore")[0] == 1


def test_zero_vectors_raise_naming_faces():
    mesh = fvf.disk(6, 8)
    u = SADDLE(mesh)
    u[[4, 9]] = 0.0
    with pytest.raises(FieldShapeError, match=r"faces \[4, 9\]"):
        vertex_indices(mesh, u)
    with pytest.raises(FieldShapeError, match="zero"):
        singularities(mesh, np.zeros((mesh.n_faces, 3)))
    # Normal-only vectors are zero tangent vectors.
    w = np.zeros((mesh.n_faces, 3))
    w[:, 2] = 1.0
    with pytest.raises(FieldShapeError, match="zero"):
        vertex_indices(mesh, w, tangent="ignore")


def test_zero_vectors_warn_mode():
    mesh = fvf.disk(6, 8)
    u = SADDLE(mesh)
    ref = vertex_indices(mesh, u)
    fan = np.flatnonzero((mesh.faces == 0).any(axis=1))
    u[fan[0]] = 1e-14 * u[fan[0]]
    with pytest.warns(ZeroFieldWarning, match="set to 0"):
        ind = vertex_indices(mesh, u, zero="warn")
    touched = np.unique(mesh.faces[fan[0]])
    assert not ind[touched].any()
    keep = np.setdiff1d(np.arange(mesh.n_vertices), touched)
    assert np.array_equal(ind[keep], ref[keep])
    # A looser/tighter threshold decides what counts as zero.
    assert vertex_indices(mesh, u, zero_rtol=0.0)[0] == -1
    with pytest.warns(ZeroFieldWarning):
        ids, _ = singularities(mesh, np.zeros((mesh.n_faces, 3)), zero="warn")
    assert ids.size == 0


def test_face_zero_and_normal_vectors():
    mesh = fvf.disk(6, 8)
    d = (mesh.vertices - mesh.face_centroids[11]) * [1, 1, 0]
    d[mesh.faces[20, 0]] = [0.0, 0.0, 2.0]  # normal to the (flat) faces around it
    with pytest.raises(FieldShapeError, match="normal to the face"):
        face_indices(mesh, d)
    with pytest.warns(ZeroFieldWarning):
        ind = face_indices(mesh, d, zero="warn")
    bad = np.flatnonzero((mesh.faces == mesh.faces[20, 0]).any(axis=1))
    assert not ind[bad].any()
    assert ind[11] == 1
    # A vertex field vanishing at a vertex (the pole of a rotation) raises.
    sphere = fvf.icosphere(1)
    with pytest.raises(FieldShapeError, match="zero"):
        face_indices(sphere, np.cross([0.0, 0.0, 1.0], sphere.vertices))


def test_singularity_positions():
    mesh = fvf.disk(4, 6)
    assert np.array_equal(singularity_positions(mesh, [0, 3]), mesh.vertices[[0, 3]])
    P = singularity_positions(mesh, np.array([2, 5]), kind="face")
    assert np.allclose(P, mesh.vertices[mesh.faces[[2, 5]]].mean(axis=1))
    assert P.flags.writeable and P.dtype == np.float64
    assert singularity_positions(mesh, []).shape == (0, 3)
    ids, _ = singularities(mesh, RADIAL(mesh))
    assert singularity_positions(mesh, ids).shape == (1, 3)
    with pytest.raises(ValueError, match="kind"):
        singularity_positions(mesh, [0], kind="edge")
    with pytest.raises(FieldShapeError, match="outside"):
        singularity_positions(mesh, [mesh.n_vertices])
    with pytest.raises(FieldShapeError, match="outside"):
        singularity_positions(mesh, [-1], kind="face")
    with pytest.raises(FieldShapeError, match="integer"):
        singularity_positions(mesh, [0.5])


@pytest.mark.parametrize("name, chi", CLOSED_SHARED)
def test_designed_fields_satisfy_poincare_hopf(name, chi):
    """Poincaré–Hopf: the indices of designed fields sum to χ on every closed shared mesh."""
    mesh = load_shared(name)
    faces = np.array([0, mesh.n_faces // 2])
    directions = mesh.face_bases[faces, 0]
    v = fvf.design_field(mesh, faces, directions, hard=True)
    ids, idx = fvf.singularities(mesh, v)
    assert idx.sum() == chi
    assert len(ids) >= abs(chi)
