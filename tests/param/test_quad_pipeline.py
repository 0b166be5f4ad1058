"""The parts of fvf.quad_mesh that make it hold on meshes users bring: the validity gate,
components, remeshing, sharp features, open surfaces (domes), the result object."""

from __future__ import annotations

import contextlib
import dataclasses
import warnings

import numpy as np
import pytest

import fvf
import quadcheck
from fvf.mesh.shapes import midpoint_subdivision
from fvf.param import quadmesh
from fvf.param.caps import boundary_loops, capped, cut_caps, doubled
from fvf.param.features import (
    MIN_CHAIN,
    feature_constraints,
    feature_coverage,
    feature_density,
    feature_edge_ids,
    sharp_edges,
)
from fvf.param.quad_validity import check_quad_mesh, topology_signature
from fvf.param.remesh import needs_remesh, remesh_for_quads


def box(a=2.0, b=1.0, c=0.5):
    """A 12-triangle box, as CAD exports one: (V, F)."""
    V = np.array([[x, y, z] for x in (0, a) for y in (0, b) for z in (0, c)], dtype=float)
    F = np.array(
        [
            [0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
            [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3],
        ]
    )  # fmt: skip
    return V, F


def grid_quads(n):
    """A flat n × n quad grid on the unit square: (V, Q)."""
    x, y = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1), indexing="ij")
    V = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a = (i * (n + 1) + j).ravel()
    return V, np.stack([a, a + n + 1, a + n + 2, a + 1], axis=1)


# ---------------------------------------------------------------------------- the gate
def test_the_gate_passes_a_grid_and_names_each_planted_defect():
    V, Q = grid_quads(6)
    T = np.concatenate([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]])
    mesh = fvf.TriMesh(V, T)
    assert check_quad_mesh(mesh, V, Q).valid
    flipped = Q.copy()
    flipped[7] = flipped[7, ::-1]
    assert "oriented" in str(check_quad_mesh(mesh, V, flipped))
    assert "topology" in str(check_quad_mesh(mesh, V, np.delete(Q, 14, axis=0)))
    twice = np.concatenate([Q, Q[:1]])
    assert "bound > 2 quads" in str(check_quad_mesh(mesh, V, twice))
    lifted = V.copy()
    lifted[Q[20], 2] = 5.0
    assert "Hausdorff" in str(check_quad_mesh(mesh, lifted, Q))


@pytest.mark.parametrize("lift", [0.9, 1.1])
def test_the_gate_measures_hausdorff_within_its_step_on_a_finer_input(lift):
    """A 6 × 6 quad grid lifted ``lift`` quad edges above a 47 × 47 triangulated plane
    (sides not multiples of each other): the distance is exactly ``lift`` edges; the gate
    measures it to within HAUSDORFF_STEP above and passes or fails it at one edge."""
    from fvf.param.quality import HAUSDORFF_STEP

    Vi, Qi = grid_quads(47)
    mesh = fvf.TriMesh(Vi, np.concatenate([Qi[:, [0, 1, 2]], Qi[:, [0, 2, 3]]]))
    V, Q = grid_quads(6)
    V = V + [0.0, 0.0, lift / 6]
    verdict = check_quad_mesh(mesh, V, Q)
    got = verdict.hausdorff
    assert lift - 1e-9 <= got <= lift + HAUSDORFF_STEP, got
    assert verdict.valid == (lift < 1)
    assert max(verdict.one_sided) == pytest.approx(got / 6)  # the mesh's units (edge 1/6)


def test_the_results_quality_takes_the_gates_hausdorff_and_folds():
    """``result.quality`` does not sample both surfaces again: its Hausdorff distances are
    the gate's (sampled every quarter mean quad edge, where quad_quality samples every
    quarter of the square root of the mean quad area) and agree with a fresh measurement
    to within that step."""
    mesh = fvf.icosphere(3)
    made = fvf.quad_mesh(mesh, target_faces=200)
    fresh = fvf.quad_quality(mesh, made.vertices, made.quads)
    diag = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    to, back = (d / diag for d in made.validity.one_sided)
    assert made.quality.hausdorff_to_input == to and made.quality.hausdorff_from_input == back
    step = 0.25 * np.sqrt(4 * np.pi / len(made.quads)) / diag
    assert abs(fresh.hausdorff_to_input - to) < step
    assert abs(fresh.hausdorff_from_input - back) < step
    assert made.quality.n_folded == fresh.n_folded == 0


def test_the_gate_finds_a_pinched_vertex():
    """Two grids sharing one corner: every edge is manifold, the corner is not."""
    V, Q = grid_quads(2)
    W = np.concatenate([V, V[1:] + [1.0, 1.0, 0.0]])
    remap = np.concatenate([[8], np.arange(9, 17)])  # the second grid's vertex 0 is vertex 8
    Q2 = np.concatenate([Q, remap[Q]])
    T = np.concatenate([Q2[:, [0, 1, 2]], Q2[:, [0, 2, 3]]])
    verdict = check_quad_mesh(fvf.TriMesh(*fvf.split_nonmanifold_vertices(W, T)[:2]), W, Q2)
    assert "not manifold" in str(verdict) and "[8]" in str(verdict)


def test_topology_signature_counts_components_and_loops():
    V, Q = grid_quads(3)
    assert topology_signature(V.shape[0], Q) == [(1, 1)]
    assert topology_signature(V.shape[0] * 2, np.concatenate([Q, Q + V.shape[0]])) == [
        (1, 1),
        (1, 1),
    ]


# ---------------------------------------------------------------------------- features
def test_a_box_has_twelve_sharp_edges_and_its_quads_follow_them():
    V, F = box()
    mesh = fvf.TriMesh(V, F)
    sharp = sharp_edges(mesh)
    assert sharp.size == 12  # the face diagonals are flat
    faces, dirs = feature_constraints(mesh, sharp)
    assert faces.size == 12 and np.allclose(np.linalg.norm(dirs, axis=1), 1.0)
    made = fvf.quad_mesh(mesh, target_faces=300)
    assert feature_coverage(mesh, sharp, made.vertices, made.quads) > 0.99  # 1.0 measured


def test_feature_edges_are_integer_iso_lines_of_the_parameterization():
    """Each sharp edge of a box keeps one uv coordinate, exactly, at an integer value
    (the conditions are part of the integer lattice, so rounding and fold repair keep
    them); the other coordinate moves along it."""
    V, F = box()
    for _ in range(3):
        V, F = midpoint_subdivision(V, F)
    mesh = fvf.TriMesh(V, F)
    sharp = sharp_edges(mesh)
    p = fvf.seamless_parameterization(mesh, features=sharp, target_faces=300)
    t = np.where(mesh.edge_faces[sharp, 0] >= 0, *mesh.edge_faces[sharp].T)
    ends = [np.argmax(mesh.faces[t] == mesh.edges[sharp, i][:, None], axis=1) for i in (0, 1)]
    ua, ub = p.uv[t, ends[0]], p.uv[t, ends[1]]  # (k, 2) each
    const = np.argmin(np.abs(ua - ub), axis=1)
    k = np.arange(sharp.size)
    assert np.array_equal(ua[k, const], ub[k, const])
    assert np.array_equal(ua[k, const], np.round(ua[k, const]))
    assert np.abs(ua[k, 1 - const] - ub[k, 1 - const]).min() > 0.1  # 0.35 measured
    free = fvf.seamless_parameterization(mesh, target_faces=300)  # no features given
    fa, fb = free.uv[t, ends[0]], free.uv[t, ends[1]]
    assert np.abs(fa - fb).min(axis=1).max() > 1e-3  # not iso-lines by themselves


