"""Meeting users where they are: meshes from trimesh, meshio, PyVista and pyFM at every
entrance (as_mesh), results written for ParaView and MeshLab (PLY properties, VTK), the
command's repair, ``FILE.npz:KEY`` and the one layout of functions.

The peers are the real libraries (the ``[test]`` extra); a test whose library is missing
is skipped.
"""

from __future__ import annotations

import inspect
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import fvf
import fvf.viz
from fvf import errors
from fvf.cli.main import EXIT_BAD_INPUT, EXIT_OK, EXIT_PROBLEMS, main

ROOT = Path(__file__).resolve().parents[2]
SPOT = Path(fvf.mesh.spot_path()) if hasattr(fvf.mesh, "spot_path") else None


def _rotation(mesh) -> np.ndarray:
    return mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))


# ---------------------------------------------------------------------------- as_mesh
def test_as_mesh_plain_inputs():
    ico = fvf.icosphere(1)
    assert fvf.as_mesh(ico) is ico
    for pair in ((ico.vertices, ico.faces), [ico.vertices.tolist(), ico.faces.tolist()]):
        mesh = fvf.as_mesh(pair)
        assert np.array_equal(mesh.vertices, ico.vertices)
        assert np.array_equal(mesh.faces, ico.faces)
    repaired = fvf.repair_mesh(np.vstack([ico.vertices, [[9.0, 9, 9]]]), ico.faces)
    assert repaired.mesh.n_vertices == 42 and fvf.as_mesh(repaired).n_vertices == 42
    with pytest.raises(TypeError, match=r"as_mesh: got builtins\.dict; pass a fvf\.TriMesh"):
        fvf.as_mesh({"vertices": ico.vertices})
    with pytest.raises(errors.MeshIndexError):
        fvf.as_mesh((ico.vertices, ico.faces + 1))


def test_as_mesh_trimesh():
    trimesh = pytest.importorskip("trimesh")
    t = trimesh.creation.icosphere(2)
    mesh = fvf.as_mesh(t)
    assert np.array_equal(mesh.vertices, t.vertices) and np.array_equal(mesh.faces, t.faces)
    assert fvf.as_mesh(t) is mesh  # remembered while the arrays are unchanged
    L = fvf.laplacian(t)
    assert (abs(L - fvf.laplacian(mesh)) > 0).nnz == 0
    f = np.asarray(t.vertices)[:, 0]
    ft = fvf.flow(t, _rotation(mesh), f, 0.3, method="upwind")
    assert np.allclose(ft, fvf.flow(mesh, _rotation(mesh), f, 0.3, method="upwind"))
    t.vertices = t.vertices * 2.0  # edited: a new TriMesh
    assert fvf.as_mesh(t) is not mesh and fvf.as_mesh(t).total_area > 3 * mesh.total_area


def test_as_mesh_meshio():
    meshio = pytest.importorskip("meshio")
    ico = fvf.icosphere(1)
    m = meshio.Mesh(ico.vertices, [("triangle", ico.faces)])
    assert np.array_equal(fvf.as_mesh(m).faces, ico.faces)
    X = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1], [2, 0.5]])  # planar quads: z = 0
    quads = meshio.Mesh(
        X, [("quad", np.array([[0, 1, 2, 3]])), ("triangle", np.array([[1, 4, 2]]))]
    )
    with pytest.warns(errors.PolygonTriangulatedWarning):
        mesh = fvf.as_mesh(quads)
    assert mesh.n_faces == 3 and np.allclose(mesh.vertices[:, 2], 0)
    tets = meshio.Mesh(ico.vertices[:4], [("tetra", np.array([[0, 1, 2, 3]]))])
    with pytest.raises(errors.MeshShapeError, match="tetra.*surface"):
        fvf.as_mesh(tets)


