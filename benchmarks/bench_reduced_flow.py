"""Cost of a reduced spectral flow against the full flow, at equal accuracy on the span.

On unit icospheres, f_0 is a combination of the first Laplace–Beltrami eigenfunctions
(so it lies in the span of the basis) and v = e_z × x is a rotation, whose exact flow
turns f_0 about z: f(t) = f_0 ∘ R_z(−t). We time

- full: ``fvf.flow`` (expm_multiply on the n x n D^V_v), and
- reduced: ``basis.reduced_flow`` (D̂_v, a k x k exponential, reconstruction),

and print both errors against the exact rotation of the PL interpolant (the accuracy of
each), their mutual difference, and the time ratio. The basis itself is a one-off cost per
mesh, printed separately. BLAS threads are pinned to 1 (threadpoolctl).

Run: ``.venv/bin/python benchmarks/bench_reduced_flow.py [--levels 4,5,6] [--k 50]``
"""

from __future__ import annotations

import argparse

import numpy as np
from bench_flows import best, rotate_z  # shared with the flow table (same folder)
from bench_flows import f_poly as f_exact
from threadpoolctl import threadpool_limits

import fvf
from fvf.spectral.basis import SpectralBasis


def row(mesh, k: int, t: float) -> None:
    X, a = mesh.vertices, mesh.vertex_areas
    tb, basis = best(lambda: SpectralBasis(mesh, k), 1)
    f0 = basis.reconstruct(basis.project(f_exact(X)))  # in the span (k >= 16 holds l <= 3)
    v = mesh.project_tangent(np.cross([0.0, 0.0, 1.0], mesh.face_centroids))
    exact = f_exact(rotate_z(X, -t))

    def norm(g):
        return float(np.sqrt(a @ g**2))

    tf, full = best(lambda: fvf.flow(mesh, v, f0, t), 3)
    tr, red = best(lambda: basis.reduced_flow(v, f0, t), 3)
    print(
        f"{mesh.n_vertices:>7} {k:>4} {tb:>8.3f} {tf:>8.4f} {tr:>9.4f} {tr / tf:>6.2f}x "
        f"{norm(full - exact):>9.2e} {norm(red - exact):>9.2e} {norm(full - red):>10.2e}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--levels", default="4,5,6")
    ap.add_argument("--k", type=int, default=49)
    ap.add_argument("--t", type=float, default=1.0)
    args = ap.parse_args()
    threadpool_limits(1)
    print("BLAS threads pinned to 1 (threadpoolctl); times are best of 3")
    print(
        f"{'n':>7} {'k':>4} {'basis s':>8} {'full s':>8} {'reduced s':>9} {'ratio':>7} "
        f"{'err full':>9} {'err red':>9} {'|full-red|':>10}"
    )
    for level in map(int, args.levels.split(",")):
        row(fvf.icosphere(level), args.k, args.t)
    print("err: A_V-norm distance to the exact rotation; the span holds f_0's exact rotation")


if __name__ == "__main__":
    main()
