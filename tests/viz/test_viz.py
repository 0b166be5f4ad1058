"""fvf.viz: pictures checked by what they show, arrows in their faces, LIC along v."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import fvf

viz = pytest.importorskip("fvf.viz")
pytest.importorskip("matplotlib")
pytest.importorskip("PIL")


@pytest.fixture(scope="module")
def sphere():
    return fvf.icosphere(3)


def rotation_field(mesh):
    """The rotation about the z axis, tangent per face (m, 3)."""
    return mesh.project_tangent(np.cross([0.0, 0.0, 1.0], mesh.face_centroids))


def along_across(mesh, v, T):
    """Area-weighted ⟨∇T, v̂⟩² and ⟨∇T, J v̂⟩² summed over faces."""
    u = viz.unit_field(mesh, v)
    g = fvf.gradient(mesh, T)
    a = mesh.face_areas
    return a @ ((g * u).sum(1) ** 2), a @ ((g * fvf.rotate(mesh, u)).sum(1) ** 2)


def test_import_fvf_does_not_import_the_viz_extra():
    code = (
        "import sys, fvf, fvf.viz\n"
        "print([m for m in ('matplotlib', 'polyscope', 'PIL') if m in sys.modules])"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"


def test_missing_extra_names_the_install_command():
    from fvf.viz._deps import require

    with pytest.raises(viz.MissingExtraError, match=r"pip install 'fvf\[viz\]'"):
        require("no_such_module_fvf_test")
    assert issubclass(viz.MissingExtraError, fvf.FvfError)


def test_arrows_lie_in_their_faces_with_absolute_length(rng):
    mesh = fvf.jittered_sphere(2, 0.3, seed=2)
    v = mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3)))
    seg = viz.arrow_segments(mesh, v, 0.37)
    assert seg.shape == (mesh.n_faces, 2, 3)
    np.testing.assert_allclose(seg[:, 0], mesh.face_centroids, rtol=0, atol=1e-15)
    d = seg[:, 1] - seg[:, 0]
    normal = np.abs((d * mesh.face_normals).sum(1))
    assert normal.max() <= 1e-12 * np.linalg.norm(d, axis=1).max()
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 0.37 * np.linalg.norm(v, axis=1))
    # default scale: the robust longest arrow (here the longest: no outliers) is
    # DEFAULT_ARROW_LENGTH mean edge lengths
    w = mesh.project_tangent(np.cross([0.0, 0.0, 1.0], mesh.face_centroids))
    d = np.diff(viz.arrow_segments(mesh, w), axis=1)[:, 0]
    top = np.linalg.norm(d, axis=1).max()
    assert top == pytest.approx(viz.DEFAULT_ARROW_LENGTH * mesh.mean_edge_length)
    # one huge vector does not shrink every other arrow
    spiked = w.copy()
    spiked[7] *= 1e4
    # (the robust top is the 99th percentile of |v| then, 0.4% below the max of w here)
    assert viz.default_arrow_scale(mesh, spiked) == pytest.approx(
        viz.default_arrow_scale(mesh, w), rel=0.02
    )


def test_direction_set_turns_the_representative_by_2pi_over_n(rng):
    mesh = fvf.jittered_sphere(2, 0.3, seed=5)
    u = mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3)))
    for n in (1, 2, 3, 4, 6):
        d = viz.direction_set(mesh, u, n)
        assert d.shape == (n, mesh.n_faces, 3)
        np.testing.assert_allclose(d[0], u, atol=1e-14)
        length = np.linalg.norm(u, axis=1)
        np.testing.assert_allclose(
            np.linalg.norm(d, axis=2), np.broadcast_to(length, (n, length.size))
        )
        assert np.abs((d * mesh.face_normals[None]).sum(2)).max() < 1e-13  # tangent
        # d_{k+1} is d_k turned by +2π/N about the normal: cos and sin of the angle
        nxt = np.roll(d, -1, axis=0)
        norm2 = (u * u).sum(1)[None]
        cos = (d * nxt).sum(2) / norm2
        sin = (np.cross(d, nxt) * mesh.face_normals[None]).sum(2) / norm2
        np.testing.assert_allclose(cos, np.cos(2 * np.pi / n), atol=1e-12)
        np.testing.assert_allclose(sin, np.sin(2 * np.pi / n), atol=1e-12)
    with pytest.raises(fvf.FvfError, match="positive integer"):
        viz.direction_set(mesh, u, 0)


def test_lic_is_correlated_along_v_not_across(sphere):
    mesh = fvf.icosphere(4)
    v = rotation_field(mesh)
    T = viz.lic_texture(mesh, v)
    noise = viz.lic_noise(mesh)
    along, across = along_across(mesh, v, T)
    assert along < 0.35 * across  # measured 0.27 (icosphere 4), 0.17 (icosphere 3)
    n_along, n_across = along_across(mesh, v, noise)  # the noise itself is isotropic
    assert 0.6 < n_along / n_across < 1.6
    assert noise.min() <= T.min() and T.max() <= noise.max()  # upwind: convex averages
    # the same along Jv: the texture turns with the field
    along, across = along_across(mesh, fvf.rotate(mesh, v), viz.lic_texture(mesh, v))
    assert across < 0.35 * along


def test_streamlines_stay_on_the_surface_and_follow_v():
    mesh = fvf.jittered_sphere(3, 0.3, seed=4)
    v = rotation_field(mesh) + 0.3 * fvf.gradient(mesh, mesh.vertices[:, 2])
    lines, faces = viz.streamlines(mesh, v, 40, return_faces=True)
    assert len(lines) > 20
    unit = viz.unit_field(mesh, v)
    G = fvf.calculus.hat_gradients(mesh)
    X, F = mesh.vertices, mesh.faces
    total = 0
    for p, f in zip(lines, faces, strict=True):
        assert p.shape == (f.size + 1, 3)
        seg = np.diff(p, axis=0)
        length = np.linalg.norm(seg, axis=1)
        keep = length > 1e-9 * mesh.mean_edge_length
        # parallel to v in the face the segment crosses
        cos = (seg[keep] * unit[f[keep]]).sum(1) / length[keep]
        assert np.all(cos > 1 - 1e-9)
        # both ends inside that face: barycentric coordinates in [0, 1]
        for q in (p[:-1], p[1:]):
            b = np.einsum("kij,kij->ki", G[f], q[:, None, :] - X[F[f][:, [1, 2, 0]]])
            assert b.min() > -1e-8 and abs(b.sum(1) - 1).max() < 1e-8
        total += length.sum()
    assert total > 10 * len(lines) * mesh.mean_edge_length


def backends():
    out = ["matplotlib"]
    if viz.polyscope_status() is None:
        out.insert(0, "polyscope-egl")
    return out


def need(backend):
    if backend not in backends():
        pytest.skip(f"polyscope headless unavailable: {viz.polyscope_status()}")


def picture(path):
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB")).astype(int)


def content(img):
    """Fraction of non-white pixels and the number of distinct hues (12 bins) of saturated
    pixels."""
    import matplotlib.colors as mcolors

    busy = (img < 245).any(2)
    hsv = mcolors.rgb_to_hsv(img / 255.0)
    sat = (hsv[..., 1] > 0.3) & (hsv[..., 2] > 0.2)
    hues = np.unique((hsv[..., 0][sat] * 12).astype(int))
    return busy.mean(), hues.size


def near_color(img, rgb, tol=40):
    """Pixels within ``tol`` (0-255 units, each channel) of a colour in [0, 1]."""
    return (np.abs(img - 255 * np.asarray(rgb)[None, None]) <= tol).all(2)


@pytest.mark.parametrize("backend", ["polyscope-egl", "matplotlib"])
def test_render_function_field_markers(sphere, tmp_path, backend):
    need(backend)
    v = rotation_field(sphere)
    ids, ind = fvf.singularities(sphere, v)
    info = viz.render(
        sphere,
        tmp_path / "a.png",
        function=sphere.vertices[:, 2],
        field=v,
        singularities=(fvf.singularity_positions(sphere, ids), ind),
        title="z",
        backend=backend,
        size=(400, 300),
        colorbar_label="height z",
    )
    assert info.backend == backend and info.size == (400, 300)
    assert info.n_singularities == 2 and info.n_arrows > 100
    img = picture(info.path)
    assert img.shape == (300, 400, 3)
    busy, hues = content(img)
    assert 0.15 < busy < 0.8  # the sphere fills a fair part of the picture, not all of it
    assert hues >= 4  # viridis from purple to yellow, the arrows and markers
    # the colorbar: a column of many colours in the side column, above the legend
    side = img[:, 400 - 124 :]
    assert np.unique(side[40:160].reshape(-1, 3) // 16, axis=0).shape[0] > 20
    # the legend: the marker colour of index +1 (both singularities of the rotation)
    assert near_color(side[150:], viz.index_color(1), tol=25).sum() > 20


@pytest.mark.parametrize("backend", ["polyscope-egl", "matplotlib"])
def test_arrow_pixels_are_present_and_contrast_with_the_colormap(sphere, tmp_path, backend):
    """The arrows' colour is far (CIELAB) from every colour of the surface, and many pixels
    of the picture have it."""
    from fvf.viz.colors import srgb_to_lab

    need(backend)
    v = rotation_field(sphere)
    f = sphere.vertices[:, 2]
    common = dict(function=f, backend=backend, size=(400, 300), view=(0, 20, "z"))
    bare = picture(viz.render(sphere, tmp_path / "bare.png", **common).path)
    info = viz.render(sphere, tmp_path / "arrows.png", field=v, **common)
    img = picture(info.path)
    color = info.extra["arrow_colors"][0]
    surface = bare[:, :276][(bare[:, :276] < 245).any(2)] / 255.0  # the shaded colormap
    gap = np.linalg.norm(srgb_to_lab(surface) - srgb_to_lab(color), axis=1)
    assert np.percentile(gap, 1) > 35  # ΔE*: clearly another colour everywhere
    arrow_px = near_color(img, color, tol=45).sum()
    assert arrow_px > 5 * info.n_arrows  # every arrow shows (12 px apart at this size)
    assert near_color(bare, color, tol=45).sum() < 0.02 * arrow_px  # not a colormap colour
    # and they sit on the sphere, with a halo (black or white) around them
    changed = (np.abs(img - bare).sum(2) > 60)[:, :276]
    assert 0.03 < changed.mean() < 0.3


@pytest.mark.parametrize("backend", ["polyscope-egl", "matplotlib"])
def test_arrow_density_is_chosen_in_screen_space(sphere, tmp_path, backend):
    """A 16x finer mesh of the same sphere gets as many arrows, as visible as before (a
    fixed count of faces made them vanish on a 750k-face mesh)."""
    need(backend)
    fine, v_fine, _ = viz.subdivide(sphere, rotation_field(sphere), levels=2)
    shown = []
    for mesh, v, name in ((sphere, rotation_field(sphere), "coarse"), (fine, v_fine, "fine")):
        info = viz.render(mesh, tmp_path / f"{name}.png", field=v, backend=backend, size=(320, 240))
        px = near_color(picture(info.path), info.extra["arrow_colors"][0], tol=45).sum()
        shown.append((info.n_arrows, px, info.arrow_scale))
    (n0, px0, s0), (n1, px1, s1) = shown
    assert n0 > 60 and abs(n1 - n0) < 0.25 * n0
    assert px1 > 0.6 * px0
    assert s1 == pytest.approx(s0, rel=0.05)  # the length is set by the picture, not the mesh
    # more pixels, more arrows; a given spacing sets the count
    big = viz.render(fine, tmp_path / "big.png", field=v_fine, size=(560, 420), backend=backend)
    dense = viz.render(
        fine,
        tmp_path / "dense.png",
        field=v_fine,
        size=(320, 240),
        arrow_spacing=8,
        backend=backend,
    )
    assert big.n_arrows > 1.5 * n1 and dense.n_arrows > 1.5 * n1
    capped = viz.render(
        fine, tmp_path / "cap.png", field=v_fine, size=(320, 240), max_arrows=30, backend=backend
    )
    assert 10 < capped.n_arrows <= 33


@pytest.mark.parametrize("backend", ["polyscope-egl", "matplotlib"])
def test_n_direction_fields_draw_n_strokes_per_face(sphere, tmp_path, backend):
    from fvf.viz.overlay import panel_overlay
    from fvf.viz.scene import build_scene

    need(backend)
    v = viz.unit_field(sphere, rotation_field(sphere))
    for n in (2, 4):
        scene = build_scene(sphere, field=v, n=n)
        ov = panel_overlay(scene, scene.frames[0], 1.0, 300, 300)
        g = ov.glyphs[0]
        assert g.polygons.shape == (n * ov.n_arrows, 4, 3)  # n strokes per chosen face
        # every stroke starts at its face's centroid and lies in the face's plane
        d = g.polygons.mean(1) - g.anchors
        assert np.abs((d * g.normals).sum(1)).max() < 1e-12
    info = viz.render(
        sphere, tmp_path / "cross.png", field=v, n=4, backend=backend, size=(320, 240)
    )
    px = near_color(picture(info.path), info.extra["arrow_colors"][0], tol=45).sum()
    assert px > 8 * info.n_arrows  # four strokes per face
    for bad in (0, 2.5, -4):
        with pytest.raises(fvf.FvfError, match="positive integer"):
            viz.render(sphere, tmp_path / "x.png", field=v, n=bad, backend=backend)


def test_robust_colour_range_excludes_outliers(sphere, tmp_path):
    f = sphere.vertices[:, 2].copy()
    info = viz.render(
        sphere, tmp_path / "clean.png", function=f, backend="matplotlib", size=(200, 150)
    )
    assert info.clim == (f.min(), f.max())  # nothing to clip: the exact range
    spiked = f.copy()
    spiked[[3, 50, 97]] = [500.0, -300.0, 800.0]  # needle-face spikes
    info = viz.render(
        sphere, tmp_path / "spiked.png", function=spiked, backend="matplotlib", size=(200, 150)
    )
    lo, hi = info.clim
    assert -1.0 <= lo < -0.8 and 0.8 < hi <= 1.0  # the spikes do not set the range
    scene = fvf.viz.scene.build_scene(sphere, function=spiked)
    assert scene.colorbar["extend"] == "both"  # clipped values show on the colorbar
    lo, hi, _, _ = viz.robust_limits(spiked, sphere.vertex_areas, symmetric=True)
    assert lo == -hi and 0.8 < hi <= 1.0
    info = viz.render(
        sphere,
        tmp_path / "full.png",
        function=spiked,
        clim="full",
        backend="matplotlib",
        size=(200, 150),
    )
    assert info.clim == (-300.0, 800.0)
    with pytest.raises(fvf.FvfError, match="clim"):
        viz.render(sphere, tmp_path / "x.png", function=f, clim="loud", backend="matplotlib")


def test_singularity_legend_shows_every_index_and_its_colour(sphere, tmp_path):
    P = sphere.vertices[[0, 5, 9, 11, 20, 30]]
    ind = np.array([1, -1, 0.25, -0.25, 0.5, -0.5])
    labels = [viz.index_label(i) for i in ind]
    assert labels == ["+1", "-1", "+1/4", "-1/4", "+1/2", "-1/2"]
    colors = {tuple(viz.index_color(i)) for i in ind}
    assert len(colors) == 6  # every index its own colour
    info = viz.render(
        sphere, tmp_path / "s.png", singularities=(P, ind), backend="matplotlib", size=(400, 300)
    )
    legend = picture(info.path)[:, 400 - 124 :]
    for i in ind:
        assert near_color(legend, viz.index_color(i), tol=20).sum() > 15, i
    # no singularities: the legend says so rather than vanishing
    info = viz.render(
        sphere,
        tmp_path / "none.png",
        singularities=(np.zeros((0, 3)), []),
        backend="matplotlib",
        size=(400, 300),
    )
    assert (picture(info.path)[:, 400 - 124 :] < 100).any()


@pytest.mark.parametrize("backend", ["polyscope-egl", "matplotlib"])
def test_two_sides_show_both_halves(sphere, tmp_path, backend):
    from fvf.viz.overlay import panel_overlay
    from fvf.viz.scene import build_scene

    need(backend)
    v = rotation_field(sphere)
    views = viz.two_sides(viz.View(up="z"))
    info = viz.render(
        sphere, tmp_path / "two.png", field=v, view=views, backend=backend, size=(600, 300)
    )
    assert info.extra["panels"] == 2
    img = picture(info.path)
    left, right = img[:, :297], img[:, 303:]
    for half in (left, right):
        assert 0.15 < content(half)[0] < 0.8
    scene = build_scene(sphere, field=v, view=views)
    front, back = (scene.frames[i][2] for i in (0, 1))
    np.testing.assert_allclose(front, -back * np.array([1, 1, -1]), atol=1e-12)  # turned 180°
    faces = [
        np.unique(
            np.round(panel_overlay(scene, scene.frames[i], 1.0, 300, 300).glyphs[0].anchors, 9),
            axis=0,
        )
        for i in (0, 1)
    ]
    # arrows of the second panel are on the far side of the first
    assert (faces[1] @ front < 0).mean() > 0.9 and (faces[0] @ front > 0).mean() > 0.9


def test_up_axis_is_detected_from_what_the_shape_stands_on():
    box = fvf.TriMesh(*_box(1.0, 1.2, 3.0))  # tall in z, standing on its -z face
    assert viz.detect_up_axis(box.vertices) == "z"
    assert viz.detect_up_axis(box.vertices[:, [0, 2, 1]]) == "y"  # tall in y
    plate = _box(3.0, 2.0, 0.2)[0]  # flat in the xy plane: looked at from +z with y up
    assert viz.detect_up_axis(plate) == "y"
    assert viz.detect_up_axis(fvf.icosphere(2).vertices) == "y"


@pytest.mark.parametrize(
    "name, up", [("spot.obj", "y"), ("nefertiti.obj", "z"), ("lion-00.off", "y")]
)
def test_up_axis_of_scans(name, up):
    from conftest import shared_mesh_path

    mesh = fvf.TriMesh(*fvf.read_mesh(shared_mesh_path(name)))
    c = mesh.face_areas @ mesh.face_centroids / mesh.total_area
    assert viz.detect_up_axis(mesh.vertices, c) == up
    assert fvf.viz.scene.build_scene(mesh).views[0].up == up


def _box(a, b, c):
    """A closed box [0, a] x [0, b] x [0, c] split into 2 triangles per side, per unit."""
    import itertools

    V = np.array(list(itertools.product([0, a], [0, b], [0, c])), dtype=float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    F = np.array([t for q in quads for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))])
    return V, F


def ink_box(img):
    """(rows, columns) spanned by the non-white pixels of a picture."""
    rows = np.flatnonzero((img < 245).any(2).any(1))
    cols = np.flatnonzero((img < 245).any(2).any(0))
    return rows[-1] - rows[0] + 1, cols[-1] - cols[0] + 1


@pytest.mark.parametrize("backend", ["polyscope-egl", "matplotlib"])
def test_up_option_stands_the_shape_up(tmp_path, backend):
    """An ellipsoid tall in y is drawn taller than wide with up y, wider than tall with up
    z; with up -y its top (high y, yellow in viridis) is at the bottom of the picture."""
    need(backend)
    ball = fvf.icosphere(3)
    tall = fvf.TriMesh(ball.vertices * [1.0, 3.0, 1.0], ball.faces)
    y = tall.vertices[:, 1]
    common = dict(backend=backend, size=(300, 300), view=(0.0, 0.0))
    shapes = {}
    for up in ("y", "z", "-y"):
        info = viz.render(tall, tmp_path / f"{up}.png", up=up, **common)
        assert info.extra["up"] == up
        shapes[up] = ink_box(picture(info.path))
    assert shapes["y"][0] > 2.5 * shapes["y"][1]  # rows vs columns: 3 : 1 seen from the front
    assert shapes["z"][1] > 2.5 * shapes["z"][0]  # seen from +x, y across
    assert shapes["-y"] == pytest.approx(shapes["y"], abs=2)
    style = viz.RenderStyle(size=(300, 300), view=(0.0, 0.0), backend=backend, cmap="viridis")
    for up, top_is_high in (("y", True), ("-y", False)):
        img = picture(
            viz.render(tall, tmp_path / "f.png", function=y, style=style.replace(up=up)).path
        )
        panel = img[:, :200]
        rows = np.flatnonzero((panel < 245).any(2).any(1))
        top, bottom = panel[rows[:20]], panel[rows[-20:]]
        # viridis: yellow (high) has far more red than purple (low)
        red_top = top[..., 0][(top < 245).any(2)].mean()
        red_bottom = bottom[..., 0][(bottom < 245).any(2)].mean()
        assert (red_top > red_bottom + 60) == top_is_high, (up, red_top, red_bottom)
    # a view's own up wins over the style's; the style's fills in "auto"
    scene = fvf.viz.scene.build_scene(tall, view=[(0, 0, "z"), (0, 0)], up="-x")
    assert [v.up for v in scene.views] == ["z", "-x"]
    with pytest.raises(fvf.ParameterError, match="up must be one of"):
        viz.RenderStyle(up="w")
    with pytest.raises(fvf.FvfError, match="view.up"):
        viz.render(tall, tmp_path / "x.png", view=(0, 0, "+q"), backend="matplotlib")


def test_render_style_holds_the_appearance(sphere, tmp_path):
    """A RenderStyle draws what the same keywords draw; keywords replace its options; a
    bad option fails when the style is made."""
    import dataclasses

    v = rotation_field(sphere)
    f = sphere.vertices[:, 2]
    options = dict(
        cmap="magma", clim="symmetric", colorbar_label="z", arrow_spacing=20, size=(320, 240),
        view=(10.0, 30.0, "z"), title="styled", backend="matplotlib", arrow_color=(0, 0.8, 0),
    )  # fmt: skip
    style = viz.RenderStyle(**options)
    a = viz.render(sphere, tmp_path / "a.png", function=f, field=v, **options)
    b = viz.render(sphere, path=tmp_path / "b.png", function=f, field=v, style=style)
    assert a.clim == b.clim and a.n_arrows == b.n_arrows and a.arrow_scale == b.arrow_scale
    np.testing.assert_array_equal(picture(a.path), picture(b.path))
    c = viz.render(sphere, tmp_path / "c.png", function=f, field=v, style=style, size=(200, 150))
    assert c.size == (200, 150) and c.extra["arrow_colors"][0] == (0.0, 0.8, 0.0)
    assert style.size == (320, 240) and (style.width, style.height) == (320, 240)
    with pytest.raises(dataclasses.FrozenInstanceError):
        style.cmap = "viridis"  # type: ignore[misc]
    assert viz.RenderStyle() == viz.RenderStyle(cmap="viridis", size=(800, 600))
    for bad in (dict(size=(10, 10)), dict(clim=(1, 0)), dict(max_arrows=0),
                dict(arrow_scale=-1.0), dict(backend="vtk"), dict(arrow_spacing=1)):  # fmt: skip
        with pytest.raises(fvf.ParameterError):
            viz.RenderStyle(**bad)
        with pytest.raises(fvf.ParameterError):
            style.replace(**bad)
    with pytest.raises(TypeError, match="unexpected keyword argument 'colour'"):
        viz.render(sphere, tmp_path / "x.png", colour="red")
    with pytest.raises(fvf.FvfError, match="RenderStyle"):
        viz.render(sphere, tmp_path / "x.png", style={"cmap": "magma"})
    scene = fvf.viz.scene.build_scene(sphere, function=f, style=style, cmap="viridis")
    assert scene.colorbar["cmap"] == "viridis" and scene.colorbar["label"] == "z"


def test_polyscope_render_leaves_the_callers_scene(sphere, tmp_path):
    """Structures the caller registered in polyscope stay (enabled as they were) and are
    not drawn; only render's own are removed; the camera and window are restored."""
    need("polyscope-egl")
    from fvf.viz.ps_backend import PREFIX, init_headless

    ps = init_headless()
    kw = dict(
        function=sphere.vertices[:, 2], field=rotation_field(sphere), backend="polyscope-egl",
        size=(240, 180), singularities=(sphere.vertices[:2], [1, 1]),
        streamlines=viz.streamlines(sphere, rotation_field(sphere), 10),
    )  # fmt: skip
    alone = picture(viz.render(sphere, tmp_path / "alone.png", **kw).path)
    ball = fvf.icosphere(1)
    # "mesh" is the name render used for its own mesh; this one hides the sphere
    mine = ps.register_surface_mesh("mesh", 1.3 * ball.vertices, ball.faces, color=(1, 0, 0))
    dots = ps.register_point_cloud("my points", sphere.vertices, enabled=False)
    try:
        ps.set_window_size(321, 123)
        ps.look_at_dir((3.0, 1.0, 2.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
        ps.set_view_projection_mode("perspective")
        ps.set_vertical_fov_degrees(33.0)
        ps.set_background_color((0.1, 0.2, 0.3))

        def state():
            return (
                ps.get_camera_view_matrix(), ps.get_vertical_fov_degrees(),
                ps.get_view_projection_mode(), ps.get_window_size(),
                ps.get_background_color(), ps.get_length_scale(), *ps.get_bounding_box(),
            )  # fmt: skip

        before = state()
        shared = picture(viz.render(sphere, tmp_path / "shared.png", **kw).path)
        np.testing.assert_array_equal(shared, alone)  # the caller's structures are not drawn
        assert ps.has_surface_mesh("mesh") and ps.has_point_cloud("my points")
        assert mine.is_enabled() and not dots.is_enabled()
        for name in ("mesh", "field 0", "halo 0"):
            assert not ps.has_surface_mesh(PREFIX + name)
        assert not ps.has_curve_network(PREFIX + "streamlines")
        assert not ps.has_point_cloud(PREFIX + "singularities")
        for x, y in zip(state(), before, strict=True):
            if isinstance(x, str):
                assert x == y
            else:
                np.testing.assert_allclose(x, y)
    finally:
        ps.remove_surface_mesh("mesh", error_if_absent=False)
        ps.remove_point_cloud("my points", error_if_absent=False)


def lic_reference(mesh, points, texel, L, seed=0):
    """Classical LIC of the rotation about z computed without the mesh: the solid noise
    averaged over arcs of the circles of latitude through the points (Hann window)."""
    from fvf.viz.lic import SAMPLES_PER_TEXEL, solid_noise

    h = texel / SAMPLES_PER_TEXEL
    taps = int(round(L / h))
    s = h * np.arange(-taps, taps + 1)
    w = 0.5 * (1.0 + np.cos(np.pi * np.arange(-taps, taps + 1) / (taps + 1)))
    r = np.hypot(points[:, 0], points[:, 1])
    phi = np.arctan2(points[:, 1], points[:, 0])
    T = np.zeros(len(points))
    for sk, wk in zip(s, w, strict=True):
        a = phi + sk / np.maximum(r, 1e-12)
        X = np.stack([r * np.cos(a), r * np.sin(a), points[:, 2]], axis=1)
        T += wk * solid_noise(X, texel, seed)
    return T / w.sum()


@pytest.mark.parametrize("level", [2, 4])
def test_surface_lic_matches_a_reference_lic_of_the_rotation(level):
    """On a sphere the rotation's LIC shows circles of latitude: it agrees with the LIC
    computed along the exact circles, and varies far more across latitudes than along
    them, whatever the mesh's resolution."""
    mesh = fvf.icosphere(level)
    v = rotation_field(mesh)
    tex = viz.surface_lic(mesh, v, resolution=120)
    canvas = tex.mesh
    X = canvas.vertices
    keep = np.hypot(X[:, 0], X[:, 1]) > 0.3  # away from the poles (singular points)
    ref = lic_reference(mesh, X[keep], tex.texel, tex.length)
    rank = np.corrcoef(tex.values[keep], fvf.viz.colors.equalize(ref))[0, 1]
    assert rank > 0.7  # measured 0.79 (icosphere 2), 0.85 (icosphere 4)
    # along v neighbours agree, across they differ: canvas edges by direction
    E = canvas.edges
    d = X[E[:, 1]] - X[E[:, 0]]
    mid = 0.5 * (X[E[:, 0]] + X[E[:, 1]])
    tangent = np.cross([0.0, 0.0, 1.0], mid)
    cos = (
        np.abs((d * tangent).sum(1))
        / np.linalg.norm(d, axis=1)
        / np.maximum(np.linalg.norm(tangent, axis=1), 1e-12)
    )
    away = np.hypot(mid[:, 0], mid[:, 1]) > 0.3
    jump = (tex.values[E[:, 1]] - tex.values[E[:, 0]]) ** 2
    along = jump[away & (cos > 0.95)].mean()
    across = jump[away & (cos < 0.3)].mean()
    assert across > 4 * along  # measured 9.9 and 9.7
    assert abs(tex.values.mean() - 0.5) < 0.01 and tex.values.std() > 0.25  # equalized


def test_surface_lic_resolution_is_independent_of_the_mesh():
    coarse, fine = fvf.icosphere(2), fvf.icosphere(4)
    a = viz.surface_lic(coarse, rotation_field(coarse), resolution=100)
    b = viz.surface_lic(fine, rotation_field(fine), resolution=100)
    assert a.texel == pytest.approx(b.texel, rel=1e-3)
    # both canvases resolve the texel (median edge at most a texel)
    for tex in (a, b):
        E = tex.mesh.edges
        assert (
            np.median(np.linalg.norm(np.diff(tex.mesh.vertices[E], axis=1)[:, 0], axis=1))
            <= tex.texel
        )
    f = coarse.vertices[:, 2]
    np.testing.assert_allclose(a.vertex_values(f), a.mesh.vertices[:, 2], atol=1e-12)  # linear
    with pytest.raises(fvf.FvfError, match="resolution"):
        viz.surface_lic(coarse, rotation_field(coarse), resolution=4)


@pytest.mark.parametrize("backend", ["polyscope-egl", "matplotlib"])
def test_render_texture_and_streamlines(sphere, tmp_path, backend):
    need(backend)
    v = rotation_field(sphere)
    T = viz.lic_texture(sphere, v)
    lines = viz.streamlines(sphere, v, 30)
    info = viz.render(
        sphere, tmp_path / "t.png", texture=T, streamlines=lines, backend=backend, size=(320, 240)
    )
    img = picture(info.path)
    busy, _ = content(img)
    assert img.shape == (240, 320, 3) and 0.2 < busy < 0.9
    grey = img[(img < 245).any(2)]
    assert grey.std() > 20  # a texture, not a flat colour
    assert info.n_streamlines == len(lines) > 20
    lic = viz.surface_lic(sphere, v, resolution=80)
    info = viz.render(
        sphere,
        tmp_path / "l.png",
        texture=lic,
        function=sphere.vertices[:, 2],
        backend=backend,
        size=(320, 240),
    )
    assert picture(info.path)[(picture(info.path) < 245).any(2)].std() > 20
    with pytest.raises(fvf.FieldShapeError, match="LIC texture"):
        viz.render(fvf.icosphere(2), tmp_path / "x.png", texture=lic, backend=backend)


def test_auto_falls_back_to_matplotlib_with_one_warning(sphere, tmp_path, monkeypatch):
    from fvf.viz import backends as b

    monkeypatch.delenv("FVF_VIZ_BACKEND", raising=False)
    monkeypatch.setitem(b._STATUS, "polyscope", "EGL missing (test)")
    monkeypatch.setitem(b._STATUS, "warned", False)
    monkeypatch.setattr(b.importlib.util, "find_spec", lambda name: object())
    with pytest.warns(viz.RenderBackendWarning, match="EGL missing"):
        info = viz.render(sphere, tmp_path / "f.png", size=(200, 150))
    assert info.backend == "matplotlib" and "EGL missing" in info.fallback
    info = viz.render(sphere, tmp_path / "g.png", size=(200, 150))  # no second warning
    with pytest.raises(fvf.FvfError, match="not available"):
        viz.render(sphere, tmp_path / "h.png", backend="polyscope-egl")


def test_bad_inputs_raise_typed_errors(sphere, tmp_path):
    def r(**kw):
        viz.render(sphere, tmp_path / "x.png", backend="matplotlib", size=(200, 150), **kw)

    with pytest.raises(fvf.FieldShapeError, match="one value per vertex"):
        r(function=np.ones(7))
    with pytest.raises(fvf.FvfError, match="backend"):
        viz.render(sphere, tmp_path / "x.png", backend="vtk")
    with pytest.raises(fvf.FvfError, match="colormap"):
        r(function=np.ones(sphere.n_vertices), cmap="nope")
    with pytest.raises(fvf.FvfError, match="arrow_spacing"):
        r(field=rotation_field(sphere), arrow_spacing=0.5)
    with pytest.raises(fvf.FvfError, match="field_labels"):
        r(field=[rotation_field(sphere)] * 2, field_labels=["v"])
    with pytest.raises(fvf.FvfError, match="view.up"):
        r(view=(0, 10, "w"))
    with pytest.raises(fvf.FieldShapeError, match="singularity positions"):
        r(singularities=(np.zeros((2, 3)), [1]))


def test_two_fields_get_two_colours_and_a_legend(sphere, tmp_path):
    v = rotation_field(sphere)
    w = fvf.rotate(sphere, v)
    info = viz.render(
        sphere,
        tmp_path / "vw.png",
        field=[v, w],
        field_labels=["v", "w"],
        backend="matplotlib",
        size=(400, 300),
    )
    c0, c1 = info.extra["arrow_colors"]
    assert c0 != c1
    img = picture(info.path)
    for c in (c0, c1):
        assert near_color(img[:, :276], c, tol=45).sum() > 200  # arrows of both
        assert near_color(img[:, 276:], c, tol=30).sum() > 20  # and their legend patches


def test_view_without_display_raises(sphere, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    with pytest.raises(viz.NoDisplayError, match="render"):
        viz.view(sphere)


def test_write_gif(tmp_path):
    from PIL import Image

    frames = [np.full((20, 30, 3), c, dtype=np.uint8) for c in (0, 120, 250)]
    path = viz.write_gif(frames + [np.zeros((20, 30, 3))], tmp_path / "a.gif", fps=5)
    im = Image.open(path)
    assert im.n_frames == 4 and im.size == (30, 20)


def test_subdivide_keeps_surface_and_field(sphere):
    v = rotation_field(sphere)
    fine, fv, parent = viz.subdivide(sphere, v)
    assert fine.n_faces == 4 * sphere.n_faces
    assert fine.total_area == pytest.approx(sphere.total_area, rel=1e-12)
    np.testing.assert_allclose(fine.face_normals, sphere.face_normals[parent], atol=1e-12)
    np.testing.assert_array_equal(fv, v[parent])


@pytest.mark.parametrize("backend", ["polyscope-egl", "matplotlib"])
def test_render_face_function_on_a_mesh_with_boundary(tmp_path, backend):
    need(backend)
    disk = fvf.disk(8, 6)
    f = disk.face_centroids[:, 0]
    v = disk.project_tangent(np.cross([0.0, 0.0, 1.0], disk.face_centroids))
    info = viz.render(
        disk,
        tmp_path / "d.png",
        function=f,
        field=v,
        view=(0, 60, "z"),
        backend=backend,
        size=(300, 240),
        texture=viz.lic_texture(disk, v),
    )
    assert info.n_arrows > 20 and info.clim == (f.min(), f.max())
    busy, hues = content(picture(info.path))
    assert 0.1 < busy < 0.9 and hues >= 3


def test_a_long_title_is_never_cut_off(sphere, tmp_path):
    """A title wider than the panels is centred on the whole picture, and one wider than
    the picture gets a smaller font: the edge columns of the title band stay blank."""
    from PIL import Image

    from fvf.viz.compose import TITLE_HEIGHT

    for words in (8, 30):
        path = tmp_path / f"title{words}.png"
        title = " ".join(["mirror error"] * words)
        viz.render(
            sphere, path, field=rotation_field(sphere), title=title, backend="matplotlib",
            size=(320, 240),
        )  # fmt: skip
        band = np.asarray(Image.open(path).convert("L"))[:TITLE_HEIGHT]
        ink = np.flatnonzero((band < 200).any(axis=0))
        assert ink.size and ink[0] > 0 and ink[-1] < band.shape[1] - 1, (words, ink[[0, -1]])


def test_magnitude_of_a_cross_field_as_colour(tmp_path):
    """``function="magnitude"``: the crosses stay unit length, |u| colours the faces with
    the label ``|field|``; a typed error without a field."""
    from fvf.viz import backends

    mesh = fvf.icosphere(2)
    u = fvf.design_field(mesh, n=4)
    seen: dict = {}
    out = fvf.viz.render(
        mesh, tmp_path / "m.png", field=u, function="magnitude", backend="matplotlib"
    )
    assert (tmp_path / "m.png").stat().st_size > 0 and out is not None
    f = backends._field_magnitude("magnitude", u, None, seen)
    assert (
        np.allclose(f, np.linalg.norm(np.asarray(u), axis=1))
        and seen["colorbar_label"] == "|field|"
    )
    kept = {"colorbar_label": "mine"}
    backends._field_magnitude("magnitude", [u, u], None, kept)
    assert kept["colorbar_label"] == "mine"
    with pytest.raises(fvf.ParameterError, match="without a field"):
        fvf.viz.render(mesh, tmp_path / "x.png", function="magnitude")
    with pytest.raises(fvf.ParameterError, match="got 'norm'"):
        fvf.viz.render(mesh, tmp_path / "x.png", field=u, function="norm")


def _cube():
    """The unit cube as CAD exports it: 8 vertices, 12 triangles, outward."""
    V = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    F = np.array([t for a, b, c, d in quads for t in ([a, b, c], [a, c, d])])
    return V, F


def test_sharp_edges_split_the_shading_and_smooth_surfaces_do_not():
    """The shading's vertex normals (polyscope) are split along chains of sharp edges: a
    12-triangle cube gets one normal per face at each corner, its face's own; a sphere
    and Spot's short ear creases keep one smooth normal per vertex."""
    from fvf.viz.ps_backend import shading_corners

    cube = fvf.TriMesh(*_cube())
    corner, faces, normals = shading_corners(cube)
    assert len(corner) == 24 and np.array_equal(corner[faces], cube.faces)
    assert np.allclose(normals[faces], cube.face_normals[:, None, :])
    ball = fvf.icosphere(3)
    corner, faces, normals = shading_corners(ball)
    assert len(corner) == ball.n_vertices and np.array_equal(corner[faces], ball.faces)
    radial = ball.vertices / np.linalg.norm(ball.vertices, axis=1, keepdims=True)
    assert np.einsum("kd,kd->k", normals, radial[corner]).min() > 0.99
    spot = fvf.mesh.builtin.spot()
    assert len(shading_corners(spot)[0]) <= spot.n_vertices + 20


def test_a_cad_box_is_drawn_with_flat_faces(tmp_path):
    """Each face of a 12-triangle box is drawn in one colour (its slivers' vertex normals
    averaged over its 90° edges shaded it as a gradient)."""
    need("polyscope-egl")
    V, F = _cube()
    box = fvf.TriMesh(V * [4.0, 2.0, 1.0], F)
    img = picture(
        viz.render(box, tmp_path / "box.png", backend="polyscope-egl", size=(300, 240)).path
    )
    drawn = img[(img < 235).any(2)]
    colours, counts = np.unique(drawn, axis=0, return_counts=True)
    assert np.sort(counts)[::-1][:3].sum() > 0.9 * len(drawn)  # three faces seen, flat
