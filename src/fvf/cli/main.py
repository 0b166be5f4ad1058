"""The ``fvf`` command: the chapter's operations on your meshes, from the shell.

It contains no math: every number comes from a library call. Meshes are OBJ, OFF or PLY
files; functions and fields are read from and written to ``.npz`` data files whose keys
are documented in :mod:`fvf.fieldio` and ``docs/cli.md`` (``f`` vertex functions, ``v``
and ``u`` per-face fields, ``t`` times, ...).

Exit status: 0 success; 1 ``fvf info`` found problems in the mesh; 2 bad input (a missing
or unreadable file, an invalid mesh, wrong data keys or shapes, bad options); 3 a feature
unavailable here (``fvf.viz`` or its ``[viz]`` extra missing, no display for ``view``);
4 the computation failed (e.g. a flow overflowed). Errors are one line on stderr,
``fvf: error: <cause>``; ``--debug`` shows the traceback instead. Warnings (fvf's
:class:`~fvf.errors.FvfWarning`) are one line each, ``fvf: warning: <cause>``.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import warnings
from pathlib import Path
from typing import NoReturn

__all__ = ["main", "EXIT_OK", "EXIT_PROBLEMS", "EXIT_BAD_INPUT", "EXIT_UNAVAILABLE", "EXIT_FAILED"]

EXIT_OK = 0
#: ``fvf info`` found problems in the mesh.
EXIT_PROBLEMS = 1
#: Bad input: missing or unreadable file, invalid mesh, wrong data keys or shapes, options.
EXIT_BAD_INPUT = 2
#: The feature is not available here (fvf.viz or its extra missing, no display).
EXIT_UNAVAILABLE = 3
#: The computation failed (e.g. a flow overflowed to inf).
EXIT_FAILED = 4

_EXIT_TEXT = """exit status: 0 success, 1 `fvf info` found problems, 2 bad input,
3 feature unavailable (fvf.viz / [viz] extra / display), 4 computation failed.
Data files: .npz with keys f (n,)|(k,n), v (m,3), u (m,3), u1 (m,3), t (T,); see docs/cli.md."""


_DEBUG = "show the traceback of an error instead of one line"
_MERGE = "(or PLY properties); several files: a later one's keys replace an earlier one's"


def _version() -> str:
    from fvf import __version__

    return __version__


class Unavailable(RuntimeError):
    """A feature the command needs is not available on this machine."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit status 2)."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


# ---------------------------------------------------------------------------- helpers
def _load_mesh(path: str):
    """The TriMesh of a mesh file; an invalid mesh's error points to ``fvf info``."""
    import fvf

    V, F = fvf.read_mesh(path)
    try:
        return fvf.TriMesh(V, F)
    except fvf.MeshError as exc:
        raise type(exc)(f"{path}: {exc} (`fvf info {path}` lists every problem)") from exc


def _load_data(paths: str | list[str], mesh):
    """One data file, or several merged (a later file's key replaces an earlier's)."""
    from fvf.io.datafile import DataFile, read_data

    if isinstance(paths, str):
        return read_data(paths, mesh)
    files = [read_data(p, mesh) for p in paths]
    return files[0] if len(files) == 1 else DataFile.merged(files)


def _times(args, data):
    """The times of ``--t``, else the data file's ``t``: float64 (T,)."""
    import numpy as np

    if args.t:
        try:
            values = [float(x) for item in args.t for x in item.split(",") if x.strip()]
        except ValueError:
            values = []
        if not values or not np.isfinite(values).all():
            raise ValueError(
                f"--t needs finite numbers (e.g. --t 0 0.5 1); got {' '.join(args.t)!r}"
            )
        return np.array(values)
    if data is not None and "t" in data:
        return data.times("t")
    raise ValueError("give the times with --t (e.g. --t 0 0.5 1) or store them as key 't'")


def _viz():
    """fvf.viz, or Unavailable with the reason and the fix."""
    try:
        from fvf import viz
    except ImportError as exc:
        raise Unavailable(
            f"rendering needs fvf.viz and the [viz] extra (pip install 'fvf[viz]'): {exc}"
        ) from exc
    if not hasattr(viz, "render"):
        raise Unavailable("this fvf.viz has no render(); update fvf (pip install -U 'fvf[viz]')")
    return viz


