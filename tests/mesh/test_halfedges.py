"""The sorted half-edge pass (fvf.mesh.halfedges) against independent references.

References: ``np.unique`` for edges, their faces and sides; scipy's connected components
of the corner graph for the fans around each vertex; a COO assembly for the 1-ring
pattern. Checked on the corpus meshes (closed, with boundary, several components) and on
hostile meshes: bow-ties (open fans sharing a vertex), double cones (closed fans sharing a
vertex), a closed and an open fan at one vertex, and fans of several hundred faces.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

import fvf
from conftest import load_shared
from fvf.mesh import halfedges

# ---------------------------------------------------------------------------- references


def reference_edges(F: np.ndarray, n: int):
    """Edges, face_edges, counts and edge corners by np.unique (the former construction)."""
    tail, head = F[:, [1, 2, 0]].ravel(), F[:, [2, 0, 1]].ravel()
    key = np.minimum(tail, head) * n + np.maximum(tail, head)
    uniq, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    edges = np.stack([uniq // n, uniq % n], axis=1)
    corners = np.full((uniq.size, 2), -1, dtype=np.int64)
    corners[inverse, (tail != edges[inverse, 0]).astype(int)] = np.arange(tail.size)
    return edges, inverse.reshape(-1, 3), counts, corners


def reference_fans(F: np.ndarray, corners: np.ndarray, n: int) -> np.ndarray:
    """Fans per vertex: connected components of the corners joined across interior edges."""
    m = F.shape[0]
    c = corners[(corners >= 0).all(axis=1)]
    t0, a0 = np.divmod(c[:, 0], 3)
    t1, a1 = np.divmod(c[:, 1], 3)
    r = np.concatenate([3 * t0 + (a0 + 1) % 3, 3 * t0 + (a0 + 2) % 3])
    k = np.concatenate([3 * t1 + (a1 + 2) % 3, 3 * t1 + (a1 + 1) % 3])
    g = sp.coo_array((np.ones(r.size), (r, k)), shape=(3 * m, 3 * m))
    n_fans, label = connected_components(g, directed=False)
    vertex_of_fan = np.empty(n_fans, dtype=np.int64)
    vertex_of_fan[label] = F.ravel()
    return np.bincount(vertex_of_fan, minlength=n)


def fans_of(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Fans per vertex by the sorted pass (the input must be edge-manifold and oriented)."""
    runs = halfedges.sort_halfedges(F, len(V))
    assert runs.counts.max() <= 2 and halfedges.misoriented_edges(runs).size == 0
    corners = halfedges.edge_corners(runs)
    fans = halfedges.vertex_fans(F, corners, len(V), np.bincount(F.ravel()).max())
    np.testing.assert_array_equal(fans, reference_fans(F, corners, len(V)))
    return fans


# ---------------------------------------------------------------------------- hostile meshes


def fan(k: int, kind: str):
    """k faces around the apex 0, outward oriented.

    ``"cone"``: a closed cone (the ring 1..k and a cap around vertex k + 1 below);
    ``"disk"``: the apex inside a disk bounded by the ring (a closed fan, with boundary);
    ``"wedge"``: the apex on the boundary of k faces over an arc 1..k+1 (an open fan).
    """
    arc = kind == "wedge"
    a = (np.pi if arc else 2 * np.pi) * np.arange(k + arc) / k
    ring = np.column_stack([np.cos(a), np.sin(a), np.zeros(a.size)])
    V = np.vstack([[0.0, 0, 1], ring, [0, 0, -1]])
    i = np.arange(k)
    j = i + 1 if arc else (i + 1) % k
    F = np.column_stack([np.zeros(k, int), i + 1, j + 1])
    if kind == "cone":
        return V, np.vstack([F, np.column_stack([np.full(k, k + 1), j + 1, i + 1])])
    return V[:-1], F


