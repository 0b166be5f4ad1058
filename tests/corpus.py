"""The hostile-input corpus: meshes and fields that real data will throw at fvf.

Three kinds of entries, each a function returning named entries (so nothing is built at
import time and a test can ask for one entry by name):

- :func:`buildable` -- name -> zero-argument builder of a valid :class:`fvf.TriMesh`
  (a single triangle, the 12-vertex icosahedron, boundaries, corners, several components,
  extreme scales and offsets, rotations, needles, and the shared real meshes with boundary
  or slivers; the shared ones skip
  cleanly when ``../shared/meshes`` is absent, through ``conftest.load_shared``).
- :func:`raw` -- name -> :class:`RawEntry`: vertex and face arrays that ``TriMesh`` must
  reject with the documented error type (or, where documented, accept).
- :func:`hostile_face_fields` / :func:`hostile_vertex_functions` -- name -> (array,
  expected outcome) for a given mesh.
- :func:`extreme_fields` -- fields of magnitude 1e-200 and 1e200, for the functions whose
  results do not depend on the size (angles, indices) or scale linearly (norms).
- :func:`hostile_files` -- name -> :class:`FileEntry`: mesh files with byte order marks,
  CR-only line endings, 4OFF, Python-only number spellings, binary junk, and paths that
  are not files (a FIFO, /dev/zero, a folder, a sparse 1 GiB file); each with the
  vertices it must give or the error it must raise.
- :func:`hostile_data_files` -- name -> (writer, expected): ``.npz`` archives whose keys
  declare huge arrays, are truncated, hold objects, or are not files.
- :func:`hostile_options` -- name -> (call, expected error): option values that must be
  refused with a typed error (no hang, no bad_alloc, no silent fallback).

Generated meshes stay small (at most a few hundred faces) so the public-API sweep is fast;
the big shared meshes are listed in :data:`SLOW` and marked ``slow`` by the tests.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

import fvf
from fvf import errors

# ---------------------------------------------------------------------------- generators


def annulus(n_rings: int = 3, n_sectors: int = 24, inner: float = 0.5) -> fvf.TriMesh:
    """Flat annulus inner <= r <= 1 in z = 0 (two boundary loops, chi = 0), normals +z."""
    r = np.linspace(inner, 1.0, n_rings + 1)
    a = 2 * np.pi * np.arange(n_sectors) / n_sectors
    R, A = np.meshgrid(r, a, indexing="ij")
    X = np.stack([R * np.cos(A), R * np.sin(A), 0 * R], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_rings), np.arange(n_sectors), indexing="ij")
    p = i * n_sectors + j
    q = i * n_sectors + (j + 1) % n_sectors
    F = np.concatenate(
        [
            np.stack([p, p + n_sectors, q + n_sectors], -1).reshape(-1, 3),
            np.stack([p, q + n_sectors, q], -1).reshape(-1, 3),
        ]
    )
    return fvf.TriMesh(X, F)


# Shapes with an exact or a near symmetry (correspondence and symmetric design).
REFLECT = np.array([-1.0, 1.0, 1.0])


def spiky_ball(seed: int = 11, spikes: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A scan with spikes: a unit sphere (icosphere 4) with 3 % radial noise and ``spikes``
    vertices pushed out to 1.4 times their radius; returns (V, F, sorted spike indices)."""
    rng = np.random.default_rng(seed)
    s = fvf.icosphere(4)
    V = s.vertices * (1 + 0.03 * rng.normal(size=(s.n_vertices, 1)))
    tips = np.sort(rng.choice(s.n_vertices, spikes, replace=False))
    V[tips] *= 1.4
    return V, s.faces, tips


def blob(level: int = 3, symmetric: bool = False) -> fvf.TriMesh:
    """An icosphere stretched to (2, 1.2, 0.8) with smooth bumps: no symmetry at all, or
    (``symmetric``) exactly the reflection x -> -x, which maps vertices to vertices."""
    sphere = fvf.icosphere(level)
    x, y, z = sphere.vertices.T
    r = 1 + 0.25 * y + 0.2 * z + 0.15 * np.cos(2.5 * y) * z
    r += 0.3 * x**2 * y if symmetric else 0.3 * x * y + 0.2 * x**3
    return fvf.TriMesh(sphere.vertices * np.array([2.0, 1.2, 0.8]) * r[:, None], sphere.faces)


