"""Functions and fields in files: the ``.npz`` schema of the ``fvf`` command, and PLY properties.

The ``fvf`` subcommands read a mesh (OBJ, OFF, PLY) and a *data file* holding functions
and fields on it, and write their results as another data file. A data file is an
uncompressed or compressed NumPy ``.npz`` archive (``numpy.savez``), read with
``allow_pickle=False``, so only plain numeric and string arrays are allowed. Keys:

| key        | dtype, shape          | meaning                                        |
|------------|-----------------------|------------------------------------------------|
| `f`        | float, (n,) or (n, k) | vertex (PL) function(s), one column per function|
| `v`        | float, (m, 3)         | per-face tangent field (ambient xyz per face)  |
| `u`        | float, (m, 3)         | a second field: bracket partner, or transported|
| `u1`       | float, (m, 3)         | end field of an interpolation (eq. 68)         |
| `t`        | float, () or (T,)     | times, when the command line gives none        |
| `n_<key>`  | int, ()               | the N of the N-field under `key` (`n` for `v`) |
| `vertices` | float, (n, 3)         | optional copy of the mesh's vertices           |
| `faces`    | int, (m, 3)           | optional copy of the mesh's faces (0-based)    |

Rows follow the mesh file's vertex and face order: one layout everywhere, the library's,
with the mesh's elements along the first axis and one column per function (results over
times add a leading time axis: ``f_t`` is (T, n) or (T, n, k)). Files written by fvf
before this layout (and files made by hand that way) stored several functions as rows,
(k, n) and (T, k, n); they are still read, transposed, with a
:class:`~fvf.errors.LegacyLayoutWarning` (only when the shape says so unambiguously: k != n).
Files that fvf writes now say ``layout = "columns"`` and are never transposed.

``v`` is the field that flows or transports (or the first of a bracket); ``u`` is the
bracket's partner w, the transported field u (eq. 67) or u_0 (eq. 68). When ``vertices``
/ ``faces`` are present they must match the mesh (faces exactly, vertices to
:data:`MESH_MATCH_RTOL` of its size), so data are never applied to the wrong mesh.

Design constraints (``fvf design --constraints C.npz``, :func:`fvf.design_field`):

| key                | dtype, shape      | meaning                                         |
|--------------------|-------------------|-------------------------------------------------|
| `constraint_faces` | int, (k,)         | the constrained faces                           |
| `directions`       | float, (k, 3)     | ambient directions, projected onto their faces  |
| `points`           | float, (k, 3)     | ambient points instead of `constraint_faces`    |
| `barycentric`      | float, (k, 3)     | optional with `constraint_faces`: checked points|
| `weights`          | float, () or (k,) | optional soft weights (> 0)                     |

A constraint given by a point applies to the face nearest the point
(:func:`fvf.closest_faces`); barycentric rows must be >= 0 and sum to 1
(:func:`fvf.locate_points`).

Non-tangent fields are projected onto the face planes with a
:class:`~fvf.errors.NonTangentFieldWarning` (:func:`fvf.as_face_field`).

What the commands write back: their results (see ``docs/cli.md``), the inputs they used
(under the same keys), a copy of the mesh (``vertices``, ``faces``) and the provenance
strings ``fvf_version``, ``command`` (the command line), ``mesh_path`` (absolute) and
``inputs`` (absolute paths of the data files read, shape (j,)), plus ``created_utc``.

A PLY file can serve as a data file too (:func:`fvf.io.meshfile.read_ply_properties`): each scalar
vertex property other than x, y, z becomes a function of that name (n,), each scalar face
property a per-face function (m,), and each triple of face properties ``<p>x, <p>y, <p>z``
a per-face field ``<p>`` (m, 3) — so ``vx vy vz`` is the field ``v``; the PLY's own
vertices and faces become ``vertices`` and ``faces``, so they must match the mesh used.

Several data files can be combined with :meth:`DataFile.merged` (a later file's key
replaces an earlier one's), as the commands do when given several files.

Every problem raises a typed :class:`~fvf.errors.FvfError` naming the file and the key:
:class:`DataFileError` (unreadable file), :class:`DataKeyError` (a missing key, listing
the keys present), :class:`~fvf.errors.FieldShapeError` (wrong dtype or shape, with the
expected shape), :class:`MeshMismatchError` (the stored mesh copy differs from the mesh).
"""

from __future__ import annotations

