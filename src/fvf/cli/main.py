"""The ``fvf`` command: the chapter's operations on your meshes, from the shell.

It contains no math: every number comes from a library call. Meshes are OBJ, OFF or PLY
files; functions and fields are read from and written to ``.npz`` data files whose keys
are documented in :mod:`fvf.fieldio` and ``docs/cli.md`` (``f`` vertex functions, ``v``
and ``u`` per-face fields, ``t`` times, ...).

Exit status: 0 success; 1 ``fvf info`` found problems in the mesh, or ``fvf batch``
finished with failed meshes; 2 bad input (a missing
or unreadable file, an invalid mesh, wrong data keys or shapes, bad options, an output
that is an input); 3 a feature unavailable here (``fvf.viz`` or its ``[viz]`` extra
missing, no display for ``view``); 4 the computation failed (e.g. a flow overflowed, out
of memory); 5 an output could not be written (disk full, file size limit); 6 a flow grew
beyond ``--growth-limit`` (the output is written); 130 / 143
interrupted (SIGINT / SIGTERM). Errors are one line on stderr, ``fvf: error: <cause>``;
``--debug`` shows the traceback instead. Warnings (fvf's :class:`~fvf.errors.FvfWarning`)
are one line each, ``fvf: warning: <cause>``.

Files (``docs/files.md``): every output is written whole or not at all (a temporary file
beside it, renamed when complete), and no command writes onto one of its inputs (also
through a link) unless given ``--force``.
"""

from __future__ import annotations

import argparse
import json
import re
import shlex
import signal
import sys
import threading
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

if TYPE_CHECKING:
    import numpy as np

    from ..io.datafile import DataFile
    from ..mesh.prepared import PreparedMesh
    from ..mesh.trimesh import TriMesh
    from ..spectral.correspondence import MatchResult

__all__ = [
    "main",
    "EXIT_OK",
    "EXIT_PROBLEMS",
    "EXIT_BAD_INPUT",
    "EXIT_UNAVAILABLE",
    "EXIT_FAILED",
    "EXIT_GREW",
    "EXIT_WRITE_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_TERMINATED",
]

EXIT_OK = 0
#: ``fvf info`` found problems in the mesh; ``fvf batch`` finished with failed meshes.
EXIT_PROBLEMS = 1
#: Bad input: missing or unreadable file, invalid mesh, wrong data keys or shapes, options.
EXIT_BAD_INPUT = 2
#: The feature is not available here (fvf.viz or its extra missing, no display).
EXIT_UNAVAILABLE = 3
#: The computation failed (e.g. a flow overflowed to inf, or memory ran out).
EXIT_FAILED = 4
#: An output could not be written (disk full, file size limit, read-only file system);
#: a file already at the output path is unchanged.
EXIT_WRITE_FAILED = 5
#: A flow or transport grew a function or field beyond ``--growth-limit``: the output was
#: written, but it is not a trustworthy result (``--growth-limit inf`` accepts it).
EXIT_GREW = 6
#: Interrupted by SIGINT (Ctrl-C) / terminated by SIGTERM; no output is half-written.
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143

_EXIT_TEXT = """exit status: 0 success, 1 `fvf info` found problems or `fvf batch` had failed
meshes, 2 bad input,
3 feature unavailable (fvf.viz / [viz] extra / display), 4 computation failed,
5 output not written (disk full...), 6 the result grew beyond --growth-limit (written;
--growth-limit inf accepts it), 130/143 interrupted.
Outputs are written whole or not at all, never onto an input (unless --force).
Data files: .npz with keys f (n,)|(n,k), v (m,3), u (m,3), u1 (m,3), t (T,); see docs/cli.md.
A key option can name another file: --field designed.npz:v. -o *.ply/.vtp/.vtu writes the
results as mesh properties (ParaView, MeshLab); a .ply output is a valid fvf input."""


_DEBUG = "show the traceback of an error instead of one line"
_MERGE = (
    "(or PLY properties); several files: a later one's keys replace an earlier one's; a key "
    "option may name its own file: --field other.npz:v"
)


def _version() -> str:
    from fvf import __version__

    return __version__


class Unavailable(RuntimeError):
    """A feature the command needs is not available on this machine."""


#: A number on the command line: decimal, as in C (Python's float() would also take
#: "1_0" as 10, and "nan", "inf", "infinity").
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def _real(text: str) -> float:
    """argparse type: a finite decimal number."""
    if _DECIMAL.fullmatch(text.strip()) is None:
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite decimal number (e.g. 0.5)")
    return float(text)


def _real_or_inf(text: str) -> float:
    """argparse type: a finite decimal number or ``inf``."""
    return float("inf") if text.strip().lower() in ("inf", "+inf") else _real(text)


def _integer(text: str) -> int:
    """argparse type: a decimal integer (no underscores)."""
    if re.fullmatch(r"[+-]?[0-9]+", text.strip()) is None:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer (e.g. 50)")
    return int(text)