def mirror_index(mesh: fvf.TriMesh) -> np.ndarray:
    """The vertex at the mirror position (x -> -x) of each vertex, exact for blob(symmetric)."""
    d, idx = cKDTree(mesh.vertices).query(mesh.vertices * REFLECT)
    assert d.max() < 1e-12
    return idx


def mirror_image(mesh: fvf.TriMesh) -> fvf.TriMesh:
    """The reflected copy, faces flipped so that normals still point outwards."""
    return fvf.TriMesh(mesh.vertices * REFLECT, mesh.faces[:, [0, 2, 1]])


def grid_arrays(k: int = 6, bump: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A (k+1) x (k+1) grid on the unit square, z = bump·sin(πx) sin(πy); (V, F), normals +z."""
    s = np.linspace(0.0, 1.0, k + 1)
    x, y = np.meshgrid(s, s, indexing="ij")
    z = bump * np.sin(np.pi * x) * np.sin(np.pi * y)
    X = np.stack([x, y, z], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    a = i * (k + 1) + j
    b = a + (k + 1)  # (i + 1, j)
    F = np.concatenate(
        [np.stack([a, b, b + 1], -1).reshape(-1, 3), np.stack([a, b + 1, a + 1], -1).reshape(-1, 3)]
    )
    return X, F


def square(k: int = 6) -> fvf.TriMesh:
    """The flat unit square: a boundary loop with four 90-degree corners."""
    return fvf.TriMesh(*grid_arrays(k))


def sliver(eps: float = 1e-6) -> fvf.TriMesh:
    """A curved 5 x 5 grid with one needle face of relative area ~eps (min angle ~1e-4 rad).

    Vertex (2, 2) is moved to within eps of the ring edge (3, 2)-(3, 3), so the face
    ((2,2), (3,2), (3,3)) is a needle while its 1-ring stays star-shaped.
    """
    X, F = grid_arrays(5, bump=0.2)
    h = 1.0 / 5
    c = 2 * 6 + 2
    X[c, 0] = 3 * h - eps * h
    X[c, 1] = 2.5 * h
    X[c, 2] = 0.2 * np.sin(np.pi * X[c, 0]) * np.sin(np.pi * X[c, 1])
    return fvf.TriMesh(X, F)


def two_spheres() -> fvf.TriMesh:
    """Two disjoint icospheres (two components, chi = 4)."""
    a = fvf.icosphere(1)
    X = np.concatenate([a.vertices, a.vertices + [3.0, 0.0, 0.0]])
    F = np.concatenate([a.faces, a.faces + a.n_vertices])
    return fvf.TriMesh(X, F)


def base_sphere() -> fvf.TriMesh:
    """The irregular closed mesh that is scaled, moved and rotated (320 faces)."""
    return fvf.jittered_sphere(2, 0.3, seed=1)


def rotation_matrix(seed: int = 7) -> np.ndarray:
    """A fixed proper rotation (det +1), from a seeded QR."""
    q, r = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def transformed(mesh: fvf.TriMesh, scale=1.0, shift=0.0, rotation=None) -> fvf.TriMesh:
    """X -> scale · R X + shift, same faces."""
    X = mesh.vertices if rotation is None else mesh.vertices @ rotation.T
    return fvf.TriMesh(scale * X + shift, mesh.faces)


def _shared(name: str) -> Callable[[], fvf.TriMesh]:
    def build():
        from conftest import load_shared

        return load_shared(name)

    return build


# ---------------------------------------------------------------------------- entries

#: Shared meshes too big or too slow for the fast suite's API sweep (tests mark them
#: ``slow``; woody: 34 s, its quad mesh at a quarter of its faces takes six attempts).
SLOW = ("camelhead.off", "stanford-bunny.obj", "nefertiti.obj", "woody.obj")

#: Entries with boundary, for the boundary tests.
WITH_BOUNDARY = ("disk", "annulus", "square", "sliver", "woody.obj", "camelhead.off")


def buildable() -> dict[str, Callable[[], fvf.TriMesh]]:
    """Name -> builder of every valid corpus mesh (generated first, then shared)."""
    R = rotation_matrix()
    return {
        "single_triangle": lambda: fvf.TriMesh([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]]),
        "icosahedron": lambda: fvf.icosphere(0),
        "icosphere1": lambda: fvf.icosphere(1),
        "disk": lambda: fvf.disk(4, 6),
        "annulus": annulus,
        "square": square,
        "sliver": sliver,
        "two_spheres": two_spheres,
        "sphere_x1e-8": lambda: transformed(base_sphere(), scale=1e-8),
        "sphere_x1e8": lambda: transformed(base_sphere(), scale=1e8),
        "sphere_+1e6": lambda: transformed(base_sphere(), shift=1e6),
        "sphere_rotated": lambda: transformed(base_sphere(), rotation=R),
        "woody.obj": _shared("woody.obj"),
        "camelhead.off": _shared("camelhead.off"),
        "stanford-bunny.obj": _shared("stanford-bunny.obj"),
        "nefertiti.obj": _shared("nefertiti.obj"),
    }


@dataclass(frozen=True)
class RawEntry:
    """Arrays given to ``TriMesh`` and what must happen.

    ``error`` is the documented error type, or None when the arrays are documented to be
    accepted (``note`` says what they then are).
    """

    vertices: object
    faces: object
    error: type[Exception] | None
    note: str


def _tetra() -> tuple[np.ndarray, np.ndarray]:
    X = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])
    return X, F


def raw() -> dict[str, RawEntry]:
    """Name -> raw arrays that TriMesh must reject (or accept, where documented)."""
    ico = fvf.icosphere(1)
    X, F = ico.vertices.copy(), ico.faces.copy()
    n = X.shape[0]
    out: dict[str, RawEntry] = {}

    out["unreferenced_vertex"] = RawEntry(
        np.vstack([X, [[5.0, 5.0, 5.0]]]), F, errors.UnreferencedVertexError, "vertex n unused"
    )
    # A duplicated vertex that no face uses is an unreferenced vertex.
    out["duplicate_vertex_unused"] = RawEntry(
        np.vstack([X, X[:1]]), F, errors.UnreferencedVertexError, "copy of vertex 0 unused"
    )
    # Faces split between a vertex and its copy: a valid mesh with a slit (boundary).
    F2 = F.copy()
    ring = np.flatnonzero((F == 0).any(axis=1))
    F2[ring[:2]] = np.where(F2[ring[:2]] == 0, n, F2[ring[:2]])
    out["duplicate_vertex_split"] = RawEntry(
        np.vstack([X, X[:1]]), F2, None, "accepted: a mesh with boundary along the split"
    )
    out["duplicated_face"] = RawEntry(X, np.vstack([F, F[:1]]), errors.NonManifoldError, "")
    out["duplicated_flipped_face"] = RawEntry(
        X, np.vstack([F, F[:1, ::-1]]), errors.NonManifoldError, "face 0 again, reversed"
    )
    Ff = F.copy()
    Ff[3] = Ff[3, ::-1]
    out["flipped_face"] = RawEntry(X, Ff, errors.OrientationError, "face 3 reversed")
    # Three triangles on one edge.
    Xe = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, 0, 1]])
    Fe = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    out["nonmanifold_edge"] = RawEntry(Xe, Fe, errors.NonManifoldError, "edge (0, 1) x3")
    # Two tetrahedra sharing one vertex (a bow tie in 3-D).
    Xt, Ft = _tetra()
    Xv = np.vstack([Xt, Xt[1:] + 2 * (Xt[0] - Xt[1:].mean(0))])
    Fv = np.vstack([Ft, np.where(Ft == 0, 0, Ft + 3)])
    out["nonmanifold_vertex"] = RawEntry(Xv, Fv, errors.NonManifoldError, "vertex 0 two fans")
    Xz = X.copy()
    a, b, c = F[0]
    Xz[c] = 0.5 * (Xz[a] + Xz[b])  # face 0 collinear
    out["zero_area_face"] = RawEntry(Xz, F, errors.DegenerateFaceError, "face 0 collinear")
    Fr = F.copy()
    Fr[0, 2] = Fr[0, 1]
    out["repeated_index_face"] = RawEntry(X, Fr, errors.MeshIndexError, "face 0 = (a, b, b)")
    Xn = X.copy()
    Xn[4, 1] = np.nan
    out["nan_vertex"] = RawEntry(Xn, F, errors.NonFiniteError, "")
    Xi = X.copy()
    Xi[2, 0] = np.inf
    out["inf_vertex"] = RawEntry(Xi, F, errors.NonFiniteError, "")
    out["index_out_of_range"] = RawEntry(X, np.where(F == 5, n, F), errors.MeshIndexError, "")
    out["negative_index"] = RawEntry(X, np.where(F == 5, -1, F), errors.MeshIndexError, "")
    out["one_based_faces"] = RawEntry(X, F + 1, errors.MeshIndexError, "OBJ-style indices")
    out["vertices_2d"] = RawEntry(X[:, :2], F, errors.MeshShapeError, "")
    out["vertices_1d"] = RawEntry(X.ravel(), F, errors.MeshShapeError, "")
    out["quads"] = RawEntry(X, np.hstack([F, F[:, :1]]), errors.MeshShapeError, "")
    out["float_faces"] = RawEntry(X, F.astype(float), errors.MeshShapeError, "")
    out["complex_vertices"] = RawEntry(X.astype(complex), F, errors.MeshShapeError, "")
    out["string_vertices"] = RawEntry(X.astype(str), F, errors.MeshShapeError, "")
    out["object_vertices"] = RawEntry(X.astype(object), F, errors.MeshShapeError, "")
    out["empty_faces"] = RawEntry(X, np.zeros((0, 3), dtype=np.int64), errors.MeshShapeError, "")
    out["empty_mesh"] = RawEntry(np.zeros((0, 3)), np.zeros((0, 3), int), errors.MeshShapeError, "")
    out["ragged_lists"] = RawEntry(X.tolist(), [[0, 1], [1, 2, 3]], errors.MeshShapeError, "")
    return out


def hostile_face_fields(mesh: fvf.TriMesh, rng: np.random.Generator) -> dict[str, tuple]:
    """Name -> (per-face field, expected): expected is "ok", a warning type, or an error type.

    ``"ok"`` means a finite, correct result; "huge" fields (1e150 per entry) are valid
    input whose quadratic results (1e300) still fit in float64.
    """
    m = mesh.n_faces
    u = mesh.project_tangent(rng.standard_normal((m, 3)))
    nan = u.copy()
    nan[m // 2, 1] = np.nan
    inf = u.copy()
    inf[0, 0] = -np.inf
    return {
        "zero": (np.zeros((m, 3)), "ok"),
        "huge": (1e150 * u / np.abs(u).max(), "ok"),
        # a tangent field rounded to float32: its rounding is not a normal component
        "float32": (u.astype(np.float32), "ok"),
        "non_tangent": (u + mesh.face_normals, errors.NonTangentFieldWarning),
        "nan": (nan, errors.FieldValueError),
        "inf": (inf, errors.FieldValueError),
        "too_short": (u[:-1], errors.FieldShapeError),
        "per_vertex": (np.ones((mesh.n_vertices, 3)), errors.FieldShapeError),
        "flat_3m_plus_1": (np.zeros(3 * m + 1), errors.FieldShapeError),
        "complex": (u.astype(complex), errors.FieldShapeError),
    }


def hostile_vertex_functions(mesh: fvf.TriMesh, rng: np.random.Generator) -> dict[str, tuple]:
    """Name -> (PL function, expected) as in :func:`hostile_face_fields`."""
    n = mesh.n_vertices
    f = rng.standard_normal(n)
    nan = f.copy()
    nan[n // 3] = np.nan
    return {
        "zero": (np.zeros(n), "ok"),
        "huge": (1e150 * f / np.abs(f).max(), "ok"),
        "nan": (nan, errors.FieldValueError),
        "too_long": (np.zeros(n + 1), errors.FieldShapeError),
        "per_face": (np.zeros(mesh.n_faces), errors.FieldShapeError),
        "string": (f.astype(str), errors.FieldShapeError),
    }


def extreme_fields(mesh: fvf.TriMesh, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Name -> tangent field (m, 3) of magnitude 1e-200 / 1 / 1e200 (same directions)."""
    u = mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3)))
    u = u / np.abs(u).max()
    return {"tiny": 1e-200 * u, "unit": u, "huge": 1e200 * u}


