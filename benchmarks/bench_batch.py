"""Benchmark ``fvf.batch``: a batch of meshes on 1 and 2 Dask workers against a serial loop.

Run from the repository root::

    .venv/bin/python benchmarks/bench_batch.py                 # mixed + small corpora, 3 repeats
    .venv/bin/python benchmarks/bench_batch.py --repeats 5 --k 20
    .venv/bin/python benchmarks/bench_batch.py --quick         # smoke test (fewer meshes, 1 repeat)
    .venv/bin/python benchmarks/bench_batch.py --in-worker --only small   # loop here vs in a worker

Two corpora, written to a temporary folder (the shared meshes are read from
``../shared/meshes`` or ``$FVF_SHARED_MESHES`` and never copied):

- **mixed**: every shared mesh up to ~23k faces (12 meshes: knight, woody, spot, bunny,
  fertility, bob, 3holes, rocker-arm, camelhead, sphere_s2, faust, lion) and generated
  spheres, jittered spheres, tori and disks of 80 to 23k faces: 40 meshes in all;
- **small**: 40 generated meshes of 80 to 1,300 faces (42 to 650 vertices), where the
  per-mesh cost of the batch machinery (scheduling, hashing, the result file) shows most.
  The loop and a 1-worker batch also run over 40, 120 and 200 such meshes: the slope of
  a line fitted through all runs is the cost of one more mesh, the intercept the per-run
  cost.

Each mesh runs the default tasks (``info, basis, fields, singularities``, ``k``
eigenpairs). The **serial loop** calls the same library functions in this process, one
mesh after the other, and writes each mesh's arrays with ``numpy.savez`` (the batch
writes one result file per mesh too, and fsyncs it). The **run_job loop** calls
``fvf.batch.run_job`` (the worker side of the batch) on each mesh in this process,
without Dask: the batch's own per-mesh work (hashing the file, looking for a stored
result, the atomic result file, the row). The **batch** runs
``fvf.batch.run`` on a local cluster of 1 or 2 single-threaded worker processes started
before the timer (its start-up, the same for every batch, is timed separately) and closed
after it, so that only one cluster runs at a time, as under ``fvf batch`` (an idle second
cluster in this process made the batches about 15 % slower per small mesh); each repeat
writes into a fresh folder, so nothing is skipped. Before the timed runs, the loop and
each cluster process two meshes untimed (first calls: lazy imports and caches). BLAS
runs on one thread everywhere: threadpoolctl in this process (after numpy and scipy are
loaded), ``OMP/OPENBLAS/MKL_NUM_THREADS=1`` in the workers (Dask's nanny sets them).

The machine is shared with other jobs, so every configuration is repeated (interleaved:
serial, 1 worker, 2 workers, then again) and the medians are reported, with the load
average before and after. CPU seconds (this process's, plus the workers' for a batch) are
reported too: unlike wall time they hardly depend on what else runs on the machine, so
they show the batch machinery's own cost.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import shutil
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

import fvf

SHARED = Path(
    os.environ.get("FVF_SHARED_MESHES", Path(__file__).resolve().parents[2] / "shared" / "meshes")
)
SHARED_MIXED = [
    "decimated-knight.off",
    "woody.obj",
    "spot.obj",
    "bunny-lowres.off",
    "fertility.off",
    "bob_tri.obj",
    "3holes.off",
    "rocker-arm.obj",
    "camelhead.off",
    "sphere_s2.off",
    "faust_r_tr_reg_001.off",
    "lion-00.off",
]


#: Batch sizes of the per-mesh cost (``marginal``).
MARGINAL_SIZES = (40, 120, 200)


def _write(folder: Path, name: str, mesh) -> Path:
    path = folder / name
    fvf.write_mesh(path, mesh.vertices, mesh.faces)
    return path


def mixed_corpus(folder: Path, quick: bool) -> list[Path]:
    """Shared meshes (those present) and generated ones, 80 to ~23k faces: 40 files."""
    folder.mkdir(parents=True, exist_ok=True)
    files = [SHARED / n for n in SHARED_MIXED if (SHARED / n).exists()]
    generated = []
    for level in (1, 2, 3, 4, 4):
        generated.append((f"icosphere{level}-{len(generated)}.off", fvf.icosphere(level)))
    for seed, level in enumerate((2, 3, 3, 4, 4, 4, 3, 2, 2, 3)):
        generated.append((f"jitter{seed}-{level}.off", fvf.jittered_sphere(level, 0.3, seed=seed)))
    for i, (a, b) in enumerate(((12, 6), (24, 12), (40, 20), (60, 30), (80, 40), (90, 45))):
        generated.append((f"torus{i}.obj", fvf.torus(a, b)))
    for i, r in enumerate((5, 8, 12, 16, 20, 24, 28)):
        generated.append((f"disk{i}.ply", fvf.disk(r, r)))
    files += [_write(folder, name, mesh) for name, mesh in generated]
    files = files[: 44 if not quick else 10]
    return files


def small_corpus(folder: Path, quick: bool, count: int = 40) -> list[Path]:
    """``count`` generated meshes of 80 to ~1,300 faces (the first 40 are always the same)."""
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for i in range(count if not quick else 8):
        kind = i % 4
        if kind == 0:
            mesh = fvf.jittered_sphere(1 + i % 3, 0.3, seed=i)
        elif kind == 1:
            mesh = fvf.torus(10 + 2 * (i % 7), 5 + i % 5)
        elif kind == 2:
            mesh = fvf.disk(5 + i % 6, 5 + i % 6)
        else:
            mesh = fvf.icosphere(1 + i % 3)
        files.append(_write(folder, f"small{i:02d}.off", mesh))
    return files


def serial_loop(files: list[Path], out: Path, k: int) -> tuple[float, float]:
    """The library called directly on each mesh, one after the other: (wall, CPU) seconds."""
    from fvf.mesh.diagnostics import mesh_report

    out.mkdir(parents=True, exist_ok=True)
    start, cpu = time.perf_counter(), time.process_time()
    for path in files:
        V, F = fvf.read_mesh(path)
        mesh_report(V, F)
        mesh = fvf.TriMesh(V, F)
        lam, phi = fvf.laplace_basis(mesh, k)
        v = fvf.design_field(mesh)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ids, index = fvf.singularities(mesh, v, zero="warn")
        pos = fvf.singularity_positions(mesh, ids, "vertex")
        np.savez(
            out / f"{path.stem}.npz",
            eigenvalues=lam,
            eigenfunctions=phi.T,
            v=v,
            singularity_vertices=ids,
            singularity_indices=index,
            singularity_positions=pos,
        )
    return time.perf_counter() - start, time.process_time() - cpu


def runner_loop(files: list[Path], out: Path, k: int) -> tuple[float, float]:
    """``fvf.batch.run_job`` on each mesh in this process, no Dask: what the batch does per
    mesh besides the library (hash, result check, atomic result file, summary row)."""
    from fvf.batch.runner import MeshJob, run_job
    from fvf.batch.store import options_text

    tasks = ("info", "basis", "fields", "singularities")
    opts = {"k": k, "n": None}
    text = options_text(tasks, opts)
    start, cpu = time.perf_counter(), time.process_time()
    for path in files:
        result = str(out / f"{path.stem}.npz")
        row = run_job(MeshJob(path.stem, str(path), result, tasks, opts, text, "bench"))
        if row["status"] != "ok":
            raise RuntimeError(f"run_job failed: {row}")
    return time.perf_counter() - start, time.process_time() - cpu


def _cpu() -> float:
    return time.process_time()


@contextlib.contextmanager
def running_cluster(workers: int, startup: dict[int, float]):
    """A local cluster as fvf.batch starts it, closed at the end of the block; its client.

    Only one cluster runs at a time: a LocalCluster's scheduler and client live in this
    process, and an idle second one (its heartbeats, its event loop) made the other's
    batches about 15 % slower per small mesh here. The start-up time is recorded in
    ``startup`` (first start per worker count)."""
    import dask
    import distributed

    from fvf.batch.driver import _warm, local_cluster_config

    start = time.perf_counter()
    with dask.config.set(local_cluster_config(retries=3)):
        cluster = distributed.LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address="127.0.0.1:0",
            silence_logs=logging.CRITICAL,
        )
        client = distributed.Client(cluster)
    try:
        client.wait_for_workers(workers)
        client.run(_warm)
        startup.setdefault(workers, time.perf_counter() - start)
        yield client
    finally:
        client.close()
        cluster.close()


def batch(files: list[Path], out: Path, k: int, client) -> tuple[float, float]:
    """fvf.batch.run on the client's cluster: (wall, CPU of the workers and this process)."""
    before = sum(client.run(_cpu).values()) + time.process_time()
    start = time.perf_counter()
    rows = fvf.batch.run(files, out, k=k, client=client, progress=False, as_frame=False)
    seconds = time.perf_counter() - start
    cpu = sum(client.run(_cpu).values()) + time.process_time() - before
    bad = [r for r in rows if r["status"] != "ok"]
    if bad:
        raise RuntimeError(f"batch rows not ok: {bad[:3]}")
    return seconds, cpu


