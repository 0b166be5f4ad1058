"""PLY results that MeshLab shows: on each element with data, fvf writes MeshLab's standard
``quality`` (float) and ``red green blue`` (uchar) properties, a picture of the element's
first array (a 3-vector by its length) through fvf's own numpy colormap, after its named
properties; fvf's readers recognise the picture and still round-trip exactly.

The file is parsed here by a reader of its own (not fvf's), and by MeshLab itself
(pymeshlab), trimesh, meshio and PyVista when they are installed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import fvf
from fvf.cli.main import EXIT_OK, main
from fvf.io.colormap import NOT_FINITE, colormap_table, scalar_colours, scalar_positions

_TYPES = {"double": "<f8", "float": "<f4", "uchar": "u1", "int": "<i4"}


def parse_ply(path: Path) -> tuple[list[str], dict[str, np.ndarray]]:
    """(comments, {element: structured records}) of a binary little-endian PLY whose faces
    are triangles: an independent reader for the checks."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    lines = data[:end].decode("ascii").splitlines()
    assert lines[:2] == ["ply", "format binary_little_endian 1.0"]
    comments = [ln[8:] for ln in lines if ln.startswith("comment ")]
    elements: list[tuple[str, int, list]] = []
    for ln in lines:
        w = ln.split()
        if w[0] == "element":
            elements.append((w[1], int(w[2]), []))
        elif w[0] == "property" and w[1] == "list":
            elements[-1][2].extend([("count", _TYPES[w[2]]), (w[4], _TYPES[w[3]], (3,))])
        elif w[0] == "property":
            elements[-1][2].append((w[2], _TYPES[w[1]]))
    out, at = {}, end
    for name, size, fields in elements:
        dtype = np.dtype(fields)
        out[name] = np.frombuffer(data, dtype, size, at)
        at += dtype.itemsize * size
    assert at == len(data)
    return comments, out


@pytest.fixture
def sphere():
    mesh = fvf.icosphere(2)
    f = mesh.vertices[:, 2] ** 2 - 0.3
    v = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    return mesh, f, v


def test_quality_and_colours_picture_the_first_arrays(sphere, tmp_path):
    mesh, f, v = sphere
    path = tmp_path / "result.ply"
    fvf.write_mesh(path, mesh.vertices, mesh.faces,
                   vertex_data={"f": f, "g": mesh.vertices[:, 0]},
                   face_data={"v": v, "area": mesh.face_areas})  # fmt: skip
    comments, el = parse_ply(path)
    vertex, face = el["vertex"], el["face"]
    assert vertex.dtype.names == ("x", "y", "z", "f", "g", "quality", "red", "green", "blue")
    assert face.dtype.names[-4:] == ("quality", "red", "green", "blue")
    assert vertex.dtype["quality"] == np.float32 and vertex.dtype["red"] == np.uint8
    assert np.array_equal(vertex["f"], f)  # the named properties stay, as doubles
    assert np.array_equal(vertex["quality"], f.astype(np.float32))
    rgb = np.column_stack([vertex[c] for c in ("red", "green", "blue")])
    assert np.array_equal(rgb, scalar_colours(f))
    table = colormap_table()
    assert np.array_equal(rgb[np.argmin(f)], table[0]) and np.array_equal(
        rgb[np.argmax(f)], table[-1]
    )
    t = (f - f.min()) / (f.max() - f.min())
    assert np.array_equal(rgb, table[np.rint(t * 255).astype(int)])
    speed = np.linalg.norm(v, axis=1)  # a vector field: its length
    assert np.array_equal(face["quality"], speed.astype(np.float32))
    assert np.array_equal(np.column_stack([face[c] for c in ("red", "green", "blue")]),
                          scalar_colours(speed))  # fmt: skip
    assert "fvf picture vertex: f" in comments and "fvf picture face: |v|" in comments


def test_fvf_reads_its_files_back_exactly(sphere, tmp_path):
    mesh, f, v = sphere
    path = tmp_path / "result.ply"
    u = fvf.NField(v, 4)
    fvf.write_mesh(path, mesh.vertices, mesh.faces, vertex_data={"f": f},
                   face_data={"u": u, "area": mesh.face_areas})  # fmt: skip
    vertex, face = fvf.io.read_ply_properties(path)
    assert list(vertex) == ["f"] and list(face) == ["ux", "uy", "uz", "area"]
    assert np.array_equal(vertex["f"], f) and np.array_equal(face["area"], mesh.face_areas)
    data = fvf.io.read_data(path, mesh)
    assert set(data) == {"f", "u", "ux", "uy", "uz", "area", "n_u", "vertices", "faces"}
    assert isinstance(data["u"], fvf.NField) and data["u"].n == 4
    assert np.array_equal(data["u"], v) and np.array_equal(data["f"], f)
    V, F = fvf.read_mesh(path)
    assert np.array_equal(V, mesh.vertices) and np.array_equal(F, mesh.faces)