class _Terminated(BaseException):
    """SIGTERM, raised in the main thread so that outputs being written are cleaned up."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit status 2)."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


# ---------------------------------------------------------------------------- helpers
def _load_mesh(path: str) -> TriMesh:
    """The TriMesh of a mesh file; an invalid mesh's error points to ``fvf info``."""
    import fvf

    V, F = fvf.read_mesh(path)
    try:
        return fvf.TriMesh(V, F)
    except fvf.MeshError as exc:
        raise type(exc)(f"{path}: {exc} (`fvf info {path}` lists every problem)") from exc


def _load_data(paths: str | list[str], mesh: TriMesh) -> DataFile:
    """One data file, or several merged (a later file's key replaces an earlier's)."""
    from fvf.io.datafile import DataFile, read_data

    if isinstance(paths, str):
        return read_data(paths, mesh)
    files = [read_data(p, mesh) for p in paths]
    return files[0] if len(files) == 1 else DataFile.merged(files)


def _split_source(spec: str) -> tuple[str | None, str]:
    """``FILE.npz:KEY`` -> (FILE.npz, KEY); a plain ``KEY`` -> (None, KEY)."""
    from fvf.io.datafile import MESH_DATA_SUFFIXES

    head, sep, key = spec.rpartition(":")
    if sep and Path(head).suffix.lower() in (".npz", *MESH_DATA_SUFFIXES) and key:
        return head, key
    return None, spec


class _Sources:
    """The data files of a command, and keys named ``FILE.npz:KEY`` from other files
    (read on first use, checked against the mesh, listed as inputs)."""

    def __init__(self, args, mesh):
        self.mesh, self.extra = mesh, {}
        self.data = _load_data(args.data, mesh) if args.data else None
        self.paths = list(args.data or [])

    def _file(self, spec: str) -> tuple[DataFile, str]:
        from fvf.io.datafile import read_data

        path, key = _split_source(spec)
        if path is None:
            if self.data is None:
                raise ValueError(
                    f"no data file to read key {key!r} from: give a DATA file, or name the "
                    f"file in the option, e.g. fields.npz:{key}"
                )
            return self.data, key
        if path not in self.extra:
            self.extra[path] = read_data(path, self.mesh)
            self.paths.append(path)
        return self.extra[path], key

    def has(self, spec: str) -> bool:
        path, key = _split_source(spec)
        if path is not None:
            return True
        return self.data is not None and key in self.data

    def field(self, spec: str) -> np.ndarray:
        data, key = self._file(spec)
        return data.field(key, self.mesh)

    def functions(self, spec: str) -> np.ndarray:
        data, key = self._file(spec)
        return data.functions(key, self.mesh)

    def select(self, spec: str) -> tuple[DataFile, Any]:
        data, key = self._file(spec)
        return data, data.select(key, self.mesh.n_vertices)


def _times(args, data):
    """The times of ``--t``, else the data file's ``t``: float64 (T,)."""
    import numpy as np

    if args.t:
        try:
            values = [_real(x) for item in args.t for x in item.split(",") if x.strip()]
        except argparse.ArgumentTypeError:
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


_KEY_OPTIONS = ("field", "function", "first", "second", "transported", "to")


def _inputs(args: argparse.Namespace) -> list:
    """Every file a command reads: the mesh, the data files, the constraints, and the
    files named in ``FILE.npz:KEY`` options."""
    data = getattr(args, "data", None) or []
    data = [data] if isinstance(data, str) else list(data)
    named = [_split_source(getattr(args, o, None) or "")[0] for o in _KEY_OPTIONS]
    meshes = [getattr(args, o, None) for o in ("mesh", "mesh_1", "mesh_2")]
    extra = [getattr(args, o, None) for o in ("constraints", "landmarks", "truth")]
    return [*meshes, *data, *extra, *named]


def _progress(args: argparse.Namespace) -> Any:
    """The library's ``progress`` option for a command: bars on stderr with ``--progress``;
    on a terminal also without it, for any stage running longer than 2 s; else None."""
    if getattr(args, "progress", False):
        return True
    if sys.stderr.isatty():
        from fvf.numerics.progress import make_progress

        return make_progress(True, delay=2.0)
    return None


def _check_outputs(args: argparse.Namespace, *outputs: tuple[str, str | None]) -> None:
    """Refuse, before any work, outputs that are inputs (unless --force)."""
    from fvf.io.atomic import check_not_input

    for option, path in outputs:
        if path is not None:
            check_not_input(path, _inputs(args), force=args.force, option=option)


def _data_output(args: argparse.Namespace) -> tuple[str, str]:
    from fvf.io.datafile import data_path

    return "-o", str(data_path(args.output))


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
        out,
        arrays,
        mesh=mesh,
        mesh_path=args.mesh,
        command=args.command_line,
        inputs=inputs,
        overwrite_inputs=args.force,
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
        print(f"  problem: {_shell_fix(problem)}")
    if not report["problems"]:
        print("  no problems found")
    elif _repairable(report):
        fixed = Path(path).stem + "_fixed" + Path(path).suffix
        print(f"  fix: fvf repair {shlex.quote(str(path))} -o {shlex.quote(fixed)}")
    return report