def glued_at_apex(*parts):
    """Copies of (V, F), each moved apart, sharing vertex 0 (every apex sits at 0)."""
    Vs, Fs, offset = [np.zeros((1, 3))], [], 1
    for s, (V, F) in enumerate(parts):
        W = V[1:] - V[0] + [3.0 * (s + 1), 0, 0]
        W[:, 0] *= (-1) ** s
        Fs.append(np.where(F == 0, 0, F - 1 + offset))
        Vs.append(W)
        offset += len(W)
    return np.vstack(Vs), np.vstack(Fs)


HOSTILE = {
    # name: ((V, F), fans at vertex 0)
    "bow-tie (two triangles at a vertex)": (glued_at_apex(fan(1, "wedge"), fan(1, "wedge")), 2),
    "three open fans": (glued_at_apex(fan(1, "wedge"), fan(2, "wedge"), fan(3, "wedge")), 3),
    "double cone (two closed fans)": (glued_at_apex(fan(6, "cone"), fan(7, "cone")), 2),
    "two disks touching at their centres": (glued_at_apex(fan(5, "disk"), fan(6, "disk")), 2),
    "a closed and an open fan": (glued_at_apex(fan(5, "cone"), fan(4, "wedge")), 2),
    "open fan of 700 faces": (fan(700, "wedge"), 1),
    "closed cone of 700 faces": (fan(700, "cone"), 1),
    "cones of 300 and 500 faces": (glued_at_apex(fan(300, "cone"), fan(500, "cone")), 2),
    "open fan of 600, cone of 9": (glued_at_apex(fan(600, "wedge"), fan(9, "cone")), 2),
}


# ---------------------------------------------------------------------------- tests


GENERATED = {
    "icosphere2": lambda: fvf.icosphere(2),
    "torus": lambda: fvf.torus(12, 8),
    "disk": lambda: fvf.disk(5, 6),
    "two components": lambda: fvf.TriMesh(
        np.vstack([fvf.icosphere(1).vertices, fvf.disk(3, 6).vertices + 5.0]),
        np.vstack([fvf.icosphere(1).faces, fvf.disk(3, 6).faces + 42]),
    ),
}
SHARED = ["bunny-lowres.off", "fertility.off", "woody.obj", "camelhead.off", "bob_tri.obj"]
CORPUS = [*GENERATED, *SHARED]


def get_mesh(name: str) -> fvf.TriMesh:
    return GENERATED[name]() if name in GENERATED else load_shared(name)


