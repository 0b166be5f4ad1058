"""The flows users call, against scipy: ``fvf.flow`` once, and ``FunctionalFlow`` reused.

For each mesh and field (a rotation v = J∇z, skew; and a compressible v = ∇z), both
normalized to unit top speed, at t = 10 mean edge lengths:

* **one-off**: ``fvf.flow(mesh, v, f, t)`` from the field (the operator D^V_v is built
  inside the timer) against the same in scipy: D^V_v = I_V^F [v]•ᵀ grad by scipy sparse
  products (grad and I_V^F prebuilt, as a scipy user would hold them), then
  ``scipy.sparse.linalg.expm_multiply(-t D, f)``. Goal: fvf ≤ 0.6× scipy.
* **reused**: ``FunctionalFlow`` built once and applied to 10 functions against
  ``expm_multiply`` on the prebuilt operator 10 times. Goal: fvf ≤ 0.6× scipy.

Both sides solve to their default accuracy; the script prints the max relative
difference. BLAS threads are pinned to 1 (threadpoolctl); each figure is the best of
``--repeat`` runs, and the two sides of a ratio run alternately, so a noisy machine moves
both. Sizes: ``ico6`` (81,920 faces, generated), and from ../shared/meshes
``armadillo.obj`` (86k), ``armadillo_loop1.ply`` (346k), ``armadillo_750k.ply``, and
``arm1.4M`` (``igl.loop`` of armadillo twice, 1.38M faces; needs libigl).

Run from the repository root::

    .venv/bin/python benchmarks/bench_flow_calls.py                 # every size
    .venv/bin/python benchmarks/bench_flow_calls.py --meshes ico6   # one size
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from threadpoolctl import threadpool_limits

import fvf

SHARED = Path(__file__).resolve().parents[2] / "shared" / "meshes"
GOAL = 0.6
MESHES = ["ico6", "armadillo.obj", "armadillo_loop1.ply", "armadillo_750k.ply", "arm1.4M"]


def load(name: str) -> fvf.TriMesh | None:
    if name.startswith("ico"):
        return fvf.icosphere(int(name[3:]))
    if name == "arm1.4M":
        try:
            import igl
        except ImportError:
            return None
        V, F = igl.read_triangle_mesh(str(SHARED / "armadillo.obj"))
        return fvf.TriMesh(*igl.loop(V, F, 2))
    path = SHARED / name
    return fvf.TriMesh(*fvf.read_mesh(path)) if path.exists() else None


def scipy_operator(mesh: fvf.TriMesh, G: sp.sparray, IVF: sp.sparray, v: np.ndarray):
    """D^V_v = I_V^F [v]•ᵀ grad with scipy products (eq. 36)."""
    m = mesh.n_faces
    cols = np.arange(3 * m)
    vdot_T = sp.csr_array((v.ravel(), (np.repeat(np.arange(m), 3), cols)), shape=(m, 3 * m))
    return (IVF @ (vdot_T @ G)).tocsr()


def best(fn, repeat: int) -> tuple[float, object]:
    out, times = None, []
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return min(times), out


def run_case(mesh, kind: str, repeat: int) -> list[str]:
    X = mesh.vertices
    v = fvf.gradient(mesh, X[:, 2])
    if kind == "rotation":
        v = fvf.rotate(mesh, v)
    v = v / np.linalg.norm(v, axis=1).max()
    f = np.sin(3 * X[:, 0] / np.ptp(X[:, 0])) + X[:, 1] / np.ptp(X[:, 1])
    t = 10 * mesh.mean_edge_length
    G, IVF = fvf.grad(mesh), fvf.face_to_vertex(mesh)
    trace_free = None  # expm_multiply computes the trace itself

    def ours_once():
        return fvf.flow(mesh, v, f, t, growth_limit=np.inf)

    def scipy_once():
        D = scipy_operator(mesh, G, IVF, v)
        return spla.expm_multiply(-t * D, f, traceA=trace_free)

    fs = [f * (1 + 0.1 * k) + 0.01 * k * X[:, 0] for k in range(10)]
    phi = fvf.FunctionalFlow(mesh, v, growth_limit=np.inf)
    D = phi.operator
    phi(f, t)
    method = phi.stats["method"]  # what "auto" chose for this field and time

    def ours_reused():
        return [phi(g, t) for g in fs]

    def scipy_reused():
        return [spla.expm_multiply(-t * D, g) for g in fs]

    rows = []
    for label, ours, theirs in (
        ("one-off", ours_once, scipy_once),
        ("reused x10", ours_reused, scipy_reused),
    ):
        t_ours, t_theirs = np.inf, np.inf
        for _ in range(repeat):  # alternate, so both sides see the same machine
            a, out_ours = best(ours, 1)
            b, out_theirs = best(theirs, 1)
            t_ours, t_theirs = min(t_ours, a), min(t_theirs, b)
        x, y = np.asarray(out_ours), np.asarray(out_theirs)
        diff = float(np.abs(x - y).max() / np.abs(y).max())
        ratio = t_ours / t_theirs
        verdict = "PASS" if ratio <= GOAL else "MISS"
        rows.append(
            f"  {kind:9s} {label:11s} fvf {t_ours:8.3f} s  scipy {t_theirs:8.3f} s  "
            f"ratio {ratio:5.2f}  {verdict}  (max rel diff {diff:.1e}, {method})"
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", default=",".join(MESHES))
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    threadpool_limits(1)
    warnings.simplefilter("ignore", fvf.FlowGrowthWarning)
    print(f"BLAS threads: 1 (threadpoolctl); goal: fvf <= {GOAL}x scipy; t = 10 edge lengths")
    for name in args.meshes.split(","):
        mesh = load(name)
        if mesh is None:
            print(f"{name}: not available, skipped")
            continue
        print(f"{name}: {mesh.n_vertices} vertices, {mesh.n_faces} faces")
        for kind in ("rotation", "gradient"):
            for row in run_case(mesh, kind, args.repeat):
                print(row, flush=True)


if __name__ == "__main__":
    main()