def _shell_fix(problem: str) -> str:
    """A problem line whose Python fix names repair steps, told for the shell instead."""
    from fvf.mesh.repair import REPAIR_STEPS

    text, sep, fix = problem.partition(" Fix: ")
    steps = re.findall(r"fvf\.(\w+)\(", fix)
    if not sep or not steps or not all(step in REPAIR_STEPS for step in steps):
        return problem
    return f"{text} Fixed by `fvf repair` (step {', '.join(dict.fromkeys(steps))})."


def _repairable(report: dict) -> bool:
    """Whether ``fvf repair`` addresses the problems (all but non-finite coordinates,
    bad shapes and non-orientable surfaces)."""
    fixable = ("Unreferenced", "Duplicate", "Degenerate", "NonManifold", "Orientation")
    return any(p.split(":")[0].startswith(fixable) for p in report["problems"])


def _cmd_info(args: argparse.Namespace) -> int:
    report = info(args.mesh, args.json)
    return EXIT_OK if not report["problems"] else EXIT_PROBLEMS


def _cmd_repair(args: argparse.Namespace) -> int:
    import numpy as np

    import fvf
    from fvf.io.atomic import atomic_path

    out = Path(args.output)
    maps = out.with_name(out.stem + ".maps.npz")
    _check_outputs(args, ("-o", str(out)), ("the index maps", str(maps)))
    V, F = fvf.read_mesh(args.mesh)
    result = fvf.repair_mesh(V, F, tol=args.tol)
    mesh = result.mesh  # the repaired mesh must be valid (else: what is left, status 2)
    fvf.write_mesh(out, mesh.vertices, mesh.faces)
    with atomic_path(maps) as tmp:
        np.savez(
            tmp,
            vertex_origin=result.vertex_origin,
            vertex_map=result.vertex_map,
            face_origin=result.face_origin,
            face_map=result.face_map,
            flipped=result.flipped,
            log=np.array(list(result.log) or ["nothing to repair"]),
            mesh_path=np.array(str(Path(args.mesh).resolve())),
            command=np.array(args.command_line),
        )
    for line in result.log or ("nothing to repair",):
        print(f"  {line}")
    print(
        f"wrote {out} ({mesh.n_vertices} vertices, {mesh.n_faces} faces) and {maps} "
        "(vertex_origin, vertex_map, face_origin, face_map, flipped: old <-> new indices)"
    )
    return EXIT_OK


def _cmd_demo(args: argparse.Namespace) -> int:
    from fvf.cli.demo import demo

    demo(args.mesh, Path(args.out))
    return EXIT_OK


#: The options of ``fvf flow`` and the methods of :func:`fvf.flow` that take them.
_FLOW_OPTIONS = {
    "k": ("spectral",),
    "dt": ("cayley",),
    "growth_limit": ("chapter", "skew", "cayley"),
}


def _cmd_flow(args: argparse.Namespace) -> int:
    import fvf

    _check_outputs(args, _data_output(args), ("--png", args.png))
    viz = _viz() if args.png else None
    mesh = _load_mesh(args.mesh)
    src = _Sources(args, mesh)
    v, f = src.field(args.field), src.functions(args.function)
    t = _times(args, src.data)
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
    progress = _progress(args)
    if args.method in ("chapter", "skew") and progress is not None:
        options["progress"] = progress
    f_t = fvf.flow(mesh, v, f, t, method=args.method, **options)  # (T, n) or (T, n, k)
    arrays = {"f": f, "v": v, "t": t, "f_t": f_t, "method": _str(args.method)}
    _write(args, args.output, arrays, mesh, src.paths)
    if viz is not None:
        last = f_t[-1] if f.ndim == 1 else f_t[-1, :, 0]
        title = f"flow ({args.method}) at t = {t[-1]:g}"
        _render(viz, mesh, args.png, function=last, field=v, title=title)
    return EXIT_OK


def _cmd_bracket(args: argparse.Namespace) -> int:
    import fvf

    _check_outputs(args, _data_output(args))
    mesh = _load_mesh(args.mesh)
    src = _Sources(args, mesh)
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
    _write(args, args.output, arrays, mesh, src.paths)
    return EXIT_OK


def _cmd_transport(args: argparse.Namespace) -> int:
    import fvf

    _check_outputs(args, _data_output(args))
    mesh = _load_mesh(args.mesh)
    src = _Sources(args, mesh)
    v, u = src.field(args.field), src.field(args.transported)
    t = _times(args, src.data)
    growth = {} if args.growth_limit is None else {"growth_limit": args.growth_limit}
    arrays = {"v": v, "u": u, "t": t}
    if args.to is not None or src.has("u1"):
        u1 = src.field(args.to or "u1")
        u_t = fvf.interpolate(mesh, v, u, u1, t, **growth)
        arrays.update(u1=u1, u_t=u_t, mode=_str("interpolate"))
    else:
        progress = _progress(args)
        if progress is not None:
            growth["progress"] = progress
        result = fvf.FieldTransport(mesh, v, **growth)(u, t)  # = fvf.Ad(mesh, v, u, t), eq. 67
        arrays.update(u_t=result.fields, normal_part=result.normal_part, mode=_str("Ad"))
    _write(args, args.output, arrays, mesh, src.paths)
    return EXIT_OK


