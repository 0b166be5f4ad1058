"""``fvf render``: a PNG of a mesh with a function, a field and singularities
(:func:`fvf.viz.render`); a pure-quad mesh file is drawn with its wireframe and irregular
vertices (:func:`fvf.viz.render_quads`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ...io.picturefile import picture_format
from ..common import (
    EXIT_OK,
    add_display_options,
    add_output,
    add_picture_options,
    check_outputs,
    display_arrays,
    integer,
    load_mesh,
    load_viz,
    picture_options,
    real,
    render_picture,
    unavailable,
)
from ..registry import register_command


def _quad_file(path: str) -> tuple[Any, Any] | None:
    """(V, Q) when the mesh file holds only quads, else None."""
    from fvf.errors import MeshReadError
    from fvf.io.meshfile import read_quad_mesh

    try:
        return read_quad_mesh(path)
    except MeshReadError as exc:
        if "non-quads" in str(exc):
            return None
        raise


def _arguments(p: argparse.ArgumentParser) -> None:
    add_display_options(p)
    add_output(p, "output picture: .png, .pdf or .svg")
    p.add_argument("--cmap", help="matplotlib colormap name (default viridis)")
    p.add_argument("--clim", nargs=2, type=real, metavar=("LO", "HI"), help="color range")
    p.add_argument("--arrow-scale", type=real, help="arrow length per unit field (absolute)")
    add_picture_options(p)
    p.add_argument("--title", help="picture title")
    p.add_argument("--max-arrows", type=integer, help="at most about this many arrows per view")
    p.add_argument(
        "--arrow-spacing", type=real, help="pixels between arrows (default: 1/22 of the view)"
    )
    p.add_argument("--backend", help="auto (default), polyscope-egl or matplotlib")


@register_command(
    "render",
    help="render a mesh with a function, a field and singularities to PNG, PDF or SVG "
    "(fvf.viz); a "
    "pure-quad mesh is drawn with its wireframe and irregular vertices by valence",
    example="fvf render mesh.obj designed.npz --field v --singularities -o field.png",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Write the PNG."""
    check_outputs(args, ("-o", args.output))
    picture_format(args.output)
    if args.title is None:  # named after what is drawn: the mesh file (and the data file)
        names = [Path(args.mesh).name] + [Path(d).name for d in args.data or []]
        args.title = ", ".join(names)
    viz = load_viz()
    quads = None if args.data else _quad_file(args.mesh)
    if quads is not None:  # a quad mesh: shading, wireframe, irregular vertices by valence
        kwargs = {n: getattr(args, n) for n in ("title", "backend") if getattr(args, n)}
        kwargs.update(picture_options(args))
        try:
            info = viz.render_quads(*quads, args.output, **kwargs)
        except ImportError as exc:
            raise unavailable(exc) from exc
        print(f"wrote {info.path} (backend: {info.backend})")
        return EXIT_OK
    mesh = load_mesh(args.mesh)
    kwargs, _ = display_arrays(args, mesh)
    for name in ("arrow_scale", "cmap", "title", "backend", "max_arrows", "arrow_spacing"):
        if getattr(args, name) is not None:
            kwargs[name] = getattr(args, name)
    kwargs.update(picture_options(args))
    if args.clim is not None:
        kwargs["clim"] = tuple(args.clim)
    render_picture(viz, mesh, args.output, **kwargs)
    return EXIT_OK
