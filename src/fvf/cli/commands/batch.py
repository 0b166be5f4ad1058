"""``fvf batch``: registered tasks over many meshes and mesh pairs on a Dask cluster
(:func:`fvf.batch.run`); exit status 1 when some meshes failed."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..common import EXIT_OK, EXIT_PROBLEMS
from ..registry import register_command


def _example() -> str:
    """The example of ``fvf batch --help``, with the registered batch tasks."""
    from fvf.batch import registered_tasks

    listing = "\n".join(
        f"  {t.name:<14} ({t.kind}) {t.description}" for t in registered_tasks().values()
    )
    return (
        "fvf batch scans/ 'more/*.ply' -o results/ --tasks info,basis --k 30 --workers 2\n"
        "  fvf batch scans/ -o results/ --scheduler tcp://10.0.0.5:8786\n\n"
        f"tasks:\n{listing}\n\n"
        "Results: OUT/summary.csv (one row per mesh and pair), OUT/meshes/<name>.npz,\n"
        "OUT/pairs/<a>--<b>.npz; see docs/batch.md. Exit status 1: some meshes failed."
    )


def _arguments(p: argparse.ArgumentParser) -> None:
    from fvf.batch import DEFAULT_MESH_TASKS

    p.add_argument("inputs", nargs="*", help="mesh files, folders, quoted glob patterns")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="output folder")
    p.add_argument(
        "--tasks",
        help=f"comma-separated task names (default: {','.join(DEFAULT_MESH_TASKS)}, "
        "and a pair task with --pairs)",
    )
    p.add_argument("--k", type=int, default=50, help="eigenpairs of basis / fmap (default 50)")
    p.add_argument("--n", type=int, help="field symmetry N (N-fields, when supported)")
    p.add_argument("--quads", type=int, metavar="N", help="quads per mesh of the quad task")
    p.add_argument(
        "--fallback",
        choices=("error", "split"),
        default="error",
        help="quad task: a part whose attempts all fail fails the mesh (default) or is "
        "split from triangles",
    )
    p.add_argument("--pairs", metavar="CSV", help="mesh pairs, source,target[,map] per line")
    p.add_argument("--workers", type=int, help="local worker processes (default: one per core)")
    p.add_argument(
        "--memory-limit",
        default="auto",
        help="per local worker, e.g. 4GB (default auto: memory / workers)",
    )
    p.add_argument("--scheduler", metavar="ADDRESS", help="use a running Dask cluster")
    p.add_argument(
        "--retries", type=int, default=3, help="reruns of a job whose worker died (default 3)"
    )
    p.add_argument("--quiet", action="store_true", help="no progress display")


@register_command(
    "batch",
    help="run tasks over many meshes in parallel on a Dask cluster (local by default); "
    "reruns skip finished meshes",
    example=_example,
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Run the batch; print the counts and the first failures."""
    import fvf.batch
    from fvf.batch import interrupts

    # In the command's own process a Ctrl-C after the first stays ignored until the
    # quiet-exit handler of fvf.cli.main takes over: no moment with the default handler.
    with interrupts.held(for_good=getattr(args, "own_process", False)):
        rows = fvf.batch.run(
            args.inputs,
            args.output,
            args.tasks,
            k=args.k,
            n=args.n,
            quads=args.quads,
            fallback=args.fallback,
            pairs=args.pairs,
            scheduler=args.scheduler,
            workers=args.workers,
            memory_limit=args.memory_limit,
            retries=args.retries,
            progress=not args.quiet,
            as_frame=False,
            command=args.command_line,
        )
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "skipped", "failed")}
    print(
        f"{len(rows)} jobs: {counts['ok']} ok, {counts['skipped']} skipped, "
        f"{counts['failed']} failed; summary in {Path(args.output) / 'summary.csv'}"
    )
    failed = [r for r in rows if r["status"] == "failed"]
    for r in failed[:20]:
        print(f"fvf: failed: {r['mesh']}: {r['error']}", file=sys.stderr)
    if len(failed) > 20:
        print(f"fvf: ... and {len(failed) - 20} more failed (summary.csv)", file=sys.stderr)
    return EXIT_PROBLEMS if failed else EXIT_OK
