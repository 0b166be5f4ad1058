"""Fig. 12: interpolation of two fields along a flow (eq. 68) versus their average.

u_0 and u_1 are gradients of two bumps centred at a_0 and a_1 on the "equator" of the
mesh (scaled to unit radius); v rotates about z by the angle θ between them. The average
(u_0 + u_1)/2 has two maxima and a saddle between them; the interpolant
u_½ = ½ Ad_{Φ_{v,½}} u_0 + ½ Ad_{Φ_{v,−½}} u_1 has one maximum that moved along the flow
line. Default mesh: the unit icosphere of level 4 (2562 vertices), where the picture is
exact; on other meshes the counts are printed as measured.

    python examples/fig12_interpolation.py [MESH] [--out DIR] [--no-pictures]
"""

from __future__ import annotations

import numpy as np
from _common import parse_args, picture, report, strip, unit_radius

import fvf


def main() -> None:
    args = parse_args(__doc__.splitlines()[0], default="fvf.icosphere(4)")
    if args.mesh:
        mesh = unit_radius(fvf.TriMesh(*fvf.read_mesh(args.mesh)))
        print(f"mesh: {args.mesh} ({mesh.n_vertices} vertices, {mesh.n_faces} faces)")
    else:
        mesh = fvf.icosphere(4)
        print(f"mesh: fvf.icosphere(4) ({mesh.n_vertices} vertices, {mesh.n_faces} faces)")
    X = mesh.vertices
    theta = 2.4
    u0, u1, v = fvf.examples.fig12_fields(mesh, theta, width=0.9)  # (m, 3) each

    frames = fvf.interpolate(mesh, v, u0, u1, np.linspace(0.0, 1.0, 5))  # (5, m, 3)
    average = 0.5 * (u0 + u1)

    def near_side(u):  # singular vertices with x > 0 (where the bumps are) and indices
        ids, index = fvf.singularities(mesh, u, zero="warn")
        keep = X[ids, 0] > 0
        return ids[keep], index[keep]

    print("singularities on the near side (x > 0): (count, indices)")
    for name, u in [("u_0", u0), ("average", average), ("interpolant t = 1/2", frames[2])]:
        ids, index = near_side(u)
        report(name, [len(ids), index.tolist()])
    ids, _ = near_side(frames[2])
    if len(ids):
        p = X[ids[0]]
        report(
            "interpolant's singularity: height z, angle / theta",
            [round(float(p[2]), 4), round(float(np.arctan2(p[1], p[0]) / theta), 4)],
        )

    def draw(viz, path):
        side = viz.View(azimuth=0.0, elevation=10.0, up="z")  # from +x: the bumps' side
        panels = []
        named = [(u, f"t = {t:.2f}") for u, t in zip(frames, np.linspace(0, 1, 5), strict=True)]
        for u, title in [*named, (average, "average (u_0 + u_1)/2")]:
            ids, index = near_side(u)
            panels.append(
                dict(
                    field=u,
                    texture=viz.lic_texture(mesh, u),
                    singularities=(fvf.singularity_positions(mesh, ids), index),
                    view=side,
                    title=title,
                )
            )
        strip(viz, mesh, path, panels, size=(320, 320))

    picture(args, "fig12_interpolation.png", draw)


if __name__ == "__main__":
    main()
