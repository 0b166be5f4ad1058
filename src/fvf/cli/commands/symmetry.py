"""``fvf symmetry``: the left-right intrinsic symmetry of a shape
(:func:`fvf.symmetry_map`, orientation-reversing), for symmetric field design."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..common import (
    EXIT_OK,
    MESH_FILE,
    PROGRESS,
    add_output,
    add_picture_options,
    check_outputs,
    data_output,
    match_pictures,
    picture_options,
    progress_option,
    save_npz,
)
from ..registry import register_command


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("mesh", help=MESH_FILE)
    p.add_argument("--k", type=int, default=100, help="functional map size (100)")
    p.add_argument("--k-fit", type=int, default=15, help="fitted map size (15)")
    p.add_argument("--progress", action="store_true", help=PROGRESS)
    add_output(p, "output .npz")
    p.add_argument(
        "--png",
        metavar="NAME",
        help="also write NAME (.png, .pdf or .svg): the mesh and its colours mirrored",
    )
    add_picture_options(p)


@register_command(
    "symmetry",
    help="left-right intrinsic symmetry of a shape (fvf.symmetry_map, orientation-reversing)",
    example="fvf symmetry A.off -o sym.npz [--png sym.png]\n"
    "  (sym.npz: p2p (n,), C (k,k) and the basis, for fvf.map_consistent_field)",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Write the self-map and its basis (and the picture); print how involutive it is."""
    import numpy as np

    import fvf

    check_outputs(args, data_output(args), ("--png", args.png))
    result = fvf.symmetry_map(args.mesh, k=args.k, k_fit=args.k_fit, progress=progress_option(args))
    p = result.prepared_1
    arrays = {
        "p2p": result.p2p,
        "C": result.C,
        "eigenvalues": result.basis.eigenvalues,
        "eigenvectors": result.basis.eigenvectors,
        "vertices": p.mesh.vertices,
        "faces": p.mesh.faces,
        "mesh_path": np.array(str(Path(args.mesh).resolve())),
        "command": np.array(args.command_line),
    }
    save_npz(args.output, arrays)
    involution = float(np.mean(result.p2p[result.p2p] == np.arange(result.p2p.size)))
    print(f"symmetry map: {involution:.1%} of the vertices are fixed by applying it twice")
    if args.png:
        name = Path(args.mesh).name
        names = (name, f"{name} mirrored")
        match_pictures(result, args.png, result.prepared_2, names, picture_options(args))
    return EXIT_OK
