"""``fvf quad``: a quad mesh along a cross field: the seamless parameterization
(:func:`fvf.seamless_parameterization`), integer-grid extraction and its quality
(:func:`fvf.quad_quality`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from ..common import (
    EXIT_OK,
    Sources,
    add_output,
    check_outputs,
    integer,
    load_mesh,
    load_viz,
    unavailable,
)
from ..registry import register_command


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("mesh", help="closed OBJ, OFF or PLY triangle mesh")
    p.add_argument("data", nargs="*", help=".npz data file(s) holding the --field key")
    p.add_argument("--faces", type=integer, required=True, metavar="N", help="target quads")
    p.add_argument(
        "--align",
        choices=("curvature", "smooth"),
        default="curvature",
        help="default cross field: curvature aligned (default) or smoothest",
    )
    p.add_argument(
        "--field",
        metavar="KEY",
        help="cross field (m,3), one representative per face: a key of DATA or FILE.npz:KEY",
    )
    add_output(p, "output quad mesh (.obj, .off, .ply, .vtu or .vtp)")
    p.add_argument("--uv", metavar="OBJ", help="also write the parameterized mesh with vt")
    p.add_argument("--png", help="also render the quad mesh (fvf.viz)")


def _stage_printer() -> Callable[[str, int, int], None]:
    """The ``progress`` of the parameterization: one line on stderr as each stage starts
    (and each round of the fold repair), with the seconds since now."""
    import time

    t0 = time.perf_counter()
    started: list[str] = []

    def progress(message: str, done: int, total: int) -> None:  # each stage as it starts
        if done == 0 or message not in started:  # and the fold repair's rounds
            started.append(message)
            print(f"fvf quad: {time.perf_counter() - t0:6.1f}s  {message}", file=sys.stderr)

    return progress


@register_command(
    "quad",
    help="quad mesh along a cross field: seamless parameterization and integer-grid "
    "extraction (fvf.quad_mesh)",
    example="fvf quad spot.obj --faces 2000 -o spot_quads.obj --uv spot_uv.obj\n"
    "  fvf quad spot.obj --faces 2000 --field cross.npz:u -o spot_quads.obj",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Write the quad mesh (and the parameterized mesh, the picture); print its quality."""
    import fvf
    from fvf.io.meshfile import check_writable, write_uv_mesh

    check_outputs(args, ("-o", args.output), ("--uv", args.uv), ("--png", args.png))
    check_writable(args.output, face_size=4)  # a format that holds quads, before the work
    mesh = load_mesh(args.mesh)
    field = Sources(args, mesh).field(args.field) if args.field else None
    progress = _stage_printer()

    from fvf.param.extraction import extract_quads

    param = fvf.seamless_parameterization(
        mesh, target_faces=args.faces, field=field, align=args.align, progress=progress
    )
    progress("quad extraction", 0, 1)
    qm = extract_quads(mesh, param.uv)
    V, Q = qm.vertices, qm.quads
    fvf.write_mesh(args.output, V, Q)
    q = fvf.quad_quality(mesh, V, Q, parameterization=param)
    print(
        f"wrote {args.output}: {Q.shape[0]} quads, {V.shape[0]} vertices, "
        f"{q.n_irregular} irregular ({q.irregular_fraction:.1%}), corner angle deviation "
        f"median {q.angle_deviation_median:.1f} deg, 95% {q.angle_deviation_p95:.1f} deg"
    )
    if args.uv:
        write_uv_mesh(args.uv, mesh.vertices, mesh.faces, param.uv)
        print(f"wrote {args.uv}: the parameterized triangle mesh (vt per corner)")
    if args.png:
        viz = load_viz()
        try:
            info = viz.render_quads(V, Q, args.png, title=f"{Q.shape[0]} quads")
        except ImportError as exc:
            raise unavailable(exc) from exc
        print(f"wrote {info.path}")
    return EXIT_OK
