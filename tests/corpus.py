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

Generated meshes stay small (at most a few hundred faces) so the public-API sweep is fast;
the big shared meshes are listed in :data:`SLOW` and marked ``slow`` by the tests.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

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

#: Shared meshes too big for the fast suite (tests mark them ``slow``).
SLOW = ("camelhead.off", "stanford-bunny.obj", "nefertiti.obj")

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
