"""Quad meshes: fvf.quad_mesh against Instant Meshes, side by side at equal quad counts.

Run from the repository root (needs ``pip install pynanoinstantmeshes``, a bench-only
peer, and the shared meshes in ``../shared/meshes`` or ``$FVF_SHARED_MESHES``)::

    .venv/bin/python benchmarks/bench_quads.py                 # the five meshes below
    .venv/bin/python benchmarks/bench_quads.py --meshes spot.obj --ratio 0.25
    .venv/bin/python benchmarks/bench_quads.py --scaling       # fvf alone, 86k..750k faces
    .venv/bin/python benchmarks/bench_quads.py --wild          # the wild corpus, 2,000 quads
    .venv/bin/python benchmarks/bench_quads.py --wild --quads 500 --only scan_body cad_box_hole
    .venv/bin/python benchmarks/bench_quads.py --wild --methods fvf instant   # no QuadriFlow

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

``--wild``: the meshes people bring (``tests/param/wild_corpus.py``: CAD solids as STL soups,
noisy scans with holes, several parts, y-up and scaled copies, hostile tiny inputs; built
here, no shared meshes needed), each written in its natural format and read back as a
user would. fvf, Instant Meshes (as ``fvf.param.peer`` calls it: defaults, pure quads by
1-to-4 subdivision) and QuadriFlow (``pip install pyquadriflow``, optional; default
flags) each run in a child process with BLAS pinned to one thread, on the same arrays, at
``--quads`` (2,000) quads; with ``--scad``, on the OpenSCAD parts of
``benchmarks/openscad`` instead (exported as ASCII STL by the ``openscad`` command: flanges,
brackets, gears, knobs, a thread, thin shells, a fan grille, a dome with vents). Every
output is judged by the independent checker ``tests/param/quadcheck.py`` (valid, or the
failed checks; a typed fvf error, a foreign exception, a crash or a timeout is reported as
such) and measured by
``quadcheck.metrics``: irregular vertices (interior valence ≠ 4, boundary ∉ {2, 3}),
|corner angle − 90°| median, coverage of the sharp edges (dihedral > 30°) by quad edges
within a quarter quad edge, Hausdorff distance over the mean quad edge, and CPU time
(``time.process_time`` of the child from the loaded arrays: fvf's includes building the
TriMesh; a run stopped at ``--timeout`` seconds of wall time counts the CPU time it
used until then). Goals, for fvf: valid on ≥ 95 % of the corpus; median irregular % and median
angle error (over the meshes where both returned quads) ≤ Instant Meshes'; total CPU
time ≤ 3 × Instant Meshes'.
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
WILD_METHODS = ("fvf", "instant", "quadriflow")
#: 27 parametric CAD parts in OpenSCAD's language (``--wild --scad``).
SCAD = ROOT / "benchmarks" / "openscad"
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
            made = fvf.quad_mesh(mesh, target_faces=target)
            Vq, Q, ps = made.vertices, made.quads, made.parameterizations
            extra = {
                "flips": sum(p.n_flipped for p in ps),
                "cones": sum(int(p.singular.size) for p in ps),
                "attempts": len(made.attempts),
            }
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


# ---------------------------------------------------------------------------- --wild
def _wild_remesh(method: str, V, F, target: int):
    """(Vq, Q) of one remesher on the welded arrays (V, F); fvf errors propagate."""
    import numpy as np

    if method == "fvf":  # as `fvf quad FILE`: zero-area faces repaired as `fvf repair` does
        import fvf
        import wild_corpus

        return fvf.quad_mesh(wild_corpus.repaired_as_cli(V, F), target_faces=target)
    if method == "instant":  # as fvf.param.peer.instant_meshes, without fvf's validation
        import pynanoinstantmeshes as pim

        n = max(target, 32) // 4
        Vq, Q = pim.remesh(
            V.astype(np.float32), F.astype(np.uint32), n, face_count=n, deterministic=True
        )
        return np.asarray(Vq, np.float64), np.asarray(Q, np.int64)
    from pyQuadriFlow.pyQuadriFlow import pyquadriflow

    out = pyquadriflow(target, 0, V.tolist(), F.tolist(), False, False, False, False, False)
    return np.asarray(out["vertices"], np.float64), np.asarray(out["faces"], np.int64)


def _wild_child(method: str, mesh_path: str, target: int, out: str) -> None:
    """Read one corpus file, remesh it, write (V, Q, status, times) to ``out`` (.npz)."""
    import numpy as np
    from threadpoolctl import threadpool_limits

    sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "tests" / "param")]
    import fvf
    import wild_corpus

    threadpool_limits(1)
    V, F = wild_corpus.load(mesh_path)
    Vq, Q = np.zeros((0, 3)), np.zeros((0, 4), np.int64)
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        Vq, Q = _wild_remesh(method, V, F, target)
        status = "ok"
    except fvf.FvfError as exc:
        status = f"typed {type(exc).__name__}: {exc}"
    except Exception as exc:  # noqa: BLE001 -- reported, not hidden
        kind = "foreign" if method == "fvf" else "error"
        status = f"{kind} {type(exc).__name__}: {exc}"
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    np.savez(out, V=Vq, Q=Q, status=status[:300], cpu=cpu, wall=wall)


def _children_cpu() -> float:
    """CPU seconds of the finished child processes so far (user + system)."""
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def _wild_run(method: str, path: Path, target: int, tmp: Path, timeout: float) -> dict:
    import numpy as np

    out = tmp / f"{method}_{path.stem}.npz"
    cmd = [sys.executable, __file__, "--wild-child", method, str(path), str(target), str(out)]
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    used = _children_cpu()
    try:
        r = subprocess.run(
            cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, timeout=timeout
        )
    except subprocess.TimeoutExpired:  # killed and reaped: its CPU time is in RUSAGE_CHILDREN
        cpu = _children_cpu() - used
        status = f"timeout after {timeout:.0f} s wall ({cpu:.0f} s CPU)"
        return {"status": status, "cpu": cpu, "wall": timeout}
    if r.returncode != 0 or not out.exists():
        tail = r.stderr.decode(errors="replace").strip().splitlines()[-1:] or [""]
        status = f"crashed (exit {r.returncode}) {tail[0][:120]}"
        return {"status": status, "cpu": float("nan"), "wall": float("nan")}
    d = np.load(out)
    keys = {"status": str(d["status"]), "cpu": float(d["cpu"]), "wall": float(d["wall"])}
    return {"V": d["V"], "Q": d["Q"], **keys}


def _wild_judge(V, F, r: dict) -> dict:
    """Add the quadcheck verdict and metrics to a run's record."""
    import quadcheck

    if r["status"] != "ok":
        r["why"] = r["status"]
        return r
    Vq, Q = r["V"], r["Q"]
    try:
        v = quadcheck.check(V, F, Vq, Q)
    except Exception as exc:  # noqa: BLE001 -- a broken output, e.g. mixed polygons
        r["why"] = f"unjudgeable output {Q.shape}: {type(exc).__name__}: {exc}"[:160]
        return r
    r["verdict"] = v
    r["why"] = "valid" if v.valid else v.summary()
    if v.checks["indices"]:
        r["metrics"] = quadcheck.metrics(V, F, Vq, Q)
    return r


