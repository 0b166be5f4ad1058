"""The ``fvf`` command. It contains no math: every number comes from a library call."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

__all__ = ["main"]


def info(path: str) -> dict:
    """Print a validation report of a mesh file (every problem, with indices and fixes)."""
    import fvf
    from fvf.diagnostics import mesh_report

    report = mesh_report(*fvf.read_mesh(path))
    print(f"{path}:")
    for key, val in report.items():
        if key != "problems":
            print(f"  {key}: {val}")
    for problem in report["problems"]:
        print(f"  problem: {problem}")
    if not report["problems"]:
        print("  no problems found")
    return report


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``fvf`` command."""
    parser = argparse.ArgumentParser(prog="fvf", description=__doc__)
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser(
        "demo",
        help="run the chapter's story on a mesh (default: the built-in spot.obj)",
        epilog="example: fvf demo --mesh bunny.off --out results/",
    )
    p.add_argument("--mesh", help="OBJ, OFF or PLY file (default: built-in spot)")
    p.add_argument("--out", default="fvf-demo", help="output folder (default: fvf-demo)")
    p = sub.add_parser(
        "info",
        help="validation report of a mesh file (OBJ, OFF, PLY)",
        epilog="example: fvf info bunny.off   (exit status 1 when a problem is found)",
    )
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    args = parser.parse_args(argv)
    try:
        if args.command == "demo":
            from fvf.demo import demo

            demo(args.mesh, Path(args.out))
        elif args.command == "info":
            return 0 if not info(args.mesh)["problems"] else 1
    except (ValueError, OSError) as exc:
        if args.debug:
            raise
        print(f"fvf: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