def test_which_array_is_shown(sphere, tmp_path):
    mesh, f, v = sphere
    path = tmp_path / "p.ply"
    fvf.write_mesh(path, mesh.vertices, mesh.faces, face_data={"v": v})
    comments, el = parse_ply(path)
    assert "quality" not in el["vertex"].dtype.names  # no vertex data, no vertex picture
    assert "fvf picture face: |v|" in comments
    # a property of the data's own named like a standard one: the data keeps its own
    fvf.write_mesh(path, mesh.vertices, mesh.faces, vertex_data={"f": f, "quality": -f})
    comments, el = parse_ply(path)
    assert el["vertex"].dtype.names == ("x", "y", "z", "f", "quality")
    assert not [c for c in comments if c.startswith("fvf picture")]
    assert np.array_equal(fvf.io.read_ply_properties(path)[0]["quality"], -f)
    fvf.write_mesh(path, mesh.vertices, mesh.faces)  # a bare mesh: no properties at all
    _, el = parse_ply(path)
    assert el["vertex"].dtype.names == ("x", "y", "z") and el["face"].dtype.names == (
        "count",
        "vertex_indices",
    )


def test_other_files_keep_their_quality_as_data(tmp_path):
    path = tmp_path / "meshlab.ply"
    path.write_text(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nproperty float quality\nproperty uchar red\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n"
        "0 0 0 0.5 10\n1 0 0 1.5 20\n0 1 0 2.5 30\n3 0 1 2\n"
    )
    vertex, _ = fvf.io.read_ply_properties(path)
    assert np.array_equal(vertex["quality"], [0.5, 1.5, 2.5])
    assert np.array_equal(vertex["red"], [10, 20, 30])


def test_the_colormap():
    table = colormap_table()
    assert table.shape == (256, 3) and table.dtype == np.uint8 and not table.flags.writeable
    # perceptual: the lightness (Rec. 709 luma of linear light) rises monotonically
    lin = np.where(
        table / 255 <= 0.04045, table / 255 / 12.92, ((table / 255 + 0.055) / 1.055) ** 2.4
    )
    luma = lin @ [0.2126, 0.7152, 0.0722]
    assert np.all(np.diff(luma) > -1e-4)  # 8-bit rounding aside
    assert np.all(np.diff(luma[::8]) > 0) and luma[-1] > 40 * luma[0]
    assert table[0, 2] > table[0, 1] and table[-1, 0] > table[-1, 2]  # violet to yellow
    x = np.array([2.0, np.nan, 4.0, np.inf, 3.0])
    assert np.allclose(scalar_positions(x), [0, np.nan, 1, np.nan, 0.5], equal_nan=True)
    c = scalar_colours(x)
    assert np.array_equal(c[1], NOT_FINITE) and np.array_equal(c[3], NOT_FINITE)
    assert np.array_equal(scalar_colours([7.0, 7.0]), table[[128, 128]])
    assert np.array_equal(scalar_colours([-1e308, 1e308])[[0, 1]], table[[0, -1]])


def test_meshlab_reads_the_picture(sphere, tmp_path):
    pymeshlab = pytest.importorskip("pymeshlab")
    mesh, f, v = sphere
    path = tmp_path / "result.ply"
    fvf.write_mesh(path, mesh.vertices, mesh.faces, vertex_data={"f": f}, face_data={"v": v})
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    m = ms.current_mesh()
    assert m.has_vertex_scalar() and m.has_face_scalar()
    assert m.has_vertex_color() and m.has_face_color()
    assert np.array_equal(m.vertex_scalar_array(), f.astype(np.float32))
    speed = np.linalg.norm(v, axis=1)
    assert np.allclose(m.face_scalar_array(), speed.astype(np.float32), rtol=0, atol=0)
    assert np.allclose(m.vertex_color_matrix()[:, :3] * 255, scalar_colours(f), atol=1e-3)
    assert np.allclose(m.face_color_matrix()[:, :3] * 255, scalar_colours(speed), atol=1e-3)


def test_other_readers_open_the_file(sphere, tmp_path):
    mesh, f, v = sphere
    both, vertex_only = tmp_path / "both.ply", tmp_path / "vertex.ply"
    fvf.write_mesh(both, mesh.vertices, mesh.faces, vertex_data={"f": f}, face_data={"v": v})
    fvf.write_mesh(vertex_only, mesh.vertices, mesh.faces, vertex_data={"f": f})
    try:
        import trimesh
    except ImportError:
        trimesh = None
    if trimesh is not None:
        t = trimesh.load(both, process=False)
        assert t.faces.shape == (mesh.n_faces, 3)
        assert np.array_equal(t.visual.vertex_colors[:, :3], scalar_colours(f))
    try:
        import pyvista
    except ImportError:
        pyvista = None
    if pyvista is not None:
        p = pyvista.read(both)
        assert p.n_cells == mesh.n_faces and np.array_equal(p.point_data["RGB"], scalar_colours(f))
    try:
        import meshio
    except ImportError:
        return
    m = meshio.read(vertex_only)  # meshio 5 reads vertex properties (not face ones)
    assert np.array_equal(m.point_data["f"], f)
    assert np.array_equal(m.point_data["quality"], f.astype(np.float32))


def test_the_command_writes_the_picture(tmp_path, capsys):
    mesh = fvf.icosphere(2)
    fvf.write_mesh(tmp_path / "ico.obj", mesh.vertices, mesh.faces)
    out = tmp_path / "design.ply"
    assert main(["design", str(tmp_path / "ico.obj"), "-o", str(out)]) == EXIT_OK
    capsys.readouterr()
    comments, el = parse_ply(out)
    v = fvf.io.read_data(out, mesh)["v"]
    assert "fvf picture face: |v|" in comments
    speed = np.linalg.norm(np.asarray(v), axis=1)
    assert np.array_equal(el["face"]["quality"], speed.astype(np.float32))
    assert "quality" not in fvf.io.read_data(out, mesh)