@pytest.mark.parametrize("sections", [48, 32, 12])
def test_rims_of_tessellated_holes_and_bosses_are_features(sections):
    """A plate with a hole and a boss, tessellated as CSG tools do (48 sections: wall
    facets 7.5° apart, 12: OpenSCAD's default for small circles, 30°): every rim edge is
    sharp (90°) and its sides bend only about the wall's axial edges, across it, so the
    rims are features besides the box's 12 edges; the wall facets are not."""
    mf = pytest.importorskip("manifold3d")
    solid = mf.Manifold.cube([60.0, 40.0, 1.0])
    solid = solid - mf.Manifold.cylinder(3.0, 4.3, 4.3, sections).translate([20.0, 20.0, -1.0])
    solid = solid + mf.Manifold.cylinder(6.0, 5.0, 5.0, sections).translate([45.0, 20.0, 0.5])
    m = solid.to_mesh64()
    mesh = fvf.TriMesh(np.asarray(m.vert_properties)[:, :3], np.asarray(m.tri_verts))
    sharp = sharp_edges(mesh)
    E = mesh.vertices[mesh.edges[sharp]]
    on_rim = np.isin(np.round(E[:, :, 2], 9), [0.0, 1.0, 6.5]).all(axis=1)  # horizontal
    assert sharp.size == 12 + 4 * sections  # two rims of the hole, two of the boss
    assert on_rim.all()


def test_noise_makes_few_features_with_the_cross_bend_rule():
    """On a noisy sphere the edges the cross-bend rule adds (sides bent only about axes
    across the edge) are a small part of those the smooth-sides rule takes: noise bends
    about every axis."""
    from fvf.param.features import SMOOTH_SIDES, _side_roughness, dihedral_angles

    S = fvf.jittered_sphere(4, 1.0, seed=0)
    d = dihedral_angles(S)
    bent = np.flatnonzero(d > 35.0)
    smooth_sides = bent[_side_roughness(S, d > 35.0, d, bent) < SMOOTH_SIDES * 35.0]
    both = sharp_edges(S, 35.0)
    assert np.isin(smooth_sides, both).all()
    assert both.size <= 1.02 * smooth_sides.size  # 869 against 860 measured


def test_a_spikes_sharp_sides_are_no_feature_but_a_box_corners_edges_are():
    """A vertex of a sphere pulled out 1.5 edges (a scan's spike) makes sharp edges about
    it: its sides and the ring below them, all within 1.8 edges of the tip. As chains they
    are long enough (MIN_CHAIN h, h = 2 edges), but they lie within that length of the tip,
    where five meet: no feature. The box's 12 edges meet three at a corner, and its far
    corners are 2.3 away: a feature at h = 0.5, a point at h = 1.5."""
    S = fvf.icosphere(4)
    e = S.mean_edge_length
    V = S.vertices.copy()
    V[0] *= 1 + 1.5 * e  # valence 5
    spike = fvf.TriMesh(V, S.faces)
    sharp = sharp_edges(spike)
    assert sharp.size == 10 and np.bincount(spike.edges[sharp].ravel()).max() == 5
    assert sharp_edges(spike, 35.0, MIN_CHAIN * 2 * e).size == 0
    assert sharp_edges(spike, 35.0, 1.0 * e).size == 10  # a chain farther than asked: kept
    B = fvf.TriMesh(*box())
    assert sharp_edges(B, 35.0, MIN_CHAIN * 0.5).size == 12
    assert sharp_edges(B, 35.0, MIN_CHAIN * 1.5).size == 0


def test_user_feature_edges_must_be_edges():
    mesh = fvf.icosphere(1)
    assert feature_edge_ids(mesh, mesh.edges[[3, 1]][:, ::-1]).tolist() == [3, 1]
    with pytest.raises(fvf.ParameterError, match=r"feature edges \[1\] \(1 in all\)"):
        feature_edge_ids(mesh, np.array([mesh.edges[0], [0, 0]]))


# ---------------------------------------------------------------------------- remeshing
def test_midpoint_subdivision_keeps_the_surface_and_quadruples_the_faces():
    V, F = box()
    W, G = midpoint_subdivision(V, F)
    mesh = fvf.TriMesh(W, G)
    assert G.shape[0] == 48 and mesh.euler_characteristic == 2
    assert np.isclose(mesh.total_area, fvf.TriMesh(V, F).total_area)


@pytest.mark.parametrize("method", ["subdivide", "pymeshlab"])
def test_the_remeshed_edge_is_the_fraction_asked_of_the_quad_edge(method):
    """The default fraction and the finer one of fvf.quad_mesh's later attempts: the mean
    edge is at most the fraction's (subdivision: halved until it is; pymeshlab's isotropic
    remeshing: within a fifth of it)."""
    from fvf.param.remesh import FINE_REMESH_FRACTION, REMESH_FRACTION

    if method == "pymeshlab":
        pytest.importorskip("pymeshlab")
    mesh = fvf.TriMesh(*box())
    h = 1.0
    edges = {}
    for fraction in (REMESH_FRACTION, FINE_REMESH_FRACTION):
        S = remesh_for_quads(mesh, h, method=method, fraction=fraction)
        assert S.is_closed and S.euler_characteristic == 2
        edges[fraction] = S.mean_edge_length
        assert edges[fraction] <= fraction * h * (1.2 if method == "pymeshlab" else 1.0)
    assert edges[FINE_REMESH_FRACTION] < edges[REMESH_FRACTION]


@pytest.mark.parametrize("method", ["subdivide", "pymeshlab"])
def test_a_coarse_box_is_remeshed_then_quad_meshed(method):
    if method == "pymeshlab":
        pytest.importorskip("pymeshlab")
    V, F = box()
    mesh = fvf.TriMesh(V, F)
    h = np.sqrt(mesh.total_area / 200)
    assert "longer than" in needs_remesh(mesh, h)
    S = remesh_for_quads(mesh, h, method=method)
    assert S.euler_characteristic == 2 and S.mean_edge_length < h
    made = fvf.quad_mesh(mesh, target_faces=200, remesher=method, remesh=True)
    assert made.validity.valid and made.surfaces[0].n_faces > mesh.n_faces
    faces, closest = fvf.param.quad_folds.closest_surface_points(mesh, made.vertices)
    assert np.abs(closest - made.vertices).max() < 1e-9  # on the input surface
    assert np.array_equal(made.vertex_faces, faces) or made.vertex_faces.shape == faces.shape


