"""fvf.match on any two meshes: specks (small components of the input) dropped by the
same rule as the pieces the non-manifold cut makes, several large components refused
with their sizes, and the map kept good on a shape with holes, a scaled and moved copy
and a copy with specks (generated, seeded; the FAUST_r figures are in
docs/correspondence.md, *Any two meshes*, made by ``benchmarks/any_mesh.py``).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import fvf
from conftest import import_benchmark
from corpus import blob
from fvf.mesh.prepared import prepare_mesh

any_mesh = import_benchmark("any_mesh")

TETRA = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
TETRA_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


@pytest.fixture(scope="module")
def shape():
    return blob()  # 642 vertices, no symmetry


def with_tetra_specks(mesh: fvf.TriMesh, count: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """The mesh's arrays with ``count`` small tetrahedra (4 vertices each) floating beside
    its first vertices, appended."""
    V, F = [mesh.vertices], [mesh.faces]
    size = 0.5 * mesh.mean_edge_length
    for j in range(count):
        V.append(mesh.vertices[j] + 2 * size + size * TETRA)
        F.append(TETRA_FACES + mesh.n_vertices + 4 * j)
    return np.vstack(V), np.vstack(F)


def test_specks_are_dropped_with_a_warning_and_stand_for_the_nearest_vertex(shape):
    V, F = with_tetra_specks(shape)
    n = shape.n_vertices
    with pytest.warns(fvf.SmallComponentWarning, match=r"dropped 2 small component.*8 vertices"):
        p = prepare_mesh(V, F, name="scan")
    assert p.mesh.n_vertices == n and p.n_input == n + 8
    assert np.array_equal(p.mesh.vertices, shape.vertices)
    assert np.array_equal(p.mesh_to_input, np.arange(n))
    assert np.array_equal(p.input_to_mesh[:n], np.arange(n))
    _, nearest = fvf.mesh.prepared.cKDTree(shape.vertices).query(V[n:])
    assert np.array_equal(p.input_to_mesh[n:], nearest)  # the convention of dropped pieces
    assert p.changed and "small component" in p.log[0]


@pytest.mark.parametrize("cut", ["soup", "patches"])
def test_a_soup_or_patches_are_welded_not_dropped_as_specks(shape, cut):
    """A triangle soup (every face its own three vertices) and a mesh exported in patches
    (vertices repeated along the patch borders) are one surface once welded: each of
    their pieces is under the speck size, and all but one were dropped (the soup of Spot
    kept one triangle, then "too few vertices: subdivide the mesh"). Every input vertex
    stands for the welded vertex at its position."""
    F0 = shape.faces
    if cut == "soup":
        V = shape.vertices[F0].reshape(-1, 3)
        F = np.arange(len(V)).reshape(-1, 3)
    else:  # 8 patches by face index, each with its own copies of its vertices
        patch = np.arange(len(F0)) * 8 // len(F0)
        V, F, base = [], [], 0
        for k in range(8):
            used, local = np.unique(F0[patch == k], return_inverse=True)
            V.append(shape.vertices[used])
            F.append(local.reshape(-1, 3) + base)
            base += used.size
        V, F = np.vstack(V), np.vstack(F)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fvf.DuplicateVertexWarning)
        p = prepare_mesh(V, F, name="scan")
    assert p.mesh.n_vertices == shape.n_vertices and p.mesh.n_faces == len(F0)
    assert np.array_equal(p.mesh.vertices[p.input_to_mesh], V)


def test_specks_on_a_mesh_that_also_needs_repair(shape):
    """A non-manifold flap (cut off by the repair) and specks of the input: both dropped
    by the one rule, every input vertex indexed."""
    V, F = with_tetra_specks(shape, 1)
    a, b = shape.edges[0]
    tip = V[[a, b]].mean(0) + 0.05 * shape.mean_edge_length
    V2, F2 = np.vstack([V, tip]), np.vstack([F, [[a, b, len(V)]]])
    with pytest.warns(fvf.SmallComponentWarning):
        p = prepare_mesh(V2, F2)
    assert p.mesh.n_vertices == shape.n_vertices and p.n_input == len(V2)
    assert np.array_equal(p.input_to_mesh[: shape.n_vertices], np.arange(shape.n_vertices))
    assert p.input_to_mesh[-1] in (a, b)
    assert p.input_to_mesh.min() >= 0


def test_two_shapes_in_one_mesh_raise_with_their_sizes(shape):
    small = fvf.icosphere(1)  # 42 vertices: more than 1 % of 642 + 42
    V = np.vstack([shape.vertices, small.vertices * 0.2 + 5.0])
    F = np.vstack([shape.faces, small.faces + shape.n_vertices])
    with pytest.raises(fvf.DisconnectedMeshError, match=r"642, 42 vertices.*Fix: match each"):
        prepare_mesh(V, F, name="mesh_2")
    with pytest.raises(fvf.DisconnectedMeshError, match="mesh_1 has 2 connected components"):
        fvf.match((V, F), shape, k=20, k_fit=10)
    # a looser rule lets the second piece go, with the warning
    with pytest.warns(fvf.SmallComponentWarning):
        assert prepare_mesh(V, F, max_dropped_fraction=0.1).mesh.n_vertices == 642


def _error(shape, p2p, truth):
    return fvf.mean_geodesic_error(shape, p2p, truth)


def test_match_with_specks_keeps_the_map(shape):
    V, F = with_tetra_specks(shape)
    n = shape.n_vertices
    with pytest.warns(fvf.SmallComponentWarning):
        p = fvf.match(shape, (V, F), k=30, k_fit=10)
    assert p.shape == (n + 8,)
    assert np.array_equal(p[:n], np.arange(n))  # measured: exact
    _, nearest = fvf.mesh.prepared.cKDTree(shape.vertices).query(V[n:])
    assert np.array_equal(p[n:], p[nearest])  # a speck vertex: its nearest vertex's image
    with pytest.warns(fvf.SmallComponentWarning):  # specks on mesh 1: never an image
        q = fvf.match((V, F), shape, k=30, k_fit=10)
    assert np.array_equal(q, np.arange(n))


def test_match_with_holes_keeps_the_map(shape):
    """Three small holes (balls of radius 0.03 √area): the kept vertices still map near
    themselves (measured mean 0.0011, max 0.052 / √area). Larger holes break the map on
    this smooth blob (docs/correspondence.md, *Any two meshes*)."""
    V2, F2, to_new = any_mesh.cut_holes(shape.vertices, shape.faces, radius=0.03, seed=1)
    assert V2.shape[0] < shape.n_vertices
    assert fvf.TriMesh(V2, F2).n_boundary_loops == 3
    kept = np.flatnonzero(to_new >= 0)
    p = fvf.match(shape, (V2, F2), k=40, k_fit=15)
    err = fvf.geodesic_errors(shape, p[to_new[kept]], kept)
    assert err.mean() < 0.01 and err.max() < 0.1, (err.mean(), err.max())


def test_match_of_a_scaled_moved_copy_is_exact(shape):
    """× 1000, rotated, translated and renumbered: every vertex to its own."""
    V, F, _ = any_mesh.scaled_and_moved(shape.vertices, shape.faces, seed=4)
    perm = np.random.default_rng(5).permutation(shape.n_vertices)  # new i = old perm[i]
    p = fvf.match(shape, (V[perm], np.argsort(perm)[F]), k=30, k_fit=10)
    assert np.array_equal(p, perm)


def test_match_warns_from_the_callers_line(shape):
    V, F = with_tetra_specks(shape, 1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fvf.match(shape, (V, F), k=20, k_fit=10)
    assert [w.filename for w in caught] == [__file__]
