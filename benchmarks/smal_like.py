r"""A generated stand-in for SMAL_r: quadrupeds of different "species" with ground-truth maps.

Run from the repository root::

    .venv/bin/python benchmarks/smal_like.py --out DIR [--n-species 8] [--seed 0]
        [--n-pairs 10] [--template-vertices 5000]
    .venv/bin/python benchmarks/bench_correspondence.py --dataset DIR \
        --pairs-file DIR/pairs.txt

It writes the layout of ``correspondence_dataset.py`` (``DIR/shapes/NAME.off``,
``DIR/corres/NAME.vts``, 1-based), ``DIR/pairs.txt`` (pairs of different species),
``DIR/template.off`` and ``DIR/species.json`` (each species' parameters). This is not
SMAL_r (the SMAL animals remeshed): it is made here, so that the protocol can be run on
animals of different proportions when SMAL_r is not at hand.

* **Template.** A quadruped, x forward and z up: the level set of a smooth union
  (polynomial smooth minimum) of a body ellipsoid, a neck capsule, a head ellipsoid, two
  ear ellipsoids, a tail capsule and four legs of two capsules each (hip to knee, knee to
  foot), meshed by manifold3d's marching tetrahedra and remeshed isotropically (pymeshlab)
  to about ``--template-vertices`` vertices.
* **Species.** The template's vertices moved by a smooth space deformation, a blend of one
  affine map per part,

  .. math::  \phi(p) = \sum_j w_j(p)\,(A_j p + b_j), \qquad
             w_j(p) = \frac{e^{-d_j(p)/\tau}}{\sum_l e^{-d_l(p)/\tau}},

  d_j the distance to part j's primitive. The maps form a chain from the body (elongation
  along x, girth): each part is scaled along its axis (leg length, neck and tail length)
  and across it (leg thickness; head and ears as a whole) about its joint (hip, knee,
  neck base, head, tail base, ear base), turned there by a pose rotation (hip swing and
  splay, knee bend, neck pitch and yaw, head pitch, tail pitch and yaw) and attached
  where its parent's map sends the joint, so neighbouring maps agree at the joints.
  Every parameter is drawn from a seeded generator; a draw whose deformed mesh intersects
  itself (pymeshlab's face-face test) is drawn again.
* **Remeshing.** Each species is remeshed isotropically (pymeshlab) to a vertex count
  drawn between 3,000 and 6,000 (another connectivity); its ``.vts`` names, for every
  template vertex, the remeshed vertex nearest to where the deformation sent it.

Every written mesh is checked to be one closed manifold component
(:func:`fvf.mesh.mesh_report`) without self-intersections. manifold3d and pymeshlab (the
``[remesh]`` extra) are needed; without them the script says so and exits with status 2.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

import fvf

Mesh = tuple[np.ndarray, np.ndarray]

#: Blend width τ of the smooth union (template) and of the part weights (deformation).
SMOOTH_UNION = 0.06
WEIGHT_WIDTH = 0.04
#: Vertex counts of the remeshed species are drawn in this range.
SPECIES_VERTICES = (3000, 6000)
#: pymeshlab's isotropic remeshing at the equilateral edge length for n vertices gives
#: about 0.93 n vertices on these shapes: the edge asked is shortened by the square root.
REMESH_YIELD = 0.965


# ---------------------------------------------------------------------------- the template
@dataclass(frozen=True)
class Part:
    """One primitive: an ellipsoid (``a`` centre, ``radii``) or a capsule (segment ``a`` to
    ``b``, radius ``radii[0]``)."""

    name: str
    a: tuple[float, float, float]
    radii: tuple[float, ...]
    b: tuple[float, float, float] | None = None


def _legs() -> list[Part]:
    out = []
    for end, x in (("front", 0.35), ("back", -0.38)):
        for side, y in (("left", 0.14), ("right", -0.14)):
            out.append(Part(f"{end}_{side}_upper", (x, y, 0.85), (0.075,), (x, y, 0.45)))
            out.append(Part(f"{end}_{side}_lower", (x, y, 0.45), (0.06,), (x, y, 0.08)))
    return out


PARTS: tuple[Part, ...] = (
    Part("body", (0.0, 0.0, 1.0), (0.55, 0.24, 0.24)),
    Part("neck", (0.42, 0.0, 1.08), (0.09,), (0.72, 0.0, 1.42)),
    Part("head", (0.84, 0.0, 1.48), (0.17, 0.1, 0.1)),
    Part("ear_left", (0.78, 0.07, 1.6), (0.04, 0.035, 0.08)),
    Part("ear_right", (0.78, -0.07, 1.6), (0.04, 0.035, 0.08)),
    Part("tail", (-0.5, 0.0, 1.08), (0.045,), (-0.95, 0.0, 0.85)),
    *_legs(),
)
_BOX = np.array([[-1.05, -0.34, -0.03], [1.08, 0.34, 1.75]])


def part_distances(P: np.ndarray) -> np.ndarray:
    """Signed distance (negative inside; ellipsoids approximately) from each point to each
    part, float64 (n, len(PARTS)); P float64 (n, 3)."""
    D = np.empty((P.shape[0], len(PARTS)))
    for j, part in enumerate(PARTS):
        a = np.asarray(part.a)
        if part.b is None:
            r = np.asarray(part.radii)
            D[:, j] = (np.linalg.norm((P - a) / r, axis=1) - 1.0) * r.min()
        else:
            ab = np.asarray(part.b) - a
            t = np.clip((P - a) @ ab / (ab @ ab), 0.0, 1.0)
            D[:, j] = np.linalg.norm(P - a - t[:, None] * ab, axis=1) - part.radii[0]
    return D


def _smooth_union(D: np.ndarray, k: float = SMOOTH_UNION) -> np.ndarray:
    """Polynomial smooth minimum over the columns of D (blend width k), float64 (n,)."""
    d = D[:, 0]
    for j in range(1, D.shape[1]):
        h = np.maximum(k - np.abs(d - D[:, j]), 0.0) / k
        d = np.minimum(d, D[:, j]) - h * h * k * 0.25
    return d


def _level_set(edge: float) -> Mesh:
    """The template surface by manifold3d's marching tetrahedra at ``edge``: the smooth
    union is sampled on a grid of spacing edge / 2 and interpolated trilinearly."""
    import manifold3d

    h = 0.5 * edge
    axes = [np.arange(lo - h, hi + 2 * h, h) for lo, hi in _BOX.T]
    G = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    shape = tuple(len(a) for a in axes)
    inside = (-_smooth_union(part_distances(G))).reshape(shape)
    vals = inside.ravel().tolist()
    s0, s1 = shape[1] * shape[2], shape[2]
    lo = [float(a[0]) for a in axes]
    top = [n - 2 for n in shape]

    def f(x: float, y: float, z: float) -> float:
        u, v, w = (x - lo[0]) / h, (y - lo[1]) / h, (z - lo[2]) / h
        i, j = min(max(int(u), 0), top[0]), min(max(int(v), 0), top[1])
        k = min(max(int(w), 0), top[2])
        u, v, w = u - i, v - j, w - k
        c = i * s0 + j * s1 + k
        out = 0.0
        for di, wi in ((0, 1 - u), (s0, u)):
            for dj, wj in ((0, 1 - v), (s1, v)):
                out += wi * wj * ((1 - w) * vals[c + di + dj] + w * vals[c + di + dj + 1])
        return out

    bounds = [*(_BOX[0] - 0.02), *(_BOX[1] + 0.02)]
    m = manifold3d.Manifold.level_set(f, bounds, edge).to_mesh64()
    V = np.asarray(m.vert_properties, dtype=np.float64)[:, :3]
    return np.ascontiguousarray(V), np.asarray(m.tri_verts, dtype=np.int64)


def _edge_for(area: float, n_vertices: int) -> float:
    """Edge length of equilateral triangles tiling ``area`` with about ``n_vertices``
    vertices (a closed genus-0 mesh has twice as many faces)."""
    return float(np.sqrt(2.0 * area / (np.sqrt(3.0) * n_vertices)))


def remesh(V: np.ndarray, F: np.ndarray, n_vertices: int) -> Mesh:
    """Isotropic remeshing (pymeshlab) to about ``n_vertices`` vertices."""
    import pymeshlab

    area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    edge = _edge_for(float(area.sum()), n_vertices) * REMESH_YIELD
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V, F.astype(np.int32)))
    ms.meshing_isotropic_explicit_remeshing(
        targetlen=pymeshlab.PureValue(edge), maxsurfdist=pymeshlab.PureValue(0.3 * edge),
        iterations=12, featuredeg=180.0,
    )  # fmt: skip
    m = ms.current_mesh()
    V2, F2 = np.asarray(m.vertex_matrix(), np.float64), np.asarray(m.face_matrix(), np.int64)
    used = np.unique(F2)
    remap = np.full(V2.shape[0], -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    return np.ascontiguousarray(V2[used]), remap[F2]


def template(n_vertices: int = 5000) -> Mesh:
    """The quadruped template (about ``n_vertices`` vertices), float64 (n, 3), int64 (m, 3)."""
    V, F = _level_set(_edge_for(3.2, n_vertices))
    return remesh(V, F, n_vertices)


# ---------------------------------------------------------------------------- the species
def _rot(axis, degrees: float) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    t = np.radians(degrees)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * (K @ K)


def _along(axis, length: float, across: float) -> np.ndarray:
    """Scaling by ``length`` along ``axis`` and ``across`` perpendicular to it, (3, 3)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    return across * np.eye(3) + (length - across) * np.outer(a, a)