def _loop_in_worker(files: list[Path], out: Path, k: int) -> tuple[float, float]:
    return serial_loop(files, out, k)


def in_worker(files: list[Path], k: int, repeats: int, client, tmp: Path) -> None:
    """The serial loop here and inside one Dask worker process (as one task): the cost of
    the worker's own machinery (event loop, monitors) on the same computation."""
    client.submit(_loop_in_worker, files[:2], tmp / "warm-iw", k, pure=False).result()
    serial_loop(files[:2], tmp / "warm-ih", k)
    here, there = [], []
    for r in range(repeats):
        here.append(serial_loop(files, tmp / f"ih{r}", k))
        job = client.submit(_loop_in_worker, files, tmp / f"iw{r}", k, pure=False)
        there.append(job.result())
    print("\n| serial loop | median wall (s) | median CPU (s) | runs (wall s) |")
    print("|---|---|---|---|")
    for label, runs in (("in this process", here), ("inside a Dask worker", there)):
        walls = ", ".join(f"{w:.2f}" for w, _ in runs)
        print(
            f"| {label} | {statistics.median(w for w, _ in runs):.2f} | "
            f"{statistics.median(c for _, c in runs):.2f} | {walls} |"
        )


def measure(name: str, files: list[Path], k: int, repeats: int, startup: dict, tmp: Path):
    labels = ("serial loop", "run_job loop, no Dask", "batch, 1 worker", "batch, 2 workers")
    wall: dict[str, list[float]] = {label: [] for label in labels}
    cpu: dict[str, list[float]] = {label: [] for label in labels}
    warm = files[-2:]  # first calls (lazy imports, caches) outside the timer, everywhere
    serial_loop(warm, tmp / "warm-serial", k)
    for r in range(repeats):
        out = tmp / f"{name}-serial-{r}"
        w, c = serial_loop(files, out, k)
        wall["serial loop"].append(w)
        cpu["serial loop"].append(c)
        shutil.rmtree(out)
        out = tmp / f"{name}-runner-{r}"
        w, c = runner_loop(files, out, k)
        wall["run_job loop, no Dask"].append(w)
        cpu["run_job loop, no Dask"].append(c)
        shutil.rmtree(out)
        for workers in (1, 2):
            label = f"batch, {workers} worker{'s' if workers > 1 else ''}"
            with running_cluster(workers, startup) as client:
                batch(warm, tmp / f"warm-{workers}-{r}", k, client)
                out = tmp / f"{name}-batch{workers}-{r}"
                w, c = batch(files, out, k, client)
            wall[label].append(w)
            cpu[label].append(c)
            shutil.rmtree(out)
        done = ", ".join(f"{label} {v[-1]:.1f} s" for label, v in wall.items())
        print(f"  {name} repeat {r + 1}: {done}", file=sys.stderr, flush=True)
    return wall, cpu


