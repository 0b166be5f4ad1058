"""A second corpus of the parts and scans people bring, built apart from the wild corpus
(``wild_corpus.py``) and judged by ``quadcheck`` alone: CSG parts (a notched cylinder, a
knife-edged wedge, a star extrusion, a chamfered box, a tower in y-up millimetres, two
solids of revolution linked in one file), a sphere at 1e-3 given as a triangle soup, a
frustum, a wavy torus, a body with an axle at 1e6, and scans with holes cut (vertices left
over, as a scanning tool leaves them: ``as_mesh(repair=True)`` first).

Each must come out valid at 600 quads: the notched cylinder was rejected by fvf's own
fold gate on every attempt, and the soup was meshed triangle by triangle for minutes.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

import fvf
import quadcheck
from wild_corpus import _from_manifold

mf = pytest.importorskip("manifold3d")


def notched_cylinder():
    cut = mf.Manifold.cube([0.8, 3, 0.8], True).translate([0.5, 0, 0.6])
    return _from_manifold(mf.Manifold.cylinder(2, 1, 1, 96, True) - cut)


def wedge_knife():
    return _from_manifold(mf.Manifold.extrude(mf.CrossSection([[[0, 0], [4, 0], [0, 0.6]]]), 2))


def star_extrusion():
    a = np.linspace(0, 2 * np.pi, 14, endpoint=False)
    r = np.where(np.arange(14) % 2 == 0, 1.0, 0.45)
    star = np.stack([r * np.cos(a), r * np.sin(a)], 1).tolist()
    return _from_manifold(mf.Manifold.extrude(mf.CrossSection([star]), 0.4))


def chamfer_box():
    cutter = mf.Manifold.cube([2, 2, 2], True).rotate([45, 0, 0]).translate([0, 0, 2.1])
    return _from_manifold(mf.Manifold.cube([2, 2, 2], True) - cutter)


def tower_yup_millimetres():
    tower = mf.Manifold.cube([1, 1, 1], True) + mf.Manifold.cube([0.5, 0.5, 2], True).translate(
        [0, 0, 1]
    )
    V, F = _from_manifold(tower)
    return 1e3 * V[:, [0, 2, 1]] * [1, 1, -1], F[:, [0, 2, 1]]  # y up, still outward


def linked_rings():
    ring = mf.Manifold.revolve(mf.CrossSection.circle(0.25, 24).translate([1, 0]), 48)
    return _from_manifold(ring + ring.rotate([90, 0, 0]).translate([3, 0, 0]))


def sphere_soup_milli():
    V, F = _from_manifold(mf.Manifold.sphere(1, 48))
    corners = 1e-3 * V[F].reshape(-1, 3)
    return corners, np.arange(len(corners)).reshape(-1, 3)


def frustum():
    return _from_manifold(mf.Manifold.cylinder(3, 0.5, 0.2, 64, True))


def wavy_torus():
    rng = np.random.default_rng(7)
    t, s = np.meshgrid(
        np.linspace(0, 2 * np.pi, 60, endpoint=False),
        np.linspace(0, 2 * np.pi, 24, endpoint=False),
        indexing="ij",
    )
    R = 1 + 0.3 * np.cos(3 * t) + 0.25 * np.cos(s)
    z = 0.25 * np.sin(s) + 0.01 * rng.normal(size=s.shape)
    V = np.stack([R * np.cos(t), R * np.sin(t), z], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(60), np.arange(24), indexing="ij")
    a, b = i * 24 + j, (i + 1) % 60 * 24 + j
    c, d = (i + 1) % 60 * 24 + (j + 1) % 24, i * 24 + (j + 1) % 24
    F = np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)]).reshape(-1, 3)
    return V, F


def sphere_axle_mega():
    V, F = _from_manifold(mf.Manifold.sphere(1, 40) + mf.Manifold.cube([0.3, 0.3, 2.6], True))
    return 1e6 * V, F


def scan_bowl():
    V, F = _from_manifold(mf.Manifold.sphere(1, 64))
    return V, F[V[F].mean(axis=1)[:, 2] < 0.6]  # the cap's vertices stay in the arrays


def scan_sphere_holes():
    V, F = _from_manifold(mf.Manifold.sphere(1, 80))
    centre = V[F].mean(axis=1)
    keep = np.ones(len(F), bool)
    for c in ([1, 0, 0], [0, -1, 0.3], [-0.5, 0.5, -0.7]):
        keep &= np.linalg.norm(centre - np.array(c) / np.linalg.norm(c), axis=1) > 0.35
    return V * (1 + 0.01 * np.sin(7 * V[:, :1])), F[keep]


SHAPES = {
    f.__name__: f
    for f in (
        notched_cylinder,
        wedge_knife,
        star_extrusion,
        chamfer_box,
        tower_yup_millimetres,
        linked_rings,
        sphere_soup_milli,
        frustum,
        wavy_torus,
        sphere_axle_mega,
        scan_bowl,
        scan_sphere_holes,
    )
}


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.slow) if n == "scan_sphere_holes" else n  # 4-5 s
        for n in SHAPES
    ],
)
@pytest.mark.filterwarnings("ignore::fvf.errors.DuplicateVertexWarning")  # the soup's
def test_each_part_gets_a_valid_quad_mesh(name):
    """Valid by the independent judge, against the surface fvf meshed (``result.mesh``:
    the joined soup, the repaired scan), whose topology matches the input's repair."""
    mesh = fvf.as_mesh(SHAPES[name](), repair=True)
    if name == "sphere_soup_milli":
        with pytest.warns(fvf.VerticesWeldedWarning):
            made = fvf.quad_mesh(mesh, target_faces=600)
    else:
        made = fvf.quad_mesh(mesh, target_faces=600)
    V, Q = np.asarray(made.vertices), np.asarray(made.quads)
    verdict = quadcheck.check(made.mesh.vertices, made.mesh.faces, V, Q)
    assert verdict.valid, verdict.summary()
    assert made.mesh.n_components == mesh.n_components or name == "sphere_soup_milli"
    assert 400 <= len(Q) <= 900


