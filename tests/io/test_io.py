"""Tests of fvf.io: reading OBJ/OFF/PLY exactly as stored, writing, errors, fuzzing."""

from __future__ import annotations

import struct
import time
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fvf
from conftest import shared_mesh_path
from fvf.errors import FvfError, MeshIndexError, MeshReadError, MeshShapeError
from fvf.io import meshfile as io
from fvf.io.meshfile import PolygonTriangulatedWarning, read_mesh, write_mesh

# name -> (#vertices in the file, #referenced vertices, #faces), from MANIFEST.md
MANIFEST = {
    "decimated-knight.off": (502, 502, 1000),
    "woody.obj": (694, 694, 1267),
    "spot.obj": (2930, 2930, 5856),
    "bunny-lowres.off": (3485, 3485, 6966),
    "fertility.off": (4494, 4494, 9000),
    "bob_tri.obj": (5344, 5344, 10688),
    "3holes.off": (3596, 3596, 7200),
    "rocker-arm.obj": (10044, 10044, 20088),
    "camelhead.off": (11381, 11381, 22704),
    "stanford-bunny.obj": (34834 + 1113, 34834, 69451),
    "armadillo.obj": (43243, 43243, 86482),
    "nefertiti.obj": (49971, 49971, 99938),
    "armadillo_loop1.ply": (172966, 172966, 345928),
    "armadillo_750k.ply": (375002, 375002, 750000),
    "sphere_s2.off": (2562, 2562, 5120),
    "faust_r_tr_reg_001.off": (5000, 5000, 9996),
    "lion-00.off": (5000, 5000, 9996),
}
VS_IGL = [
    "spot.obj",
    "bob_tri.obj",
    "stanford-bunny.obj",
    "woody.obj",
    "camelhead.off",
    "decimated-knight.off",
    "lion-00.off",
    "faust_r_tr_reg_001.off",
    "armadillo_loop1.ply",
    "armadillo_750k.ply",
]


def check_mesh(V, F):
    """The output contract of read_mesh."""
    assert V.dtype == np.float64 and V.ndim == 2 and V.shape[1] == 3
    assert V.flags.c_contiguous
    assert F.dtype == np.int64 and F.ndim == 2 and F.shape[1] == 3 and len(F) > 0
    assert F.min() >= 0 and F.max() < len(V)


def read_text(tmp_path, name, text):
    path = tmp_path / name
    path.write_bytes(text.encode() if isinstance(text, str) else text)
    return read_mesh(path)


def test_public_api():
    assert io.__all__[:2] == ["read_mesh", "write_mesh"]
    assert {"read_quad_mesh", "write_quad_mesh", "write_uv_mesh"} <= set(io.__all__)
    assert all(getattr(io, name) is getattr(fvf.io, name) for name in io.__all__)
    assert fvf.PolygonTriangulatedWarning is io.PolygonTriangulatedWarning
    assert issubclass(MeshReadError, ValueError)


# ---------------------------------------------------------------- shared meshes
@pytest.mark.parametrize("name", sorted(MANIFEST))
def test_shared_mesh(name):
    """MANIFEST counts (unreferenced vertices kept), and the same arrays as libigl."""
    n, referenced, m = MANIFEST[name]
    path = shared_mesh_path(name)
    V, F = read_mesh(path)
    check_mesh(V, F)
    assert V.shape == (n, 3) and F.shape == (m, 3)
    assert np.count_nonzero(np.bincount(F.ravel(), minlength=n)) == referenced
    if name in VS_IGL:
        igl = pytest.importorskip("igl")
        V_igl, F_igl = igl.read_triangle_mesh(str(path))
        np.testing.assert_array_equal(V, V_igl)
        np.testing.assert_array_equal(F, F_igl)


def test_large_binary_ply_is_fast():
    path = shared_mesh_path("armadillo_750k.ply")
    best = np.inf
    for _ in range(2):
        start = time.perf_counter()
        read_mesh(path)
        best = min(best, time.perf_counter() - start)
    assert best < 1.0, f"reading 750k binary faces took {best:.2f} s"


