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
    # default scale: the longest arrow is DEFAULT_ARROW_LENGTH mean edge lengths
    d = np.diff(viz.arrow_segments(mesh, v), axis=1)[:, 0]
    top = np.linalg.norm(d, axis=1).max()
    assert top == pytest.approx(viz.DEFAULT_ARROW_LENGTH * mesh.mean_edge_length)


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


@pytest.mark.parametrize("backend", ["polyscope-egl", "matplotlib"])
def test_render_function_field_markers(sphere, tmp_path, backend):
    if backend not in backends():
        pytest.skip(f"polyscope headless unavailable: {viz.polyscope_status()}")
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
    )
    assert info.backend == backend and info.size == (400, 300)
    assert info.n_singularities == 2 and info.n_arrows > 100
    img = picture(info.path)
    assert img.shape == (300, 400, 3)
    busy, hues = content(img)
    assert 0.15 < busy < 0.8  # the sphere fills a fair part of the picture, not all of it
    assert hues >= 4  # viridis from purple to yellow, the red arrows and markers
    # the colorbar: a column of many colours right of the scene
    bar = img[60:240, 300:400]
    assert np.unique(bar.reshape(-1, 3) // 16, axis=0).shape[0] > 20


@pytest.mark.parametrize("backend", ["polyscope-egl", "matplotlib"])
def test_render_texture_and_streamlines(sphere, tmp_path, backend):
    if backend not in backends():
        pytest.skip(f"polyscope headless unavailable: {viz.polyscope_status()}")
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
    with pytest.raises(fvf.FieldShapeError, match="one value per vertex"):
        viz.render(sphere, tmp_path / "x.png", function=np.ones(7), backend="matplotlib")
    with pytest.raises(fvf.FvfError, match="backend"):
        viz.render(sphere, tmp_path / "x.png", backend="vtk")
    with pytest.raises(fvf.FvfError, match="colormap"):
        viz.render(
            sphere,
            tmp_path / "x.png",
            function=np.ones(sphere.n_vertices),
            cmap="nope",
            backend="matplotlib",
        )


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
    if backend not in backends():
        pytest.skip(f"polyscope headless unavailable: {viz.polyscope_status()}")
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
    assert info.n_arrows == disk.n_faces and info.clim == (f.min(), f.max())
    busy, hues = content(picture(info.path))
    assert 0.1 < busy < 0.9 and hues >= 3
