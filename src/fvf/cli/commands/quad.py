"""``fvf quad``: a valid quad mesh along a cross field (:func:`fvf.quad_mesh`: every
component, retries, the validity gate) or a typed error and exit status 4, nothing written."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..common import (
    EXIT_OK,
    Sources,
    add_output,
    add_picture_options,
    check_outputs,
    checked_mesh,
    integer,
    load_viz,
    picture_options,
    unavailable,
)
from ..registry import register_command


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "mesh",
        help="triangle mesh (OBJ, OFF, PLY, STL; several parts and boundary loops allowed)",
    )
    p.add_argument("data", nargs="*", help=".npz data file(s) holding the --field key")
    p.add_argument("--faces", type=integer, required=True, metavar="N", help="target quads")
    p.add_argument(
        "--align",
        choices=("curvature", "smooth"),
        default="curvature",
        help="default cross field: curvature aligned (default) or smoothest",
    )
    p.add_argument(
        "--field",
        metavar="KEY",
        help="cross field (m,3), one representative per face: a key of DATA or FILE.npz:KEY",
    )
    p.add_argument(
        "--crease-angle",
        type=float,
        default=35.0,
        metavar="DEG",
        help="edges sharper than this dihedral angle are features the quads follow (35; "
        "0 turns feature detection off)",
    )
    p.add_argument(
        "--features",
        metavar="FILE",
        help='text file of feature edges, one "i j" vertex pair (0-based) per line',
    )
    p.add_argument(
        "--remesh",
        choices=("auto", "always", "never"),
        default="auto",
        help="remesh the input at the quad scale: when its triangles ask for it or an "
        "attempt failed (auto), always, or never",
    )
    p.add_argument(
        "--fallback",
        choices=("error", "split"),
        default="error",
        help="a part where every attempt fails: exit 4 with the error (default), or split "
        "its triangles into three quads each (valid quads that follow no field; said on "
        "stderr and in the quality line)",
    )
    add_output(p, "output quad mesh (.obj, .off, .ply, .vtu or .vtp)")
    p.add_argument("--uv", metavar="OBJ", help="also write the parameterized mesh with vt")
    p.add_argument("--png", help="also render the quad mesh (fvf.viz): .png, .pdf or .svg")
    add_picture_options(p)


def _stage_printer() -> Callable[[str, int, int], None]:
    """The ``progress`` of the parameterization: one line on stderr as each stage starts
    (and each round of the fold repair), with the seconds since now."""
    import time

    t0 = time.perf_counter()
    started: list[str] = []

    def progress(message: str, done: int, total: int) -> None:  # each stage as it starts
        if done == 0 or message not in started:  # and the fold repair's rounds
            started.append(message)
            print(f"fvf quad: {time.perf_counter() - t0:6.1f}s  {message}", file=sys.stderr)

    return progress


@register_command(
    "quad",
    help="quad mesh along a cross field: seamless parameterization and integer-grid "
    "extraction (fvf.quad_mesh)",
    example="fvf quad spot.obj --faces 2000 -o spot_quads.obj --uv spot_uv.obj\n"
    "  fvf quad spot.obj --faces 2000 --field cross.npz:v -o spot_quads.obj\n"
    "  (cross.npz: the v of `fvf design spot.obj --n 4 -o cross.npz`)",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Write the quad mesh (and the parameterized mesh, the picture); print its quality."""
    import fvf
    from fvf.io.inputfile import read_index_table
    from fvf.io.meshfile import check_writable, write_uv_mesh

    check_outputs(args, ("-o", args.output), ("--uv", args.uv), ("--png", args.png))
    check_writable(args.output, face_size=4)  # a format that holds quads, before the work
    mesh, new_index = _faces_only(args.mesh)
    field = Sources(args, mesh).field(args.field) if args.field else None
    features = None
    if args.features:
        features = read_index_table(args.features, 2, "feature edges", fvf.ParameterError)
        if new_index is not None:  # (feature edges join vertices of faces: all kept)
            features = new_index[features]
    made = fvf.quad_mesh(
        mesh,
        target_faces=args.faces,
        field=field,
        align=args.align,
        crease_angle=args.crease_angle if args.crease_angle > 0 else None,
        features=features,
        remesh=_REMESH[args.remesh],
        fallback=args.fallback,
        progress=_stage_printer(),
    )
    fvf.write_mesh(args.output, made.vertices, made.quads)
    print(f"wrote {args.output}: {made.summary()}")
    if args.uv and _write_uv(args.uv, made, write_uv_mesh):
        print(f"wrote {args.uv}: the parameterized triangle mesh (vt per corner)")
    elif args.uv:
        print(
            f"fvf quad: {args.uv} not written: every part was split from triangles "
            "(--fallback split), none has a parameterization",
            file=sys.stderr,
        )
    if args.png:
        viz = load_viz()
        Q = made.quads
        try:
            title = f"{Path(args.mesh).name}: {Q.shape[0]} quads"
            info = viz.render_quads(
                made.vertices, Q, args.png, title=title, **picture_options(args)
            )
        except ImportError as exc:
            raise unavailable(exc) from exc
        print(f"wrote {info.path}")
    return EXIT_OK


_REMESH: dict[str, bool | str] = {"auto": "auto", "always": True, "never": "never"}


def _faces_only(path: str) -> tuple[Any, Any]:
    """The mesh of ``path`` without the vertices that belong to no face (a quad mesh is
    made from the faces; scans keep such vertices, e.g. the Stanford bunny's 1,113), and
    the new index of every old vertex (int64 (n,), -1 for a dropped one; None when none
    was dropped). Faces of zero area (an exporter's T-junctions and collapsed slivers) are
    repaired by ``fvf repair``'s default steps (:func:`fvf.repair_mesh`). Said on stderr;
    every other problem is refused as ``checked_mesh`` does."""
    import fvf

    V, F = fvf.read_mesh(path)
    err = sys.stderr
    try:
        return checked_mesh(path, V, F), None
    except fvf.UnreferencedVertexError:
        fixed = fvf.remove_unreferenced_vertices(V, F)
        dropped = len(V) - fixed.vertices.shape[0]
        print(f"fvf quad: {dropped} vertices of {path} belong to no face: left out", file=err)
    except fvf.DegenerateFaceError:
        fixed = fvf.repair_mesh(V, F)  # its log names the faces
        print(
            f"fvf quad: {path}: faces have zero area; repaired as `fvf repair` does "
            f"({'; '.join(fixed.log) or 'nothing changed'}): the quads are made from the "
            "repaired surface",
            file=err,
        )
    return checked_mesh(path, fixed.vertices, fixed.faces), fixed.vertex_map


def _write_uv(path: str, made: Any, write_uv_mesh: Callable[..., None]) -> bool:
    """The triangle meshes the parameterizations live on, one file (components side by
    side, each in its own uv chart); False (nothing written) when no component has one."""
    import numpy as np

    Vs, Fs, uvs, offset = [], [], [], 0
    for surface, param in zip(made.surfaces, made.parameterizations, strict=True):
        if param is None:  # split from triangles (--fallback split): no uv
            continue
        Vs.append(surface.vertices)
        Fs.append(surface.faces + offset)
        uvs.append(param.uv)
        offset += surface.n_vertices
    if not Vs:
        return False
    write_uv_mesh(path, np.concatenate(Vs), np.concatenate(Fs), np.concatenate(uvs))
    return True
