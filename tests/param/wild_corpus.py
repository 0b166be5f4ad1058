r"""Meshes of the kinds people bring to a quad mesher ("the wild corpus").

Deterministic (seeded, no downloads), each a pair ``V`` float64 (n, 3), ``F`` int64 (m, 3),
built on demand by name (:func:`mesh`) and written in its natural format by
:func:`write_corpus`: binary STL soups for CAD (written by :func:`write_stl`, read back and
welded by :func:`read_stl`), OBJ / PLY / OFF for scans (through :func:`fvf.write_mesh`).
CAD solids come from manifold3d booleans (its planar triangulation is what CAD exporters
give: long slivers from hole rims to far corners, fan-triangulated caps), scans from level
sets of smooth unions of ellipsoids and capsules (manifold3d's marching tetrahedra) or from
deformed spheres and tori, with normal noise and a few one-vertex spikes.

========================  =====  ===  =====  ======  =========================================
name                      kind   χ    parts  loops   what it tests
========================  =====  ===  =====  ======  =========================================
cad_box_hole              cad     0   1      0       through hole (genus 1), 90° edges, slivers
cad_l_bracket             cad    -2   1      0       L of two boxes with a hole per leg, concave
                                                     90° edge
cad_cylinder_boss         cad     2   1      0       off-centre boss on a disc: circular sharp
                                                     edges, fan-like caps
cad_plate_holes           cad   -10   1      0       plate with six holes (genus 6)
cad_extrusion             cad     0   1      0       extruded gear profile with a bore: many
                                                     short sharp edges, long side slivers
cad_two_parts             cad     4   2      0       two disjoint solids in one file
cad_sliver_cylinder       cad     2   1      0       exporter-style cylinder: caps fanned from
                                                     one rim vertex, 190:1 side triangles
cad_thin_tray             cad     2   1      0       tray with 1 mm walls and a rib: rims
                                                     narrower than a quad edge
cad_u_channel             cad     2   1      0       U channel of 1.5 mm sheet
cad_flush_fins            cad     2   1      0       plate with four 1.2 mm fins flush with its
                                                     front and back (coplanar comb faces)
scan_body                 scan    2   1      0       smooth body (torso, head, limbs), noise,
                                                     spikes
scan_body_holes           scan   -1   1      3       the body open at the soles and the crown
scan_body_yup             scan    2   1      0       the body rotated z-up to y-up
scan_body_remeshed        scan    2   1      0       the body meshed again on a rotated grid
                                                     (other connectivity), no noise
scan_potato               scan    2   1      0       deformed sphere, noise, spikes
scan_potato_hole          scan    1   1      1       the potato open (a disc)
scan_potato_milli         scan    2   1      0       the potato scaled by 1e-3
scan_potato_kilo          scan    2   1      0       the potato scaled by 1e3
scan_torus                scan    0   1      0       deformed noisy torus (genus 1)
scan_multipart            scan    6   3      0       the body and two balls beside it
tiny_two_triangles        tiny    3   2      1       a 2-triangle square beside a sphere
tiny_strip                tiny    1   1      1       a single open triangle strip (ribbon)
tiny_cube12               tiny    2   1      0       a 12-triangle cube, as CAD exports a box
========================  =====  ===  =====  ======  =========================================

Every scan has 600 to 20,000 faces; box-like CAD parts have a few dozen (as OpenSCAD
exports them), the others up to 20,000. manifold3d is
needed for the ``cad_`` and ``body`` entries (:func:`available` says which can be built).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = [
    "Entry",
    "ENTRIES",
    "names",
    "mesh",
    "available",
    "write_corpus",
    "load",
    "repaired_as_cli",
    "write_stl",
    "read_stl",
]

Mesh = tuple[np.ndarray, np.ndarray]


@dataclass(frozen=True)
class Entry:
    """One corpus mesh: how to build it and what it must be.

    Attributes
    ----------
    name, kind, fmt : str
        Kind ``"cad"``, ``"scan"`` or ``"tiny"``; file format ``"stl"``, ``"obj"``,
        ``"ply"`` or ``"off"``.
    chi, components, loops : int
        Euler characteristic, connected components and boundary loops.
    tests : str
        What the mesh tests (the table above).
    build : callable () -> (V, F)
    needs_manifold : bool
        Built with manifold3d.
    """

    name: str
    kind: str
    fmt: str
    chi: int
    components: int
    loops: int
    tests: str
    build: Callable[[], Mesh]
    needs_manifold: bool = False


# ---------------------------------------------------------------------------- small helpers
def _manifold():
    import manifold3d

    return manifold3d


def _from_manifold(solid) -> Mesh:
    """(V float64, F int64) of a manifold3d.Manifold."""
    m = solid.to_mesh64()
    V = np.ascontiguousarray(np.asarray(m.vert_properties)[:, :3], dtype=np.float64)
    return V, np.ascontiguousarray(np.asarray(m.tri_verts), dtype=np.int64)


def _concat(*meshes: Mesh) -> Mesh:
    """Disjoint union of meshes (one file, several parts)."""
    Vs, Fs, off = [], [], 0
    for V, F in meshes:
        Vs.append(V)
        Fs.append(F + off)
        off += V.shape[0]
    return np.concatenate(Vs), np.concatenate(Fs)


def _vertex_normals(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals, float64 (n, 3)."""
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N = np.zeros_like(V)
    for k in range(3):
        np.add.at(N, F[:, k], fn)
    return N / np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-300)


