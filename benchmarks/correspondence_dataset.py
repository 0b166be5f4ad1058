"""The standard shape-correspondence protocol on a folder of meshes with correspondences to a
template (the layout of the remeshed FAUST_r, SCAPE_r and SMAL_r sets):

    DIR/shapes/NAME.off      (or .obj, .ply)
    DIR/corres/NAME.vts      one 1-based vertex index of NAME per template point

Line i of every ``.vts`` file names the vertex of that shape that corresponds to template
point i, so two shapes A and B correspond at the pairs (vts_A[i], vts_B[i]). For a pair
"A B", a matcher returns p2p_21: for each vertex of B a vertex of A (``fvf.match(A, B)``);
the error of template point i is the literature's

    100 · d_A(p2p_21[vts_B[i]], vts_A[i]) / √area(A),

d_A the geodesic distance on A (:func:`fvf.geodesic_errors`, ``"unfolded"`` distances:
+2 to +4 % above exact polyhedral geodesics), averaged over the template points for the
pair's error. Run through ``bench_correspondence.py --dataset DIR``; ``make_dataset``
writes a small generated set in this layout (used by the tests).
"""

from __future__ import annotations

import csv
import itertools
import json
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

import fvf
from fvf.io.atomic import atomic_path
from fvf.mesh.prepared import PreparedMesh, prepare_mesh
from fvf.mesh.shapes import midpoint_subdivision

MESH_SUFFIXES = (".off", ".obj", ".ply")

#: A pair's mean error above this (× 100 unit) counts as a failure ("flip") in the summary.
FLIP_THRESHOLD = 5.0


@dataclass(frozen=True)
class Shape:
    """A shape as read (the arrays fvf gets) and prepared (what pyFM gets, and where
    errors are measured)."""

    vertices: np.ndarray
    faces: np.ndarray
    prepared: PreparedMesh


Matcher = Callable[[Shape, Shape], np.ndarray]


@dataclass
class PairRow:
    """One pair, one method: mean and max error (× 100 unit), wall and CPU seconds."""

    pair: str
    method: str
    mean_error: float
    max_error: float
    wall: float
    cpu: float


# ---------------------------------------------------------------------------- reading
def read_vts(path: str | Path) -> np.ndarray:
    """A ``.vts`` file's 1-based indices as 0-based int64 (t,)."""
    idx = np.loadtxt(path, dtype=np.int64, ndmin=1)
    if idx.size and idx.min() < 1:
        raise ValueError(f"{path}: .vts indices are 1-based; found {idx.min()}")
    return idx - 1


def dataset_shapes(folder: str | Path) -> dict[str, Path]:
    """NAME -> mesh path, for every shape of ``folder/shapes`` with ``folder/corres/NAME.vts``."""
    folder = Path(folder)
    shapes = {}
    for p in sorted((folder / "shapes").iterdir()):
        if p.suffix.lower() in MESH_SUFFIXES and (folder / "corres" / f"{p.stem}.vts").exists():
            shapes[p.stem] = p
    if not shapes:
        raise FileNotFoundError(f"{folder}: no shapes/NAME.off with corres/NAME.vts")
    return shapes


def dataset_pairs(
    names: Sequence[str], pairs_file: str | Path | None = None, max_pairs: int | None = None
) -> list[tuple[str, str]]:
    """Pairs (A, B) to run: from ``pairs_file`` (two names per line, '#' comments), else
    every unordered pair of ``names`` in sorted order (A before B); the first
    ``max_pairs`` of them."""
    if pairs_file is not None:
        pairs = []
        for line in Path(pairs_file).read_text().splitlines():
            words = line.split("#")[0].split()
            if words:
                if len(words) != 2 or not set(words) <= set(names):
                    raise ValueError(f"{pairs_file}: {line!r} is not two shapes of the set")
                pairs.append((words[0], words[1]))
    else:
        pairs = list(itertools.combinations(sorted(names), 2))
    return pairs[:max_pairs] if max_pairs else pairs