import datetime
import os
import re
import warnings
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from .._version import __version__
from ..errors import (  # noqa: F401 (re-exported)
    DataFileError,
    DataKeyError,
    FieldShapeError,
    FvfError,
    InputOverwriteError,
    LegacyLayoutWarning,
    MeshMismatchError,
    MeshReadError,
    user_stacklevel,
)
from ..mesh.convert import MeshLike, as_mesh
from ..mesh.inputs import as_direction_count, as_face_field, as_vertex_function
from ..mesh.nfield import NField
from ..mesh.trimesh import TriMesh
from .atomic import atomic_path, check_not_input
from .datamembers import LazyArray, npz_members, ply_arrays, vtk_arrays
from .fieldorder import order_key, orders_of

__all__ = [
    "DataFile",
    "read_data",
    "write_data",
    "data_path",
    "mesh_properties",
    "element_of",
    "FACE_KEYS",
    "MESH_MATCH_RTOL",
    "MESH_DATA_SUFFIXES",
]

#: Stored ``vertices`` must match the mesh's to this fraction of the bounding-box diagonal.
MESH_MATCH_RTOL = 1e-9

_SELECT = re.compile(r"^(?P<key>[^\[\]]+)(\[(?P<index>\s*(-?\d+|:)\s*(,\s*(-?\d+|:)\s*)*)\])?$")


