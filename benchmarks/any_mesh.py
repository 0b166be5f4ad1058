""":func:`fvf.match` on "any two meshes": the second mesh of a pair with holes cut, cut to
a part, scaled and moved, remeshed, or with specks added, against the first as it is.

Run from the repository root (FAUST_r layout: ``DIR/shapes/*.off``, ``DIR/corres/*.vts``)::

    .venv/bin/python benchmarks/any_mesh.py --dataset faust_r \\
        [--pairs tr_reg_080-tr_reg_081,tr_reg_090-tr_reg_091] [--alterations holes,scaled]
        [--seeds 0,1,2] [--json out.json]

(the default pairs: 080 ← 081, 085 ← 086, 090 ← 091, 095 ← 096).

For a pair "A B" the map is ``fvf.match(A, B')`` (each vertex of B' to a vertex of A) with
its defaults, B' the altered B, one BLAS thread (threadpoolctl). The error is the
protocol's (``correspondence_dataset.pair_errors``): 100 · geodesic distance on A /
√area(A) at the template points, carried to B' by :func:`alter`'s vertex map (template
points on removed parts of B are left out; "covered" is the fraction kept). The
alterations, each seeded:

* ``none``: B as it is.
* ``holes``: the faces with a vertex in three balls of radius 0.04 √area(B) around
  random vertices removed, then the unreferenced vertices.
* ``big-holes``: the same with radius 0.08 √area(B) (a hole may cut off a finger: a
  piece of more than 1 % of the vertices raises ``DisconnectedMeshError``, reported as
  such).
* ``partial``: only the upper 60 % of B by height (the faces whose three vertices are
  in it), then the unreferenced vertices.
* ``partial+landmarks``: the same part, with 6 true landmark pairs (template points far
  apart on the part) passed to ``fvf.match``.
* ``scaled``: B × 1000, rotated and translated.
* ``remeshed``: B remeshed isotropically by pymeshlab at 1.3 times its mean edge length
  (a different vertex count and connectivity); a template point goes to the nearest new
  vertex.
* ``specks``: three floating specks (icospheres of 12 vertices, 1 % of B's extent) just
  off the surface, appended to B's arrays.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

import fvf

ALTERATIONS = (
    "none",
    "holes",
    "big-holes",
    "partial",
    "partial+landmarks",
    "scaled",
    "remeshed",
    "specks",
)


def _up_axis(V: np.ndarray) -> int:
    """The axis of the largest extent (a standing body's height)."""
    return int(np.argmax(np.ptp(V, axis=0)))


def _keep_faces(V: np.ndarray, F: np.ndarray, face_keep: np.ndarray):
    """(V', F', to_new): the faces kept and the vertices they reference; to_new (n,) is
    each input vertex's new index, -1 when removed."""
    F = F[face_keep]
    used = np.unique(F)
    to_new = np.full(V.shape[0], -1, dtype=np.int64)
    to_new[used] = np.arange(used.size)
    return V[used], to_new[F], to_new


def cut_holes(V, F, n_holes: int = 3, radius: float = 0.04, seed: int = 0):
    """Remove the faces with a vertex within ``radius`` √area of ``n_holes`` random vertices."""
    rng = np.random.default_rng(seed)
    mesh = fvf.TriMesh(V, F)
    r = radius * np.sqrt(mesh.total_area)
    centres = V[rng.choice(V.shape[0], n_holes, replace=False)]
    inside = cKDTree(centres).query(V)[0] <= r
    return _keep_faces(V, F, ~inside[F].any(axis=1))


def upper_part(V, F, fraction: float = 0.6, axis: int | None = None):
    """Keep the faces whose vertices all lie in the upper ``fraction`` of the height."""
    axis = _up_axis(V) if axis is None else axis
    h = V[:, axis]
    above = h >= h.max() - fraction * np.ptp(h)
    return _keep_faces(V, F, above[F].all(axis=1))


def scaled_and_moved(V, F, scale: float = 1000.0, seed: int = 0):
    """``scale`` times V, rotated by a random rotation and translated."""
    rng = np.random.default_rng(seed)
    Q, R = np.linalg.qr(rng.standard_normal((3, 3)))
    Q *= np.sign(np.diag(R))
    if np.linalg.det(Q) < 0:
        Q[:, 0] *= -1
    shift = scale * rng.uniform(-2, 2, 3)
    return scale * V @ Q.T + shift, F.copy(), np.arange(V.shape[0], dtype=np.int64)


def remeshed(V, F, factor: float = 1.3):
    """Isotropic remeshing (pymeshlab) at ``factor`` times the mean edge length; each input
    vertex goes to the nearest new vertex."""
    import pymeshlab

    e = np.linalg.norm(V[F] - V[np.roll(F, -1, axis=1)], axis=2).mean()
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V, F.astype(np.int32)))
    length = getattr(pymeshlab, "PureValue", None) or pymeshlab.AbsoluteValue
    ms.meshing_isotropic_explicit_remeshing(
        targetlen=length(factor * e), featuredeg=180.0, iterations=10
    )
    m = ms.current_mesh()
    V2, F2 = m.vertex_matrix().astype(float), m.face_matrix().astype(np.int64)
    return V2, F2, cKDTree(V2).query(V)[1].astype(np.int64)


