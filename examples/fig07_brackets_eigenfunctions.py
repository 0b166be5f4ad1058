"""Fig. 7: the vertex bracket D^V_{[v,w]} (eq. 46) and the mixed bracket D^F_{[v,w]} (eq. 54)
applied to Laplace–Beltrami eigenfunctions.

The roughness of each result is its Dirichlet ratio ‖∇g‖²/‖g‖² (fvf.bracket_smoothness);
the ratio vertex/mixed > 1 means the mixed bracket is the smoother one, the chapter's
claim. It holds on irregular meshes; on fairly regular real meshes the vertex bracket is
often the smoother by this measure (docs/notes.md). The script measures the given mesh
and, for comparison, a jittered (irregular) sphere.

    python examples/fig07_brackets_eigenfunctions.py [MESH] [--out DIR] [--no-pictures]
"""

from __future__ import annotations

import numpy as np
from _common import load_mesh, parse_args, picture, report, strip, unit_radius

import fvf


def rotation_fields(mesh: fvf.TriMesh) -> tuple[np.ndarray, np.ndarray]:
    """Two smooth fields: ambient rotations about z and about x, projected on the faces."""
    C = mesh.face_centroids
    v = mesh.project_tangent(np.cross([0.0, 0.0, 1.0], C))
    w = mesh.project_tangent(np.cross([1.0, 0.0, 0.0], C) + [0.0, 0.3, 0.0])
    return v, w


def measure(mesh: fvf.TriMesh, k: int = 12):
    """Roughness ratios vertex/mixed for eigenfunctions 1..k-1, and the two results."""
    basis = fvf.SpectralBasis(mesh, k)
    v, w = rotation_fields(mesh)
    phis = basis.eigenvectors[:, 1:]  # (n, k-1), without the constant
    rough_V, rough_F = fvf.bracket_smoothness(mesh, v, w, phis)
    phi = phis[:, 4]
    return rough_V / rough_F, fvf.bracket_V(mesh, v, w) @ phi, fvf.bracket_F(mesh, v, w) @ phi


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    mesh = unit_radius(load_mesh(args.mesh))
    ratios, out_V, out_F = measure(mesh)
    print("roughness of D^V_[v,w] phi / roughness of D^F_[v,w] phi, eigenfunctions 1..11")
    report("ratios", np.round(ratios, 3).tolist())
    report("median ratio on this mesh", float(np.median(ratios)))
    sphere = fvf.jittered_sphere(3, 0.3, seed=3)
    report("median ratio on a jittered sphere (642 vertices)", float(np.median(measure(sphere)[0])))

    def draw(viz, path):
        panels = []
        for values, name in [(out_V, "vertex"), (out_F, "mixed")]:
            top = float(np.percentile(np.abs(values), 98))  # a few vertices are far out
            panels.append(
                dict(function=values, clim=(-top, top), cmap="RdBu_r", title=f"{name} bracket")
            )
        strip(viz, mesh, path, panels)

    picture(args, "fig07_brackets.png", draw)


if __name__ == "__main__":
    main()