def _mean_edge(V: np.ndarray, F: np.ndarray) -> float:
    E = V[F[:, [1, 2, 0]]] - V[F]
    return float(np.linalg.norm(E, axis=2).mean())


def _scanify(V: np.ndarray, F: np.ndarray, seed: int, spikes: int = 4) -> np.ndarray:
    """Noise along the normals (σ = 0.1 mean edge) and ``spikes`` one-vertex spikes
    (1.2 mean edges out)."""
    rng = np.random.default_rng(seed)
    N = _vertex_normals(V, F)
    h = _mean_edge(V, F)
    W = V + N * (0.1 * h * rng.standard_normal(V.shape[0]))[:, None]
    idx = rng.choice(V.shape[0], spikes, replace=False)
    W[idx] += 1.2 * h * N[idx]
    return W


def _cut_holes(V: np.ndarray, F: np.ndarray, centres: np.ndarray, radius: float) -> Mesh:
    """Drop the faces touching a vertex within ``radius`` of a centre, then the unused
    vertices (a scan missing the parts the scanner could not see)."""
    d = np.linalg.norm(V[:, None, :] - centres[None, :, :], axis=2).min(axis=1)
    gone = d < radius
    keep = ~gone[F].any(axis=1)
    return _compact(V, F[keep])


def _compact(V: np.ndarray, F: np.ndarray) -> Mesh:
    used = np.unique(F)
    remap = np.full(V.shape[0], -1, np.int64)
    remap[used] = np.arange(used.size)
    return V[used], remap[F]


def _rotation(axis: tuple[float, float, float], degrees: float) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    t = math.radians(degrees)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(t) * K + (1 - math.cos(t)) * (K @ K)


# ---------------------------------------------------------------------------- CAD solids
def _circle(r: float, n: int, cx: float = 0.0, cy: float = 0.0, cw: bool = False) -> np.ndarray:
    t = 2 * np.pi * np.arange(n) / n
    if cw:
        t = -t
    return np.stack([cx + r * np.cos(t), cy + r * np.sin(t)], 1)


def open_box_two_holes() -> Mesh:
    """A random-part-like open box (106 × 48 × 31 mm, 3.55 mm walls and floor) with two
    floor holes: 100 mm faces beside the holes' small triangles (not in the corpus; the
    tests of the fold gate and of the remeshing use it)."""
    mf = _manifold()
    L, W, H, t = 106.48, 48.05, 31.08, 3.552
    inner = mf.Manifold.cube([L - 2 * t, W - 2 * t, H]).translate([t, t, t])
    box = mf.Manifold.cube([L, W, H]) - inner
    for d, x, y in ((8.34, 72.67, 22.99), (7.01, 76.02, 9.17)):
        box = box - mf.Manifold.cylinder(3 * H, d / 2, d / 2, 32).translate([x, y, -H])
    return _from_manifold(box)


def cad_box_hole() -> Mesh:
    mf = _manifold()
    box = mf.Manifold.cube([40.0, 30.0, 20.0], center=True)
    hole = mf.Manifold.cylinder(30.0, 8.0, circular_segments=160, center=True)
    return _from_manifold(box - hole)


