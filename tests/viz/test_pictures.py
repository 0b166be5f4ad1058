"""Pictures for a paper: the up axis, missing data, file names, sizes and formats, one
vocabulary for singularities, glyphs sized by the mesh (fvf.viz and the picture options of
the commands)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

import fvf

viz = pytest.importorskip("fvf.viz")
pytest.importorskip("matplotlib")
Image = pytest.importorskip("PIL.Image")

MPL = {"backend": "matplotlib"}


def body(up: str = "y") -> fvf.TriMesh:
    """A body-like shape: three ellipsoids stacked along y (legs, trunk, head), 2.5 tall
    and 0.7 wide; ``up="z"`` stores it z-up."""
    base = fvf.icosphere(2)
    parts = [
        ((0.0, 0.5, 0.0), (0.25, 0.5, 0.2)),
        ((0.0, 1.5, 0.0), (0.35, 0.6, 0.25)),
        ((0.0, 2.3, 0.0), (0.18, 0.22, 0.18)),
    ]
    V = np.vstack([base.vertices * np.array(r) + np.array(c) for c, r in parts])
    F = np.vstack([base.faces + i * base.n_vertices for i in range(len(parts))])
    if up == "z":  # (x, y, z) -> (x, -z, y): the same body, z up, still right-handed
        V = np.stack([V[:, 0], -V[:, 2], V[:, 1]], axis=1)
    return fvf.TriMesh(V, F)


def picture(path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB")).astype(int)


def extent(img: np.ndarray) -> tuple[int, int]:
    """Width and height of the non-white part of a picture without side column."""
    ys, xs = np.nonzero((img < 240).any(2))
    return int(np.ptp(xs)), int(np.ptp(ys))


@pytest.mark.parametrize("up", ["y", "z"])
def test_a_standing_body_is_drawn_standing_by_default(tmp_path, up):
    mesh = body(up)
    info = viz.render(mesh, tmp_path / "b.png", size=(400, 400), **MPL)
    assert info.extra["up"] == up
    w, h = extent(picture(info.path))
    assert h > 2 * w, (w, h)
    # turned on its side with --up x: wider than tall; --view keeps working with --up
    info = viz.render(mesh, tmp_path / "s.png", size=(400, 400), up="x", **MPL)
    w, h = extent(picture(info.path))
    assert w > 2 * h, (w, h)


def test_cli_up_size_dpi_and_view(tmp_path):
    from fvf.cli.main import main

    mesh = body("z")
    path = tmp_path / "body.obj"
    fvf.write_mesh(path, mesh.vertices, mesh.faces)
    out = tmp_path / "b.png"
    argv = ["render", str(path), "-o", str(out), "--backend", "matplotlib"]
    assert main([*argv, "--size", "300", "400", "--dpi", "300", "--up", "auto"]) == 0
    img = Image.open(out)
    assert img.size == (300, 400)
    assert tuple(round(d) for d in img.info["dpi"]) == (300, 300)
    w, h = extent(picture(out))
    assert h > 2 * w
    assert main([*argv, "--view", "90", "10", "--up", "z"]) == 0
    w, h = extent(picture(out))
    assert h > 2 * w
    assert main([*argv, "--up", "w"]) == 2  # not a choice


@pytest.mark.parametrize("suffix", [".pdf", ".svg"])
def test_pictures_as_pdf_and_svg(tmp_path, suffix):
    mesh = fvf.icosphere(2)
    out = tmp_path / f"f{suffix}"
    viz.render(mesh, out, function=mesh.vertices[:, 0], title="x", dpi=200, **MPL)
    data = out.read_bytes()
    if suffix == ".pdf":
        assert data.startswith(b"%PDF") and b"%%EOF" in data[-64:]
    else:
        root = ET.fromstring(data)
        assert root.tag.endswith("svg")
        assert root.get("width") == "288pt"  # 800 px at 200 dpi: 4 inches of 72 pt
    curves = tmp_path / f"c{suffix}"
    viz.plot_error_curves({"a": np.array([0.0, 0.05, np.nan])}, curves)
    data = curves.read_bytes()
    assert data.startswith(b"%PDF") if suffix == ".pdf" else ET.fromstring(data) is not None


def test_missing_values_are_grey_and_named(tmp_path):
    from fvf.viz.scene import NO_DATA_COLOR

    mesh = fvf.icosphere(3)
    e = np.abs(mesh.vertices[:, 0]) * 0.1
    e[mesh.vertices[:, 1] > 0] = np.nan  # no ground truth on one half
    info = viz.render_error_map(mesh, e, tmp_path / "e.png", size=(500, 400), **MPL)
    assert info.clim == (0.0, 0.1)
    img = picture(info.path)
    grey = (np.abs(img - 255 * np.array(NO_DATA_COLOR)) <= 60).all(2) & (np.ptp(img, axis=2) < 8)
    panel = grey[:, :376]
    assert panel.sum() > 2000  # the half without truth is grey, not black (zero error)
    assert grey[:, 376:].sum() > 20  # its swatch in the legend
    scene = fvf.viz.scene.build_scene(mesh, function=e, nan_label="no ground truth")
    assert scene.no_data == "no ground truth"
    with pytest.raises(fvf.FieldValueError):
        viz.render(mesh, tmp_path / "x.png", function=np.full(mesh.n_vertices, np.nan))
    with pytest.raises(fvf.FieldValueError):
        viz.render(mesh, tmp_path / "x.png", function=np.full(mesh.n_vertices, np.inf))


def test_cli_match_pictures_are_named_as_asked(tmp_path):
    from fvf.cli.main import main

    mesh = fvf.icosphere(2)
    a = tmp_path / "ball.off"
    fvf.write_mesh(a, mesh.vertices, mesh.faces)
    truth = np.arange(mesh.n_vertices)
    truth[::4] = -1
    np.savetxt(tmp_path / "t.txt", truth, fmt="%d")
    out = tmp_path / "map.pdf"
    argv = ["match", str(a), str(a), "-o", str(tmp_path / "m"), "--k", "20", "--k-fit", "8"]
    argv += ["--truth", str(tmp_path / "t.txt"), "--truth-missing", "-1", "--png", str(out)]
    assert main([*argv, "--size", "700", "300", "--up", "z"]) == 0
    assert out.read_bytes().startswith(b"%PDF")
    assert (tmp_path / "map_errors.pdf").read_bytes().startswith(b"%PDF")
    assert not (tmp_path / "map_colors.pdf").exists()


def test_correspondence_has_one_colorbar_and_the_given_names(tmp_path, monkeypatch):
    import fvf.viz.correspondence as corr

    mesh = fvf.icosphere(2)
    calls = []
    real = corr.render

    def spy(*args, **kwargs):
        calls.append(kwargs)
        return real(*args, **kwargs)

    monkeypatch.setattr(corr, "render", spy)
    out = tmp_path / "c.png"
    corr.render_correspondence(
        mesh, mesh, np.arange(mesh.n_vertices), out, names=("a.off", "b.off"), **MPL
    )
    assert [c["title"] for c in calls] == ["a.off", "b.off"]
    assert [c["colorbar"] for c in calls] == [False, True]
    assert Image.open(out).size == (1200, 520)


def test_quad_pictures_speak_of_valence_in_the_fields_colours(tmp_path):
    from fvf.viz.compose import marker_label

    assert marker_label(0.25, "valence") == "valence 3"
    assert marker_label(-0.25, "valence") == "valence 5"
    assert marker_label(-0.25) == "index -1/4"
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]], float)
    Q = np.array([[0, 1, 2, 3], [1, 4, 5, 2]])
    captured = {}
    real = fvf.viz.quads.render

    def spy(*args, **kwargs):
        captured.update(kwargs)
        return real(*args, **kwargs)

    fvf.viz.quads.render = spy
    try:
        viz.render_quads(V, Q, tmp_path / "q.png", **MPL)
    finally:
        fvf.viz.quads.render = real
    assert captured["singularity_kind"] == "valence"
    # corners have valence 2: index (4 - 2) / 4 = +1/2; the middle ones 3, regular on the
    # boundary, are not marked
    assert sorted(captured["singularities"][1]) == [0.5, 0.5, 0.5, 0.5]


def test_index_colours_are_told_apart_by_lightness():
    from fvf.viz.colors import srgb_to_lab

    for a, b in [(-0.25, -0.5), (-0.5, -1), (0.25, 0.5), (0.5, 1), (0.25, -0.25)]:
        la, lb = srgb_to_lab(viz.index_color(a)), srgb_to_lab(viz.index_color(b))
        assert abs(la[0] - lb[0]) > 12 or np.linalg.norm(la - lb) > 40, (a, b)


def test_crosses_are_unit_and_dense_wireframes_thin():
    from fvf.viz.overlay import panel_overlay

    mesh = fvf.icosphere(3)
    c = mesh.face_centroids
    u = mesh.project_tangent(np.cross(c, [0.0, 0.0, 1.0]) * (np.abs(c[:, 2]) ** 3 + 1e-3)[:, None])
    scene = fvf.viz.scene.build_scene(mesh, field=u, n=4)
    g = panel_overlay(scene, scene.frame, 1.0, 400, 400).glyphs[0]
    length = np.linalg.norm(g.polygons.max(1) - g.polygons.min(1), axis=1)
    assert length.max() < 1.5 * np.median(length)  # no crosses shrunk to dots
    coarse = fvf.viz.quads.quad_wireframe(
        np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float), np.array([[0, 1, 2, 3]])
    )
    dense = fvf.icosphere(5)  # 30,720 edges
    fine = list(dense.vertices[dense.edges])
    widths = []
    for lines in (coarse, fine):
        s = fvf.viz.scene.build_scene(dense, streamlines=lines)
        widths.append(panel_overlay(s, s.frame, 1.0, 400, 400).line_width)
    assert widths[1] < 0.6 * widths[0]


def test_demo_pictures_take_up_size_and_dpi(tmp_path):
    from fvf.cli.main import parser
    from fvf.cli.report import Story

    story = Story(tmp_path, True, (200, 150), options={"up": "x", "dpi": 150})
    st = story.begin("a section")
    story.picture(st, "b.png", body("y"), "body", backend="matplotlib")
    img = Image.open(tmp_path / "b.png")
    assert img.size == (200, 150) and round(img.info["dpi"][0]) == 150
    w, h = extent(picture(tmp_path / "b.png"))
    assert w > h  # lying on its side: x is up
    args = parser().parse_args(["demo", "--size", "300", "200", "--up", "z", "--dpi", "72"])
    assert (args.size, args.up, args.dpi) == ([300, 200], "z", 72)


def test_examples_write_to_a_temporary_folder_by_default(monkeypatch):
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    monkeypatch.syspath_prepend(str(root / "examples"))
    import _common

    monkeypatch.setattr(sys, "argv", ["fig03_flow.py"])
    out = Path(_common.parse_args("x").out)
    assert out.is_dir() and root not in out.resolve().parents
    out.rmdir()


def test_a_quad_with_three_collinear_corners_is_drawn(tmp_path):
    """A valid quad mesh may hold a quad with three corners on a line (on a boundary): its
    zero-area half is left out of the shading instead of failing the TriMesh check."""
    from fvf.viz.quads import _shading_mesh

    V = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0], [5, 5, 5]], float)
    Q = np.array([[0, 1, 2, 4]])  # 0, 1, 2 collinear: the split along 0-2 has a zero half
    mesh = _shading_mesh(V, Q)
    assert mesh.n_faces == 2 and np.isclose(mesh.total_area, 1.0)  # split along 1-4
    assert mesh.n_vertices == 4  # vertices 3 and 5, in no quad, dropped
    info = viz.render_quads(V, np.array([[0, 1, 2, 4]]), tmp_path / "q.png", **MPL)
    assert (tmp_path / "q.png").stat().st_size > 0 and info is not None


def test_an_open_quad_grid_marks_only_its_corners(tmp_path):
    """A 4 x 3 grid of quads: its 6 interior vertices have valence 4, its 10 boundary
    vertices but the corners valence 3 (regular on a boundary), its 4 corners valence 2:
    only the corners are marked (every boundary vertex was, as valence 3)."""
    x, y = np.meshgrid(np.arange(5.0), np.arange(4.0), indexing="ij")
    V = np.stack([x.ravel(), y.ravel(), np.zeros(20)], axis=1)
    i, j = np.meshgrid(np.arange(4), np.arange(3), indexing="ij")
    a = (4 * i + j).ravel()
    Q = np.stack([a, a + 4, a + 5, a + 1], axis=1)
    info = viz.render_quads(V, Q, tmp_path / "q.png", **MPL)
    assert info.n_singularities == 4


def test_a_colorbar_of_small_values_shows_its_whole_exponent(tmp_path):
    """A colorbar of values ~1e-5 shows the common factor above it in full: the panels
    (drawn dark here) lie under it, not over its left end (the '1' of '1e-5' was hidden,
    leaving 'e-5')."""
    from fvf.viz.compose import compose, layout
    from fvf.viz.scene import Scene

    mesh = fvf.icosphere(1)
    scene = Scene(
        mesh=mesh,
        colors=np.zeros((mesh.n_vertices, 3)),
        colors_on="vertices",
        frames=[np.eye(3)],
        views=[None],
        field_mesh=mesh,
        colorbar={"cmap": "RdBu_r", "clim": (-2.3e-5, 2.3e-5), "label": "bracket"},
    )
    w, h = 600, 450
    lay = layout(w, h, None, True, 0, 1)
    dark = np.full((lay.scene_height, lay.scene_width, 3), 60, dtype=np.uint8)
    compose(dark, scene, tmp_path / "c.png", w, h, None)
    img = picture(tmp_path / "c.png")
    # the band above the colorbar's top end (90 % of the height), left of the side column
    top = h - int(0.90 * lay.scene_height)
    band = img[max(top - 30, 0) : top, lay.scene_width - 40 : lay.scene_width]
    assert band.min() < 30  # dark text drawn over the dark panels, not hidden under them


def test_a_quad_mesh_with_a_doublet_is_drawn(tmp_path):
    """Two quads sharing two edges (a valence-2 vertex, as fvf.quad_mesh made on a body
    scan) whose shading splits both end in the same triangle, once each way round: the fin
    is left out of the shading instead of failing the TriMesh check (an edge in four
    triangles); the wireframe and the valence-2 marker still show it."""
    from fvf.viz.quads import _shading_mesh

    V = np.array([[0, 0, 0], [2, 0, 0], [1, 1, 1.5], [0, 2, 0], [2, 2, 0]], float)
    Q = np.array([[0, 1, 2, 3], [1, 4, 3, 2]])  # vertex 2 in both, on edges 1-2 and 2-3
    mesh = _shading_mesh(V, Q)
    assert mesh.n_faces == 2 and np.isclose(mesh.total_area, 4.0)  # the square 0-1-4-3
    info = viz.render_quads(V, Q, tmp_path / "q.png", **MPL)
    assert (tmp_path / "q.png").stat().st_size > 0 and info is not None


def test_polyscope_lines_are_not_thinner_than_it_draws_whole():
    """A dense wireframe, thinner than a pixel in the overlay, is drawn by polyscope at
    least LINE_MIN_PX wide: thinner tubes came out as dashes."""
    from unittest.mock import MagicMock

    from fvf.viz import ps_backend
    from fvf.viz.overlay import panel_overlay

    dense = fvf.icosphere(5)
    scene = fvf.viz.scene.build_scene(dense, streamlines=list(dense.vertices[dense.edges]))
    overlay = panel_overlay(scene, scene.frame, 1.0, 400, 400)
    assert overlay.line_width < ps_backend.LINE_MIN_PX  # the case at hand
    ps = MagicMock()
    for has in ("has_surface_mesh", "has_point_cloud", "has_curve_network"):
        getattr(ps, has).return_value = False
    try:
        ps_backend.populate(ps, scene, overlay=overlay)
    finally:
        ps_backend.remove_ours(ps)
    (radius,), _ = ps.register_curve_network.return_value.set_radius.call_args
    assert np.isclose(2.0 * radius * overlay.pixel_scale, ps_backend.LINE_MIN_PX)
