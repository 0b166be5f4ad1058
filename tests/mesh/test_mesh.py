"""TriMesh: cached geometry, topology against MANIFEST.md, frames and converters."""

import numpy as np
import pytest

import fvf
from conftest import BOUNDARY_SHARED, CLOSED_SHARED, load_shared


@pytest.mark.parametrize("name, chi", CLOSED_SHARED)
def test_shared_closed_topology(name, chi):
    mesh = load_shared(name)
    assert mesh.is_closed and mesh.n_components == 1
    assert mesh.euler_characteristic == chi
    assert mesh.genus == (2 - chi) // 2
    assert mesh.n_boundary_loops == 0


@pytest.mark.parametrize("name, chi, loops", BOUNDARY_SHARED + [("stanford-bunny.obj", -3, 5)])
def test_shared_boundary_topology(name, chi, loops):
    mesh = load_shared(name)
    assert not mesh.is_closed
    assert mesh.euler_characteristic == chi
    assert mesh.n_boundary_loops == loops
    assert mesh.genus == 0


def test_generated_shapes():
    s = fvf.icosphere(3)
    assert (s.n_vertices, s.n_faces) == (642, 1280) and s.genus == 0
    assert np.allclose(np.linalg.norm(s.vertices, axis=1), 1)
    # outward normals
    assert (np.einsum("ij,ij->i", s.face_normals, s.face_centroids) > 0).all()
    t = fvf.torus(20, 10)
    assert t.genus == 1 and t.is_closed
    d = fvf.disk(4, 6)
    assert d.n_boundary_loops == 1 and (d.face_normals[:, 2] > 0).all()
    j = fvf.jittered_sphere(2, 0.3, seed=3)
    assert np.array_equal(j.vertices, fvf.jittered_sphere(2, 0.3, seed=3).vertices)


def test_edges_and_adjacency(closed):
    E, FE, EF, FA = closed.edges, closed.face_edges, closed.edge_faces, closed.face_adjacency
    F = closed.faces
    assert (E[:, 0] < E[:, 1]).all() and closed.n_edges * 2 == 3 * closed.n_faces
    for a in range(3):  # edge opposite corner a joins the other two corners
        ends = np.sort(F[:, [(a + 1) % 3, (a + 2) % 3]], axis=1)
        assert np.array_equal(E[FE[:, a]], ends)
    assert (EF >= 0).all() and (FA >= 0).all()
    # adjacency is symmetric and neighbours share the edge
    t = np.arange(closed.n_faces)
    for a in range(3):
        nb = FA[:, a]
        assert (FA[nb] == t[:, None]).any(axis=1).all()
    # column 0 of edge_faces traverses the edge from E[:, 0] to E[:, 1]
    f0 = F[EF[:, 0]]
    pos = np.argmax(f0 == E[:, :1], axis=1)
    assert np.array_equal(f0[np.arange(len(E)), (pos + 1) % 3], E[:, 1])


def test_edge_ids_finds_each_side_in_either_order_and_nothing_else(closed, rng):
    E = closed.edges
    pick = rng.choice(closed.n_edges, 50, replace=False)
    flip = rng.random(50) < 0.5
    pairs = np.where(flip[:, None], E[pick][:, ::-1], E[pick])
    assert np.array_equal(closed.edge_ids(pairs), pick)
    F = closed.faces
    n = closed.n_vertices
    joined = set(map(tuple, E.tolist()))
    a, b = rng.integers(0, n, 200), rng.integers(0, n, 200)
    none = [(i, j) for i, j in zip(a, b, strict=True) if (min(i, j), max(i, j)) not in joined]
    assert (closed.edge_ids(np.array(none)) == -1).all()
    assert (closed.edge_ids([[-1, F[0, 0]], [F[0, 0], n], [n, n + 1]]) == -1).all()
    assert closed.edge_ids(np.zeros((0, 2), np.int64)).shape == (0,)


