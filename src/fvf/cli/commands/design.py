"""``fvf design``: the smoothest tangent field meeting direction constraints
(:func:`fvf.design_field`), and its singularities (:func:`fvf.singularities`)."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from ..common import (
    EXIT_OK,
    MESH_FILE,
    PROGRESS,
    add_output,
    check_outputs,
    data_output,
    integer,
    load_data,
    load_mesh,
    progress_option,
    real,
    write_results,
)
from ..registry import register_command

if TYPE_CHECKING:
    from ...mesh.trimesh import TriMesh


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("mesh", help=MESH_FILE)
    p.add_argument("--constraints", help=".npz with constraint_faces|points, directions")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument(
        "--soft",
        type=real,
        metavar="W",
        help="soft weight of every constraint, per unit area (1/length^2: scale the mesh "
        "by s, scale W by 1/s^2); default: 100 times each face's own stiffness, scale-free",
    )
    mode.add_argument("--hard", action="store_true", help="meet the constraints exactly")
    p.add_argument("--kind", choices=("knoppel", "singer_wu"), default="knoppel")
    p.add_argument("--keep-length", action="store_true", help="don't normalize directions")
    p.add_argument(
        "--n", type=integer, default=1, help="directions per face: 1 vector, 2 line, 4 cross, 6 …"
    )
    p.add_argument(
        "--align", choices=("curvature",), help="align to principal curvature directions (even n)"
    )
    p.add_argument("--align-strength", type=real, metavar="B", help="alignment weight (1)")
    p.add_argument(
        "--curvature-smoothing",
        type=real,
        metavar="L",
        help="design with the angle defect smoothed over length L (mesh units), so that "
        "spikes of a scan do not each force a cone (closed meshes)",
    )
    p.add_argument("--progress", action="store_true", help=PROGRESS)
    add_output(p, "output .npz (keys v, n, singularity_*)")


def _constraints(args: argparse.Namespace, mesh: TriMesh, arrays: dict, kwargs: dict) -> None:
    """Read ``--constraints`` into the keyword arguments of :func:`fvf.design_field` and
    the arrays to write (faces or points, directions, weights)."""
    import fvf

    c = load_data(args.constraints, mesh)
    k = None
    if "points" in c:
        kwargs["points"] = arrays["points"] = c.numbers("points", (None, 3))
        k = arrays["points"].shape[0]
    else:
        kwargs["faces"] = arrays["constraint_faces"] = c.integers("constraint_faces", (None,))
        k = arrays["constraint_faces"].shape[0]
        if "barycentric" in c:
            arrays["barycentric"] = c.numbers("barycentric", (k, 3))
            arrays["points"] = fvf.locate_points(mesh, kwargs["faces"], arrays["barycentric"])[1]
    kwargs["directions"] = arrays["directions"] = c.numbers("directions", (k, 3))
    if "weights" in c:
        w = c["weights"]
        kwargs["weights"] = arrays["weights"] = c.numbers("weights", (k,) if w.ndim else ())


@register_command(
    "design",
    help="smoothest tangent field meeting direction constraints (fvf.design_field), "
    "and its singularities",
    example="fvf design mesh.obj --constraints c.npz --soft 50 -o designed.npz\n"
    "  (c.npz: constraint_faces (k,) int or points (k,3), directions (k,3))\n"
    "fvf design mesh.obj --n 4 --align curvature -o cross.npz",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Write the designed field and its singularities; print their indices."""
    import numpy as np

    import fvf

    check_outputs(args, data_output(args))
    mesh = load_mesh(args.mesh)
    arrays: dict[str, Any] = {}
    inputs: list[str] = []
    kwargs: dict[str, Any] = {"hard": args.hard, "kind": args.kind}
    kwargs["normalize"] = not args.keep_length
    if args.constraints is not None:
        inputs.append(args.constraints)
        _constraints(args, mesh, arrays, kwargs)
    if args.soft is not None:
        kwargs["weights"] = arrays["weights"] = np.asarray(args.soft, dtype=float)
    n = args.n
    kwargs.update(n=n, progress=progress_option(args), curvature_smoothing=args.curvature_smoothing)
    if args.align is not None:
        kwargs["align"] = args.align
        if args.align_strength is not None:
            kwargs["align_strength"] = args.align_strength
    v = fvf.design_field(mesh, **kwargs)
    ids, index = fvf.singularities(mesh, v, n=n, zero="fill")
    arrays.update(
        v=v,
        singularity_vertices=ids,
        singularity_indices=index,
        singularity_positions=fvf.singularity_positions(mesh, ids, "vertex"),
    )
    if n != 1:
        arrays["n"] = np.asarray(n, dtype=float)
    write_results(args, args.output, arrays, mesh, inputs)
    shown = [str(x) for x in index.tolist()[:20]]
    print(f"singularities: {ids.size} (indices {', '.join(shown)})")
    return EXIT_OK