def test_a_box_far_finer_than_its_remeshing_is_decimated_first_and_stays_the_box(monkeypatch):
    """A 12-triangle box midpoint-subdivided to 12,288 triangles has more than
    PRE_DECIMATE times the 600 or so triangles remeshed at 0.175: pymeshlab decimates it
    first (planar quadrics) and the remeshed surface is the box's, as from the box itself:
    vertices on its faces (within MeshLab's single precision), its twelve edges sharp,
    about as many triangles."""
    pytest.importorskip("pymeshlab")
    import pymeshlab

    from fvf.param import remesh

    V, F = box()
    fine = fvf.TriMesh(*midpoint_subdivision(*midpoint_subdivision(*midpoint_subdivision(V, F))))
    fine = fvf.TriMesh(*midpoint_subdivision(*midpoint_subdivision(fine.vertices, fine.faces)))
    assert fine.n_faces == 12 * 4**5
    h = 0.25
    assert fine.n_faces > remesh.PRE_DECIMATE * 2.31 * fine.total_area / (0.7 * h) ** 2
    calls = []
    real = pymeshlab.MeshSet.meshing_decimation_quadric_edge_collapse

    def counted(self, **kwargs):
        calls.append(kwargs["targetfacenum"])
        return real(self, **kwargs)

    monkeypatch.setattr(pymeshlab.MeshSet, "meshing_decimation_quadric_edge_collapse", counted)
    S = remesh_for_quads(fine, h, method="pymeshlab")
    coarse = remesh_for_quads(fvf.TriMesh(V, F), h, method="pymeshlab")
    assert len(calls) == 1  # the fine box only
    assert S.is_closed and S.euler_characteristic == 2
    lo, hi = V.min(axis=0), V.max(axis=0)
    off = np.minimum(np.abs(S.vertices - lo), np.abs(S.vertices - hi)).min(axis=1)
    assert off.max() < 1e-4 * np.ptp(V)  # on the box (the decimation: single precision)
    assert abs(S.n_faces - coarse.n_faces) <= 0.1 * coarse.n_faces
    E = S.vertices[S.edges[sharp_edges(S, 35.0)]]
    length = np.linalg.norm(E[:, 1] - E[:, 0], axis=1).sum()
    assert length == pytest.approx(4 * (2.0 + 1.0 + 0.5), rel=1e-3)  # the box's edges


def test_the_remeshed_surface_of_a_thin_walled_box_has_no_zero_area_triangles():
    """pymeshlab's remeshing of an open box with 3.55 mm walls and two floor holes leaves
    triangles with three vertices on one crease line; they are split away (T-junction
    splits, pairs sharing their long edge flipped first; again at another edge length where
    some are left), and the surface keeps its topology. pymeshlab's output depends on the
    process's address layout: in about one process in 60 it has 349 such triangles (pairs
    along the whole inner rim) instead of 5, which only the flips resolve."""
    pytest.importorskip("manifold3d")
    pytest.importorskip("pymeshlab")
    import wild_corpus as wc
    from fvf.mesh.defects import zero_area_faces
    from fvf.mesh.trimesh import DEGENERATE_AREA_RTOL
    from fvf.param.remesh import REMESH_FRACTION, _pymeshlab_remesh

    mesh = fvf.TriMesh(*wc.open_box_two_holes())
    edge = 1.8555  # pymeshlab 2025.7: 5 zero-area triangles, 3 in a row (remeshed again)
    V, F = _pymeshlab_remesh(mesh, edge, 35.0)
    assert zero_area_faces(V, F, DEGENERATE_AREA_RTOL).any()  # the case exists
    S = remesh_for_quads(mesh, edge / REMESH_FRACTION)
    assert S.is_closed and S.euler_characteristic == mesh.euler_characteristic


# ---------------------------------------------------------------------------- components
def test_every_component_is_meshed_and_a_tiny_one_is_left_out_with_a_warning(monkeypatch):
    from fvf.param import quadmesh

    a = fvf.icosphere(3)
    tiny = fvf.icosphere(1)
    V = np.concatenate([a.vertices, 0.02 * tiny.vertices + 3.0])
    F = np.concatenate([a.faces, tiny.faces + a.n_vertices])
    mesh = fvf.TriMesh(V, F)
    made = fvf.quad_mesh(mesh, target_faces=300)  # meshed at its own, smaller quad size
    assert made.components.tolist() == [0, 1] and made.dropped_components.size == 0
    assert (made.quads >= np.flatnonzero(made.vertex_faces >= a.n_faces).min()).all(1).sum() >= 6
    real = quadmesh._mesh_part

    def tiny_fails(part, *args):
        if part.label == 1:
            raise fvf.QuadMeshError("planted")
        return real(part, *args)

    monkeypatch.setattr(quadmesh, "_mesh_part", tiny_fails)
    with pytest.warns(fvf.SmallComponentWarning, match=r"components \[1\]"):
        made = fvf.quad_mesh(mesh, target_faces=300)
    assert made.dropped_components.tolist() == [1] and made.components.tolist() == [0]
    monkeypatch.undo()
    two = fvf.TriMesh(
        np.concatenate([a.vertices, a.vertices + 3.0]),
        np.concatenate([a.faces, a.faces + a.n_vertices]),
    )
    made = fvf.quad_mesh(two, target_faces=300)
    assert made.components.tolist() == [0, 1] and len(made.parameterizations) == 2
    assert topology_signature(made.vertices.shape[0], made.quads) == [(2, 0), (2, 0)]


# ---------------------------------------------------------------------------- open surfaces
def test_domes_close_every_hole_and_their_quads_are_cut_off():
    mesh = fvf.disk(8, 24)
    n = mesh.boundary_vertices.size
    assert [loop.size for loop in boundary_loops(mesh)] == [n]
    cap = capped(mesh, 0.2)
    assert cap.mesh.is_closed and cap.mesh.euler_characteristic == 2
    assert cap.rim.size == n and cap.is_cap.sum() == cap.mesh.n_faces - mesh.n_faces
    made = fvf.quad_mesh(mesh, target_faces=100)
    assert topology_signature(made.vertices.shape[0], made.quads) == [(1, 1)]
    V, Q, vf = cut_caps(cap, *_all_cap_quads(cap))
    assert Q.shape[0] == 0 and V.shape[0] == 0 and vf.shape[0] == 0


def _all_cap_quads(cap):
    """A quad on a dome (its centre lies on the dome): cut off."""
    top = cap.mesh.vertices[-1]
    P = top + 0.01 * np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    return P, np.array([[0, 1, 2, 3]]), np.zeros(4, np.int64)  # faces unused by domes


