"""Mesh files as other tools write them, read by fvf with the right geometry, and hostile
files refused with a typed error naming the file and the place.

Part 1 writes, by hand, the dialects real exporters produce (Blender-style OBJ with
``v/vt/vn`` and materials, MeshLab's ``NCOFF``, PLY in three encodings with normals,
colours and extra elements, STL with several solids or a binary header that begins with
``solid``). Part 2 has trimesh, meshio and pymeshlab write every format they support
(skipped when the library is missing). Part 3 is hostile input: each must be an
:class:`fvf.errors.FvfError`, never a raw Python or numpy exception, never silently wrong
geometry. Everything is generated in ``tmp_path``.
"""

from __future__ import annotations

import struct
import warnings

import numpy as np
import pytest

import fvf
from fvf.cli.main import EXIT_BAD_INPUT, EXIT_OK, main
from fvf.errors import (
    FvfError,
    MeshReadError,
    NonFiniteError,
    PolygonTriangulatedWarning,
    VerticesWeldedWarning,
)
from fvf.io import read_mesh

# ---------------------------------------------------------------------------- the cube
#: A unit cube: 8 vertices, 6 quads turning outwards (normals point out of the cube).
CUBE_V = np.array(
    [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
    dtype=np.float64,
)
CUBE_Q = np.array(
    [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [2, 3, 7, 6], [1, 2, 6, 5], [3, 0, 4, 7]]
)
#: Each quad (a, b, c, d) as the two triangles (a, b, c), (a, c, d).
CUBE_T = CUBE_Q[:, [0, 1, 2, 0, 2, 3]].reshape(-1, 3)


def signed_volume(V: np.ndarray, F: np.ndarray) -> float:
    """The volume a closed triangle mesh encloses, positive when its faces turn outwards."""
    T = V[F]
    return float(np.einsum("ij,ij->i", T[:, 0], np.cross(T[:, 1], T[:, 2])).sum() / 6)


def check_cube(V: np.ndarray, F: np.ndarray, *, exact: bool = True) -> None:
    """``(V, F)`` is the cube: its vertices in file order, consistently outward triangles."""
    assert V.dtype == np.float64 and F.dtype == np.int64 and F.shape[1] == 3
    if exact:
        np.testing.assert_array_equal(V, CUBE_V)
        np.testing.assert_array_equal(F, CUBE_T)
    assert len(F) == 12
    assert signed_volume(V, F) == pytest.approx(1.0)
    mesh = fvf.TriMesh(V, F)  # closed, manifold, consistently oriented
    assert mesh.n_vertices - mesh.n_edges + mesh.n_faces == 2


def read(path, **kwargs):
    """read_mesh, with the warnings that announce triangulation and welding let through."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PolygonTriangulatedWarning)
        warnings.simplefilter("ignore", VerticesWeldedWarning)
        return read_mesh(path, **kwargs)


def write(tmp_path, name: str, content: str | bytes):
    path = tmp_path / name
    path.write_bytes(content.encode() if isinstance(content, str) else content)
    return path


def obj_lines(v_format: str = "v {x} {y} {z}", f_format: str = "{a} {b} {c} {d}") -> list[str]:
    """The cube's ``v`` and ``f`` lines; ``f_format`` spells each face's 1-based corners."""
    v = [v_format.format(x=x, y=y, z=z) for x, y, z in CUBE_V.tolist()]
    f = ["f " + f_format.format(**dict(zip("abcd", q + 1, strict=True))) for q in CUBE_Q]
    return v + f


# ---------------------------------------------------------------------------- part 1: OBJ
BLENDER_OBJ = "\n".join(
    [
        "# Blender 4.1.1",
        "# www.blender.org",
        "mtllib cube.mtl",
        "o Cube",
        *obj_lines()[:8],
        "vn -0.0000 -0.0000 -1.0000",
        "vn -0.0000 -0.0000 1.0000",
        "vt 0.625000 0.500000",
        "vt 0.875000 0.500000",
        "s off",
        "usemtl Material",
        *obj_lines(f_format="{a}/1/1 {b}/2/1 {c}/1/2 {d}/2/2")[8:],
        "",
    ]
)

OBJ_DIALECTS = {
    "blender_v_vt_vn": BLENDER_OBJ,
    "v_double_slash_vn": "\n".join(obj_lines(f_format="{a}//1 {b}//1 {c}//1 {d}//1")) + "\n",
    "v_slash_vt": "vt 0 0\n" + "\n".join(obj_lines(f_format="{a}/1 {b}/1 {c}/1 {d}/1")),
    "negative_relative_indices": "\n".join(obj_lines()[:8])
    + "\n"
    + "".join("f " + " ".join(str(i - 8) for i in q) + "\n" for q in CUBE_Q),
    "vertex_colours": "\n".join(obj_lines("v {x} {y} {z} 0.8 0.1 0.1")) + "\n",
    "w_coordinate": "\n".join(obj_lines("v {x} {y} {z} 1.0")) + "\n",
    "groups_objects_smoothing": "\n".join(
        ["mtllib a.mtl b.mtl", "o Body", "g body side", *obj_lines()[:8], "s 1", "usemtl red"]
        + [*obj_lines()[8:11], "g top", "s off", "usemtl blue", *obj_lines()[11:], "l 1 2"]
    ),
    "crlf_bom_trailing_blanks_comments": "\ufeff# exported\r\n"
    + "\r\n".join(line + " \t# note" for line in obj_lines())
    + "   \r\n\r\n",
    "tabs_and_repeated_blanks": "\n".join(
        line.replace(" ", "\t  ") for line in obj_lines(f_format="{a}  {b}\t{c} {d}")
    ),
    "line_continuation": "\n".join(obj_lines()[:8])
    + "\n"
    + "".join(f"f {q[0] + 1} {q[1] + 1} \\\n  {q[2] + 1} {q[3] + 1}\n" for q in CUBE_Q),
    "continuation_crlf_and_vertex": "v 0 0 \\\r\n 0\r\n" + "\r\n".join(obj_lines()[1:]) + "\r\n",
}


@pytest.mark.parametrize("name", list(OBJ_DIALECTS))
def test_obj_dialects_read_as_the_cube(tmp_path, name):
    with pytest.warns(PolygonTriangulatedWarning, match="6 polygons"):
        V, F = read_mesh(write(tmp_path, f"{name}.obj", OBJ_DIALECTS[name]))
    check_cube(V, F)


def test_obj_quads_as_stored_and_continued_line_numbers(tmp_path):
    V, Q = read_mesh(write(tmp_path, "q.obj", OBJ_DIALECTS["line_continuation"]), faces="quads")
    np.testing.assert_array_equal(Q, CUBE_Q)
    text = OBJ_DIALECTS["line_continuation"] + "f 1 2 \\\n 99\n"  # line 21 continues
    with pytest.raises(MeshReadError, match=r"bad\.obj: line 21: .* index 99"):
        read_mesh(write(tmp_path, "bad.obj", text))


def test_a_comment_or_path_ending_with_a_backslash_continues_nothing(tmp_path):
    """A Windows folder at the end of a comment or a ``mtllib`` line (``C:\\scans\\``)
    swallowed the next vertex: every vertex after it moved down one index, silently."""
    lines = obj_lines()
    text = "mtllib C:\\a\\b\\\n" + "\n".join(lines[:3] + ["# from C:\\Users\\me\\scans\\"])
    text += "\n" + "\n".join(lines[3:]) + "\nv 9 9 9\n"  # an extra vertex: no face needs it
    V, F = read_mesh(write(tmp_path, "win.obj", text), faces="quads")
    assert V.shape == (9, 3) and np.array_equal(V[-1], [9, 9, 9])
    np.testing.assert_array_equal(V[:8], CUBE_V)
    np.testing.assert_array_equal(F, CUBE_Q)


def test_off_lines_beyond_the_declared_counts_are_refused(tmp_path):
    """A header of 2 faces over 4 face lines: the last two were dropped unsaid (a sphere
    with holes, then repaired as such); now the reader names them."""
    text = "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 3 1\n3 0 2 3\n3 1 3 2\n"
    with pytest.raises(MeshReadError, match=r"line 9: 2 data lines follow the 4 vertices and 2"):
        read_mesh(write(tmp_path, "more.off", text))


# ---------------------------------------------------------------------------- polygons
def test_ngons_and_non_convex_polygons_come_back_unfolded(tmp_path):
    """Convex polygons keep their fans; a dart quad whose reflex corner is not v0 and an
    L-shaped hexagon starting at a corner that does not see the others are split so that
    every triangle turns the polygon's way and the areas add up."""
    dart = [(0, 0), (1, 1), (2, 0), (1, 3)]  # reflex corner: v1
    ell = [(2, 1), (1, 1), (1, 2), (0, 2), (0, 0), (2, 0)]  # v0 does not see v3
    hexagon = [(float(np.cos(a)), float(np.sin(a))) for a in np.arange(6) * np.pi / 3]
    text, faces, start = "", "", 1
    for ring in (dart, ell, hexagon):
        text += "".join(f"v {x!r} {y!r} 0\n" for x, y in ring)
        faces += "f " + " ".join(str(start + i) for i in range(len(ring))) + "\n"
        start += len(ring)
    with pytest.warns(PolygonTriangulatedWarning, match=r"3 polygons .* \(2 non-convex"):
        V, F = read_mesh(write(tmp_path, "polys.obj", text + faces))
    assert F.shape == (2 + 4 + 4, 3)
    T = V[F]
    cross = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])[:, 2] / 2
    assert (cross > 0).all()  # no triangle folds over
    assert cross[:2].sum() == pytest.approx(2.0) and cross[2:6].sum() == pytest.approx(3.0)
    np.testing.assert_array_equal(F[6:], [[10, 11, 12], [10, 12, 13], [10, 13, 14], [10, 14, 15]])
    assert np.isin(F[:2], [0, 1, 2, 3]).all() and np.isin(F[2:6], np.arange(4, 10)).all()