def cad_l_bracket() -> Mesh:
    mf = _manifold()
    base = mf.Manifold.cube([60.0, 40.0, 6.0])
    wall = mf.Manifold.cube([6.0, 40.0, 50.0])
    hole1 = mf.Manifold.cylinder(20.0, 5.0, circular_segments=128).translate([35.0, 20.0, -5.0])
    hole2 = (
        mf.Manifold.cylinder(20.0, 5.0, circular_segments=128)
        .rotate([0.0, 90.0, 0.0])
        .translate([-5.0, 20.0, 32.0])
    )
    return _from_manifold((base + wall) - hole1 - hole2)


def cad_cylinder_boss() -> Mesh:
    mf = _manifold()
    disc = mf.Manifold.cylinder(10.0, 30.0, circular_segments=256)
    boss = mf.Manifold.cylinder(12.0, 7.0, circular_segments=96).translate([12.0, 5.0, 8.0])
    return _from_manifold(disc + boss)


def cad_plate_holes() -> Mesh:
    mf = _manifold()
    plate = mf.Manifold.cube([100.0, 60.0, 5.0])
    holes = [
        mf.Manifold.cylinder(20.0, 4.0 + 1.5 * (i % 2), circular_segments=96).translate(
            [20.0 + 30.0 * (i // 2), 15.0 + 30.0 * (i % 2), -5.0]
        )
        for i in range(6)
    ]
    return _from_manifold(mf.Manifold.batch_boolean([plate, *holes], mf.OpType.Subtract))


def cad_extrusion() -> Mesh:
    mf = _manifold()
    teeth, n = 24, 24 * 8
    t = 2 * np.pi * np.arange(n) / n
    r = 30.0 + 3.0 * (np.cos(teeth * t) > 0)  # square teeth: many short sharp edges
    outer = np.stack([r * np.cos(t), r * np.sin(t)], 1)
    bore = _circle(10.0, 128, cw=True)
    return _from_manifold(mf.Manifold.extrude(mf.CrossSection([outer, bore]), 15.0))


def cad_two_parts() -> Mesh:
    mf = _manifold()
    box = mf.Manifold.cube([20.0, 20.0, 10.0])
    knob = mf.Manifold.cylinder(20.0, 8.0, circular_segments=200).translate([45.0, 10.0, 0.0])
    box_hole = box - mf.Manifold.cylinder(4.0, 3.0, circular_segments=64).translate(
        [10.0, 10.0, 8.0]
    )  # a blind hole: still genus 0
    return _concat(_from_manifold(box_hole), _from_manifold(knob))


def cad_thin_tray() -> Mesh:
    """A tray 100 × 70 × 20 with 1 mm walls and floor and a 1 mm rib across."""
    mf = _manifold()
    box = mf.Manifold.cube([100.0, 70.0, 20.0])
    box = box - mf.Manifold.cube([98.0, 68.0, 20.0]).translate([1.0, 1.0, 1.0])
    return _from_manifold(box + mf.Manifold.cube([1.0, 68.0, 15.0]).translate([49.5, 1.0, 0.0]))


def cad_u_channel() -> Mesh:
    """A U channel 40 × 120 × 30 bent from 1.5 mm sheet."""
    mf = _manifold()
    cut = mf.Manifold.cube([37.0, 122.0, 30.0]).translate([1.5, -1.0, 1.5])
    return _from_manifold(mf.Manifold.cube([40.0, 120.0, 30.0]) - cut)


def cad_flush_fins() -> Mesh:
    """A plate 60 × 40 × 4 with four 1.2 mm fins 25 tall, flush with its front and back."""
    mf = _manifold()
    plate = mf.Manifold.cube([60.0, 40.0, 4.0])
    for i in range(4):
        plate = plate + mf.Manifold.cube([1.2, 40.0, 25.0]).translate([3.0 + 5.0 * i, 0.0, 4.0])
    return _from_manifold(plate)


def cad_sliver_cylinder(r: float = 10.0, h: float = 60.0, n: int = 200) -> Mesh:
    """A cylinder as a CAD exporter writes it: no vertex at the cap centres, each cap
    fanned from its rim vertex 0, each side quad split into two long triangles."""
    ring = np.concatenate([_circle(r, n), np.zeros((n, 1))], 1)
    V = np.concatenate([ring, ring + [0.0, 0.0, h]])
    i = np.arange(n)
    j = (i + 1) % n
    side = np.concatenate([np.stack([i, j, j + n], 1), np.stack([i, j + n, i + n], 1)])
    k = np.arange(1, n - 1)
    bottom = np.stack([np.zeros_like(k), k + 1, k], 1)
    top = np.stack([np.full_like(k, n), k + n, k + 1 + n], 1)
    return V, np.concatenate([side, bottom, top]).astype(np.int64)


def tiny_cube12() -> Mesh:
    V = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])
    F = np.array(
        [
            [0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
            [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3],
        ],
        dtype=np.int64,
    )  # fmt: skip
    return V * 25.0, F


# ---------------------------------------------------------------------------- scans
def _smin(a: float, b: float, k: float) -> float:
    """Polynomial smooth minimum of two distances (blend width k)."""
    h = max(k - abs(a - b), 0.0) / k
    return min(a, b) - h * h * k * 0.25


def _capsule(p, a, b, r: float) -> float:
    ab = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
    ap = (p[0] - a[0], p[1] - a[1], p[2] - a[2])
    t = (ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / (ab[0] ** 2 + ab[1] ** 2 + ab[2] ** 2)
    t = min(max(t, 0.0), 1.0)
    return math.dist(p, (a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2])) - r


def _ellipsoid(p, c, r) -> float:
    q = [(p[i] - c[i]) / r[i] for i in range(3)]
    return (math.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2) - 1.0) * min(r)


