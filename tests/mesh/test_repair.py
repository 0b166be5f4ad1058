"""Tests of fvf.repair: each repair on constructed broken meshes, its maps, and clean meshes.

The contract checked everywhere (:func:`check_maps`): the new arrays are the old ones seen
through the maps, ``vertices == V[vertex_origin]``, each kept old vertex sits at
``vertex_map[i]``, each new face is its old face (corners 1 and 2 swapped where flipped),
the inputs are untouched, and the result is a valid TriMesh or the documented error.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fvf
from conftest import BOUNDARY_SHARED, CLOSED_SHARED, load_shared
from fvf.mesh.diagnostics import mesh_report
from fvf.mesh.repair import REPAIR_STEPS

ALL_STEPS = list(REPAIR_STEPS)


# ---------------------------------------------------------------------------- helpers
def frozen(*arrays):
    """Read-only copies: a repair that writes into its input raises."""
    out = []
    for a in arrays:
        a = np.array(a)
        a.flags.writeable = False
        out.append(a)
    return out


def check_maps(V, F, r, atol=0.0):
    """The RepairResult contract for input (V, F); ``atol`` > 0 for merges within a tolerance."""
    V, F = np.asarray(V, float), np.asarray(F, np.int64)
    n, m = len(V), len(F)
    n2, m2 = len(r.vertices), len(r.faces)
    assert r.vertices.dtype == np.float64 and r.vertices.shape == (n2, 3)
    assert r.faces.dtype == np.int64 and r.faces.shape == (m2, 3)
    assert r.vertex_origin.shape == (n2,) and r.vertex_map.shape == (n,)
    assert r.face_origin.shape == (m2,) and r.face_map.shape == (m,)
    assert r.flipped.shape == (m2,) and r.flipped.dtype == bool
    assert not np.shares_memory(r.vertices, V) and not np.shares_memory(r.faces, F)
    if m2:
        assert r.faces.min() >= 0 and r.faces.max() < n2
    # vertices: new -> old is exact; every kept old vertex is where vertex_map says
    np.testing.assert_array_equal(r.vertices, V[r.vertex_origin])
    kept = r.vertex_map >= 0
    assert (r.vertex_map < n2).all()
    np.testing.assert_allclose(r.vertices[r.vertex_map[kept]], V[kept], rtol=0, atol=atol)
    # faces: new -> old, with the documented corner swap on flipped faces
    np.testing.assert_array_equal(r.face_map[r.face_origin], np.arange(m2))
    assert np.count_nonzero(r.face_map >= 0) == m2
    expected = F[r.face_origin]
    expected[r.flipped] = expected[r.flipped][:, [0, 2, 1]]
    np.testing.assert_allclose(r.vertices[r.faces], V[expected], rtol=0, atol=atol)
    # each corner's vertex is (a copy of) the image of the old corner's vertex
    assert (r.vertex_map[expected] >= 0).all()
    np.testing.assert_array_equal(r.vertex_map[r.vertex_origin[r.faces]], r.vertex_map[expected])


def positional_function(X):
    """A smooth function of position: equal on coincident vertices."""
    return np.sin(3 * X[:, 0]) + X[:, 1] * X[:, 2]


def icosphere_arrays(level=2):
    mesh = fvf.icosphere(level)
    return np.array(mesh.vertices), np.array(mesh.faces)


def signed_volume(V, F):
    P = V[F]
    return np.einsum("ij,ij->i", P[:, 0], np.cross(P[:, 1], P[:, 2])).sum() / 6


def cone(k=12, height=1.0):
    """A closed cone with its apex (vertex 0) at the origin, outward oriented."""
    a = 2 * np.pi * np.arange(k) / k
    ring = np.column_stack([np.cos(a), np.sin(a), np.full(k, height)])
    V = np.vstack([[0.0, 0, 0], ring, [0, 0, height]])
    i = np.arange(k)
    j = (i + 1) % k
    side = np.column_stack([np.zeros(k, int), j + 1, i + 1])
    cap = np.column_stack([np.full(k, k + 1), i + 1, j + 1])
    return V, np.vstack([side, cap])


def two_cones():
    """Two closed cones touching at their apex (vertex 0): a vertex with two fans."""
    V1, F1 = cone()
    V2 = V1[1:] * [1, 1, -1]  # mirrored below, apex shared
    F2 = np.where(F1 == 0, 0, F1 + len(V1) - 1)[:, [0, 2, 1]]  # mirroring flips orientation
    return np.vstack([V1, V2]), np.vstack([F1, F2])


def bowtie():
    """Two triangles sharing only vertex 0, plus a separate fan of two triangles at 0."""
    V = np.array(
        [[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [-1, 0, 0], [-1, -1, 0], [0, 1, 1], [0, -1, 1]]
    )
    F = np.array([[0, 1, 2], [0, 3, 4], [0, 5, 6]])
    return V, F


def moebius(k=10):
    """A Moebius strip of 2k triangles (non-orientable)."""
    t = 2 * np.pi * np.arange(k) / k
    V = []
    for a in t:
        for s in (-0.3, 0.3):
            r = 1 + s * np.cos(a / 2)
            V.append([r * np.cos(a), r * np.sin(a), s * np.sin(a / 2)])
    F = []
    for i in range(k):
        a0, a1 = 2 * i, 2 * i + 1
        b0, b1 = (2 * i + 2, 2 * i + 3) if i + 1 < k else (1, 0)  # the half twist
        F += [[a0, b0, a1], [a1, b0, b1]]
    return np.array(V), np.array(F)


def book():
    """Three triangles on the spine (0, 1): a non-manifold edge."""
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]])
    return V, np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])


def flip_some(F, rng, k):
    idx = np.sort(rng.choice(len(F), k, replace=False))
    G = F.copy()
    G[idx] = G[idx][:, ::-1]
    return G, idx


def clean_meshes():
    out = {"icosphere2": fvf.icosphere(2), "torus": fvf.torus(16, 8), "disk": fvf.disk(5, 6)}
    out["two_cones_split"] = fvf.TriMesh(*fvf.split_nonmanifold_vertices(*two_cones())[:2])
    return out


# ---------------------------------------------------------------------------- RepairResult
def test_result_unpacks_like_the_old_tuple_and_composes(rng):
    V, F = icosphere_arrays(1)
    V = np.vstack([V, [[9.0, 9, 9]]])
    r = fvf.remove_unreferenced_vertices(V, F)
    X, G, kept = r
    np.testing.assert_array_equal(kept, np.arange(len(V) - 1))
    assert r.vertex_map[-1] == -1 and r.changed and "[42]" in r.log[0]
    assert "43 -> 42 vertices" in repr(r)
    # then(): the composition equals applying the two repairs in turn
    G2, _ = flip_some(F, rng, 7)
    a = fvf.orient_faces(V, G2)
    b = fvf.remove_unreferenced_vertices(a.vertices, a.faces)
    ab = a.then(b)
    check_maps(V, G2, ab)
    np.testing.assert_array_equal(ab.faces, b.faces)
    assert ab.log == a.log + b.log
    f = positional_function(V)
    np.testing.assert_array_equal(ab.vertex_values(f), positional_function(ab.vertices))
    g = rng.standard_normal((len(G2), 3))
    np.testing.assert_array_equal(ab.face_values(g), g)


@pytest.mark.parametrize("step", ALL_STEPS)
def test_bad_arrays_raise_typed_errors(step):
    fn = REPAIR_STEPS[step]
    with pytest.raises(fvf.MeshShapeError, match="vertices"):
        fn(np.zeros((3, 2)), [[0, 1, 2]])
    with pytest.raises(fvf.MeshShapeError, match="faces"):
        fn(np.zeros((3, 3)), [[0.0, 1, 2]])
    with pytest.raises(fvf.MeshShapeError, match="rectangular"):
        fn([[0, 0, 0], [1, 0]], [[0, 1, 2]])
    with pytest.raises(fvf.MeshIndexError, match=r"faces \[1\]"):
        fn(np.eye(3), [[0, 1, 2], [0, 1, 3]])
    empty = fn(np.zeros((0, 3)), np.zeros((0, 3), int))
    assert empty.vertices.shape == (0, 3) and empty.faces.shape == (0, 3) and not empty.changed


# ---------------------------------------------------------------------------- clean meshes
def _assert_identity(V, F, r):
    assert not r.changed and r.log == ()
    np.testing.assert_array_equal(r.vertices, V)
    np.testing.assert_array_equal(r.faces, F)
    for a, size in [(r.vertex_origin, len(V)), (r.vertex_map, len(V))]:
        np.testing.assert_array_equal(a, np.arange(size))
    for a in [r.face_origin, r.face_map]:
        np.testing.assert_array_equal(a, np.arange(len(F)))
    assert not r.flipped.any()


@pytest.mark.parametrize("name", ["icosphere2", "torus", "disk", "two_cones_split"])
def test_clean_generated_meshes_come_back_unchanged(name):
    mesh = clean_meshes()[name]
    V, F = frozen(mesh.vertices, mesh.faces)
    steps = [*ALL_STEPS, "repair_mesh"]
    if name == "two_cones_split":  # the split apex is two coincident vertices: welding undoes it
        steps = [s for s in steps if s not in ("remove_duplicate_vertices", "repair_mesh")]
        welded = fvf.remove_duplicate_vertices(V, F)
        np.testing.assert_array_equal(welded.faces, two_cones()[1])
    for step in steps:
        r = fvf.repair_mesh(V, F) if step == "repair_mesh" else REPAIR_STEPS[step](V, F)
        _assert_identity(V, F, r)
        check_maps(V, F, r)


@pytest.mark.parametrize("name", [n for n, _ in CLOSED_SHARED] + [n for n, *_ in BOUNDARY_SHARED])
def test_clean_shared_meshes_come_back_unchanged(name):
    mesh = load_shared(name)
    V, F = frozen(mesh.vertices, mesh.faces)
    r = fvf.repair_mesh(V, F, steps=ALL_STEPS)
    _assert_identity(V, F, r)
    assert mesh_report(V, F)["problems"] == []


# ---------------------------------------------------------------------------- orientation
def test_orient_faces_restores_flipped_faces(rng):
    V, F = frozen(*icosphere_arrays(2))
    G, idx = flip_some(F, rng, 60)
    G = frozen(G)[0]
    with pytest.raises(fvf.OrientationError):
        fvf.TriMesh(V, G)
    r = fvf.orient_faces(V, G)
    check_maps(V, G, r)
    np.testing.assert_array_equal(np.flatnonzero(r.flipped), idx)
    assert "flipped faces" in r.log[0] and "1 of 1 components" in r.log[0]
    mesh = fvf.TriMesh(r.vertices, r.faces)
    np.testing.assert_allclose(mesh.face_normals, fvf.TriMesh(V, F).face_normals, atol=1e-15)
    assert signed_volume(r.vertices, r.faces) > 0


def test_orient_faces_chooses_outward_for_closed_and_majority_for_open(rng):
    V, F = icosphere_arrays(1)
    inside_out = F[:, ::-1]
    r = fvf.orient_faces(V, inside_out)
    assert r.flipped.all() and signed_volume(r.vertices, r.faces) > 0
    assert not fvf.orient_faces(V, inside_out, outward=False).changed
    # an open disk: the majority orientation wins, either way round
    disk = fvf.disk(5, 6)
    D, E = np.array(disk.vertices), np.array(disk.faces)
    E2, idx = flip_some(E, rng, len(E) // 3)
    r = fvf.orient_faces(D, E2)
    np.testing.assert_array_equal(np.flatnonzero(r.flipped), idx)
    E3, idx3 = flip_some(E, rng, 2 * len(E) // 3)
    r = fvf.orient_faces(D, E3)
    np.testing.assert_array_equal(np.flatnonzero(~r.flipped), idx3)
    fvf.TriMesh(r.vertices, r.faces)


def test_orient_faces_per_component_and_across_a_nonmanifold_vertex(rng):
    # a sphere and an inside-out torus far away, plus flips, plus two cones at one vertex
    V1, F1 = icosphere_arrays(1)
    torus = fvf.torus(12, 6)
    V2 = np.array(torus.vertices) + [10.0, 0, 0]
    F2 = np.array(torus.faces)[:, ::-1] + len(V1)
    V3, F3 = two_cones()
    V = np.vstack([V1, V2, V3 + [0, 10.0, 0]])
    F0 = np.vstack([F1, F2, F3 + len(V1) + len(V2)])
    F, idx = flip_some(F0, rng, 40)
    r = fvf.orient_faces(V, F)
    check_maps(V, F, r)
    assert "of 4 components" in r.log[0]
    t = np.arange(len(F))
    in_torus = (t >= len(F1)) & (t < len(F1) + len(F2))  # inside out: the others flip
    expected = np.isin(t, idx) ^ in_torus
    np.testing.assert_array_equal(r.flipped, expected)
    fixed = fvf.split_nonmanifold_vertices(r.vertices, r.faces)
    mesh = fvf.TriMesh(fixed.vertices, fixed.faces)
    assert mesh.n_components == 4 and mesh.euler_characteristic == 2 + 0 + 2 + 2


def test_orient_faces_rejects_moebius_and_nonmanifold_edges():
    V, F = moebius()
    with pytest.raises(fvf.NonOrientableError, match=r"faces \[0, 1, .*\(20 in all\).*non-orient"):
        fvf.orient_faces(V, F)
    # TriMesh says so too, instead of advising orient_faces, which cannot fix it
    with pytest.raises(fvf.NonOrientableError, match="No repair can fix this") as caught:
        fvf.TriMesh(V, F)
    assert "orient_faces" not in str(caught.value)
    assert issubclass(fvf.NonOrientableError, fvf.OrientationError)
    S, G = icosphere_arrays(1)
    G = G.copy()
    G[::5] = G[::5, ::-1]  # an orientable mesh with faces flipped: the fix is named
    with pytest.raises(fvf.OrientationError, match="orient_faces") as caught:
        fvf.TriMesh(S, G)
    assert not isinstance(caught.value, fvf.NonOrientableError)
    # a Moebius strip next to a fine sphere: only the strip's faces are named
    S, G = icosphere_arrays(0)
    with pytest.raises(fvf.OrientationError, match=r"faces \[20, 21, .*\(20 in all\)"):
        fvf.orient_faces(np.vstack([S, V + 5]), np.vstack([G, F + len(S)]))
    with pytest.raises(fvf.NonManifoldError, match=r"\(0, 1\).*split_nonmanifold_edges"):
        fvf.orient_faces(*book())


# ---------------------------------------------------------------------------- vertices
def test_remove_duplicate_vertices_welds_a_triangle_soup():
    V, F = icosphere_arrays(2)
    soup = V[F].reshape(-1, 3)  # OBJ-like: every face has its own three vertices
    S = np.arange(len(soup)).reshape(-1, 3)
    soup_f, S_f = frozen(soup, S)
    with pytest.warns(fvf.DuplicateVertexWarning, match="triangle soup.*remove_duplicate"):
        assert fvf.TriMesh(soup, S).n_components == len(F)  # valid, but 320 loose triangles
    r = fvf.remove_duplicate_vertices(soup_f, S_f)
    check_maps(soup, S, r)
    mesh = fvf.TriMesh(r.vertices, r.faces)
    assert (mesh.n_vertices, mesh.n_components, mesh.is_closed) == (len(V), 1, True)
    # first occurrences are kept in order, and the weld is the original mesh renumbered
    assert (np.diff(r.vertex_origin) > 0).all()
    perm = r.vertex_map[np.arange(len(soup))]
    np.testing.assert_array_equal(r.faces, perm[S])
    f_old = positional_function(soup)
    np.testing.assert_array_equal(r.vertex_values(f_old), positional_function(r.vertices))
    np.testing.assert_array_equal(f_old, r.vertex_values(f_old)[r.vertex_map])
    assert "960 -> 162 vertices" in r.log[0]
    report = mesh_report(soup, S)
    assert report["duplicate_vertices"] == len(soup) - len(V) and report["ok"]
    assert "fvf.remove_duplicate_vertices(V, F)" in report["hints"][0]


def test_remove_duplicate_vertices_tolerance_and_signed_zero(rng):
    V, F = icosphere_arrays(1)
    soup = V[F].reshape(-1, 3)
    S = np.arange(len(soup)).reshape(-1, 3)
    noisy = soup + 1e-10 * rng.standard_normal(soup.shape)
    assert len(fvf.remove_duplicate_vertices(noisy, S).vertices) == len(soup)
    r = fvf.remove_duplicate_vertices(noisy, S, tol=1e-8)
    assert len(r.vertices) == len(V)
    check_maps(noisy, S, r, atol=2e-8 * np.sqrt(12))
    assert np.abs(r.vertices[r.vertex_map] - noisy).max() < 1e-8 * 2 * np.sqrt(3)
    fvf.TriMesh(r.vertices, r.faces)
    X = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [-0.0, 0, -0.0]])
    r = fvf.remove_duplicate_vertices(X, [[0, 1, 2], [3, 2, 1]])
    np.testing.assert_array_equal(r.vertex_map, [0, 1, 2, 0])
    with pytest.raises(fvf.NonFiniteError, match=r"vertices \[1\]"):
        fvf.remove_duplicate_vertices([[0, 0, 0], [np.nan, 0, 0], [0, 1, 0]], [[0, 1, 2]], tol=0.1)
    with pytest.raises(ValueError, match="tol"):
        fvf.remove_duplicate_vertices(X, [[0, 1, 2]], tol=-1)


def test_welding_can_create_degenerate_faces_which_are_named():
    X = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0]])
    r = fvf.remove_duplicate_vertices(X, [[0, 1, 2], [0, 1, 3]])
    assert "faces [1] (1 in all) now repeat a vertex" in r.log[0]
    assert "remove_degenerate_faces" in r.log[0]


def test_remove_unreferenced_vertices_maps():
    V, F = icosphere_arrays(1)
    extra = np.vstack([[[5.0, 5, 5]], V, [[6.0, 6, 6]]])
    r = fvf.remove_unreferenced_vertices(extra, F + 1)
    check_maps(extra, F + 1, r)
    assert r.vertex_map[0] == r.vertex_map[-1] == -1
    np.testing.assert_array_equal(r.faces, F)


# ---------------------------------------------------------------------------- faces
def test_remove_duplicate_faces_including_flipped_and_rotated(rng):
    V, F = icosphere_arrays(1)
    idx = rng.choice(len(F), 9, replace=False)
    copies = F[idx].copy()
    copies[:3] = copies[:3][:, ::-1]  # flipped duplicates
    copies[3:6] = np.roll(copies[3:6], 1, axis=1)  # same orientation, rotated
    G = np.vstack([F, copies])
    with pytest.raises(fvf.NonManifoldError, match="more than two faces"):
        fvf.TriMesh(V, G)
    r = fvf.remove_duplicate_faces(*frozen(V, G))
    check_maps(V, G, r)
    np.testing.assert_array_equal(r.faces, F)
    np.testing.assert_array_equal(r.face_map[len(F) :], -1)
    assert "(3 of them in the opposite order)" in r.log[0]
    # a copy that comes first wins: the kept face is the lowest index, in its own order
    r = fvf.remove_duplicate_faces(V, np.vstack([copies[:1], F]))
    np.testing.assert_array_equal(r.faces[0], copies[0])
    assert r.face_map[1 + idx[0]] == -1
    with pytest.raises(fvf.OrientationError):
        fvf.TriMesh(r.vertices, r.faces)  # the flipped copy was first: orient_faces next
    fvf.TriMesh(*fvf.orient_faces(r.vertices, r.faces)[:2])


def test_a_flipped_duplicate_pillow_is_a_problem_though_trimesh_accepts_it():
    V = np.eye(3)
    F = np.array([[0, 1, 2], [0, 2, 1]])
    assert fvf.TriMesh(V, F).euler_characteristic == 2  # a closed surface of zero volume
    report = mesh_report(V, F)
    assert not report["ok"] and "fvf.remove_duplicate_faces(V, F)" in report["problems"][0]
    r = fvf.remove_duplicate_faces(V, F)
    np.testing.assert_array_equal(r.faces, F[:1])
    np.testing.assert_array_equal(r.face_map, [0, -1])


def test_remove_degenerate_faces_repeated_indices_and_zero_area():
    V, F = icosphere_arrays(1)
    mid = (V[F[0, 0]] + V[F[0, 1]]) / 2  # a new vertex on edge (F0, F1): zero-area face
    X = np.vstack([V, [mid]])
    G = np.vstack([F[:5], [[3, 3, 7]], F[5:], [[F[0, 0], len(V), F[0, 1]], [1, 2, 1]]])
    with pytest.raises(fvf.MeshIndexError, match="repeat a vertex"):
        fvf.TriMesh(X, G)
    with pytest.raises(fvf.DegenerateFaceError, match="zero area"):
        fvf.TriMesh(X, np.vstack([F, [[F[0, 0], len(V), F[0, 1]]]]))
    r = fvf.remove_degenerate_faces(*frozen(X, G))
    check_maps(X, G, r)
    np.testing.assert_array_equal(r.faces, F)
    dropped = np.flatnonzero(r.face_map < 0)
    np.testing.assert_array_equal(dropped, [5, len(G) - 2, len(G) - 1])
    assert f"vertices [{len(V)}] (1 in all) are now unreferenced" in r.log[0]
    with pytest.raises(fvf.UnreferencedVertexError):
        fvf.TriMesh(r.vertices, r.faces)
    fixed = fvf.repair_mesh(X, G)
    check_maps(X, G, fixed)
    assert fvf.TriMesh(fixed.vertices, fixed.faces).n_faces == len(F)
    # a looser threshold drops needles too
    thin = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 1e-6, 0]])
    assert not fvf.remove_degenerate_faces(thin, [[0, 1, 2]]).changed
    assert fvf.remove_degenerate_faces(thin, [[0, 1, 2]], area_rtol=1e-5).faces.shape == (0, 3)


# ---------------------------------------------------------------------------- non-manifold
def test_split_two_cones_touching_at_the_apex():
    V, F = two_cones()
    assert signed_volume(*cone()) > 0
    with pytest.raises(fvf.NonManifoldError, match=r"vertices \[0\].*2 separate fans"):
        fvf.TriMesh(V, F)
    r = fvf.split_nonmanifold_vertices(*frozen(V, F))
    check_maps(V, F, r)
    np.testing.assert_array_equal(r.vertex_origin, np.append(np.arange(len(V)), 0))
    np.testing.assert_array_equal(r.vertex_map, np.arange(len(V)))
    mesh = fvf.TriMesh(r.vertices, r.faces)
    assert mesh.n_components == 2 and mesh.euler_characteristic == 4 and mesh.is_closed
    # the fan with the lowest corner (face 0, the upper cone) keeps index 0
    assert (r.faces[: len(F) // 2] != len(V)).all() and (r.faces[len(F) // 2 :] != 0).all()
    f = positional_function(V)
    np.testing.assert_array_equal(r.vertex_values(f), positional_function(r.vertices))
    assert "split vertices [0] (1 in all)" in r.log[0]


def test_split_a_vertex_with_three_fans():
    V, F = bowtie()
    r = fvf.split_nonmanifold_vertices(V, F)
    check_maps(V, F, r)
    np.testing.assert_array_equal(r.vertex_origin[len(V) :], [0, 0])
    np.testing.assert_array_equal(r.faces[:, 0], [0, len(V), len(V) + 1])
    assert fvf.TriMesh(r.vertices, r.faces).n_components == 3
    # works on inconsistently oriented input too (fans are found by vertex identity)
    G = np.vstack([F, [[1, 2, 7]]])  # runs 1 -> 2 like face 0
    X = np.vstack([V, [[2.0, 0.5, 0]]])
    r = fvf.split_nonmanifold_vertices(X, G)
    assert len(r.vertices) == len(X) + 2


def test_nonmanifold_edges_are_named_and_cut():
    V, F = book()
    with pytest.raises(fvf.NonManifoldError, match=r"\(0, 1\).*split_nonmanifold_edges"):
        fvf.split_nonmanifold_vertices(V, F)
    r = fvf.split_nonmanifold_edges(*frozen(V, F))
    check_maps(V, F, r)
    mesh = fvf.TriMesh(r.vertices, r.faces)
    assert mesh.n_components == 3 and mesh.n_vertices == 9
    np.testing.assert_array_equal(np.sort(r.vertex_origin[5:]), [0, 0, 1, 1])
    assert "cut along edges [(0, 1)]" in r.log[0]
    # a duplicated face is the usual cause: the message says so
    S, G = icosphere_arrays(0)
    with pytest.raises(fvf.NonManifoldError, match=r"faces \[20\].*remove_duplicate_faces"):
        fvf.split_nonmanifold_vertices(S, np.vstack([G, G[3]]))
    with pytest.raises(fvf.NonManifoldError, match="remove_duplicate_faces"):
        fvf.orient_faces(S, np.vstack([G, G[3]]))


# ---------------------------------------------------------------------------- everything at once
def messy_scan(rng):
    """A sphere as an unwelded soup, with flips, duplicates, slivers, orphans, a bow-tie."""
    V, F = icosphere_arrays(2)
    G, _ = flip_some(F, rng, 50)
    G = np.vstack([G, G[:4], G[4:6][:, ::-1]])  # duplicated and flipped-duplicated faces
    soup = V[G].reshape(-1, 3)
    S = np.arange(len(soup)).reshape(-1, 3)
    W, H = two_cones()
    X = np.vstack([soup, W + 5.0, [[7.0, 7, 7]]])  # plus an orphan vertex
    T = np.vstack([S, H + len(soup), [[0, 0, 1]]])
    return X, T, (V, F)


def test_repair_mesh_cleans_a_messy_scan(rng):
    X, T, (V, F) = messy_scan(rng)
    before = mesh_report(X, T)  # a soup: its flips and duplicates show once welded
    said = " ".join(before["problems"] + before["hints"])
    welded = fvf.remove_duplicate_vertices(X, T)
    said += " ".join(mesh_report(welded.vertices, welded.faces)["problems"])
    for fn in [
        "remove_unreferenced_vertices",
        "remove_duplicate_vertices",
        "remove_degenerate_faces",
        "remove_duplicate_faces",
        "split_nonmanifold_vertices",
        "orient_faces",
    ]:
        assert f"fvf.{fn}(V, F)" in said, fn
    r = fvf.repair_mesh(*frozen(X, T))
    check_maps(X, T, r)
    mesh = fvf.TriMesh(r.vertices, r.faces)
    assert mesh.n_components == 3 and mesh.is_closed
    assert mesh.n_vertices == len(V) + len(two_cones()[0]) + 1  # apex split in two
    assert mesh.n_faces == len(F) + len(two_cones()[1])
    assert signed_volume(r.vertices, r.faces) > 0
    assert mesh_report(r.vertices, r.faces)["problems"] == []
    assert len(r.log) == 6 and r.log[0].startswith("remove_duplicate_vertices")
    # the composed maps equal applying the steps one by one
    manual = fvf.repair_mesh(X, T, steps=())
    for name in fvf.mesh.repair.DEFAULT_REPAIR_STEPS:
        manual = manual.then(REPAIR_STEPS[name](manual.vertices, manual.faces))
    for field in ["vertices", "faces", "vertex_origin", "vertex_map", "face_origin", "flipped"]:
        np.testing.assert_array_equal(getattr(manual, field), getattr(r, field))
    with pytest.raises(ValueError, match="unknown repair steps"):
        fvf.repair_mesh(X, T, steps=["weld"])


# ---------------------------------------------------------------------------- error messages


@pytest.mark.parametrize(
    ("build", "error", "fix"),
    [
        (
            lambda: (np.vstack([np.eye(3), [[5, 5, 5]]]), [[0, 1, 2]]),
            "UnreferencedVertexError",
            "remove_unreferenced_vertices",
        ),
        pytest.param(lambda: (np.eye(3), [[0, 1, 1]]), "MeshIndexError", "remove_degenerate_faces"),
        pytest.param(
            lambda: ([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]], [[0, 1, 2]]),
            "DegenerateFaceError",
            "remove_degenerate_faces",
        ),
        pytest.param(
            lambda: (icosphere_arrays(0)[0], np.vstack([icosphere_arrays(0)[1]] * 2)),
            "NonManifoldError",
            "remove_duplicate_faces",
        ),
        pytest.param(book, "NonManifoldError", "split_nonmanifold_edges"),
        pytest.param(two_cones, "NonManifoldError", "split_nonmanifold_vertices"),
        pytest.param(
            lambda: (
                icosphere_arrays(0)[0],
                icosphere_arrays(0)[1][[0, 1, 2]][:, ::-1].tolist()
                + icosphere_arrays(0)[1][3:].tolist(),
            ),
            "OrientationError",
            "orient_faces",
        ),
    ],
)
def test_trimesh_error_names_the_repair(build, error, fix):
    V, F = build()
    with pytest.raises(getattr(fvf, error)) as info:
        fvf.TriMesh(V, F)
    assert f"fvf.{fix}" in str(info.value)


@pytest.mark.parametrize(
    ("build", "fix"),
    [
        (
            lambda: (np.vstack([np.eye(3), [[5, 5, 5]]]), [[0, 1, 2]]),
            "remove_unreferenced_vertices",
        ),
        (lambda: (np.eye(3), [[0, 1, 1], [0, 1, 2]]), "remove_degenerate_faces"),
        (
            lambda: ([[0, 0, 0], [1, 0, 0], [2, 0, 0.0], [0, 1, 0]], [[0, 1, 2], [0, 1, 3]]),
            "remove_degenerate_faces",
        ),
        (
            lambda: (icosphere_arrays(0)[0], np.vstack([icosphere_arrays(0)[1]] * 2)),
            "remove_duplicate_faces",
        ),
        (book, "split_nonmanifold_edges"),
        (two_cones, "split_nonmanifold_vertices"),
        (bowtie, "split_nonmanifold_vertices"),
        (
            lambda: (
                icosphere_arrays(0)[0],
                icosphere_arrays(0)[1][:, ::-1][[0, 1]].tolist()
                + icosphere_arrays(0)[1][2:].tolist(),
            ),
            "orient_faces",
        ),
    ],
)
def test_mesh_report_names_the_repair_for_each_problem(build, fix):
    V, F = build()
    report = mesh_report(V, F)
    assert not report["ok"]
    assert any(f"Fix: {fix}" in p or f"fvf.{fix}(" in p for p in report["problems"])
    steps = list(fvf.mesh.repair.DEFAULT_REPAIR_STEPS)
    steps.insert(steps.index("split_nonmanifold_vertices"), "split_nonmanifold_edges")
    r = fvf.repair_mesh(V, F, steps=steps)
    assert mesh_report(r.vertices, r.faces)["problems"] == []
    fvf.TriMesh(r.vertices, r.faces)


def test_mesh_report_moebius_and_nonfinite():
    report = mesh_report(*moebius())
    assert report["orientation"] == "non-orientable"
    assert any("non-orientable" in p for p in report["problems"])
    report = mesh_report([[0, 0, 0], [np.inf, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    assert report["problems"][0].startswith("NonFiniteError: vertices [1]")


def test_docs_repair_md_runs(capsys):
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "repair.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) == 2
    namespace: dict = {}
    for i, block in enumerate(blocks):
        exec(compile(block, f"docs/repair.md block {i}", "exec"), namespace)
    out = capsys.readouterr().out
    assert "remove_duplicate_vertices: merged" in out and "faces flipped" in out


# ---------------------------------------------------------------------------- property test
ALL_DEFAULT_AND_CUT = [*fvf.mesh.repair.DEFAULT_REPAIR_STEPS[:3], "split_nonmanifold_edges"]
ALL_DEFAULT_AND_CUT += list(fvf.mesh.repair.DEFAULT_REPAIR_STEPS[3:])


@settings(derandomize=True, max_examples=300, deadline=None)
@given(
    n=st.integers(3, 10),
    faces=st.lists(st.tuples(*[st.integers(0, 9)] * 3), min_size=1, max_size=24),
    dup=st.integers(0, 3),
    seed=st.integers(0, 2**32 - 1),
)
def test_random_broken_meshes_repair_to_a_trimesh_or_a_documented_error(n, faces, dup, seed):
    """Random faces on a few points (non-manifold, flipped, duplicated, degenerate, soups)."""
    rng = np.random.default_rng(seed)
    V = rng.standard_normal((n, 3))
    V = np.vstack([V, V[:dup]])  # some coincident vertices
    F = np.array(faces) % len(V)
    r = None
    try:
        r = fvf.repair_mesh(*frozen(V, F), steps=ALL_DEFAULT_AND_CUT)
    except fvf.OrientationError as exc:
        assert "non-orientable" in str(exc)
    except fvf.NonManifoldError as exc:
        assert "still shared" in str(exc)
    report = mesh_report(V, F)
    if report["ok"]:  # no problems: TriMesh accepts the arrays as they are
        fvf.TriMesh(V, F)
    if r is not None and not r.changed:
        assert report["ok"]
    if r is None:
        return
    check_maps(V, F, r)
    if len(r.faces) == 0:
        with pytest.raises(fvf.MeshShapeError, match="empty"):
            fvf.TriMesh(r.vertices, r.faces)
        return
    mesh = fvf.TriMesh(r.vertices, r.faces)
    assert mesh_report(r.vertices, r.faces)["problems"] == []
    assert fvf.repair_mesh(mesh.vertices, mesh.faces, steps=ALL_STEPS[1:]).log == ()


def test_a_t_junction_is_closed_not_left_as_a_slit():
    """A zero-area face whose apex lies on its long edge (an exporter's T-junction): the
    face across that edge is split at the apex, so the sphere stays closed (dropping the
    face alone leaves a 3-vertex slit, a boundary loop on one line)."""
    s = fvf.icosphere(2)
    V, F = s.vertices.copy(), s.faces.copy()
    a, b, c = F[0]
    V[c] = 0.25 * V[a] + 0.75 * V[b]
    fixed = fvf.repair_mesh(V, F)
    mesh = fixed.mesh
    assert mesh.is_closed and mesh.euler_characteristic == 2
    assert mesh.n_vertices == s.n_vertices and mesh.n_faces == s.n_faces
    assert fixed.face_map[0] == -1 and "split_t_junctions" in fixed.log[0]
    across = np.flatnonzero(np.bincount(fixed.face_origin, minlength=F.shape[0]) == 2)
    assert across.size == 1 and set(F[across[0]]) >= {a, b} and c not in F[across[0]]
    assert np.isclose(mesh.total_area, s.total_area - 0.0, rtol=0.05)
    dropped = fvf.repair_mesh(V, F, ["remove_degenerate_faces"]).mesh
    assert not dropped.is_closed and set(dropped.boundary_vertices) == {a, b, c}
    same = fvf.split_t_junctions(s.vertices, s.faces)
    assert not same.changed and np.array_equal(same.faces, s.faces)


def test_two_zero_area_faces_sharing_their_long_edge_are_flipped_then_split():
    """A pocket: u, a, b, w on one line, the zero-area faces (u, w, a) and (w, u, b) share
    the long edge uw, with p's fan above and q's below. Flipping uw and splitting the two
    faces across the new long edges gives the six faces of the diamond with the line
    u-a-b-w as edges: the area (1), orientation and boundary kept."""
    V = np.array([[0, 0, 0], [0.3, 0, 0], [0.6, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0]], float)
    u, a, b, w, p, q = range(6)
    F = np.array([[u, a, p], [a, w, p], [u, q, b], [b, q, w], [u, w, a], [w, u, b]])
    fixed = fvf.split_t_junctions(V, F)
    assert "flipped the long edge shared by each pair of zero-area faces in [4, 5]" in fixed.log[0]
    mesh = fvf.TriMesh(fixed.vertices, fixed.faces)
    assert mesh.n_faces == 6 and mesh.euler_characteristic == 1
    assert mesh.n_boundary_loops == 1
    assert np.allclose(mesh.face_normals, [0, 0, 1])  # every face oriented as the input's
    assert mesh.total_area == pytest.approx(1.0)
    line = {tuple(sorted(e)) for e in mesh.edges.tolist()}
    assert {(u, a), (a, b), (b, w)} <= line and (u, w) not in line
    assert fixed.face_map[4:].tolist() == [-1, -1]  # flipped, then removed
    assert sorted(np.bincount(fixed.face_origin, minlength=4).tolist()) == [1, 1, 2, 2]


def test_a_split_that_would_add_an_edge_the_mesh_has_is_not_made():
    """A flat pillow: (u, w, a) with a on uw, the face (w, u, p) across uw, and (u, a, p),
    (a, w, p) folded over it. Splitting (w, u, p) at a would make a second edge ap, shared
    by four faces; the zero-area face is left for remove_degenerate_faces instead."""
    V = np.array([[0, 0, 0], [1, 0, 0], [0.5, 0, 0], [0.5, 1, 0]], float)
    u, w, a, p = range(4)
    F = np.array([[w, u, p], [u, w, a], [u, a, p], [a, w, p]])
    fixed = fvf.split_t_junctions(V, F)
    assert not fixed.changed and np.array_equal(fixed.faces, F)