# ---------------------------------------------------------------------------- matchers
def fvf_matcher(**kwargs) -> Matcher:
    """``fvf.match`` with its defaults (or ``kwargs``) on the arrays as read."""

    def run(s1: Shape, s2: Shape) -> np.ndarray:
        return fvf.match((s1.vertices, s1.faces), (s2.vertices, s2.faces), **kwargs)

    return run


def pyfm_matcher() -> Matcher | None:
    """pyFM's README pipeline (see ``bench_correspondence.run_pyfm``), or None when
    pyfmaps is not installed."""
    try:
        import pyFM  # noqa: F401
    except ImportError:
        return None
    from bench_correspondence import run_pyfm

    return lambda s1, s2: run_pyfm(s1.prepared, s2.prepared, 1.0)


# ---------------------------------------------------------------------------- protocol
def pair_errors(
    p1: PreparedMesh, p2p_21: np.ndarray, vts_1: np.ndarray, vts_2: np.ndarray
) -> np.ndarray:
    """100 · geodesic error / √area(A) at each template point, float64 (t,)."""
    to = p1.input_to_mesh
    return 100.0 * fvf.geodesic_errors(p1.mesh, to[p2p_21[vts_2]], to[vts_1])


def run_protocol(
    folder: str | Path,
    methods: dict[str, Matcher],
    *,
    pairs_file: str | Path | None = None,
    max_pairs: int | None = None,
    out: Callable[[str], None] = print,
) -> tuple[list[PairRow], dict[str, np.ndarray]]:
    """Run every method on every pair; print a row per pair and the summary.

    Returns
    -------
    rows : list of PairRow
    errors : dict method -> float64 (pairs · t,), every template point's error, pooled
    """
    shapes = dataset_shapes(folder)
    pairs = dataset_pairs(list(shapes), pairs_file, max_pairs)
    vts = {name: read_vts(Path(folder) / "corres" / f"{name}.vts") for name in shapes}
    loaded: dict[str, Shape] = {}
    rows: list[PairRow] = []
    pooled: dict[str, list[np.ndarray]] = {m: [] for m in methods}
    cols = "".join(f" | {m + ' err':>9} {'max':>6} {'s':>6}" for m in methods)
    out(f"{'pair':>24}{cols}")
    for a, b in pairs:
        for name in (a, b):
            if name not in loaded:
                V, F = fvf.read_mesh(shapes[name])
                loaded[name] = Shape(V, F, prepare_mesh(V, F, name=name))
        s1, s2 = loaded[a], loaded[b]
        line = f"{a + ' <- ' + b:>24}"
        for method, run in methods.items():
            w0, c0 = time.perf_counter(), time.process_time()
            p2p = np.asarray(run(s1, s2), dtype=np.int64)
            wall, cpu = time.perf_counter() - w0, time.process_time() - c0
            e = pair_errors(s1.prepared, p2p, vts[a], vts[b])
            pooled[method].append(e)
            rows.append(PairRow(f"{a} {b}", method, float(e.mean()), float(e.max()), wall, cpu))
            line += f" | {e.mean():9.2f} {e.max():6.1f} {wall:6.1f}"
        out(line)
    for line in summary(rows, list(methods)):
        out(line)
    return rows, {m: np.concatenate(v) if v else np.zeros(0) for m, v in pooled.items()}


def summary(rows: Sequence[PairRow], methods: Sequence[str]) -> list[str]:
    """Markdown table: per method the mean over pairs, the worst pair, the pairs above
    :data:`FLIP_THRESHOLD`, and the mean wall and CPU seconds per pair (the CPU time
    includes the time spent in BLAS)."""
    head = "| method | pairs | mean error | max pair error | pairs > 5 | wall s | CPU s |"
    lines = [
        head,
        "|---|---|---|---|---|---|---|",
    ]
    for m in methods:
        r = [x for x in rows if x.method == m]
        if not r:
            continue
        mean = np.array([x.mean_error for x in r])
        lines.append(
            f"| {m} | {len(r)} | {mean.mean():.2f} | {mean.max():.2f} | "
            f"{int((mean > FLIP_THRESHOLD).sum())} | {np.mean([x.wall for x in r]):.1f} | "
            f"{np.mean([x.cpu for x in r]):.1f} |"
        )
    return lines