def _cmd_design(args: argparse.Namespace) -> int:
    import fvf

    _check_outputs(args, _data_output(args))
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
    n = args.n
    kwargs.update(n=n, progress=_progress(args), curvature_smoothing=args.curvature_smoothing)
    if args.align is not None:
        kwargs["align"] = args.align
        if args.align_strength is not None:
            kwargs["align_strength"] = args.align_strength
    v = fvf.design_field(mesh, **kwargs)
    ids, index = fvf.singularities(mesh, v, n=n, zero="warn")
    arrays.update(
        v=v,
        singularity_vertices=ids,
        singularity_indices=index,
        singularity_positions=fvf.singularity_positions(mesh, ids, "vertex"),
    )
    if n != 1:
        arrays["n"] = _array(n)
    _write(args, args.output, arrays, mesh, inputs)
    shown = [str(x) for x in index.tolist()[:20]]
    print(f"singularities: {ids.size} (indices {', '.join(shown)})")
    return EXIT_OK


def _cmd_quad(args: argparse.Namespace) -> int:
    import time

    import fvf
    from fvf.io.meshfile import check_writable, write_uv_mesh

    _check_outputs(args, ("-o", args.output), ("--uv", args.uv), ("--png", args.png))
    check_writable(args.output, face_size=4)  # a format that holds quads, before the work
    mesh = _load_mesh(args.mesh)
    field = _Sources(args, mesh).field(args.field) if args.field else None
    t0 = time.perf_counter()

    started: list[str] = []

    def progress(message: str, done: int, total: int) -> None:  # each stage as it starts
        if done == 0 or message not in started:  # and the fold repair's rounds
            started.append(message)
            print(f"fvf quad: {time.perf_counter() - t0:6.1f}s  {message}", file=sys.stderr)

    from fvf.param.extraction import extract_quads

    param = fvf.seamless_parameterization(
        mesh, target_faces=args.faces, field=field, align=args.align, progress=progress
    )
    progress("quad extraction", 0, 1)
    qm = extract_quads(mesh, param.uv)
    V, Q = qm.vertices, qm.quads
    fvf.write_mesh(args.output, V, Q)
    q = fvf.quad_quality(mesh, V, Q, parameterization=param)
    print(
        f"wrote {args.output}: {Q.shape[0]} quads, {V.shape[0]} vertices, "
        f"{q.n_irregular} irregular ({q.irregular_fraction:.1%}), corner angle deviation "
        f"median {q.angle_deviation_median:.1f} deg, 95% {q.angle_deviation_p95:.1f} deg"
    )
    if args.uv:
        write_uv_mesh(args.uv, mesh.vertices, mesh.faces, param.uv)
        print(f"wrote {args.uv}: the parameterized triangle mesh (vt per corner)")
    if args.png:
        viz = _viz()
        try:
            info = viz.render_quads(V, Q, args.png, title=f"{Q.shape[0]} quads")
        except ImportError as exc:
            raise Unavailable(" ".join(str(exc).split())) from exc
        print(f"wrote {info.path}")
    return EXIT_OK


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


def _read_landmarks(path: str) -> np.ndarray:
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


def _match_pictures(
    args: argparse.Namespace, result: MatchResult, stem: str, mesh_2_prepared: PreparedMesh
) -> None:
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


def _cmd_match(args: argparse.Namespace) -> int:
    import numpy as np

    import fvf

    _check_outputs(args, _data_output(args), ("--png", args.png))
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


def _cmd_symmetry(args: argparse.Namespace) -> int:
    import numpy as np

    import fvf

    _check_outputs(args, _data_output(args), ("--png", args.png))
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
    src = _Sources(args, mesh)
    data = src.data
    if args.singularities and data is None and not args.field:
        raise ValueError("--singularities needs a DATA file or a --field")
    if args.function:
        kwargs["function"] = _numbers_of(src, args.function, [(mesh.n_vertices,), (mesh.n_faces,)])
    if args.field:
        kwargs["field"] = _numbers_of(src, args.field, [(mesh.n_faces, 3), (mesh.n_vertices, 3)])
    n = args.n
    if n is None:
        n = int(data.numbers("n", ())) if data is not None and "n" in data else 1
    if n != 1:
        kwargs["n"] = n
    if args.singularities:
        if data is not None and "singularity_positions" in data and "singularity_indices" in data:
            pos = data.numbers("singularity_positions", (None, 3))
            idx = data.numbers("singularity_indices", (pos.shape[0],))
        elif "field" in kwargs and kwargs["field"].shape[0] == mesh.n_faces:
            ids, idx = fvf.singularities(mesh, kwargs["field"], n=n, zero="warn")
            pos = fvf.singularity_positions(mesh, ids, "vertex")
        elif "field" in kwargs:
            ids, idx = fvf.face_singularities(mesh, kwargs["field"], zero="warn")
            pos = fvf.singularity_positions(mesh, ids, "face")
        else:
            raise ValueError(
                f"--singularities needs keys singularity_positions and singularity_indices "
                f"in {data.path if data is not None else 'the data files'} (fvf design "
                "writes them) or a --field KEY to find them in"
            )
        kwargs["singularities"] = (pos, idx)
    return kwargs, args.data


