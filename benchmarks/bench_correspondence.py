"""Benchmark :func:`fvf.match` against pyFM (PyPI ``pyfmaps``) on the camel-gallop frames.

Run from the repository root::

    .venv/bin/python benchmarks/bench_correspondence.py               # all six pairs
    .venv/bin/python benchmarks/bench_correspondence.py --pairs 2-3,1-3
    .venv/bin/python benchmarks/bench_correspondence.py --json out.json
    .venv/bin/python benchmarks/bench_correspondence.py --dataset DIR [--pairs-file P]
        [--max-pairs N] [--curve curve.csv] [--png curve.png] [--k K] [--no-pyfm]
    .venv/bin/python benchmarks/bench_correspondence.py --timing   # 5k and 20k vertices

``--dataset DIR`` runs the standard protocol on a folder in the FAUST_r / SCAPE_r / SMAL_r
layout (``DIR/shapes/*.off``, ``DIR/corres/*.vts``) instead of the camels: see
``correspondence_dataset.py``. ``--make-dataset DIR`` writes a small generated set in that
layout.

Data: ``../shared/meshes/correspondence`` (four frames, different triangulations, and six
ground-truth maps; see its MANIFEST.md). ``camel_a_to_b.txt`` gives for each vertex of
frame a its vertex of frame b, so mesh 1 = frame b, mesh 2 = frame a and the map is
p2p_21. The entry 0 marks vertices without ground truth (449–861 per file, against at
most a handful of true preimages of vertex 0): those vertices are left out of every
error.

Contestants, on the same arrays:

* **fvf**: ``fvf.match(V_1, F_1, V_2, F_2)`` with its defaults, on the frames as read
  (fvf repairs the non-manifold edges itself and returns a map of the input vertices).
* **pyFM**: the quickstart of pyfmaps' README (version printed): ``TriMesh(...,
  area_normalize=True, center=True)``, ``preprocess(descr_type="WKS",
  subsample_step=2)``, ``fit(K=30, w_descr=1, w_lap=1e-1, w_dcomm=1, w_orient=1)``,
  ``zoomout_refine(nit=16, step=5)``, ``get_p2p``. pyFM is given fvf's repaired arrays
  (``fvf.mesh.prepare_mesh``: the same geometry without the non-manifold flaps), and its
  map is carried back to the input vertices the same way as fvf's.
  ``--pyfm-orient 0`` runs the variant without the orientation term.

Error: mean geodesic distance on mesh 1 between predicted and true images, divided by
√(area of mesh 1), with :func:`fvf.mean_geodesic_error` (Dijkstra on edges and unfolded
face-pair diagonals: +2 to +4 % above exact geodesics, the same for both). Time: wall and
CPU seconds of the whole call (eigenpairs included), BLAS pinned to one thread with
threadpoolctl. A pair PASSes when fvf's error is at most pyFM's and its wall time at most
pyFM's; the goal is also a mean error at most half of pyFM's.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from importlib import metadata
from pathlib import Path

import correspondence_dataset  # the --dataset protocol, beside this file
import numpy as np
from threadpoolctl import threadpool_limits

import fvf
from fvf.io.atomic import atomic_path
from fvf.mesh.prepared import prepare_mesh

DATA = (
    Path(
        os.environ.get(
            "FVF_SHARED_MESHES", Path(__file__).resolve().parents[2] / "shared" / "meshes"
        )
    )
    / "correspondence"
)
PAIRS = [(1, 3), (2, 3), (2, 4), (3, 1), (3, 2), (4, 2)]


def _timed(fn, *args):
    w0, c0 = time.perf_counter(), time.process_time()
    out = fn(*args)
    return out, time.perf_counter() - w0, time.process_time() - c0


def run_fvf(V1, F1, V2, F2) -> np.ndarray:
    return fvf.match((V1, F1), (V2, F2))


def run_pyfm(prep_1, prep_2, w_orient: float) -> np.ndarray:
    from pyFM.functional import FunctionalMapping
    from pyFM.mesh import TriMesh

    m1 = TriMesh(
        prep_1.mesh.vertices.copy(), prep_1.mesh.faces.copy(), area_normalize=True, center=True
    )
    m2 = TriMesh(
        prep_2.mesh.vertices.copy(), prep_2.mesh.faces.copy(), area_normalize=True, center=True
    )
    model = FunctionalMapping(m1, m2)
    model.preprocess(descr_type="WKS", subsample_step=2)
    model.fit(K=30, w_descr=1e0, w_lap=1e-1, w_dcomm=1e0, w_orient=w_orient)
    fm_zo = model.zoomout_refine(nit=16, step=5)
    p2p = np.asarray(model.get_p2p(fm_zo), dtype=np.int64)  # prepared mesh 2 -> prepared 1
    return prep_1.mesh_to_input[p2p[prep_2.input_to_mesh]]


def errors_of(prep_1, p2p_21, truth, valid) -> np.ndarray:
    """Normalized geodesic errors (on prepared mesh 1) of the valid vertices of mesh 2."""
    to = prep_1.input_to_mesh
    return fvf.geodesic_errors(prep_1.mesh, to[p2p_21[valid]], to[truth[valid]])


def figures(folder: Path, maps: dict, errors: dict) -> None:
    """Transferred colours and error maps of the first pair, pooled error curves, and the
    symmetry map of frame 3, as PNG files in ``folder``."""
    from fvf import viz

    folder.mkdir(parents=True, exist_ok=True)
    pooled = {m: np.concatenate([e[m] for e in errors.values()]) for m in ("fvf", "pyFM")}
    viz.plot_error_curves(
        pooled, folder / "curves.png", title="camel pairs: cumulative geodesic error"
    )
    pair = next(iter(maps))
    prep_1, prep_2, truth, valid, by_method = maps[pair]
    for method, p2p in by_method.items():
        q = prep_1.input_to_mesh[p2p[prep_2.mesh_to_input]]
        viz.render_correspondence(
            prep_1.mesh, prep_2.mesh, q, folder / f"colors_{pair}_{method}.png", title=method
        )
        e = np.zeros(p2p.size)
        e[valid] = errors[pair][method]
        viz.render_error_map(
            prep_2.mesh,
            e[prep_2.mesh_to_input],
            folder / f"errors_{pair}_{method}.png",
            title=f"{method}: geodesic error / sqrt(area)",
        )
    sym = fvf.symmetry_map(DATA / "camel-gallop-03.off")
    viz.render_correspondence(
        sym.prepared_1.mesh,
        sym.prepared_1.mesh,
        sym.p2p_21_prepared,
        folder / "symmetry_3.png",
        title="symmetry_map",
    )
    print(f"wrote pictures to {folder}")


def planted() -> int:
    """Mean and max geodesic error against the identity of the planted pairs of
    ``tests/spectral/test_correspondence_flips.py`` (generated body; FAUST frame when present),
    with ``check_symmetry`` on and off, and the confidence of the choice."""
    tests = Path(__file__).resolve().parents[1] / "tests"
    sys.path[:0] = [str(tests), str(tests / "spectral")]
    from test_correspondence_flips import displaced, mirror_image, near_symmetric_body

    shapes = {"body": (near_symmetric_body(), dict(k=40, k_fit=15))}
    faust = DATA.parent / "faust_r_tr_reg_001.off"
    if faust.exists():
        shapes["FAUST"] = (fvf.TriMesh(*fvf.read_mesh(faust)), {})
    print("| shape | pair | check | mean error | max error | orientation | confidence | s |")
    print("|---|---|---|---|---|---|---|---|")
    for name, (S, kw) in shapes.items():
        ident = np.arange(S.n_vertices)
        for pair, T in (("mirror", mirror_image(S)), ("displaced", displaced(S))):
            for check in (True, False):
                res, wall, _ = _timed(
                    lambda S=S, T=T, c=check, kw=kw: fvf.match_result(S, T, check_symmetry=c, **kw)
                )
                e = fvf.geodesic_errors(S, res.p2p_21, ident)
                conf = "" if res.confidence is None else f"{res.confidence:.2f}"
                a = fvf.spectral.orientation_agreement(S, T, res.p2p_21)
                print(
                    f"| {name} | {pair} | {'on' if check else 'off'} | {e.mean():.4f} | "
                    f"{e.max():.4f} | {a:+.2f} | {conf} | {wall:.0f} |",
                    flush=True,
                )
    return 0


def dataset(args: argparse.Namespace) -> int:
    """The protocol of ``correspondence_dataset.py`` on ``args.dataset``, fvf beside pyFM."""
    cd = correspondence_dataset
    threadpool_limits(1)
    cd.silence_pyfm()
    methods = {"fvf": cd.fvf_matcher(**({"k": args.k} if args.k else {}))}
    pyfm = None if args.no_pyfm else cd.pyfm_matcher()
    if pyfm is not None:
        methods["pyFM"] = pyfm
    elif not args.no_pyfm:
        print("pyFM (PyPI pyfmaps) is not installed: fvf only")
    versions = f"fvf {fvf.__version__}, numpy {np.__version__}"
    if pyfm is not None:
        versions += f", pyfmaps {metadata.version('pyfmaps')}"
    print(f"{versions}; one BLAS thread (threadpoolctl)")
    print("error: 100 * geodesic distance on A / sqrt(area A), at the template points")
    rows, errors = cd.run_protocol(
        args.dataset, methods, pairs_file=args.pairs_file, max_pairs=args.max_pairs
    )
    cd.write_outputs(rows, errors, curve=args.curve, png=args.png, json_path=args.json)
    return 0


def timing(pairs: list[tuple[int, int]]) -> int:
    """fvf against pyFM on camel pairs at about 5k vertices (the frames) and 20k (one
    midpoint subdivision of each frame: the original vertices keep their indices, so the
    ground truth still holds for them): errors, wall and CPU seconds, fvf's steps."""
    from fvf.mesh.shapes import midpoint_subdivision

    threadpool_limits(1)
    warnings.filterwarnings("ignore", module="pyFM")
    print(
        "| n | pair | fvf error | pyFM error | fvf CPU s | pyFM CPU s | fvf wall s | "
        "pyFM wall s | fvf steps (wall s) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for subdivide in (False, True):
        for a, b in pairs:
            V1, F1 = fvf.read_mesh(DATA / f"camel-gallop-0{b}.off")
            V2, F2 = fvf.read_mesh(DATA / f"camel-gallop-0{a}.off")
            truth = np.loadtxt(DATA / f"camel_{a}_to_{b}.txt", dtype=np.int64)
            valid, n_2 = truth != 0, len(V2)
            if subdivide:
                V1, F1 = midpoint_subdivision(V1, F1)
                V2, F2 = midpoint_subdivision(V2, F2)
            prep_1, prep_2 = prepare_mesh(V1, F1), prepare_mesh(V2, F2)
            res, w_f, c_f = _timed(fvf.match_result, (V1, F1), (V2, F2))
            p_pyfm, w_p, c_p = _timed(run_pyfm, prep_1, prep_2, 1.0)
            e_f = errors_of(prep_1, res.p2p_21[:n_2], truth, valid).mean()
            e_p = errors_of(prep_1, p_pyfm[:n_2], truth, valid).mean()
            steps = ", ".join(f"{k} {v:.1f}" for k, v in res.timings.items())
            print(
                f"| {len(V1)} | {a} → {b} | {e_f:.4f} | {e_p:.4f} | {c_f:.1f} | {c_p:.1f} | "
                f"{w_f:.1f} | {w_p:.1f} | {steps} |",
                flush=True,
            )
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pairs", default=",".join(f"{a}-{b}" for a, b in PAIRS))
    ap.add_argument("--pyfm-orient", type=float, default=1.0, help="pyFM's w_orient (README: 1)")
    ap.add_argument("--json", help="also write the results here")
    ap.add_argument("--figures", help="also write pictures (needs the [viz] extra) here")
    ap.add_argument(
        "--planted",
        action="store_true",
        help="instead: the planted flips (mirror image, displaced copy) with and without "
        "fvf.match's symmetry check",
    )
    ap.add_argument("--dataset", help="instead: the protocol on a FAUST_r-style folder")
    ap.add_argument("--pairs-file", help="--dataset: pairs to run, two shape names a line")
    ap.add_argument("--max-pairs", type=int, help="--dataset: run the first N pairs only")
    ap.add_argument("--curve", help="--dataset: write the cumulative curves (CSV) here")
    ap.add_argument("--png", help="--dataset: draw the cumulative curves (PNG) here")
    ap.add_argument("--k", type=int, help="--dataset: fvf.match's k (default: its own)")
    ap.add_argument("--no-pyfm", action="store_true", help="--dataset: fvf only")
    ap.add_argument("--make-dataset", help="write a small generated set to this folder")
    ap.add_argument(
        "--timing",
        action="store_true",
        help="instead: fvf and pyFM times on camel pairs 1-3 and 2-4 (or --pairs) at 5k "
        "vertices and, midpoint-subdivided, at 20k",
    )
    args = ap.parse_args(argv)
    if args.planted:
        return planted()
    if args.timing:
        default = ",".join(f"{a}-{b}" for a, b in PAIRS)
        chosen = "1-3,2-4" if args.pairs == default else args.pairs
        return timing([tuple(int(x) for x in p.split("-")) for p in chosen.split(",")])
    if args.make_dataset:
        names = correspondence_dataset.make_dataset(args.make_dataset)
        print(f"wrote {len(names)} shapes to {args.make_dataset}")
        return 0
    if args.dataset:
        return dataset(args)
    pairs = [tuple(int(x) for x in p.split("-")) for p in args.pairs.split(",")]
    if not DATA.exists():
        print(f"no data at {DATA} (set FVF_SHARED_MESHES)")
        return 1
    threadpool_limits(1)
    warnings.filterwarnings("ignore", module="pyFM")
    print(f"fvf {fvf.__version__}, pyfmaps {metadata.version('pyfmaps')}, numpy {np.__version__}")
    print("one BLAS thread (threadpoolctl); error = mean geodesic / sqrt(area), valid vertices")
    head = f"{'pair':>5} | {'fvf err':>8} {'pyFM err':>8} {'ratio':>6} | "
    head += f"{'fvf s':>6} {'pyFM s':>6} {'fvf cpu':>7} {'pyFM cpu':>8} | verdict"
    print(head)
    rows, maps, errors = [], {}, {}
    for a, b in pairs:
        V1, F1 = fvf.read_mesh(DATA / f"camel-gallop-0{b}.off")
        V2, F2 = fvf.read_mesh(DATA / f"camel-gallop-0{a}.off")
        truth = np.loadtxt(DATA / f"camel_{a}_to_{b}.txt", dtype=np.int64)
        valid = truth != 0
        prep_1, prep_2 = prepare_mesh(V1, F1), prepare_mesh(V2, F2)
        p_fvf, w_fvf, c_fvf = _timed(run_fvf, V1, F1, V2, F2)
        p_pyfm, w_pyfm, c_pyfm = _timed(run_pyfm, prep_1, prep_2, args.pyfm_orient)
        errors[f"{a}to{b}"] = {
            "fvf": errors_of(prep_1, p_fvf, truth, valid),
            "pyFM": errors_of(prep_1, p_pyfm, truth, valid),
        }
        maps[f"{a}to{b}"] = (prep_1, prep_2, truth, valid, {"fvf": p_fvf, "pyFM": p_pyfm})
        e_fvf, e_pyfm = (float(errors[f"{a}to{b}"][m].mean()) for m in ("fvf", "pyFM"))
        ok = e_fvf <= e_pyfm and w_fvf <= w_pyfm
        rows.append(
            dict(
                pair=f"{a}->{b}",
                fvf_error=e_fvf,
                pyfm_error=e_pyfm,
                fvf_wall=w_fvf,
                pyfm_wall=w_pyfm,
                fvf_cpu=c_fvf,
                pyfm_cpu=c_pyfm,
                verdict="PASS" if ok else "MISS",
            )
        )
        print(
            f"{a}->{b:<2} | {e_fvf:8.4f} {e_pyfm:8.4f} {e_fvf / e_pyfm:6.2f} | {w_fvf:6.1f} "
            f"{w_pyfm:6.1f} {c_fvf:7.1f} {c_pyfm:8.1f} | {rows[-1]['verdict']}",
            flush=True,
        )
    mean_fvf = float(np.mean([r["fvf_error"] for r in rows]))
    mean_pyfm = float(np.mean([r["pyfm_error"] for r in rows]))
    half = mean_fvf <= 0.5 * mean_pyfm
    print(
        f" mean | {mean_fvf:8.4f} {mean_pyfm:8.4f} {mean_fvf / mean_pyfm:6.2f} | "
        f"{np.mean([r['fvf_wall'] for r in rows]):6.1f} "
        f"{np.mean([r['pyfm_wall'] for r in rows]):6.1f}"
        f" | mean error <= half of pyFM's: {'PASS' if half else 'MISS'}"
    )
    if args.figures:
        figures(Path(args.figures), maps, errors)
    if args.json:
        with atomic_path(args.json) as tmp:
            Path(tmp).write_text(
                json.dumps(dict(rows=rows, pyfm_w_orient=args.pyfm_orient), indent=1)
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
