"""Fig. 11: as-commuting-as-possible (ACAP) fields of v and their singularities (§4.4.2).

The smallest eigenvectors of ad_vᵀ ad_v + λ L_conn on tangent fields (fvf.acap_fields) are
the smooth fields that commute best with v. The script prints each one's bracket energy
‖ad_v u‖² (against a random smooth gradient's, both of unit L2 norm) and its singularities:
their indices sum to the Euler characteristic (Poincaré–Hopf).

    python examples/fig11_acap.py [MESH] [--out DIR] [--no-pictures]
"""

from __future__ import annotations

import numpy as np
from _common import l2, load_mesh, parse_args, picture, report, strip, unit_radius

import fvf


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    mesh = unit_radius(load_mesh(args.mesh))
    X = mesh.vertices
    v = fvf.rotate(mesh, fvf.gradient(mesh, X[:, 1]))  # J grad y
    v /= l2(mesh, v)
    A = fvf.ad(mesh, v)  # (3n, 3m)
    a3 = np.repeat(mesh.vertex_areas, 3)

    def energy(u):  # ‖ad_v u‖² / ‖u‖², A_V-weighted
        return float(a3 @ (A @ u.ravel()) ** 2) / l2(mesh, u) ** 2

    rng = np.random.default_rng(0)
    random_gradient = fvf.gradient(mesh, np.sin(3 * X @ rng.standard_normal(3)))
    fields = fvf.acap_fields(mesh, v, 1e-2, 2)  # (2, m, 3)
    print("ACAP fields of v = J grad y (lambda = 1e-2)")
    report("bracket energy of v itself", energy(v))
    report("bracket energy of a random smooth gradient", energy(random_gradient))
    singular = []
    for i, u in enumerate(fields):
        ids, index = fvf.singularities(mesh, u)
        singular.append((ids, index))
        report(f"field {i} bracket energy", energy(u))
        report(
            f"field {i} singularities, index sum (chi = {mesh.euler_characteristic})",
            [len(ids), int(index.sum())],
        )

    def draw(viz, path):
        panels = []
        for i, (u, (ids, index)) in enumerate(zip(fields, singular, strict=True)):
            where = fvf.singularity_positions(mesh, ids)
            panels.append(
                dict(
                    texture=viz.lic_texture(mesh, u),
                    singularities=(where, index),
                    title=f"ACAP field {i} (LIC) and singularities",
                )
            )
        strip(viz, mesh, path, panels)

    picture(args, "fig11_acap.png", draw)


if __name__ == "__main__":
    main()