class DataFile(Mapping):
    """The arrays of one data file, with checked access by key.

    A read-only mapping ``key -> numpy.ndarray``; the accessors check dtype and shape
    against a mesh and name the file, the key, its shape and the expected shape in every
    error.

    Parameters
    ----------
    arrays : mapping of str to array_like
    path : str or os.PathLike
        Where the arrays came from (used in messages).
    sources : mapping of str to path, optional
        The file of each key, when they come from several files (:meth:`merged`).
    """

    def __init__(
        self,
        arrays: Mapping[str, Any],
        path: str | os.PathLike,
        sources: Mapping[str, str | os.PathLike] | None = None,
        columns: Iterable[Path] = (),
    ):
        self.path = Path(path)
        self._arrays = {
            k: a if isinstance(a, LazyArray) else np.asarray(a) for k, a in arrays.items()
        }
        self._sources = {k: Path(v) for k, v in (sources or {}).items()}
        self._columns: set[Path] = set(columns)
        for k, a in self._arrays.items():  # arrays given in memory (PLY, VTK properties)
            if not isinstance(a, LazyArray):
                self._arrays[k] = self._with_order(k, a)

    @classmethod
    def merged(cls, files: Sequence[DataFile]) -> DataFile:
        """The keys of several data files in one, a later file's key replacing an earlier's.

        Lets a command take, say, a designed field from one file and functions from another.
        Each file's mesh copy has been checked on reading; messages name each key's file.
        """
        arrays: dict[str, np.ndarray | LazyArray] = {}
        sources: dict[str, Path] = {}
        columns: set[Path] = set()
        for data in files:
            columns |= data._columns
            for key in data:  # unread keys stay unread (a key is loaded when used)
                arrays[key], sources[key] = data._arrays[key], data.source(key)
        return cls(arrays, " + ".join(str(d.path) for d in files), sources, columns)

    def source(self, key: str) -> Path:
        """The file that ``key`` came from."""
        return self._sources.get(key, self.path)

    def _at(self, key: str) -> str:
        return f"{self.source(key)}: key {key!r}"

    def __getitem__(self, key: str) -> np.ndarray:
        if key not in self._arrays:
            have = ", ".join(sorted(self._arrays)) or "none"
            raise DataKeyError(
                f"{self.path}: no key {key!r} (keys present: {have}); add it, e.g. "
                f"np.savez(path, {key}=...), or pick another key"
            )
        a = self._arrays[key]
        if isinstance(a, LazyArray):
            a = self._arrays[key] = self._with_order(key, a.load())
        return a

    def order(self, key: str) -> int | None:
        """The N stored for the field ``key`` (:mod:`fvf.io.fieldorder`: the key
        ``n_<key>``, or ``n`` for ``v``), None when the file stores none."""
        name = order_key(key)
        if name in self._arrays:
            value = np.asarray(self[name])
            if value.shape not in ((), (1,)):
                raise FieldShapeError(f"{self._at(name)} must be one integer, the N of {key!r}")
            return as_direction_count(value.item(), self._at(name))
        if key == "v" and "n" in self._arrays:  # what fvf design writes for its field v
            value = np.asarray(self["n"])
            if value.size == 1 and value.dtype.kind in "iuf" and float(value.item()) >= 1:
                if float(value.item()).is_integer():
                    return int(value.item())
        return None

    def _with_order(self, key: str, a: np.ndarray) -> np.ndarray:
        """``a`` as an :class:`fvf.NField` when it is a field whose N the file stores."""
        if a.ndim not in (2, 3) or a.shape[-1] != 3 or a.dtype.kind not in "biuf":
            return a
        n = self.order(key)
        return a if n is None else NField(a, n)

    def __contains__(self, key: object) -> bool:
        return key in self._arrays

    def __iter__(self) -> Iterator[str]:
        return iter(self._arrays)

    def __len__(self) -> int:
        return len(self._arrays)

    def __repr__(self) -> str:
        shapes = ", ".join(
            f"{k}: {'(not read yet)' if isinstance(a, LazyArray) else f'{a.dtype}{a.shape}'}"
            for k, a in self._arrays.items()
        )
        return f"DataFile({str(self.path)!r}, {{{shapes}}})"

    def _numeric(self, key: str, a: np.ndarray, what: str) -> np.ndarray:
        if a.dtype == object or not (
            np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)
        ):
            raise FieldShapeError(
                f"{self._at(key)} must hold real numbers ({what}); got dtype {a.dtype} "
                f"with shape {a.shape}"
            )
        return a.astype(np.float64)

    def select(self, spec: str, n: int | None = None) -> np.ndarray:
        """The array named by ``spec``: a key, optionally indexed, e.g. ``"f_t[2]"``.

        Parameters
        ----------
        spec : str
            ``KEY`` or ``KEY[i]`` or ``KEY[i, j]`` (integer indices, negative allowed; ``:``
            keeps an axis, e.g. ``f_t[2, :, 0]``: time 2, function 0).
        n : int, optional
            The mesh's vertex count: arrays in the legacy row layout are then read in
            the columns layout first (:meth:`migrated`).

        Returns
        -------
        numpy.ndarray
            The (indexed) array, as stored.

        Raises
        ------
        DataKeyError
            Unknown key, or ``spec`` not of the form above.
        FieldShapeError
            An index out of range (naming the key's shape).
        """
        match = _SELECT.match(spec.strip())
        if match is None:
            raise DataKeyError(
                f"{self.path}: cannot read {spec!r} as KEY or KEY[i] or KEY[i,j] (e.g. f_t[2])"
            )
        key = match["key"].strip()
        a = self[key] if n is None else self.migrated(key, n)
        if match["index"] is None:
            return a
        index = tuple(
            slice(None) if i.strip() == ":" else int(i) for i in match["index"].split(",")
        )
        if len(index) > a.ndim or any(
            not isinstance(i, slice) and not -s <= i < s
            for i, s in zip(index, a.shape, strict=False)
        ):
            raise FieldShapeError(
                f"{self.source(key)}: index {list(index)} is outside key {key!r} of shape "
                f"{a.shape}; indices select along its leading axes"
            )
        return a[index]

    def check_mesh(self, mesh: TriMesh) -> None:
        """Check the stored ``vertices`` / ``faces`` copies (when present) against ``mesh``.

        Raises
        ------
        FieldShapeError
            A copy has the wrong shape.
        MeshMismatchError
            Faces differ, or vertices differ by more than :data:`MESH_MATCH_RTOL` times the
            bounding-box diagonal (naming the first offending rows).
        """
        from ..errors import format_indices

        if "faces" in self:
            F = self.integers("faces", (None, 3))
            if F.shape != mesh.faces.shape:
                raise MeshMismatchError(
                    f"{self._at('faces')} has shape {F.shape} but the mesh has "
                    f"{mesh.faces.shape}: the data belong to another mesh; pass that mesh"
                )
            bad = np.flatnonzero((F != mesh.faces).any(axis=1))
            if bad.size:
                raise MeshMismatchError(
                    f"{self._at('faces')} differs from the mesh's faces at rows "
                    f"{format_indices(bad)}: the data belong to another mesh (or a reordered "
                    "one); pass that mesh"
                )
        if "vertices" in self:
            X = self._numeric("vertices", self["vertices"], "vertex positions")
            if X.shape != mesh.vertices.shape:
                raise MeshMismatchError(
                    f"{self._at('vertices')} has shape {X.shape} but the mesh has "
                    f"{mesh.vertices.shape}: the data belong to another mesh; pass that mesh"
                )
            size = float(np.ptp(mesh.vertices, axis=0).max()) or 1.0
            bad = np.flatnonzero(~(np.abs(X - mesh.vertices) <= MESH_MATCH_RTOL * size).all(axis=1))
            if bad.size:
                raise MeshMismatchError(
                    f"{self._at('vertices')} differs from the mesh's vertices at rows "
                    f"{format_indices(bad)}: the data belong to another mesh; pass that mesh"
                )

    def functions(self, key: str, mesh: TriMesh) -> np.ndarray:
        """Vertex function(s) under ``key``: float64 (n,) or (n, k), one column per function.

        Raises
        ------
        DataKeyError, FieldShapeError
            Missing key; wrong dtype, shape or non-finite values.

        Warns
        -----
        LegacyLayoutWarning
            The key holds (k, n) with k != n, the layout of older files: it is transposed.
        """
        a = self._numeric(key, self[key], "vertex functions")
        n = mesh.n_vertices
        if a.ndim == 2 and a.shape[1] == n and a.shape[0] != n and not self.columns(key):
            a = _legacy(self._at(key), a, a.T, f"({n}, {a.shape[0]})")
        if not ((a.ndim == 1 and a.shape[0] == n) or (a.ndim == 2 and a.shape[0] == n)):
            hint = ""
            if a.shape[-1:] == (mesh.n_faces,) or a.shape[:1] == (mesh.n_faces,):
                hint = "; it has one value per face: fvf needs one per vertex"
            elif a.ndim == 2 and a.shape[1] == n:
                hint = "; it looks like (k, n): store the transpose, one column per function"
            raise FieldShapeError(
                f"{self._at(key)} has shape {a.shape}, expected ({n},) or ({n}, k): "
                f"vertex functions, one value per mesh vertex{hint}"
            )
        as_vertex_function(mesh, a, f"{self._at(key)}", columns=True)
        return a

    def columns(self, key: str) -> bool:
        """Whether ``key``'s file says its arrays have the columns layout (written by fvf
        with ``layout = "columns"``): then it is never transposed."""
        source = self.source(key)
        return source in self._columns

    def migrated(self, key: str, n: int) -> np.ndarray:
        """``self[key]``, with the legacy row layout (k, n) / (T, k, n) of a file without
        ``layout = "columns"`` transposed to (n, k) / (T, n, k) (warning once)."""
        a = self[key]
        if self.columns(key) or a.ndim < 2 or a.shape[-1] != n or a.shape[-2] == n:
            return a
        want = a.shape[:-2] + (n, a.shape[-2])
        return _legacy(self._at(key), a, np.swapaxes(a, -1, -2), str(want))

    def field(self, key: str, mesh: TriMesh) -> np.ndarray:
        """A per-face tangent field under ``key``: float64 (m, 3), projected onto the faces;
        an :class:`fvf.NField` when the file stores its N (:meth:`order`).

        Raises
        ------
        DataKeyError, FieldShapeError
            Missing key; wrong dtype, shape or non-finite values.

        Warns
        -----
        NonTangentFieldWarning
            The field had a normal component (it is projected away).
        """
        a = self._numeric(key, self[key], "a per-face field")
        m = mesh.n_faces
        if a.shape != (m, 3):
            hint = ""
            if a.shape == (mesh.n_vertices, 3):
                hint = "; it has one vector per vertex: convert with fvf.vertex_to_face_values"
            raise FieldShapeError(
                f"{self._at(key)} has shape {a.shape}, expected ({m}, 3): one ambient "
                f"xyz vector per mesh face{hint}"
            )
        u = as_face_field(mesh, a, f"{self._at(key)}")
        n = self.order(key)
        return u if n is None else NField(u, n)

    def times(self, key: str = "t") -> np.ndarray:
        """Times under ``key``: float64 (T,) (a scalar becomes (1,)).

        Raises
        ------
        DataKeyError, FieldShapeError
            Missing key; not a finite scalar or 1-D array.
        """
        a = self._numeric(key, self[key], "times")
        if a.ndim > 1 or a.size == 0 or not np.isfinite(a).all():
            raise FieldShapeError(
                f"{self._at(key)} must hold finite times, shape () or (T,); got shape {a.shape}"
            )
        return np.atleast_1d(a)

    def integers(self, key: str, shape: tuple[int | None, ...]) -> np.ndarray:
        """Integer indices under ``key`` of the given shape (None: any length): int64."""
        a = self[key]
        if not np.issubdtype(a.dtype, np.integer) or not _fits(a.shape, shape):
            raise FieldShapeError(
                f"{self._at(key)} has dtype {a.dtype} and shape {a.shape}, expected "
                f"integers of shape {_shape_text(shape)}"
            )
        return a.astype(np.int64)

    def numbers(self, key: str, shape: tuple[int | None, ...]) -> np.ndarray:
        """Real numbers under ``key`` of the given shape (None: any length): float64."""
        a = self._numeric(key, self[key], f"shape {_shape_text(shape)}")
        if not _fits(a.shape, shape):
            raise FieldShapeError(
                f"{self._at(key)} has shape {a.shape}, expected {_shape_text(shape)}"
            )
        return a