def _square_of_four(cap_squares):
    """A 2 x 2 grid of unit squares (two triangles each, square s = 2 j + i at (i, j)), the
    listed squares' triangles marked as dome; the four squares as quads."""
    from fvf.param.caps import Capped

    x, y = np.meshgrid(np.arange(3.0), np.arange(3.0), indexing="xy")
    V = np.stack([x.ravel(), y.ravel(), np.zeros(9)], 1)
    corner = np.array([0, 1, 4, 3])
    Q = np.array([corner + 3 * j + i for j in (0, 1) for i in (0, 1)])
    F = np.concatenate([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]])  # square s: faces s and s + 4
    is_cap = np.isin(np.arange(8) % 4, cap_squares)
    return Capped(fvf.TriMesh(V, F), is_cap, np.zeros(0, np.int64)), V, Q


def test_cutting_domes_never_leaves_two_quads_touching_at_a_corner():
    """Kept squares 0 and 3 would meet only at the centre vertex (two fans: not a
    manifold quad mesh); the dome's squares around it are put back. Without a pinch the
    cut is as before."""
    from fvf.param.quad_validity import quad_vertex_fans

    cap, V, Q = _square_of_four([1, 2])
    V2, Q2, _ = cut_caps(cap, V, Q, np.zeros(9, np.int64))
    assert Q2.shape == (4, 4) and (quad_vertex_fans(V2.shape[0], Q2) == 1).all()
    cap, V, Q = _square_of_four([1, 3])
    V2, Q2, _ = cut_caps(cap, V, Q, np.zeros(9, np.int64))
    assert Q2.shape == (2, 4) and (quad_vertex_fans(V2.shape[0], Q2) == 1).all()


def test_a_cylinder_open_at_both_ends_keeps_its_two_loops():
    made = fvf.quad_mesh(_open_cylinder(), target_faces=200)
    assert topology_signature(made.vertices.shape[0], made.quads) == [(0, 2)]


def _strip(n: int = 12) -> fvf.TriMesh:
    """A flat strip one triangle wide: every interior edge is a chord (both ends on the
    boundary), its inner faces have two chords, its end faces two boundary edges."""
    x = np.arange(n, dtype=float)
    V = np.concatenate([np.stack([x, 0 * x, 0 * x], 1), np.stack([x, 0 * x + 1, 0 * x], 1)])
    i = np.arange(n - 1)
    return fvf.TriMesh(
        V, np.concatenate([np.stack([i, i + 1, i + n], 1), np.stack([i + 1, i + 1 + n, i + n], 1)])
    )


def _triforce() -> fvf.TriMesh:
    """A face whose three edges are chords, with an ear (one chord) on each."""
    V = np.array([[0, 0, 0], [2, 0, 0], [1, 1.7, 0], [1, -1, 0], [2.4, 1.2, 0], [-0.4, 1.2, 0]])
    return fvf.TriMesh(V, np.array([[0, 1, 2], [0, 3, 1], [1, 4, 2], [2, 5, 0]]))


def _boundary_pairs(mesh: fvf.TriMesh) -> set:
    return {tuple(sorted(e)) for e in mesh.edges[mesh.boundary_edges].tolist()}


@pytest.mark.parametrize("name", ["disk", "cylinder", "strip", "triforce"])
def test_the_mirror_image_closes_an_open_surface_with_twice_its_area(name):
    """Glued to its mirror image along its boundary: closed and manifold, chi = 2 chi(M),
    exactly twice the area, every face of the copy on its twin with the opposite normal,
    the rims are M's boundary edges, and no edge of M's sheet joins two rim vertices
    without being a rim edge (the chords are split, else four faces would share them)."""
    mesh = {
        "disk": fvf.disk(4, 6),
        "cylinder": _open_cylinder(),
        "strip": _strip(),
        "triforce": _triforce(),
    }[name]
    cap = doubled(mesh)
    closed = cap.mesh
    assert cap.mirrored and closed.is_closed
    assert closed.euler_characteristic == 2 * mesh.euler_characteristic
    assert closed.total_area == pytest.approx(2 * mesh.total_area, rel=1e-12)
    m = closed.n_faces // 2
    assert cap.is_cap.tolist() == [False] * m + [True] * m
    np.testing.assert_allclose(closed.face_centroids[m:], closed.face_centroids[:m], atol=1e-12)
    np.testing.assert_allclose(closed.face_normals[m:], -closed.face_normals[:m], atol=1e-12)
    rim = {tuple(sorted(e)) for e in closed.edges[cap.rim].tolist()}
    assert rim == _boundary_pairs(mesh) and cap.rim.min() >= 0
    sheet = fvf.TriMesh(*fvf.remove_unreferenced_vertices(closed.vertices, closed.faces[:m])[:2])
    assert sheet.total_area == pytest.approx(mesh.total_area, rel=1e-12)
    ends = np.zeros(sheet.n_vertices, bool)
    ends[sheet.boundary_vertices] = True
    inner = (sheet.edge_faces >= 0).all(axis=1)
    assert not (inner & ends[sheet.edges].all(axis=1)).any()
    split = {"disk": 0, "cylinder": 0, "strip": 2 * 11 - 1, "triforce": 3}[name]
    assert sheet.n_vertices == mesh.n_vertices + split


def _open_cylinder() -> fvf.TriMesh:
    t = np.linspace(0, 2 * np.pi, 33)[:-1]
    z = np.linspace(0, 2, 17)
    X = np.stack(
        [np.cos(t)[None].repeat(17, 0), np.sin(t)[None].repeat(17, 0), z[:, None].repeat(32, 1)],
        axis=2,
    ).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(16), np.arange(32), indexing="ij")
    a, b = (i * 32 + j).ravel(), (i * 32 + (j + 1) % 32).ravel()
    F = np.concatenate([np.stack([a, b, b + 32], 1), np.stack([a, b + 32, a + 32], 1)])
    return fvf.TriMesh(X, F)


def _rectangle(bend: float | None) -> fvf.TriMesh:
    """A 4 x 1 rectangle, flat or rolled onto a cylinder of radius ``bend`` (an isometry)."""
    u, v = np.meshgrid(np.linspace(0, 4, 41), np.linspace(0, 1, 11), indexing="ij")
    u, v = u.ravel(), v.ravel()
    X = (
        np.c_[u, v, 0 * u]
        if bend is None
        else np.c_[bend * np.sin(u / bend), v, bend * np.cos(u / bend)]
    )
    i, j = np.meshgrid(np.arange(40), np.arange(10), indexing="ij")
    a = (i * 11 + j).ravel()
    return fvf.TriMesh(
        X, np.concatenate([np.stack([a, a + 11, a + 12], 1), np.stack([a, a + 12, a + 1], 1)])
    )


@pytest.mark.parametrize("bend", [None, 2.0])
def test_a_rectangle_closed_by_its_mirror_image_is_a_grid_with_its_corners(bend, monkeypatch):
    """A 4 x 1 rectangle (flat, or rolled into a developable sheet) closed by its mirror
    image (a pillowcase with four cones of index 1/2 at its corners; its domes would hold
    2.4 and 1.6 times its area, so the mirror image is asked for first here) is meshed at
    h = 0.2 as the 20 x 5 grid: the four corners in one quad each, the other 46 boundary
    vertices in two, the 76 interior ones in four."""
    monkeypatch.setattr(quadmesh, "DOME_AREA_LIMIT", 1.0)
    mesh = _rectangle(bend)
    made = fvf.quad_mesh(mesh, target_faces=100)
    # one attempt: its grid lines run along the input's edges on both sheets, whose rays
    # have the same 3D directions at the rims (extraction tells them apart by the sheet)
    assert "smooth field, features as iso-lines" in made.attempts[0]
    assert len(made.attempts) == 1
    counts = np.bincount(np.bincount(made.quads.ravel()), minlength=5)
    assert made.quads.shape[0] == 100 and counts.tolist() == [0, 4, 46, 0, 76]
    assert quadcheck.check(mesh.vertices, mesh.faces, *map(np.asarray, made)).valid