# ---------------------------------------------------------------------------- files
@dataclass(frozen=True)
class FileEntry:
    """A mesh file and what :func:`fvf.read_mesh` must do with it.

    ``data`` is the file's bytes, or a kind of special path the test builds
    (``"fifo"``, ``"devzero"``, ``"folder"``, ``"sparse"``). ``vertices`` are the
    vertices it must read (faces are ``[[0, 1, 2]]`` unless ``faces`` says otherwise),
    or ``error`` the type it must raise with ``words`` in the message.
    """

    suffix: str
    data: bytes | str
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None
    error: type[Exception] | None = None
    words: tuple[str, ...] = ()


_TRI = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
_OBJ = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
_OFF = b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
_PLY_HEAD = (
    b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    b"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
)
_PLY = _PLY_HEAD + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"


def _binary_ply(eol: bytes) -> bytes:
    head = _PLY_HEAD.replace(b"ascii", b"binary_little_endian").replace(b"\n", eol)
    body = _TRI.astype("<f4").tobytes() + bytes([3]) + np.array([0, 1, 2], "<i4").tobytes()
    return head + body


def hostile_files() -> dict[str, FileEntry]:
    """Name -> mesh file that real data throws at :func:`fvf.read_mesh`."""
    bom = b"\xef\xbb\xbf"
    err = errors.MeshReadError
    return {
        # encodings and line endings: read as the text says
        "obj_utf8_bom": FileEntry(".obj", bom + _OBJ, _TRI),
        "off_utf8_bom": FileEntry(".off", bom + _OFF, _TRI),
        "ply_utf8_bom": FileEntry(".ply", bom + _PLY, _TRI),
        "obj_crlf": FileEntry(".obj", _OBJ.replace(b"\n", b"\r\n"), _TRI),
        "obj_cr_only": FileEntry(".obj", _OBJ.replace(b"\n", b"\r"), _TRI),
        "off_cr_only": FileEntry(".off", _OFF.replace(b"\n", b"\r"), _TRI),
        "ply_ascii_cr_only": FileEntry(".ply", _PLY.replace(b"\n", b"\r"), _TRI),
        "ply_binary_cr_header": FileEntry(".ply", _binary_ply(b"\r"), _TRI),
        "ply_binary_crlf_header": FileEntry(".ply", _binary_ply(b"\r\n"), _TRI),
        "obj_utf16": FileEntry(
            ".obj", _OBJ.decode().encode("utf-16"), error=err, words=("UTF-16",)
        ),
        # 4OFF: homogeneous coordinates, divided by w
        "off_4off": FileEntry(".off", b"4OFF\n3 1 0\n0 0 0 2\n2 0 0 2\n0 4 0 4\n3 0 1 2\n", _TRI),
        "off_4off_w0": FileEntry(
            ".off",
            b"4OFF\n3 1 0\n0 0 0 1\n1 0 0 0\n0 1 0 1\n3 0 1 2\n",
            error=err,
            words=("line 4", "w = 0"),
        ),  # fmt: skip
        "off_4off_no_w": FileEntry(".off", _OFF.replace(b"OFF", b"4OFF"), error=err, words=("w",)),
        # Python's float()/int() quirks are not the file format
        "obj_underscore": FileEntry(
            ".obj", _OBJ.replace(b"v 1 0 0", b"v 1_0 0 0"), error=err, words=("line 2", "1_0")
        ),
        "obj_face_underscore": FileEntry(
            ".obj", _OBJ.replace(b"f 1 2 3", b"f 1 2 0_3"), error=err, words=("line 4", "0_3")
        ),
        "off_underscore": FileEntry(
            ".off", _OFF.replace(b"1 0 0", b"1_000 0 0"), error=err, words=("line 4",)
        ),
        "ply_underscore": FileEntry(
            ".ply", _PLY.replace(b"1 0 0\n", b"1_0 0 0\n"), error=err, words=("1_0",)
        ),
        "obj_nan": FileEntry(
            ".obj", _OBJ.replace(b"v 0 1 0", b"v nan 1 0"), error=err, words=("line 3", "finite")
        ),
        "obj_infinity": FileEntry(
            ".obj", _OBJ.replace(b"v 0 1 0", b"v 0 Infinity 0"), error=err, words=("finite",)
        ),
        "off_inf": FileEntry(
            ".off", _OFF.replace(b"0 1 0", b"0 -inf 0"), error=err, words=("inf",)
        ),
        "obj_hex": FileEntry(
            ".obj", _OBJ.replace(b"v 0 1 0", b"v 0 1 0x10"), error=err, words=("0x10",)
        ),
        # not mesh files at all: refused from their first bytes
        "obj_binary_junk": FileEntry(
            ".obj", bytes(range(256)) * 64, error=err, words=("binary", "NUL")
        ),
        "ply_not_ply": FileEntry(".ply", b"hello\n" * 100, error=err, words=("'ply'",)),
        # paths that are not regular files: refused before they are opened
        "fifo": FileEntry(".obj", "fifo", error=err, words=("FIFO",)),
        "devzero": FileEntry(".off", "devzero", error=err, words=("character device",)),
        "folder": FileEntry(".ply", "folder", error=err, words=("directory",)),
        "sparse_1gib": FileEntry(".obj", "sparse", error=err, words=("NUL",)),
    }