def _wild_row(name: str, method: str, r: dict) -> str:
    m, v = r.get("metrics"), r.get("verdict")
    cols = ["-"] * 5
    if m is not None:
        cov = m["feature_coverage"]
        cols = [
            f"{r['Q'].shape[0]}",
            f"{m['irregular']:.1%}",
            f"{m['angle_median']:.1f}",
            "n/a" if cov != cov else f"{cov:.0%}",
            f"{v.hausdorff_rel:.2f}",
        ]
    nums = " ".join(f"{c:>6s}" for c in cols)
    return f"{name:20s} {method:10s} {nums} {r['cpu']:6.1f}  {r['why'][:110]}"


def _median(xs: list[float]) -> float:
    import numpy as np

    return float(np.median(xs)) if xs else float("nan")


def _valid(r: dict) -> bool:
    return r.get("verdict") is not None and r["verdict"].valid


def _cpu_total(runs: list[dict]) -> float:
    return sum(r["cpu"] for r in runs if r["cpu"] == r["cpu"])  # crashes (NaN) left out


def _wild_summary(names: list[str], res: dict, methods: list[str]) -> None:
    n = len(names)
    print("\ntotals")
    for meth in methods:
        runs = [res[k, meth] for k in names]
        valid = sum(_valid(r) for r in runs)
        out = [r["metrics"] for r in runs if "metrics" in r]
        irr = _median([m["irregular"] for m in out])
        ang = _median([m["angle_median"] for m in out])
        print(
            f"  {meth:10s} valid {valid}/{n} ({valid / n:.0%})  outputs {len(out)}  "
            f"median irregular {irr:.1%}  median angle {ang:.1f}°  "
            f"CPU {_cpu_total(runs):.1f} s"
        )
    if "instant" not in methods:
        return
    both = [k for k in names if "metrics" in res[k, "fvf"] and "metrics" in res[k, "instant"]]

    def med(meth: str, key: str) -> float:
        return _median([res[k, meth]["metrics"][key] for k in both])

    f_irr, i_irr = med("fvf", "irregular"), med("instant", "irregular")
    f_ang, i_ang = med("fvf", "angle_median"), med("instant", "angle_median")
    f_cpu = _cpu_total([res[k, "fvf"] for k in names])
    i_cpu = _cpu_total([res[k, "instant"] for k in names])
    valid = sum(_valid(res[k, "fvf"]) for k in names)
    goals = [
        (f"fvf valid >= 95 % ({valid}/{n})", valid >= 0.95 * n),
        (
            f"median irregular <= IM's ({f_irr:.1%} vs {i_irr:.1%}; the {len(both)} meshes "
            "both returned quads for)",
            bool(both) and f_irr <= i_irr,
        ),
        (f"median angle error <= IM's ({f_ang:.1f}° vs {i_ang:.1f}°)", f_ang <= i_ang),
        (
            f"CPU time <= 3x IM's ({f_cpu:.1f} s vs {i_cpu:.1f} s, "
            f"{f_cpu / max(i_cpu, 1e-9):.1f}x)",
            f_cpu <= 3.0 * i_cpu,
        ),
    ]
    print("\ngoals")
    for text, ok in goals:
        print(f"  {'PASS' if ok else 'MISS'}  {text}")