def _write(args, out, arrays, mesh, inputs=()):
    import numpy as np

    from fvf.io.datafile import write_data

    for key, a in arrays.items():  # never write a result that overflowed
        if a.dtype.kind in "fc" and not np.isfinite(a).all():
            raise FloatingPointError(
                f"the result {key!r} {a.shape} has NaN or inf values: the computation "
                "overflowed (try shorter times, a smaller field or --method upwind); "
                "nothing was written"
            )

    path = write_data(
        out, arrays, mesh=mesh, mesh_path=args.mesh, command=args.command_line, inputs=inputs
    )
    shapes = ", ".join(f"{k} {tuple(v.shape)}" for k, v in arrays.items() if v.ndim)
    print(f"wrote {path}: {shapes}")
    return path


def _render(viz, mesh, path, **kwargs):
    try:
        info = viz.render(mesh, path, **kwargs)
    except ImportError as exc:  # fvf.viz.MissingExtraError
        raise Unavailable(" ".join(str(exc).split())) from exc
    backend = getattr(info, "backend", None)
    fallback = getattr(info, "fallback", None)
    print(
        f"wrote {path}"
        + (f" (backend: {backend})" if backend else "")
        + (f"; fell back because {fallback}" if fallback else "")
    )
    return info


# ---------------------------------------------------------------------------- commands
def info(path: str, as_json: bool = False) -> dict:
    """Print a validation report of a mesh file (every problem, with indices and fixes)."""
    import fvf
    from fvf.mesh.diagnostics import mesh_report

    report = mesh_report(*fvf.read_mesh(path))
    if as_json:
        print(json.dumps({"path": str(path), **report}, indent=2, default=str))
        return report
    print(f"{path}:")
    for key, val in report.items():
        if key not in ("problems", "hints"):
            print(f"  {key}: {val}")
    for hint in report.get("hints", []):
        print(f"  hint: {hint}")
    for problem in report["problems"]:
        print(f"  problem: {problem}")
    if not report["problems"]:
        print("  no problems found")
    return report


def _cmd_info(args) -> int:
    report = info(args.mesh, args.json)
    return EXIT_OK if not report["problems"] else EXIT_PROBLEMS


def _cmd_demo(args) -> int:
    from fvf.cli.demo import demo

    demo(args.mesh, Path(args.out))
    return EXIT_OK


#: The options of ``fvf flow`` and the methods of :func:`fvf.flow` that take them.
_FLOW_OPTIONS = {
    "k": ("spectral",),
    "dt": ("cayley",),
    "growth_limit": ("chapter", "skew", "cayley"),
}


def _cmd_flow(args) -> int:
    import fvf

    viz = _viz() if args.png else None
    mesh = _load_mesh(args.mesh)
    data = _load_data(args.data, mesh)
    v, f = data.field(args.field, mesh), data.functions(args.function, mesh)
    t = _times(args, data)
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
    f_t = fvf.flow(mesh, v, f.T, t, method=args.method, **options)  # (T, n) or (T, n, k)
    f_t = f_t if f.ndim == 1 else f_t.transpose(0, 2, 1)  # (T, k, n): rows are functions
    arrays = {"f": f, "v": v, "t": t, "f_t": f_t, "method": _str(args.method)}
    _write(args, args.output, arrays, mesh, args.data)
    if viz is not None:
        last = f_t[-1] if f.ndim == 1 else f_t[-1, 0]
        title = f"flow ({args.method}) at t = {t[-1]:g}"
        _render(viz, mesh, args.png, function=last, field=v, title=title)
    return EXIT_OK


def _cmd_bracket(args) -> int:
    import fvf

    mesh = _load_mesh(args.mesh)
    data = _load_data(args.data, mesh)
    v, w = data.field(args.first, mesh), data.field(args.second, mesh)
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
    if args.function is not None or "f" in data:
        f = data.functions(args.function or "f", mesh)
        arrays["f"] = f
        arrays["bracket_F_f"] = (fvf.bracket_F(mesh, v, w) @ f.T).T  # eq. 54
        arrays["bracket_V_f"] = (fvf.bracket_V(mesh, v, w) @ f.T).T  # eq. 46
    _write(args, args.output, arrays, mesh, args.data)
    return EXIT_OK