def _line_fit(points: list[tuple[int, float]]) -> tuple[float, float, tuple[float, float]]:
    """Least-squares t = slope * meshes + intercept over every run, and a 90 % bootstrap
    interval of the slope (500 resamples of the runs, seeded)."""
    x = np.array([n for n, _ in points], dtype=float)
    y = np.array([t for _, t in points])
    A = np.stack([x, np.ones_like(x)], axis=1)
    slope, intercept = np.linalg.lstsq(A, y, rcond=None)[0]
    rng = np.random.default_rng(0)
    boots = []
    for _ in range(500):
        i = rng.integers(0, x.size, x.size)
        if np.ptp(x[i]) > 0:
            boots.append(np.linalg.lstsq(A[i], y[i], rcond=None)[0][0])
    low, high = np.percentile(boots, [5, 95])
    return float(slope), float(intercept), (float(low), float(high))


def marginal(
    files: list[Path], k: int, repeats: int, client, tmp: Path, sizes: tuple[int, ...]
) -> None:
    """Cost of one more small mesh: the loop and a 1-worker batch over ``sizes``
    meshes (interleaved, ``repeats`` times); a line fitted through all runs gives the
    per-mesh cost (slope) and the per-run cost (intercept: planning, the lock, the first
    and last round trip, summary.csv). Sizes from 40 to 200 meshes, because the
    difference is a few per cent of a run and a run varies by a few per cent between
    repeats: the slope between 40 and 80 meshes alone moved from +9 % to +23 % between
    two runs on this machine."""
    runs: dict[str, list[tuple[int, float]]] = {"loop": [], "batch": []}
    for r in range(repeats):
        for size in sizes:
            out = tmp / f"marginal-{r}-{size}"
            runs["loop"].append((size, serial_loop(files[:size], out / "l", k)[0]))
            runs["batch"].append((size, batch(files[:size], out / "b", k, client)[0]))
            shutil.rmtree(out)
    fit = {label: _line_fit(points) for label, points in runs.items()}
    (loop, loop_fixed, loop_ci), (one, one_fixed, one_ci) = fit["loop"], fit["batch"]
    extra = one / loop - 1
    counts = ", ".join(map(str, sizes))
    print(
        f"\nOne more small mesh ({counts} meshes, {repeats} repeats, least squares): loop "
        f"{1e3 * loop:.1f} ms (90 % {1e3 * loop_ci[0]:.1f}-{1e3 * loop_ci[1]:.1f}), batch on "
        f"1 worker {1e3 * one:.1f} ms ({1e3 * one_ci[0]:.1f}-{1e3 * one_ci[1]:.1f}): "
        f"{100 * extra:+.1f} % (goal <= +10 %: {'PASS' if extra <= 0.10 else 'MISS'}); per "
        f"run: loop {1e3 * loop_fixed:.0f} ms, batch {1e3 * one_fixed:.0f} ms"
    )