def _body_distance(x: float, y: float, z: float) -> float:
    """Signed distance (negative inside) of a standing figure, 1.7 units tall, z up."""
    p = (x, y, z)
    d = _ellipsoid(p, (0.0, 0.0, 1.1), (0.19, 0.12, 0.32))
    d = _smin(d, _ellipsoid(p, (0.0, 0.0, 1.55), (0.1, 0.11, 0.13)), 0.06)
    for s in (-1.0, 1.0):
        d = _smin(d, _capsule(p, (0.2 * s, 0.0, 1.33), (0.46 * s, 0.03, 0.93), 0.05), 0.06)
        d = _smin(d, _capsule(p, (0.09 * s, 0.0, 0.88), (0.12 * s, 0.02, 0.08), 0.07), 0.08)
        d = _smin(d, _ellipsoid(p, (0.12 * s, 0.07, 0.05), (0.05, 0.11, 0.04)), 0.05)  # feet
    return d


_BODY_BOX = np.array([[-0.56, -0.17, -0.05], [0.56, 0.23, 1.73]])  # the body's bbox + 0.05


def _body_sdf(x: float, y: float, z: float) -> float:
    """Inside-positive distance of the body; outside its box, the distance to the box."""
    lo, hi = _BODY_BOX
    dx = max(lo[0] - x, x - hi[0], 0.0)
    dy = max(lo[1] - y, y - hi[1], 0.0)
    dz = max(lo[2] - z, z - hi[2], 0.0)
    if dx or dy or dz:
        return -math.sqrt(dx * dx + dy * dy + dz * dz) - 0.05
    return -_body_distance(x, y, z)


def _body(edge: float = 0.03, rotation: np.ndarray | None = None) -> Mesh:
    """The body's level set (manifold3d marching tetrahedra), optionally meshed on a grid
    turned by ``rotation`` (the surface stays put, its connectivity changes)."""
    mf = _manifold()
    R = np.eye(3) if rotation is None else rotation
    corners = np.array([[a, b, c] for a in _BODY_BOX[:, 0] for b in _BODY_BOX[:, 1]
                        for c in _BODY_BOX[:, 2]]) @ R.T  # fmt: skip
    bounds = [*corners.min(0), *corners.max(0)]
    r = R.tolist()

    def inside(x: float, y: float, z: float) -> float:  # the body at R^T q
        return _body_sdf(
            r[0][0] * x + r[1][0] * y + r[2][0] * z,
            r[0][1] * x + r[1][1] * y + r[2][1] * z,
            r[0][2] * x + r[1][2] * y + r[2][2] * z,
        )

    V, F = _from_manifold(mf.Manifold.level_set(inside, bounds, edge))
    return V @ R, F


def scan_body() -> Mesh:
    V, F = _body()
    return _scanify(V, F, seed=1), F


def scan_body_holes() -> Mesh:
    V, F = mesh("scan_body")
    soles = [[0.12, 0.07, 0.0], [-0.12, 0.07, 0.0]]
    crown = [0.0, 0.0, 1.7]
    return _cut_holes(V, F, np.array([*soles, crown]), 0.05)