def _zigzag(k: int) -> np.ndarray:
    """A non-convex k-gon, k even: corners alternately on radii 1 and 0.8 (a gear's cap)."""
    a = np.arange(k) * 2 * np.pi / k
    r = np.where(np.arange(k) % 2 == 0, 1.0, 0.8)
    return np.column_stack([r * np.cos(a), r * np.sin(a), np.zeros(k)])


@pytest.mark.parametrize("earcut", [True, False], ids=["mapbox_earcut", "fallback"])
def test_a_gear_cap_is_ear_clipped_by_either_path(earcut, monkeypatch):
    """A zig-zag 400-gon (its fan folds): k - 2 triangles of its corners, each turning
    the polygon's way, areas adding up to the polygon's, with mapbox_earcut or without."""
    from fvf.io.formats.triangulate import triangulate

    if earcut:
        pytest.importorskip("mapbox_earcut")
    else:
        monkeypatch.setitem(__import__("sys").modules, "mapbox_earcut", None)
    P = _zigzag(400)
    F, n_split, n_resplit = triangulate(P, np.array([400]), np.arange(400))
    assert F.shape == (398, 3) and n_split == n_resplit == 1
    T = P[F]
    area = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])[:, 2] / 2
    shoelace = 0.5 * np.sum(P[:, 0] * np.roll(P[:, 1], -1) - np.roll(P[:, 0], -1) * P[:, 1])
    assert (area > 0).all() and area.sum() == pytest.approx(shoelace, rel=1e-12)


