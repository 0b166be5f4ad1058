r"""``fvf.quad_mesh`` on seeded random CSG parts: hollow boxes with thin walls, ribs, holes.

Run from the repository root (needs manifold3d, ``pip install -e '.[test]'``)::

    .venv/bin/python benchmarks/random_parts.py [--seeds 0 40] [--quads 2000] [--family shapes]
    .venv/bin/python benchmarks/random_parts.py --family mixed --stl

Part ``seed`` is drawn by ``numpy.random.default_rng(seed)``: a box of 40–120 × 30–80 ×
10–40 mm; with probability 0.7 hollowed from the top with walls and floor $t$ of 0.8–4 mm
and zero to two ribs across it ($t$ thick, 0.3–0.9 of the height); zero to three holes of
3–10 mm through the floor (32 segments); with probability 0.5 a boss of 5–15 mm under it
(48 segments).

``--family shapes`` (:func:`shape`), a family the pipeline was not tuned on: by ``seed mod
4`` a bracket (the hull of three cylinders of 3–6 mm radius, 5–12 mm high) with one to
three holes; one to four spheres of 5–20 mm unioned and cut flat; a 2–6 mm plate with
bosses and a slot, rotated, with a 10 mm cube beside it (two parts); a cylinder with a
bore and a bar across its foot.

``--family mixed`` (:func:`mixed`), written to look for crashes rather than to measure:
one to five cubes, cylinders and cones (12–96 segments), spheres and tori, 4–40 mm, each
flattened to a plate or rod 2–10 % thick with probability 0.3, turned and moved at random,
joined by union, difference or intersection; with probability 0.3 a second part beside
it; the whole scaled by a power of ten from $10^{-3}$ to $10^{3}$. ``--stl`` gives each
part to fvf as ``fvf quad FILE`` would get it: a binary STL soup read back by
``fvf.read_mesh`` (welded), zero-area faces repaired as ``fvf repair`` does. A foreign
exception (not an ``fvf.FvfError``) is printed as ``FOREIGN``. ``--fallback split`` asks
``fvf.quad_mesh(..., fallback="split")``: a part whose attempts all fail is split from
triangles (marked ``split``).

Each part is meshed at ``--quads`` quads in this process (BLAS on one thread,
threadpoolctl) and the output judged by the independent checker
``tests/param/quadcheck.py``. One line per part (seed, wall or kind, triangles, quads,
valid or the error, attempts, CPU seconds), then the valid count and the CPU total.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def part(seed: int):
    """The manifold3d solid of part ``seed`` (module docstring) and its wall t (mm)."""
    import manifold3d as mf

    cube, cyl = mf.Manifold.cube, mf.Manifold.cylinder
    r = np.random.default_rng(seed)
    L, W, H = r.uniform(40, 120), r.uniform(30, 80), r.uniform(10, 40)
    t = r.uniform(0.8, 4.0)
    s = cube([L, W, H])
    if r.random() < 0.7:  # hollow, open top
        s = s - cube([L - 2 * t, W - 2 * t, H]).translate([t, t, t])
        for _ in range(r.integers(0, 3)):  # ribs
            x = r.uniform(t, L - 2 * t)
            s = s + cube([t, W - 2 * t, r.uniform(0.3, 0.9) * H]).translate([x, t, 0])
    for _ in range(r.integers(0, 4)):  # holes through the floor
        d = r.uniform(3, 10)
        at = [r.uniform(d, L - d), r.uniform(d, W - d), -H]
        s = s - cyl(H * 3, d / 2, d / 2, 32).translate(at)
    if r.random() < 0.5:  # a boss underneath
        d = r.uniform(5, 15)
        s = s + cyl(r.uniform(3, 10), d / 2, d / 2, 48).translate(
            [L / 2, W / 2, -r.uniform(3, 10) + 0.01]
        )
    return s, t


def shape(seed: int):
    """The manifold3d solid of part ``seed`` of ``--family shapes`` (module docstring) and
    its kind (0–3)."""
    import manifold3d as mf

    M, r, kind = mf.Manifold, np.random.default_rng(1000 + seed), seed % 4
    if kind == 0:  # a bracket with holes
        c = M.cylinder(r.uniform(5, 12), r.uniform(3, 6), r.uniform(3, 6), 48)
        at = [(0, 0), (r.uniform(30, 60), 0), (0, r.uniform(20, 50))]
        s = M.batch_hull([c.translate([x, y, 0]) for x, y in at])
        for _ in range(r.integers(1, 4)):
            d = r.uniform(1, 3)
            s = s - M.cylinder(40, d, d, 32).translate([r.uniform(5, 25), r.uniform(2, 15), -10])
    elif kind == 1:  # spheres cut flat
        s = M.sphere(r.uniform(10, 20), 64)
        for _ in range(r.integers(1, 4)):
            s = s + M.sphere(r.uniform(5, 12), 48).translate(r.uniform(-15, 15, 3))
        s = s - M.cube([100, 100, 100]).translate([-50, -50, r.uniform(-5, 5)])
    elif kind == 2:  # a rotated plate with bosses and a slot, and a cube beside it
        s = M.cube([r.uniform(40, 80), r.uniform(20, 40), r.uniform(2, 6)])
        for _ in range(r.integers(1, 4)):
            d = r.uniform(2, 5)
            s = s + M.cylinder(r.uniform(4, 12), d, d, 40).translate(
                [r.uniform(5, 35), r.uniform(5, 15), 1]
            )
        s = s - M.cube([20, r.uniform(1.5, 4), 30]).translate([10, 8, -10])
        s = s.rotate([r.uniform(0, 90), r.uniform(0, 90), 0])
        s = s + M.cube([10, 10, 10]).translate([120, 0, 0])
    else:  # a cylinder with a bore and a bar across its foot
        d = r.uniform(10, 20)
        s = M.cylinder(r.uniform(5, 20), d, d, 64)
        b = r.uniform(3, 8)
        s = s - M.cylinder(50, b, b, 48).translate([0, 0, -10])
        s = s + M.cube([r.uniform(20, 40), 4, 4]).translate([0, -2, 0])
    return s, kind


def mixed(seed: int):
    """The manifold3d solid of part ``seed`` of ``--family mixed`` (module docstring) and
    its scale (a power of ten)."""
    import manifold3d as mf

    M, r = mf.Manifold, np.random.default_rng(2000 + seed)

    def primitive():
        size = r.uniform(4, 40, 3)
        kind = r.integers(4)
        if kind == 0:
            p = M.cube(size.tolist(), center=True)
        elif kind == 1:
            p = M.cylinder(
                size[2], size[0] / 2, r.uniform(0.2, 1) * size[0] / 2, int(r.integers(12, 97)), True
            )
        elif kind == 2:
            p = M.sphere(size[0] / 2, int(r.integers(16, 65)))
        else:  # a torus: a circle revolved
            ring = mf.CrossSection.circle(size[1] / 6, 24).translate([size[0] / 2 + size[1] / 6, 0])
            p = M.revolve(ring, int(r.integers(24, 73)))
        if r.random() < 0.3:  # a thin plate or a thin rod
            p = p.scale([1, 1, r.uniform(0.02, 0.1)])
        return p.rotate(r.uniform(0, 360, 3).tolist()).translate(r.uniform(-15, 15, 3).tolist())

    s = primitive()
    for _ in range(r.integers(1, 5)):
        op = r.integers(3)
        other = primitive()
        s = s + other if op == 0 else s - other if op == 1 else s ^ other
        if s.is_empty():
            s = primitive()
    if r.random() < 0.3:  # a second part beside it
        s = s + primitive().translate([80, 0, 0])
    scale = 10.0 ** int(r.integers(-3, 4))
    return s.scale([scale] * 3), scale


def _through_stl(V: np.ndarray, F: np.ndarray, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(V, F) written as a binary STL soup and read back as ``fvf quad FILE`` reads it:
    welded by ``fvf.read_mesh``, zero-area faces repaired by ``fvf.repair_mesh``."""
    import fvf
    import wild_corpus

    wild_corpus.write_stl(path, V, F)
    return wild_corpus.repaired_as_cli(*fvf.read_mesh(path))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", nargs=2, type=int, default=[0, 40], metavar=("FIRST", "END"))
    ap.add_argument("--quads", type=int, default=2000)
    ap.add_argument("--family", choices=["boxes", "shapes", "mixed"], default="boxes")
    ap.add_argument("--stl", action="store_true", help="each part through a binary STL soup")
    ap.add_argument(
        "--fallback",
        choices=["error", "split"],
        default="error",
        help="fvf.quad_mesh's fallback: parts whose attempts all fail split from triangles",
    )
    args = ap.parse_args()
    tmp = tempfile.TemporaryDirectory()
    sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "tests" / "param")]
    from threadpoolctl import threadpool_limits

    import fvf
    import quadcheck

    threadpool_limits(1)
    warnings.simplefilter("ignore")
    valid = total = split = 0
    cpu = 0.0
    make = {"boxes": part, "shapes": shape, "mixed": mixed}[args.family]
    for seed in range(*args.seeds):
        solid, t = make(seed)
        m = solid.to_mesh64()
        V = np.asarray(m.vert_properties)[:, :3].astype(np.float64)
        F = np.asarray(m.tri_verts).astype(np.int64)
        start = time.process_time()
        try:
            if args.stl:  # as `fvf quad FILE` gets it: a soup, welded, zero-area faces repaired
                V, F = _through_stl(V, F, Path(tmp.name) / f"{seed}.stl")
            r = fvf.quad_mesh((V, F), target_faces=args.quads, fallback=args.fallback)
            ok = quadcheck.check(V, F, np.asarray(r.vertices), np.asarray(r.quads)).valid
            res = f"{len(r.quads):6d} {'valid' if ok else 'INVALID':8s} {len(r.attempts):2d}"
            res += " split" if r.split_components.size else ""
        except fvf.FvfError as exc:
            ok, res = False, f"{'-':>6s} {type(exc).__name__:8s}"
        except Exception as exc:  # noqa: BLE001 -- a foreign exception is a bug: reported
            ok, res = False, f"{'-':>6s} FOREIGN {type(exc).__name__}: {str(exc)[:60]}"
        dt = time.process_time() - start
        valid, total, cpu = valid + ok, total + 1, cpu + dt
        split += res.endswith("split")
        label = {"boxes": f"t={t:4.2f}", "shapes": f"kind {t}", "mixed": f"x{t:g}"}[args.family]
        print(f"{seed:4d}  {label:6s}  {F.shape[0]:5d}  {res:20s} {dt:6.1f}", flush=True)
    print(f"valid {valid} / {total} ({split} split from triangles)   CPU {cpu:.1f} s")


if __name__ == "__main__":
    main()
