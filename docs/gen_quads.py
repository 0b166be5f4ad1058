"""Regenerate the pictures of ``docs/quads.md`` (needs the ``[viz]`` extra).

    python docs/gen_quads.py

Spot (built in) and Bob (CC0, ``../shared/meshes/bob_tri.obj`` when present) are quad meshed
with the default curvature-aligned field; a rounded cube shows the eight valence-3
corners; a mirror-symmetric mesh shows the symmetric quads. Pictures go to docs/quads/.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

import fvf
import fvf.viz

OUT = Path(__file__).resolve().parent / "quads"
SHARED = Path(
    os.environ.get("FVF_SHARED_MESHES", Path(__file__).resolve().parents[2] / "shared" / "meshes")
)


def rounded_cube(subdivisions: int = 4, p: float = 8.0) -> fvf.TriMesh:
    s = fvf.icosphere(subdivisions)
    X = s.vertices / (np.abs(s.vertices) ** p).sum(axis=1, keepdims=True) ** (1 / p)
    return fvf.TriMesh(X, s.faces)


def picture(name: str, mesh: fvf.TriMesh, target: int, view=None) -> None:
    made = fvf.quad_mesh(mesh, target_faces=target)
    V, Q, p, q = made.vertices, made.quads, made.parameterizations[0], made.quality
    kw = {"size": (640, 480)} | ({"view": view} if view else {})
    fvf.viz.render_quads(
        V,
        Q,
        OUT / f"{name}_quads.png",
        title=f"{name}: {len(Q)} quads, {q.n_irregular} irregular vertices",
        **kw,
    )
    fvf.viz.render_checkerboard(
        mesh,
        p.uv,
        OUT / f"{name}_checker.png",
        subdivisions=3,
        title=f"{name}: seamless parameterization ({p.singular.size} cones)",
        **kw,
    )
    print(name, len(Q), "quads", q.n_irregular, "irregular", p.singular.size, "cones")


def symmetric_pictures() -> None:
    """A mirror-symmetric peanut: quads of a turned (non-symmetric) and of the symmetrized
    field."""
    from scipy.spatial import cKDTree

    s = fvf.icosphere(4)
    X = s.vertices
    w = 0.6 + 0.5 * X[:, 0] ** 2
    Y = np.stack([1.6 * X[:, 0], X[:, 1] * w, X[:, 2] * w + 0.2 * X[:, 1]], axis=1)
    mesh = fvf.TriMesh(Y, s.faces)

    def mirror(P):
        return P * np.array([-1.0, 1.0, 1.0])

    _, pi = cKDTree(Y).query(mirror(Y))
    # the default field is already nearly symmetric: turn it by a non-symmetric angle
    u0 = fvf.param.default_cross_field(mesh)
    theta = 0.35 + 0.3 * mesh.face_centroids[:, 0]
    u = np.cos(theta)[:, None] * u0 + np.sin(theta)[:, None] * np.cross(mesh.face_normals, u0)
    for name, field in (("plain", u), ("symmetric", fvf.symmetrize_cross_field(mesh, u, pi))):
        V, Q = fvf.quad_mesh(mesh, target_faces=800, field=field)
        med, worst = fvf.quad_symmetry_error(V, Q, mirror)
        fvf.viz.render_quads(
            V,
            Q,
            OUT / f"peanut_{name}.png",
            size=(640, 400),
            view=(0, 10),
            title=f"{'turned' if name == 'plain' else name} field: mirror error median "
            f"{med:.3f}, max {worst:.3f} edges",
        )
        print("peanut", name, med, worst)


def main() -> None:
    OUT.mkdir(exist_ok=True)
    picture("spot", fvf.spot(), 1500)
    picture("cube", rounded_cube(4), 600, view=(35, 30))
    symmetric_pictures()
    bob = SHARED / "bob_tri.obj"
    if bob.exists():
        picture("bob", fvf.TriMesh(*fvf.read_mesh(bob)), 1500)
    else:
        print("bob_tri.obj not found; skipped", file=sys.stderr)


if __name__ == "__main__":
    main()