def test_as_mesh_pyvista():
    pv = pytest.importorskip("pyvista")
    sphere = pv.Sphere(theta_resolution=12, phi_resolution=8)
    mesh = fvf.as_mesh(sphere)
    assert mesh.n_faces == sphere.n_cells and np.allclose(mesh.vertices, sphere.points)
    assert fvf.singularities(sphere, fvf.gradient(mesh, mesh.vertices[:, 2]))[1].sum() == 2
    plane = pv.Plane(i_resolution=3, j_resolution=2)  # quads
    with pytest.warns(errors.PolygonTriangulatedWarning):
        assert fvf.as_mesh(plane).n_faces == 12
    with pytest.raises(TypeError, match="extract_surface"):
        fvf.as_mesh(pv.ImageData(dimensions=(3, 3, 3)))


def test_as_mesh_pyfm():
    pytest.importorskip("pyFM")
    from pyFM.mesh import TriMesh as PyFMTriMesh

    ico = fvf.icosphere(2)
    m = PyFMTriMesh(ico.vertices.copy(), ico.faces.copy())
    mesh = fvf.as_mesh(m)
    assert np.array_equal(mesh.faces, ico.faces)
    assert np.allclose(fvf.vertex_areas(m), ico.vertex_areas)


RESULTS = {"FluidResult", "LicTexture"}  # results holding a mesh, not entrances


def _required_after_mesh(fn) -> int:
    """How many required positional parameters ``fn`` has after its mesh."""
    target = fn.__init__ if inspect.isclass(fn) else fn
    params = list(inspect.signature(target).parameters.values())
    params = params[1:] if inspect.isclass(fn) else params
    kinds = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    return sum(p.kind in kinds and p.default is inspect.Parameter.empty for p in params[1:])


def _mesh_entrances() -> list[tuple[str, object]]:
    """Every public callable (flat namespace, fvf.viz) whose first parameter is a mesh."""
    out = []
    for space, names in ((fvf, fvf.__all__), (fvf.viz, fvf.viz.__all__)):
        for name in names:
            obj = getattr(space, name)
            target = obj.__init__ if inspect.isclass(obj) else obj
            if not callable(obj) or inspect.ismodule(obj):
                continue
            try:
                params = list(inspect.signature(target).parameters)
            except (TypeError, ValueError):
                continue
            params = params[1:] if inspect.isclass(obj) else params
            if params[:1] == ["mesh"] and name not in RESULTS:
                out.append((f"{space.__name__}.{name}", obj))
    return out


@pytest.mark.parametrize("name,fn", _mesh_entrances(), ids=[n for n, _ in _mesh_entrances()])
def test_every_public_entrance_calls_as_mesh(name, fn):
    """docs/architecture.md: every public entrance converts its mesh with as_mesh first,
    so a foreign object gives as_mesh's TypeError (no AttributeError 'cached'), before any
    other argument is looked at (here all None)."""
    with pytest.raises(TypeError, match=r"as_mesh: got builtins\.object"):
        fn(object(), *[None] * _required_after_mesh(fn))


# ---------------------------------------------------------------------------- soups, seams
def test_uv_seam_split_names_the_weld():
    trimesh = pytest.importorskip("trimesh")
    path = Path(fvf.mesh.builtin.__file__).parent / "data" / "spot.obj"
    split = trimesh.load(path)  # trimesh splits vertices at UV seams by default
    with pytest.raises(errors.NonManifoldError) as info:
        fvf.as_mesh(split)
    text = str(info.value)
    assert "remove_duplicate_vertices" in text and "merge_tex=True" in text
    assert "split_nonmanifold_vertices" not in text  # not the wrong fix
    welded = trimesh.load(path, merge_tex=True, merge_norm=True)
    assert fvf.as_mesh(welded).n_vertices == 2930
    V, F, _ = fvf.remove_duplicate_vertices(split.vertices, split.faces)
    assert fvf.TriMesh(V, F).is_closed