def test_a_rolled_rectangle_whose_domes_fail_is_closed_by_its_mirror_image():
    """The rolled rectangle's domes hold 1.6 times its area, so they come first; their first
    attempt fails (as do all 12), and the mirror image's first attempt, tried next, gives
    the grid with its four corners."""
    mesh = _rectangle(2.0)
    made = fvf.quad_mesh(mesh, target_faces=100)
    assert [line.split(": ")[1] for line in made.attempts] == ["domes", "its mirror image"]
    counts = np.bincount(np.bincount(made.quads.ravel()), minlength=5)
    assert made.quads.shape[0] == 100 and counts.tolist() == [0, 4, 46, 0, 76]


def _sheet(nu: int, nv: int, point) -> fvf.TriMesh:
    """A grid of (nu - 1) x (nv - 1) squares, two triangles each, mapped by ``point(u, v)``
    (u, v in [0, 1], arrays) to 3D."""
    u, v = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv), indexing="ij")
    i, j = np.meshgrid(np.arange(nu - 1), np.arange(nv - 1), indexing="ij")
    a = (i * nv + j).ravel()
    F = np.concatenate([np.stack([a, a + nv, a + nv + 1], 1), np.stack([a, a + nv + 1, a + 1], 1)])
    return fvf.TriMesh(point(u.ravel(), v.ravel()), F)


def _twisted(u, v):  # half a turn of twist along a 4 x 0.3 strip
    s = 0.3 * (v - 0.5)
    return np.stack([4 * u, s * np.cos(np.pi * u), s * np.sin(np.pi * u)], axis=1)


def _helicoid(u, v):  # 1.5 turns, radii 0.3-0.8, pitch 2.5
    t, r = 3 * np.pi * u, 0.3 + 0.5 * v
    return np.stack([r * np.cos(t), r * np.sin(t), 0.4 * t], axis=1)


@pytest.mark.parametrize(
    "mesh",
    [lambda: _sheet(200, 5, _twisted), lambda: _sheet(200, 6, _helicoid)],
    ids=["twisted strip", "helicoid"],
)
def test_sheets_whose_boundary_winds_through_space_are_valid(mesh):
    """Sheets whose one boundary loop winds through space: a twisted strip (domes 5 times
    its area: its mirror image first) and a helicoid (domes 3.3 times: domes first, all
    their attempts fail in about 30 s, then the mirror image; here the mirror image is
    asked for first), valid by quadcheck with each of the four corners in one quad."""
    M = mesh()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(quadmesh, "DOME_AREA_LIMIT", 1.0)
        made = fvf.quad_mesh(M, target_faces=500)
    assert quadcheck.check(M.vertices, M.faces, made.vertices, made.quads).valid
    assert np.count_nonzero(np.bincount(made.quads.ravel()) == 1) == 4
    assert topology_signature(made.vertices.shape[0], made.quads) == [(1, 1)]


def test_a_folded_quad_on_the_open_sheet_is_told_apart_by_its_corners_not_its_normal():
    """A 3 x 3 grid of squares and its mirror image's quads, quad 0 folded (its inner
    corner pulled past the outer one, on both sheets): the sheet of the faces of its
    corners off the loops says it is the open sheet's, whatever its normal says; so the
    open sheet's nine quads are kept (for the untangling on the input) and the copy's cut."""
    from fvf.param.caps import _facing_open

    g = np.arange(16).reshape(4, 4)
    x, y = np.meshgrid(np.arange(4.0), np.arange(4.0), indexing="ij")
    V = np.stack([x.ravel(), y.ravel(), np.zeros(16)], axis=1)
    a, b, c, d = g[:-1, :-1].ravel(), g[1:, :-1].ravel(), g[1:, 1:].ravel(), g[:-1, 1:].ravel()
    cap = doubled(fvf.TriMesh(V, np.r_[np.c_[a, b, c], np.c_[a, c, d]]))
    m, n = cap.mesh.n_faces // 2, cap.mesh.n_vertices
    copies = np.setdiff1d(cap.mesh.faces[m:], cap.mesh.faces[:m])  # (chords split first)
    twin = np.arange(n)
    for v in copies:
        twin[np.flatnonzero((cap.mesh.vertices[:16] == cap.mesh.vertices[v]).all(axis=1))] = v
    Q = np.r_[np.c_[a, b, c, d], twin[np.c_[a, b, c, d]][:, ::-1]]
    vf = np.array([np.flatnonzero((cap.mesh.faces == v).any(axis=1))[0] for v in range(n)])
    X = cap.mesh.vertices.copy()
    X[5] = X[twin[5]] = [-0.5, -0.5, 0.0]  # quad 0 (0, 4, 5, 1) and its twin folded
    assert _facing_open(cap, X, Q, vf).tolist() == [True] * 9 + [False] * 9


def test_a_users_feature_edge_that_is_a_chord_follows_its_split():
    """A user's feature edge across a strip one triangle wide is a chord, split before the
    gluing: its two halves are the feature (it was refused as no edge of the mesh)."""
    strip = _strip(40)
    made = fvf.quad_mesh(strip, target_faces=120, features=[[15, 55]])
    assert quadcheck.check(strip.vertices, strip.faces, made.vertices, made.quads).valid
    assert "its mirror image" in made.attempts[0]


def test_a_mirror_image_that_cannot_be_built_yields_to_the_domes(monkeypatch):
    """Splitting a sliver's chord leaves faces too thin for the mesh checks: closing by
    the mirror image fails as one attempt that says so, and the domes are tried (made to
    fail here: a typed error naming both closures)."""

    def domes_fail(part, plans, *args):
        raise fvf.QuadMeshError("domes failed", attempts=("a dome attempt",))

    monkeypatch.setattr(quadmesh, "_mesh_part", domes_fail)
    V = np.array([[0, 0, 0], [1, 0, 0], [0.5, 3e-14, 0], [1, 1, 0]], float)
    with pytest.raises(fvf.QuadMeshError, match="closing it: DegenerateFaceError") as err:
        fvf.quad_mesh(fvf.TriMesh(V, np.array([[0, 1, 2], [1, 3, 2]])), target_faces=20)
    assert err.value.attempts[0].startswith("its mirror image: closing it: DegenerateFaceError")
    assert err.value.attempts[1] == "domes: a dome attempt"