@pytest.mark.perf
def test_a_40000_corner_cap_reads_in_seconds_with_mapbox_earcut():
    """Extruded outlines put the whole outline in one polygon: a 40,000-corner zig-zag
    cap took 354 s by the Python ear clipping (restarting at corner 0 after each ear)."""
    import time

    pytest.importorskip("mapbox_earcut")
    from fvf.io.formats.triangulate import triangulate

    P = _zigzag(40_000)
    t = time.perf_counter()
    F, _, n_resplit = triangulate(P, np.array([40_000]), np.arange(40_000))
    assert time.perf_counter() - t < 5.0 and n_resplit == 1 and F.shape == (39_998, 3)


def test_triangulation_of_random_simple_polygons_never_folds():
    """Seeded star-shaped polygons (simple, slightly off their plane), each starting at a
    random corner: every triangle turns the polygon's way and the areas add up. Polygons
    with NaN, huge or repeated corners give k - 2 triangles of their own corners, silently."""
    from fvf.io.formats.triangulate import triangulate

    rng = np.random.default_rng(20261206)
    done = 0
    while done < 300:
        k = int(rng.integers(4, 12))
        angle = np.sort(rng.uniform(0, 2 * np.pi, k))
        if np.diff(np.r_[angle, angle[0] + 2 * np.pi]).max() > 0.95 * np.pi:
            continue  # the centre must see every corner, else the polygon may cross itself
        done += 1
        r = rng.uniform(0.1, 1, k)
        P = np.column_stack([r * np.cos(angle), r * np.sin(angle), 1e-9 * rng.normal(size=k)])
        P = np.roll(P, int(rng.integers(k)), axis=0)
        F, n_split, _ = triangulate(P, np.array([k]), np.arange(k))
        T = P[F]
        twice = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])[:, 2]
        x, y = P[:, 0], P[:, 1]
        assert n_split == 1 and (twice > -1e-12).all()
        assert twice.sum() / 2 == pytest.approx(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) / 2)
    for _ in range(300):
        n = int(rng.integers(3, 12))
        V = rng.normal(size=(n, 3)) * rng.choice([1.0, 1e-300, 1e300])
        V[rng.integers(n)] = rng.choice([np.nan, np.inf, 0.0])
        V[rng.integers(n)] = V[rng.integers(n)]
        counts = rng.integers(3, 9, size=int(rng.integers(1, 5)))
        flat = rng.integers(0, n, size=counts.sum())
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            F, _, _ = triangulate(V, counts, flat)
        owner = np.repeat(np.arange(counts.size), counts - 2)
        corners = np.split(flat, np.cumsum(counts)[:-1])
        assert F.shape == (counts.sum() - 2 * counts.size, 3)
        assert all(np.isin(F[owner == p], corners[p]).all() for p in range(counts.size))


# ---------------------------------------------------------------------------- part 1: OFF
def off_text(head: str, vertex_tail: str = "", face_tail: str = "", counts_inline=False) -> str:
    counts = "8 6 12"
    lines = [f"{head} {counts}" if counts_inline else head, "# comment line"]
    lines += [] if counts_inline else [counts + "  # vertices faces edges"]
    lines += [f"{x:g} {y:g} {z:g}{vertex_tail}" for x, y, z in CUBE_V.tolist()]
    lines += ["4 " + " ".join(map(str, q)) + face_tail for q in CUBE_Q]
    return "\n".join(lines) + "\n"


OFF_DIALECTS = {
    "plain": off_text("OFF"),
    "counts_on_the_OFF_line": off_text("OFF", counts_inline=True),
    "COFF_rgba_vertices": off_text("COFF", vertex_tail=" 255 128 0 255"),
    "NOFF_normals": off_text("NOFF", vertex_tail=" 0.577 0.577 0.577"),
    "NCOFF_meshlab": off_text("NCOFF", vertex_tail=" 255 255 255 255 0 0 1.5708 "),
    "CNOFF": off_text("CNOFF", vertex_tail=" 0.5 0.5 0.5 1 0 0 1"),
    "face_colours_int": off_text("OFF", face_tail=" 255 0 0"),
    "face_colours_float_rgba": off_text("OFF", face_tail=" 0.1 0.2 0.3 1.0"),
    "crlf_and_bom": "\ufeff" + off_text("OFF").replace("\n", "\r\n"),
}


@pytest.mark.parametrize("name", list(OFF_DIALECTS))
def test_off_dialects_read_as_the_cube(tmp_path, name):
    check_cube(*read(write(tmp_path, f"{name}.off", OFF_DIALECTS[name])))


# ---------------------------------------------------------------------------- part 1: PLY
def ply_bytes(fmt: str, count: str = "uchar", index: str = "int", name="vertex_indices"):
    """The cube as PLY with float xyz, float normals, uchar colours, a face flag after the
    list, and extra elements: ``material`` before the vertices, ``edge`` after the faces."""
    order = {"binary_little_endian": "<", "binary_big_endian": ">", "ascii": ""}[fmt]
    header = [
        "ply",
        f"format {fmt} 1.0",
        "comment exported by a scanner",
        "obj_info generated for the test",
        "element material 1",
        "property uchar ambient_red",
        "property float ambient_coeff",
        "element vertex 8",
        *[f"property float {c}" for c in ("x", "y", "z", "nx", "ny", "nz")],
        *[f"property uchar {c}" for c in ("red", "green", "blue", "alpha")],
        "element face 6",
        f"property list {count} {index} {name}",
        "property uchar flags",
        "element edge 2",
        "property int vertex1",
        "property int vertex2",
        "end_header",
    ]
    head = ("\n".join(header) + "\n").encode()
    normals = CUBE_V - 0.5
    if not order:
        rows = ["200 0.5"]
        rows += [
            " ".join(f"{x:g}" for x in (*p, *n)) + " 255 128 0 255"
            for p, n in zip(CUBE_V, normals, strict=True)
        ]
        rows += ["4 " + " ".join(map(str, q)) + " 7" for q in CUBE_Q] + ["0 1", "1 2"]
        return head + ("\n".join(rows) + "\n").encode()
    code = {"uchar": "u1", "int": "i4", "uint": "u4", "ushort": "u2", "uint8": "u1"}
    material = np.array([(200, 0.5)], dtype=[("r", "u1"), ("c", order + "f4")])
    vrec = np.zeros(8, dtype=[("p", order + "f4", (6,)), ("rgba", "u1", (4,))])
    vrec["p"] = np.column_stack([CUBE_V, normals])
    vrec["rgba"] = [255, 128, 0, 255]
    frec = np.zeros(
        6, dtype=[("k", order + code[count]), ("i", order + code[index], (4,)), ("f", "u1")]
    )
    frec["k"], frec["i"], frec["f"] = 4, CUBE_Q, 7
    edges = np.array([[0, 1], [1, 2]], dtype=order + "i4")
    return head + material.tobytes() + vrec.tobytes() + frec.tobytes() + edges.tobytes()