def _fits(shape: tuple[int, ...], want: tuple[int | None, ...]) -> bool:
    return len(shape) == len(want) and all(
        w is None or s == w for s, w in zip(shape, want, strict=True)
    )


def _shape_text(want: tuple[int | None, ...]) -> str:
    inner = ", ".join("k" if w is None else str(w) for w in want)
    return f"({inner},)" if len(want) == 1 else f"({inner})"


def read_data(path: str | os.PathLike, mesh: MeshLike | None = None) -> DataFile:
    """Read a data file (``.npz``, or ``.ply`` properties) and check it against a mesh.

    An ``.npz`` key is read when it is first used (``data[key]``), so keys a command does
    not use cost nothing, whatever they hold; each key's stored header (dtype, shape) is
    checked against its size in the archive before any memory is allocated for it.

    Parameters
    ----------
    path : str or os.PathLike
        An ``.npz`` archive with the keys of this module's schema, a ``.ply`` file whose
        vertex/face properties become functions and fields (see the module docstring), or
        a VTK file (``.vtu``, ``.vtp``, ``.vtk``; PyVista or meshio) whose point and cell
        data do. It must be a regular file (not a FIFO or a device). A field whose N the
        file stores (:mod:`fvf.io.fieldorder`) is read as an :class:`fvf.NField`.
    mesh : TriMesh or any :data:`fvf.MeshLike`, optional
        When given, the stored mesh copies (``vertices``, ``faces``) must match it.

    Returns
    -------
    DataFile
        The arrays by key.

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    DataFileError
        The file is not a regular file or not a readable ``.npz`` (or ``.ply``) file; a
        key holds object arrays, declares more data than it holds, or does not fit in
        memory (raised when the key is read).
    MeshMismatchError
        The stored mesh copy differs from ``mesh``.
    """
    mesh = None if mesh is None else as_mesh(mesh)
    path = Path(path)
    if path.suffix.lower() == ".ply":
        arrays: dict[str, Any] = ply_arrays(path)
        columns = [path]  # PLY properties are columns
    elif path.suffix.lower() in (".vtu", ".vtp", ".vtk"):
        arrays, columns = vtk_arrays(path), [path]
    else:
        members = npz_members(path)
        arrays = dict(members)
        layout = members.get("layout")
        columns = [path] if layout is not None and str(layout.load()) == "columns" else []
    data = DataFile(arrays, path, columns=columns)
    if mesh is not None:
        data.check_mesh(mesh)
    return data