def report(name: str, files: list[Path], wall: dict, cpu: dict, startup: dict) -> None:
    n = len(files)
    faces = [fvf.read_mesh(f)[1].shape[0] for f in files]
    med = {label: statistics.median(v) for label, v in wall.items()}
    med_cpu = {label: statistics.median(v) for label, v in cpu.items()}
    serial, serial_cpu = med["serial loop"], med_cpu["serial loop"]
    print(
        f"\n### {name}: {n} meshes, {min(faces):,} to {max(faces):,} faces "
        f"({sum(faces):,} in all)\n"
    )
    print("| run | median wall (s) | runs (s) | wall vs loop | median CPU (s) | CPU vs loop |")
    print("|---|---|---|---|---|---|")
    for label, value in med.items():
        runs = ", ".join(f"{t:.1f}" for t in wall[label])
        print(
            f"| {label} | {value:.1f} | {runs} | {serial / value:.2f}× faster | "
            f"{med_cpu[label]:.1f} | {100 * (med_cpu[label] / serial_cpu - 1):+.0f} % |"
        )
    one = med["batch, 1 worker"]
    print(
        f"\nPer mesh, batch on 1 worker minus loop: {1e3 * (one - serial) / n:+.0f} ms wall "
        f"({100 * (one / serial - 1):+.1f} %), "
        f"{1e3 * (med_cpu['batch, 1 worker'] - serial_cpu) / n:+.0f} ms CPU; cluster start-up "
        "(not in the times above): "
        + ", ".join(f"{w} worker(s) {s:.1f} s" for w, s in startup.items())
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--k", type=int, default=20, help="eigenpairs per mesh (default 20)")
    parser.add_argument("--quick", action="store_true", help="few meshes, one repeat")
    parser.add_argument("--only", choices=("mixed", "small"), help="one corpus only")
    parser.add_argument(
        "--in-worker", action="store_true", help="the serial loop here and inside a worker"
    )
    args = parser.parse_args()
    repeats = 1 if args.quick else args.repeats
    threadpool_limits(1)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(
        f"fvf {fvf.__version__}, python {sys.version.split()[0]}, {os.cpu_count()} cores, "
        f"load average {load}, k = {args.k}, {repeats} repeats",
        flush=True,
    )
    tmp = Path(tempfile.mkdtemp(prefix="fvf-bench-batch-"))
    startup: dict[int, float] = {}
    try:
        corpora = {"mixed": mixed_corpus, "small": small_corpus}
        for name, make in corpora.items():
            if args.only and name != args.only:
                continue
            files = make(tmp / name, args.quick)
            if args.in_worker:
                with running_cluster(1, startup) as client:
                    in_worker(files, args.k, repeats, client, tmp)
                continue
            wall, cpu = measure(name, files, args.k, repeats, startup, tmp)
            report(name, files, wall, cpu, startup)
            if name == "small":
                sizes = MARGINAL_SIZES if not args.quick else (4, 8)
                more = small_corpus(tmp / "small", args.quick, count=sizes[-1])
                with running_cluster(1, startup) as client:
                    batch(more[-2:], tmp / "warm-marginal", args.k, client)
                    marginal(more, args.k, repeats, client, tmp, sizes)
        print(f"\nload average after: {os.getloadavg()}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