def _cmd_transport(args) -> int:
    import fvf

    mesh = _load_mesh(args.mesh)
    data = _load_data(args.data, mesh)
    v, u = data.field(args.field, mesh), data.field(args.transported, mesh)
    t = _times(args, data)
    arrays = {"v": v, "u": u, "t": t}
    if args.to is not None or "u1" in data:
        u1 = data.field(args.to or "u1", mesh)
        arrays.update(u1=u1, u_t=fvf.interpolate(mesh, v, u, u1, t), mode=_str("interpolate"))
    else:
        result = fvf.FieldTransport(mesh, v)(u, t)  # = fvf.Ad(mesh, v, u, t), eq. 67
        arrays.update(u_t=result.fields, normal_part=result.normal_part, mode=_str("Ad"))
    _write(args, args.output, arrays, mesh, args.data)
    return EXIT_OK


def _cmd_design(args) -> int:
    import fvf

    mesh = _load_mesh(args.mesh)
    arrays, inputs, kwargs = {}, [], {"hard": args.hard, "kind": args.kind}
    kwargs["normalize"] = not args.keep_length
    if args.constraints is not None:
        c = _load_data(args.constraints, mesh)
        inputs.append(args.constraints)
        k = None
        if "points" in c:
            kwargs["points"] = arrays["points"] = c.numbers("points", (None, 3))
            k = arrays["points"].shape[0]
        else:
            kwargs["faces"] = arrays["constraint_faces"] = c.integers("constraint_faces", (None,))
            k = arrays["constraint_faces"].shape[0]
            if "barycentric" in c:
                arrays["barycentric"] = c.numbers("barycentric", (k, 3))
                arrays["points"] = fvf.locate_points(mesh, kwargs["faces"], arrays["barycentric"])[
                    1
                ]
        kwargs["directions"] = arrays["directions"] = c.numbers("directions", (k, 3))
        if "weights" in c:
            w = c["weights"]
            kwargs["weights"] = arrays["weights"] = c.numbers("weights", (k,) if w.ndim else ())
    if args.soft is not None:
        kwargs["weights"] = arrays["weights"] = _array(args.soft)
    v = fvf.design_field(mesh, **kwargs)
    ids, index = fvf.singularities(mesh, v, zero="warn")
    arrays.update(
        v=v,
        singularity_vertices=ids,
        singularity_indices=index,
        singularity_positions=fvf.singularity_positions(mesh, ids, "vertex"),
    )
    _write(args, args.output, arrays, mesh, inputs)
    print(f"singularities: {ids.size} (indices {index.tolist()[:20]})")
    return EXIT_OK


def _read_landmarks(path: str):
    """Landmark pairs from a text file: one line "i1 i2" per landmark (vertex of the first
    mesh, vertex of the second), '#' comments allowed; int64 (q, 2)."""
    import numpy as np

    try:
        L = np.loadtxt(path, dtype=np.int64, comments="#", ndmin=2)
    except ValueError as exc:
        raise ValueError(f"{path}: landmarks must be two integers per line ({exc})") from exc
    if L.shape[1] != 2:
        raise ValueError(f"{path}: landmarks must be two integers per line; got {L.shape[1]}")
    return L


def _save_npz(path: str, arrays: dict) -> str:
    import numpy as np

    from fvf import __version__
    from fvf.io.atomic import atomic_path

    out = Path(path)
    if out.suffix.lower() != ".npz":
        out = out.with_name(out.name + ".npz")
    out.parent.mkdir(parents=True, exist_ok=True)
    arrays = dict(arrays, fvf_version=np.array(__version__))
    with atomic_path(out) as tmp:
        np.savez(tmp, **arrays)
    shapes = ", ".join(f"{k} {tuple(v.shape)}" for k, v in arrays.items() if np.ndim(v))
    print(f"wrote {out}: {shapes}")
    return str(out)


def _match_pictures(args, result, stem: str, mesh_2_prepared) -> None:
    """Transferred colours (and the error map when a ground truth is given)."""
    viz = _viz()
    p1, p2 = result.prepared_1, mesh_2_prepared
    p2p = p1.input_to_mesh[result.p2p_21[p2.mesh_to_input]]  # prepared 2 -> prepared 1
    path = f"{stem}_colors.png"
    try:
        viz.render_correspondence(p1.mesh, p2.mesh, p2p, path)
    except ImportError as exc:
        raise Unavailable(" ".join(str(exc).split())) from exc
    print(f"wrote {path}")


