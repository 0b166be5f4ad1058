"""What the commands of ``fvf`` share: exit codes, option types, input files, output checks.

Every command reads its mesh and data files through :func:`load_mesh` and :class:`Sources`,
refuses outputs that are inputs with :func:`check_outputs` before any work, and writes
through :func:`write_results` or :func:`save_npz` (whole or not at all). Nothing here
computes: the numbers come from library calls in the commands.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .. import errors as fvf_errors

if TYPE_CHECKING:
    import numpy as np

    from ..io.datafile import DataFile
    from ..mesh.prepared import PreparedMesh
    from ..mesh.trimesh import TriMesh

__all__ = [
    "EXIT_OK",
    "EXIT_PROBLEMS",
    "EXIT_BAD_INPUT",
    "EXIT_UNAVAILABLE",
    "EXIT_FAILED",
    "EXIT_GREW",
    "EXIT_WRITE_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_TERMINATED",
    "Unavailable",
    "real",
    "real_or_inf",
    "integer",
    "add_output",
    "add_display_options",
    "load_mesh",
    "load_data",
    "split_source",
    "Sources",
    "times",
    "load_viz",
    "unavailable",
    "inputs",
    "progress_option",
    "check_outputs",
    "check_output_places",
    "data_output",
    "derived_picture",
    "add_picture_options",
    "picture_options",
    "write_results",
    "render_picture",
    "save_npz",
    "match_pictures",
    "display_arrays",
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


class Unavailable(RuntimeError):
    """A feature the command needs is not available on this machine."""


def unavailable(exc: BaseException) -> Unavailable:
    """:class:`Unavailable` with the one-line message of ``exc`` (a missing extra, no
    display); raise it ``from exc``."""
    return Unavailable(" ".join(str(exc).split()))


# ---------------------------------------------------------------------------- options
#: A number on the command line: decimal, as in C (Python's float() would also take
#: "1_0" as 10, and "nan", "inf", "infinity").
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def real(text: str) -> float:
    """argparse type: a finite decimal number."""
    if _DECIMAL.fullmatch(text.strip()) is None:
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite decimal number (e.g. 0.5)")
    return float(text)


def real_or_inf(text: str) -> float:
    """argparse type: a finite decimal number or ``inf``."""
    return float("inf") if text.strip().lower() in ("inf", "+inf") else real(text)


def integer(text: str) -> int:
    """argparse type: a decimal integer (no underscores)."""
    if re.fullmatch(r"[+-]?[0-9]+", text.strip()) is None:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer (e.g. 50)")
    return int(text)


#: Help of the DATA arguments that merge several files.
MERGE = (
    "(or PLY properties); several files: a later one's keys replace an earlier one's; a key "
    "option may name its own file: --field other.npz:v"
)
#: Help of ``--progress``.
PROGRESS = "progress bars on stderr (tqdm); on a terminal shown anyway after 2 s"


def add_output(p: argparse.ArgumentParser, help: str) -> None:
    """``-o/--output`` and ``--force`` (allow the output to be an input)."""
    p.add_argument("-o", "--output", required=True, help=help)
    p.add_argument(
        "--force",
        action="store_true",
        help="allow an output to replace an input file (refused by default); a link there "
        "is replaced, never written through",
    )


#: The mesh formats the command reads (:func:`fvf.read_mesh`), for the help texts.
MESH_FORMATS = "OBJ, OFF, PLY, STL, VTK, glTF"
#: The help of a command's mesh file argument.
MESH_FILE = f"mesh file ({MESH_FORMATS})"


def add_display_options(p: argparse.ArgumentParser) -> None:
    """The mesh, data files and what to draw, of ``fvf render`` and ``fvf view``."""
    p.add_argument("mesh", help=MESH_FILE)
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
        help="directions per face of --field: draw N strokes (default: the n stored with "
        "the field, else key n, else 1)",
    )


# ---------------------------------------------------------------------------- inputs
def load_mesh(path: str) -> TriMesh:
    """The TriMesh of a mesh file; an invalid mesh's error points to ``fvf info``."""
    import fvf

    V, F = fvf.read_mesh(path)
    return checked_mesh(path, V, F)