# ---------------------------------------------------------------- round trips
@pytest.mark.parametrize("suffix", [".obj", ".off", ".ply", ".OBJ", ".Off", ".PLY"])
def test_round_trip_is_exact(tmp_path, rng, suffix):
    V = rng.standard_normal((50, 3)) * 10.0 ** rng.integers(-300, 300, (50, 1))
    V[0] = [1 / 3, -0.0, 5e-324]
    V[1] = [np.pi, -1e308, 2.0**-1074]
    F = rng.integers(0, 50, (80, 3))
    path = tmp_path / f"mesh{suffix}"
    write_mesh(path, V, F)
    V2, F2 = read_mesh(str(path))
    check_mesh(V2, F2)
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(F2, F)
    assert np.array_equal(np.signbit(V2), np.signbit(V))


def test_write_mesh_rejects_bad_input(tmp_path):
    V, F = np.zeros((3, 3)), np.array([[0, 1, 2]])
    with pytest.raises(MeshShapeError, match="vertices"):
        write_mesh(tmp_path / "a.obj", V[:, :2], F)
    with pytest.raises(MeshShapeError, match="faces"):
        write_mesh(tmp_path / "a.obj", V, F.astype(float))
    with pytest.raises(MeshIndexError):
        write_mesh(tmp_path / "a.ply", V, F + 1)
    with pytest.raises(FvfError, match=r"\.obj"):
        write_mesh(tmp_path / "a.3ds", V, F)  # not a format fvf writes


# ---------------------------------------------------------------- OBJ
SQUARE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [5, 5, 5]], dtype=float)


def test_obj_statements_and_index_forms(tmp_path):
    text = (
        "# comment line\r\n"
        "mtllib x.mtl\r\n"
        "o object\r\n"
        "\r\n"
        "v 0 0 0\r\n"
        "v   1.0\t0 0  1.0\r\n"  # w coordinate
        "vt 0.5 0.5\r\n"
        "vn 0 0 1\r\n"
        "  v 1 1 0 0.1 0.2 0.3\r\n"  # vertex colors, leading whitespace
        "v 0 1 0 # trailing comment\r\n"
        "g group\r\ns 1\r\nusemtl m\r\n"
        "f 1/1/1 2/1/1 3/1/1\r\n"
        "f 1//1 3//1 4//1\r\n"
        "f 2/1 3/1 1/1\r\n"
        "f -4 -2 -1\r\n"
        "l 1 2\r\n"
        "v 5 5 5\r\n"  # unreferenced, after the faces
        "f\t1  2   4 # comment"
    )
    V, F = read_text(tmp_path, "m.obj", text)
    check_mesh(V, F)
    np.testing.assert_array_equal(V, SQUARE_V)
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 3], [1, 2, 0], [0, 2, 3], [0, 1, 3]])


def test_obj_keeps_vertices_at_uv_seams(tmp_path):
    # two faces share vertex positions but not UVs: vertices must not be split
    text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvt 9 9\n"
    text += "f 1/1 2/2 3/3\nf 2/5 4/4 3/5\n"
    V, F = read_text(tmp_path, "seam.obj", text)
    assert V.shape == (4, 3)
    np.testing.assert_array_equal(F, [[0, 1, 2], [1, 3, 2]])


def test_obj_polygons_are_fan_triangulated_with_one_warning(tmp_path):
    text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\nf 1 2 3 4\nf 1 2 3\nf 1 2 3 5 4\n"
    with pytest.warns(PolygonTriangulatedWarning, match="2 polygons") as record:
        V, F = read_text(tmp_path, "quad.obj", text)
    assert len(record) == 1
    check_mesh(V, F)
    np.testing.assert_array_equal(
        F, [[0, 1, 2], [0, 2, 3], [0, 1, 2], [0, 1, 2], [0, 2, 4], [0, 4, 3]]
    )