def test_triangle_soup_warns_with_the_fix():
    ico = fvf.icosphere(2)
    soup = ico.vertices[ico.faces].reshape(-1, 3)
    with pytest.warns(errors.DuplicateVertexWarning, match="soup.*remove_duplicate_vertices"):
        mesh = fvf.TriMesh(soup, np.arange(len(soup)).reshape(-1, 3))
    assert mesh.n_components == ico.n_faces
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fvf.TriMesh(*fvf.remove_duplicate_vertices(soup, np.arange(len(soup)).reshape(-1, 3))[:2])
        few = ico.vertices[ico.faces[:8]].reshape(-1, 3)  # a few loose triangles: no warning
        fvf.TriMesh(few, np.arange(len(few)).reshape(-1, 3))


# ---------------------------------------------------------------------------- export
def test_ply_properties_round_trip(tmp_path):
    mesh = fvf.icosphere(2)
    f, v = mesh.vertices[:, 0], _rotation(mesh)
    path = tmp_path / "p.ply"
    fvf.write_mesh(path, mesh.vertices, mesh.faces, vertex_data={"f": f, "n": mesh.vertices},
                   face_data={"v": v, "area": mesh.face_areas})  # fmt: skip
    V, F = fvf.read_mesh(path)
    assert np.array_equal(V, mesh.vertices) and np.array_equal(F, mesh.faces)
    vertex, face = fvf.io.read_ply_properties(path)
    assert np.array_equal(vertex["f"], f) and np.array_equal(vertex["ny"], mesh.vertices[:, 1])
    data = fvf.io.read_data(path, mesh)
    assert np.array_equal(data.field("v", mesh), v)
    assert np.array_equal(data["area"], mesh.face_areas)
    with pytest.raises(errors.FvfError, match="OBJ files cannot hold"):
        fvf.write_mesh(tmp_path / "p.obj", mesh.vertices, mesh.faces, vertex_data={"f": f})
    with pytest.raises(errors.FieldShapeError, match=r"\(162,\) or \(162, 3\)"):
        fvf.write_mesh(path, mesh.vertices, mesh.faces, vertex_data={"f": f[:-1]})
    with pytest.raises(errors.FvfError, match="property name"):
        fvf.write_mesh(path, mesh.vertices, mesh.faces, vertex_data={"x": f})


def test_vtk_files(tmp_path):
    mesh = fvf.icosphere(2)
    f, v = mesh.vertices[:, 0], _rotation(mesh)
    meshio = pytest.importorskip("meshio")
    fvf.write_mesh(tmp_path / "a.vtu", mesh.vertices, mesh.faces, vertex_data={"f": f},
                   face_data={"v": v})  # fmt: skip
    back = meshio.read(tmp_path / "a.vtu")
    assert np.allclose(back.points, mesh.vertices) and np.allclose(back.point_data["f"], f)
    assert np.allclose(back.cell_data["v"][0], v)
    pv = pytest.importorskip("pyvista")
    fvf.write_mesh(tmp_path / "a.vtp", mesh.vertices, mesh.faces, vertex_data={"f": f},
                   face_data={"v": v})  # fmt: skip
    poly = pv.read(tmp_path / "a.vtp")
    assert poly.n_cells == mesh.n_faces and np.allclose(poly.cell_data["v"], v)
    assert np.array_equal(fvf.as_mesh(poly).faces, mesh.faces)


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("interop")
    mesh = fvf.icosphere(2)
    fvf.write_mesh(d / "ico.obj", mesh.vertices, mesh.faces)
    f = mesh.vertices[:, 0]
    np.savez(d / "fields.npz", f=f, v=_rotation(mesh),
             u=mesh.project_tangent(np.cross([1.0, 0, 0], mesh.face_centroids)))  # fmt: skip
    return d, mesh