def _legacy(where: str, a: np.ndarray, moved: np.ndarray, shape: str) -> np.ndarray:
    warnings.warn(
        f"{where} has shape {a.shape}, the layout of files from older fvf versions (one row "
        f"per function); it was read as {shape}, one column per function. Fix: save it "
        "again with the functions as columns (fvf now writes layout='columns').",
        LegacyLayoutWarning,
        stacklevel=user_stacklevel(),
    )
    return moved


def _strings(values: Iterable[str]) -> np.ndarray:
    return np.array([str(v) for v in values], dtype=str)


def write_data(
    path: str | os.PathLike,
    arrays: Mapping[str, npt.ArrayLike],
    *,
    mesh: MeshLike,
    mesh_path: str | os.PathLike,
    command: str,
    inputs: Iterable[str | os.PathLike] = (),
    overwrite_inputs: bool = False,
    kinds: Mapping[str, str] | None = None,
) -> Path:
    """Write results as an ``.npz`` data file, with a mesh copy and their provenance.

    The file is written whole or not at all (:func:`fvf.io.atomic.atomic_path`), and never
    onto the mesh file or a data file it was computed from.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; ``.npz`` is appended when missing (as ``numpy.savez`` does). Parent
        folders are created.
    arrays : mapping of str to array_like
        The results and the inputs used, by schema key.
    mesh : TriMesh or any :data:`fvf.MeshLike`
        Stored as ``vertices`` (float64 (n, 3)) and ``faces`` (int64 (m, 3)).
    mesh_path : str or os.PathLike
        Stored (absolute) as the string ``mesh_path``.
    command : str
        The command line, stored as ``command``.
    inputs : iterable of path
        Data files read, stored (absolute) as the string array ``inputs`` (j,).
    overwrite_inputs : bool
        Allow ``path`` to be ``mesh_path`` or one of ``inputs`` (default: refuse).
    kinds : mapping of str to {"vertex", "face"}, optional
        For a mesh file output (PLY, VTK) of a mesh with as many vertices as faces: the
        element each key belongs to (default :func:`element_of`).

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    InputOverwriteError
        ``path`` is the mesh file or an input (also through a link), and
        ``overwrite_inputs`` is false.
    OutputWriteError
        The file could not be written (disk full, ...); a file already there is unchanged.
    """
    mesh = as_mesh(mesh)
    path = data_path(path)
    inputs = list(inputs)
    check_not_input(path, [mesh_path, *inputs], force=overwrite_inputs)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = {k: a if isinstance(a, NField) else np.asarray(a) for k, a in arrays.items()}
    provenance = dict(
        fvf_version=__version__,
        command=command,
        mesh_path=str(Path(mesh_path).resolve()),
        created_utc=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    )
    if path.suffix.lower() != ".npz":
        return _write_mesh_data(path, out, mesh, provenance, kinds)
    for key, n in orders_of(out).items():  # the N of each N-field (fvf.io.fieldorder)
        out[key] = out[key].view(np.ndarray)
        out[order_key(key)] = np.asarray(n, dtype=np.int64)
    out.update(
        vertices=np.asarray(mesh.vertices, dtype=np.float64),
        faces=np.asarray(mesh.faces, dtype=np.int64),
        fvf_version=np.array(__version__),
        command=np.array(command),
        mesh_path=np.array(str(Path(mesh_path).resolve())),
        inputs=_strings(str(Path(p).resolve()) for p in inputs),
        created_utc=np.array(provenance["created_utc"]),
        layout=np.array("columns"),
    )
    with atomic_path(path) as tmp:
        np.savez(tmp, **out)  # type: ignore[arg-type]  # numpy's stub types **kwds as bool
    return path