def make_file(path, entry: FileEntry):
    """Create ``path`` for a :class:`FileEntry`; returns the path to read."""
    import os
    from pathlib import Path

    path = Path(path).with_suffix(entry.suffix)
    if entry.data == "fifo":
        os.mkfifo(path)
    elif entry.data == "devzero":
        path.symlink_to("/dev/zero")
    elif entry.data == "folder":
        path.mkdir()
    elif entry.data == "sparse":
        with open(path, "wb") as fh:
            fh.truncate(1 << 30)  # 1 GiB of zeros that occupy no disk
    else:
        path.write_bytes(entry.data)
    return path


def _npz_with_member(path, name: str, header: dict, payload: bytes, **arrays) -> None:
    """An .npz holding ``arrays`` and one hand-made member ``name`` (header, payload)."""
    import io
    import zipfile

    np.savez(path, **arrays)
    raw = io.BytesIO()
    np.lib.format.write_array_header_2_0(raw, header)
    with zipfile.ZipFile(path, "a") as archive:
        archive.writestr(name + ".npy", np.lib.format.magic(2, 0) + raw.getvalue()[8:] + payload)


def _save_npy(path, a: np.ndarray) -> None:
    """One array in .npy format at ``path`` (whatever its suffix)."""
    with open(path, "wb") as fh:
        np.save(fh, a)


