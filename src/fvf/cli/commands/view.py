"""``fvf view``: polyscope's interactive window on a mesh, a function, a field and
singularities (:func:`fvf.viz.view`; needs a display)."""

from __future__ import annotations

import argparse

from ..common import EXIT_OK, add_display_options, display_arrays, load_mesh, load_viz, unavailable
from ..registry import register_command


@register_command(
    "view",
    help="open an interactive polyscope window (needs a display)",
    example="fvf view mesh.obj flowed.npz --function f_t[2] --field v",
    arguments=add_display_options,
)
def run(args: argparse.Namespace) -> int:
    """Open the window; return when it is closed."""
    viz = load_viz()
    mesh = load_mesh(args.mesh)
    kwargs, _ = display_arrays(args, mesh)
    try:
        viz.view(mesh, **kwargs)
    except (ImportError, viz.NoDisplayError) as exc:
        raise unavailable(exc) from exc
    return EXIT_OK