PLY_CASES = [
    (fmt, count, index, name)
    for fmt in ("ascii", "binary_little_endian", "binary_big_endian")
    for count, index, name in (
        ("uchar", "int", "vertex_indices"),
        ("uchar", "uint", "vertex_indices"),
        ("int", "int", "vertex_index"),
        ("uint8", "int", "vertex_index"),
        ("ushort", "uint", "vertex_indices"),
    )
]


@pytest.mark.parametrize(("fmt", "count", "index", "name"), PLY_CASES)
def test_ply_dialects_read_as_the_cube(tmp_path, fmt, count, index, name):
    path = write(tmp_path, "cube.ply", ply_bytes(fmt, count, index, name))
    check_cube(*read(path))
    vprops, fprops = fvf.io.read_ply_properties(path)
    assert list(vprops) == ["nx", "ny", "nz", "red", "green", "blue", "alpha"]
    np.testing.assert_array_equal(vprops["red"], np.full(8, 255.0))
    np.testing.assert_array_equal(fprops["flags"], np.full(12, 7.0))  # one per triangle


def test_mixed_polygon_binary_ply(tmp_path):
    """Triangles and quads in one binary face list (the record sizes vary)."""
    tris = CUBE_T[:4]
    faces = [*tris, *CUBE_Q[2:]]
    head = (
        b"ply\nformat binary_big_endian 1.0\nelement vertex 8\nproperty double x\n"
        b"property double y\nproperty double z\nelement face 8\n"
        b"property list uchar int vertex_indices\nproperty float quality\nend_header\n"
    )
    body = CUBE_V.astype(">f8").tobytes()
    body += b"".join(struct.pack(f">B{len(f)}if", len(f), *f, 1.0) for f in faces)
    V, F = read(write(tmp_path, "mixed.ply", head + body))
    check_cube(V, F)


# ---------------------------------------------------------------------------- part 1: STL
def stl_facets(T: np.ndarray) -> str:
    facet = "  facet normal 0 0 0\n    outer loop\n" + "      vertex {} {} {}\n" * 3
    facet += "    endloop\n  endfacet\n"
    return "".join(facet.format(*(f"{x:e}" for x in t.ravel())) for t in T)


def stl_binary(T: np.ndarray, header: bytes) -> bytes:
    rec = np.zeros(len(T), dtype=[("n", "<f4", (3,)), ("c", "<f4", (3, 3)), ("a", "<u2")])
    rec["c"] = T
    return header.ljust(80)[:80] + struct.pack("<I", len(T)) + rec.tobytes()


def test_stl_with_several_solids_and_a_zero_area_facet(tmp_path):
    T = CUBE_V[CUBE_T]
    text = "solid top\n" + stl_facets(T[:6]) + "endsolid top\n"
    text += "solid   \n" + stl_facets(T[6:]) + "endsolid\n"  # no name
    with pytest.warns(VerticesWeldedWarning, match="36 corners of 12 ascii STL facets"):
        V, F = read_mesh(write(tmp_path, "two.stl", text))
    check_cube(V, F, exact=False)
    zero = np.concatenate([T, T[:1, [0, 1, 1]]])  # a facet with a repeated corner
    with pytest.warns(VerticesWeldedWarning, match="1 facets now repeat a vertex"):
        V, F = read_mesh(write(tmp_path, "zero.stl", stl_binary(zero, b"binary")))
    assert F.shape == (13, 3) and np.array_equal(V[F], zero)


@pytest.mark.parametrize(
    "header", [b"solid", b"solid Cube exported by SolidWorks", b"solid\n", b"SOLID x"]
)
def test_binary_stl_whose_header_says_solid_is_binary_by_its_size(tmp_path, header):
    T = CUBE_V[CUBE_T]
    V, F = read(write(tmp_path, "cad.stl", stl_binary(T, header)))
    check_cube(V, F, exact=False)
    assert np.array_equal(V[F], T)


# ---------------------------------------------------------------------------- part 1: 3MF
def threemf(model: str, rels: bool = True, prefix: str = "") -> bytes:
    """A 3MF archive holding ``model`` as its 3D model part (as slicers write it)."""
    import io
    import zipfile

    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        z.writestr("[Content_Types].xml", "<Types/>")
        if rels:
            z.writestr(
                "_rels/.rels",
                '<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/'
                'relationships"><Relationship Target="/3D/3dmodel.model" Id="r0" '
                'Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>'
                "</Relationships>",
            )
        z.writestr("3D/3dmodel.model", model)
    return out.getvalue()


def _corrupt_deflate() -> bytes:
    """A 3MF archive whose compressed model part has its bytes flipped (zlib's error)."""
    import io
    import zipfile

    model = "<model><resources>" + cube_object(1) + "</resources></model>"
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("3D/3dmodel.model", model * 4)
    data = bytearray(out.getvalue())
    start = data.index(b"3dmodel.model") + len("3dmodel.model")  # the local header's name
    for i in range(start + 10, start + 60):
        data[i] ^= 0x5A
    return bytes(data)