def scan_body_yup() -> Mesh:
    V, F = mesh("scan_body")
    return V @ _rotation((1.0, 0.0, 0.0), -90.0).T, F


def scan_body_remeshed() -> Mesh:
    return _body(edge=0.036, rotation=_rotation((1.0, 2.0, 3.0), 37.0))


def _icosahedron() -> Mesh:
    p = (1 + 5**0.5) / 2
    V = np.array(
        [[-1, p, 0], [1, p, 0], [-1, -p, 0], [1, -p, 0], [0, -1, p], [0, 1, p],
         [0, -1, -p], [0, 1, -p], [p, 0, -1], [p, 0, 1], [-p, 0, -1], [-p, 0, 1]], float
    )  # fmt: skip
    F = np.array(
        [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], np.int64
    )  # fmt: skip
    return V, F


def _geodesic(nu: int) -> Mesh:
    """Unit geodesic sphere of frequency ``nu``: each icosahedron face cut into nu^2
    triangles (20 nu^2 faces), vertices welded and pushed onto the sphere."""
    V0, F0 = _icosahedron()
    i, j = np.meshgrid(np.arange(nu + 1), np.arange(nu + 1), indexing="ij")
    keep = i + j <= nu
    i, j = i[keep], j[keep]
    lattice = {(a, b): n for n, (a, b) in enumerate(zip(i.tolist(), j.tolist(), strict=True))}
    tris = []
    for a in range(nu):
        for b in range(nu - a):
            tris.append((lattice[a, b], lattice[a + 1, b], lattice[a, b + 1]))
            if a + b < nu - 1:
                tris.append((lattice[a + 1, b], lattice[a + 1, b + 1], lattice[a, b + 1]))
    local = np.array(tris, np.int64)
    w = np.stack([nu - i - j, i, j], 1) / nu  # barycentric weights of the lattice points
    P = np.einsum("lk,fkd->fld", w, V0[F0]).reshape(-1, 3)
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    F = (local[None, :, :] + i.size * np.arange(F0.shape[0])[:, None, None]).reshape(-1, 3)
    V, inv = np.unique(np.round(P, 9), axis=0, return_inverse=True)
    return V / np.linalg.norm(V, axis=1, keepdims=True), inv.ravel()[F]


