"""Benchmark the sparse Hermitian factorization backends of ``fvf.numerics.cholesky``.

Run from the repository root::

    .venv/bin/python benchmarks/bench_cholesky.py   # spot, fertility, rocker-arm, armadillo
    .venv/bin/python benchmarks/bench_cholesky.py --meshes spot.obj

For each shared mesh (read from ``../shared/meshes`` or ``$FVF_SHARED_MESHES``) two
systems: the dual-graph Laplacian of the cone edits plus a small mass term (real, one
unknown per face, as in ``fvf.design.cancellation``), and the 4-direction connection
Laplacian plus a mass term (complex, as in ``fvf.design_field``). Per backend: the
factorization, one solve, and a block of 100 right-hand sides (per right-hand side),
best of three, BLAS on one thread (threadpoolctl). ``solves="few"`` picks the backend
with the fastest factorization, ``solves="many"`` the one with the fastest solves;
the last column says which one each rule picks here.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from threadpoolctl import threadpool_limits

import fvf
from fvf.numerics.cholesky import available_backends, factor_hermitian

SHARED = Path(
    os.environ.get("FVF_SHARED_MESHES", Path(__file__).resolve().parents[2] / "shared" / "meshes")
)
MESHES = ["spot.obj", "fertility.off", "rocker-arm.obj", "armadillo.obj"]


def dual_laplacian(mesh: fvf.TriMesh) -> sp.csr_array:
    """D^T D + 1e-3 I over the interior edges' face pairs, float64 (m, m)."""
    ef = mesh.edge_faces[(mesh.edge_faces >= 0).all(axis=1)]
    k, m = ef.shape[0], mesh.n_faces
    D = sp.csr_array(
        (np.r_[np.ones(k), -np.ones(k)], (np.r_[np.arange(k), np.arange(k)], ef.T.ravel())),
        shape=(k, m),
    )
    return sp.csr_array(D.T @ D + 1e-3 * sp.eye_array(m))


def best(func, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=MESHES)
    args = parser.parse_args()
    threadpool_limits(1)
    backends = [b for b in available_backends() if b != "scipy"] + ["scipy"]
    rng = np.random.default_rng(0)
    print("| mesh | system | unknowns | backend | factor (ms) | 1 solve (ms) | per rhs, 100 (ms) |")
    print("|---|---|---|---|---|---|---|")
    for name in args.meshes:
        path = SHARED / name
        if not path.exists():
            print(f"| {name} | missing | | | | | |")
            continue
        mesh = fvf.TriMesh(*fvf.read_mesh(path))
        systems = {
            "dual Laplacian (real)": dual_laplacian(mesh),
            "connection Laplacian (complex)": sp.csr_array(
                fvf.connection_laplacian(mesh, n=4) + sp.diags_array(1e-3 * mesh.face_areas)
            ),
        }
        for label, K in systems.items():
            dtype = complex if np.iscomplexobj(K.data) else float
            B = rng.standard_normal((K.shape[0], 100)).astype(dtype)
            timings = {}
            for backend in backends:
                if backend == "scipy" and K.shape[0] > 50_000:
                    continue  # minutes; not a contender at this size
                fac = factor_hermitian(K, backend)
                timings[backend] = (
                    best(lambda b=backend, K=K: factor_hermitian(K, b)),
                    best(lambda f=fac, B=B: f.solve(B[:, 0])),
                    best(lambda f=fac, B=B: f.solve(B), repeats=1) / B.shape[1],
                )
            for backend, (fa, one, per) in timings.items():
                print(
                    f"| {name} | {label} | {K.shape[0]:,} | {backend} | {1e3 * fa:.1f} | "
                    f"{1e3 * one:.2f} | {1e3 * per:.2f} |",
                    flush=True,
                )
            few = factor_hermitian(K, "auto", solves="few").backend
            many = factor_hermitian(K, "auto", solves="many").backend
            fastest_factor = min(timings, key=lambda b: timings[b][0])
            fastest_solves = min(timings, key=lambda b: timings[b][2])
            print(
                f"| {name} | {label} | | auto: few -> {few}, many -> {many} | fastest "
                f"{fastest_factor} | | fastest {fastest_solves} |"
            )


if __name__ == "__main__":
    main()