def _cmd_match(args) -> int:
    import numpy as np

    import fvf

    landmarks = _read_landmarks(args.landmarks) if args.landmarks else None
    result = fvf.match(
        args.mesh_1,
        args.mesh_2,
        k=args.k,
        k_fit=args.k_fit,
        landmarks=landmarks,
        full_output=True,
    )
    arrays = {
        "p2p_21": result.p2p_21,
        "C_12": result.C_12,
        "mesh_1_path": np.array(str(Path(args.mesh_1).resolve())),
        "mesh_2_path": np.array(str(Path(args.mesh_2).resolve())),
        "command": np.array(args.command_line),
    }
    if args.truth:
        truth = np.loadtxt(args.truth, dtype=np.int64, ndmin=1)
        valid = truth != args.truth_missing if args.truth_missing is not None else None
        p1 = result.prepared_1
        err = fvf.geodesic_errors(p1.mesh, p1.input_to_mesh[result.p2p_21], p1.input_to_mesh[truth])
        if valid is not None:
            err = np.where(valid, err, np.nan)
        arrays["errors"] = err
        print(f"mean geodesic error / sqrt(area): {np.nanmean(err):.4f}")
    _save_npz(args.output, arrays)
    times = ", ".join(f"{k} {v:.1f} s" for k, v in result.timings.items())
    print(f"matched {result.p2p_21.size} vertices ({times})")
    if args.png:
        stem = str(Path(args.png).with_suffix(""))
        _match_pictures(args, result, stem, result.prepared_2)
        if args.truth:
            p2 = result.prepared_2
            e = np.nan_to_num(arrays["errors"])[p2.mesh_to_input]
            _viz().render_error_map(p2.mesh, e, f"{stem}_errors.png")
            print(f"wrote {stem}_errors.png")
    return EXIT_OK


def _cmd_symmetry(args) -> int:
    import numpy as np

    import fvf

    result = fvf.symmetry_map(args.mesh, k=args.k, k_fit=args.k_fit)
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
    _save_npz(args.output, arrays)
    involution = float(np.mean(result.p2p[result.p2p] == np.arange(result.p2p.size)))
    print(f"symmetry map: {involution:.1%} of the vertices are fixed by applying it twice")
    if args.png:
        stem = str(Path(args.png).with_suffix(""))
        _match_pictures(args, result, stem, result.prepared_2)
    return EXIT_OK


def _display_arrays(args, mesh):
    """function, field and singularities to draw, from the data file and the options."""
    import fvf

    kwargs = {}
    data = _load_data(args.data, mesh) if args.data else None
    if data is None and (args.function or args.field or args.singularities):
        raise ValueError("--function, --field and --singularities need a DATA file")
    if args.function:
        kwargs["function"] = _numbers_of(data, args.function, [(mesh.n_vertices,), (mesh.n_faces,)])
    if args.field:
        kwargs["field"] = _numbers_of(data, args.field, [(mesh.n_faces, 3), (mesh.n_vertices, 3)])
    if args.singularities:
        if "singularity_positions" in data and "singularity_indices" in data:
            pos = data.numbers("singularity_positions", (None, 3))
            idx = data.integers("singularity_indices", (pos.shape[0],))
        elif "field" in kwargs and kwargs["field"].shape[0] == mesh.n_faces:
            ids, idx = fvf.singularities(mesh, kwargs["field"], zero="warn")
            pos = fvf.singularity_positions(mesh, ids, "vertex")
        elif "field" in kwargs:
            ids, idx = fvf.face_singularities(mesh, kwargs["field"], zero="warn")
            pos = fvf.singularity_positions(mesh, ids, "face")
        else:
            raise ValueError(
                f"--singularities needs keys singularity_positions and singularity_indices "
                f"in {data.path} (fvf design writes them) or a --field KEY to find them in"
            )
        kwargs["singularities"] = (pos, idx)
    return kwargs, args.data