@pytest.mark.parametrize("name", CORPUS)
def test_sorted_pass_matches_unique(name):
    mesh = get_mesh(name)
    F, n = np.asarray(mesh.faces), mesh.n_vertices
    edges, face_edges, counts, corners = reference_edges(F, n)
    np.testing.assert_array_equal(mesh.edges, edges)
    np.testing.assert_array_equal(mesh.face_edges, face_edges)
    np.testing.assert_array_equal(mesh.edge_corners, corners)
    np.testing.assert_array_equal(mesh.boundary_edges, np.flatnonzero(counts == 1))
    ef = np.where(corners >= 0, corners // 3, -1)
    np.testing.assert_array_equal(mesh.edge_faces, ef)
    across = ef[face_edges]  # (m, 3, 2): the face on each side of each face's edges
    me = np.arange(mesh.n_faces)[:, None]
    np.testing.assert_array_equal(
        mesh.face_adjacency, np.where(across[..., 0] == me, across[..., 1], across[..., 0])
    )
    runs = halfedges.sort_halfedges(F, n)
    np.testing.assert_array_equal(runs.counts, counts)
    # each run holds its edge's half-edges, forward (lo -> hi) ones first
    h = runs.halfedges
    tail, head = (
        F.ravel()[h + halfedges._NEXT_STEP[h % 3]],
        F.ravel()[h + halfedges._PREV_STEP[h % 3]],
    )
    edge_of_run = np.repeat(np.arange(counts.size), counts)
    np.testing.assert_array_equal(np.minimum(tail, head), edges[edge_of_run, 0])
    np.testing.assert_array_equal(np.maximum(tail, head), edges[edge_of_run, 1])
    np.testing.assert_array_equal(runs.backward, tail > head)


@pytest.mark.parametrize("name", ["torus", "disk", "two components", "camelhead.off"])
@pytest.mark.parametrize("path", ["two packed sorts", "argsort"])
def test_sort_fallbacks_give_the_same_pass(name, path, monkeypatch):
    """Keys too wide to pack with their positions: two narrower packed sorts (edge keys
    of huge meshes), or argsort (positions beyond 2³¹). Same results as one packed sort."""
    mesh = get_mesh(name)
    F, n = np.asarray(mesh.faces), mesh.n_vertices
    packed = halfedges.sort_halfedges(F, n)
    ring = halfedges.one_ring(packed.edges, n)
    one_sort = (2 * n * n - 1).bit_length() + (F.size - 1).bit_length()
    monkeypatch.setattr(halfedges, "_INT64_BITS", one_sort - 1 if path != "argsort" else 0)
    assert not halfedges._packs(2 * n * n, F.size)
    assert halfedges._packs(2 * n, F.size) == (path != "argsort")
    fallback = halfedges.sort_halfedges(F, n)
    for a, b in zip(packed, fallback, strict=True):  # no ties: (edge, direction) is unique
        np.testing.assert_array_equal(a, b)
    for a, b in zip(ring, halfedges.one_ring(fallback.edges, n), strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(halfedges.edge_corners(packed), halfedges.edge_corners(fallback))


@pytest.mark.parametrize("name", CORPUS)
def test_twin_map_is_an_involution_on_interior_halfedges(name):
    mesh = get_mesh(name)
    F = np.asarray(mesh.faces).ravel()
    c = mesh.edge_corners
    interior = (c >= 0).all(axis=1)
    twin = np.full(F.size, -1)
    twin[c[interior, 0]] = c[interior, 1]
    twin[c[interior, 1]] = c[interior, 0]
    h = np.flatnonzero(twin >= 0)
    assert h.size == 2 * interior.sum() and (c[~interior] >= 0).sum() == mesh.boundary_edges.size
    np.testing.assert_array_equal(twin[twin[h]], h)
    assert (twin[h] // 3 != h // 3).all()  # in another face
    nxt, prv = halfedges._NEXT_STEP, halfedges._PREV_STEP
    tail, head = F[h + nxt[h % 3]], F[h + prv[h % 3]]
    g = twin[h]
    np.testing.assert_array_equal(F[g + nxt[g % 3]], head)  # the twin runs the other way
    np.testing.assert_array_equal(F[g + prv[g % 3]], tail)


@pytest.mark.parametrize("name", CORPUS)
def test_fans_match_connected_components_on_the_corpus(name):
    mesh = get_mesh(name)
    fans = fans_of(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    assert (fans == 1).all()


@pytest.mark.parametrize("name", list(HOSTILE))
def test_fans_match_connected_components_on_hostile_meshes(name):
    (V, F), at_apex = HOSTILE[name]
    fans = fans_of(V, F)
    assert fans[0] == at_apex
    assert (fans[1:] == 1).all()
    if at_apex == 1:
        fvf.TriMesh(V, F)  # a manifold vertex of valence 600-700 (10 doubling rounds)
        return
    with pytest.raises(
        fvf.NonManifoldError,
        match=rf"vertices \[0\] \(1 in all\) are non-manifold: their faces form {at_apex} "
        r"separate fans.*"
        r"split_nonmanifold_vertices",
    ):
        fvf.TriMesh(V, F)


def test_fans_count_every_vertex_on_a_chain_of_bow_ties():
    """Several non-manifold vertices, with 2 and 3 fans, are all named."""
    V, F = glued_at_apex(fan(3, "wedge"), fan(4, "disk"))
    W, G = glued_at_apex(fan(5, "cone"), fan(6, "cone"), fan(3, "wedge"))
    V2 = np.vstack([V, W + [0, 20.0, 0]])
    F2 = np.vstack([F, G + len(V)])
    fans = fans_of(V2, F2)
    assert np.flatnonzero(fans > 1).tolist() == [0, len(V)]
    assert fans[0] == 2 and fans[len(V)] == 3
    with pytest.raises(
        fvf.NonManifoldError, match=rf"vertices \[0, {len(V)}\] .* form 3 separate fans"
    ):
        fvf.TriMesh(V2, F2)


@pytest.mark.parametrize("name", [*CORPUS[:4], *HOSTILE])
def test_corner_fans_match_vertex_fans_in_any_orientation(name):
    """The repairs' fans (any orientation) are the validated mesh's fans, whatever faces
    are flipped; edge_pairs flags exactly the edges whose faces were flipped apart."""
    if name in HOSTILE:
        V, F = HOSTILE[name][0]
    else:
        mesh = get_mesh(name)
        V, F = mesh.vertices, mesh.faces
    V, F = np.asarray(V), np.array(F)
    expected = fans_of(V, F)
    flip = np.random.default_rng(5).random(len(F)) < 0.3
    F[flip] = F[flip][:, ::-1]
    runs = halfedges.sort_halfedges(F, len(V))
    count, labels = halfedges.corner_fans(F, runs)
    vertex_of_fan = np.empty(count, dtype=np.int64)
    vertex_of_fan[labels] = F.ravel()
    np.testing.assert_array_equal(np.bincount(vertex_of_fan, minlength=len(V)), expected)
    first, second, same = halfedges.edge_pairs(runs)
    np.testing.assert_array_equal(same, flip[first // 3] != flip[second // 3])
    np.testing.assert_array_equal(
        halfedges.misoriented_edges(runs), np.flatnonzero(runs.counts == 2)[same]
    )


@pytest.mark.parametrize("name", CORPUS)
def test_one_ring_pattern_and_slots_match_coo(name, rng):
    mesh = get_mesh(name)
    F, n = np.asarray(mesh.faces), mesh.n_vertices
    E = np.asarray(mesh.edges)
    rows = np.concatenate([E[:, 0], E[:, 1], np.arange(n)])
    cols = np.concatenate([E[:, 1], E[:, 0], np.arange(n)])
    ref = sp.coo_array((np.ones(rows.size), (rows, cols)), shape=(n, n)).tocsr()
    ref.sort_indices()
    indptr, indices, slots = mesh.vertex_pattern
    np.testing.assert_array_equal(indptr, ref.indptr)
    np.testing.assert_array_equal(indices, ref.indices)
    assert indices.dtype == np.int32 and indptr.dtype == np.int32
    # every slot holds the entry (F[t, a], F[t, b])
    r = np.repeat(np.arange(n), np.diff(indptr))
    np.testing.assert_array_equal(r[slots], np.broadcast_to(F[:, :, None], slots.shape))
    np.testing.assert_array_equal(indices[slots], np.broadcast_to(F[:, None, :], slots.shape))
    w, d = rng.standard_normal(E.shape[0]), rng.standard_normal(n)
    A = mesh.assemble_edge_operator(w, d)
    B = sp.coo_array((np.concatenate([w, w, d]), (rows, cols)), shape=(n, n)).tocsr()
    assert abs(A - B).max() == 0.0 and A.has_sorted_indices


def test_stiffness_from_edge_lengths_matches_the_hat_gradient_blocks(rng):
    """W from squared edge lengths equals Σ_t A_F ⟨∇φ_a, ∇φ_b⟩ assembled per face."""
    mesh = fvf.jittered_sphere(2, 0.35, seed=3)
    g = fvf.calculus.hat_gradients(mesh)
    K = mesh.face_areas[:, None, None] * np.einsum("tik,tjk->tij", g, g)
    ref = mesh.assemble_vertex_operator(K)
    W = fvf.stiffness(mesh)
    assert abs(W - ref).max() <= 1e-12 * abs(ref).max()
    assert (W != W.T).nnz == 0  # exactly symmetric
    assert np.abs(W @ np.ones(mesh.n_vertices)).max() <= 1e-13 * abs(W).max()