def openscad_corpus(tmp: Path) -> dict[str, Path]:
    """``benchmarks/openscad/*.scad`` exported by the ``openscad`` command as ASCII STL
    (OpenSCAD's default, a triangle soup) into ``tmp``: name -> path."""
    import shutil

    exe = shutil.which("openscad")
    if exe is None:
        raise SystemExit("--scad needs the openscad command (Debian: apt install openscad)")
    tmp.mkdir(parents=True, exist_ok=True)
    paths = {}
    for scad in sorted(SCAD.glob("*.scad")):
        paths[scad.stem] = tmp / f"{scad.stem}.stl"
        subprocess.run(
            [exe, "-o", str(paths[scad.stem]), str(scad)], check=True, capture_output=True
        )
    return paths


def wild(
    target: int,
    only: list[str] | None,
    tmp: Path,
    timeout: float,
    which: list[str],
    scad: bool = False,
) -> None:
    import platform

    sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "tests" / "param")]
    import wild_corpus

    methods = ["fvf"]
    for meth, mod in (("instant", "pynanoinstantmeshes"), ("quadriflow", "pyQuadriFlow")):
        if meth not in which:
            continue
        try:
            __import__(mod)
            methods.append(meth)
        except ImportError:
            print(f"({meth} skipped: pip install {mod.lower()})")
    if scad:
        paths = openscad_corpus(tmp / "openscad")
        names = only or list(paths)
    else:
        names = only or [n for n in wild_corpus.names() if wild_corpus.available(n)]
        paths = wild_corpus.write_corpus(tmp / "corpus", names)
    print(
        f"{'OpenSCAD parts' if scad else 'wild corpus'}: {len(names)} meshes, {target} "
        "quads asked; each run a child process "
        f"with BLAS pinned to 1 thread (threadpoolctl); CPU seconds; {platform.node()}"
    )
    head = ["quads", "irreg", "ang50", "feat", "H/edge", "cpu_s"]
    print(f"{'mesh':20s} {'method':10s} " + " ".join(f"{h:>6s}" for h in head) + "  valid?")
    res = {}
    for name in names:
        V, F = wild_corpus.load(paths[name])
        for meth in methods:
            res[name, meth] = _wild_judge(V, F, _wild_run(meth, paths[name], target, tmp, timeout))
            print(_wild_row(name, meth, res[name, meth]), flush=True)
    _wild_summary(names, res, methods)


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        _child(sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5])
        return
    if len(sys.argv) > 1 and sys.argv[1] == "--wild-child":
        _wild_child(sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5])
        return
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", nargs="+", default=MESHES)
    ap.add_argument("--ratio", type=float, default=0.25, help="target quads per input face")
    ap.add_argument("--scaling", action="store_true", help="fvf alone on 86k..750k faces")
    ap.add_argument(
        "--wild",
        action="store_true",
        help="the wild corpus (tests/param/wild_corpus.py)",
    )
    ap.add_argument(
        "--scad",
        action="store_true",
        help="--wild on the OpenSCAD parts of benchmarks/openscad (needs openscad)",
    )
    ap.add_argument("--quads", type=int, default=2000, help="--wild: quads asked")
    ap.add_argument("--only", nargs="+", help="--wild: these corpus meshes only")
    ap.add_argument("--timeout", type=float, default=600.0, help="--wild: seconds per run")
    ap.add_argument(
        "--methods",
        nargs="+",
        default=list(WILD_METHODS),
        choices=WILD_METHODS,
        help="--wild: the remeshers compared (fvf always runs)",
    )
    args = ap.parse_args()
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        if args.wild:
            wild(args.quads, args.only, Path(d), args.timeout, args.methods, args.scad)
        elif args.scaling:
            scaling(args.ratio, Path(d))
        else:
            compare(args.meshes, args.ratio, Path(d))


if __name__ == "__main__":
    main()