def test_face_bases_and_converters(closed, rng):
    B, N = closed.face_bases, closed.face_normals
    assert B.shape == (closed.n_faces, 2, 3)
    gram = np.einsum("tij,tkj->tik", B, B)
    assert np.abs(gram - np.eye(2)).max() < 1e-12
    assert np.abs(np.einsum("tij,tj->ti", B, N)).max() < 1e-12
    u = closed.project_tangent(rng.standard_normal((closed.n_faces, 3)))
    assert np.abs(closed.from_local(closed.to_local(u)) - u).max() < 1e-12
    assert np.abs(closed.from_complex(closed.to_complex(u)) - u).max() < 1e-12
    z = rng.standard_normal(closed.n_faces) + 1j * rng.standard_normal(closed.n_faces)
    assert np.abs(closed.to_complex(closed.from_complex(z)) - z).max() < 1e-12


def test_immutable_and_cached():
    mesh = fvf.icosphere(1)
    with pytest.raises(AttributeError, match="immutable"):
        mesh.vertices = np.zeros((3, 3))
    with pytest.raises(ValueError, match="read-only"):
        mesh.vertices[0, 0] = 5.0
    with pytest.raises(ValueError, match="read-only"):
        mesh.face_areas[0] = 1.0
    assert fvf.grad(mesh) is fvf.grad(mesh)  # cached once
    G = fvf.grad(mesh)
    with pytest.raises(ValueError, match="read-only"):
        G.data[0] = 1.0
    X = np.array(mesh.vertices)
    X[0] = 7.0  # the caller's array is copied at construction
    assert fvf.TriMesh(X, mesh.faces).vertices[0, 0] == 7.0 and mesh.vertices[0, 0] != 7.0


def test_components_and_repr():
    a, b = fvf.icosphere(1), fvf.icosphere(1)
    mesh = fvf.TriMesh(
        np.vstack([a.vertices, b.vertices + 3]), np.vstack([a.faces, b.faces + a.n_vertices])
    )
    assert mesh.n_components == 2 and mesh.euler_characteristic == 4
    assert set(np.unique(mesh.vertex_components)) == {0, 1}
    with pytest.raises(ValueError, match="per component"):
        _ = mesh.genus
    assert "n_faces=160" in repr(mesh)


def test_vertex_pattern_assembly_matches_coo(closed, rng):
    import scipy.sparse as sp

    K = rng.standard_normal((closed.n_faces, 3, 3))
    d = rng.standard_normal(closed.n_vertices)
    A = closed.assemble_vertex_operator(K, diagonal=d)
    F = closed.faces
    rows = np.repeat(F, 3, axis=1).ravel()
    cols = np.tile(F, (1, 3)).ravel()
    ref = sp.coo_array((K.ravel(), (rows, cols)), shape=A.shape).tocsr() + sp.diags_array(d)
    assert abs(A - ref).max() < 1e-12
    assert A.has_sorted_indices


def test_builtin_spot_is_the_bundled_file_as_read_mesh_reads_it():
    """fvf.mesh.builtin reads spot.obj itself (the mesh layer sits below the file layer)."""
    mesh = fvf.mesh.builtin.spot()
    V, F = fvf.read_mesh(fvf.mesh.builtin.spot_path())
    assert np.array_equal(mesh.vertices, V) and np.array_equal(mesh.faces, F)
    assert mesh.vertices.dtype == np.float64 and mesh.faces.dtype == np.int64
    assert fvf.spot is fvf.mesh.spot is fvf.examples.spot is fvf.mesh.builtin.spot


@pytest.mark.parametrize("name", ["fig12_fields", "compressible_case"])
def test_scenes_moved_to_examples_still_resolve_from_mesh_builtin(name):
    with pytest.warns(DeprecationWarning, match=rf"fvf\.examples\.{name}"):
        old = getattr(fvf.mesh.builtin, name)
    assert old is getattr(fvf.examples, name)
    with pytest.raises(AttributeError):
        fvf.mesh.builtin.no_such_scene  # noqa: B018
