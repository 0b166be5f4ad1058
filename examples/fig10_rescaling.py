"""Fig. 10: commutation-guided rescaling (eqs. 65–66).

Find f minimizing ½‖[v, f u]‖² + (α/2)‖∇f‖² with ∫f² = 1 (fvf.rescale), then compare the
bracket of v with u and with the rescaled f u, both scaled to the same L2 size: the
bracket becomes smaller and more evenly spread (its coefficient of variation drops).

    python examples/fig10_rescaling.py [MESH] [--out DIR] [--no-pictures]
"""

from __future__ import annotations

import numpy as np
from _common import l2, load_mesh, parse_args, picture, report, strip, unit_radius

import fvf


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    mesh = unit_radius(load_mesh(args.mesh))
    X, a = mesh.vertices, mesh.vertex_areas
    v = fvf.rotate(mesh, fvf.gradient(mesh, X[:, 1]))  # J grad y
    u = fvf.gradient(mesh, X[:, 0] + X[:, 2] ** 2)
    alpha = 10.0

    f = fvf.rescale(mesh, v, u, alpha)  # (n,), A_V-normalized
    fu = (fvf.vertex_to_face(mesh) @ f)[:, None] * u
    fu *= l2(mesh, u) / l2(mesh, fu)  # same L2 size as u

    def cv(b):  # coefficient of variation of a pointwise norm (n,)
        mean = (a @ b) / a.sum()
        return float(np.sqrt(a @ (b - mean) ** 2 / a.sum()) / mean)

    before, after = fvf.bracket_norm(mesh, v, u), fvf.bracket_norm(mesh, v, fu)
    print(f"rescaling u to commute with v (alpha = {alpha})")
    report("bracket L2 after / before", float(np.sqrt(a @ after**2) / np.sqrt(a @ before**2)))
    report("coefficient of variation after / before", cv(after) / cv(before))
    report("range of f", [round(float(f.min()), 4), round(float(f.max()), 4)])

    def draw(viz, path):
        clim = (0.0, float(np.percentile(before, 98)))  # same colour scale for both
        panels = [
            dict(function=before, clim=clim, title="|[v, u]|", cmap="magma"),
            dict(function=after, clim=clim, title="|[v, f u]|, rescaled", cmap="magma"),
            dict(function=f, title="the rescaling f"),
        ]
        strip(viz, mesh, path, panels)

    picture(args, "fig10_rescaling.png", draw)


if __name__ == "__main__":
    main()
