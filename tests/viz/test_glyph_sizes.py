"""Glyphs and singularity markers no larger than the detail they sit on
(fvf.viz.overlay.feature_factors)."""

from __future__ import annotations

import numpy as np
import pytest

import fvf

overlay = pytest.importorskip("fvf.viz.overlay")
scene_mod = pytest.importorskip("fvf.viz.scene")


def ball_and_finger() -> fvf.TriMesh:
    """A unit sphere beside a thin ellipsoid (radius 0.03, 1.8 long): a body and a finger."""
    ball = fvf.icosphere(4)
    finger = ball.vertices * [0.03, 0.03, 0.9] + [1.5, 0.0, 0.0]
    V = np.vstack([ball.vertices, finger])
    F = np.vstack([ball.faces, ball.faces + ball.n_vertices])
    return fvf.TriMesh(V, F)


def test_feature_factors_follow_the_curvature():
    mesh = ball_and_finger()
    c = np.array([[0.0, 0.0, 1.0], [1.53, 0.0, 0.0]])  # on the ball, on the finger's side
    n = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    f = overlay.feature_factors(mesh.vertices, c, n, np.array([0.1, 0.1]))
    assert f[0] == 1.0  # 0.1 on a unit sphere is flat
    assert f[1] <= 0.5  # 0.1 across a finger 0.06 wide is not


def test_crosses_and_markers_shrink_on_thin_parts():
    mesh = ball_and_finger()
    c = mesh.face_centroids
    u = mesh.project_tangent(np.cross(c - [0.7, 0, 0], [0.0, 1.0, 0.0]) + [0.0, 0.0, 0.3])
    markers = np.array([[0.0, 0.0, -1.0], [1.5, 0.0, -0.9]])  # on the ball, the finger tip
    scene = scene_mod.build_scene(
        mesh, field=u, n=4, singularities=(markers, np.array([0.25, -0.25])), view=(90.0, 0.0, "z")
    )
    ov = overlay.panel_overlay(scene, scene.frame, 1.0, 600, 450)
    g = ov.glyphs[0]
    k = g.anchors.shape[0] // 4
    length = np.linalg.norm(g.polygons - g.anchors[:, None], axis=2).max(1)[:k]
    on_finger = g.anchors[:k, 0] > 1.3
    assert on_finger.sum() >= 3 and (~on_finger).sum() >= 20
    assert np.median(length[on_finger]) < 0.6 * np.median(length[~on_finger])
    assert ov.marker_radii[1] < 0.6 * ov.marker_radii[0]
    assert ov.marker_radii[1] * ov.pixel_scale > 2.0 - 1e-9  # never below 2 pixels


def test_legend_counts_are_never_cut_off(tmp_path):
    """A legend line as long as "index +1/4 (1650)" widens the side column: nothing is
    drawn in the picture's last pixels (it was cut at "(165")."""
    pytest.importorskip("matplotlib")
    Image = pytest.importorskip("PIL.Image")
    import fvf.viz
    from fvf.viz.compose import LEGEND_WIDTH, legend_width

    mesh = fvf.icosphere(3)
    rng = np.random.default_rng(3)
    k = 1650 + 1250
    pos = mesh.vertices[rng.choice(mesh.n_vertices, k)]
    idx = np.r_[np.full(1650, 0.25), np.full(1250, -0.25)]
    scene = scene_mod.build_scene(mesh, singularities=(pos, idx))
    assert legend_width(scene, 960) > LEGEND_WIDTH
    for size in ((960, 450), (500, 400)):
        info = fvf.viz.render(
            mesh, tmp_path / "s.png", singularities=(pos, idx), size=size, backend="matplotlib"
        )
        img = np.asarray(Image.open(info.path).convert("RGB")).astype(int)
        assert (img[:, -3:] > 245).all(), size


def test_fields_and_markers_stay_apart_for_colour_blind_readers():
    """Each overlay is named by its colour in the legend: two fields, and a field and the
    singularity markers, differ by ΔE* > 30 also as deuteranopes and protanopes see them
    (the second field was orange beside a green first one: ΔE* 14 for them)."""
    from fvf.viz.colors import simulate_color_blindness, srgb_to_lab

    mesh = fvf.icosphere(2)
    rng = np.random.default_rng(4)
    v, w = (mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3))) for _ in range(2))
    pos, idx = mesh.vertices[:2], np.array([0.25, -0.25])
    for kwargs in ({}, {"function": mesh.vertices[:, 1]}, {"singularities": (pos, idx)}):
        scene = scene_mod.build_scene(mesh, field=[v, w], **kwargs)
        colors = [f.color for f in scene.fields]
        if scene.markers is not None:
            colors += [fvf.viz.index_color(i) for i in idx]
        for i in range(len(colors)):
            for j in range(i):
                for kind in (None, "deuteranopia", "protanopia"):
                    a, b = colors[i], colors[j]
                    if kind:
                        a, b = simulate_color_blindness(a, kind), simulate_color_blindness(b, kind)
                    assert np.linalg.norm(srgb_to_lab(a) - srgb_to_lab(b)) > 30, (kwargs, kind)


def test_checkerboard_squares_are_cut_exactly():
    """The checkerboard's pieces each lie in one square of the uv grid (straight edges,
    not sub-triangles coloured one by one) and tile the triangles they come from."""
    from fvf.viz.quads import _cut_at_integers

    mesh = fvf.icosphere(2)
    rng = np.random.default_rng(6)
    X = mesh.vertices[mesh.faces]
    W = X[..., :2] * 7.3 + rng.uniform(-0.2, 0.2, (mesh.n_faces, 1, 2))
    for axis in (0, 1):
        X, W = _cut_at_integers(X, W, axis)
    cell = np.floor(W.mean(axis=1))
    assert (W >= cell[:, None] - 1e-9).all() and (W <= cell[:, None] + 1 + 1e-9).all()
    area = 0.5 * np.linalg.norm(np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), axis=1)
    assert area.sum() == pytest.approx(mesh.total_area, rel=1e-12)
    assert X.shape[0] > 3 * mesh.n_faces  # the grid is finer than the mesh: many cuts


def test_equal_texture_values_share_one_grey():
    from fvf.viz.colors import equalize

    g = equalize(np.array([0.35, 0.85, 0.35, 0.85, 0.35]), np.array([1.0, 1, 1, 1, 2]))
    np.testing.assert_allclose(g, [1 / 3, 5 / 6, 1 / 3, 5 / 6, 1 / 3])
    r = np.random.default_rng(0).random(50)  # distinct values: the ranks, as before
    np.testing.assert_allclose(equalize(r), (np.argsort(np.argsort(r)) + 0.5) / 50)
