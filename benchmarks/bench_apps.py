"""Benchmark the Lie-bracket applications: Ad transport (eq. 67) and ACAP fields (§4.4.2).

Run from the repository root::

    .venv/bin/python benchmarks/bench_apps.py            # ~10k, ~100k, ~1M faces
    .venv/bin/python benchmarks/bench_apps.py --quick    # the two small sizes
    .venv/bin/python benchmarks/bench_apps.py --sizes 2e4 --acap-timeout 600

Meshes are the spot mesh refined by 1-to-4 midpoint subdivision (``bench_core.py``'s
helpers; 5,856 / 93,696 / 1,499,136 faces for the default sizes). BLAS runs on one thread
(threadpoolctl).

Transport: v = e_z × (x − c) projected per face and scaled to max|v| = 1, u = grad sin(5x).
Times are given in units of 10 mean edge lengths h̄: "t = 1" is the physical time 10 h̄,
over which the fastest point of the flow moves 10 h̄ (so the work is about the same at every
size). A product is one matrix-vector product (one column) with G = [I_F^V] ad_v or with
Gᵀ; expm_multiply also spends products on its 1-norm estimates, all of which are counted.
Both exponential actions are run: ``fvf.numerics.expm.expm_action`` (the default of FieldTransport)
and ``scipy.sparse.linalg.expm_multiply`` (expm_action at tol 1e-10); "rel diff" is the
largest difference between the two results relative to the largest entry.
floor = (products with G) x (time of one) + (products with Gᵀ) x (time of one); wall/floor
close to 1 means that the products are all the time (the rest: expm_multiply's vector
work and Python overhead).

ACAP: ``acap_fields(mesh, v, 1e-2, k=4)`` with v = J grad y (unit L2 norm), run in a child
process with a time limit (``--acap-timeout``); its stages are printed as they finish, so a
run that hits the limit still reports the assembly. ``--acap-solver`` picks the eigensolver
(auto: the direct factorization below 120k faces, the multilevel LOBPCG of
``fvf.multilevel`` from there on); the table gives time, peak RSS, the largest relative
residual of the 4 pairs and the LOBPCG iterations. The ACAP sizes alone, e.g. at 375k and
1.5M faces with the multilevel solver::

    .venv/bin/python benchmarks/bench_apps.py --acap-only --sizes 4e5,1.5e6
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np
import scipy

import fvf

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_core import fmt_bytes, fmt_time, peak_rss, pick_levels, print_table, spot_level  # noqa: E402

ACAP_CHILD_FLAG = "--_acap-child"
TIMES = (0.1, 1.0)  # in units of 10 mean edge lengths


def best(fn, reps: int, budget: float = 2.0) -> float:
    """Best wall time of fn() over up to reps runs (at least one, stop after budget s)."""
    out = math.inf
    gc.collect()
    start = time.perf_counter()
    for _ in range(reps):
        gc.disable()
        try:
            t0 = time.perf_counter()
            fn()
            out = min(out, time.perf_counter() - t0)
        finally:
            gc.enable()
        if time.perf_counter() - start > budget:
            break
    return out


def transport_fields(mesh: fvf.TriMesh) -> tuple[np.ndarray, np.ndarray]:
    C = mesh.face_centroids
    v = mesh.project_tangent(np.cross([0.0, 0.0, 1.0], C - C.mean(0)))
    v /= np.linalg.norm(v, axis=1).max()
    u = fvf.gradient(mesh, np.sin(5.0 * mesh.vertices[:, 0]))
    return v, u


def bench_transport(V: np.ndarray, F: np.ndarray, formed: bool) -> dict:
    mesh = fvf.TriMesh(V, F)
    m = mesh.n_faces
    reps = int(np.clip(round(1e6 / m), 3, 20))
    v, u = transport_fields(mesh)
    h = mesh.mean_edge_length
    out: dict = dict(m=m, h=h)

    t0 = time.perf_counter()
    T = fvf.FieldTransport(mesh, v)
    out["build"] = time.perf_counter() - t0
    op = T.operator
    out["factor_bytes"] = sum(a.nbytes for a in (op.ad.data, op.ad.indices, op.ad.indptr)) + sum(
        a.nbytes for a in (op.vertex_to_face.data, op.vertex_to_face.indices)
    )
    x = u.ravel()
    out["one"] = best(lambda: op.matvec(x), reps)
    op.rmatvec(x)  # builds ad_vᵀ once, outside the timings
    out["one_adj"] = best(lambda: op.rmatvec(x), reps)

    rows, refs = [], {}
    for method in ("auto", "expm_multiply"):
        T.method = method
        for t in TIMES:
            tt = t * 10.0 * h
            runs, wall, fwd, adj = max(1, reps // 4), math.inf, 0, 0
            start = time.perf_counter()
            for i in range(runs):
                op.reset_counts()
                t0 = time.perf_counter()
                res = T(u, tt).fields
                wall = min(wall, time.perf_counter() - t0)
                if i == 0:
                    fwd, adj = op.n_matvec, op.n_rmatvec  # products of one call
                if time.perf_counter() - start > 1.0:
                    break
            refs[method, t] = res
            floor = fwd * out["one"] + adj * out["one_adj"]
            name = "krylov" if method == "auto" else method
            rows.append(dict(t=t, method=name, wall=wall, fwd=fwd, adj=adj, floor=floor))
    for row in rows:  # the two actions against each other (independent algorithms)
        a, b = refs["auto", row["t"]], refs["expm_multiply", row["t"]]
        row["err"] = float(np.abs(a - b).max() / np.abs(b).max())
    out["runs"] = rows

    if formed:
        t0 = time.perf_counter()
        G = T.generator
        out["form"] = time.perf_counter() - t0
        out["form_bytes"] = G.data.nbytes + G.indices.nbytes + G.indptr.nbytes
        out["form_nnz"] = G.nnz
        out["form_one"] = best(lambda: G @ x, reps)
        out["trace_err"] = abs(G.diagonal().sum() - op.trace) / max(abs(op.trace), 1e-300)
        del G
        T._generator = None
    return out


# ------------------------------------------------------------------------------ ACAP
def acap_child(path: str, solver: str = "auto") -> None:
    """Stages of acap_fields on a fresh mesh, one JSON line each as it finishes."""
    from threadpoolctl import threadpool_limits

    from fvf.design.commuting import ACAP_MULTILEVEL_MIN_FACES, acap_energy_matrix
    from fvf.design.connection import real_connection_laplacian, tangent_basis_matrix
    from fvf.numerics.eigen import eigen_residuals, smallest_eigenpairs
    from fvf.numerics.multilevel import face_field_eigenpairs
    from fvf.operators.brackets import ad

    with threadpool_limits(1):
        d = np.load(path)
        V, F = d["V"], d["F"]

        def emit(**kw):
            print(json.dumps(kw), flush=True)

        def field(mesh):
            v = fvf.rotate(mesh, fvf.gradient(mesh, mesh.vertices[:, 1]))
            return v / np.sqrt(mesh.face_areas @ (v * v).sum(1))

        # the parts of E_B, each on a fresh mesh (no shared caches)
        mesh = fvf.TriMesh(V, F)
        v = field(mesh)
        t0 = time.perf_counter()
        ad(mesh, v, tangent="ignore")
        emit(stage="ad_v", t=time.perf_counter() - t0)
        t0 = time.perf_counter()
        real_connection_laplacian(mesh, "knoppel")
        tangent_basis_matrix(mesh)
        emit(stage="L_conn + B", t=time.perf_counter() - t0)
        mesh = fvf.TriMesh(V, F)
        v = field(mesh)
        t0 = time.perf_counter()
        E = acap_energy_matrix(mesh, v, 1e-2)
        emit(stage="E_B assembly (all)", t=time.perf_counter() - t0, nnz=int(E.nnz))
        mass = np.repeat(mesh.face_areas, 2)
        if solver == "auto":
            solver = "multilevel" if mesh.n_faces >= ACAP_MULTILEVEL_MIN_FACES else "direct"
        t0 = time.perf_counter()
        info: dict = {}
        if solver == "multilevel":
            lam, X = face_field_eigenpairs(mesh, E, 4, info=info)
        else:
            lam, X = smallest_eigenpairs(E, mass, 4)
        t = time.perf_counter() - t0
        res = eigen_residuals(E, mass, lam, X)
        emit(
            stage="eigensolve",
            solver=solver,
            t=t,
            lam=[float(x) for x in lam],
            res=[float(x) for x in res],
            **{
                key: (val if not isinstance(val, np.ndarray) else val.tolist())
                for key, val in info.items()
                if key != "residuals"
            },
        )
        emit(stage="peak RSS", bytes=peak_rss())


def bench_acap(
    V: np.ndarray, F: np.ndarray, timeout: float, solver: str = "auto"
) -> tuple[list[dict], str]:
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "mesh.npz")
        np.savez(path, V=V, F=F)
        cmd = [sys.executable, os.path.abspath(__file__), ACAP_CHILD_FLAG, path, solver]
        status = "ok"
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
            text = proc.stdout
            if proc.returncode != 0:
                status = f"failed: {proc.stderr.strip().splitlines()[-1:]}"
        except subprocess.TimeoutExpired as exc:
            text = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
            status = f"stopped after {timeout:.0f} s"
    return [json.loads(line) for line in text.splitlines() if line.startswith("{")], status


# ------------------------------------------------------------------------------ main
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="only the two small sizes")
    ap.add_argument("--sizes", default="1e4,1e5,1e6", help="target face counts")
    ap.add_argument("--acap-timeout", type=float, default=1800.0, help="seconds per ACAP run")
    ap.add_argument(
        "--acap-solver",
        default="auto",
        choices=("auto", "direct", "multilevel"),
        help="eigensolver of acap_fields (auto: multilevel from 120k faces)",
    )
    ap.add_argument("--acap-only", action="store_true", help="skip the transport benchmark")
    ap.add_argument("--no-acap", action="store_true")
    ap.add_argument(
        "--no-formed", action="store_true", help="skip forming G (2.7 GB at 1.5M faces)"
    )
    args = ap.parse_args()

    from threadpoolctl import threadpool_info, threadpool_limits

    limiter = threadpool_limits(1)  # noqa: F841  (kept alive for the whole run)
    print("fvf applications benchmark: Ad transport and ACAP fields")
    print(
        f"  python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
        f"fvf {fvf.__version__}; os.cpu_count() = {os.cpu_count()}"
    )
    print(
        "  threads: threadpool_limits(1) -> "
        + ", ".join(f"{p.get('internal_api')}={p.get('num_threads')}" for p in threadpool_info())
    )
    print(
        "  transport times t in units of 10 mean edge lengths (t = 1: max displacement 10 h̄); "
        "max|v| = 1"
    )

    targets = [float(s) for s in args.sizes.split(",") if s.strip()]
    if args.quick:
        targets = sorted(targets)[:2]
    levels = pick_levels(targets, fvf.mesh.builtin.spot().n_faces)
    trows, frows, acap = [], [], []
    for level in levels:
        V, F = spot_level(level)
        m = F.shape[0]
        print(f"\n== spot x{4**level}: n = {V.shape[0]:,}, m = {m:,} faces ==", flush=True)
        if args.acap_only:
            r: dict = dict(runs=[])
        else:
            r = bench_transport(V, F, formed=not args.no_formed)
            print(
                f"  FieldTransport build {fmt_time(r['build'])}; "
                f"factors {fmt_bytes(r['factor_bytes'])} "
                f"(+ ad_vᵀ, same size); one product G {fmt_time(r['one'])}, Gᵀ "
                f"{fmt_time(r['one_adj'])}",
                flush=True,
            )
        for run in r["runs"]:
            trows.append(
                [
                    f"{m:,}",
                    f"{run['t']:g}",
                    run["method"],
                    fmt_time(run["wall"]),
                    f"{run['fwd']}",
                    f"{run['adj']}",
                    fmt_time(r["one"]),
                    f"{run['wall'] / run['floor']:.2f}",
                    f"{run['err']:.1e}",
                ]
            )
            print("  t = " + "  ".join(trows[-1][1:]), flush=True)
        if "form" in r:
            frows.append(
                [
                    f"{m:,}",
                    fmt_time(r["form"]),
                    fmt_bytes(r["form_bytes"]),
                    f"{r['form_nnz'] / m:.0f}",
                    fmt_time(r["form_one"]),
                    fmt_time(r["one"]),
                    f"{r['trace_err']:.1e}",
                ]
            )
        if not args.no_acap:
            stages, status = bench_acap(V, F, args.acap_timeout, args.acap_solver)
            acap.append((m, stages, status))
            for s in stages:
                print(f"  ACAP {s}", flush=True)
            print(f"  ACAP status: {status}", flush=True)

    if trows:
        print(
            "\n== Ad transport: fvf expm_action (krylov) vs scipy expm_multiply"
            " (G as a LinearOperator, exact trace); rel diff = max|krylov - expm_multiply| / max| |"
        )
        print_table(
            [
                "faces",
                "t (10 h̄)",
                "action",
                "wall",
                "prod G",
                "prod Gᵀ",
                "one product",
                "wall/floor",
                "rel diff",
            ],
            trows,
        )
    if frows:
        print("\n  G formed as a sparse matrix (not used by FieldTransport), for comparison:")
        print_table(
            ["faces", "form G", "G bytes", "nnz/face", "G product", "factored", "trace rel.err"],
            frows,
        )
    if acap:
        print("\n== ACAP fields, acap_fields(mesh, v, 1e-2, k=4) (fresh process per size) ==")
        rows = []
        for m, stages, status in acap:
            by = {s["stage"]: s for s in stages}

            def t(name, by=by):
                return fmt_time(by[name]["t"]) if name in by else "-"

            total = (
                fmt_time(by["E_B assembly (all)"]["t"] + by["eigensolve"]["t"])
                if "eigensolve" in by
                else "-"
            )
            rss = fmt_bytes(by["peak RSS"]["bytes"]) if "peak RSS" in by else "-"
            eig = by.get("eigensolve", {})
            rows.append(
                [
                    f"{m:,}",
                    eig.get("solver", "-"),
                    t("ad_v"),
                    t("L_conn + B"),
                    t("E_B assembly (all)"),
                    t("eigensolve"),
                    total,
                    rss,
                    f"{max(eig['res']):.1e}" if "res" in eig else "-",
                    str(eig.get("iterations", "-")),
                    status,
                ]
            )
        print_table(
            [
                "faces",
                "solver",
                "ad_v",
                "L_conn+B",
                "E_B all",
                "eigensolve",
                "total",
                "peak RSS",
                "max res",
                "LOBPCG its",
                "status",
            ],
            rows,
        )
        print(
            "  max res: largest relative residual of the 4 pairs (fvf.eigen_residuals; "
            "both solvers target 1e-8)"
        )


if __name__ == "__main__":
    if len(sys.argv) in (3, 4) and sys.argv[1] == ACAP_CHILD_FLAG:
        acap_child(*sys.argv[2:])
    else:
        main()
