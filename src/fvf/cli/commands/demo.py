"""``fvf demo``: the chapter's story on a mesh, with pictures and a report
(:func:`fvf.cli.demo.demo`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..common import EXIT_OK
from ..registry import register_command


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--mesh", help="OBJ, OFF or PLY file (default: built-in spot)")
    p.add_argument("--out", default="fvf-demo", help="output folder (default: fvf-demo)")


@register_command(
    "demo",
    help="run the chapter's story on a mesh (default: the built-in spot.obj)",
    example="fvf demo --mesh bunny.off --out results/",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Run the demo into ``--out``."""
    from ..demo import demo

    demo(args.mesh, Path(args.out))
    return EXIT_OK