def _numbers_of(src, spec, shapes):
    from fvf.errors import FieldShapeError

    data, a = src.select(spec)
    if a.dtype.kind not in "fiu" or a.shape not in shapes:
        want = " or ".join(str(s) for s in shapes)
        raise FieldShapeError(
            f"{data.path}: {spec!r} has dtype {a.dtype} and shape {a.shape}, expected real "
            f"numbers of shape {want} (select a time with KEY[i], a function with "
            "KEY[:, j] or KEY[i, :, j])"
        )
    return a.astype(float)


def _cmd_render(args: argparse.Namespace) -> int:
    _check_outputs(args, ("-o", args.output))
    viz = _viz()
    quads = None if args.data else _quad_file(args.mesh)
    if quads is not None:  # a quad mesh: shading, wireframe, irregular vertices by valence
        kwargs = {n: getattr(args, n) for n in ("title", "backend") if getattr(args, n)}
        kwargs.update({n: tuple(getattr(args, n)) for n in ("size", "view") if getattr(args, n)})
        try:
            info = viz.render_quads(*quads, args.output, **kwargs)
        except ImportError as exc:
            raise Unavailable(" ".join(str(exc).split())) from exc
        print(f"wrote {info.path} (backend: {info.backend})")
        return EXIT_OK
    mesh = _load_mesh(args.mesh)
    kwargs, _ = _display_arrays(args, mesh)
    for name in ("arrow_scale", "cmap", "title", "backend", "max_arrows", "arrow_spacing"):
        if getattr(args, name) is not None:
            kwargs[name] = getattr(args, name)
    for name in ("clim", "size", "view"):
        if getattr(args, name) is not None:
            kwargs[name] = tuple(getattr(args, name))
    _render(viz, mesh, args.output, **kwargs)
    return EXIT_OK


def _cmd_view(args: argparse.Namespace) -> int:
    viz = _viz()
    mesh = _load_mesh(args.mesh)
    kwargs, _ = _display_arrays(args, mesh)
    try:
        viz.view(mesh, **kwargs)
    except (ImportError, viz.NoDisplayError) as exc:
        raise Unavailable(" ".join(str(exc).split())) from exc
    return EXIT_OK


def _cmd_batch(args: argparse.Namespace) -> int:
    import fvf.batch

    rows = fvf.batch.run(
        args.inputs,
        args.output,
        args.tasks,
        k=args.k,
        n=args.n,
        pairs=args.pairs,
        scheduler=args.scheduler,
        workers=args.workers,
        memory_limit=args.memory_limit,
        retries=args.retries,
        progress=not args.quiet,
        as_frame=False,
        command=args.command_line,
    )
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "skipped", "failed")}
    print(
        f"{len(rows)} jobs: {counts['ok']} ok, {counts['skipped']} skipped, "
        f"{counts['failed']} failed; summary in {Path(args.output) / 'summary.csv'}"
    )
    failed = [r for r in rows if r["status"] == "failed"]
    for r in failed[:20]:
        print(f"fvf: failed: {r['mesh']}: {r['error']}", file=sys.stderr)
    if len(failed) > 20:
        print(f"fvf: ... and {len(failed) - 20} more failed (summary.csv)", file=sys.stderr)
    return EXIT_PROBLEMS if failed else EXIT_OK


def _str(s: str) -> Any:
    import numpy as np

    return np.array(s)


def _array(x):
    import numpy as np

    return np.asarray(x, dtype=float)


# ---------------------------------------------------------------------------- parser
def _add(sub: Any, name: str, help: str, example: str) -> argparse.ArgumentParser:
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


_PROGRESS = "progress bars on stderr (tqdm); on a terminal shown anyway after 2 s"


def _add_output(p: argparse.ArgumentParser, help: str) -> None:
    """``-o/--output`` and ``--force`` (allow the output to be an input)."""
    p.add_argument("-o", "--output", required=True, help=help)
    p.add_argument(
        "--force",
        action="store_true",
        help="allow an output to replace an input file (refused by default); a link there "
        "is replaced, never written through",
    )


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
    p.add_argument(
        "--n",
        type=int,
        help="directions per face of --field: draw N strokes (default: key n, else 1)",
    )


def parser() -> argparse.ArgumentParser:
    """The argument parser of the ``fvf`` command."""
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
    _add_mesh_commands(sub)
    _add_field_commands(sub)
    _add_design_commands(sub)
    _add_correspondence_commands(sub)
    _add_picture_commands(sub)
    _add_batch(sub)
    return top