def cube_object(oid: int, prefix: str = "", extra: str = "") -> str:
    p = prefix
    verts = "".join(f'<{p}vertex  y="{y:g}" x="{x:g}" z="{z:g}" />' for x, y, z in CUBE_V)
    tris = "".join(f"<{p}triangle v1='{a}' v2='{b}' v3='{c}' {extra}/>" for a, b, c in CUBE_T)
    return (
        f'<{p}object id="{oid}" type="model"><{p}mesh><{p}vertices>{verts}</{p}vertices>'
        f"<{p}triangles>{tris}</{p}triangles></{p}mesh></{p}object>"
    )


def test_3mf_as_slicers_write_it(tmp_path):
    """A namespace prefix, attributes in any order and quoting, triangle properties, and
    the cube placed twice: by a build item's transform (scaled 2, moved 10 in x) and as a
    component of another object (moved 5 in z) placed by an item without transform."""
    ns = 'xmlns:m="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"'
    model = (
        f'<?xml version="1.0"?><m:model unit="millimeter" {ns}><m:resources>'
        + cube_object(1, "m:", extra='pid="3" p1="0"')
        + '<m:object id="2" type="model"><m:components><m:component objectid="1" '
        'transform="1 0 0 0 1 0 0 0 1 0 0 5"/></m:components></m:object></m:resources>'
        '<m:build><m:item objectid="1" transform="2 0 0 0 2 0 0 0 2 10 0 0"/>'
        '<m:item objectid="2"/></m:build></m:model>'
    )
    V, F = read_mesh(write(tmp_path, "part.3mf", threemf(model)))
    assert F.shape == (24, 3) and V.shape == (16, 3)
    np.testing.assert_array_equal(V[:8], 2 * CUBE_V + [10, 0, 0])
    np.testing.assert_array_equal(V[8:], CUBE_V + [0, 0, 5])
    np.testing.assert_array_equal(F[:12], CUBE_T)
    np.testing.assert_array_equal(F[12:], CUBE_T + 8)
    assert signed_volume(V, F) == pytest.approx(8 + 1)
    # a comment, '>' in quoted values, a self-closing object: the same build
    odd = model.replace("<m:build>", '<m:build><!-- <m:item objectid="1"/> -->')
    odd = odd.replace('<m:item objectid="1" ', '<m:item partnumber="a>b" objectid="1" ')
    odd = odd.replace("<m:resources>", '<m:resources><m:object id="9" name="x>y"/>')
    V3, F3 = read_mesh(write(tmp_path, "odd.3mf", threemf(odd)))
    np.testing.assert_array_equal(V3, V)
    np.testing.assert_array_equal(F3, F)
    # without _rels/.rels: the archive's one .model file
    V2, F2 = read_mesh(write(tmp_path, "norels.3mf", threemf(model, rels=False)))
    np.testing.assert_array_equal(V2, V)


def test_3mf_round_trip_and_the_quad_command(tmp_path):
    s = fvf.torus(16, 8)
    path = tmp_path / "torus.3mf"
    fvf.write_mesh(path, s.vertices, s.faces)
    V, F = read_mesh(path)
    assert np.array_equal(V, s.vertices) and np.array_equal(F, s.faces)
    out = tmp_path / "q.obj"
    assert main(["quad", str(path), "--faces", "100", "-o", str(out)]) == EXIT_OK


@pytest.mark.parametrize(
    ("content", "said"),
    [
        (b"not a zip", "zip archive"),
        (threemf("<model/>")[:-30], "zip archive"),
        (_corrupt_deflate(), "zip archive"),
        (
            '<model><resources><object id="1"><mesh><vertices><vertex x="nan" y="0" z="0"/>'
            '<vertex x="1" y="0" z="0"/><vertex x="0" y="1" z="0"/></vertices><triangles>'
            '<triangle v1="0" v2="1" v3="2"/></triangles></mesh></object></resources>'
            '<build><item objectid="1"/></build></model>',
            "not a finite number",
        ),
        ("<model><resources>" + cube_object(1) + "</resources><build/></model>", "places no"),
        (
            '<model><resources><object id="1"><mesh><vertices><vertex x="0" y="0"/>'
            "</vertices><triangles/></mesh></object></resources>"
            '<build><item objectid="1"/></build></model>',
            "z= attributes",
        ),
        (
            "<model><resources>" + cube_object(1) + '</resources><build><item objectid="7"/>'
            "</build></model>",
            "object 7 is referred to",
        ),
        (
            "<model><resources>" + cube_object(1) + '</resources><build><item objectid="1" '
            'p:path="/3D/other.model"/></build></model>',
            "another model part",
        ),
        (
            "<model><resources>" + cube_object(1) + '</resources><build><item objectid="1" '
            'transform="1 0 0"/></build></model>',
            "not 12 finite",
        ),
    ],
    ids=[
        "not zip",
        "truncated",
        "corrupt deflate",
        "nan",
        "no build",
        "vertex without z",
        "missing object",
        "other part",
        "transform",
    ],
)
def test_damaged_3mf_files_are_typed_errors(tmp_path, content, said):
    data = content if isinstance(content, bytes) else threemf(content)
    with pytest.raises(MeshReadError, match=said):
        read_mesh(write(tmp_path, "bad.3mf", data))