def test_flow_to_ply_round_trips(work, capsys):
    d, mesh = work
    args = [str(d / "ico.obj"), str(d / "fields.npz"), "--t", "0", "0.5", "--method", "upwind"]
    assert main(["flow", *args, "-o", str(d / "flow.npz")]) == EXIT_OK
    assert main(["flow", *args, "-o", str(d / "flow.ply")]) == EXIT_OK
    npz = np.load(d / "flow.npz")
    data = fvf.io.read_data(d / "flow.ply", mesh)  # the PLY is a data file on the mesh
    assert np.array_equal(data["f_t_1"], npz["f_t"][1])
    assert np.array_equal(data.field("v", mesh), npz["v"])
    again = ["flow", str(d / "flow.ply"), str(d / "flow.ply"), "--function", "f_t_1"]
    assert main([*again, "--t", "0", "-o", str(d / "again.npz")]) == EXIT_OK  # mesh too
    assert np.allclose(np.load(d / "again.npz")["f_t"][0], npz["f_t"][1])
    header = (d / "flow.ply").read_bytes().split(b"end_header")[0].decode()
    assert "comment fvf command: fvf flow" in header and "keys not stored" in header
    assert main(["design", str(d / "ico.obj"), "-o", str(d / "design.ply")]) == EXIT_OK
    marks = fvf.io.read_ply_properties(d / "design.ply")[0]["singularity_index"]
    npz = fvf.io.read_data(d / "design.ply", mesh)
    ids, ind = fvf.singularities(mesh, npz.field("v", mesh))
    assert np.array_equal(np.flatnonzero(marks), ids) and np.array_equal(marks[ids], ind)
    capsys.readouterr()


def test_keys_from_several_files(work, capsys):
    """Two fields made by fvf design are both key v: FILE.npz:KEY brackets them."""
    d, mesh = work
    np.savez(d / "c1.npz", constraint_faces=[0], directions=mesh.face_edge_vectors[[0], 0])
    np.savez(d / "c2.npz", constraint_faces=[9], directions=mesh.face_edge_vectors[[9], 1])
    for i in (1, 2):
        argv = ["design", str(d / "ico.obj"), "--constraints", str(d / f"c{i}.npz")]
        assert main([*argv, "-o", str(d / f"des{i}.npz")]) == EXIT_OK
    a, b = str(d / "des1.npz"), str(d / "des2.npz")
    argv = ["bracket", str(d / "ico.obj"), "--first", f"{a}:v", "--second", f"{b}:v"]
    assert main([*argv, "-o", str(d / "ab.npz")]) == EXIT_OK
    out = np.load(d / "ab.npz")
    v1, v2 = np.load(a)["v"], np.load(b)["v"]
    assert np.allclose(out["commutator"], fvf.commutator_field(mesh, v1, v2), atol=1e-12)
    assert sorted(out["inputs"].tolist()) == sorted([str(Path(a)), str(Path(b))])
    assert main([*argv, "-o", a]) == EXIT_BAD_INPUT  # an input named in an option, too
    assert "InputOverwriteError" in capsys.readouterr().err


def test_one_layout_and_old_files(work, capsys, tmp_path):
    d, mesh = work
    X = mesh.vertices
    F = np.stack([X[:, 0], X[:, 1]], axis=1)  # (n, 2): one column per function
    np.savez(tmp_path / "new.npz", f=F, v=_rotation(mesh))
    argv = ["flow", str(d / "ico.obj"), str(tmp_path / "new.npz"), "--t", "0.1", "0.2"]
    assert main([*argv, "--method", "upwind", "-o", str(tmp_path / "o.npz")]) == EXIT_OK
    out = np.load(tmp_path / "o.npz")
    assert out["f_t"].shape == (2, 162, 2) and str(out["layout"]) == "columns"
    expected = fvf.flow(mesh, _rotation(mesh), F, [0.1, 0.2], method="upwind")
    assert np.allclose(out["f_t"], expected)  # exactly the library's layout
    np.savez(tmp_path / "old.npz", f=F.T, v=_rotation(mesh))  # rows: the old layout
    data = fvf.io.read_data(tmp_path / "old.npz", mesh)
    with pytest.warns(errors.LegacyLayoutWarning, match=r"\(2, 162\).*\(162, 2\)"):
        assert np.array_equal(data.functions("f", mesh), F)
    old_out = {"f_t": np.swapaxes(expected, 1, 2), "f": F.T, "vertices": X, "faces": mesh.faces}
    np.savez(tmp_path / "old_out.npz", **old_out)  # what older fvf wrote: (T, k, n)
    old = fvf.io.read_data(tmp_path / "old_out.npz", mesh)
    with pytest.warns(errors.LegacyLayoutWarning):
        assert np.array_equal(old.select("f_t[1, :, 0]", mesh.n_vertices), expected[1, :, 0])
    new = fvf.io.read_data(tmp_path / "o.npz", mesh)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a file that says layout=columns is never moved
        assert new.select("f_t[1, :, 1]", mesh.n_vertices).shape == (162,)


