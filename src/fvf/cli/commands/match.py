"""``fvf match``: a vertex correspondence between two near-isometric shapes
(:func:`fvf.match`), with geodesic errors against a ground truth
(:func:`fvf.geodesic_errors`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from ..common import (
    EXIT_OK,
    MESH_FORMATS,
    PROGRESS,
    add_output,
    add_picture_options,
    check_outputs,
    data_output,
    derived_picture,
    load_viz,
    match_pictures,
    picture_options,
    progress_option,
    save_npz,
)
from ..registry import register_command

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy as np

    from fvf.spectral.candidates import MapCandidate


def _read_landmarks(path: str) -> np.ndarray:
    """Landmark pairs from a text file: one line "i1 i2" per landmark (vertex of the first
    mesh, vertex of the second), '#' comments allowed; int64 (q, 2)."""
    from fvf.errors import LandmarkError
    from fvf.io.inputfile import read_index_table

    return read_index_table(path, 2, "landmarks", LandmarkError)


def _read_truth(args: argparse.Namespace) -> np.ndarray | None:
    """The ground truth of ``--truth``, checked against the meshes before the match:
    int64 (n_2,) of vertices of mesh 1 (or ``--truth-missing``)."""
    import numpy as np

    import fvf
    from fvf.errors import CorrespondenceError
    from fvf.io.inputfile import read_index_table

    if not args.truth:
        return None
    truth = read_index_table(args.truth, 1, "the ground truth", CorrespondenceError)
    n_1, n_2 = (len(fvf.read_mesh(p)[0]) for p in (args.mesh_1, args.mesh_2))
    bad = (truth < 0) | (truth >= n_1)
    if args.truth_missing is not None:
        bad &= truth != args.truth_missing
    if truth.shape != (n_2,) or bad.any():
        first = f"; line {np.flatnonzero(bad)[0] + 1} is {truth[bad][0]}" if bad.any() else ""
        raise CorrespondenceError(
            f"{args.truth}: the ground truth needs {n_2} lines (one per vertex of "
            f"{args.mesh_2}), each a vertex of {args.mesh_1} in [0, {n_1}) or the "
            f"--truth-missing value; it has {truth.size}{first}"
        )
    if args.truth_missing is None and truth.size:  # a placeholder the user did not name
        values, counts = np.unique(truth, return_counts=True)
        top = int(np.argmax(counts))
        if counts[top] > max(0.05 * truth.size, 10):
            print(
                f"fvf match: {counts[top]} of the {truth.size} rows of {args.truth} are "
                f"{values[top]}: if that marks vertices without a ground truth (the shared "
                f"camel files use 0), pass --truth-missing {values[top]}, or they count as "
                "errors",
                file=sys.stderr,
            )
    return truth


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("mesh_1", help=f"first mesh ({MESH_FORMATS}): the map lands on it")
    p.add_argument("mesh_2", help="second mesh: the map has one entry per vertex of it")
    p.add_argument("--k", type=int, default=200, help="final functional map size (200)")
    p.add_argument("--k-fit", type=int, default=15, help="fitted map size (15)")
    p.add_argument("--progress", action="store_true", help=PROGRESS)
    p.add_argument("--landmarks", help='text file, one "i1 i2" pair of vertex indices per line')
    p.add_argument("--truth", help="ground-truth p2p_21 (one integer per line): report errors")
    p.add_argument("--truth-missing", type=int, help="value marking vertices without truth")
    add_output(p, "output .npz (keys p2p_21, C_12)")
    p.add_argument(
        "--png",
        metavar="NAME",
        help="also write the transferred colours to NAME (.png, .pdf or .svg) and, with "
        "--truth, the error map to NAME_errors with the same suffix",
    )
    add_picture_options(p)


@register_command(
    "match",
    help="vertex correspondence between two near-isometric shapes (fvf.match: functional "
    "maps with the orientation term, ZoomOut)",
    example="fvf match A.off B.off -o map.npz --k 200 [--landmarks l.txt] [--png map.png]\n"
    "  (map.npz: p2p_21 (n_B,) = vertex of A for each vertex of B, C_12 (k,k))",
    arguments=_arguments,
)
def run(args: argparse.Namespace) -> int:
    """Write the map (and its errors against ``--truth``, the pictures)."""
    import numpy as np

    import fvf

    errors_png = derived_picture(args.png, "errors") if args.png and args.truth else None
    check_outputs(args, data_output(args), ("--png", args.png), ("--png", errors_png))
    landmarks = _read_landmarks(args.landmarks) if args.landmarks else None
    truth = _read_truth(args)
    result = fvf.match_result(
        args.mesh_1,
        args.mesh_2,
        k=args.k,
        k_fit=args.k_fit,
        landmarks=landmarks,
        progress=progress_option(args),
    )
    arrays = {
        "p2p_21": result.p2p_21,
        "C_12": result.C_12,
        "mesh_1_path": np.array(str(Path(args.mesh_1).resolve())),
        "mesh_2_path": np.array(str(Path(args.mesh_2).resolve())),
        "command": np.array(args.command_line),
    }
    if truth is not None:
        valid = truth != args.truth_missing if args.truth_missing is not None else None
        p1 = result.prepared_1
        known = truth if valid is None else np.where(valid, truth, 0)
        err = fvf.geodesic_errors(p1.mesh, p1.input_to_mesh[result.p2p_21], p1.input_to_mesh[known])
        if valid is not None:
            err = np.where(valid, err, np.nan)
        arrays["errors"] = err
        if np.isnan(err).all():
            print("no vertex has a ground truth (all are --truth-missing): no mean error")
        else:
            print(f"mean geodesic error / sqrt(area): {np.nanmean(err):.4f}")
    save_npz(args.output, arrays)
    times = ", ".join(f"{k} {v:.1f} s" for k, v in result.timings.items())
    print(f"matched {result.p2p_21.size} vertices ({times})")
    if result.confidence is not None:
        print(_choice_line(result.alternatives, result.confidence))
    if args.png:
        names = (Path(args.mesh_1).name, Path(args.mesh_2).name)
        if Path(args.mesh_1).resolve() == Path(args.mesh_2).resolve():
            names = (names[0], f"{names[1]} (self-map)")
        options = picture_options(args)
        match_pictures(result, args.png, result.prepared_2, names, options)
        if errors_png is not None:
            p2 = result.prepared_2
            e = arrays["errors"][p2.mesh_to_input]  # NaN: no ground truth, drawn grey
            load_viz().render_error_map(
                p2.mesh,
                e,
                errors_png,
                title=f"geodesic error / sqrt(area) on {names[1]}",
                **options,
            )
            print(f"wrote {errors_png}")
    return EXIT_OK


def _choice_line(alternatives: Sequence[MapCandidate], confidence: float) -> str:
    """One line on the candidate map chosen and how sure the choice is."""
    chosen = next(c.name for c in alternatives if c.chosen)
    others = [c.name for c in alternatives if not c.chosen]
    if not others:
        return f"chosen: {chosen} (every candidate refined into the same map)"
    return (
        f"chosen: {chosen} of {len(alternatives)} distinct candidate maps, confidence "
        f"{confidence:.2f} (1 - its energy / the runner-up's, {others[0]}; near 0: "
        "about as good, --landmarks decide)"
    )
