"""N-fields that know their N (fvf.NField) and files that keep it; VTK files read back."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

import fvf
from fvf.cli.main import main
from fvf.io import read_data, write_data
from fvf.io.formats import vtk


@pytest.fixture(scope="module")
def torus():
    return fvf.torus(24, 12)


@pytest.fixture(scope="module")
def cross(torus):
    return fvf.design_field(torus, n=4)


# ---------------------------------------------------------------------------- the object
def test_design_returns_an_nfield_and_consumers_read_its_n(torus, cross):
    assert isinstance(cross, fvf.NField) and isinstance(cross, np.ndarray)
    assert cross.n == 4 and cross.shape == (torus.n_faces, 3) and cross.dtype == np.float64
    ids, ind = fvf.singularities(torus, cross)
    ids4, ind4 = fvf.singularities(torus, cross, n=4)
    np.testing.assert_array_equal(ids, ids4)
    np.testing.assert_array_equal(ind, ind4)
    bare = np.asarray(cross)
    assert type(bare) is np.ndarray
    ids1, _ = fvf.singularities(torus, bare)  # a bare array is a vector field, as before
    assert not np.array_equal(ids1, ids)
    np.testing.assert_array_equal(
        fvf.vertex_indices(torus, cross), fvf.vertex_indices(torus, bare, n=4)
    )
    np.testing.assert_array_equal(fvf.period_jumps(torus, cross), fvf.period_jumps(torus, bare, 4))
    np.testing.assert_array_equal(fvf.comb(torus, cross), fvf.comb(torus, bare, 4))
    np.testing.assert_array_equal(
        fvf.cut_graph(torus, cross).mask, fvf.cut_graph(torus, bare, 4).mask
    )
    np.testing.assert_array_equal(fvf.to_power(torus, cross), fvf.to_power(torus, bare, 4))
    np.testing.assert_array_equal(
        fvf.design.all_directions(torus, cross), fvf.design.all_directions(torus, bare, 4)
    )


def test_every_n_field_design_carries_n(torus):
    assert fvf.design_field(torus).n == 1
    assert fvf.design_field(torus, [0], [torus.face_bases[0, 0]], n=2, hard=True).n == 2
    assert fvf.design_field(torus, n=4, align="curvature").n == 4
    _, stack = fvf.smoothest_fields(torus, 2, n=6)
    assert stack.n == 6 and stack.shape == (2, torus.n_faces, 3)
    assert stack[1].n == 6 and type(stack[:, 0]) is np.ndarray
    w = fvf.to_power(torus, stack[0])
    assert fvf.from_power(torus, w, 6).n == 6
    assert fvf.param.default_cross_field(torus, "smooth").n == 4
    tidy = fvf.design.cancellation.cancel_close_singularities(
        torus, fvf.design_field(torus, n=4), radius=0.0
    )
    assert tidy.n == 4


def test_an_explicit_n_that_contradicts_the_field_is_a_typed_error(torus, cross):
    for call in (
        lambda: fvf.singularities(torus, cross, n=2),
        lambda: fvf.comb(torus, cross, 1),
        lambda: fvf.period_jumps(torus, cross, 6),
        lambda: fvf.quad_mesh(torus, field=fvf.design_field(torus, n=2), target_faces=60),
    ):
        with pytest.raises(fvf.DirectionCountConflictError, match="n=4|n=2"):
            call()
    assert issubclass(fvf.DirectionCountConflictError, fvf.DirectionCountError)
    with pytest.raises(fvf.DirectionCountError, match="bare array: give n="):
        fvf.comb(torus, np.asarray(cross))  # no default order for combing


def test_arithmetic_reductions_and_slices_are_plain_arrays(cross):
    for value in (
        2 * cross,
        cross + cross,
        -cross,
        cross[:5],
        cross[:, 0],
        cross[np.array([0, 3])],
        cross.sum(axis=0),
        np.linalg.norm(cross, axis=1),
        np.concatenate([cross, cross]),
        np.asarray(cross),
    ):
        assert type(value) is np.ndarray
    assert type(cross.sum()) is np.float64 and type(cross[0, 0]) is np.float64
    doubled = cross.copy()
    alias = doubled
    doubled *= 2  # in place: the field itself, still an NField
    assert doubled is alias and doubled.n == 4
    np.testing.assert_array_equal(doubled, 2 * np.asarray(cross))
    assert np.array_equal(cross * 1.0, np.asarray(cross))
    assert cross.copy().n == 4 and cross.astype(np.float32).n == 4
    for twin in (pickle.loads(pickle.dumps(cross)), copy.deepcopy(cross), copy.copy(cross)):
        assert isinstance(twin, fvf.NField) and twin.n == 4
        np.testing.assert_array_equal(twin, cross)
    assert repr(fvf.NField(np.eye(3), 2)).endswith("n=2)")
    html = cross._repr_html_()
    assert "NField" in html and "<table>" in html
    with pytest.raises(fvf.FieldShapeError):
        fvf.NField(np.zeros(5), 4)
    with pytest.raises(fvf.DirectionCountError):
        fvf.NField(np.zeros((5, 3)), 0)


# ---------------------------------------------------------------------------- files
FORMATS = [".npz", ".ply", ".vtu", ".vtp", ".vtk"]


def _need(suffix):
    if suffix in (".vtp", ".vtk"):
        pytest.importorskip("pyvista")
    elif suffix == ".vtu" and not (vtk._have("meshio") or vtk._have("pyvista")):
        pytest.skip("no VTK library")


@pytest.mark.parametrize("suffix", FORMATS)
def test_results_round_trip_with_their_n(tmp_path, torus, cross, suffix):
    _need(suffix)
    rng = np.random.default_rng(5)
    f = rng.standard_normal(torus.n_vertices)
    line = fvf.NField(torus.project_tangent(rng.standard_normal((torus.n_faces, 3))), 2)
    path = write_data(
        tmp_path / f"out{suffix}",
        {"v": cross, "u": line, "f": f},
        mesh=torus,
        mesh_path=tmp_path / "torus.obj",
        command="test",
    )
    data = read_data(path, torus)
    for key, field in (("v", cross), ("u", line)):
        back = data[key]
        assert isinstance(back, fvf.NField) and back.n == field.n
        np.testing.assert_array_equal(back, field)  # exactly
        assert data.field(key, torus).n == field.n
    np.testing.assert_array_equal(data["f"], f)
    ids, ind = fvf.singularities(torus, data["v"])
    np.testing.assert_array_equal(ind, fvf.singularities(torus, cross, n=4)[1])


@pytest.mark.parametrize("suffix", [".ply", ".vtu", ".vtp", ".vtk"])
@pytest.mark.parametrize("size", [3, 4])
def test_write_mesh_round_trips_meshes_quads_and_fields(tmp_path, torus, cross, suffix, size):
    _need(suffix)
    if size == 3:
        V, F, fdata = torus.vertices, torus.faces, {"v": cross, "g": np.arange(torus.n_faces)}
    else:
        k = np.arange(6)
        V = np.array([[x, y, 0.1 * x * y] for y in range(3) for x in range(4)], dtype=float)
        F = np.array([[i, i + 1, i + 5, i + 4] for i in k + k // 3])
        fdata = {"q": fvf.NField(np.tile([1.0, 0.0, 0.0], (len(F), 1)), 4)}
    path = tmp_path / f"m{suffix}"
    fvf.write_mesh(path, V, F, vertex_data={"h": V[:, 2]}, face_data=fdata)
    V2, F2 = fvf.read_mesh(path, faces="any")
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(F2, F)
    data = read_data(path)
    np.testing.assert_array_equal(data["h"], V[:, 2])
    for key, a in fdata.items():
        if size == 4:  # read_data aligns face data with the triangulated mesh
            np.testing.assert_array_equal(data[key], np.repeat(a, 2, axis=0))
        else:
            np.testing.assert_array_equal(data[key], a)
        assert getattr(data[key], "n", None) == getattr(a, "n", None)


def test_the_peers_read_fvf_vtk_files_with_names_and_n(tmp_path, torus, cross):
    meshio = pytest.importorskip("meshio")
    pv = pytest.importorskip("pyvista")
    fvf.write_mesh(tmp_path / "a.vtu", torus.vertices, torus.faces, face_data={"v": cross})
    back = meshio.read(tmp_path / "a.vtu")
    np.testing.assert_array_equal(back.cell_data["v"][0], cross)
    assert int(np.asarray(back.field_data["n_v"]).ravel()[0]) == 4
    for suffix in (".vtu", ".vtp", ".vtk"):
        fvf.write_mesh(tmp_path / f"b{suffix}", torus.vertices, torus.faces, face_data={"v": cross})
        grid = pv.read(tmp_path / f"b{suffix}")
        np.testing.assert_array_equal(grid.cell_data["v"], cross)
        assert int(grid.field_data["n_v"][0]) == 4


def test_vtk_files_of_other_tools(tmp_path):
    pv = pytest.importorskip("pyvista")
    poly = pv.PolyData(
        np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]], dtype=float),
        np.array([4, 0, 1, 2, 3, 3, 1, 4, 2]),
    )
    poly.cell_data["c"] = np.array([7.0, 8.0])
    poly.save(tmp_path / "mixed.vtp")
    with pytest.warns(fvf.PolygonTriangulatedWarning):
        V, F = fvf.read_mesh(tmp_path / "mixed.vtp")
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 3], [1, 4, 2]])
    np.testing.assert_array_equal(read_data(tmp_path / "mixed.vtp")["c"], [7.0, 7.0, 8.0])
    grid = pv.ImageData(dimensions=(3, 3, 3)).cast_to_unstructured_grid()
    grid.save(tmp_path / "volume.vtu")
    with pytest.raises(fvf.MeshReadError, match="extract_surface"):
        fvf.read_mesh(tmp_path / "volume.vtu")
    (tmp_path / "broken.vtu").write_bytes(b"<VTKFile nonsense")
    with pytest.raises(fvf.MeshReadError):
        fvf.read_mesh(tmp_path / "broken.vtu")


def test_reading_vtk_without_the_libraries_names_the_extra(tmp_path, monkeypatch, torus):
    pytest.importorskip("pyvista")
    fvf.write_mesh(tmp_path / "a.vtp", torus.vertices, torus.faces)
    monkeypatch.setattr(vtk, "_have", lambda module: False)
    with pytest.raises(fvf.MissingExtraError, match=r"fvf\[vtk\]"):
        fvf.read_mesh(tmp_path / "a.vtp")


def test_meshio_reads_vtu_when_pyvista_is_missing(tmp_path, monkeypatch, torus, cross):
    pytest.importorskip("meshio")
    fvf.write_mesh(tmp_path / "a.vtu", torus.vertices, torus.faces, face_data={"v": cross})
    monkeypatch.setattr(vtk, "_have", lambda module: module == "meshio")
    V, F = fvf.read_mesh(tmp_path / "a.vtu")
    np.testing.assert_array_equal(F, torus.faces)
    data = read_data(tmp_path / "a.vtu", torus)
    assert data["v"].n == 4
    np.testing.assert_array_equal(data["v"], cross)


# ---------------------------------------------------------------------------- command line
@pytest.mark.parametrize("suffix", [".npz", ".ply", ".vtu"])
def test_cli_design_then_consumers_keep_n(tmp_path, torus, suffix, capsys):
    _need(suffix)
    mesh = tmp_path / "torus.obj"
    fvf.write_mesh(mesh, torus.vertices, torus.faces)
    out = tmp_path / f"line{suffix}"
    assert main(["design", str(mesh), "--n", "2", "-o", str(out)]) == 0
    data = read_data(out, torus)
    assert data["v"].n == 2
    capsys.readouterr()
    # quad meshing needs a cross field: the line field is refused before any stage runs
    code = main(["quad", str(mesh), "--faces", "60", "--field", f"{out}:v", "-o",
                 str(tmp_path / "q.obj")])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and "DirectionCountConflictError" in err and "n=2" in err
    assert not (tmp_path / "q.obj").exists()


def test_cli_render_takes_n_from_the_file(tmp_path, torus, monkeypatch):
    viz = pytest.importorskip("fvf.viz")
    seen = {}

    def fake_render(mesh, path, **kwargs):  # what the command asks to draw
        seen.update(kwargs)
        return None

    monkeypatch.setattr(viz, "render", fake_render)
    mesh = tmp_path / "torus.obj"
    fvf.write_mesh(mesh, torus.vertices, torus.faces)
    fvf.write_mesh(tmp_path / "c.ply", torus.vertices, torus.faces,
                   face_data={"w": fvf.design_field(torus, n=4)})  # fmt: skip
    png = str(tmp_path / "c.png")
    args = ["render", str(mesh), str(tmp_path / "c.ply"), "--field", "w", "--singularities"]
    assert main([*args, "-o", png]) == 0
    assert seen["n"] == 4 and seen["field"].n == 4
    assert len(seen["singularities"][1]) == len(fvf.singularities(torus, seen["field"])[0])
    assert main([*args, "--n", "2", "-o", png]) == 2  # contradicts the file's n = 4


# ---------------------------------------------------------------------------- notebooks
def _filled(cls: type):
    """An instance of the dataclass ``cls``, every array field 10000 x 3, the rest None."""
    import dataclasses

    obj = object.__new__(cls)
    for f in dataclasses.fields(cls):
        value = np.arange(30_000.0).reshape(-1, 3) if "ndarray" in str(f.type) else None
        object.__setattr__(obj, f.name, value)
    return obj


def test_results_show_a_table_in_a_notebook(torus, cross):
    classes = [fvf.SeamlessParameterization, fvf.MatchResult, fvf.TransportResult]
    classes += [fvf.FluidResult, fvf.mesh.PrincipalCurvatures, fvf.design.nfields.CutGraph]
    for cls in classes:
        html = _filled(cls)._repr_html_()
        assert html.startswith("<table>") and cls.__name__ in html, cls
        assert "float64(10000, 3)" in html and "29999" not in html, cls
    html = fvf.repair_mesh(torus.vertices, torus.faces)._repr_html_()
    assert "RepairResult" in html and "vertices" in html
    assert "n=4" in fvf.numerics.summary.short_value(cross)


def test_render_without_a_path_shows_the_picture_in_a_notebook(torus, cross):
    viz = pytest.importorskip("fvf.viz")
    pytest.importorskip("matplotlib")
    info = viz.render(torus, field=cross, size=(160, 120), backend="matplotlib")
    assert info.path is None and info.png.startswith(b"\x89PNG")
    assert info._repr_png_() == info.png and "png" not in repr(info)


# ---------------------------------------------------------------------------- glTF
def test_gltf_round_trip_and_seams_welded(tmp_path, torus):
    pytest.importorskip("trimesh")

    V = torus.vertices.astype(np.float32).astype(np.float64)  # glTF stores float32
    for suffix in (".glb", ".gltf"):
        fvf.write_mesh(tmp_path / f"t{suffix}", V, torus.faces)
        V2, F2 = fvf.read_mesh(tmp_path / f"t{suffix}")
        np.testing.assert_array_equal(V2, V)
        np.testing.assert_array_equal(F2, torus.faces)
    # a seam: vertex 0 stored twice (as glTF does where normals or uvs jump)
    Vs = np.vstack([V, V[:1]])
    Fs = torus.faces.copy()
    Fs[Fs[:, 0] == 0, 0] = len(V)
    fvf.write_mesh(tmp_path / "seam.glb", Vs, Fs)
    with pytest.warns(fvf.VerticesWeldedWarning, match="welded 1 glTF vertices"):
        V3, F3 = fvf.read_mesh(tmp_path / "seam.glb")
    np.testing.assert_array_equal(V3, V)
    np.testing.assert_array_equal(F3, torus.faces)
    assert fvf.as_mesh(tmp_path / "t.glb").n_faces == torus.n_faces
    with pytest.raises(fvf.MeshFormatError):
        fvf.write_mesh(tmp_path / "q.glb", V, torus.faces, face_data={"v": torus.face_normals})


def test_gltf_without_trimesh_names_the_package(tmp_path, torus, monkeypatch):
    pytest.importorskip("trimesh")
    from fvf.io.formats import gltf

    fvf.write_mesh(tmp_path / "t.glb", torus.vertices, torus.faces)

    def missing(path):
        raise fvf.MissingExtraError(f"{path}: needs trimesh: pip install trimesh")

    monkeypatch.setattr(gltf, "requires", missing)
    with pytest.raises(fvf.MissingExtraError, match="trimesh"):
        fvf.read_mesh(tmp_path / "t.glb")
    (tmp_path / "bad.glb").write_bytes(b"glTF nonsense")
    monkeypatch.undo()
    with pytest.raises(fvf.MeshReadError):
        fvf.read_mesh(tmp_path / "bad.glb")


def test_a_stack_of_fields_keeps_n(tmp_path, torus):
    _, stack = fvf.smoothest_fields(torus, 2, n=4)
    path = write_data(tmp_path / "s.npz", {"fields": stack}, mesh=torus,
                      mesh_path=tmp_path / "t.obj", command="test")  # fmt: skip
    back = read_data(path, torus)["fields"]
    assert back.n == 4 and back[1].n == 4
    np.testing.assert_array_equal(back, stack)
    ply = write_data(tmp_path / "s.ply", {"fields": stack}, mesh=torus,
                     mesh_path=tmp_path / "t.obj", command="test")  # fmt: skip
    data = read_data(ply, torus)
    assert data["fields_1"].n == 4
    np.testing.assert_array_equal(data["fields_1"], stack[1])