def _numbers_of(data, spec, shapes):
    from fvf.errors import FieldShapeError

    a = data.select(spec)
    if a.dtype.kind not in "fiu" or a.shape not in shapes:
        want = " or ".join(str(s) for s in shapes)
        raise FieldShapeError(
            f"{data.path}: {spec!r} has dtype {a.dtype} and shape {a.shape}, expected real "
            f"numbers of shape {want} (select one row with KEY[i])"
        )
    return a.astype(float)


def _cmd_render(args) -> int:
    viz = _viz()
    mesh = _load_mesh(args.mesh)
    kwargs, _ = _display_arrays(args, mesh)
    for name in ("arrow_scale", "cmap", "title", "backend", "max_arrows"):
        if getattr(args, name) is not None:
            kwargs[name] = getattr(args, name)
    for name in ("clim", "size", "view"):
        if getattr(args, name) is not None:
            kwargs[name] = tuple(getattr(args, name))
    _render(viz, mesh, args.output, **kwargs)
    return EXIT_OK


def _cmd_view(args) -> int:
    viz = _viz()
    mesh = _load_mesh(args.mesh)
    kwargs, _ = _display_arrays(args, mesh)
    try:
        viz.view(mesh, **kwargs)
    except (ImportError, viz.NoDisplayError) as exc:
        raise Unavailable(" ".join(str(exc).split())) from exc
    return EXIT_OK


def _str(s: str):
    import numpy as np

    return np.array(s)


def _array(x):
    import numpy as np

    return np.asarray(x, dtype=float)


# ---------------------------------------------------------------------------- parser
def _add(sub, name: str, help: str, example: str) -> argparse.ArgumentParser:
    p = sub.add_parser(
        name,
        help=help,
        description=help,
        epilog=f"example:\n  {example}\n\n{_EXIT_TEXT}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    # --debug after the command too (SUPPRESS keeps the top-level value when absent)
    p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=_DEBUG)
    return p


def _add_display_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    p.add_argument("data", nargs="*", help=".npz data file(s) (or PLY with properties)")
    p.add_argument("--function", metavar="KEY", help="vertex/face function to color by (KEY[i])")
    p.add_argument("--field", metavar="KEY", help="per-face (or per-vertex) field to draw")
    p.add_argument(
        "--singularities",
        action="store_true",
        help="mark singularities (stored singularity_* keys, else found in --field)",
    )


