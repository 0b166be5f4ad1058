"""``fvf info``: the validation report of a mesh file
(:func:`fvf.mesh.diagnostics.mesh_report`); exit status 1 when it finds a problem."""

from __future__ import annotations

import argparse
import json
import re
import shlex
from pathlib import Path

from ..common import EXIT_OK, EXIT_PROBLEMS, MESH_FILE, MESH_FORMATS
from ..registry import register_command

__all__ = ["info", "run"]


def info(path: str, as_json: bool = False) -> dict:
    """Print a validation report of a mesh file (every problem, with indices and fixes)."""
    import fvf
    from fvf.mesh.diagnostics import mesh_report

    report = mesh_report(*fvf.read_mesh(path))
    if as_json:
        print(json.dumps({"path": str(path), **report}, indent=2, default=str))
        return report
    print(f"{path}:")
    for key, val in report.items():
        if key not in ("problems", "hints"):
            print(f"  {key}: {val}")
    for hint in report.get("hints", []):
        print(f"  hint: {hint}")
    for problem in report["problems"]:
        print(f"  problem: {_shell_fix(problem)}")
    if not report["problems"]:
        print("  no problems found")
    elif _repairable(report):
        fixed = Path(path).stem + "_fixed" + Path(path).suffix
        print(f"  fix: fvf repair {shlex.quote(str(path))} -o {shlex.quote(fixed)}")
    return report


def _shell_fix(problem: str) -> str:
    """A problem line whose Python fix names repair steps, told for the shell instead."""
    from .repair import cli_repair_steps

    text, sep, fix = problem.partition(" Fix: ")
    steps = re.findall(r"fvf\.(\w+)\(", fix)
    if not sep or not steps or not all(step in cli_repair_steps() for step in steps):
        return problem
    return f"{text} Fixed by `fvf repair` (step {', '.join(dict.fromkeys(steps))})."


def _repairable(report: dict) -> bool:
    """Whether ``fvf repair`` addresses the problems (all but non-finite coordinates,
    bad shapes and non-orientable surfaces)."""
    fixable = ("Unreferenced", "Duplicate", "Degenerate", "Repeated", "NonManifold", "Orientation")
    return any(p.split(":")[0].startswith(fixable) for p in report["problems"])


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("mesh", help=MESH_FILE)
    p.add_argument("--json", action="store_true", help="print the report as JSON")


@register_command(
    "info",
    help=f"validation report of a mesh file ({MESH_FORMATS}): every problem with indices and fix",
    example="fvf info bunny.off   (exit status 1 when a problem is found)",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Print the report; exit status 1 when it lists a problem."""
    report = info(args.mesh, args.json)
    return EXIT_OK if not report["problems"] else EXIT_PROBLEMS