def checked_mesh(path: str, V: Any, F: Any) -> TriMesh:
    """``TriMesh(V, F)`` of arrays read from ``path``; an invalid mesh's error names the
    file, points to ``fvf info`` and, for what it fixes, to ``fvf repair``."""
    import fvf

    try:
        return fvf.TriMesh(V, F)
    except fvf.MeshError as exc:
        hint = f"`fvf info {path}` lists every problem"
        if isinstance(exc, REPAIRABLE) and not isinstance(exc, fvf_errors.NonOrientableError):
            stem = Path(path).stem
            hint += f"; `fvf repair {path} -o {stem}_fixed.obj` fixes it"
        raise type(exc)(f"{path}: {exc} ({hint})") from exc


#: The mesh errors `fvf repair`'s default steps fix (welding, unreferenced vertices,
#: degenerate faces, non-manifold edges and vertices, orientation).
REPAIRABLE = (
    fvf_errors.DegenerateFaceError,
    fvf_errors.UnreferencedVertexError,
    fvf_errors.NonManifoldError,
    fvf_errors.OrientationError,
)


def load_data(paths: str | list[str], mesh: TriMesh) -> DataFile:
    """One data file, or several merged (a later file's key replaces an earlier's)."""
    from fvf.io.datafile import DataFile, read_data

    if isinstance(paths, str):
        return read_data(paths, mesh)
    files = [read_data(p, mesh) for p in paths]
    return files[0] if len(files) == 1 else DataFile.merged(files)


def split_source(spec: str) -> tuple[str | None, str]:
    """``FILE.npz:KEY`` -> (FILE.npz, KEY); a plain ``KEY`` -> (None, KEY)."""
    from fvf.io.datafile import MESH_DATA_SUFFIXES

    head, sep, key = spec.rpartition(":")
    if sep and Path(head).suffix.lower() in (".npz", *MESH_DATA_SUFFIXES) and key:
        return head, key
    return None, spec


class Sources:
    """The data files of a command, and keys named ``FILE.npz:KEY`` from other files
    (read on first use, checked against the mesh, listed as inputs)."""

    def __init__(self, args, mesh):
        self.mesh, self.extra = mesh, {}
        self.data = load_data(args.data, mesh) if args.data else None
        self.paths = list(args.data or [])

    def _file(self, spec: str) -> tuple[DataFile, str]:
        from fvf.io.datafile import read_data

        path, key = split_source(spec)
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
        """Whether ``spec`` names a key that can be read (a ``FILE:KEY`` always can)."""
        path, key = split_source(spec)
        if path is not None:
            return True
        return self.data is not None and key in self.data

    def field(self, spec: str) -> np.ndarray:
        """The per-face field of ``spec``: float64 (m, 3)."""
        data, key = self._file(spec)
        return data.field(key, self.mesh)

    def functions(self, spec: str) -> np.ndarray:
        """The vertex functions of ``spec``: float64 (n,) or (n, k)."""
        data, key = self._file(spec)
        return data.functions(key, self.mesh)

    def select(self, spec: str) -> tuple[DataFile, Any]:
        """The file of ``spec`` and the array it selects (``KEY[i]``, ``KEY[:, j]``)."""
        data, key = self._file(spec)
        return data, data.select(key, self.mesh.n_vertices)


def times(args, data):
    """The times of ``--t``, else the data file's ``t``: float64 (T,)."""
    import numpy as np

    if args.t:
        try:
            values = [real(x) for item in args.t for x in item.split(",") if x.strip()]
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


def load_viz():
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


def inputs(args: argparse.Namespace) -> list:
    """Every file a command reads: the mesh, the data files, the constraints, and the
    files named in ``FILE.npz:KEY`` options."""
    data = getattr(args, "data", None) or []
    data = [data] if isinstance(data, str) else list(data)
    named = [split_source(getattr(args, o, None) or "")[0] for o in _KEY_OPTIONS]
    meshes = [getattr(args, o, None) for o in ("mesh", "mesh_1", "mesh_2")]
    extra = [getattr(args, o, None) for o in ("constraints", "landmarks", "truth", "features")]
    return [*meshes, *data, *extra, *named]