@pytest.mark.parametrize(
    ("text", "parts"),
    [
        ("v 0 0 0\nv 1 0 0\nv 0 1 x\nf 1 2 3\n", ["line 3", "'x'", "number"]),
        ("v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", ["line 2", "x y z"]),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 10\n", ["line 5", "10", "3 vertices"]),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", ["line 4", "index 0", "1..3"]),
        ("v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n", ["line 3", "-3"]),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3.5\n", ["line 4", "'3.5'", "integer"]),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 /2 3\n", ["line 4", "''"]),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n", ["line 5", "2 vertices"]),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999999\n", ["line 4"]),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n", ["no faces"]),
        ("# only a comment\n", ["no faces"]),
    ],
)
def test_obj_errors(tmp_path, text, parts):
    with pytest.raises(MeshReadError) as info:
        read_text(tmp_path, "bad.obj", text)
    message = str(info.value)
    assert "bad.obj" in message
    for part in parts:
        assert part in message


# ---------------------------------------------------------------- OFF
def test_off_variants(tmp_path):
    plain = "OFF\n# comment\n\n4 2 0\n0 0 0\n1 0 0\n1 1 0 # c\n0 1 0\n3 0 1 2\n3 0 2 3\n"
    inline = "OFF 4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2 255 0 0\n3 0 2 3 0 255 0\n"
    colored = (
        "COFF\r\n4 2 5\r\n0 0 0 1 0 0 1\r\n1 0 0 1 0 0 1\r\n# c\r\n1 1 0 0 1 0 1\r\n"
        "0 1 0 0 0 1 1\r\n3 0 1 2\r\n3  0 2 3\r\n"
    )
    normals = "NOFF\n4 2 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n3 0 2 3\n"
    for k, text in enumerate([plain, inline, colored, normals]):
        V, F = read_text(tmp_path, f"m{k}.off", text)
        check_mesh(V, F)
        np.testing.assert_array_equal(V, SQUARE_V[:4])
        np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 3]])


def test_off_quads(tmp_path):
    text = "OFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n5 5 5\n4 0 1 2 3\n3 0 1 4\n"
    with pytest.warns(PolygonTriangulatedWarning, match="1 polygons"):
        V, F = read_text(tmp_path, "q.off", text)
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 3], [0, 1, 4]])


@pytest.mark.parametrize(
    ("text", "parts"),
    [
        ("OFF\n0.5 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", ["line 2", "counts", "0.5 0 0"]),
        ("OFF\n", ["counts"]),
        ("OFF\n3 1 0\n0 0 0\n1 0 0\n", ["promises 3 vertices", "truncated"]),
        ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", ["line 6", "index 3", "0..2"]),
        ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", ["line 6", "4 vertices"]),
        ("OFF\n3 1 0\n0 0 0\n1 e 0\n0 1 0\n3 0 1 2\n", ["line 4", "'e'"]),
        ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\nx 0 1 2\n", ["line 6", "'x'"]),
        ("PLY\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", ["line 1", "OFF header"]),
        ("OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", ["no faces"]),
    ],
)
def test_off_errors(tmp_path, text, parts):
    with pytest.raises(MeshReadError) as info:
        read_text(tmp_path, "bad.off", text)
    for part in ["bad.off", *parts]:
        assert part in str(info.value)


# ---------------------------------------------------------------- PLY
ASCII_PLY = """ply
format ascii 1.0
comment made by hand
obj_info nothing
element material 2
property uchar red
property list uchar int ids
element vertex 4
property float x
property float nx
property double y
property int z
property uchar red
element face 2
property uchar flags
property list uchar int vertex_indices
element edge 1
property int vertex1
property int vertex2
end_header
255 3 1 2 3
0 0 0

0 9 0 0 1
1 9 0 0 2
1 9 1 0 3
0 9 1 0 4
7 3 0 1 2
7 3 0 2 3
0 1
"""


