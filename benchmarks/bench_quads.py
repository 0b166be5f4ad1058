"""Quad meshes: fvf.quad_mesh against Instant Meshes, side by side at equal quad counts.

Run from the repository root (needs ``pip install pynanoinstantmeshes``, a bench-only
peer, and the shared meshes in ``../shared/meshes`` or ``$FVF_SHARED_MESHES``)::

    .venv/bin/python benchmarks/bench_quads.py                 # the five meshes below
    .venv/bin/python benchmarks/bench_quads.py --meshes spot.obj --ratio 0.25
    .venv/bin/python benchmarks/bench_quads.py --scaling       # fvf alone, 86k..750k faces

Per mesh, fvf runs first with a target of ``ratio × input faces`` quads; Instant Meshes
(``pynanoinstantmeshes.remesh``, pure quads: it subdivides its quad-dominant mesh 1-to-4,
so it is asked for a quarter of fvf's final count) then aims at fvf's final quad count.
Each run is a child process (its wall time and peak RSS are its own; BLAS pinned to one
thread with threadpoolctl in the child; Instant Meshes runs ``deterministic=True``).
Both outputs are measured by ``fvf.quad_quality`` against the input: irregular-vertex
fraction, |corner angle − 90°| median and 95th percentile, area distortion (std/mean of
quad areas), the larger of the two one-sided Hausdorff distances (fraction of the bbox
diagonal), and whether the output is a closed manifold with the input's χ.

Goals (PASS/MISS per mesh): irregular fraction ≤ ½ of Instant Meshes', angle deviation
(median and p95) no worse, zero flipped uv triangles and a valid closed output, time
≤ 5 × Instant Meshes'.
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

MESHES = ["spot.obj", "bob_tri.obj", "fertility.off", "rocker-arm.obj", "armadillo.obj"]
SCALING = ["armadillo.obj", "armadillo_loop1.ply", "armadillo_750k.ply"]
ROOT = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("FVF_SHARED_MESHES", ROOT.parent / "shared" / "meshes"))


def _child(method: str, mesh_path: str, target: int, out: str) -> None:
    """Run one remesher, write (V, Q) and the timing to ``out`` (.npz)."""
    import numpy as np
    from threadpoolctl import threadpool_limits

    import fvf

    threadpool_limits(1)
    mesh = fvf.TriMesh(*fvf.read_mesh(mesh_path))
    t0 = time.perf_counter()  # both timings start from the checked mesh
    extra = {}
    if method.startswith("fvf"):
        try:
            Vq, Q, p = fvf.quad_mesh(mesh, target_faces=target, return_parameterization=True)
            extra = {"flips": p.n_flipped, "cones": int(p.singular.size)}
        except fvf.FvfError as exc:
            Vq, Q = np.zeros((0, 3)), np.zeros((0, 4), np.int64)
            extra = {"error": f"{type(exc).__name__}: {exc}"[:200]}
    else:
        from fvf.peers import instant_meshes

        Vq, Q = instant_meshes(mesh, max(target, 32))
    seconds = time.perf_counter() - t0
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    np.savez(out, V=Vq, Q=Q, seconds=seconds, rss_mb=rss, extra=json.dumps(extra))


def run_child(method: str, mesh_path: Path, target: int, tmp: Path):
    import numpy as np

    out = tmp / f"{method}_{mesh_path.stem}.npz"
    cmd = [sys.executable, __file__, "--child", method, str(mesh_path), str(target), str(out)]
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL)
    d = np.load(out)
    return d["V"], d["Q"], float(d["seconds"]), float(d["rss_mb"]), json.loads(str(d["extra"]))


def measure(mesh, V, Q):
    import fvf

    if Q.shape[0] == 0:
        return None
    try:
        q = fvf.quad_quality(mesh, V, Q)
    except fvf.FvfError:
        return None
    return q


def fmt(q, seconds, rss, mesh, extra=None):
    if q is None:
        return f"{'broken output ' + str((extra or {}).get('error', '')):>60}"
    valid = q.closed and q.manifold and q.euler_characteristic == mesh.euler_characteristic
    haus = max(q.hausdorff_to_input, q.hausdorff_from_input)
    return (
        f"{q.n_quads:7d} {q.irregular_fraction:7.2%} {q.angle_deviation_median:6.1f} "
        f"{q.angle_deviation_p95:6.1f} {q.area_cv:6.2f} {haus:8.4f} {seconds:7.1f} "
        f"{rss:7.0f} {'yes' if valid else 'NO':>5}"
    )


def compare(names: list[str], ratio: float, tmp: Path) -> None:
    import fvf

    head = (
        f"{'mesh':15s} {'method':8s} {'quads':>7s} {'irreg':>7s} {'ang50':>6s} {'ang95':>6s} "
        f"{'areaCV':>6s} {'Hausd':>8s} {'time_s':>7s} {'RSS_MB':>7s} {'valid':>5s}"
    )
    print(head)
    for name in names:
        path = SHARED / name
        mesh = fvf.TriMesh(*fvf.read_mesh(path))
        target = max(int(ratio * mesh.n_faces), 100)
        Vf, Qf, tf, rf, ef = run_child("fvf", path, target, tmp)
        qf = measure(mesh, Vf, Qf)
        final = Qf.shape[0] if Qf.shape[0] else target
        Vi, Qi, ti, ri, _ = run_child("im", path, final, tmp)
        qi = measure(mesh, Vi, Qi)
        print(f"{name:15s} {'fvf':8s} {fmt(qf, tf, rf, mesh, ef)}")
        print(f"{'':15s} {'instant':8s} {fmt(qi, ti, ri, mesh)}")
        goals = []
        if qf is not None and qi is not None:
            goals.append(("irregular<=IM/2", qf.irregular_fraction <= 0.5 * qi.irregular_fraction))
            goals.append(
                (
                    "angles<=IM",
                    qf.angle_deviation_median <= qi.angle_deviation_median
                    and qf.angle_deviation_p95 <= qi.angle_deviation_p95,
                )
            )
        ok = (
            qf is not None
            and qf.closed
            and qf.manifold
            and qf.euler_characteristic == mesh.euler_characteristic
            and ef.get("flips", 1) == 0
        )
        goals.append(("valid&0flips", ok))
        goals.append(("time<=5xIM", tf <= 5.0 * ti))
        print(
            f"{'':15s} {'goals':8s} "
            + "  ".join(f"{g}:{'PASS' if v else 'MISS'}" for g, v in goals)
            + f"   (fvf cones {ef.get('cones', '-')}, time ratio {tf / ti:.1f}x)",
            flush=True,
        )


def scaling(ratio: float, tmp: Path) -> None:
    import fvf

    print(f"{'mesh':22s} {'faces':>8s} {'quads':>7s} {'time_s':>7s} {'s/kface':>8s} {'RSS_MB':>7s}")
    for name in SCALING:
        path = SHARED / name
        V, F = fvf.read_mesh(path)
        target = max(int(ratio * F.shape[0]), 100)
        Vf, Qf, tf, rf, ef = run_child("fvf", path, target, tmp)
        print(
            f"{name:22s} {F.shape[0]:8d} {Qf.shape[0]:7d} {tf:7.1f} "
            f"{1000 * tf / F.shape[0]:8.3f} {rf:7.0f} {ef.get('error', '')}",
            flush=True,
        )


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        _child(sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5])
        return
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", nargs="+", default=MESHES)
    ap.add_argument("--ratio", type=float, default=0.25, help="target quads per input face")
    ap.add_argument("--scaling", action="store_true", help="fvf alone on 86k..750k faces")
    args = ap.parse_args()
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        if args.scaling:
            scaling(args.ratio, Path(d))
        else:
            compare(args.meshes, args.ratio, Path(d))


if __name__ == "__main__":
    main()