def test_no_raw_exception_escapes_on_3mf_garbage(tmp_path):
    """Seeded random cuts and byte flips of a valid model part: a typed error or a mesh."""
    rng = np.random.default_rng(11)
    good = "<model><resources>" + cube_object(1) + '</resources><build><item objectid="1"/>'
    good += "</build></model>"
    for k in range(40):
        text = bytearray(good.encode())
        for i in rng.integers(0, len(text), size=int(rng.integers(1, 20))):
            text[i] = int(rng.integers(32, 127))
        cut = bytes(text[: int(rng.integers(len(text) // 2, len(text) + 1))])
        try:
            read(write(tmp_path, f"g{k}.3mf", threemf(cut.decode())))
        except FvfError:
            pass


# ---------------------------------------------------------------------------- part 2: tools
def icosphere_f32() -> tuple[np.ndarray, np.ndarray]:
    """An icosphere whose coordinates are float32 numbers (STL and glTF store float32)."""
    ico = fvf.icosphere(1)
    return ico.vertices.astype(np.float32).astype(np.float64), ico.faces


def same_surface(path, V0: np.ndarray, F0: np.ndarray, *, indexed: bool = True) -> None:
    """The file at ``path`` reads back as (V0, F0): the same arrays when the format keeps
    shared vertices (``indexed``), the same facet corners after welding otherwise."""
    V, F = read(path)
    assert V.shape == V0.shape and F.shape == F0.shape
    if indexed:
        np.testing.assert_allclose(V, V0, rtol=0, atol=1e-6)
        np.testing.assert_array_equal(F, F0)
    else:
        np.testing.assert_allclose(V[F], V0[F0], rtol=0, atol=1e-6)
    assert signed_volume(V, F) == pytest.approx(signed_volume(V0, F0), rel=1e-5)


TRIMESH_EXPORTS = {
    "obj": ({}, True),
    "off": ({}, True),
    "ply": ({}, True),
    "ply ascii": ({"encoding": "ascii"}, True),
    "stl": ({}, False),
    "stl ascii": ({"file_type": "stl_ascii"}, False),
    "glb": ({}, True),
}


@pytest.mark.parametrize("what", list(TRIMESH_EXPORTS))
def test_files_written_by_trimesh(tmp_path, what):
    trimesh = pytest.importorskip("trimesh")
    V0, F0 = icosphere_f32()
    mesh = trimesh.Trimesh(V0, F0, process=False)
    mesh.visual.vertex_colors = np.tile([200, 30, 30, 255], (len(V0), 1)).astype(np.uint8)
    kwargs, indexed = TRIMESH_EXPORTS[what]
    path = tmp_path / f"trimesh.{what.split()[0]}"
    mesh.export(path, **kwargs)
    same_surface(path, V0, F0, indexed=indexed)


def test_obj_with_normals_and_uv_and_gltf_written_by_trimesh(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    V0, F0 = icosphere_f32()
    mesh = trimesh.Trimesh(V0, F0, process=False)
    text = trimesh.exchange.obj.export_obj(mesh, include_normals=True)
    same_surface(write(tmp_path, "n.obj", text), V0, F0)
    uv = trimesh.Trimesh(V0, F0, process=False, visual=trimesh.visual.TextureVisuals(uv=V0[:, :2]))
    uv.export(tmp_path / "uv.obj")
    same_surface(tmp_path / "uv.obj", V0, F0)
    files = trimesh.exchange.gltf.export_gltf(mesh, embed_buffers=True)
    same_surface(write(tmp_path, "m.gltf", next(iter(files.values()))), V0, F0)


MESHIO_EXPORTS = {
    "obj": {},
    "off": {},
    "ply": {},
    "ply ascii": {"binary": False},
    "stl": {},
    "stl binary": {"binary": True},
    "vtk": {},
    "vtk ascii": {"binary": False},
    "vtu": {},
    "vtu ascii": {"binary": False},
}


@pytest.mark.parametrize("what", list(MESHIO_EXPORTS))
def test_files_written_by_meshio(tmp_path, what):
    meshio = pytest.importorskip("meshio")
    suffix = what.split()[0]
    V0, F0 = icosphere_f32()
    path = tmp_path / f"meshio.{suffix}"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "PLY doesn't support 64-bit integers", ascii VTK
        meshio.write(path, meshio.Mesh(V0, [("triangle", F0)]), **MESHIO_EXPORTS[what])
    same_surface(path, V0, F0, indexed=suffix != "stl")


@pytest.mark.parametrize("suffix", ["obj", "ply", "vtk", "vtu"])
def test_quads_written_by_meshio(tmp_path, suffix):
    meshio = pytest.importorskip("meshio")
    path = tmp_path / f"quads.{suffix}"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        meshio.write(path, meshio.Mesh(CUBE_V, [("quad", CUBE_Q)]))
    check_cube(*read(path))
    np.testing.assert_array_equal(read_mesh(path, faces="quads")[1], CUBE_Q)


PYMESHLAB_EXPORTS = {
    "obj": {},
    "off": {},
    "ply": {},
    "ply ascii": {"binary": False},
    "ply normals colours": {"save_vertex_normal": True, "save_vertex_color": True},
    "stl": {},
    "stl ascii": {"binary": False},
}


@pytest.mark.parametrize("what", list(PYMESHLAB_EXPORTS))
def test_files_written_by_pymeshlab(tmp_path, what):
    pymeshlab = pytest.importorskip("pymeshlab")
    V0, F0 = icosphere_f32()
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V0, F0))
    suffix = what.split()[0]
    path = tmp_path / f"meshlab.{suffix}"
    ms.save_current_mesh(str(path), **PYMESHLAB_EXPORTS[what])
    same_surface(path, V0, F0, indexed=suffix != "stl")


@pytest.mark.parametrize("suffix", ["obj", "off", "ply"])
def test_quads_written_by_pymeshlab(tmp_path, suffix):
    """MeshLab stores quads as triangle pairs and writes them back as polygons, starting
    where it likes: the same surface, whatever the diagonal."""
    pymeshlab = pytest.importorskip("pymeshlab")
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(CUBE_V, CUBE_T))
    path = tmp_path / f"quads.{suffix}"
    ms.save_current_mesh(str(path))
    check_cube(*read(path), exact=False)


# ---------------------------------------------------------------------------- part 3: hostile
PNG = b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)) * 4
JPEG = b"\xff\xd8\xff\xe0\x00\x10JFIF\x00" + bytes(300)
TRI_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
TRI_OFF = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n"
PLY_HEAD = (
    "ply\nformat {} 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
)