def test_ascii_ply(tmp_path):
    V, F = read_text(tmp_path, "a.ply", ASCII_PLY)
    check_mesh(V, F)
    np.testing.assert_array_equal(V, SQUARE_V[:4])
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 3]])
    V2, F2 = read_text(tmp_path, "b.ply", ASCII_PLY.replace("\n", "\r\n"))
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(F2, F)


def test_ascii_ply_vertex_index_and_polygons(tmp_path):
    text = (
        "ply\nformat ascii 1.0\nelement vertex 5\nproperty double x\nproperty double y\n"
        "property double z\nelement face 2\nproperty list int uint vertex_index\nend_header\n"
        "0 0 0\n1 0 0\n1 1 0\n0 1 0\n5 5 5\n4 0 1 2 3\n3 4 0 1\n"
    )
    with pytest.warns(PolygonTriangulatedWarning, match="1 polygons"):
        V, F = read_text(tmp_path, "p.ply", text)
    np.testing.assert_array_equal(V, SQUARE_V)
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 3], [4, 0, 1]])


def binary_ply(order, faces, count_type="uchar", index_type="int"):
    """A binary PLY with odd vertex properties and extra elements before and after faces."""
    e = order
    fmt = {"<": "binary_little_endian", ">": "binary_big_endian"}[order]
    ctype = {"uchar": "B", "int": "i", "ushort": "H"}[count_type]
    itype = {"int": "i", "uint": "I", "short": "h"}[index_type]
    header = (
        f"ply\nformat {fmt} 1.0\ncomment binary test\n"
        "element material 2\nproperty uchar red\nproperty list uchar float coeffs\n"
        "element vertex 5\nproperty float x\nproperty float nx\nproperty double y\n"
        "property short z\nproperty uchar red\n"
        f"element face {len(faces)}\nproperty uchar flags\n"
        f"property list {count_type} {index_type} vertex_indices\nproperty float quality\n"
        "element edge 2\nproperty int vertex1\nproperty list uchar int more\nend_header\n"
    )
    body = struct.pack(f"{e}BB2fBB", 1, 2, 0.5, 0.25, 2, 0)
    for x, y, z in SQUARE_V:
        body += struct.pack(f"{e}ffdhB", x, -1.0, y, int(z), 200)
    for face in faces:
        body += struct.pack(f"{e}B{ctype}{len(face)}{itype}f", 9, len(face), *face, 0.5)
    body += struct.pack(f"{e}iB2i", 0, 2, 1, 2) + struct.pack(f"{e}iB", 3, 0)
    return header.encode() + body


@pytest.mark.parametrize("order", ["<", ">"])
@pytest.mark.parametrize(
    ("count_type", "index_type"), [("uchar", "int"), ("int", "uint"), ("ushort", "short")]
)
def test_binary_ply(tmp_path, order, count_type, index_type):
    data = binary_ply(order, [[0, 1, 2], [0, 2, 3], [4, 0, 1]], count_type, index_type)
    V, F = read_text(tmp_path, "b.ply", data)
    check_mesh(V, F)
    np.testing.assert_array_equal(V, SQUARE_V)
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 3], [4, 0, 1]])


@pytest.mark.parametrize("order", ["<", ">"])
def test_binary_ply_mixed_polygons(tmp_path, order):
    data = binary_ply(order, [[0, 1, 2], [0, 1, 2, 3], [4, 0, 1], [4, 3, 2, 1, 0]])
    with pytest.warns(PolygonTriangulatedWarning, match="2 polygons") as record:
        V, F = read_text(tmp_path, "mixed.ply", data)
    assert len(record) == 1
    np.testing.assert_array_equal(V, SQUARE_V)
    expected = [[0, 1, 2], [0, 1, 2], [0, 2, 3], [4, 0, 1], [4, 3, 2], [4, 2, 1], [4, 1, 0]]
    np.testing.assert_array_equal(F, expected)


