"""``fvf repair``: a repaired mesh (:func:`fvf.repair_mesh`) and the index maps beside it."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..common import EXIT_OK, MESH_FILE, add_output, check_output_places, check_outputs, real
from ..registry import register_command


def _maps_path(output: str) -> Path:
    """Where the index maps of the repaired mesh ``output`` go: ``<stem>.maps.npz``."""
    out = Path(output)
    return out.with_name(out.stem + ".maps.npz")


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("mesh", help=MESH_FILE)
    p.add_argument(
        "--tol", type=real, default=0.0, help="weld vertices closer than this (default 0)"
    )
    p.add_argument(
        "--despike",
        action="store_true",
        help="also move a scan's spike vertices (standing far above the ring of their "
        "neighbours) to their rings' centroids (fvf.flatten_spikes; changes the geometry)",
    )
    add_output(p, "repaired mesh (.obj, .off, .ply); the maps go to <stem>.maps.npz beside it")


def cli_repair_steps() -> tuple[str, ...]:
    """The steps of ``fvf repair``: :data:`fvf.DEFAULT_REPAIR_STEPS` with non-manifold
    edges split too, before the vertices (what ``fvf info`` proposes for them)."""
    from fvf.mesh.repair import DEFAULT_REPAIR_STEPS

    steps: list[str] = []
    for name in DEFAULT_REPAIR_STEPS:
        if name == "split_nonmanifold_vertices":
            steps.append("split_nonmanifold_edges")
        steps.append(name)
    return tuple(steps)


@register_command(
    "repair",
    help="repair a mesh (fvf.repair_mesh): weld, drop unreferenced vertices, degenerate and "
    "duplicate faces, split non-manifold edges and vertices, orient; writes the index maps",
    example="fvf repair scan.obj -o scan_fixed.obj   (maps: scan_fixed.maps.npz; "
    "--despike for a scan's spikes)",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Write the repaired mesh and its index maps; print the repair log."""
    import numpy as np

    import fvf
    from fvf.io.atomic import atomic_path

    out, maps = Path(args.output), _maps_path(args.output)
    check_outputs(args, ("-o", str(out)), ("the index maps", str(maps)))
    check_output_places(out, maps)
    fvf.io.check_writable(out)
    V, F = fvf.read_mesh(args.mesh)
    steps = cli_repair_steps() + (("flatten_spikes",) if args.despike else ())
    result = fvf.repair_mesh(V, F, steps, tol=args.tol)
    mesh = result.mesh  # the repaired mesh must be valid (else: what is left, status 2)
    # the maps are written to their temporary file first and renamed last: a failure of
    # either file leaves both outputs as they were
    with atomic_path(maps) as tmp:
        np.savez(
            tmp,
            vertex_origin=result.vertex_origin,
            vertex_map=result.vertex_map,
            face_origin=result.face_origin,
            face_map=result.face_map,
            flipped=result.flipped,
            log=np.array(list(result.log) or ["nothing to repair"]),
            mesh_path=np.array(str(Path(args.mesh).resolve())),
            command=np.array(args.command_line),
        )
        fvf.write_mesh(out, mesh.vertices, mesh.faces)
    for line in result.log or ("nothing to repair",):
        print(f"  {line}")
    print(
        f"wrote {out} ({mesh.n_vertices} vertices, {mesh.n_faces} faces) and {maps} "
        "(vertex_origin, vertex_map, face_origin, face_map, flipped: old <-> new indices)"
    )
    return EXIT_OK