def hostile_data_files(mesh: fvf.TriMesh) -> dict[str, tuple[Callable, object]]:
    """Name -> (write(path), expected): a data file and what ``fvf flow`` on its ``f`` and
    ``v`` must do: ``"ok"`` (the unused keys are never read) or the error type."""
    n, m = mesh.n_vertices, mesh.n_faces
    f = mesh.vertices[:, 0]
    v = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    huge = {"descr": "<f8", "fortran_order": False, "shape": (10**12,)}  # 8 TB declared
    long = {"descr": "<f8", "fortran_order": False, "shape": (1,) * 3000}  # 20 kB header
    return {
        "unused_key_declares_8tb": (
            lambda p: _npz_with_member(p, "junk", huge, b"\0" * 64, f=f, v=v),
            "ok",
        ),
        "unused_key_with_20kb_header": (
            lambda p: _npz_with_member(p, "junk", long, b"\0" * 8, f=f, v=v),
            "ok",
        ),
        "used_key_declares_8tb": (
            lambda p: _npz_with_member(p, "v", huge, b"\0" * 64, f=f),
            errors.DataFileError,
        ),
        "used_key_truncated": (
            lambda p: _npz_with_member(
                p, "v", {"descr": "<f8", "fortran_order": False, "shape": (m, 3)}, b"\0" * 64, f=f
            ),
            errors.DataFileError,
        ),
        "object_array": (
            lambda p: np.savez(p, f=f, v=np.array([object()] * 3), allow_pickle=True),
            errors.DataFileError,
        ),
        "fifo": (lambda p: __import__("os").mkfifo(p), errors.DataFileError),
        "devzero": (lambda p: p.symlink_to("/dev/zero"), errors.DataFileError),
        "single_npy": (lambda p: _save_npy(p, f), errors.DataFileError),
        "vertex_count_mismatch": (
            lambda p: np.savez(p, f=np.zeros(n + 1), v=v),
            errors.FieldShapeError,
        ),
    }