#: Suffixes of the mesh formats :func:`write_data` writes results into, as properties.
MESH_DATA_SUFFIXES = (".ply", ".vtp", ".vtu", ".vtk")


def data_path(path: str | os.PathLike) -> Path:
    """The file :func:`write_data` writes for ``path``: ``.npz`` appended unless the
    suffix is ``.npz`` or one of :data:`MESH_DATA_SUFFIXES`."""
    path = Path(path)
    if path.suffix.lower() in (".npz", *MESH_DATA_SUFFIXES):
        return path
    return path.with_name(path.name + ".npz")


#: Keys of fvf's results that hold one value per face (tangent fields ``v``, ``u``,
#: ``w``, ``field``, and any key ending ``_face``): the element they are written to when a
#: mesh has as many vertices as faces, so that their length cannot tell.
FACE_KEYS = frozenset({"v", "u", "w", "field", "fields"})


def element_of(key: str, kinds: Mapping[str, str] | None = None) -> str:
    """``"vertex"`` or ``"face"``: where the array ``key`` belongs when its length does not
    tell (``kinds[key]`` when given, else :data:`FACE_KEYS` and the ``_face`` suffix; a
    key with a time or function index, ``v_3``, is the key before it)."""
    if kinds is not None and key in kinds:
        if kinds[key] not in ("vertex", "face"):
            raise DataFileError(
                f"the kind of {key!r} must be 'vertex' or 'face', not {kinds[key]!r}"
            )
        return kinds[key]
    base = re.sub(r"(_\d+)+$", "", key)
    return "face" if base in FACE_KEYS or base.endswith("_face") else "vertex"