def species_parameters(rng: np.random.Generator) -> dict[str, float]:
    """One species' proportions (factors) and pose (degrees), drawn from ``rng``."""
    u = rng.uniform
    p = dict(
        elongation=u(0.8, 1.35), girth=u(0.85, 1.2), leg_length=u(0.7, 1.35),
        leg_thickness=u(0.75, 1.3), front_back=u(0.9, 1.1), neck_length=u(0.6, 1.6),
        head_size=u(0.75, 1.35), ear_size=u(0.6, 1.5), tail_length=u(0.5, 1.8),
        neck_pitch=u(-30, 25), neck_yaw=u(-20, 20), head_pitch=u(-20, 20),
        tail_pitch=u(-30, 30), tail_yaw=u(-30, 30),
    )  # fmt: skip
    for leg in ("front_left", "front_right", "back_left", "back_right"):
        p[f"{leg}_swing"] = u(-22, 22)
        p[f"{leg}_splay"] = u(-4, 4)
        p[f"{leg}_knee"] = u(0, 30)
    return p


def part_maps(p: dict[str, float]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each part's affine map (A (3, 3), b (3,)): x -> A x + b, chained from the body."""
    by = {part.name: part for part in PARTS}
    c = np.asarray(by["body"].a)
    maps = {"body": (np.diag([p["elongation"], p["girth"], p["girth"]]), None)}
    maps["body"] = (maps["body"][0], c - maps["body"][0] @ c)

    def attach(name, parent, joint, M):  # M about ``joint``, joint sent where parent sends it
        A, b = maps[parent]
        joint = np.asarray(joint)
        maps[name] = (M, A @ joint + b - M @ joint)

    for leg in ("front_left", "front_right", "back_left", "back_right"):
        up, lo = by[f"{leg}_upper"], by[f"{leg}_lower"]
        side = 1.0 if "left" in leg else -1.0
        R = _rot((0, 1, 0), p[f"{leg}_swing"]) @ _rot((1, 0, 0), side * p[f"{leg}_splay"])
        length = p["leg_length"] * (p["front_back"] if "front" in leg else 1 / p["front_back"])
        S = _along((0, 0, 1), length, p["leg_thickness"])
        attach(up.name, "body", up.a, R @ S)
        knee = -1.0 if "front" in leg else 1.0  # front knees bend the foot back
        attach(lo.name, up.name, lo.a, R @ _rot((0, 1, 0), knee * p[f"{leg}_knee"]) @ S)
    neck = by["neck"]
    axis = np.subtract(neck.b, neck.a)
    R_neck = _rot((0, 0, 1), p["neck_yaw"]) @ _rot((0, 1, 0), -p["neck_pitch"])
    attach("neck", "body", neck.a, R_neck @ _along(axis, p["neck_length"], 1.0))
    R_head = R_neck @ _rot((0, 1, 0), -p["head_pitch"])
    attach("head", "neck", neck.b, p["head_size"] * R_head)
    for ear in ("ear_left", "ear_right"):
        base = np.asarray(by[ear].a) - np.array([0.0, 0.0, 0.06])
        attach(ear, "head", base, p["head_size"] * R_head @ _along((0, 0, 1), p["ear_size"], 1.0))
    tail = by["tail"]
    R_tail = _rot((0, 0, 1), p["tail_yaw"]) @ _rot((0, 1, 0), p["tail_pitch"])
    S_tail = _along(np.subtract(tail.b, tail.a), p["tail_length"], 1.0)
    attach("tail", "body", tail.a, R_tail @ S_tail)
    return maps


def deform(V: np.ndarray, p: dict[str, float], width: float = WEIGHT_WIDTH) -> np.ndarray:
    """The template's vertices V float64 (n, 3) moved by the species' blend of part maps
    (module docstring), float64 (n, 3)."""
    D = part_distances(V)
    W = np.exp(-(D - D.min(axis=1, keepdims=True)) / width)
    W /= W.sum(axis=1, keepdims=True)
    maps = part_maps(p)
    out = np.zeros_like(V)
    for j, part in enumerate(PARTS):
        A, b = maps[part.name]
        out += W[:, j : j + 1] * (V @ A.T + b)
    return out


# ---------------------------------------------------------------------------- checks
def self_intersecting_faces(V: np.ndarray, F: np.ndarray) -> int:
    """How many faces intersect another face (pymeshlab's face-face test)."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V, F.astype(np.int32)))
    ms.compute_selection_by_self_intersections_per_face()
    return int(ms.current_mesh().selected_face_number())


def check_mesh(V: np.ndarray, F: np.ndarray, what: str) -> None:
    """Raise ValueError unless (V, F) is one closed manifold component, positively
    oriented (positive volume), without self-intersections."""
    rep = fvf.mesh.mesh_report(V, F)
    topo = (rep.get("manifold"), rep.get("closed"), rep.get("components"))
    if not rep["ok"] or topo != (True, True, 1):
        raise ValueError(f"{what}: not one closed manifold component: {rep['problems']} {topo}")
    volume = np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum() / 6
    if volume <= 0:
        raise ValueError(f"{what}: volume {volume:.3g} is not positive")
    n = self_intersecting_faces(V, F)
    if n:
        raise ValueError(f"{what}: {n} self-intersecting faces")


# ---------------------------------------------------------------------------- the set
@dataclass(frozen=True)
class Species:
    """One written species: its name, its parameters (:func:`species_parameters`), where
    the deformation sent the template's vertices (float64 (t, 3)), and its remeshed
    surface as written (float64 (n, 3), int64 (m, 3))."""

    name: str
    parameters: dict[str, float]
    deformed: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray


def make_smal_like(
    folder: str | Path,
    n_species: int = 8,
    seed: int = 0,
    n_pairs: int = 10,
    template_vertices: int = 5000,
    species_vertices: tuple[int, int] = SPECIES_VERTICES,
    max_tries: int = 20,
) -> list[Species]:
    """Write the set (module docstring) to ``folder``; returns the species.

    Raises
    ------
    ValueError
        A mesh failed :func:`check_mesh`, or no self-intersection-free draw was found for
        a species in ``max_tries`` draws.
    """
    folder = Path(folder)
    for sub in ("shapes", "corres"):
        (folder / sub).mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    T, F = template(template_vertices)
    check_mesh(T, F, "template")
    fvf.write_mesh(folder / "template.off", T, F)
    out: list[Species] = []
    for i in range(n_species):
        for _ in range(max_tries):
            params = species_parameters(rng)
            X = deform(T, params)
            if self_intersecting_faces(X, F) == 0:
                break
        else:
            raise ValueError(f"species {i}: every draw intersects itself")
        V2, F2 = remesh(X, F, int(rng.integers(*species_vertices)))
        perm = rng.permutation(len(V2))  # new vertex i = remeshed vertex perm[i]
        V2, F2 = V2[perm], np.argsort(perm)[F2]
        name = f"species_{i:02d}"
        check_mesh(V2, F2, name)
        nearest = cKDTree(V2).query(X)[1]
        fvf.write_mesh(folder / "shapes" / f"{name}.off", V2, F2)
        np.savetxt(folder / "corres" / f"{name}.vts", nearest + 1, fmt="%d")
        out.append(Species(name, params, X, V2, F2))
    pairs = list(itertools.combinations([sp.name for sp in out], 2))
    chosen = rng.permutation(len(pairs))[:n_pairs]
    lines = [" ".join(pairs[k][:: rng.choice([1, -1])]) for k in sorted(chosen)]
    (folder / "pairs.txt").write_text("\n".join(lines) + "\n")
    table = {sp.name: {k: round(v, 4) for k, v in sp.parameters.items()} for sp in out}
    (folder / "species.json").write_text(json.dumps(table, indent=1) + "\n")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, help="the folder to write")
    ap.add_argument("--n-species", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n-pairs", type=int, default=10)
    ap.add_argument("--template-vertices", type=int, default=5000)
    args = ap.parse_args(argv)
    try:
        import manifold3d  # noqa: F401
        import pymeshlab  # noqa: F401
    except ImportError as exc:
        print(f"smal_like.py needs manifold3d and pymeshlab (pip install 'fvf[remesh]'): {exc}")
        return 2
    species = make_smal_like(
        args.out, args.n_species, args.seed, args.n_pairs, args.template_vertices
    )
    for sp in species:
        print(f"{sp.name}: {len(sp.vertices)} vertices")
    print(f"wrote {len(species)} species and pairs.txt to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
