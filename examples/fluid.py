"""Showcase: an ideal fluid on a surface by vorticity transport (Azencot et al. 2014).

The vorticity ω is carried by the velocity u = J grad ψ it induces (Δψ = ω), with the
functional flow of the chapter in a Laplace–Beltrami basis (fvf.ideal_fluid,
method="spectral"). Energy and enstrophy are conserved: their relative drifts are printed.

    python examples/fluid.py [MESH] [--out DIR] [--no-pictures]
"""

from __future__ import annotations

import numpy as np
from _common import load_mesh, parse_args, picture, report, strip, unit_radius

import fvf


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    mesh = unit_radius(load_mesh(args.mesh))
    X = mesh.vertices
    # four vortices of alternating sign at the extremes of the mesh along x and z
    ends = [X[:, 0].argmax(), X[:, 2].argmax(), X[:, 0].argmin(), X[:, 2].argmin()]
    omega0 = sum((-1) ** i * np.exp(-20 * ((X - X[e]) ** 2).sum(1)) for i, e in enumerate(ends))
    dt = fvf.fluid_time_step(mesh, omega0, 0.5)  # Courant number 0.5
    steps = 200
    # spectral: Galerkin in 64 eigenfunctions (closed meshes); midpoint: the full n x n
    # implicit midpoint rule, which also handles a boundary (free-slip walls)
    method = "spectral" if mesh.is_closed else "midpoint"
    result = fvf.ideal_fluid(mesh, omega0, dt, steps, method=method, save_every=50)
    drift = result.drift()
    print(f"ideal fluid, {steps} steps of dt = {dt:.4g} ({method})")
    report("relative energy drift", drift["energy"])
    report("relative enstrophy drift", drift["enstrophy"])
    report(
        "circulation (integral of vorticity) first, last",
        [float(mesh.vertex_areas @ w) for w in result.vorticity[[0, -1]]],
    )
    report("saved times", np.round(result.times, 4).tolist())

    def draw(viz, path):
        top = float(np.percentile(np.abs(result.vorticity), 99))
        panels = []
        for i in range(0, len(result.times), 2):
            texture = viz.lic_texture(mesh, result.velocity(i))  # the flow's streaks
            panels.append(
                dict(
                    function=result.vorticity[i],
                    texture=texture,
                    clim=(-top, top),
                    cmap="RdBu_r",
                    title=f"vorticity, t = {result.times[i]:.3g}",
                )
            )
        strip(viz, mesh, path, panels)

    picture(args, "fluid.png", draw)


if __name__ == "__main__":
    main()
