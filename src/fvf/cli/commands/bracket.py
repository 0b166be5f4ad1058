"""``fvf bracket``: the Lie bracket of two per-face fields: the commutator field
D^F_[v,w] X (eq. 54), its norm, and both brackets applied to functions (eqs. 46, 54)."""

from __future__ import annotations

import argparse

from ..common import (
    EXIT_OK,
    MERGE,
    MESH_FILE,
    Sources,
    add_output,
    check_outputs,
    data_output,
    load_mesh,
    write_results,
)
from ..registry import register_command


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("mesh", help=MESH_FILE)
    p.add_argument("data", nargs="*", help=".npz with keys v, u (m,3) [, f] " + MERGE)
    p.add_argument("--first", default="v", metavar="KEY", help="first field key (default v)")
    p.add_argument("--second", default="u", metavar="KEY", help="second field key (default u)")
    p.add_argument("--function", metavar="KEY", help="functions to apply both brackets to")
    add_output(p, "output .npz")


@register_command(
    "bracket",
    help="Lie bracket of two per-face fields: commutator field D^F_[v,w] X and its norm",
    example="fvf bracket mesh.obj fields.npz -o bracket.npz   (fields.npz: v, u; optional f)",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Write the commutator field, its norm and the brackets of the functions."""
    import fvf

    check_outputs(args, data_output(args))
    mesh = load_mesh(args.mesh)
    src = Sources(args, mesh)
    v, w = src.field(args.first), src.field(args.second)
    commutator = fvf.commutator_field(mesh, v, w)  # (n, 3), eq. 54 applied to X
    arrays = {
        "v": v,
        "u": w,
        "commutator": commutator,
        # I_F^V per coordinate, projected onto the faces (for drawing as arrows)
        "commutator_face": mesh.project_tangent(fvf.vertex_to_face(mesh) @ commutator),
        "bracket_norm": fvf.bracket_norm(mesh, v, w, where="vertex"),
        "bracket_norm_face": fvf.bracket_norm(mesh, v, w, where="face"),
    }
    if args.function is not None or src.has("f"):
        f = src.functions(args.function or "f")
        arrays["f"] = f
        arrays["bracket_F_f"] = fvf.bracket_F(mesh, v, w) @ f  # eq. 54, shape of f
        arrays["bracket_V_f"] = fvf.bracket_V(mesh, v, w) @ f  # eq. 46
    write_results(args, args.output, arrays, mesh, src.paths)
    return EXIT_OK
