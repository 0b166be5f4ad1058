"""Benchmark :func:`fvf.numerics.eigen.smallest_eigenpairs` against a plain shift-invert eigsh call.

Run from the repository root::

    .venv/bin/python benchmarks/bench_spectral.py                    # every mesh, k = 50,100,200
    .venv/bin/python benchmarks/bench_spectral.py --quick            # the ~10k mesh only
    .venv/bin/python benchmarks/bench_spectral.py --sizes 4e4 --k 200
    .venv/bin/python benchmarks/bench_spectral.py --skip-reference-above 100000

For each mesh and k it runs, each in a fresh child process (so peak memory is measured
per solve and includes SuperLU's and ARPACK's C/Fortran allocations):

* ``fvf``: ``smallest_eigenpairs(W, mass, k)`` with the default ``method="auto"`` and
  ``tol=1e-8`` (block shift-invert Krylov–Schur on a symmetric-mode SuperLU factor);
* ``eigsh``: the plain reference call
  ``scipy.sparse.linalg.eigsh(W, k, M=diags(mass), sigma=σ, which="LM")`` (scipy's own
  COLAMD SuperLU factorization, ARPACK, default ``tol=0``) with the same shift σ
  (:func:`fvf.numerics.eigen.default_shift`).

It prints wall and CPU time, the time ratio eigsh/fvf ("speed-up"), peak extra resident
memory (VmHWM after ``/proc/self/clear_refs`` minus VmRSS before the solve, so the mesh and
W are not counted) and its ratio, the largest relative residual of each (as defined by
:func:`fvf.numerics.eigen.eigen_residuals`) and the largest eigenvalue difference
max_i |λ_i(fvf) − λ_i(eigsh)| / λ_k(eigsh).

Everything runs on one thread: BLAS pools are limited to 1 with threadpoolctl in each
child (SuperLU and ARPACK's own code are single-threaded). CPU time
(``time.process_time``) is printed beside wall time because the machine may be shared.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

MESH_DIR = Path(
    os.environ.get("FVF_SHARED_MESHES", Path(__file__).resolve().parents[2] / "shared" / "meshes")
)
# (label, file): ~10k, ~41k (two meshes), ~170k, ~375k vertices.
MESHES = [
    ("10k", "rocker-arm.obj"),
    ("43k", "armadillo.obj"),
    ("50k", "nefertiti.obj"),
    ("173k", "armadillo_loop1.ply"),
    ("375k", "armadillo_750k.ply"),
]
N_VERTICES = {
    "rocker-arm.obj": 10044,
    "armadillo.obj": 43243,
    "nefertiti.obj": 49971,
    "armadillo_loop1.ply": 172966,
    "armadillo_750k.ply": 375002,
}
CHILD_FLAG = "--_child"
GOAL = 2.0  # eigsh time / fvf time, at no more peak memory than eigsh's


# ------------------------------------------------------------------------------- child
def _rss_kib(field: str) -> int:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    return 0


def _reset_peak() -> bool:
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:
        return False


def child(mesh_file: str, k: int, which: str, tol: float) -> None:
    """Run one solve and print a JSON line with its timings, memory and results."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla
    from threadpoolctl import threadpool_info, threadpool_limits

    import fvf
    from fvf import calculus
    from fvf.numerics.eigen import default_shift, eigen_residuals, smallest_eigenpairs

    V, F = fvf.read_mesh(MESH_DIR / mesh_file)
    mesh = fvf.TriMesh(V, F)
    W = calculus.stiffness(mesh)
    mass = np.asarray(mesh.vertex_areas)
    with threadpool_limits(1):
        threads = sorted({d["num_threads"] for d in threadpool_info()})
        if which == "eigsh":
            Wc = sp.csc_matrix(W)
            M = sp.diags(mass).tocsc()
            sigma = default_shift(W, mass)
        base = _rss_kib("VmRSS")
        peak_ok = _reset_peak()
        t0, c0 = time.perf_counter(), time.process_time()
        if which == "fvf":
            lam, X = smallest_eigenpairs(W, mass, k, tol=tol)
        else:
            lam, X = spla.eigsh(Wc, k, M=M, sigma=sigma, which="LM")
            order = np.argsort(lam)
            lam, X = lam[order], X[:, order]
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        peak = _rss_kib("VmHWM")
        res = eigen_residuals(W, mass, lam, X)
        orth = float(np.abs(X.T @ (mass[:, None] * X) - np.eye(k)).max())
    out = {
        "n": mesh.n_vertices,
        "wall": wall,
        "cpu": cpu,
        "mem_mib": (peak - base) / 1024 if peak_ok else float("nan"),
        "maxres": float(res.max()),
        "orth": orth,
        "evals": lam.tolist(),
        "threads": threads,
    }
    print("RESULT " + json.dumps(out), flush=True)


# ------------------------------------------------------------------------------ parent
def run_child(mesh_file: str, k: int, which: str, tol: float, timeout: float) -> dict | None:
    cmd = [sys.executable, __file__, CHILD_FLAG, mesh_file, str(k), which, repr(tol)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"timeout after {timeout:.0f} s"}
    for line in proc.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    return {"error": (proc.stderr.strip().splitlines() or ["no output"])[-1]}


