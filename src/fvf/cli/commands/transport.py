"""``fvf transport``: a field u transported along v, Ad_{Phi_{v,t}} u (eq. 67,
:class:`fvf.FieldTransport`), or interpolated to u1 (eq. 68, :func:`fvf.interpolate`)."""

from __future__ import annotations

import argparse

from ..common import (
    EXIT_OK,
    MERGE,
    MESH_FILE,
    PROGRESS,
    Sources,
    add_output,
    check_outputs,
    data_output,
    load_mesh,
    progress_option,
    real_or_inf,
    times,
    write_results,
)
from ..registry import register_command


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("mesh", help=MESH_FILE)
    p.add_argument("data", nargs="*", help=".npz with keys v, u (m,3) [, u1] " + MERGE)
    p.add_argument("--t", nargs="+", metavar="T", help="times (interpolation: in [0, 1])")
    p.add_argument("--field", default="v", metavar="KEY", help="flowing field key (default v)")
    p.add_argument("--transported", default="u", metavar="KEY", help="moved field (default u)")
    p.add_argument("--to", metavar="KEY", help="end field: interpolate (default u1 if present)")
    p.add_argument(
        "--growth-limit",
        type=real_or_inf,
        help="exit 6 above this L2 growth (>= 1; default 100; inf: never)",
    )
    p.add_argument("--progress", action="store_true", help=PROGRESS)
    add_output(p, "output .npz (key u_t (T,m,3))")


@register_command(
    "transport",
    help="transport a field u along v, Ad_{Phi_{v,t}} u (eq. 67), or interpolate u to u1 (68)",
    example="fvf transport mesh.obj fields.npz --t 0 0.25 0.5 -o moved.npz   (keys v, u [, u1])",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Write u_t: transported (mode Ad) or interpolated (mode interpolate)."""
    import numpy as np

    import fvf

    check_outputs(args, data_output(args))
    mesh = load_mesh(args.mesh)
    src = Sources(args, mesh)
    v, u = src.field(args.field), src.field(args.transported)
    t = times(args, src.data)
    growth = {} if args.growth_limit is None else {"growth_limit": args.growth_limit}
    arrays = {"v": v, "u": u, "t": t}
    if args.to is not None or src.has("u1"):
        u1 = src.field(args.to or "u1")
        u_t = fvf.interpolate(mesh, v, u, u1, t, **growth)
        arrays.update(u1=u1, u_t=u_t, mode=np.array("interpolate"))
    else:
        progress = progress_option(args)
        if progress is not None:
            growth["progress"] = progress
        result = fvf.FieldTransport(mesh, v, **growth)(u, t)  # = fvf.Ad(mesh, v, u, t), eq. 67
        arrays.update(u_t=result.fields, normal_part=result.normal_part, mode=np.array("Ad"))
    write_results(args, args.output, arrays, mesh, src.paths)
    return EXIT_OK
