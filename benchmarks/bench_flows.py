"""Flow methods x meshes: accuracy, norm behaviour, matrix-vector products and time.

For every mesh and every method of :func:`fvf.flows.dispatch.flow` ("chapter", "upwind", "skew",
"cayley", "spectral") it measures three cases.

* **rotation** (spheres only, where the exact answer is known): v = e_z × x and the degree-3
  polynomial f_0 = x + yz/2 + 0.3x²y; the exact flow is f_0 ∘ R_z(−t). It reports the
  A_V-L2 error at t = 1.
* **compressible**: the mesh is centred at its vertex mean and scaled to unit radius, then
  v = grad x (unit L2 norm) and f_0 = sin 3y + z, the lion case of docs/chapter.md, up to
  t = 0.1. It reports the range of f(0.1) against [min f_0, max f_0] and ‖f(0.1)‖/‖f_0‖.
  "BLOW-UP" marks a range more than 10x the initial one.
* **divergence-free**: v = J grad g, with g a smooth function scaled to unit RMS speed, and
  t = 0.2·√area. It reports |‖f(t)‖/‖f_0‖ − 1|.

"products" counts the sparse n x n matrix-vector products of the compressible flow,
including those of the chapter flow's growth check; "chapter" and "skew" use the Krylov
action of :mod:`fvf.numerics.expm` (its own count, ``stats["matvecs"]``).
For Cayley it adds "+ s solves": s pairs of triangular solves with one LU. The spectral
flow needs none, because it works in k x k. "time" is the compressible flow (best of r).
"setup" is the operator, the LU or the eigenbasis (k = 50), built once per field or mesh.

BLAS threads are pinned to 1 (threadpoolctl). FlowGrowthWarnings are recorded, not shown:
"(warned)" marks the compressible flows that issued one.

Run from the repository root::

    .venv/bin/python benchmarks/bench_flows.py            # every mesh (about a minute)
    .venv/bin/python benchmarks/bench_flows.py --quick    # spheres, spot and lion
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from threadpoolctl import threadpool_limits

import fvf
from fvf.flows.dispatch import METHODS, TransportFlow

SHARED = Path(
    os.environ.get("FVF_SHARED_MESHES", Path(__file__).resolve().parents[2] / "shared" / "meshes")
)


# ---------------------------------------------------------------------------- counting
class _Counter:
    """Counts products of n x n CSR/CSC arrays with vectors (columns count separately)."""

    def __init__(self) -> None:
        self.n = None
        self.count = 0
        cls = sp._compressed._cs_matrix
        self._orig = cls._matmul_vector, cls._matmul_multivector
        counter = self

        def vec(A, x):
            if A.shape == (counter.n, counter.n):
                counter.count += 1
            return counter._orig[0](A, x)

        def multi(A, x):
            if A.shape == (counter.n, counter.n):
                counter.count += x.shape[1]
            return counter._orig[1](A, x)

        cls._matmul_vector, cls._matmul_multivector = vec, multi

    def start(self, n: int) -> None:
        self.n, self.count = n, 0


def best(fn, r: int):
    t, out = np.inf, None
    for _ in range(r):
        s = time.perf_counter()
        out = fn()
        t = min(t, time.perf_counter() - s)
    return t, out


# ---------------------------------------------------------------------------- cases
def rotate_z(p, angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1], p[:, 2]], 1)


def f_poly(p):
    return p[:, 0] + 0.5 * p[:, 1] * p[:, 2] + 0.3 * p[:, 0] ** 2 * p[:, 1]


def norm(mesh, f):
    return float(np.sqrt(mesh.vertex_areas @ (f * f)))


def options_for(method, basis):
    return {"basis": basis} if method == "spectral" else {}


def run_mesh(name, mesh, is_sphere, counter, repeats, methods):
    rows = []
    mesh_n, v, f0 = fvf.examples.compressible_case(mesh)
    basis = {}
    if "spectral" in methods:
        tb, basis["n"] = best(lambda: fvf.SpectralBasis(mesh_n, 50), 1)
    X = mesh.vertices
    rot_v = mesh.project_tangent(np.cross([0.0, 0.0, 1.0], mesh.face_centroids))
    if "spectral" in methods and is_sphere:
        basis["rot"] = fvf.SpectralBasis(mesh, 50)
    # divergence-free field on the normalized mesh
    Xn = mesh_n.vertices
    g = np.cos(2 * Xn[:, 1]) + Xn[:, 0] * Xn[:, 2]
    w = fvf.rotate(mesh_n, fvf.gradient(mesh_n, g))
    w /= np.sqrt((mesh_n.face_areas * (w * w).sum(1)).sum() / mesh_n.total_area)
    t_free = 0.2 * np.sqrt(mesh_n.total_area)
    lo, hi = f0.min(), f0.max()
    for method in methods:
        row = {"mesh": name, "n": mesh.n_vertices, "method": method}
        opts = options_for(method, basis.get("n"))
        ts, phi = best(lambda opts=opts, method=method: TransportFlow(mesh_n, v, method, **opts), 1)
        row["setup"] = ts + (tb if method == "spectral" else 0.0)
        counter.start(mesh_n.n_vertices)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", fvf.FlowGrowthWarning)
            ft = phi(f0, 0.1)  # first call: counts, builds Cayley's LU / chapter's estimate
        row["products"] = counter.count
        if method in ("chapter", "skew"):  # expm_action's in-place kernels bypass the counter
            row["products"] += phi.stats["matvecs"]
        row["warned"] = any(issubclass(w.category, fvf.FlowGrowthWarning) for w in caught)
        if method == "cayley":
            row["products"] = f"{counter.count} + {phi.stats['steps']} solves"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", fvf.FlowGrowthWarning)
            row["time"], ft = best(lambda phi=phi: phi(f0, 0.1), repeats)
        row["range"] = (float(ft.min()), float(ft.max()))
        row["blowup"] = (ft.max() - ft.min()) > 10 * (hi - lo) or not np.isfinite(ft).all()
        row["norm_ratio"] = norm(mesh_n, ft) / norm(mesh_n, f0)
        # divergence-free
        opts_free = options_for(method, basis.get("n"))
        phi_free = TransportFlow(mesh_n, w, method, **opts_free)
        f_free = np.sin(2 * Xn[:, 0]) + Xn[:, 1]
        reference = norm(mesh_n, f_free)
        if method == "spectral":  # the spectral flow keeps the norm of the projection
            reference = norm(mesh_n, phi_free.basis.reconstruct(phi_free.basis.project(f_free)))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", fvf.FlowGrowthWarning)  # boundary meshes
            free = phi_free(f_free, t_free)
        row["free_drift"] = abs(norm(mesh_n, free) / reference - 1)
        # rotation
        if is_sphere:
            opts_rot = options_for(method, basis.get("rot"))
            fr = TransportFlow(mesh, rot_v, method, **opts_rot)(f_poly(X), 1.0)
            row["rot_err"] = norm(mesh, fr - f_poly(rotate_z(X, -1.0)))
        rows.append(row)
        print(format_row(row, lo, hi), flush=True)
    return rows, (lo, hi)


HEADER = (
    "| mesh | n | method | rotation error (t=1) | compressible: range of f(0.1) | "
    "‖f(0.1)‖/‖f_0‖ | div-free norm drift | products | time s | setup s |\n"
    "|---|---|---|---|---|---|---|---|---|---|"
)


def format_row(r, lo, hi):
    rot = f"{r['rot_err']:.2e}" if "rot_err" in r else "–"
    rng = f"[{r['range'][0]:.3g}, {r['range'][1]:.3g}]"
    if r["blowup"]:
        rng = f"**BLOW-UP** {rng}"
    if r["warned"]:
        rng += " (warned)"
    return (
        f"| {r['mesh']} | {r['n']} | {r['method']} | {rot} | {rng} | {r['norm_ratio']:.3g} | "
        f"{r['free_drift']:.1e} | {r['products']} | {r['time']:.3f} | {r['setup']:.2f} |"
    )


# ---------------------------------------------------------------------------- fluid
def vortices(mesh):
    """Three Gaussian vortices of mixed sign (as in tests/flows/test_fluid.py)."""
    X = mesh.vertices - mesh.vertices.mean(0)
    X = X / np.linalg.norm(X, axis=1).max()
    centres = X[np.argmax(X[:, 2])], X[np.argmin(X[:, 0])], X[np.argmax(X[:, 1])]
    weights = (1.0, -1.0, 0.7)
    return sum(
        w * np.exp(-10 * ((X - c) ** 2).sum(1)) for w, c in zip(weights, centres, strict=True)
    )


FLUID_HEADER = (
    "| mesh | n | method | steps | dt | energy drift | enstrophy drift | iterations/step "
    "| LU | moved | time s |\n|---|---|---|---|---|---|---|---|---|---|---|"
)


def fluid_table(meshes, steps: int) -> None:
    from fvf.flows.fluid import fluid_time_step, ideal_fluid

    print()
    print(f"ideal fluid: three vortices, Courant 0.5, {steps} steps, tol 1e-13, k = 64")
    print(FLUID_HEADER)
    for name, mesh in meshes:
        omega0 = vortices(mesh)
        dt = fluid_time_step(mesh, omega0, 0.5)
        for method in ("midpoint", "spectral"):
            if method == "spectral" and not mesh.is_closed:
                continue
            t, res = best(
                lambda m=method, mesh=mesh, o=omega0, dt=dt: ideal_fluid(
                    mesh, o, dt, steps, method=m, save_every=steps
                ),
                1,
            )
            d = res.drift()
            moved = np.abs(res.vorticity[-1] - res.vorticity[0]).max() / np.abs(omega0).max()
            lu = res.info.get("factorizations", "–")
            print(
                f"| {name} | {mesh.n_vertices} | {method} | {steps} | {dt:.3g} | "
                f"{d['energy']:.1e} | {d['enstrophy']:.1e} | {res.iterations.mean():.1f} | "
                f"{lu} | {moved:.2f} | {t:.2f} |",
                flush=True,
            )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="spheres, spot and lion only")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--fluid-steps", type=int, default=200)
    ap.add_argument("--no-fluid", action="store_true", help="skip the fluid table")
    args = ap.parse_args()
    threadpool_limits(1)
    methods = args.methods.split(",")
    meshes = [
        ("icosphere(4)", lambda: fvf.icosphere(4), True),
        ("jittered_sphere(4, 0.3)", lambda: fvf.jittered_sphere(4, 0.3, seed=4), True),
        ("sphere_s2.off", "sphere_s2.off", True),
        ("spot.obj", "spot.obj", False),
        ("bunny-lowres.off", "bunny-lowres.off", False),
        ("faust_r_tr_reg_001.off", "faust_r_tr_reg_001.off", False),
        ("lion-00.off", "lion-00.off", False),
        ("nefertiti.obj", "nefertiti.obj", False),
    ]
    if args.quick:
        meshes = [
            m
            for m in meshes
            if m[0] in ("icosphere(4)", "jittered_sphere(4, 0.3)", "spot.obj", "lion-00.off")
        ]
    print("BLAS threads pinned to 1 (threadpoolctl); (warned) = FlowGrowthWarning issued")
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, fvf {fvf.__version__}")
    print("compressible: v = grad x (unit L2), f_0 = sin 3y + z on the mesh scaled to unit radius")
    print(HEADER)
    counter = _Counter()
    for name, source, is_sphere in meshes:
        if isinstance(source, str):
            path = SHARED / source
            if not path.exists():
                print(f"| {name} | – | skipped: {path} not found |")
                continue
            mesh = fvf.TriMesh(*fvf.read_mesh(path))
        else:
            mesh = source()
        repeats = 1 if mesh.n_vertices > 20000 else 3
        _, (lo, hi) = run_mesh(name, mesh, is_sphere, counter, repeats, methods)
        print(f"|  | initial range [{lo:.3g}, {hi:.3g}] |  |  |  |  |  |  |  |  |")
    if not args.no_fluid:
        fluid_meshes = [("icosphere(3)", fvf.icosphere(3)), ("disk(8, 6)", fvf.disk(8, 6))]
        for name in ("spot.obj", "bunny-lowres.off") if not args.quick else ():
            if (SHARED / name).exists():
                fluid_meshes.append((name, fvf.TriMesh(*fvf.read_mesh(SHARED / name))))
        fluid_table(fluid_meshes, args.fluid_steps)
    return 0


if __name__ == "__main__":
    sys.exit(main())