def _bumps(D: np.ndarray, seed: int, amplitude: float = 0.12) -> np.ndarray:
    """A smooth positive radial factor on unit directions D (n, 3)."""
    rng = np.random.default_rng(seed)
    axes = rng.standard_normal((6, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    freq = rng.uniform(1.5, 4.0, 6)
    phase = rng.uniform(0, 2 * np.pi, 6)
    return 1.0 + amplitude * np.sin(freq * (D @ axes.T) + phase).sum(1) / 2.0


def _potato_clean() -> Mesh:
    D, F = _geodesic(24)  # 11,520 faces
    V = D * _bumps(D, seed=7)[:, None] * [1.3, 1.0, 0.8]
    return V, F


def scan_potato() -> Mesh:
    V, F = _potato_clean()
    return _scanify(V, F, seed=2), F


def scan_potato_hole() -> Mesh:
    V, F = mesh("scan_potato")
    top = V[np.argmax(V[:, 2])]
    return _cut_holes(V, F, top[None, :], 0.35)


def scan_potato_milli() -> Mesh:
    V, F = mesh("scan_potato")
    return V * 1e-3, F


def scan_potato_kilo() -> Mesh:
    V, F = mesh("scan_potato")
    return V * 1e3, F


def torus_quads(n_major: int = 40, n_minor: int = 16) -> Mesh:
    """Quad torus R = 1, r = 0.35, outward normals: (V (n, 3), Q (q, 4))."""
    i, j = np.meshgrid(np.arange(n_major), np.arange(n_minor), indexing="ij")
    u, v = 2 * np.pi * i / n_major, 2 * np.pi * j / n_minor
    V = np.stack(
        [(1 + 0.35 * np.cos(v)) * np.cos(u), (1 + 0.35 * np.cos(v)) * np.sin(u), 0.35 * np.sin(v)],
        -1,
    ).reshape(-1, 3)
    a = (i * n_minor + j).ravel()
    b = (((i + 1) % n_major) * n_minor + j).ravel()
    c = (((i + 1) % n_major) * n_minor + (j + 1) % n_minor).ravel()
    d = (i * n_minor + (j + 1) % n_minor).ravel()
    return V, np.stack([a, b, c, d], 1)


def _torus_grid(n_major: int, n_minor: int) -> Mesh:
    V, Q = torus_quads(n_major, n_minor)
    return V, np.concatenate([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]])


def scan_torus() -> Mesh:
    V, F = _torus_grid(120, 40)
    V = V * _bumps(V / np.linalg.norm(V, axis=1, keepdims=True), seed=11, amplitude=0.06)[:, None]
    return _scanify(V, F, seed=3, spikes=3), F


def scan_multipart() -> Mesh:
    body = mesh("scan_body")
    D, Fb = _geodesic(8)
    ball1 = (D * 0.15 + [0.6, 0.3, 0.15], Fb)
    ball2 = (D * 0.1 + [-0.55, -0.3, 0.1], Fb)
    return _concat(body, ball1, ball2)


# ---------------------------------------------------------------------------- hostile tiny
def tiny_two_triangles() -> Mesh:
    D, F = _geodesic(16)
    square = np.array([[2.0, 0.0, 0.0], [2.2, 0.0, 0.0], [2.2, 0.2, 0.0], [2.0, 0.2, 0.0]])
    return _concat((D, F), (square, np.array([[0, 1, 2], [0, 2, 3]], np.int64)))


def tiny_strip(n: int = 300) -> Mesh:
    """A ribbon of 2(n-1) triangles along a helix, one triangle wide."""
    t = np.linspace(0.0, 4 * np.pi, n)
    centre = np.stack([np.cos(t), np.sin(t), 0.15 * t], 1)
    up = np.array([0.0, 0.0, 0.08])
    V = np.concatenate([centre - up, centre + up])
    i = np.arange(n - 1)
    F = np.concatenate([np.stack([i, i + 1, i + n], 1), np.stack([i + 1, i + 1 + n, i + n], 1)])
    return V, F.astype(np.int64)


# ---------------------------------------------------------------------------- the table
def _e(name, kind, fmt, chi, comps, loops, tests, build, manifold=False) -> Entry:
    return Entry(name, kind, fmt, chi, comps, loops, tests, build, manifold)


ENTRIES: dict[str, Entry] = {
    e.name: e
    for e in [
        _e("cad_box_hole", "cad", "stl", 0, 1, 0, "through hole", cad_box_hole, True),
        _e("cad_l_bracket", "cad", "stl", -2, 1, 0, "concave 90° edge", cad_l_bracket, True),
        _e("cad_cylinder_boss", "cad", "stl", 2, 1, 0, "boss", cad_cylinder_boss, True),
        _e("cad_plate_holes", "cad", "stl", -10, 1, 0, "genus 6", cad_plate_holes, True),
        _e("cad_extrusion", "cad", "stl", 0, 1, 0, "gear extrusion", cad_extrusion, True),
        _e("cad_two_parts", "cad", "stl", 4, 2, 0, "two solids", cad_two_parts, True),
        _e("cad_sliver_cylinder", "cad", "stl", 2, 1, 0, "fan caps", cad_sliver_cylinder),
        _e("cad_thin_tray", "cad", "stl", 2, 1, 0, "1 mm walls", cad_thin_tray, True),
        _e("cad_u_channel", "cad", "stl", 2, 1, 0, "1.5 mm sheet", cad_u_channel, True),
        _e("cad_flush_fins", "cad", "stl", 2, 1, 0, "flush thin fins", cad_flush_fins, True),
        _e("scan_body", "scan", "obj", 2, 1, 0, "noisy body", scan_body, True),
        _e("scan_body_holes", "scan", "ply", -1, 1, 3, "open body", scan_body_holes, True),
        _e("scan_body_yup", "scan", "obj", 2, 1, 0, "y up", scan_body_yup, True),
        _e("scan_body_remeshed", "scan", "off", 2, 1, 0, "remeshed", scan_body_remeshed, True),
        _e("scan_potato", "scan", "obj", 2, 1, 0, "noisy sphere", scan_potato),
        _e("scan_potato_hole", "scan", "ply", 1, 1, 1, "disc", scan_potato_hole),
        _e("scan_potato_milli", "scan", "ply", 2, 1, 0, "scale 1e-3", scan_potato_milli),
        _e("scan_potato_kilo", "scan", "off", 2, 1, 0, "scale 1e3", scan_potato_kilo),
        _e("scan_torus", "scan", "obj", 0, 1, 0, "genus 1 scan", scan_torus),
        _e("scan_multipart", "scan", "obj", 6, 3, 0, "three parts", scan_multipart, True),
        _e("tiny_two_triangles", "tiny", "obj", 3, 2, 1, "2-face part", tiny_two_triangles),
        _e("tiny_strip", "tiny", "obj", 1, 1, 1, "triangle strip", tiny_strip),
        _e("tiny_cube12", "tiny", "stl", 2, 1, 0, "12-triangle box", tiny_cube12),
    ]
}


def names(kind: str | None = None) -> list[str]:
    """Corpus names, optionally of one kind (``"cad"``, ``"scan"``, ``"tiny"``)."""
    return [n for n, e in ENTRIES.items() if kind is None or e.kind == kind]


def available(name: str) -> bool:
    """Whether ``name`` can be built here (manifold3d installed when needed)."""
    if not ENTRIES[name].needs_manifold:
        return True
    try:
        import manifold3d  # noqa: F401
    except ImportError:
        return False
    return True


_CACHE: dict[str, Mesh] = {}


def mesh(name: str) -> Mesh:
    """(V float64 (n, 3), F int64 (m, 3)) of corpus mesh ``name`` (fresh copies; built
    once per process)."""
    if name not in _CACHE:
        V, F = ENTRIES[name].build()
        _CACHE[name] = (np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int64))
    V, F = _CACHE[name]
    return V.copy(), F.copy()


