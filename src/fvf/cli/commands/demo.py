"""``fvf demo``: the chapter's story on a mesh, with pictures and a report
(:func:`fvf.cli.demo.demo`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..common import EXIT_OK, EXIT_PROBLEMS, MESH_FORMATS, add_picture_options
from ..registry import register_command


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--mesh", help=f"mesh file ({MESH_FORMATS}; default: spot)")
    p.add_argument("--out", default="fvf-demo", help="output folder (default: fvf-demo)")
    add_picture_options(p)  # --size: of a one-view picture (default 600 450)


@register_command(
    "demo",
    help="run the chapter's story on a mesh (default: the built-in spot.obj)",
    example="fvf demo --mesh bunny.off --out results/",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Run the demo into ``--out``."""
    from ..demo import demo

    size = (int(args.size[0]), int(args.size[1])) if args.size else (600, 450)
    view = tuple(args.view) if args.view else None
    report = demo(args.mesh, Path(args.out), size=size, up=args.up, dpi=args.dpi, view=view)
    if report["checks_failed"]:  # a result that fails its own checks is not a success
        print(
            f"fvf demo: {report['checks_failed']} check(s) failed on this mesh (marked ✗ "
            f"above and in {args.out}/index.html); exit status {EXIT_PROBLEMS}",
            file=sys.stderr,
        )
        return EXIT_PROBLEMS
    return EXIT_OK
