"""The exponential action (fvf.numerics.expm.expm_action) against scipy's expm_multiply on flows.

Run from the repository root::

    .venv/bin/python benchmarks/bench_expmv.py            # ~10k, ~100k, ~1M faces
    .venv/bin/python benchmarks/bench_expmv.py --quick    # ~6k and ~23k faces only
    .venv/bin/python benchmarks/bench_expmv.py --sizes 1e4,1e5 --lengths 1,10

Meshes are the built-in spot (5856 faces) refined by 1-to-4 midpoint subdivision
(``bench_core.refine``), at the level whose face count is log-closest to each size;
``--mesh PATH`` starts from another mesh instead (``--mesh ../shared/meshes/bob_tri.obj
--sizes 1e4``: 10,688 faces, the issue's ~10k).

Operators. A = −D^V_v with the inner product of the vertex areas A_V, for two unit-speed
fields (max |v| = 1, so t = L · mean edge length moves a function about L edges):

- ``skew``: v = J grad g, g = height (y). [A_V] D^V_v is skew-symmetric, so the flow keeps
  the A_V-norm and expm_action uses its three-term (Lanczos-type) recurrence.
- ``grad``: v = grad g (compressible). The discrete flow can grow norms enormously on
  irregular meshes (CHAPTER.md, "Facts we measured"); for t ≤ 10 edge lengths on these
  meshes the growth ‖f(t)‖/‖f_0‖ is printed (column "growth") and stays close to 1.

Runs, for t = 0.1, 1, 10 mean edge lengths: one right-hand side at one time ("1 rhs"), a
block of 8 right-hand sides ("8 rhs"), and one right-hand side at 16 times spread over
(0, t] ("16 t").

Columns. "K" is expm_action with its default ``method="auto"``, called as
fvf.FunctionalFlow calls it (``skew=True`` for J grad y, ``skew=False`` for grad y): the
Chebyshev series (``cheb``) from R·t ≥ 20 on for blocks, from 30 for one column of grad y
(4 without numba's kernels), R = fvf.numerics.expm.skew_bound, except for a skew operator with
several times or (with numba's kernels; without them from 20k vertices on) one
right-hand side, else the Krylov method (``lanczos`` for skew-adjoint A, ``iom``
otherwise); column ``method`` says which ran (fvf.numerics.expm.choose_method).

- ``K prod``: column products of expm_action at tol = 1e-10 (a product with an (n, 8)
  block counts 8), plus the products with |A| spent on the Chebyshev bound R (counted
  as products); ``/blk`` is the number of operator calls.
- ``EM prod``: products of scipy's expm_multiply, counted by wrapping A in
  ``fvf.numerics.expm.ExpmvCounter`` (with ``traceA``): products with A, then (+) with Aᵀ that
  its 1-norm estimates spend. Those estimates start from random vectors (numpy's global
  generator), so the counts vary by up to ~10 % between runs: the mean over seeds 0–2
  (seed 0 alone from 200k vertices on). For several times it is chained over the sorted times, as
  ``fvf.FunctionalFlow`` does today.
- ``ratio``: EM (A and Aᵀ) / K products. ``ratio14``: the same against expm_action at
  tol = 1e-14, i.e. at the accuracy expm_multiply aims at (its tolerance is fixed at
  2⁻⁵³ and cannot be loosened to 1e-10).
- ``err W`` / ``err max``: expm_action's error against expm_multiply, relative, in the
  A_V norm (the norm tol refers to) and in the max norm.
- ``K wall`` / ``EM wall``: best wall times (expm_multiply on the sparse matrix itself).
- ``floor``: K products × the time of one sparse product ``A @ x`` (for 8-column runs
  with block products, Chebyshev or Lanczos, block products × the time of ``A @ X`` with
  X (n, 8), which is cheaper per column; the bound's products at the one-column time).
  The products are timed (best of 3) right after each K run, so that a run and its floor
  come from the same stretch of this shared machine, whose speed drifts by up to 1.5x
  between minutes; ``floor`` is the median over these rounds (at least 3) and
  ``K/floor`` the median of the rounds' ratios (K wall is the best run).
  ``K/(fl+out)``: the same against floor + the time of one GEMM (T, m) @ (m, n·p)
  forming T outputs from m vectors, work that any method producing T outputs from m
  vectors does and that the products floor leaves out (0 for one time).
- ``Kry wall``: the Krylov method's wall time (``method="krylov"``), for comparison: the
  Chebyshev series spends more products than Krylov at lower cost each.

Goals (the issue): at t = 10 edge lengths, ratio ≥ 3 and K wall ≤ 1.5 × floor.

With numba installed (``pip install 'fvf[fast]'``) expm_action fuses each term's product
with its axpy, copy or norm (fvf.numerics._kernels); ``FVF_NUMBA=0`` runs the numpy/scipy path. The
script prints which ran.

BLAS pools are pinned to one thread with threadpoolctl after numpy and scipy.linalg are
loaded (both ship their own OpenBLAS); the script prints what it pinned.
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import sys
import time
import warnings
from collections.abc import Callable

import numpy as np
import scipy
import scipy.linalg  # noqa: F401  (load scipy's OpenBLAS before pinning threads)
import scipy.sparse.linalg as spla
from threadpoolctl import threadpool_info, threadpool_limits

import fvf
from fvf.numerics import _kernels
from fvf.numerics.expm import ExpmvCounter, expm_action

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_core import pick_levels, print_table, refine  # noqa: E402

TOL = 1e-10
LENGTHS = (0.1, 1.0, 10.0)
GOAL_RATIO = 3.0
GOAL_FLOOR = 1.5
BLOCK = 8
N_TIMES = 16
MIN_ROUNDS = 3


def best(fn: Callable[[], object], reps: int, budget: float = 4.0) -> tuple[float, object]:
    """Best wall time of fn() over up to ``reps`` runs (at least 1, stops after budget s)."""
    out = None
    t_best = math.inf
    start = time.perf_counter()
    gc.collect()
    for _ in range(reps):
        gc.disable()
        try:
            t0 = time.perf_counter()
            out = fn()
            t_best = min(t_best, time.perf_counter() - t0)
        finally:
            gc.enable()
        if time.perf_counter() - start > budget:
            break
    return t_best, out


def product_time(A, cols: int, reps: int | None = None, budget: float = 2.0) -> float:
    """Best time of one sparse product A @ x (cols = 1) or A @ X with X (n, cols)."""
    n = A.shape[0]
    x = np.random.default_rng(0).standard_normal((n, cols) if cols > 1 else n)
    if reps is None:
        reps = int(np.clip(2e7 / (A.nnz * cols), 10, 200))
    return best(lambda: A @ x, reps, budget=budget)[0]


def rounds_with_floor(
    fn: Callable[[], object], A, cols: int, reps: int, budget: float = 4.0
) -> list[tuple[float, float, float]]:
    """Rounds of (wall time of one fn(), best of 3 products on ``cols`` columns, best of 3
    products on one column), each product timed right after the run, so that a run and
    its floor come from the same stretch of this shared machine (its speed drifts by up
    to 1.5x between minutes). At least MIN_ROUNDS rounds (a median of one round at ~1M
    faces moved by 1.3x between runs), up to ``reps`` within ``budget`` s."""
    out = []
    start = time.perf_counter()
    for _ in range(max(reps, MIN_ROUNDS)):
        t_fn = best(fn, 1)[0]
        t_cols = product_time(A, cols, reps=3, budget=0.5)
        t_one = product_time(A, 1, reps=3, budget=0.5) if cols > 1 else t_cols
        out.append((t_fn, t_cols, t_one))
        if len(out) >= MIN_ROUNDS and time.perf_counter() - start > budget:
            break
    return out


def fields(mesh):
    """(name, A = −D^V_v) for the unit-speed fields J grad y and grad y."""
    g = mesh.vertices[:, 1]
    grad = fvf.gradient(mesh, g)
    out = []
    for name, v in (("skew", fvf.rotate(mesh, grad)), ("grad", grad)):
        v = v / np.linalg.norm(v, axis=1).max()
        out.append((name, (-fvf.D_V(mesh, v, tangent="ignore")).tocsr()))
    return out


def initial(mesh, p: int) -> np.ndarray:
    """Smooth initial functions: (n,) for p = 1, else (n, p)."""
    X = mesh.vertices - mesh.vertices.mean(0)
    X = X / np.abs(X).max()
    cols = [np.sin(3 * X[:, 0] + k) + X[:, 1] * np.cos(2 * X[:, 2] - k) for k in range(p)]
    return cols[0] if p == 1 else np.stack(cols, axis=1)


def em_chain(A, B, times, counter: ExpmvCounter | None = None):
    """expm_multiply over the sorted times (one call per time, as FunctionalFlow does)."""
    out = np.empty((len(times),) + B.shape)
    cur, now = B, 0.0
    trace = float(A.diagonal().sum())
    for i in np.argsort(times):
        dt = times[i] - now
        if counter is None:
            cur = spla.expm_multiply(dt * A, cur)
        else:
            cur = spla.expm_multiply(dt * counter, cur, traceA=dt * trace)
        now = times[i]
        out[i] = cur
    return out


def wnorm(x, w) -> float:
    x = np.asarray(x)
    return float(np.sqrt(np.einsum("i,i...->...", w, x * x).sum()))


def output_time(m: int, T: int, B) -> float:
    """Best time of forming T outputs from m vectors like B: one GEMM (T, m) @ (m, n·p)."""
    if T == 1:
        return 0.0  # one time: each vector is added once (counted in the floor's products)
    rng = np.random.default_rng(1)
    Y = rng.standard_normal((m, B.size))
    C = rng.standard_normal((T, m))
    return best(lambda: C @ Y, 5, budget=1.0)[0]


def run_case(A, w, B, times, reps, skew) -> dict:
    """One configuration: expm_action vs expm_multiply on exp(tA)B."""
    scalar = np.ndim(times) == 0
    tlist = np.atleast_1d(times)
    p = 1 if B.ndim == 1 else B.shape[1]
    # expm_multiply: counted run (LinearOperator path), then timed run (sparse path)
    # expm_multiply's 1-norm estimates start from random ±1 vectors (numpy's global
    # generator), so its product count varies from run to run by up to ~10 %: the mean over
    # seeds 0, 1, 2 (seed 0 only from 200k vertices on)
    seeds = (0, 1, 2) if A.shape[0] < 200_000 else (0,)
    em_A, em_AT = [], []
    for seed in seeds:
        counter = ExpmvCounter(A)
        np.random.seed(seed)  # noqa: NPY002 (scipy draws from the legacy global generator)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            em_counted = em_chain(A, B, tlist, counter)
        em_A.append(counter.matvecs)
        em_AT.append(counter.rmatvecs)
    em_A_mean, em_AT_mean = float(np.mean(em_A)), float(np.mean(em_AT))
    em_reps = max(1, min(reps, 3))
    t_em, em = best(lambda: em_chain(A, B, tlist), em_reps, budget=2.0)
    ref = em[0] if scalar else em
    # expm_action at tol and at 1e-14
    kw = dict(inner=w, skew=skew)
    # each run with the products timed right after it, on the call's p columns (blocks for
    # the series and Lanczos) and on one (the bound's products)
    rounds = rounds_with_floor(lambda: expm_action(A, B, times, tol=TOL, **kw), A, p, reps)
    t_k = min(r[0] for r in rounds)
    t_kry, _ = best(lambda: expm_action(A, B, times, tol=TOL, method="krylov", **kw), reps)
    x, info = expm_action(A, B, times, tol=TOL, return_info=True, **kw)
    _, info14 = expm_action(A, B, times, tol=1e-14, return_info=True, **kw)
    x_sc = x if not scalar else x[None]
    errs_w = [wnorm(x_sc[k] - em[k], w) / wnorm(em[k], w) for k in range(len(tlist))]
    errs_m = [np.abs(x_sc[k] - em[k]).max() / np.abs(em[k]).max() for k in range(len(tlist))]
    k_prod = info["matvecs"] + info["bound_products"]

    def floor_of(t_cols: float, t_one: float) -> float:
        if p > 1 and info["method"] in ("lanczos", "chebyshev"):  # block products on (n, p)
            return info["block_matvecs"] * t_cols + info["bound_products"] * t_one
        return k_prod * t_one  # single-column products (the general method: column by column)

    # the median over the rounds of (run / its own floor); floor: the median floor
    floors = [floor_of(tc, to) for _, tc, to in rounds]
    k_floor = float(np.median([r[0] / f for r, f in zip(rounds, floors, strict=True)]))
    floor = float(np.median(floors))
    t_out = output_time(info["block_matvecs"], tlist.size, B)
    k_out = float(np.median([r[0] / (f + t_out) for r, f in zip(rounds, floors, strict=True)]))
    return {
        "growth": wnorm(em[-1] if not scalar else ref, w) / wnorm(B, w),
        "k_prod": k_prod,
        "k_blk": info["block_matvecs"],
        "k_sizes": info["basis_sizes"],
        "k14": info14["matvecs"] + info14["bound_products"],
        "em_A": round(em_A_mean),
        "em_AT": round(em_AT_mean),
        "em_diff": float(np.abs(em_counted - em).max() / np.abs(em).max()),
        "ratio": (em_A_mean + em_AT_mean) / k_prod,
        "ratio14": (em_A_mean + em_AT_mean) / (info14["matvecs"] + info14["bound_products"]),
        "err_w": max(errs_w),
        "err_max": max(errs_m),
        "est": info["error_estimate"],
        "t_k": t_k,
        "t_kry": t_kry,
        "t_em": t_em,
        "floor": floor,
        "k_floor": k_floor,
        "k_out": k_out,
        "rounds": len(rounds),
        "method": {"chebyshev": "cheb"}.get(info["method"], info["method"]),
    }


HEADERS = [
    "L",
    "run",
    "method",
    "growth",
    "K prod/blk",
    "EM prod",
    "ratio",
    "K@1e-14",
    "ratio14",
    "err W",
    "err max",
    "K wall",
    "EM wall",
    "floor",
    "K/floor",
    "K/(fl+out)",
    "EM/K wall",
    "Kry wall",
]
WIDTHS = [4, 6, 7, 6, 10, 10, 6, 7, 7, 8, 8, 9, 9, 9, 7, 10, 9, 9]


def print_row(cells: list[str]) -> None:
    """One table row, printed as soon as it is measured (the ~1M-face rows take minutes)."""
    print(
        "  "
        + "  ".join(
            c.ljust(wd) if i < 2 else c.rjust(wd)
            for i, (c, wd) in enumerate(zip(cells, WIDTHS, strict=True))
        ),
        flush=True,
    )


def fmt_t(t: float) -> str:
    return f"{t * 1e3:.1f} ms" if t < 1 else f"{t:.2f} s"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="only ~6k and ~23k faces")
    ap.add_argument("--sizes", default="1e4,1e5,1e6", help="target face counts")
    ap.add_argument(
        "--lengths", default=",".join(str(x) for x in LENGTHS), help="times in mean edge lengths"
    )
    ap.add_argument("--fields", default="skew,grad")
    ap.add_argument(
        "--mesh",
        default="spot",
        help="base mesh, refined by 1-to-4 subdivision: spot (built in, 5,856 faces) or a "
        "mesh file, e.g. ../shared/meshes/bob_tri.obj (10,688 faces)",
    )
    args = ap.parse_args()

    limits = threadpool_limits(1)
    print(
        f"fvf {fvf.__version__ if hasattr(fvf, '__version__') else '?'}, "
        f"numpy {np.__version__}, scipy {scipy.__version__}"
    )
    print(
        "BLAS pinned to one thread:",
        ", ".join(
            f"{i['internal_api']} ({os.path.basename(i['filepath'])}) = {i['num_threads']}"
            for i in threadpool_info()
        ),
    )
    print(
        "fused kernels (fvf.numerics._kernels):",
        f"numba {__import__('numba').__version__}" if _kernels.ENABLED else "off",
        "(set FVF_NUMBA=0 for the numpy/scipy path)",
    )
    lengths = [float(x) for x in args.lengths.split(",")]
    want = set(args.fields.split(","))
    if args.mesh == "spot":
        title, base = "spot", fvf.mesh.builtin.spot()
    else:
        title, base = os.path.basename(args.mesh), fvf.TriMesh(*fvf.read_mesh(args.mesh))
    if args.quick:
        levels = [0, 1]
    else:
        levels = pick_levels([float(s) for s in args.sizes.split(",")], base.n_faces)

    summary = []
    for level in levels:
        mesh = fvf.TriMesh(*refine(base.vertices, base.faces, level))
        n, m = mesh.n_vertices, mesh.n_faces
        # best of up to 40 runs within each case's budget: at ~6k faces a call takes a
        # few ms and this shared machine's run-to-run spread is ±30 %
        reps = int(np.clip(round(2e7 / m), 2, 40))
        h = mesh.mean_edge_length
        w = mesh.vertex_areas
        print(
            f"\n== {title} level {level}: n = {n:,} vertices, m = {m:,} faces, "
            f"mean edge {h:.4g}, best of <= {reps}"
        )
        for name, A in fields(mesh):
            if name not in want:
                continue
            t_mv = product_time(A, 1)
            t_mm = product_time(A, BLOCK)
            print(
                f"\n-- field {name}: nnz = {A.nnz:,}; one product {fmt_t(t_mv)}, "
                f"(n, {BLOCK}) block {fmt_t(t_mm)} ({t_mm / BLOCK / t_mv:.2f} per column)"
            )
            print_row(HEADERS)
            print("  " + "-" * (sum(WIDTHS) + 2 * (len(WIDTHS) - 1)))
            for L in lengths:
                t = L * h
                configs = [
                    ("1 rhs", initial(mesh, 1), t),
                    (f"{BLOCK} rhs", initial(mesh, BLOCK), t),
                    (f"{N_TIMES} t", initial(mesh, 1), t * np.arange(1, N_TIMES + 1) / N_TIMES),
                ]
                for label, B, times in configs:
                    skew = name == "skew"  # as fvf.FunctionalFlow does (False: far from skew)
                    r = run_case(A, w, B, times, reps, skew)
                    summary.append((m, name, L, label, r))
                    print_row(
                        [
                            f"{L:g}",
                            label,
                            r["method"],
                            f"{r['growth']:.3g}",
                            f"{r['k_prod']}/{r['k_blk']}",
                            f"{r['em_A']}+{r['em_AT']}",
                            f"{r['ratio']:.2f}",
                            f"{r['k14']}",
                            f"{r['ratio14']:.2f}",
                            f"{r['err_w']:.1e}",
                            f"{r['err_max']:.1e}",
                            fmt_t(r["t_k"]),
                            fmt_t(r["t_em"]),
                            fmt_t(r["floor"]),
                            f"{r['k_floor']:.2f}",
                            f"{r['k_out']:.2f}",
                            f"{r['t_em'] / r['t_k']:.1f}x",
                            fmt_t(r["t_kry"]),
                        ]
                    )
    # ---- goals at t = 10 edge lengths
    print(
        "\n== goals at t = 10 mean edge lengths "
        f"(ratio >= {GOAL_RATIO:g}, K wall <= {GOAL_FLOOR:g} x floor)"
    )
    rows = []
    for m, name, L, label, r in summary:
        if L != 10.0:
            continue
        rows.append(
            [
                f"{m:,}",
                name,
                label,
                r["method"],
                f"{r['ratio']:.2f}",
                "pass" if r["ratio"] >= GOAL_RATIO else "MISS",
                f"{r['k_floor']:.2f}",
                "pass" if r["k_floor"] <= GOAL_FLOOR else "MISS",
                f"{r['err_w']:.1e}",
                f"{r['k_out']:.2f}",
                f"{r['t_kry'] / r['t_k']:.2f}",
            ]
        )
    if rows:
        print_table(
            [
                "faces",
                "field",
                "run",
                "method",
                "ratio",
                "goal",
                "K/floor",
                "goal",
                "err W",
                "K/(fl+out)",
                "Kry/K wall",
            ],
            rows,
        )
    limits.restore_original_limits()


if __name__ == "__main__":
    main()