def parser() -> argparse.ArgumentParser:
    """The argument parser of the ``fvf`` command."""
    from fvf.flows.dispatch import METHODS

    top = _Parser(
        prog="fvf",
        description="Operator-based tangent vector fields on your meshes (fvf "
        f"{_version()}): run `fvf COMMAND --help` for a command's options and an example.",
        epilog="examples:\n  fvf demo --out results/\n  fvf info bunny.off\n"
        f"  fvf flow bunny.off fields.npz --t 0 1 -o flowed.npz\n\n{_EXIT_TEXT}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    top.add_argument("--debug", action="store_true", help=_DEBUG)
    sub = top.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = _add(
        sub,
        "demo",
        "run the chapter's story on a mesh (default: the built-in spot.obj)",
        "fvf demo --mesh bunny.off --out results/",
    )
    p.add_argument("--mesh", help="OBJ, OFF or PLY file (default: built-in spot)")
    p.add_argument("--out", default="fvf-demo", help="output folder (default: fvf-demo)")
    p.set_defaults(run=_cmd_demo)

    p = _add(
        sub,
        "info",
        "validation report of a mesh file (OBJ, OFF, PLY): every problem with indices and fix",
        "fvf info bunny.off   (exit status 1 when a problem is found)",
    )
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.set_defaults(run=_cmd_info)

    p = _add(
        sub,
        "flow",
        "flow vertex functions along a per-face field: f(t) = Phi_{v,t} f (eq. 42, fvf.flow)",
        "fvf flow mesh.obj field.npz --t 0 0.5 1 --method upwind -o flowed.npz --png f.png",
    )
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    p.add_argument("data", nargs="+", help=".npz with keys f (n,)|(k,n), v (m,3) " + _MERGE)
    p.add_argument("--t", nargs="+", metavar="T", help="times, e.g. --t 0 0.5 1 (or key t)")
    p.add_argument("--method", choices=METHODS, default="chapter", help="default: chapter")
    p.add_argument("--function", default="f", metavar="KEY", help="function key (default f)")
    p.add_argument("--field", default="v", metavar="KEY", help="field key (default v)")
    p.add_argument("--k", type=int, help="eigenfunctions of --method spectral (default 50)")
    p.add_argument("--dt", type=float, help="step length of --method cayley")
    p.add_argument("--growth-limit", type=float, help="warn above this norm growth")
    p.add_argument("-o", "--output", required=True, help="output .npz (keys f_t (T,n)|(T,k,n))")
    p.add_argument("--png", help="also render f at the last time with the field (fvf.viz)")
    p.set_defaults(run=_cmd_flow)

    p = _add(
        sub,
        "bracket",
        "Lie bracket of two per-face fields: commutator field D^F_[v,w] X and its norm",
        "fvf bracket mesh.obj fields.npz -o bracket.npz   (fields.npz: v, u; optional f)",
    )
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    p.add_argument("data", nargs="+", help=".npz with keys v, u (m,3) [, f] " + _MERGE)
    p.add_argument("--first", default="v", metavar="KEY", help="first field key (default v)")
    p.add_argument("--second", default="u", metavar="KEY", help="second field key (default u)")
    p.add_argument("--function", metavar="KEY", help="functions to apply both brackets to")
    p.add_argument("-o", "--output", required=True, help="output .npz")
    p.set_defaults(run=_cmd_bracket)

    p = _add(
        sub,
        "transport",
        "transport a field u along v, Ad_{Phi_{v,t}} u (eq. 67), or interpolate u to u1 (68)",
        "fvf transport mesh.obj fields.npz --t 0 0.25 0.5 -o moved.npz   (keys v, u [, u1])",
    )
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    p.add_argument("data", nargs="+", help=".npz with keys v, u (m,3) [, u1] " + _MERGE)
    p.add_argument("--t", nargs="+", metavar="T", help="times (interpolation: in [0, 1])")
    p.add_argument("--field", default="v", metavar="KEY", help="flowing field key (default v)")
    p.add_argument("--transported", default="u", metavar="KEY", help="moved field (default u)")
    p.add_argument("--to", metavar="KEY", help="end field: interpolate (default u1 if present)")
    p.add_argument("-o", "--output", required=True, help="output .npz (key u_t (T,m,3))")
    p.set_defaults(run=_cmd_transport)

    p = _add(
        sub,
        "design",
        "smoothest tangent field meeting direction constraints (fvf.design_field), "
        "and its singularities",
        "fvf design mesh.obj --constraints c.npz --soft 50 -o designed.npz\n"
        "  (c.npz: constraint_faces (k,) int or points (k,3), directions (k,3))",
    )
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    p.add_argument("--constraints", help=".npz with constraint_faces|points, directions")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--soft", type=float, metavar="W", help="soft weight of every constraint")
    mode.add_argument("--hard", action="store_true", help="meet the constraints exactly")
    p.add_argument("--kind", choices=("knoppel", "singer_wu"), default="knoppel")
    p.add_argument("--keep-length", action="store_true", help="don't normalize directions")
    p.add_argument("-o", "--output", required=True, help="output .npz (keys v, singularity_*)")
    p.set_defaults(run=_cmd_design)

    p = _add(
        sub,
        "match",
        "vertex correspondence between two near-isometric shapes (fvf.match: functional "
        "maps with the orientation term, ZoomOut)",
        "fvf match A.off B.off -o map.npz --k 200 [--landmarks l.txt] [--png map.png]\n"
        "  (map.npz: p2p_21 (n_B,) = vertex of A for each vertex of B, C_12 (k,k))",
    )
    p.add_argument("mesh_1", help="first mesh (OBJ, OFF, PLY): the map lands on it")
    p.add_argument("mesh_2", help="second mesh: the map has one entry per vertex of it")
    p.add_argument("--k", type=int, default=200, help="final functional map size (200)")
    p.add_argument("--k-fit", type=int, default=15, help="fitted map size (15)")
    p.add_argument("--landmarks", help='text file, one "i1 i2" pair of vertex indices per line')
    p.add_argument("--truth", help="ground-truth p2p_21 (one integer per line): report errors")
    p.add_argument("--truth-missing", type=int, help="value marking vertices without truth")
    p.add_argument("-o", "--output", required=True, help="output .npz (keys p2p_21, C_12)")
    p.add_argument("--png", help="also write STEM_colors.png (and STEM_errors.png with --truth)")
    p.set_defaults(run=_cmd_match)

    p = _add(
        sub,
        "symmetry",
        "left-right intrinsic symmetry of a shape (fvf.symmetry_map, orientation-reversing)",
        "fvf symmetry A.off -o sym.npz [--png sym.png]\n"
        "  (sym.npz: p2p (n,), C (k,k) and the basis, for fvf.map_consistent_field)",
    )
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    p.add_argument("--k", type=int, default=100, help="functional map size (100)")
    p.add_argument("--k-fit", type=int, default=15, help="fitted map size (15)")
    p.add_argument("-o", "--output", required=True, help="output .npz")
    p.add_argument("--png", help="also write STEM_colors.png (the mesh and its mirror colours)")
    p.set_defaults(run=_cmd_symmetry)

    p = _add(
        sub,
        "render",
        "render a mesh with a function, a field and singularities to PNG (fvf.viz)",
        "fvf render mesh.obj designed.npz --field v --singularities -o field.png",
    )
    _add_display_options(p)
    p.add_argument("-o", "--output", required=True, help="output PNG")
    p.add_argument("--cmap", help="matplotlib colormap name (default viridis)")
    p.add_argument("--clim", nargs=2, type=float, metavar=("LO", "HI"), help="color range")
    p.add_argument("--arrow-scale", type=float, help="arrow length per unit field (absolute)")
    p.add_argument("--size", nargs=2, type=int, metavar=("W", "H"), help="pixels (800 600)")
    p.add_argument("--title", help="picture title")
    p.add_argument("--view", nargs=2, type=float, metavar=("AZ", "EL"), help="camera, degrees")
    p.add_argument("--max-arrows", type=int, help="arrows at about this many faces (1500)")
    p.add_argument("--backend", help="auto (default), polyscope-egl or matplotlib")
    p.set_defaults(run=_cmd_render)

    p = _add(
        sub,
        "view",
        "open an interactive polyscope window (needs a display)",
        "fvf view mesh.obj flowed.npz --function f_t[2] --field v",
    )
    _add_display_options(p)
    p.set_defaults(run=_cmd_view)
    return top


# ---------------------------------------------------------------------------- main
def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.filename is not None and exc.strerror:
        text = f"{exc.filename}: {exc.strerror}"
    else:
        text = str(exc.args[0]) if isinstance(exc, KeyError) and exc.args else str(exc)
        text = f"{type(exc).__name__}: {text}" if type(exc).__module__.startswith("fvf") else text
    return " ".join(text.split()) or type(exc).__name__


def _show_warning(message, category, filename, lineno, file=None, line=None):
    text = f"fvf: warning: {category.__name__}: {' '.join(str(message).split())}"
    if text not in _SHOWN:  # once per distinct message, wherever it was raised
        _SHOWN.add(text)
        print(text, file=sys.stderr)


_SHOWN: set[str] = set()


def main(argv: list[str] | None = None) -> int:
    """Run the ``fvf`` command with ``argv`` (default ``sys.argv[1:]``); return the exit status.

    Exit status: :data:`EXIT_OK` (0), :data:`EXIT_PROBLEMS` (1, ``info`` found problems),
    :data:`EXIT_BAD_INPUT` (2), :data:`EXIT_UNAVAILABLE` (3), :data:`EXIT_FAILED` (4).
    """
    import numpy as np

    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args = parser().parse_args(argv)
    except SystemExit as exc:  # --help (0) or a usage error (2), already printed
        return int(exc.code or 0)
    args.command_line = shlex.join(["fvf", *argv])
    _SHOWN.clear()
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        warnings.showwarning = _show_warning
        try:
            return args.run(args)
        except Exception as exc:
            if args.debug:
                raise
            if isinstance(exc, (Unavailable, ImportError)):
                status = EXIT_UNAVAILABLE
            elif isinstance(exc, (FloatingPointError, np.linalg.LinAlgError, RuntimeError)):
                status = EXIT_FAILED
            elif isinstance(exc, (ValueError, OSError, KeyError)):
                status = EXIT_BAD_INPUT
            else:
                raise
            print(f"fvf: error: {_one_line(exc)}", file=sys.stderr)
            return status
        except KeyboardInterrupt:
            print("fvf: interrupted", file=sys.stderr)
            return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