def hostile_options(mesh: fvf.TriMesh) -> dict[str, tuple[Callable[[], object], type]]:
    """Name -> (call, error): options that must be refused at the entrance, quickly."""
    f = mesh.vertices[:, 0]
    v = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    P = errors.ParameterError
    fluid = fvf.ideal_fluid
    tiny = {"tol": 1e-300}  # unreachable: only max_iterations stops the iteration
    return {
        "fluid_max_iterations_0": (lambda: fluid(mesh, f, 0.01, 2, max_iterations=0, **tiny), P),
        "fluid_max_iterations_-1": (lambda: fluid(mesh, f, 0.01, 2, max_iterations=-1, **tiny), P),
        "fluid_spectral_max_iterations_0": (
            lambda: fluid(mesh, f, 0.01, 2, method="spectral", k=8, max_iterations=0, **tiny),
            P,
        ),
        "fluid_steps_2.5": (lambda: fluid(mesh, f, 0.01, 2.5), P),
        "fluid_steps_-1": (lambda: fluid(mesh, f, 0.01, -1), P),
        "fluid_save_every_0": (lambda: fluid(mesh, f, 0.01, 2, save_every=0), P),
        "fluid_tol_nan": (lambda: fluid(mesh, f, 0.01, 2, tol=np.nan), P),
        "fluid_dt_inf": (lambda: fluid(mesh, f, np.inf, 2), P),
        "fluid_k_1.5": (lambda: fluid(mesh, f, 0.01, 2, method="spectral", k=1.5), P),
        "flow_growth_limit_nan": (lambda: fvf.flow(mesh, v, f, 1.0, growth_limit=np.nan), P),
        "flow_growth_limit_-1": (lambda: fvf.flow(mesh, v, f, 1.0, growth_limit=-1.0), P),
        "flow_growth_limit_0.5": (
            lambda: fvf.flow(mesh, v, f, 1.0, method="skew", growth_limit=0.5),
            P,
        ),
        "functional_flow_growth_limit_nan": (
            lambda: fvf.FunctionalFlow(mesh, v, growth_limit=np.nan),
            P,
        ),
        "transport_growth_limit_nan": (lambda: fvf.Ad(mesh, v, v, 0.1, growth_limit=np.nan), P),
        "flow_tangent_whatever": (lambda: fvf.flow(mesh, v, f, 1.0, tangent="whatever"), P),
        "as_face_field_tangent_whatever": (
            lambda: fvf.as_face_field(mesh, v, tangent="whatever"),
            P,
        ),
        "flow_k_0": (lambda: fvf.flow(mesh, v, f, 1.0, method="spectral", k=0), P),
        "flow_dt_-1": (lambda: fvf.flow(mesh, v, f, 1.0, method="cayley", dt=-1.0), P),
        "flow_dt_nan": (lambda: fvf.flow(mesh, v, f, 1.0, method="cayley", dt=np.nan), P),
        "flow_courant_0": (lambda: fvf.flow(mesh, v, f, 1.0, method="cayley", courant=0.0), P),
        "spectral_basis_k_2.5": (lambda: fvf.SpectralBasis(mesh, 2.5), P),
    }