def test_repair_command_and_info_hint(tmp_path, capsys):
    ico = fvf.icosphere(2)
    soup = ico.vertices[ico.faces].reshape(-1, 3)
    S = np.arange(len(soup)).reshape(-1, 3)
    V = np.vstack([soup, [[5.0, 5, 5]]])  # plus an unreferenced vertex
    fvf.write_mesh(tmp_path / "soup.ply", V, S)
    assert main(["info", str(tmp_path / "soup.ply")]) == EXIT_PROBLEMS
    out = capsys.readouterr().out
    assert "fix: fvf repair" in out and "soup_fixed.ply" in out
    assert "Fixed by `fvf repair` (step remove_unreferenced_vertices)" in out
    argv = ["repair", str(tmp_path / "soup.ply"), "-o", str(tmp_path / "fixed.obj")]
    assert main(argv) == EXIT_OK
    W, G = fvf.read_mesh(tmp_path / "fixed.obj")
    assert fvf.TriMesh(W, G).is_closed and W.shape == ico.vertices.shape
    maps = np.load(tmp_path / "fixed.maps.npz")
    assert np.array_equal(V[maps["vertex_origin"]], W) and maps["vertex_map"][-1] == -1
    assert main(["repair", str(tmp_path / "soup.ply"), "-o", str(tmp_path / "soup.ply")]) == 2
    capsys.readouterr()


# ---------------------------------------------------------------------------- defects
def test_map_consistent_field_with_the_identity_map():
    from fvf.design.symmetric import map_consistent_field

    basis = fvf.SpectralBasis(fvf.icosphere(2), 10)
    v, residual = map_consistent_field(basis, np.eye(10))
    assert np.isfinite(v).all() and residual == 0.0
    L2 = np.sqrt(basis.mesh.face_areas @ (v * v).sum(1))
    assert L2 == pytest.approx(1.0)


def test_examples_repair_or_stop_in_one_line(tmp_path):
    ico = fvf.icosphere(2)
    V = np.vstack([ico.vertices, [[5.0, 5, 5]]])  # needs repair: an unreferenced vertex
    fvf.write_mesh(tmp_path / "orphan.obj", V, ico.faces)
    (tmp_path / "broken.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 3\n")
    script = ROOT / "examples" / "fig09_commutator_field.py"
    env = {"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg"}
    run = [sys.executable, str(script), "--no-pictures"]
    r = subprocess.run([*run, str(tmp_path / "orphan.obj")], capture_output=True, text=True,
                       env=env, cwd=tmp_path)  # fmt: skip
    assert r.returncode == 0 and "needs repair" in r.stdout and "Traceback" not in r.stderr
    r = subprocess.run([*run, str(tmp_path / "broken.obj")], capture_output=True, text=True,
                       env=env, cwd=tmp_path)  # fmt: skip
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr


def test_tutorial_code_fits_the_page():
    """Code lines of the tutorial fit the site's code blocks (80 characters: no wrap)."""
    text = (ROOT / "docs" / "tutorial.md").read_text()
    long = [
        line
        for block in re.findall(r"```python\n(.*?)```", text, flags=re.S)
        for line in block.splitlines()
        if len(line) > 80
    ]
    assert not long, long


def test_readme_commands_use_the_venv():
    text = (ROOT / "README.md").read_text()
    for line in re.findall(r"```bash\n(.*?)```", text, flags=re.S)[0].splitlines()[:2]:
        assert ".venv/bin/" in line
    assert ".venv/bin/mkdocs build" in text