def fmt(x: float | None, spec: str) -> str:
    if x is None or not math.isfinite(x):
        return "-"
    return format(x, spec)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="the ~10k mesh only")
    ap.add_argument(
        "--sizes",
        default=None,
        help="comma-separated approximate vertex counts (nearest mesh in log scale) or "
        "mesh file names, e.g. 1e4,4e4 or armadillo.obj",
    )
    ap.add_argument("--k", default="50,100,200", help="comma-separated k values")
    ap.add_argument("--tol", type=float, default=1e-8, help="tol of smallest_eigenpairs")
    ap.add_argument(
        "--skip-reference-above",
        type=float,
        default=None,
        metavar="N",
        help="skip the plain eigsh reference for meshes with more than N vertices",
    )
    ap.add_argument("--timeout", type=float, default=3600.0, help="per-solve timeout (s)")
    ap.add_argument("--json", default=None, help="also write the rows to this JSON file")
    args = ap.parse_args(argv)

    if args.quick:
        meshes = [MESHES[0]]
    elif args.sizes:
        meshes = []
        for tok in args.sizes.split(","):
            tok = tok.strip()
            named = [m for m in MESHES if m[1] == tok]
            if named:
                meshes += named
                continue
            target = float(tok)
            best = min(MESHES, key=lambda m: abs(math.log(N_VERTICES[m[1]] / target)))
            meshes.append(best)
    else:
        meshes = list(MESHES)
    ks = [int(x) for x in args.k.split(",")]

    import scipy
    from threadpoolctl import threadpool_info

    print(f"python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}")
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores")
    blas = ", ".join(f"{d['internal_api']} ({d['num_threads']} threads)" for d in threadpool_info())
    print(f"BLAS here: {blas}; every timed child runs under threadpool_limits(1)")
    print(f"fvf: smallest_eigenpairs(method='auto', tol={args.tol:g})")
    print("eigsh: scipy.sparse.linalg.eigsh(W, k, M=diags(mass), sigma, which='LM'), tol=0")
    print("speed-up = eigsh time / fvf time; mem = peak extra RSS during the solve")
    print()
    hdr = (
        f"{'mesh':>22} {'n':>7} {'k':>4} | {'fvf s':>7} {'cpu':>7} {'MiB':>6} {'maxres':>8} | "
        f"{'eigsh s':>8} {'cpu':>7} {'MiB':>6} {'maxres':>8} | {'speed-up':>8} {'cpu x':>6} "
        f"{'mem x':>6} | {'max dλ/λk':>9} | goal"
    )
    print(hdr)
    print("-" * len(hdr))
    rows = []
    for _label, mesh_file in meshes:
        if not (MESH_DIR / mesh_file).exists():
            print(f"{mesh_file:>22}  (missing in {MESH_DIR}, skipped)")
            continue
        n = N_VERTICES[mesh_file]
        for k in ks:
            a = run_child(mesh_file, k, "fvf", args.tol, args.timeout)
            skip = args.skip_reference_above is not None and n > args.skip_reference_above
            b = None if skip else run_child(mesh_file, k, "eigsh", args.tol, args.timeout)
            row = {"mesh": mesh_file, "n": n, "k": k, "fvf": a, "eigsh": b}
            rows.append(row)
            if a is None or "error" in a:
                print(f"{mesh_file:>22} {n:>7} {k:>4} | fvf failed: {a and a.get('error')}")
                continue
            ok_b = b is not None and "error" not in b
            dl = float("nan")
            if ok_b:
                la, lb = np.array(a["evals"]), np.array(b["evals"])
                dl = float(np.max(np.abs(la - lb)) / abs(lb[-1]))
            ref = b if ok_b else {}

            def sb(key: str, ref: dict = ref) -> float:
                return float(ref.get(key, float("nan")))

            speed = sb("wall") / a["wall"]
            cpu_x = sb("cpu") / a["cpu"]
            mem_x = sb("mem_mib") / a["mem_mib"] if a["mem_mib"] > 0 else float("nan")
            row["speedup"], row["mem_ratio"] = speed, mem_x
            verdict = "PASS" if speed >= GOAL and mem_x >= 1.0 else "MISS"
            print(
                f"{mesh_file:>22} {a['n']:>7} {k:>4} | {a['wall']:>7.2f} {a['cpu']:>7.2f} "
                f"{a['mem_mib']:>6.0f} {a['maxres']:>8.1e} | {fmt(sb('wall'), '8.2f')} "
                f"{fmt(sb('cpu'), '7.2f')} {fmt(sb('mem_mib'), '6.0f')} "
                f"{fmt(sb('maxres'), '8.1e')} | {fmt(speed, '8.2f')} {fmt(cpu_x, '6.2f')} "
                f"{fmt(mem_x, '6.2f')} | {fmt(dl, '9.1e')} | {verdict if ok_b else '-'}"
                + ("" if ok_b or skip else f"  eigsh: {b and b.get('error')}")
                + ("  (reference skipped)" if skip else "")
            )
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    done = [r for r in rows if math.isfinite(r.get("speedup", float("nan")))]
    if done:
        speeds = [r["speedup"] for r in done]
        met = all(r["speedup"] >= GOAL and r["mem_ratio"] >= 1.0 for r in done)
        print()
        print(
            f"speed-up vs plain eigsh: min {min(speeds):.2f}x, max {max(speeds):.2f}x; goal: "
            f">= {GOAL:g}x at no more peak memory (mem x = eigsh / fvf >= 1), residual "
            f"{args.tol:g}: " + ("PASS" if met else "MISS")
        )
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == CHILD_FLAG:
        child(sys.argv[2], int(sys.argv[3]), sys.argv[4], float(sys.argv[5]))
    else:
        sys.exit(main())