#: Keys that are never mesh properties, whatever their length: the times ``t`` (T,)
#: (when T = n they would pass for a vertex function).
NOT_PROPERTIES = frozenset({"t"})

#: Keys of vertex functions: an (n, k) array is k functions ``key_<j>``, also for k = 3
#: (which would otherwise be written as a vector ``keyx keyy keyz``).
FUNCTION_KEYS = frozenset({"f", "functions", "eigenfunctions"})


def mesh_properties(
    arrays: Mapping[str, np.ndarray], mesh: TriMesh, kinds: Mapping[str, str] | None = None
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], list[str]]:
    """Per-vertex and per-face arrays among a command's results, as mesh properties.

    (n,) and (n, 3) arrays become vertex properties, (m,) and (m, 3) face properties (a
    3-vector ``p`` is ``px py pz``); arrays with a leading time (and function) axis are
    split into ``key_<i>`` (``key_<i>_<j>``; a key ending ``_t`` is split along its time
    axis first, even when T = n); the functions of :data:`FUNCTION_KEYS` (n, k) into
    ``key_<j>``; the times ``t`` are never a property; ``singularity_vertices`` with
    ``singularity_indices`` become the vertex property ``singularity_index`` (0 elsewhere).
    When n = m the length cannot tell: the element is :func:`element_of` the key (``kinds``,
    else the per-face keys :data:`FACE_KEYS` and ``*_face``; every other key per vertex).
    Returns (vertex properties, face properties, keys left out).
    """
    n, m = mesh.n_vertices, mesh.n_faces
    vertex: dict[str, np.ndarray] = {}
    face: dict[str, np.ndarray] = {}
    left: list[str] = []

    def put(name: str, a: np.ndarray) -> bool:
        base = re.sub(r"(_\d+)+$", "", name)
        if a.dtype.kind not in "biuf" or name in NOT_PROPERTIES:
            return False
        if base.endswith("_t") and a.ndim >= 2 and name == base:  # (T, ...): times first
            return all(put(f"{name}_{i}", a[i]) for i in range(a.shape[0]))
        functions = base in FUNCTION_KEYS or base.removesuffix("_t") in FUNCTION_KEYS
        if functions and a.ndim == 2 and a.shape[0] == n:  # (n, k) functions
            return all(put(f"{name}_{j}", a[:, j]) for j in range(a.shape[1]))
        if a.shape in ((n,), (n, 3)) and a.shape in ((m,), (m, 3)):  # n = m
            (face if element_of(name, kinds) == "face" else vertex)[name] = a
        elif a.shape in ((n,), (n, 3)):
            vertex[name] = a
        elif a.shape in ((m,), (m, 3)):
            face[name] = a
        elif a.ndim == 2 and a.shape[0] == n:  # (n, k): one column per function
            for j in range(a.shape[1]):
                vertex[f"{name}_{j}"] = a[:, j]
        elif a.ndim >= 2 and a.shape[0] <= 4096:  # a leading axis: times (or functions)
            return all(put(f"{name}_{i}", a[i]) for i in range(a.shape[0]))
        else:
            return False
        return True

    for key, a in arrays.items():
        if key in ("vertices", "faces", "singularity_vertices", "singularity_positions"):
            continue
        if key == "singularity_indices" and "singularity_vertices" in arrays:
            mark = np.zeros(n)
            mark[np.asarray(arrays["singularity_vertices"], dtype=np.int64)] = a
            vertex["singularity_index"] = mark
        elif not put(key, a if isinstance(a, NField) else np.asarray(a)):
            left.append(key)
    return vertex, face, left


def _write_mesh_data(
    path: Path, arrays: dict, mesh: TriMesh, provenance: dict, kinds: Mapping[str, str] | None
) -> Path:
    """The results as properties of the mesh (PLY, VTK), provenance as PLY comments."""
    from .meshfile import write_mesh

    vertex, face, left = mesh_properties(arrays, mesh, kinds)
    comments = [f"fvf {k}: {v}" for k, v in provenance.items()]
    if left:
        comments.append(f"fvf keys not stored (no value per vertex or face): {', '.join(left)}")
    write_mesh(
        path,
        mesh.vertices,
        mesh.faces,
        vertex_data=vertex,
        face_data=face,
        comments=tuple(comments),
    )
    return path
