r"""``fvf.quad_mesh`` on seeded random CSG parts: hollow boxes with thin walls, ribs, holes.

Run from the repository root (needs manifold3d, ``pip install -e '.[test]'``)::

    .venv/bin/python benchmarks/random_parts.py [--seeds 0 40] [--quads 2000]

Part ``seed`` is drawn by ``numpy.random.default_rng(seed)``: a box of 40–120 × 30–80 ×
10–40 mm; with probability 0.7 hollowed from the top with walls and floor $t$ of 0.8–4 mm
and zero to two ribs across it ($t$ thick, 0.3–0.9 of the height); zero to three holes of
3–10 mm through the floor (32 segments); with probability 0.5 a boss of 5–15 mm under it
(48 segments). Each part is meshed at ``--quads`` quads in this process (BLAS on one thread,
threadpoolctl) and the output judged by the independent checker
``tests/param/quadcheck.py``. One line per part (seed, wall, triangles, quads, valid or
the error, attempts, CPU seconds), then the valid count and the CPU total.
"""

from __future__ import annotations

import argparse
import sys
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", nargs=2, type=int, default=[0, 40], metavar=("FIRST", "END"))
    ap.add_argument("--quads", type=int, default=2000)
    args = ap.parse_args()
    sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "tests" / "param")]
    from threadpoolctl import threadpool_limits

    import fvf
    import quadcheck

    threadpool_limits(1)
    warnings.simplefilter("ignore")
    valid = total = 0
    cpu = 0.0
    for seed in range(*args.seeds):
        solid, t = part(seed)
        m = solid.to_mesh64()
        V = np.asarray(m.vert_properties)[:, :3].astype(np.float64)
        F = np.asarray(m.tri_verts).astype(np.int64)
        start = time.process_time()
        try:
            r = fvf.quad_mesh((V, F), target_faces=args.quads)
            ok = quadcheck.check(V, F, np.asarray(r.vertices), np.asarray(r.quads)).valid
            res = f"{len(r.quads):6d} {'valid' if ok else 'INVALID':8s} {len(r.attempts):2d}"
        except fvf.FvfError as exc:
            ok, res = False, f"{'-':>6s} {type(exc).__name__:8s}"
        dt = time.process_time() - start
        valid, total, cpu = valid + ok, total + 1, cpu + dt
        print(f"{seed:4d}  t={t:4.2f}  {F.shape[0]:5d}  {res:20s} {dt:6.1f}", flush=True)
    print(f"valid {valid} / {total}   CPU {cpu:.1f} s")


if __name__ == "__main__":
    main()