def test_an_open_surface_is_closed_the_other_way_when_every_attempt_fails(monkeypatch):
    """Domes come first (over a cylinder's small ends), the mirror image where the domes
    would hold more than DOME_AREA_LIMIT times the area (a strip); when every attempt on
    one fails the other is tried, and its attempts follow the failed ones in the log;
    when both fail, the error lists both."""
    cylinder = quadmesh.component_parts(_open_cylinder())[0]
    assert [name for name, _ in quadmesh._closures(cylinder, 0.2)] == [
        "domes",
        "its mirror image",
    ]
    strip = quadmesh.component_parts(_strip(40))[0]
    assert [name for name, _ in quadmesh._closures(strip, 0.2)] == [
        "its mirror image",
        "domes",
    ]
    real = quadmesh._mesh_part

    def domes_fail(part, plans, *args):
        if not part.cap.mirrored:
            raise fvf.QuadMeshError("domes failed", attempts=("a dome attempt",))
        return real(part, plans, *args)

    monkeypatch.setattr(quadmesh, "_mesh_part", domes_fail)
    made = fvf.quad_mesh(_open_cylinder(), target_faces=200)
    assert made.attempts[0] == "component 0: domes: a dome attempt"
    assert made.attempts[1].startswith("component 0: its mirror image: input surface")
    assert topology_signature(made.vertices.shape[0], made.quads) == [(0, 2)]

    from fvf.param.quad_failures import Place

    rim = _open_cylinder().vertices[0]  # every attempt fails there: one place, 4 attempts

    def all_fail(part, plans, *args):
        there = (Place(rim.copy(), 1, np.inf),)
        raise fvf.QuadMeshError(f"{quadmesh._closure_name(part)} failed", ("x",), None, there)

    monkeypatch.setattr(quadmesh, "_mesh_part", all_fail)
    with pytest.raises(fvf.QuadMeshError, match="closed by domes and by its mirror image") as err:
        fvf.quad_mesh(_open_cylinder(), target_faces=200)
    assert [p.attempts for p in err.value.places] == [4] and "4 of 4 attempts" in str(err.value)
    with pytest.raises(fvf.QuadMeshError, match="domes failed$"):
        fvf.quad_mesh(_open_cylinder(), target_faces=200, retry=False)


# ---------------------------------------------------------------------------- the result
def test_the_result_unpacks_and_says_what_it_is():
    made = fvf.quad_mesh(fvf.torus(24, 12), target_faces=150)
    V, Q = made
    assert V is made.vertices and Q is made.quads and made[1] is Q
    assert "quads=int64" in repr(made) and len(repr(made)) < 600
    assert "valid" in made.summary() and made.quality.n_quads == Q.shape[0]
    assert made.parameterization is made.parameterizations[0]
    with pytest.warns(DeprecationWarning, match="parameterization"):
        V2, Q2, p = fvf.quad_mesh(fvf.torus(24, 12), target_faces=150, return_parameterization=True)
    assert np.array_equal(Q2, Q) and p.uv.shape == (fvf.torus(24, 12).n_faces, 3, 2)


def test_an_invalid_attempt_is_never_returned(monkeypatch):
    from fvf.param import quadmesh
    from fvf.param.quad_validity import QuadValidity

    bad = QuadValidity(False, ("planted",), np.empty(0, np.int64), np.nan)
    monkeypatch.setattr(quadmesh, "check_quad_mesh", lambda *a, **k: bad)
    with pytest.raises(fvf.QuadMeshError, match="planted") as info:
        fvf.quad_mesh(fvf.torus(24, 12), target_faces=150)
    assert len(info.value.attempts) >= 3 and info.value.best is not None


def test_corner_distortion_of_a_grid_and_a_sheared_grid():
    from fvf.param.quadmesh import corner_distortion

    V, Q = grid_quads(5)
    assert corner_distortion(V, Q) < 1e-12
    sheared = V.copy()
    sheared[:, 0] += sheared[:, 1]  # every corner 45° or 135°
    assert corner_distortion(sheared, Q) == pytest.approx(45.0)


def test_a_distorted_attempt_yields_to_a_later_one_or_comes_with_a_warning(monkeypatch):
    """A valid result whose corners are far from 90° (DISTORTED_CORNERS) is set aside
    while the next attempts run; with every result distorted, the first comes back with
    a DistortedQuadsWarning and the log names each."""
    from fvf.param import quadmesh

    real = quadmesh.corner_distortion
    seen = []

    def first_distorted(V, Q):
        seen.append(Q.shape[0])
        return 60.0 if len(seen) == 1 else real(V, Q)

    monkeypatch.setattr(quadmesh, "corner_distortion", first_distorted)
    with warnings.catch_warnings():
        warnings.simplefilter("error", fvf.DistortedQuadsWarning)
        made = fvf.quad_mesh(fvf.torus(24, 12), target_faces=150)
    assert "valid but distorted" in made.attempts[0] and "valid," in made.attempts[1]
    monkeypatch.setattr(quadmesh, "corner_distortion", lambda V, Q: 60.0)
    with pytest.warns(fvf.DistortedQuadsWarning, match="60° from 90°"):
        made = fvf.quad_mesh(fvf.torus(24, 12), target_faces=150)
    assert len(made.attempts) >= 3 and not any(": valid," in a for a in made.attempts)
    assert "valid but distorted, 144 quads" in made.attempts[0] and len(made.quads) == 144
    assert made.validity.valid


def test_a_backend_failure_ends_an_attempt_not_the_call(monkeypatch):
    from fvf.param import quadmesh

    calls = []
    real = quadmesh.seamless_parameterization

    def failing_once(*args, **kwargs):
        calls.append(1)
        if len(calls) == 1:
            raise RuntimeError("Failed to resize matrix arrays!")
        return real(*args, **kwargs)

    monkeypatch.setattr(quadmesh, "seamless_parameterization", failing_once)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        made = fvf.quad_mesh(fvf.torus(24, 12), target_faces=150)
    assert "RuntimeError: Failed to resize" in made.attempts[0] and made.validity.valid


def test_a_plan_whose_remeshing_fails_is_named_in_the_log(monkeypatch):
    """A sized plan is resolved (its surface remeshed, its sizing measured) before it
    runs; when that fails, the log line names that plan, not the one before it."""
    from fvf.param import quadmesh

    def resolved(part, plan, *args):
        if plan.sized:
            raise fvf.QuadExtractionError("planted remeshing failure")
        return plan

    def attempt(part, plan, *args):
        raise fvf.QuadExtractionError("planted attempt failure")

    monkeypatch.setattr(quadmesh, "_resolved", resolved)
    monkeypatch.setattr(quadmesh, "_attempt", attempt)
    with pytest.raises(fvf.QuadMeshError) as info:
        fvf.quad_mesh(fvf.torus(24, 12), target_faces=150)
    lines = info.value.attempts
    assert any("sized by curvature" in a for a in lines)
    for a in lines:
        assert ("sized by curvature" in a) == ("planted remeshing" in a), a


