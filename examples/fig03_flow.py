"""Fig. 3: a function carried along the flow of a field, Φ_{v,t} f = exp(−t D^V_v) f (eq. 42).

v = J grad h is divergence-free, so [A_V] D^V_v is skew and the flow keeps the A_V-norm of
the function (docs/chapter.md, "Facts we measured"). For contrast, the compressible field
grad x: the chapter's flow may grow (its growth rate μ is printed) while the upwind flow
stays within the initial range on every mesh (docs/flows.md).

    python examples/fig03_flow.py [MESH] [--out DIR] [--no-pictures]
"""

from __future__ import annotations

import numpy as np
from _common import load_mesh, parse_args, picture, report, scaled_coordinate, strip

import fvf


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    mesh = load_mesh(args.mesh)
    X = mesh.vertices
    h = X[:, 1] + 0.5 * np.sin(3 * X[:, 0] / np.ptp(X[:, 0]))
    v = fvf.rotate(mesh, fvf.gradient(mesh, h))  # J grad h, (m, 3)
    f0 = np.sin(4 * scaled_coordinate(X, 2))  # (n,)
    # times: up to the time a point moving at the largest speed crosses the mesh
    times = np.linspace(0.0, 1.0, 5) * np.ptp(X[:, 0]) / np.abs(v).max()

    phi = fvf.FunctionalFlow(mesh, v)
    frames = phi(f0, times)  # (5, n)
    drift = abs(phi.norm(frames[-1]) / phi.norm(f0) - 1)
    print("flow of f0 along v = J grad h (chapter, eq. 42)")
    report("times", np.round(times, 4).tolist())
    report("[A_V] D^V_v skew (norm-preserving)", bool(phi.is_skew))
    report("relative A_V-norm drift at the last time", drift)
    report("range of f0", [round(float(f0.min()), 4), round(float(f0.max()), 4)])
    report(
        "range of f(t_last)", [round(float(frames[-1].min()), 4), round(float(frames[-1].max()), 4)]
    )

    g = fvf.gradient(mesh, X[:, 0])
    g = g / np.abs(g).max()  # compressible, unit largest speed
    mu = fvf.FunctionalFlow(mesh, g).growth_rate[0]
    up = fvf.flow(mesh, g, f0, times, method="upwind")
    print("flow of f0 along the compressible field grad x")
    report("growth rate mu of the chapter's flow (||f(t)|| <= e^(mu t) ||f0||)", mu)
    report(
        "upwind flow stays in [min f0, max f0]",
        bool(up.min() >= f0.min() - 1e-12 and up.max() <= f0.max() + 1e-12),
    )

    def draw(viz, path):
        clim = (float(frames.min()), float(frames.max()))
        panels = [
            dict(function=f, field=v, max_arrows=400, clim=clim, title=f"f(t), t = {t:.3g}")
            for f, t in zip(frames[::2], times[::2], strict=True)
        ]
        fine, v_fine, _ = viz.subdivide(mesh, v, levels=2)  # a finer canvas for the streaks
        texture = viz.lic_texture(fine, v_fine)  # noise averaged along the flow of v
        panels.append(dict(mesh=fine, texture=texture, title="LIC of v"))
        strip(viz, mesh, path, panels)

    picture(args, "fig03_flow.png", draw)


if __name__ == "__main__":
    main()
