"""Benchmark N-direction field design: smoothest and constrained/aligned fields, N = 1 and 4.

Run from the repository root::

    .venv/bin/python benchmarks/bench_nfields.py              # armadillo 86k and 750k faces
    .venv/bin/python benchmarks/bench_nfields.py --quick      # 86k only
    .venv/bin/python benchmarks/bench_nfields.py --backend scipy

Meshes: ``../shared/meshes/armadillo.obj`` (86,482 faces) and ``armadillo_750k.ply``
(749,999 faces; set FVF_SHARED_MESHES to move them). BLAS runs on one thread
(threadpoolctl). Every case runs in a fresh child process, so "peak" is that process's
peak resident memory (mesh loading included) and no cache carries over; "wall" is the
elapsed time of the case after loading the mesh, "cpu" its process CPU time (on a shared
machine wall can be several times cpu).

Cases:

* ``smoothest n``: ``fvf.smoothest_fields(mesh, 1, n=n)``.
* ``hard n``: ``fvf.design_field`` with 20 hard constraints (seeded random faces and
  directions).
* ``align 4``: ``fvf.design_field(mesh, n=4, align="curvature")`` (principal curvatures
  included).
* ``comb+sing fvf`` / ``libigl``: on the curvature-aligned cross field, ``fvf.comb`` (cut
  graph included) + ``fvf.singularities(n=4)`` against libigl's ``comb_cross_field`` +
  ``find_cross_field_singularities`` on the same field (same-run ratio; the singular vertex
  sets are compared).

Goals (asked by users): smoothest, constrained and curvature-aligned design, n = 1 and
n = 4, under 60 s wall and 1.5 GB peak at 750k faces; PASS/MISS is printed per case at
that size.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

CHILD = "--_child"
GOAL_SECONDS = 60.0
GOAL_BYTES = 1.5e9
MESHES = {"86k": "armadillo.obj", "750k": "armadillo_750k.ply"}
CASES = ("smoothest 1", "smoothest 4", "hard 1", "hard 4", "align 4", "comb+sing")


def _shared() -> Path:
    default = Path(__file__).resolve().parents[2] / "shared" / "meshes"
    return Path(os.environ.get("FVF_SHARED_MESHES", default))


def _peak() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0


def _child(mesh_name: str, case: str, backend: str) -> dict:
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)
    import numpy as np

    import fvf
    from fvf.numerics.cholesky import _auto

    V, F = fvf.read_mesh(_shared() / mesh_name)
    mesh = fvf.TriMesh(V, F)
    kind, _, n = case.partition(" ")
    # what "auto" picks for the complex systems of the designs
    used = _auto("many" if kind == "smoothest" else "few", True) if backend == "auto" else backend
    out = {"faces": mesh.n_faces, "backend": used}
    t0, c0 = time.perf_counter(), time.process_time()
    if kind == "smoothest":
        _, U = fvf.smoothest_fields(mesh, 1, n=int(n), backend=backend)
        u = U[0]
    elif kind == "hard":
        rng = np.random.default_rng(0)
        faces = rng.choice(mesh.n_faces, 20, replace=False)
        d = rng.standard_normal((20, 3))
        u = fvf.design_field(mesh, faces, d, hard=True, n=int(n), backend=backend)
    elif kind == "align":
        u = fvf.design_field(mesh, n=4, align="curvature", backend=backend)
    else:
        import igl

        u = fvf.design_field(mesh, n=4, align="curvature", backend=backend)
        u = u / np.linalg.norm(u, axis=1)[:, None]
        v = fvf.rotate(mesh, u)
        t0, c0 = time.perf_counter(), time.process_time()
        fvf.comb(mesh, u, 4)
        ids, _ = fvf.singularities(mesh, u, n=4)
        out["fvf_s"] = time.perf_counter() - t0
        Vc, Fc = np.ascontiguousarray(mesh.vertices), np.ascontiguousarray(mesh.faces)
        t1 = time.perf_counter()
        igl.comb_cross_field(Vc, Fc, u, v)
        is_s, _ = igl.find_cross_field_singularities(Vc, Fc, u, v)
        out["igl_s"] = time.perf_counter() - t1
        out["same_singularities"] = bool(
            np.array_equal(np.sort(ids), np.flatnonzero(is_s).astype(ids.dtype))
        )
        out["singularities"] = int(ids.size)
    out["wall"] = time.perf_counter() - t0
    out["cpu"] = time.process_time() - c0
    if kind != "comb+sing":
        ids, _ = fvf.singularities(mesh, u, n=int(n or 4), zero="warn")
        out["singularities"] = int(ids.size)
    out["peak"] = _peak()
    return out


def _run_case(mesh_name: str, case: str, backend: str, timeout: float) -> dict:
    cmd = [sys.executable, __file__, CHILD, mesh_name, case, backend]
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"timeout {timeout:.0f} s"}
    if r.returncode != 0:
        return {"error": (r.stderr.strip().splitlines() or ["?"])[-1]}
    return json.loads(r.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="86k faces only")
    ap.add_argument("--sizes", default=None, help="comma-separated subset of 86k,750k")
    ap.add_argument("--backend", default="auto", help="auto, cholmod, cvxopt, cholespy or scipy")
    ap.add_argument("--cases", default=",".join(CASES), help="comma-separated subset")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per case")
    args = ap.parse_args()
    sizes = ["86k"] if args.quick else ["86k", "750k"]
    if args.sizes:
        sizes = args.sizes.split(",")
    print(f"bench_nfields: one BLAS thread, backend {args.backend}, one child process per case")
    head = f"{'mesh':>5} {'case':<12} {'wall s':>8} {'cpu s':>8} {'peak':>8} {'sing':>5}  note"
    print(head)
    print("-" * len(head))
    for size in sizes:
        for case in args.cases.split(","):
            r = _run_case(MESHES[size], case, args.backend, args.timeout)
            if "error" in r:
                print(f"{size:>5} {case:<12} {'-':>8} {'-':>8} {'-':>8} {'-':>5}  {r['error']}")
                continue
            note = f"{r['backend']}"
            if case == "comb+sing":
                note += (
                    f"; fvf {r['fvf_s']:.2f} s vs libigl {r['igl_s']:.2f} s "
                    f"(x{r['fvf_s'] / r['igl_s']:.2f}), same vertices: {r['same_singularities']}"
                )
            elif size == "750k":
                ok = r["wall"] < GOAL_SECONDS and r["peak"] < GOAL_BYTES
                note += f"; {'PASS' if ok else 'MISS'} (goal 60 s, 1.5 GB)"
            print(
                f"{size:>5} {case:<12} {r['wall']:8.1f} {r['cpu']:8.1f} "
                f"{r['peak'] / 1e9:7.2f}G {r['singularities']:5d}  {note}",
                flush=True,
            )


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == CHILD:
        print(json.dumps(_child(sys.argv[2], sys.argv[3], sys.argv[4])))
    else:
        main()