def with_specks(V, F, n_specks: int = 3, size: float = 0.01, seed: int = 0):
    """Append ``n_specks`` icospheres of 12 vertices (radius ``size`` of the extent) just off
    the surface of random vertices."""
    rng = np.random.default_rng(seed)
    mesh = fvf.TriMesh(V, F)
    extent = float(np.ptp(V, axis=0).max())
    ico = fvf.icosphere(0)
    Vs, Fs = [V], [F]
    for j, i in enumerate(rng.choice(V.shape[0], n_specks, replace=False)):
        centre = V[i] + 3 * size * extent * fvf.mesh.vertex_normals(mesh)[i]
        Vs.append(centre + size * extent * ico.vertices)
        Fs.append(ico.faces + V.shape[0] + j * ico.n_vertices)
    return np.vstack(Vs), np.vstack(Fs), np.arange(V.shape[0], dtype=np.int64)


def alter(name: str, V: np.ndarray, F: np.ndarray, seed: int = 0):
    """(V', F', to_new) for one of :data:`ALTERATIONS`; to_new (n,) int64 maps each vertex
    of (V, F) to its vertex of (V', F'), -1 when removed."""
    if name == "none":
        return V, F, np.arange(V.shape[0], dtype=np.int64)
    if name in ("holes", "big-holes"):
        return cut_holes(V, F, radius=0.04 if name == "holes" else 0.08, seed=seed)
    if name.startswith("partial"):
        return upper_part(V, F)
    if name == "scaled":
        return scaled_and_moved(V, F, seed=seed)
    if name == "remeshed":
        return remeshed(V, F)
    if name == "specks":
        return with_specks(V, F, seed=seed)
    raise ValueError(f"unknown alteration {name!r}; one of {ALTERATIONS}")


def spread_landmarks(V: np.ndarray, candidates: np.ndarray, count: int) -> np.ndarray:
    """``count`` rows of ``candidates`` (indices into V) far apart (farthest points in space)."""
    chosen = [0]
    d = np.linalg.norm(V[candidates] - V[candidates[0]], axis=1)
    for _ in range(count - 1):
        chosen.append(int(np.argmax(d)))
        d = np.minimum(d, np.linalg.norm(V[candidates] - V[candidates[chosen[-1]]], axis=1))
    return np.array(chosen)


def run_pair(dataset: Path, a: str, b: str, alteration: str, seed: int = 0) -> dict:
    """One pair, one alteration: mean error, covered fraction, sizes, seconds."""
    import correspondence_dataset as cd

    VA, FA = fvf.read_mesh(dataset / "shapes" / f"{a}.off")
    VB, FB = fvf.read_mesh(dataset / "shapes" / f"{b}.off")
    vts_a = cd.read_vts(dataset / "corres" / f"{a}.vts")
    vts_b = cd.read_vts(dataset / "corres" / f"{b}.vts")
    V2, F2, to_new = alter(alteration, VB, FB, seed)
    vts_2 = to_new[vts_b]
    ok = vts_2 >= 0
    landmarks = None
    if alteration == "partial+landmarks":
        rows = np.flatnonzero(ok)[spread_landmarks(VB[vts_b], np.flatnonzero(ok), 6)]
        landmarks = np.stack([vts_a[rows], vts_2[rows]], axis=1)
    w0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            p2p = fvf.match((VA, FA), (V2, F2), landmarks=landmarks)
        except fvf.DisconnectedMeshError as exc:
            caught.append(warnings.WarningMessage(str(exc), type(exc), "", 0))
            p2p = None
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    p1 = fvf.mesh.prepare_mesh(VA, FA)
    err = cd.pair_errors(p1, p2p, vts_a[ok], vts_2[ok]) if p2p is not None else np.full(1, np.nan)
    return {
        "pair": f"{a}<-{b}",
        "alteration": alteration,
        "seed": seed,
        "n_2": int(V2.shape[0]),
        "covered": float(ok.mean()),
        "mean_error": float(err.mean()),
        "median_error": float(np.median(err)),
        "wall": wall,
        "cpu": cpu,
        "warnings": [f"{w.category.__name__}: {w.message}" for w in caught],
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dataset", type=Path, required=True, help="a folder in the FAUST_r layout")
    ap.add_argument(
        "--pairs",
        default="tr_reg_080-tr_reg_081,tr_reg_085-tr_reg_086,tr_reg_090-tr_reg_091,"
        "tr_reg_095-tr_reg_096",
    )
    ap.add_argument("--alterations", default=",".join(ALTERATIONS))
    ap.add_argument("--seeds", default="0", help="seeds of the random alterations, e.g. 0,1,2")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from threadpoolctl import threadpool_limits

    rows = []
    print("one BLAS thread; error = 100 * mean geodesic on A / sqrt(area A), template points")
    print(
        f"{'pair':24} {'alteration':18} {'seed':>4} {'n_2':>6} {'covered':>7} {'mean':>7} "
        f"{'median':>7} {'wall s':>7} {'cpu s':>6}"
    )
    with threadpool_limits(1):
        for pair in args.pairs.split(","):
            a, b = pair.split("-")
            for alteration, seed in itertools.product(
                args.alterations.split(","), map(int, args.seeds.split(","))
            ):
                r = run_pair(args.dataset, a, b, alteration, seed)
                rows.append(r)
                print(
                    f"{r['pair']:24} {alteration:18} {seed:4d} {r['n_2']:6d} {r['covered']:7.2f} "
                    f"{r['mean_error']:7.2f} {r['median_error']:7.2f} {r['wall']:7.1f} "
                    f"{r['cpu']:6.1f}",
                    flush=True,
                )
                for w in r["warnings"]:
                    print(f"    {w[:160]}")
                if args.json:
                    args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