def test_features_are_iso_lines_plain_then_with_strips_first_then_hold_the_field():
    from fvf.param import quadmesh
    from fvf.param.quad_parts import component_parts

    part = component_parts(fvf.icosphere(2))[0]
    plans = quadmesh._plans(part, 0.3, "curvature", True, "auto", True)
    at_h = [p for p in plans if p.h == 0.3]
    assert plans[: len(at_h)] == at_h  # the quad edge asked first, then shorter ones
    iso = [p.isolines for p in at_h]
    strips = [p.strips for p in at_h]
    # input, remeshed, finely remeshed: each as iso-lines, then with thin strips stretched
    # (param.strips); then the input and the remeshed surface holding the field
    assert iso[:6] == [True] * 6 and not any(iso[6:])
    assert strips[:6] == [False, True] * 3 and not any(strips[6:])
    surfaces = [(p.remeshed, p.fine, p.h) for p in plans]
    assert surfaces[:6:2] == surfaces[1:6:2]
    assert surfaces[:6:2] == [(False, False, 0.3), (True, False, 0.3), (True, True, 0.3)]
    assert surfaces[6:8] == surfaces[:4:2]
    assert not any(p.fine for p in plans[6:])
    # at 1.5x and 2.25x the quads the features are iso-lines first again (remeshed, strips)
    finer = sorted({p.h for p in plans} - {0.3}, reverse=True)
    assert np.allclose(finer, [0.3 * quadmesh.MORE_QUADS, 0.3 * quadmesh.MORE_QUADS**2])
    for h in finer:
        first = next(p for p in plans if p.h == h)
        assert first.isolines and first.strips and first.remeshed and not first.fine
        assert sum(p.isolines for p in plans if p.h == h) == 1
    assert not any(p.isolines for p in quadmesh._plans(part, 0.3, "curvature", True, "auto", False))
    never = quadmesh._plans(part, 0.3, "curvature", True, "never", True)
    assert not any(p.remeshed or p.fine for p in never)


def test_a_thin_strips_plan_without_a_strip_is_the_plain_one_or_skipped(monkeypatch):
    """Without a thin strip a strips plan is its plan without strips: skipped at the quad
    edge asked (the plain iso-line plan is in the list already), run plain at 1.5x."""
    from fvf.param import quadmesh
    from fvf.param.quad_parts import component_parts

    part = component_parts(fvf.icosphere(2))[0]
    plans = quadmesh._plans(part, 0.3, "curvature", True, "auto", True)
    opts = {"remesh": "never"}  # (no decimation)
    for has in (False, True):
        monkeypatch.setattr(quadmesh, "_has_strips", lambda *args, has=has: has)
        for plan in (p for p in plans if p.strips):
            got = quadmesh._resolved(part, plan, plans, {}, opts)
            plain = dataclasses.replace(plan, strips=False)
            want = plan if has else (None if plain in plans else plain)
            assert got == want, (has, str(plan))
    assert any(p.strips and dataclasses.replace(p, strips=False) not in plans for p in plans)


def test_an_open_surface_whose_only_features_are_its_rims_tries_them_as_iso_lines_later():
    """A scan with holes: its boundary loops are its only features (the domes' own edges
    do not count), so the attempts holding the field come first and those with the rims
    as iso-lines after them; a sharp edge of its own puts the iso-lines first again."""
    from fvf.param import quadmesh
    from fvf.param.quad_parts import component_parts

    S = fvf.icosphere(3)
    top = S.face_centroids[:, 2] > 0.8  # a hole at the top
    holed = fvf.TriMesh(*fvf.remove_unreferenced_vertices(S.vertices, S.faces[~top])[:2])
    part = component_parts(holed)[0]
    part = dataclasses.replace(part, cap=capped(part.mesh, 0.05))
    opts = {"crease_angle": 35.0, "features": True, "user_edges": None}
    found = quadmesh._features(part, part.closed, 0.3, opts)
    assert quadmesh._only_rims(part, found)
    assert not quadmesh._only_rims(part, np.concatenate([found, [0]]))  # edge 0: not a rim
    plans = quadmesh._plans(part, 0.3, "curvature", True, "auto", True, rims_only=True)
    for h in sorted({p.h for p in plans}, reverse=True):  # at each quad edge, in turn
        iso = [p.isolines for p in plans if p.h == h]
        k, n = iso.index(True), sum(iso)  # (the dome's slivers: the input is remeshed first)
        assert k >= 1 and n >= 1 and iso == [False] * k + [True] * n + [False] * (len(iso) - k - n)
    first = quadmesh._plans(part, 0.3, "curvature", True, "auto", True)
    n = sum(p.isolines for p in plans if p.h == 0.3)
    assert n >= 4 and [p.isolines for p in first][:n] == [True] * n
    assert sorted(map(str, plans)) == sorted(map(str, first))  # the same, in another order


def test_an_attempts_log_line_is_its_errors_first_clause_cut_at_a_word(monkeypatch):
    """The advice after an attempt's first "; " is said once at the end of the error, not
    per attempt; a long first clause is cut at a word with an ellipsis."""
    from fvf.param import quadmesh

    advice = "; try another target — more quads resolve small features"
    long = "word " * 100

    def attempt(part, plan, *args):
        raise fvf.QuadExtractionError((long if plan.remeshed else "12 uv triangles") + advice)

    monkeypatch.setattr(quadmesh, "_attempt", attempt)
    with pytest.raises(fvf.QuadMeshError) as info:
        fvf.quad_mesh(fvf.torus(24, 12), target_faces=150)
    lines = info.value.attempts
    assert any(a.endswith("QuadExtractionError: 12 uv triangles") for a in lines), lines
    cut = [a for a in lines if "word" in a]
    assert cut and all(a.endswith("word …") and len(a) < 400 for a in cut), cut
    assert not any("try another target" in a for a in lines)


def star_prism(teeth=60, depth=0.3, length=2.0):
    """A prism over a star of ``teeth`` points (radii 1 and 1 − depth), its ends fanned
    from their centres: sharp edges everywhere, like a knurl (V, F)."""
    k = 2 * teeth
    t = 2 * np.pi * np.arange(k) / k
    r = np.where(np.arange(k) % 2 == 0, 1.0, 1.0 - depth)
    ring = np.stack([r * np.cos(t), r * np.sin(t)], axis=1)
    V = np.vstack(
        [np.c_[ring, np.zeros(k)], np.c_[ring, np.full(k, length)], [[0, 0, 0], [0, 0, length]]]
    )
    i = np.arange(k)
    j = (i + 1) % k
    side = np.r_[np.c_[i, j, j + k], np.c_[i, j + k, i + k]]
    ends = np.r_[np.c_[np.full(k, 2 * k), j, i], np.c_[np.full(k, 2 * k + 1), i + k, j + k]]
    return V, np.r_[side, ends]


def test_feature_density_is_the_features_length_over_area_over_h():
    M = fvf.TriMesh(*box())  # 2 x 1 x 0.5: edges 14 long, area 7
    sharp = sharp_edges(M, 35.0)
    assert sharp.size == 12
    assert np.isclose(feature_density(M, sharp, 0.25), 14 * 0.25 / 7)
    assert feature_density(M, sharp[:0], 0.25) == 0.0


