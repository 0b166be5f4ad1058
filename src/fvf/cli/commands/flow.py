"""``fvf flow``: vertex functions flowed along a per-face field, f(t) = Phi_{v,t} f
(eq. 42, :func:`fvf.flow`)."""

from __future__ import annotations

import argparse

from ..common import (
    EXIT_OK,
    MERGE,
    MESH_FILE,
    PROGRESS,
    Sources,
    add_output,
    add_picture_options,
    check_outputs,
    data_output,
    integer,
    load_mesh,
    load_viz,
    picture_options,
    progress_option,
    real,
    real_or_inf,
    render_picture,
    times,
    write_results,
)
from ..registry import register_command

#: The options of ``fvf flow`` and the methods of :func:`fvf.flow` that take them.
_FLOW_OPTIONS = {
    "k": ("spectral",),
    "dt": ("cayley",),
    "growth_limit": ("chapter", "skew", "cayley"),
}


def _arguments(p: argparse.ArgumentParser) -> None:
    from fvf.flows.dispatch import METHODS

    p.add_argument("mesh", help=MESH_FILE)
    p.add_argument("data", nargs="*", help=".npz with keys f (n,)|(n,k), v (m,3) " + MERGE)
    p.add_argument("--t", nargs="+", metavar="T", help="times, e.g. --t 0 0.5 1 (or key t)")
    p.add_argument("--method", choices=METHODS, default="chapter", help="default: chapter")
    p.add_argument("--function", default="f", metavar="KEY", help="function key (default f)")
    p.add_argument("--field", default="v", metavar="KEY", help="field key (default v)")
    p.add_argument("--k", type=integer, help="eigenfunctions of --method spectral (default 50)")
    p.add_argument("--dt", type=real, help="step length of --method cayley")
    p.add_argument(
        "--growth-limit",
        type=real_or_inf,
        help="exit 6 above this norm growth (>= 1; default 100; inf: never)",
    )
    p.add_argument("--progress", action="store_true", help=PROGRESS)
    add_output(p, "output .npz (keys f_t (T,n)|(T,n,k)), or .ply/.vtp/.vtu")
    p.add_argument(
        "--png", help="also render f at the last time with the field (fvf.viz): .png, .pdf, .svg"
    )
    add_picture_options(p)


def _method_options(args: argparse.Namespace) -> dict:
    """The keyword arguments of :func:`fvf.flow` given as options; an option the method
    does not take is refused."""
    options = {}
    for name, methods in _FLOW_OPTIONS.items():
        if getattr(args, name) is None:
            continue
        if args.method not in methods:
            flag = "--" + name.replace("_", "-")
            raise ValueError(
                f"{flag} applies to --method {' or '.join(methods)}, not {args.method!r}"
            )
        options[name] = getattr(args, name)
    progress = progress_option(args)
    if args.method in ("chapter", "skew") and progress is not None:
        options["progress"] = progress
    return options


@register_command(
    "flow",
    help="flow vertex functions along a per-face field: f(t) = Phi_{v,t} f (eq. 42, fvf.flow)",
    example="fvf flow mesh.obj field.npz --t 0 0.5 1 --method upwind -o flowed.npz --png f.png",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Write f_t (and the picture of its last time with ``--png``)."""
    import numpy as np

    import fvf

    check_outputs(args, data_output(args), ("--png", args.png))
    viz = load_viz() if args.png else None
    mesh = load_mesh(args.mesh)
    src = Sources(args, mesh)
    v, f = src.field(args.field), src.functions(args.function)
    t = times(args, src.data)
    options = _method_options(args)
    f_t = fvf.flow(mesh, v, f, t, method=args.method, **options)  # (T, n) or (T, n, k)
    arrays = {"f": f, "v": v, "t": t, "f_t": f_t, "method": np.array(args.method)}
    write_results(args, args.output, arrays, mesh, src.paths)
    if viz is not None:
        last = f_t[-1] if f.ndim == 1 else f_t[-1, :, 0]
        title = f"flow ({args.method}) at t = {t[-1]:g}"
        options = picture_options(args)
        render_picture(viz, mesh, args.png, function=last, field=v, title=title, **options)
    return EXIT_OK