def progress_option(args: argparse.Namespace) -> Any:
    """The library's ``progress`` option for a command: bars on stderr with ``--progress``;
    on a terminal also without it, for any stage running longer than 2 s; else None."""
    if getattr(args, "progress", False):
        return True
    if sys.stderr.isatty():
        from fvf.numerics.progress import make_progress

        return make_progress(True, delay=2.0)
    return None


# ---------------------------------------------------------------------------- outputs
def check_outputs(args: argparse.Namespace, *outputs: tuple[str, str | None]) -> None:
    """Refuse, before any work, outputs that are inputs (unless --force), two outputs
    that name one file (the second would replace the first), and outputs that cannot be
    written (:func:`check_output_places`: a read-only folder is exit status 5 at once), and
    pictures (``--png``) whose suffix is not a picture format's
    (:func:`fvf.io.picturefile.picture_format`)."""
    from fvf.errors import OutputError
    from fvf.io.atomic import check_not_input
    from fvf.io.picturefile import picture_format

    seen: dict[str, str] = {}
    for option, path in outputs:
        if path is not None:
            check_not_input(path, inputs(args), force=args.force, option=option)
            if option == "--png":
                picture_format(path)
            key = str(Path(path).resolve())
            if key in seen:
                raise OutputError(
                    f"{seen[key]} and {option} both name {path}: the second output would "
                    "replace the first; give them different names"
                )
            seen[key] = option
    check_output_places(*(path for _, path in outputs if path is not None))


def check_output_places(*paths: str | Path) -> None:
    """Refuse, before any work, outputs that cannot be written: a folder at the path, or
    a parent that is not a writable folder. A command writing several files calls it for
    all of them, so that none is written when another one could not be.

    Raises
    ------
    OutputWriteError
        The first such path, named with the reason.
    """
    import os

    from fvf.errors import OutputWriteError

    for path in map(Path, paths):
        parent = path.parent if str(path.parent) else Path(".")
        reason = None
        if path.is_dir():
            reason = "it is a folder"
        elif parent.exists() and not parent.is_dir():
            reason = f"{parent} is not a folder"
        elif parent.is_dir() and not os.access(parent, os.W_OK | os.X_OK):
            reason = f"the folder {parent} is not writable"
        if reason is not None:
            raise OutputWriteError(
                f"{path}: cannot write the output ({reason}); nothing was written. Fix: "
                "write somewhere else"
            )


def data_output(args: argparse.Namespace) -> tuple[str, str]:
    """``("-o", path)`` of a data file output (``.npz`` added when no data suffix)."""
    from fvf.io.datafile import data_path

    return "-o", str(data_path(args.output))


def derived_picture(path: str, what: str) -> str:
    """The name of a further picture of ``--png NAME``: ``STEM_WHAT.SUFFIX`` beside NAME
    (``map.pdf``, ``errors`` -> ``map_errors.pdf``; :func:`check_outputs` has made sure
    NAME has a picture suffix)."""
    p = Path(path)
    return str(p.with_name(f"{p.stem}_{what}{p.suffix}"))


#: The choices of ``--up``.
UP_CHOICES = ("auto", "x", "y", "z", "-x", "-y", "-z")


def add_picture_options(p: argparse.ArgumentParser, size: bool = True) -> None:
    """``--up``, ``--view AZ EL``, ``--size W H`` and ``--dpi`` of every command that
    makes a picture."""
    p.add_argument(
        "--up",
        choices=UP_CHOICES,
        default="auto",
        help="mesh axis pointing up in the picture (default auto: y, or the side the "
        "shape stands on: z, or x for a left-right symmetric body turned x-up)",
    )
    p.add_argument(
        "--view",
        nargs=2,
        type=real,
        metavar=("AZ", "EL"),
        help="camera azimuth about the up axis and elevation, degrees (default: a "
        "three-quarter view from 20 degrees up; pictures of both sides keep their "
        "second view opposite)",
    )
    if size:
        p.add_argument(
            "--size", nargs=2, type=integer, metavar=("W", "H"), help="picture size in pixels"
        )
    p.add_argument(
        "--dpi",
        type=integer,
        help="dots per inch recorded in a PNG; the page of a .pdf or .svg is W/dpi inches "
        "(default 100)",
    )