def write_outputs(
    rows: Sequence[PairRow],
    errors: dict[str, np.ndarray],
    *,
    curve: str | Path | None = None,
    png: str | Path | None = None,
    json_path: str | Path | None = None,
) -> None:
    """The cumulative curves as CSV (threshold in geodesic error / √area, 0 to 0.25, and
    one column per method: the fraction of template points within it) and PNG, the rows
    as JSON."""
    if curve:
        t = np.linspace(0.0, 0.25, 101)
        cols = {m: fvf.spectral.cumulative_error_curve(e / 100.0, t)[1] for m, e in errors.items()}
        with atomic_path(curve) as tmp, open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["threshold", *cols])
            for i, ti in enumerate(t):
                w.writerow([f"{ti:.4f}", *(f"{c[i]:.5f}" for c in cols.values())])
    if png:
        from fvf import viz

        viz.plot_error_curves(
            {m: e / 100.0 for m, e in errors.items()},
            png,
            max_error=0.25,
            title="cumulative geodesic error over all pairs",
        )
    if json_path:
        with atomic_path(json_path) as tmp:
            Path(tmp).write_text(json.dumps([asdict(r) for r in rows], indent=1))


# ---------------------------------------------------------------------------- generated set
def generated_body(level: int = 3) -> fvf.TriMesh:
    """A four-limbed, near-symmetric blob: an icosphere stretched and bulged (symmetric
    about x = 0 up to a small odd term)."""
    sphere = fvf.icosphere(level)
    x, y, z = sphere.vertices.T
    r = 1 + 0.25 * y + 0.2 * z + 0.15 * np.cos(2.5 * y) * z + 0.3 * x**2 * y + 0.5 * x**4
    r += 0.05 * (x * y + x**3)
    return fvf.TriMesh(sphere.vertices * np.array([2.0, 1.2, 0.8]) * r[:, None], sphere.faces)


def _posed(X: np.ndarray, seed: int, amplitude: float = 0.03) -> np.ndarray:
    """X moved by a smooth random field of sines (``amplitude`` of the extent) and a random
    rigid motion."""
    rng = np.random.default_rng(seed)
    extent = np.ptp(X, axis=0).max()
    c = (X - X.mean(0)) / extent
    W, phase = 3.0 * rng.standard_normal((3, 3)), rng.uniform(0, 6, 3)
    Y = X + amplitude * extent * np.sin(c @ W + phase)
    Q, R = np.linalg.qr(rng.standard_normal((3, 3)))
    Q *= np.sign(np.diag(R))
    if np.linalg.det(Q) < 0:
        Q[:, 0] *= -1
    return Y @ Q.T + rng.standard_normal(3)


def make_dataset(folder: str | Path, n_shapes: int = 4, level: int = 3, seed: int = 0) -> list[str]:
    """Write a small set in the FAUST_r layout: ``n_shapes`` smoothly displaced, rigidly
    moved copies of :func:`generated_body` with shuffled vertices, every other one also
    midpoint-subdivided (a different vertex count and connectivity). The template is the
    body; its points are its vertices, which every copy keeps, so each ``.vts`` is exact.

    Returns the shape names.
    """
    folder = Path(folder)
    (folder / "shapes").mkdir(parents=True, exist_ok=True)
    (folder / "corres").mkdir(parents=True, exist_ok=True)
    body = generated_body(level)
    names = []
    for i in range(n_shapes):
        V, F = body.vertices, body.faces
        if i % 2:
            V, F = midpoint_subdivision(V, F)  # the body's vertices stay first
        V = _posed(V, seed + i)
        perm = np.random.default_rng(seed + 100 + i).permutation(len(V))  # new i = old perm[i]
        inv = np.argsort(perm)
        name = f"shape_{i:03d}"
        fvf.write_mesh(folder / "shapes" / f"{name}.off", V[perm], inv[F])
        np.savetxt(folder / "corres" / f"{name}.vts", inv[: body.n_vertices] + 1, fmt="%d")
        names.append(name)
    return names


def silence_pyfm() -> None:
    """pyFM's deprecation and convergence warnings, off."""
    warnings.filterwarnings("ignore", module="pyFM")