@pytest.mark.slow  # 6-8 s
def test_quads_beside_a_hole_never_share_a_corner_point():
    """At 1,500 quads the quad vertices beside the sphere's holes, put back on the open
    surface, fell on the same convex corner of a hole's boundary: every attempt had quads
    with two corners at one point. Those vertices now keep their place beside the
    boundary, and the mesh is valid by the judge."""
    mesh = fvf.as_mesh(scan_sphere_holes(), repair=True)
    made = fvf.quad_mesh(mesh, target_faces=1500)
    V, Q = np.asarray(made.vertices), np.asarray(made.quads)
    P = V[Q]
    assert np.linalg.norm(P - np.roll(P, -1, axis=1), axis=2).min() > 0
    verdict = quadcheck.check(mesh.vertices, mesh.faces, V, Q)
    assert verdict.valid, verdict.summary()


def plate_slot_boss():
    """A 5.25 mm plate with a boss and a 1.53 mm slot, turned, and a cube beside it (the
    OpenSCAD-like part that exposed the folds of quads put back on a coarse input)."""
    plate = mf.Manifold.cube([49.47, 20.5, 5.25]) + mf.Manifold.cylinder(
        9.56, 4.97, 4.97, 40
    ).translate([13.87, 5.41, 1])
    plate = (plate - mf.Manifold.cube([20, 1.53, 30]).translate([10, 8, -10])).rotate(
        [12.9, 48.14, 0]
    )
    return _from_manifold(plate + mf.Manifold.cube([10, 10, 10]).translate([120, 0, 0]))


@pytest.mark.slow  # 5 s
def test_quads_put_back_on_a_coarse_input_are_untangled_there():
    """The 188-triangle plate is remeshed before its field; its quads, put back on the
    input's few large triangles, folded over the slot's and the boss's edges where the
    remeshed surface had rounded them (1 to 6 quads per attempt, by the gate's count), and
    every attempt at 1,000 quads failed. They are now untangled on the input itself."""
    mesh = fvf.as_mesh(plate_slot_boss())
    made = fvf.quad_mesh(mesh, target_faces=1000)
    V, Q = np.asarray(made.vertices), np.asarray(made.quads)
    verdict = quadcheck.check(mesh.vertices, mesh.faces, V, Q)
    assert verdict.valid, verdict.summary()


@pytest.mark.perf
def test_a_rounding_with_most_triangles_flipped_is_not_repaired():
    """A hemisphere at 3,000 quads: its attempt with the rim an integer iso-line (the only
    one with ``retry=False``; the attempts holding the field come first otherwise) flips
    most triangles; the local repair is skipped there (``uv_folds.HOPELESS_FRACTION``:
    190 s of rounds that never succeed), and the default attempts give a valid mesh."""
    sphere = fvf.icosphere(4)
    centre = sphere.face_centroids
    mesh = fvf.TriMesh(
        *fvf.remove_unreferenced_vertices(sphere.vertices, sphere.faces[centre[:, 1] > -0.05])[:2]
    )
    said = []
    start = time.process_time()
    with (
        pytest.raises(fvf.QuadMeshError, match="features as iso-lines"),
        pytest.warns(fvf.FlippedParameterizationWarning),
    ):
        fvf.quad_mesh(mesh, target_faces=3000, retry=False, progress=lambda m, d, n: said.append(m))
    assert any("too many to repair" in m for m in said)
    assert time.process_time() - start < 30.0
    made = fvf.quad_mesh(mesh, target_faces=3000)
    verdict = quadcheck.check(mesh.vertices, mesh.faces, *map(np.asarray, made))
    assert verdict.valid, verdict.summary()


def test_a_cad_quad_mesh_is_shaded_with_its_rims_crisp():
    """The picture of a CAD part's quads (fvf.viz.render_quads) splits the shading at its
    rims: at 300 quads the disc's quads bend along the rim, which sharp_edges takes for
    a rough surface (it keeps 4 of the 58 edges that bend by more than 75°, and the
    shading split none); the fold chains split 56 (the other two end a chain, where the
    faces around the vertex still join the other way round)."""
    from fvf.param.features import dihedral_angles
    from fvf.viz.ps_backend import SHADING_FOLD, shading_corners
    from fvf.viz.quads import _shading_mesh
    from wild_corpus import cad_cylinder_boss, repaired_as_cli

    made = fvf.quad_mesh(repaired_as_cli(*cad_cylinder_boss()), target_faces=300)
    mesh = _shading_mesh(np.asarray(made.vertices), np.asarray(made.quads))
    folds = np.flatnonzero(dihedral_angles(mesh) > SHADING_FOLD)
    _, W, _ = shading_corners(mesh)

    def split(e):  # both ends: the two faces' corners are different shading vertices
        f, g = mesh.edge_faces[e]
        F = mesh.faces
        return all(W[f][F[f] == v] != W[g][F[g] == v] for v in mesh.edges[e])

    assert folds.size > 40
    assert sum(split(e) for e in folds) >= 0.9 * folds.size