# ---------------------------------------------------------------------------- files
_STL = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])


def write_stl(path: str | os.PathLike, V: np.ndarray, F: np.ndarray) -> None:
    """Write a binary STL triangle soup (float32, one facet normal per face)."""
    T = np.asarray(V, np.float64)[np.asarray(F)]
    n = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    rec = np.zeros(T.shape[0], _STL)
    rec["n"] = n
    rec["v"] = T
    header = b"wild corpus binary STL".ljust(80, b" ")
    with open(path, "wb") as fh:
        fh.write(header)
        fh.write(np.uint32(T.shape[0]).tobytes())
        fh.write(rec.tobytes())


def read_stl(path: str | os.PathLike) -> Mesh:
    """Read a binary STL soup and weld its corners at identical float32 coordinates.

    Returns
    -------
    V : float64 (n, 3)
    F : int64 (m, 3)
    """
    data = Path(path).read_bytes()
    count = int(np.frombuffer(data, "<u4", 1, 80)[0])
    if len(data) != 84 + 50 * count:
        raise ValueError(f"{path}: not a binary STL of {count} facets")
    rec = np.frombuffer(data, _STL, count, 84)
    corners = rec["v"].reshape(-1, 3)
    V, inv = np.unique(corners, axis=0, return_inverse=True)
    return V.astype(np.float64), inv.reshape(-1, 3).astype(np.int64)


def write_corpus(folder: str | os.PathLike, which: list[str] | None = None) -> dict[str, Path]:
    """Write the corpus meshes (all buildable ones, or ``which``) to ``folder`` in their
    natural formats; returns name -> path."""
    import fvf

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = {}
    for name in which if which is not None else [n for n in ENTRIES if available(n)]:
        e = ENTRIES[name]
        path = folder / f"{name}.{e.fmt}"
        V, F = mesh(name)
        if e.fmt == "stl":
            write_stl(path, V, F)
        else:
            fvf.write_mesh(path, V, F)
        out[name] = path
    return out


def load(path: str | os.PathLike) -> Mesh:
    """Read a corpus file as a user would, with :func:`fvf.read_mesh` (an STL soup is
    welded; the :class:`fvf.VerticesWeldedWarning` that says so is expected here)."""
    import warnings

    import fvf

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fvf.VerticesWeldedWarning)
        return fvf.read_mesh(Path(path))


def repaired_as_cli(V: np.ndarray, F: np.ndarray) -> Mesh:
    """(V, F) as ``fvf quad FILE`` meshes them: unchanged, or with zero-area faces (an
    exporter's T-junctions and collapsed slivers) repaired by :func:`fvf.repair_mesh`'s
    default steps, as ``fvf repair`` does."""
    import fvf

    try:
        fvf.TriMesh(V, F)
    except fvf.DegenerateFaceError:
        fixed = fvf.repair_mesh(V, F)
        return fixed.vertices, fixed.faces
    return V, F