def picture_options(args: argparse.Namespace) -> dict:
    """The :class:`fvf.viz.RenderStyle` options of :func:`add_picture_options`' flags."""
    out: dict[str, Any] = {}
    if getattr(args, "up", "auto") not in (None, "auto"):
        out["up"] = args.up
    if getattr(args, "view", None):
        out["view"] = tuple(args.view)
    if getattr(args, "size", None):
        out["size"] = tuple(args.size)
    if getattr(args, "dpi", None) is not None:
        out["dpi"] = args.dpi
    return out


def write_results(args, out, arrays, mesh, inputs=()):
    """Write ``arrays`` as a data file (refusing NaN or inf) and say so on stdout."""
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


def render_picture(viz, mesh, path, **kwargs):
    """``viz.render`` to ``path``, saying which backend drew it (and why a fallback)."""
    try:
        info = viz.render(mesh, path, **kwargs)
    except ImportError as exc:  # fvf.viz.MissingExtraError
        raise unavailable(exc) from exc
    backend = getattr(info, "backend", None)
    fallback = getattr(info, "fallback", None)
    print(
        f"wrote {path}"
        + (f" (backend: {backend})" if backend else "")
        + (f"; fell back because {fallback}" if fallback else "")
    )
    return info


def save_npz(path: str, arrays: dict) -> str:
    """Write ``arrays`` (and ``fvf_version``) to ``path`` (``.npz`` added), atomically."""
    import numpy as np

    from fvf._version import __version__
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


def match_pictures(
    result: Any,
    path: str,
    mesh_2_prepared: PreparedMesh,
    names: tuple[str, str] = ("mesh 1", "mesh 2"),
    options: dict | None = None,
) -> None:
    """Transferred colours of a map (``fvf match``, ``fvf symmetry``), written to ``path``
    (``--png NAME``), the panels titled ``names``; ``options``: :func:`picture_options`."""
    viz = load_viz()
    p1, p2 = result.prepared_1, mesh_2_prepared
    p2p = p1.input_to_mesh[result.p2p_21[p2.mesh_to_input]]  # prepared 2 -> prepared 1
    try:
        viz.render_correspondence(p1.mesh, p2.mesh, p2p, path, names=names, **(options or {}))
    except ImportError as exc:
        raise unavailable(exc) from exc
    print(f"wrote {path}")


# ---------------------------------------------------------------------------- drawing
def display_arrays(args, mesh):
    """function, field and singularities to draw, from the data file and the options."""
    import fvf

    kwargs = {}
    src = Sources(args, mesh)
    data = src.data
    if args.singularities and data is None and not args.field:
        raise ValueError("--singularities needs a DATA file or a --field")
    if args.function:
        kwargs["function"] = _numbers_of(src, args.function, [(mesh.n_vertices,), (mesh.n_faces,)])
    if args.field:
        kwargs["field"] = _numbers_of(src, args.field, [(mesh.n_faces, 3), (mesh.n_vertices, 3)])
    n = args.n
    own = getattr(kwargs.get("field"), "n", None)  # a field whose file stores its n
    if n is None:
        n = own if own is not None else _stored_n(data)
    if n != 1:
        kwargs["n"] = n
    if args.singularities:
        if data is not None and "singularity_positions" in data and "singularity_indices" in data:
            pos = data.numbers("singularity_positions", (None, 3))
            idx = data.numbers("singularity_indices", (pos.shape[0],))
        elif "field" in kwargs and kwargs["field"].shape[0] == mesh.n_faces:
            ids, idx = fvf.singularities(mesh, kwargs["field"], n=n, zero="fill")
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


def _stored_n(data: Any) -> int:
    """The key ``n`` of the data files (what ``fvf design`` writes), else 1."""
    return int(data.numbers("n", ())) if data is not None and "n" in data else 1


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
