"""Fig. 9: the commutator field u = D^F_{[v,w]} X of two fields (§4.3.3), a vertex field.

It is approximately tangent (the normal part is printed) and, the chapter claims, robust
to the tessellation: the same two smooth fields on a regular and on an irregular sphere
give commutator fields that fit the same smooth field (degree-2 polynomial fit; the
relative difference of the fitted coefficients is printed).

    python examples/fig09_commutator_field.py [MESH] [--out DIR] [--no-pictures]
"""

from __future__ import annotations

import numpy as np
from _common import l2, load_mesh, parse_args, picture, report, unit_radius

import fvf


def smooth_fields(mesh: fvf.TriMesh) -> tuple[np.ndarray, np.ndarray]:
    """Two smooth non-commuting fields: distorted rotations, projected on the faces."""
    C = mesh.face_centroids
    v = mesh.project_tangent(np.cross([0.0, 0.0, 1.0], C) + 0.5 * C[:, :1] * [0.0, 1.0, 0.0])
    w = mesh.project_tangent(np.cross([1.0, 0.0, 0.0], C) + 0.3 * C[:, 1:2] ** 2 * [0, 0, 1.0])
    return v, w


def polynomial_fit(mesh: fvf.TriMesh, u: np.ndarray) -> np.ndarray:
    """A_V-weighted least-squares fit of u (n, 3) by quadratic polynomials: (10, 3)."""
    X = mesh.vertices
    P = np.column_stack([np.ones(len(X)), X, X**2, X[:, [0]] * X[:, [1, 2]], X[:, [1]] * X[:, [2]]])
    sw = np.sqrt(mesh.vertex_areas)[:, None]
    return np.linalg.lstsq(sw * P, sw * u, rcond=None)[0]


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    mesh = unit_radius(load_mesh(args.mesh))
    v, w = smooth_fields(mesh)
    u = fvf.commutator_field(mesh, v, w)  # (n, 3)
    normals = fvf.face_to_vertex(mesh) @ mesh.face_normals
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    normal_part = (u * normals).sum(1, keepdims=True) * normals
    size = np.linalg.norm(u, axis=1)
    print("commutator field u = D^F_[v,w] X on this mesh")
    report("mean |u|, max |u|", [round(float(size.mean()), 4), round(float(size.max()), 4)])
    if l2(mesh, u) > 0:
        report("relative normal part ||u.N|| / ||u||", l2(mesh, normal_part) / l2(mesh, u))
    else:
        print("  u = 0: the two fields commute on this mesh")

    regular, irregular = fvf.icosphere(4), fvf.jittered_sphere(4, 0.35, seed=9)
    fits = [
        polynomial_fit(s, fvf.commutator_field(s, *smooth_fields(s))) for s in (regular, irregular)
    ]
    diff = np.linalg.norm(fits[0] - fits[1]) / np.linalg.norm(fits[0])
    print("tessellation robustness (unit sphere, 2562 vertices, regular vs jittered)")
    report("relative difference of the fitted smooth fields", float(diff))

    def draw(viz, path):
        on_faces = mesh.project_tangent(fvf.vertex_to_face(mesh) @ u)  # (m, 3), for arrows
        unit = on_faces / np.maximum(np.linalg.norm(on_faces, axis=1, keepdims=True), 1e-300)
        viz.render(
            mesh,
            path,
            function=size,
            clim=(0.0, float(np.percentile(size, 98))),
            field=unit,  # directions; the colour is |u|
            texture=viz.lic_texture(mesh, on_faces),
            title="commutator field D^F_[v,w] X (direction; colour |u|)",
            colorbar_label="|u|",
            cmap="magma",
        )

    picture(args, "fig09_commutator_field.png", draw)


if __name__ == "__main__":
    main()