def test_binary_ply_truncated(tmp_path):
    data = binary_ply("<", [[0, 1, 2], [0, 2, 3]])
    for cut in [len(data) - 30, len(data) - 12, data.index(b"end_header") + 40]:
        with pytest.raises(MeshReadError, match="truncated"):
            read_text(tmp_path, "t.ply", data[:cut])
    mixed = binary_ply("<", [[0, 1, 2, 3], [0, 2, 3]])
    with pytest.raises(MeshReadError, match=r"ends early.*'face'"):
        read_text(tmp_path, "t.ply", mixed[: mixed.index(b"end_header") + 130])


PLY_HEAD = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
PLY_HEAD += "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
PLY_BODY = "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"


@pytest.mark.parametrize(
    ("data", "parts"),
    [
        (PLY_HEAD.replace("ascii", "binary_middle_endian") + PLY_BODY, ["line 2", "format"]),
        (PLY_HEAD.replace("vertex 3", "point 3") + PLY_BODY, ["no 'vertex' element"]),
        (PLY_HEAD.replace("float z", "float w") + PLY_BODY, ["x, y and z"]),
        (PLY_HEAD.replace("face 1", "face 0") + PLY_BODY[:-8], ["no faces"]),
        (PLY_HEAD.replace("vertex_indices", "corners") + PLY_BODY, ["no 'face' element"]),
        (PLY_HEAD.replace("float y", "flaot y") + PLY_BODY, ["line 5", "'property flaot y'"]),
        (PLY_HEAD.replace("uchar int", "float int") + PLY_BODY, ["line 8"]),
        (PLY_HEAD.replace("ply", "plx", 1) + PLY_BODY, ["line 1", "'ply'"]),
        (PLY_HEAD.replace("format ascii 1.0\n", "") + PLY_BODY, ["no 'format' line"]),
        (PLY_HEAD, ["end_header"]),
        (PLY_HEAD + PLY_BODY.replace("3 0 1 2", "3 0 1 3"), ["line 13", "face 0", "index 3"]),
        (PLY_HEAD + PLY_BODY.replace("3 0 1 2", "3 0 1"), ["line 13", "3 values"]),
        (PLY_HEAD + PLY_BODY.replace("3 0 1 2", "-3 0 1"), ["line 13", "non-negative"]),
        (PLY_HEAD + PLY_BODY.replace("1 0 0", "1 0"), ["line 11", "2 values"]),
        (PLY_HEAD + PLY_BODY.replace("1 0 0", "1 zero 0"), ["line 11", "'zero'"]),
        (PLY_HEAD + PLY_BODY.replace("3 0 1 2\n", ""), ["ends after 0 of the 1 'face'"]),
    ],
)
def test_ply_errors(tmp_path, data, parts):
    with pytest.raises(MeshReadError) as info:
        read_text(tmp_path, "bad.ply", data)
    for part in ["bad.ply", *parts]:
        assert part in str(info.value)


def test_binary_ply_index_out_of_range(tmp_path):
    data = binary_ply(">", [[0, 1, 2], [0, 7, 3]])
    with pytest.raises(MeshReadError, match=r"face 1 .*index 7.*0\.\.4"):
        read_text(tmp_path, "r.ply", data)


# ---------------------------------------------------------------- generic errors
@pytest.mark.parametrize("suffix", [".obj", ".off", ".ply"])
def test_empty_file(tmp_path, suffix):
    with pytest.raises(MeshReadError, match="empty"):
        read_text(tmp_path, f"empty{suffix}", " \n\n")


def test_unsupported_suffix_and_missing_file(tmp_path):
    with pytest.raises(MeshReadError, match=r"'\.3ds'.*\.obj, \.off, \.ply"):
        read_text(tmp_path, "m.3ds", "solid\n")
    with pytest.raises(MeshReadError, match="suffix"):
        read_text(tmp_path, "noext", "v 0 0 0\n")
    with pytest.raises(FileNotFoundError):
        read_mesh(tmp_path / "missing.obj")