def _add_mesh_commands(sub: Any) -> None:
    """Subcommands demo, info and repair: the mesh itself."""
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
        "repair",
        "repair a mesh (fvf.repair_mesh): weld, drop unreferenced vertices, degenerate and "
        "duplicate faces, split non-manifold edges and vertices, orient; writes the index maps",
        "fvf repair scan.obj -o scan_fixed.obj   (maps: scan_fixed.maps.npz)",
    )
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    p.add_argument(
        "--tol", type=_real, default=0.0, help="weld vertices closer than this (default 0)"
    )
    _add_output(p, "repaired mesh (.obj, .off, .ply); the maps go to <stem>.maps.npz beside it")
    p.set_defaults(run=_cmd_repair)


def _add_field_commands(sub: Any) -> None:
    """Subcommands flow, bracket and transport: the chapter's operators on given fields."""
    from fvf.flows.dispatch import METHODS

    p = _add(
        sub,
        "flow",
        "flow vertex functions along a per-face field: f(t) = Phi_{v,t} f (eq. 42, fvf.flow)",
        "fvf flow mesh.obj field.npz --t 0 0.5 1 --method upwind -o flowed.npz --png f.png",
    )
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    p.add_argument("data", nargs="*", help=".npz with keys f (n,)|(n,k), v (m,3) " + _MERGE)
    p.add_argument("--t", nargs="+", metavar="T", help="times, e.g. --t 0 0.5 1 (or key t)")
    p.add_argument("--method", choices=METHODS, default="chapter", help="default: chapter")
    p.add_argument("--function", default="f", metavar="KEY", help="function key (default f)")
    p.add_argument("--field", default="v", metavar="KEY", help="field key (default v)")
    p.add_argument("--k", type=_integer, help="eigenfunctions of --method spectral (default 50)")
    p.add_argument("--dt", type=_real, help="step length of --method cayley")
    p.add_argument(
        "--growth-limit",
        type=_real_or_inf,
        help="exit 6 above this norm growth (>= 1; default 100; inf: never)",
    )
    p.add_argument("--progress", action="store_true", help=_PROGRESS)
    _add_output(p, "output .npz (keys f_t (T,n)|(T,n,k)), or .ply/.vtp/.vtu")
    p.add_argument("--png", help="also render f at the last time with the field (fvf.viz)")
    p.set_defaults(run=_cmd_flow)

    p = _add(
        sub,
        "bracket",
        "Lie bracket of two per-face fields: commutator field D^F_[v,w] X and its norm",
        "fvf bracket mesh.obj fields.npz -o bracket.npz   (fields.npz: v, u; optional f)",
    )
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    p.add_argument("data", nargs="*", help=".npz with keys v, u (m,3) [, f] " + _MERGE)
    p.add_argument("--first", default="v", metavar="KEY", help="first field key (default v)")
    p.add_argument("--second", default="u", metavar="KEY", help="second field key (default u)")
    p.add_argument("--function", metavar="KEY", help="functions to apply both brackets to")
    _add_output(p, "output .npz")
    p.set_defaults(run=_cmd_bracket)

    p = _add(
        sub,
        "transport",
        "transport a field u along v, Ad_{Phi_{v,t}} u (eq. 67), or interpolate u to u1 (68)",
        "fvf transport mesh.obj fields.npz --t 0 0.25 0.5 -o moved.npz   (keys v, u [, u1])",
    )
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    p.add_argument("data", nargs="*", help=".npz with keys v, u (m,3) [, u1] " + _MERGE)
    p.add_argument("--t", nargs="+", metavar="T", help="times (interpolation: in [0, 1])")
    p.add_argument("--field", default="v", metavar="KEY", help="flowing field key (default v)")
    p.add_argument("--transported", default="u", metavar="KEY", help="moved field (default u)")
    p.add_argument("--to", metavar="KEY", help="end field: interpolate (default u1 if present)")
    p.add_argument(
        "--growth-limit",
        type=_real_or_inf,
        help="exit 6 above this L2 growth (>= 1; default 100; inf: never)",
    )
    p.add_argument("--progress", action="store_true", help=_PROGRESS)
    _add_output(p, "output .npz (key u_t (T,m,3))")
    p.set_defaults(run=_cmd_transport)


