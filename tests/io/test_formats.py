"""Tests of the mesh format registry (fvf.io.formats): STL in and out, quads out and back,
check_writable before any work, every registered format round-tripping, batch finding STL."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fvf
from fvf.errors import (
    MeshFormatError,
    MeshReadError,
    MissingExtraError,
    ParameterError,
    PolygonTriangulatedWarning,
    VerticesWeldedWarning,
)
from fvf.io import check_writable, read_mesh, read_ply_properties, write_mesh
from fvf.io.formats import FORMATS, readable_suffixes, writable_suffixes
from fvf.io.formats.stl import RECORD
from test_io import MUTATION, check_mesh, mutated

# ---------------------------------------------------------------------------- data
CUBE_V = np.array(
    [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
    dtype=np.float64,
)
CUBE_F = np.array(
    [[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
     [2, 3, 7], [2, 7, 6], [1, 2, 6], [1, 6, 5], [3, 0, 4], [3, 4, 7]]
)  # fmt: skip


def stl_ascii(T: np.ndarray, name: str = "part", normal: str = "0 0 0") -> str:
    """One ``solid`` block with the triangles T (m, 3, 3)."""
    facet = f"  facet normal {normal}\n    outer loop\n"
    facet += "      vertex %r %r %r\n" * 3 + "    endloop\n  endfacet\n"
    body = (facet * len(T)) % tuple(float(x) for x in T.ravel())
    return f"solid {name}\n{body}endsolid {name}\n"


def stl_binary(T: np.ndarray, header: bytes = b"test", normals=None) -> bytes:
    """A binary STL of the triangles T (m, 3, 3); ``header`` padded to 80 bytes."""
    rec = np.zeros(len(T), dtype=RECORD)
    rec["corners"] = T
    if normals is not None:
        rec["normal"] = normals
    return header.ljust(80, b" ")[:80] + np.uint32(len(T)).tobytes() + rec.tobytes()


def grid(n: int = 4, quads: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """A bumpy n x n grid, coordinates exact in float32, as quads or triangles."""
    x, y = np.meshgrid(np.arange(n) / 8.0, np.arange(n) / 4.0, indexing="ij")
    V = np.column_stack([x.ravel(), y.ravel(), ((x * 8 + y * 4) % 3).ravel() / 16.0])
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    Q = np.column_stack([a, a + n, a + n + 1, a + 1])
    if quads:
        return V, Q
    return V, np.concatenate([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]])


def read_stl(path, **kwargs):
    with pytest.warns(VerticesWeldedWarning, match="welded"):
        return read_mesh(path, **kwargs)


# ---------------------------------------------------------------------------- STL in
def test_binary_and_ascii_stl_round_trip(tmp_path):
    mesh = fvf.icosphere(2)
    V = mesh.vertices.astype(np.float32).astype(np.float64)  # STL stores float32
    out = tmp_path / "ico.stl"
    write_mesh(out, V, mesh.faces)
    assert out.stat().st_size == 84 + 50 * mesh.n_faces
    assert not out.read_bytes().startswith(b"solid")  # so no reader takes it for ascii
    Vb, Fb = read_stl(out)
    check_mesh(Vb, Fb)
    assert Vb.shape == V.shape and np.array_equal(Vb[Fb], V[mesh.faces])  # every corner
    fvf.TriMesh(Vb, Fb)  # welded: a closed manifold again
    text = tmp_path / "ico_ascii.stl"
    text.write_text(stl_ascii(V[mesh.faces]))
    Va, Fa = read_stl(text)
    assert np.array_equal(Va, Vb) and np.array_equal(Fa, Fb)  # the same numbering


def test_binary_stl_whose_header_begins_with_solid(tmp_path):
    T = CUBE_V[CUBE_F]
    path = tmp_path / "solid_header.stl"
    path.write_bytes(stl_binary(T, header=b"solid exported by a CAD program"))
    V, F = read_stl(path)
    assert V.shape == (8, 3) and F.shape == (12, 3)
    assert np.array_equal(V[F], T)


def test_cube_soup_welds_to_8_vertices_and_12_faces(tmp_path):
    path = tmp_path / "cube.stl"
    path.write_bytes(stl_binary(CUBE_V[CUBE_F]))
    with pytest.warns(VerticesWeldedWarning, match=r"36 corners .* into 8 vertices \(28 corn"):
        V, F = read_mesh(path)
    assert V.shape == (8, 3) and F.shape == (12, 3)
    assert np.array_equal(V[F], CUBE_V[CUBE_F])
    assert np.array_equal(V, CUBE_V[[0, 2, 1, 3, 4, 5, 6, 7]])  # in order of first appearance
    mesh = fvf.TriMesh(V, F)
    assert mesh.n_vertices - mesh.n_edges + mesh.n_faces == 2


def test_multi_solid_ascii_stl(tmp_path):
    T = CUBE_V[CUBE_F]
    text = stl_ascii(T[:5], "first") + "\n" + stl_ascii(T[5:], "second").upper()
    path = tmp_path / "two.stl"
    path.write_text(text.replace("\n", "\r\n"))  # CRLF, upper-case keywords
    V, F = read_stl(path)
    assert V.shape == (8, 3) and np.array_equal(V[F], T)


def test_weld_rule_is_exact_equality(tmp_path):
    """0.0 == -0.0 welds; NaN never does; a round-off difference stays apart."""
    T = np.array(
        [[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[-0.0, 0, 0], [0, 1, 0], [1, 1e-7, 0]]],
        dtype=np.float32,
    ).astype(np.float64)
    path = tmp_path / "rule.stl"
    path.write_bytes(stl_binary(T))
    V, F = read_stl(path)
    assert len(V) == 4 and F.tolist() == [[0, 1, 2], [0, 2, 3]]
    T[:, 0, 0] = np.nan  # the first corner of both facets
    path.write_bytes(stl_binary(T))
    V, F = read_stl(path)
    assert len(V) == 5 and np.isnan(V[[0, 3], 0]).all()


def test_zero_area_facets_and_nan_normals_do_not_crash(tmp_path, capsys):
    from fvf.cli.main import main

    T = CUBE_V[CUBE_F]
    T = np.concatenate([T, T[:1, [0, 0, 1]]])  # a facet with a repeated corner
    normals = np.full((len(T), 3), np.nan)
    path = tmp_path / "part.stl"
    path.write_bytes(stl_binary(T, normals=normals))
    with pytest.warns(VerticesWeldedWarning, match="1 facets now repeat a vertex"):
        V, F = read_mesh(path)
    assert F.shape == (13, 3) and F[12, 0] == F[12, 1]
    ascii_path = tmp_path / "part_ascii.stl"
    ascii_path.write_text(stl_ascii(T, normal="nan nan -nan"))
    assert np.array_equal(read_stl(ascii_path)[1], F)
    assert main(["info", str(path)]) == 1  # the repeated vertex is a problem, reported
    captured = capsys.readouterr()
    assert "VerticesWeldedWarning" in captured.err and "welded the 39 corners" in captured.err
    assert "problem" in captured.out


def test_fvf_info_says_the_stl_was_welded(tmp_path, capsys):
    from fvf.cli.main import main

    path = tmp_path / "cube.stl"
    path.write_text(stl_ascii(CUBE_V[CUBE_F]))
    assert main(["info", str(path)]) == 0
    captured = capsys.readouterr()
    assert "fvf: warning: VerticesWeldedWarning" in captured.err
    assert "into 8 vertices" in captured.err and "no problems found" in captured.out


@pytest.mark.parametrize(
    ("name", "content", "match"),
    [
        ("binary", lambda b, a: b[:-30], r"promises 12 triangles.*ends early.*truncated"),
        ("solid", lambda b, a: b"solid" + b[5:-1], r"begins with 'solid'.*NUL.*truncated"),
        ("extra", lambda b, a: b + b"\0\0", r"2 bytes after the last triangle"),
        ("short", lambda b, a: b[:50], r"fewer than the 84 .* truncated or not an STL"),
        ("no_end", lambda b, a: a[: a.rindex(b"endsolid")], r"no 'endsolid'.*truncated"),
        ("mid_facet", lambda b, a: a[:400] + b"\nendsolid\n", r"facet \d+ .*incomplete.*trunc"),
        ("keyword", lambda b, a: a.replace(b"endloop", b"endlop", 1), r"'endlop' where 'endloop"),
        ("number", lambda b, a: a.replace(b"vertex 0.0", b"vertex 1_0", 1), r"line 4: '1_0'"),
        ("order", lambda b, a: a + a.replace(b"endsolid", b"solid"), r"'solid part' where end"),
    ],
)
def test_damaged_stl_is_a_typed_error_naming_the_problem(tmp_path, name, content, match):
    T = CUBE_V[CUBE_F]
    data = content(stl_binary(T), stl_ascii(T).encode())
    path = tmp_path / f"{name}.stl"
    path.write_bytes(data)
    with pytest.raises(MeshReadError, match=match) as info:
        read_mesh(path)
    assert str(path) in str(info.value)


# ---------------------------------------------------------------------------- quads
@pytest.mark.parametrize("suffix", [".obj", ".off", ".ply"])
def test_quads_written_and_read_back(tmp_path, suffix):
    V, Q = grid(5, quads=True)
    path = tmp_path / f"q{suffix}"
    write_mesh(path, V, Q)
    for faces in ("quads", "any"):
        V2, Q2 = read_mesh(path, faces=faces)
        assert np.array_equal(V2, V) and np.array_equal(Q2, Q) and Q2.dtype == np.int64
    assert np.array_equal(fvf.io.read_quad_mesh(path)[1], Q)
    with pytest.warns(PolygonTriangulatedWarning):  # the default: triangles, as before
        _, F = read_mesh(path)
    assert F.shape == (2 * len(Q), 3)


def test_read_mesh_faces_modes(tmp_path):
    path = tmp_path / "mixed.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nf 1 2 3 4\nf 2 5 3\n")
    with pytest.warns(PolygonTriangulatedWarning):
        _, F = read_mesh(path, faces="any")  # mixed sizes: triangulated
    assert F.tolist() == [[0, 1, 2], [0, 2, 3], [1, 4, 2]]
    with pytest.raises(MeshReadError, match="line 7: face has 3 vertices.*non-quads"):
        read_mesh(path, faces="quads")
    with pytest.raises(ParameterError, match="faces must be one of"):
        read_mesh(path, faces="quad")
    tri = tmp_path / "tri.off"
    write_mesh(tri, *grid(3))
    assert read_mesh(tri, faces="any")[1].shape == (8, 3)


def test_ply_quads_with_face_data(tmp_path):
    V, Q = grid(4, quads=True)
    label = np.arange(len(Q), dtype=np.float64)
    path = tmp_path / "q.ply"
    write_mesh(path, V, Q, face_data={"label": label})
    _, face = read_ply_properties(path, faces="quads")
    assert np.array_equal(face["label"], label)
    with pytest.warns(PolygonTriangulatedWarning):
        _, F = read_mesh(path)
    _, face = read_ply_properties(path)  # aligned with the triangles: each value twice
    assert len(face["label"]) == len(F) and np.array_equal(face["label"], np.repeat(label, 2))


def test_unwritable_requests_fail_before_any_work(tmp_path, monkeypatch):
    V, Q = grid(3, quads=True)
    with pytest.raises(MeshFormatError, match=r"STL files hold faces of 3 vertices, not 4"):
        write_mesh(tmp_path / "q.stl", V, Q)
    with pytest.raises(MeshFormatError, match=r"cannot write '\.xyz' files"):
        check_writable(tmp_path / "q.xyz", face_size=4)
    with pytest.raises(MeshFormatError, match="OBJ files cannot hold"):
        check_writable(tmp_path / "q.OBJ", vertex_data=True)
    with pytest.raises(MeshFormatError, match="STL files cannot hold"):
        write_mesh(tmp_path / "t.stl", *grid(3), face_data={"a": np.zeros(8)})
    assert list(tmp_path.iterdir()) == []  # nothing written, not even a temporary file
    assert check_writable(tmp_path / "q.PLY", 4, vertex_data=True) is FORMATS[".ply"]
    import fvf.io.formats.vtk as vtk

    monkeypatch.setattr(vtk, "_have", lambda module: False)
    with pytest.raises(MissingExtraError, match=r"\.vtp files needs PyVista"):
        check_writable(tmp_path / "q.vtp", face_size=4)
    with pytest.raises(MissingExtraError, match="meshio or PyVista"):
        write_mesh(tmp_path / "q.vtu", V, Q)
    assert list(tmp_path.iterdir()) == []


def test_fvf_quad_checks_the_output_format_before_the_pipeline(tmp_path, capsys):
    from fvf.cli.main import main

    src = tmp_path / "torus.obj"
    write_mesh(src, fvf.torus(24, 12).vertices, fvf.torus(24, 12).faces)
    for out in ("q.xyz", "q.stl"):
        assert main(["quad", str(src), "--faces", "60", "-o", str(tmp_path / out)]) == 2
        err = capsys.readouterr().err
        assert "MeshFormatError" in err and "fvf quad:" not in err  # no stage started


# ---------------------------------------------------------------------------- registry
def test_registry_lists_the_formats():
    # VTK files are read too now (through PyVista or meshio), legacy .vtk as well
    suffixes = (".obj", ".off", ".ply", ".stl", ".vtu", ".vtp", ".vtk", ".glb", ".gltf", ".3mf")
    assert readable_suffixes() == suffixes
    assert set(writable_suffixes()) == set(suffixes)
    assert fvf.io.meshfile.SUFFIXES == readable_suffixes()
    assert fvf.io.meshfile.VTK_SUFFIXES == (".vtu", ".vtp")
    with pytest.raises(MeshReadError, match=r"unsupported mesh file suffix '\.fbx'"):
        read_mesh("mesh.fbx")


def _read_back(path, fmt):
    """(V, F, vertex data, face data) of a written file, by fvf or (VTK) meshio/PyVista."""
    if "VTK" in fmt.name:  # read by the peers here; fvf's own reading: test_nfield_object
        if path.suffix == ".vtu":
            meshio = pytest.importorskip("meshio")
            m = meshio.read(path)
            F = m.cells[0].data
            return m.points, F, dict(m.point_data), {k: v[0] for k, v in m.cell_data.items()}
        pv = pytest.importorskip("pyvista")
        poly = pv.read(path)
        F = poly.faces.reshape(poly.n_cells, -1)[:, 1:]
        return poly.points, F, dict(poly.point_data), dict(poly.cell_data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", VerticesWeldedWarning)  # tested above
        V, F = read_mesh(path, faces="any")
    vdata, fdata = read_ply_properties(path, faces="any") if fmt.vertex_data else ({}, {})
    for data in (vdata, fdata):  # PLY: a 3-vector v is the properties vx vy vz
        for name in [n[:-1] for n in data if n.endswith("x") and len(n) > 1]:
            data[name] = np.column_stack([data.pop(name + c) for c in "xyz"])
    return V, F, vdata, fdata


@pytest.mark.parametrize("size", [3, 4])
@pytest.mark.parametrize("suffix", sorted(FORMATS))
def test_every_registered_format_round_trips(tmp_path, suffix, size):
    fmt = FORMATS[suffix]
    V, F = grid(4, quads=size == 4)
    rng = np.random.default_rng(3)
    vdata = {"f": rng.standard_normal(len(V)), "v": rng.standard_normal((len(V), 3))}
    fdata = {"g": rng.standard_normal(len(F)), "w": rng.standard_normal((len(F), 3))}
    vdata, fdata = (vdata if fmt.vertex_data else {}), (fdata if fmt.face_data else {})
    path = tmp_path / f"m{suffix}"
    if size not in fmt.face_sizes:
        with pytest.raises(MeshFormatError):
            write_mesh(path, V, F, vertex_data=vdata, face_data=fdata)
        assert not path.exists()
        return
    try:
        check_writable(path, size)
    except MissingExtraError:
        pytest.skip(f"{suffix} needs an optional package")
    write_mesh(path, V, F, vertex_data=vdata, face_data=fdata)
    V2, F2, vdata2, fdata2 = _read_back(path, fmt)
    assert F2.shape == F.shape
    if fmt.polygons:  # stored as given
        assert np.array_equal(V2, V) and np.array_equal(F2, F)
    else:  # a soup welded again: same corners, vertices renumbered
        assert len(V2) == len(V) and np.array_equal(V2[F2], V[F])
    assert set(vdata2) == set(vdata) and set(fdata2) == set(fdata)
    for name, a in [*vdata.items(), *fdata.items()]:
        np.testing.assert_array_equal((vdata2 | fdata2)[name], a)


def test_batch_finds_stl_files(tmp_path):
    from fvf.batch.inputs import find_meshes

    (tmp_path / "cube.STL").write_bytes(stl_binary(CUBE_V[CUBE_F]))
    write_mesh(tmp_path / "grid.obj", *grid(3))
    (tmp_path / "notes.txt").write_text("not a mesh")
    assert [p.name for p in find_meshes([tmp_path])] == ["cube.STL", "grid.obj"]


# ---------------------------------------------------------------------------- fuzzing
STL_BASES = {
    "ascii.stl": stl_ascii(CUBE_V[CUBE_F[:4]]).encode(),
    "binary.stl": stl_binary(CUBE_V[CUBE_F[:4]], header=b"solid binary"),
}


@pytest.mark.parametrize("name", list(STL_BASES))
@settings(derandomize=True, max_examples=200, deadline=None)
@given(mutations=st.lists(MUTATION, min_size=1, max_size=6))
def test_fuzz_read_stl(tmp_path_factory, name, mutations):
    """Mutated STL files either load as a valid mesh or raise MeshReadError."""
    path = tmp_path_factory.getbasetemp() / name
    path.write_bytes(mutated(STL_BASES[name], mutations))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", VerticesWeldedWarning)
        try:
            V, F = read_mesh(path)
        except MeshReadError as exc:
            assert str(path) in str(exc)
            return
    check_mesh(V, F)