# ---------------------------------------------------------------- fuzzing
FUZZ_BASES = {
    "fuzz.obj": b"# tri\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nv 0 1 0\nf 1/1 2/1 3/1\nf -4 -2 -1\n",
    "fuzz.off": b"OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n4 0 2 3 1\n",
    "ascii.ply": (PLY_HEAD + PLY_BODY).encode(),
    "binary.PLY": binary_ply("<", [[0, 1, 2], [0, 2, 3, 4]]),
}
MUTATION = st.tuples(
    st.sampled_from(["flip", "delete", "insert"]),
    st.integers(0, 10**6),
    st.one_of(st.integers(0, 255), st.sampled_from(list(b"-0123456789./ \n#eEfv"))),
)


def mutated(base: bytes, mutations) -> bytes:
    """``base`` after the (op, where, byte) mutations drawn from MUTATION, in order."""
    data = bytearray(base)
    for op, where, byte in mutations:
        k = where % (len(data) + 1)
        if op == "insert":
            data.insert(k, byte)
        elif data and op == "delete":
            del data[k % len(data)]
        elif data:
            data[k % len(data)] = byte
    return bytes(data)


@pytest.fixture(scope="module")
def fuzz_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


@pytest.mark.parametrize("name", list(FUZZ_BASES))
@settings(derandomize=True, max_examples=200, deadline=None)
@given(mutations=st.lists(MUTATION, min_size=1, max_size=6))
def test_fuzz_read_mesh(fuzz_dir, name, mutations):
    """Mutated files either parse to a valid mesh or raise MeshReadError, nothing else."""
    data = mutated(FUZZ_BASES[name], mutations)
    path = fuzz_dir / name
    path.write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PolygonTriangulatedWarning)
        try:
            V, F = read_mesh(path)
        except MeshReadError as exc:
            assert str(path) in str(exc)
            return
    check_mesh(V, F)


@pytest.mark.parametrize("name", list(FUZZ_BASES))
@settings(derandomize=True, max_examples=100, deadline=None)
@given(mutations=st.lists(MUTATION, min_size=1, max_size=2))
def test_fuzzed_files_that_load_go_through_report_and_repair(fuzz_dir, name, mutations):
    """What loads from a mutated file is reported and repaired, or a typed error says why.

    The path of a user's file: read_mesh, then ``fvf info`` (mesh_report, never raises) and
    repair_mesh (an FvfError at worst), then TriMesh on the result (an FvfError at worst).
    tests/io/fuzz_readers.py runs the same contract coverage-guided under atheris.
    """
    from fvf import TriMesh
    from fvf.mesh.diagnostics import mesh_report
    from fvf.mesh.repair import repair_mesh

    data = mutated(FUZZ_BASES[name], mutations)
    path = fuzz_dir / f"r_{name}"
    path.write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PolygonTriangulatedWarning)
        try:
            V, F = read_mesh(path)
        except MeshReadError:
            return
    report = mesh_report(V, F)
    assert isinstance(report["ok"], bool) and isinstance(report["problems"], list)
    try:
        fixed = repair_mesh(V, F)
        TriMesh(fixed.vertices, fixed.faces)
    except FvfError:  # only when something needed repair (welding can expose problems)
        assert not report["ok"] or report.get("hints")


def test_ply_properties_named_as_reserved_keys_or_on_both_elements_are_refused(tmp_path):
    """A vertex property ``t`` was read as the flow's times (162 of them, exit 0), and a
    vertex ``f`` hid a face ``f`` silently."""
    from fvf.io.datafile import read_data

    ball = fvf.icosphere(1)
    n, m = ball.n_vertices, ball.n_faces
    cases = {
        "t.ply": ({"t": np.arange(n, dtype=float)}, {}, r"vertex properties \['t'\]"),
        "both.ply": ({"f": np.zeros(n)}, {"f": np.ones(m)}, r"\['f'\] name both a vertex"),
    }
    for name, (vdata, fdata, said) in cases.items():
        path = tmp_path / name
        fvf.write_mesh(path, ball.vertices, ball.faces, vertex_data=vdata, face_data=fdata)
        with pytest.raises(fvf.DataFileError, match=said):
            read_data(path)