def binary_triangle_ply(order: str, face=(0, 1, 2), xyz=None) -> bytes:
    fmt = "binary_little_endian" if order == "<" else "binary_big_endian"
    V = np.array(xyz if xyz is not None else [[0, 0, 0], [1, 0, 0], [0, 1, 0]], order + "f4")
    return (
        PLY_HEAD.format(fmt).encode()
        + V.tobytes()
        + struct.pack(f"{order}B{len(face)}i", len(face), *face)
    )


HOSTILE = {
    # name: (content, words the message must contain besides the file name)
    "truncated_le.ply": (binary_triangle_ply("<")[:-3], ["face", "truncated"]),
    "truncated_be.ply": (binary_triangle_ply(">")[:-7], ["face", "truncated"]),
    "truncated_vertices.ply": (binary_triangle_ply("<")[:-20], ["vertex", "truncated"]),
    "header_only.ply": (PLY_HEAD.format("binary_little_endian"), ["vertex", "truncated"]),
    "no_end_header.ply": (PLY_HEAD.format("ascii")[:60], ["end_header"]),
    "truncated.stl": (stl_binary(CUBE_V[CUBE_T], b"binary")[:-30], ["truncated", "re-export"]),
    "truncated_solid_header.stl": (
        stl_binary(CUBE_V[CUBE_T], b"solid cube")[:-30],
        ["truncated", "solid"],
    ),
    "unclosed_solid.stl": ("solid a\n" + stl_facets(CUBE_V[CUBE_T][:2]), ["endsolid"]),
    "trailing_data.ply": (binary_triangle_ply("<") + b"\x03\x00\x01", ["3 bytes follow", "counts"]),
    "trailing_lines.ply": (
        PLY_HEAD.format("ascii") + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 2 1 0\n",
        ["line 14", "1 lines follow", "counts"],
    ),
    "property_twice.ply": (
        PLY_HEAD.format("ascii").replace("property float y", "property float x\nproperty float y"),
        ["'x' twice"],
    ),
    "list_coordinate.ply": (
        PLY_HEAD.format("ascii").replace("property float x", "property list uchar float x"),
        ["list x", "not lists"],
    ),
    "float_indices.ply": (
        binary_triangle_ply("<").replace(b"uchar int vertex", b"uchar float vertex"),
        ["'vertex_indices'", "integer"],
    ),
    "index_out_of_range.obj": (TRI_OBJ + "f 1 2 4\n", ["line 4", "index 4", "1..3"]),
    "index_out_of_range.off": (TRI_OFF + "3 0 1 3\n", ["line 6", "index 3", "0..2"]),
    "index_out_of_range.ply": (binary_triangle_ply("<", (0, 1, 3)), ["face 0", "index 3"]),
    "two_vertex_face.obj": (TRI_OBJ + "f 1 2\n", ["line 4", "2 vertices"]),
    "two_vertex_face.off": (TRI_OFF + "2 0 1\n", ["line 6", "2 vertices"]),
    "two_vertex_face.ply": (binary_triangle_ply(">", (0, 1)), ["face 0", "2 vertices"]),
    "nan.obj": ("v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", ["line 1", "finite"]),
    "inf.off": ("OFF\n3 1 0\n0 0 0\n1 -inf 0\n0 1 0\n3 0 1 2\n", ["line 4", "finite"]),
    "overflow.obj": ("v 1e999 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", ["line 1", "1e999"]),
    "overflow.ply": (
        PLY_HEAD.format("ascii") + "0 0 0\n1 -2e400 0\n0 1 0\n3 0 1 2\n",
        ["line 11", "-2e400"],
    ),
    "empty.obj": ("", ["empty"]),
    "empty.off": ("", ["empty"]),
    "empty.ply": ("", ["empty"]),
    "empty.stl": ("", ["empty"]),
    "blank.obj": ("  \n\r\n", ["empty"]),
    "png.obj": (PNG, ["binary"]),
    "png.off": (PNG, ["binary"]),
    "png.ply": (PNG, ["ply"]),
    "png.stl": (PNG, ["binary STL", "re-export"]),
    "jpeg.obj": (JPEG, ["binary"]),
    "mesh.3ds": (TRI_OBJ, ["suffix", ".obj"]),
    "mesh.obj.gz": (TRI_OBJ, ["suffix", ".gz"]),
    "no_suffix": (TRI_OBJ, ["suffix"]),
    "points_only.obj": (TRI_OBJ, ["no faces"]),
}


@pytest.mark.parametrize("name", list(HOSTILE))
def test_hostile_files_are_typed_errors_naming_the_file(tmp_path, name):
    content, words = HOSTILE[name]
    with pytest.raises(MeshReadError) as info:
        read_mesh(write(tmp_path, name, content))
    message = str(info.value)
    for word in [name, *words]:
        assert word in message, (word, message)


@pytest.mark.parametrize("suffix", [".vtu", ".vtk"])
def test_damaged_vtk_files_say_what_vtk_said(tmp_path, suffix):
    """VTK only logs a parse failure and returns an empty mesh; fvf reports it instead of
    calling the file a point cloud."""
    meshio = pytest.importorskip("meshio")
    pytest.importorskip("pyvista")
    path = tmp_path / f"whole{suffix}"
    meshio.write(path, meshio.Mesh(CUBE_V, [("triangle", CUBE_T)]))
    for name, data in (("cut", path.read_bytes()[:400]), ("png", PNG)):
        bad = write(tmp_path, f"{name}{suffix}", data)
        with pytest.raises(MeshReadError, match=f"{name}\\{suffix}: VTK cannot read this file"):
            read_mesh(bad)


