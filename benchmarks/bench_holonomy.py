"""Cross fields on scans with and without the smoothed-holonomy connection.

Run from the repository root (shared meshes in ``../shared/meshes`` or
``$FVF_SHARED_MESHES``)::

    .venv/bin/python benchmarks/bench_holonomy.py
    .venv/bin/python benchmarks/bench_holonomy.py --meshes lion-00.off --align smooth

For each mesh and alignment, ``fvf.design_field(mesh, n=4, align=..., curvature_smoothing=
ell)`` with ``ell = None`` (the Levi-Civita connection) and ``ell = h``, the edge length of
a 2499-quad mesh (``h = sqrt(area / 2499)``); printed: the design time, the cones
(``fvf.singularities``), how many of the vertices with angle defect beyond π/4 carry one,
and the flipped uv triangles of ``fvf.seamless_parameterization(mesh, field=u,
target_faces=2499)`` (0 is needed for a quad mesh). BLAS on one thread (threadpoolctl).
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

import fvf
from fvf.mesh.geometry import angle_defects

SHARED = Path(
    os.environ.get("FVF_SHARED_MESHES", Path(__file__).resolve().parents[2] / "shared" / "meshes")
)
CASES = [("lion-00.off", "smooth"), ("faust_r_tr_reg_001.off", "curvature")]
TARGET = 2499


def run(name: str, align: str) -> None:
    mesh = fvf.TriMesh(*fvf.read_mesh(SHARED / name))
    h = float(np.sqrt(mesh.face_areas.sum() / TARGET))
    spikes = np.flatnonzero(np.abs(angle_defects(mesh)) > np.pi / 4)
    for ell in (None, h):
        start = time.perf_counter()
        u = fvf.design_field(
            mesh, n=4, align=None if align == "smooth" else align, curvature_smoothing=ell
        )
        seconds = time.perf_counter() - start
        ids, _ = fvf.singularities(mesh, u, n=4, zero="warn")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            flipped = fvf.seamless_parameterization(mesh, field=u, target_faces=TARGET).n_flipped
        print(
            f"{name:24s} {align:9s} {'h' if ell else 'none':5s} {seconds:7.1f} {ids.size:6d} "
            f"{np.isin(ids, spikes).sum():4d}/{spikes.size:<4d} {flipped:8d}",
            flush=True,
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", nargs="+", help="subset of the meshes")
    ap.add_argument("--align", choices=["smooth", "curvature"], help="one alignment for all")
    args = ap.parse_args()
    cases = [(m, args.align or a) for m, a in CASES if not args.meshes or m in args.meshes]
    cases += [(m, args.align or "smooth") for m in args.meshes or [] if m not in dict(CASES)]
    threadpool_limits(1)
    print(f"{'mesh':24s} {'align':9s} {'ell':5s} {'design':>7s} {'cones':>6s} spikes  flipped")
    for name, align in cases:
        run(name, align)


if __name__ == "__main__":
    main()