def test_sharp_edges_denser_than_the_quads_are_no_features(monkeypatch):
    """A knurl at a quad size coarser than its teeth: its sharp edges are longer than all
    edges the quads have (density above DENSE_FEATURES), so none is a feature and the
    call says so; with quads fine enough they are features again."""
    from fvf.param import quadmesh
    from fvf.param.features import DENSE_FEATURES
    from fvf.param.quad_parts import component_parts

    M = fvf.TriMesh(*star_prism())
    part = component_parts(M)[0]
    sharp = sharp_edges(M, 35.0)
    assert sharp.size == 120 + 2 * 120  # the teeth's ridges and valleys, the two rims
    coarse = (
        2.5
        * DENSE_FEATURES
        * M.total_area
        / np.linalg.norm(
            M.vertices[M.edges[sharp, 1]] - M.vertices[M.edges[sharp, 0]], axis=1
        ).sum()
    )
    assert feature_density(M, sharp, coarse) == pytest.approx(2.5 * DENSE_FEATURES)
    opts = {"crease_angle": 35.0, "features": True, "user_edges": None}
    assert quadmesh._own_features(part, coarse, opts) is None
    assert opts["dense features"] == {
        (part.label, round(coarse, 12), "itself"): pytest.approx(2.5 * DENSE_FEATURES)
    }
    fine = {"crease_angle": 35.0, "features": True, "user_edges": None}
    assert np.array_equal(quadmesh._own_features(part, coarse / 3, fine), sharp)
    assert "dense features" not in fine
    # meshed as smooth: not sized by the teeth's curvature (here a sizing that asks for
    # quads e times shorter everywhere), where at the finer h it is
    curved = lambda surface, h: np.ones(surface.n_vertices)  # noqa: E731
    monkeypatch.setattr(quadmesh, "curvature_log_scale", curved)
    for h, unsized in ((coarse, True), (coarse / 3, False)):
        plan = quadmesh._Plan(False, "curvature", h, sized=True)
        fresh = {"crease_angle": 35.0, "features": True, "user_edges": None}
        assert (quadmesh._sizing(part, plan, {}, fresh)[1] is None) == unsized
    with pytest.warns(fvf.DenseFeaturesWarning, match="are 5 times as long"):
        with contextlib.suppress(fvf.QuadMeshError):  # one attempt, as a smooth surface
            fvf.quad_mesh(M, edge_length=coarse, retry=False)


def test_a_result_at_more_quads_than_asked_says_so(monkeypatch):
    """When only an attempt at 1.5x the quads is valid, the result comes with a
    QuadCountRaisedWarning naming its edge; at the edge asked, none."""
    from fvf.param import quadmesh

    real = quadmesh._plans

    def finer_only(part, h, *args, **kwargs):
        return [p for p in real(part, h, *args, **kwargs) if p.h < h and not p.sized][:1]

    mesh = fvf.torus(24, 12)
    asked = fvf.quad_mesh(mesh, target_faces=150)  # filterwarnings: error
    monkeypatch.setattr(quadmesh, "_plans", finer_only)
    with pytest.warns(fvf.QuadCountRaisedWarning, match="with quads of edge") as caught:
        made = fvf.quad_mesh(mesh, target_faces=150)
    assert made.validity.valid and len(made.quads) > 1.3 * len(asked.quads)
    edge = float(str(caught[0].message).split("with quads of edge ")[1].split(":")[0])
    assert edge == pytest.approx(asked.parameterization.edge_length * quadmesh.MORE_QUADS, 3e-3)


def _barycentric_off(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """How far each point P (k, 3) is from lying in its triangle T (k, 3, 3), in the
    triangle's own terms: the residual of P = a + s e1 + t e2 (least squares) plus how far
    (s, t, 1 - s - t) fall below zero, float (k,)."""
    a, e1, e2 = T[:, 0], T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]
    E = np.stack([e1, e2], axis=2)  # (k, 3, 2)
    st = np.stack([np.linalg.lstsq(E[i], P[i] - a[i], rcond=None)[0] for i in range(len(P))])
    residual = np.linalg.norm(np.einsum("kdc,kc->kd", E, st) + a - P, axis=1)
    bary = np.stack([st[:, 0], st[:, 1], 1 - st.sum(axis=1)], axis=1)
    return residual / np.linalg.norm(e1, axis=1) + np.maximum(-bary, 0).max(axis=1)


def test_every_quad_vertex_lies_on_the_input_triangle_named_for_it():
    """Spot at 2,000 quads: the untangling moves four quad vertices on the input surface,
    one of them onto another triangle; ``vertex_faces`` names the triangle each vertex
    lies on after the move (it named the one before, 0.35 quad edges away)."""
    mesh = fvf.spot()
    made = fvf.quad_mesh(mesh, target_faces=2000)
    assert "input surface" in made.attempts[-1]  # the untangling ran on the input itself
    T = mesh.vertices[mesh.faces[made.vertex_faces]]
    assert _barycentric_off(made.vertices, T).max() < 1e-6


@pytest.mark.parametrize("case", ["input", "remeshed", "open"])
def test_the_folds_the_gate_is_handed_are_its_own_test_at_the_vertices_returned(case, monkeypatch):
    """``_attempt`` hands the gate the untangling's verdict (instead of evaluating it
    again): on the input surface, on a remeshed copy put back on the input (a 12-triangle
    box, remeshing forced), and not at all for an open surface, whose boundary is snapped
    afterwards. Each verdict handed over equals ``folded_quads`` at the vertices the gate
    checks."""
    from fvf.param import quadmesh
    from fvf.param.quad_folds import folded_quads

    gate = quadmesh.check_quad_mesh
    handed = []

    def spy(mesh, V, Q, **kw):
        if kw.get("folded") is not None:
            assert np.array_equal(kw["folded"], folded_quads(mesh, V, Q))
        handed.append(kw.get("folded") is not None)
        return gate(mesh, V, Q, **kw)

    monkeypatch.setattr(quadmesh, "check_quad_mesh", spy)
    if case == "input":
        mesh, n = fvf.torus(48, 24), 300
    elif case == "remeshed":
        V = np.array([[x, y, z] for x in (0, 1) for y in (0, 2) for z in (0, 3)], float)
        quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
        mesh = fvf.TriMesh(V, np.array([t for a, b, c, d in quads for t in ([a, b, c], [a, c, d])]))
        n = 200
    else:
        S = fvf.icosphere(3)
        keep = S.faces[S.face_centroids[:, 2] > 0.1]
        used = np.unique(keep)
        mesh = fvf.TriMesh(S.vertices[used], np.searchsorted(used, keep))
        n = 200
    made = fvf.quad_mesh(mesh, target_faces=n, remesh=case == "remeshed")
    assert handed and len(made.quads) > 0
    assert ("remeshed" in made.attempts[-1]) == (case == "remeshed"), made.attempts
    assert all(handed) if case != "open" else not any(handed)