@pytest.mark.parametrize(
    "name", ["nan.ply", "inf.stl"], ids=["binary PLY with NaN", "binary STL with inf"]
)
def test_non_finite_binary_coordinates_are_refused_by_the_mesh(tmp_path, name, capsys):
    """Binary files store NaN and inf as they are; read_mesh returns the file's values and
    the mesh (and every command) refuses them with a NonFiniteError."""
    if name.endswith(".ply"):
        data = binary_triangle_ply("<", xyz=[[0, 0, 0], [np.nan, 0, 0], [0, 1, 0]])
    else:
        data = stl_binary(np.array([[[0, 0, 0], [1, 0, 0], [0, np.inf, 0]]]), b"binary")
    path = write(tmp_path, name, data)
    V, F = read(path)
    assert not np.isfinite(V).all()
    with pytest.raises(NonFiniteError, match="NaN or inf"):
        fvf.TriMesh(V, F)
    out = tmp_path / "out.obj"
    assert main(["quad", str(path), "--faces", "500", "-o", str(out)]) == EXIT_BAD_INPUT
    assert "NonFiniteError" in capsys.readouterr().err and not out.exists()


@pytest.mark.parametrize("name", ["truncated_le.ply", "png.obj", "mesh.3ds", "overflow.obj"])
def test_the_commands_report_hostile_files_in_one_line(tmp_path, name, capsys):
    path = write(tmp_path, name, HOSTILE[name][0])
    assert main(["info", str(path)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "MeshReadError" in err and name in err and "Traceback" not in err
    out = tmp_path / "out.obj"
    assert main(["quad", str(path), "--faces", "500", "-o", str(out)]) == EXIT_BAD_INPUT
    assert "MeshReadError" in capsys.readouterr().err and not out.exists()


def test_fvf_info_reads_the_dialects(tmp_path, capsys):
    for name, text in (("meshlab.off", OFF_DIALECTS["NCOFF_meshlab"]), ("b.obj", BLENDER_OBJ)):
        path = write(tmp_path, name, text)
        assert main(["info", str(path)]) == EXIT_OK
        captured = capsys.readouterr()
        assert "n_faces: 12" in captured.out and "Error" not in captured.err


def test_no_raw_exception_escapes_on_garbage(tmp_path):
    """Seeded random bytes after each format's first line: a typed error or a mesh."""
    rng = np.random.default_rng(7)
    starts = {".obj": b"v 0 0 0\n", ".off": b"OFF\n", ".ply": b"ply\n", ".stl": b"solid x\n"}
    for k in range(40):
        suffix = list(starts)[k % 4]
        body = rng.integers(0, 256, size=int(rng.integers(1, 400)), dtype=np.uint8).tobytes()
        path = write(tmp_path, f"g{k}{suffix}", starts[suffix] + body)
        try:
            read(path)
        except FvfError:
            pass


@pytest.mark.parametrize(
    ("data", "said"),
    [
        (("\n".join(obj_lines()) + "\n").encode(), "text that does not begin with 'solid'"),
        (__import__("gzip").compress(b"solid x\nendsolid x\n"), "gzip-compressed"),
        (b"ply\nformat ascii 1.0\n" + b"\x00" * 200, "a PLY file"),
    ],
    ids=["OBJ text", "gzip", "PLY"],
)
def test_a_file_of_another_format_named_stl_is_called_what_it_is(tmp_path, data, said):
    """An OBJ named .stl was called a binary STL 'truncated after 259 triangles'."""
    with pytest.raises(MeshReadError, match=f"not an STL file: it is {said}"):
        read_mesh(write(tmp_path, "part.stl", data))


def test_gltf_primitives_that_are_not_triangles_are_named(tmp_path):
    """trimesh drops TRIANGLE_FAN, strip, line and point primitives: a fan-only file was
    "0 vertices but no faces", a file with a fan beside triangles lost it silently."""
    import json

    trimesh = pytest.importorskip("trimesh")
    from trimesh.exchange import gltf

    ball = fvf.icosphere(1)
    text = next(
        iter(
            gltf.export_gltf(
                trimesh.Trimesh(ball.vertices, ball.faces), embed_buffers=True
            ).values()
        )
    )
    doc = json.loads(text)
    prim = doc["meshes"][0]["primitives"][0]
    doc["meshes"][0]["primitives"].append({**prim, "mode": 6})
    both = tmp_path / "both.gltf"
    both.write_text(json.dumps(doc))
    with pytest.warns(fvf.MeshReadWarning, match="left out primitives of the file: 1 TRIANGLE_FAN"):
        V, F = read_mesh(both)
    assert F.shape == (80, 3)
    doc["meshes"][0]["primitives"] = [{**prim, "mode": 6}]
    fan = tmp_path / "fan.gltf"
    fan.write_text(json.dumps(doc))
    with pytest.raises(MeshReadError, match="primitives are 1 TRIANGLE_FAN"):
        read_mesh(fan)


def test_a_damaged_vtu_leaves_no_vtk_log_on_stderr(tmp_path):
    """VTK's reader logs through logging.error, which installed a console handler on the
    root logger ("ERROR:root:No update piece number ..." before fvf's own message). In a
    process of its own: pytest's log capture keeps a handler on the root logger."""
    import subprocess
    import sys

    meshio = pytest.importorskip("meshio")
    pytest.importorskip("pyvista")
    path = tmp_path / "whole.vtu"
    meshio.write(path, meshio.Mesh(CUBE_V, [("triangle", CUBE_T)]))
    bad = write(tmp_path, "cut.vtu", path.read_bytes()[:400])
    code = (
        "import logging, fvf\n"
        f"try:\n    fvf.read_mesh({str(bad)!r})\n"
        "except fvf.MeshReadError:\n    print('refused')\n"
        "print(len(logging.getLogger().handlers))\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert run.stdout.split() == ["refused", "0"], run
    assert "ERROR:root" not in run.stderr, run.stderr