def _add_design_commands(sub: Any) -> None:
    """Subcommands design and quad: fields designed from the mesh, and the quad mesh along them."""
    p = _add(
        sub,
        "design",
        "smoothest tangent field meeting direction constraints (fvf.design_field), "
        "and its singularities",
        "fvf design mesh.obj --constraints c.npz --soft 50 -o designed.npz\n"
        "  (c.npz: constraint_faces (k,) int or points (k,3), directions (k,3))\n"
        "fvf design mesh.obj --n 4 --align curvature -o cross.npz",
    )
    p.add_argument("mesh", help="OBJ, OFF or PLY file")
    p.add_argument("--constraints", help=".npz with constraint_faces|points, directions")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--soft", type=_real, metavar="W", help="soft weight of every constraint")
    mode.add_argument("--hard", action="store_true", help="meet the constraints exactly")
    p.add_argument("--kind", choices=("knoppel", "singer_wu"), default="knoppel")
    p.add_argument("--keep-length", action="store_true", help="don't normalize directions")
    p.add_argument(
        "--n", type=_integer, default=1, help="directions per face: 1 vector, 2 line, 4 cross, 6 …"
    )
    p.add_argument(
        "--align", choices=("curvature",), help="align to principal curvature directions (even n)"
    )
    p.add_argument("--align-strength", type=_real, metavar="B", help="alignment weight (1)")
    p.add_argument(
        "--curvature-smoothing",
        type=_real,
        metavar="L",
        help="design with the angle defect smoothed over length L (mesh units), so that "
        "spikes of a scan do not each force a cone (closed meshes)",
    )
    p.add_argument("--progress", action="store_true", help=_PROGRESS)
    _add_output(p, "output .npz (keys v, n, singularity_*)")
    p.set_defaults(run=_cmd_design)

    p = _add(
        sub,
        "quad",
        "quad mesh along a cross field: seamless parameterization and integer-grid "
        "extraction (fvf.quad_mesh)",
        "fvf quad spot.obj --faces 2000 -o spot_quads.obj --uv spot_uv.obj\n"
        "  fvf quad spot.obj --faces 2000 --field cross.npz:u -o spot_quads.obj",
    )
    p.add_argument("mesh", help="closed OBJ, OFF or PLY triangle mesh")
    p.add_argument("data", nargs="*", help=".npz data file(s) holding the --field key")
    p.add_argument("--faces", type=_integer, required=True, metavar="N", help="target quads")
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
    _add_output(p, "output quad mesh (.obj, .off, .ply, .vtu or .vtp)")
    p.add_argument("--uv", metavar="OBJ", help="also write the parameterized mesh with vt")
    p.add_argument("--png", help="also render the quad mesh (fvf.viz)")
    p.set_defaults(run=_cmd_quad)


def _add_correspondence_commands(sub: Any) -> None:
    """Subcommands match and symmetry: maps between shapes."""
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
    _add_output(p, "output .npz (keys p2p_21, C_12)")
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
    _add_output(p, "output .npz")
    p.add_argument("--png", help="also write STEM_colors.png (the mesh and its mirror colours)")
    p.set_defaults(run=_cmd_symmetry)


def _add_picture_commands(sub: Any) -> None:
    """Subcommands render and view: pictures."""
    p = _add(
        sub,
        "render",
        "render a mesh with a function, a field and singularities to PNG (fvf.viz); a "
        "pure-quad mesh is drawn with its wireframe and irregular vertices by valence",
        "fvf render mesh.obj designed.npz --field v --singularities -o field.png",
    )
    _add_display_options(p)
    _add_output(p, "output PNG")
    p.add_argument("--cmap", help="matplotlib colormap name (default viridis)")
    p.add_argument("--clim", nargs=2, type=_real, metavar=("LO", "HI"), help="color range")
    p.add_argument("--arrow-scale", type=_real, help="arrow length per unit field (absolute)")
    p.add_argument("--size", nargs=2, type=_integer, metavar=("W", "H"), help="pixels (800 600)")
    p.add_argument("--title", help="picture title")
    p.add_argument("--view", nargs=2, type=_real, metavar=("AZ", "EL"), help="camera, degrees")
    p.add_argument("--max-arrows", type=_integer, help="at most about this many arrows per view")
    p.add_argument(
        "--arrow-spacing", type=_real, help="pixels between arrows (default: 1/22 of the view)"
    )
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


def _add_batch(sub: Any) -> None:
    from fvf.batch import DEFAULT_MESH_TASKS, registered_tasks

    listing = "\n".join(
        f"  {t.name:<14} ({t.kind}) {t.description}" for t in registered_tasks().values()
    )
    p = _add(
        sub,
        "batch",
        "run tasks over many meshes in parallel on a Dask cluster (local by default); "
        "reruns skip finished meshes",
        "fvf batch scans/ 'more/*.ply' -o results/ --tasks info,basis --k 30 --workers 2\n"
        "  fvf batch scans/ -o results/ --scheduler tcp://10.0.0.5:8786\n\n"
        f"tasks:\n{listing}\n\n"
        "Results: OUT/summary.csv (one row per mesh and pair), OUT/meshes/<name>.npz,\n"
        "OUT/pairs/<a>--<b>.npz; see docs/batch.md. Exit status 1: some meshes failed.",
    )
    p.add_argument("inputs", nargs="*", help="mesh files, folders, quoted glob patterns")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="output folder")
    p.add_argument(
        "--tasks",
        help=f"comma-separated task names (default: {','.join(DEFAULT_MESH_TASKS)}, "
        "and a pair task with --pairs)",
    )
    p.add_argument("--k", type=int, default=50, help="eigenpairs of basis / fmap (default 50)")
    p.add_argument("--n", type=int, help="field symmetry N (N-fields, when supported)")
    p.add_argument("--pairs", metavar="CSV", help="mesh pairs, source,target[,map] per line")
    p.add_argument("--workers", type=int, help="local worker processes (default: one per core)")
    p.add_argument(
        "--memory-limit",
        default="auto",
        help="per local worker, e.g. 4GB (default auto: memory / workers)",
    )
    p.add_argument("--scheduler", metavar="ADDRESS", help="use a running Dask cluster")
    p.add_argument(
        "--retries", type=int, default=3, help="reruns of a job whose worker died (default 3)"
    )
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(run=_cmd_batch)


# ---------------------------------------------------------------------------- main
def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.filename is not None and exc.strerror:
        text = f"{exc.filename}: {exc.strerror}"
    else:
        text = str(exc.args[0]) if isinstance(exc, KeyError) and exc.args else str(exc)
        text = f"{type(exc).__name__}: {text}" if type(exc).__module__.startswith("fvf") else text
    return " ".join(text.split()) or type(exc).__name__


#: Python spellings in the library's messages and the command's options that say the same.
_CLI_SPELLINGS = (
    ("pass growth_limit=np.inf to accept it", "pass --growth-limit inf to accept it"),
    ("pass growth_limit=np.inf to silence this", "pass --growth-limit inf to accept it"),
    ("growth_limit=np.inf", "--growth-limit inf"),
    ("method='upwind'", "--method upwind"),
    ("raise max_products", "shorten --t"),
)


def _cli_words(text: str) -> str:
    """A library message in the command's words (its options, not Python keywords)."""
    for python, cli in _CLI_SPELLINGS:
        text = text.replace(python, cli)
    return text


def _show_warning(message, category, filename, lineno, file=None, line=None):
    from fvf.errors import FlowGrowthWarning

    if issubclass(category, FlowGrowthWarning):
        _GREW.append(str(message))
    text = f"fvf: warning: {category.__name__}: {_cli_words(' '.join(str(message).split()))}"
    if text not in _SHOWN:  # once per distinct message, wherever it was raised
        _SHOWN.add(text)
        print(text, file=sys.stderr)


_SHOWN: set[str] = set()
_GREW: list[str] = []


def main(argv: list[str] | None = None) -> int:
    """Run the ``fvf`` command with ``argv`` (default ``sys.argv[1:]``); return the exit status.

    Exit status: :data:`EXIT_OK` (0), :data:`EXIT_PROBLEMS` (1, ``info`` found problems),
    :data:`EXIT_BAD_INPUT` (2), :data:`EXIT_UNAVAILABLE` (3), :data:`EXIT_FAILED` (4),
    :data:`EXIT_WRITE_FAILED` (5), :data:`EXIT_GREW` (6, a flow grew beyond
    ``--growth-limit``; the output was written), :data:`EXIT_INTERRUPTED` (130),
    :data:`EXIT_TERMINATED` (143).
    """
    import numpy as np

    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args = parser().parse_args(argv)
    except SystemExit as exc:  # --help (0) or a usage error (2), already printed
        return int(exc.code or 0)
    args.command_line = shlex.join(["fvf", *argv])
    args.force = getattr(args, "force", False)
    _SHOWN.clear()
    _GREW.clear()
    from fvf.errors import OutputWriteError

    with warnings.catch_warnings(), _terminate_cleanly():
        warnings.simplefilter("default")
        warnings.showwarning = _show_warning
        try:
            status = args.run(args)
            if status == EXIT_OK and _GREW:
                print(
                    "fvf: error: the result grew beyond --growth-limit (see the warning); it "
                    "was written, but do not trust it: use --method upwind (bounded on every "
                    "mesh, with or without boundary), shorter times, or pass --growth-limit "
                    "inf to accept it",
                    file=sys.stderr,
                )
                return EXIT_GREW
            return status
        except Exception as exc:
            if args.debug:
                raise
            if isinstance(exc, OutputWriteError):
                status = EXIT_WRITE_FAILED
            elif isinstance(exc, (Unavailable, ImportError)):
                status = EXIT_UNAVAILABLE
            elif isinstance(exc, (FloatingPointError, np.linalg.LinAlgError, RuntimeError)):
                status = EXIT_FAILED
            elif isinstance(exc, MemoryError):
                exc = MemoryError(
                    f"out of memory ({exc or 'allocation failed'}); use a smaller "
                    "mesh, fewer times or fewer functions"
                )
                status = EXIT_FAILED
            elif isinstance(exc, (ValueError, OSError, KeyError)):
                status = EXIT_BAD_INPUT
            else:
                raise
            print(f"fvf: error: {_cli_words(_one_line(exc))}", file=sys.stderr)
            return status
        except KeyboardInterrupt:
            print("fvf: interrupted; no output was half-written", file=sys.stderr)
            return EXIT_INTERRUPTED
        except _Terminated:
            print("fvf: terminated; no output was half-written", file=sys.stderr)
            return EXIT_TERMINATED


class _terminate_cleanly:
    """While a command runs in the main thread, SIGTERM raises :class:`_Terminated` (so
    the temporary file of an output being written is removed) instead of killing the
    process outright; the previous handler is restored afterwards."""

    def __enter__(self):
        self.previous = None
        if threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGTERM, self._raise)
        return self

    @staticmethod
    def _raise(signum, frame):
        raise _Terminated()

    def __exit__(self, *exc):
        if self.previous is not None:
            signal.signal(signal.SIGTERM, self.previous)
        return False


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
