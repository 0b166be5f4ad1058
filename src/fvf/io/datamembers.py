"""The arrays of one data file, by format: the members of an ``.npz`` archive (read on
demand, their headers checked against the stored bytes), the properties of a PLY file and
the point, cell and field data of a VTK file, under the names :mod:`fvf.io.datafile`
gives them (module docstring there)."""

from __future__ import annotations

import math
import warnings
import zipfile
from pathlib import Path

import numpy as np

from ..errors import DataFileError, MeshReadError
from .fieldorder import order_key, orders_from_comments
from .formats.base import SNIFF_BYTES
from .formats.ply import header_comments
from .inputfile import read_bytes, regular_file

__all__ = ["LazyArray", "NpzMember", "npz_members", "ply_arrays", "vtk_arrays"]


class LazyArray:
    """An array read on demand (:meth:`load`)."""

    def load(self) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError


class NpzMember(LazyArray):
    """One array of an ``.npz`` archive, read on demand (:meth:`load`)."""

    def __init__(self, path: Path, member: str, key: str) -> None:
        self.path, self.member, self.key = path, member, key

    def _fail(self, why: str) -> DataFileError:
        return DataFileError(f"{self.path}: key {self.key!r} {why}")

    def load(self) -> np.ndarray:
        """The array, after checking that its header matches the stored bytes."""
        try:
            with zipfile.ZipFile(self.path) as archive:
                info = archive.getinfo(self.member)
                with archive.open(info) as fh:
                    version = np.lib.format.read_magic(fh)
                    if version == (1, 0):
                        shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
                    else:
                        shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
                    start = fh.tell()
                if dtype.hasobject:
                    raise self._fail(
                        "holds Python objects, which fvf does not read (allow_pickle=False); "
                        "store numbers or strings"
                    )
                declared = math.prod(shape) * dtype.itemsize
                stored = info.file_size - start
                if declared != stored:
                    raise self._fail(
                        f"declares dtype {dtype} and shape {shape} ({declared} bytes) but "
                        f"holds {stored} bytes: the archive is damaged or truncated; "
                        "write it again"
                    )
                with archive.open(info) as fh:
                    return np.lib.format.read_array(fh, allow_pickle=False)
        except DataFileError:
            raise
        except MemoryError:
            raise self._fail("does not fit in memory") from None
        except (ValueError, OSError, EOFError, KeyError, zipfile.BadZipFile) as exc:
            raise self._fail(
                f"cannot be read ({type(exc).__name__}: {' '.join(str(exc).split())}); "
                "write the file again with np.savez"
            ) from exc


def npz_members(path: Path) -> dict[str, NpzMember]:
    """The keys of an ``.npz`` archive, unread."""
    regular_file(path, DataFileError)
    if read_bytes(path, DataFileError, head=6) == b"\x93NUMPY":
        raise DataFileError(
            f"{path}: holds a single array, not an .npz archive of named arrays; "
            "save it with np.savez(path, f=..., v=...)"
        )
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise DataFileError(
            f"{path}: cannot read it as an .npz archive ({type(exc).__name__}: "
            f"{' '.join(str(exc).split())}); write it with np.savez(path, f=..., v=...)"
        ) from exc
    members = {}
    for name in names:
        key = name[:-4] if name.endswith(".npy") else name
        members[key] = NpzMember(path, name, key)
    return members


def ply_arrays(path: Path) -> dict[str, np.ndarray]:
    """Functions and fields from PLY properties (see the module docstring)."""
    from .meshfile import PolygonTriangulatedWarning, read_mesh, read_ply_properties

    try:
        vertex, face = read_ply_properties(path)
        with warnings.catch_warnings():  # reported when the file is read as the mesh
            warnings.simplefilter("ignore", PolygonTriangulatedWarning)
            X, F = read_mesh(path)
    except MeshReadError as exc:
        raise DataFileError(str(exc)) from exc
    _check_property_names(path, vertex, face)
    arrays: dict[str, np.ndarray] = dict(vertex)
    arrays.update(vertices=X, faces=F)  # the PLY's own mesh: checked against the mesh used
    comments = header_comments(read_bytes(path, DataFileError, head=SNIFF_BYTES))
    for name, n in orders_from_comments(comments).items():
        arrays[order_key(name)] = np.asarray(n, dtype=np.int64)
    for name, values in face.items():
        arrays.setdefault(name, values)
    for name in list(face):
        if name.endswith("x") and len(name) > 1:
            base = name[:-1]
            triple = [base + c for c in "xyz"]
            if all(k in face for k in triple) and base not in vertex:
                arrays[base] = np.column_stack([face[k] for k in triple])
    return arrays


#: Keys of fvf's data files that are no per-vertex or per-face values: a PLY property of
#: one of these names would be read as that (a vertex property ``t`` as 162 flow times).
RESERVED_KEYS = ("t", "vertices", "faces", "layout", "inputs", "command", "mesh_path")


def _check_property_names(path: Path, vertex: dict, face: dict) -> None:
    """Refuse PLY properties named as a reserved key, or on both elements (a vertex ``f``
    hid a face ``f``): :class:`DataFileError` naming them and the fix."""
    for element, props in (("vertex", vertex), ("face", face)):
        clash = sorted(set(props) & set(RESERVED_KEYS))
        if clash:
            raise DataFileError(
                f"{path}: the {element} properties {clash} have names fvf's data files keep "
                "for other things (t: the times; vertices, faces: the mesh); rename them"
            )
    both = sorted(set(vertex) & set(face))
    if both:
        raise DataFileError(
            f"{path}: {both} name both a vertex and a face property, and one key can hold "
            "only one of them; rename one"
        )


def vtk_arrays(path: Path) -> dict[str, np.ndarray]:
    """Functions and fields from the point, cell and field data of a VTK file: each array
    under its name, rows aligned with :func:`fvf.read_mesh`'s vertices and faces (a
    polygon's row repeated for each of its fan triangles), ``vertices`` and ``faces``."""
    from .formats.vtk import read_arrays
    from .meshfile import PolygonTriangulatedWarning, read_mesh

    try:
        vtk = read_arrays(path)
        with warnings.catch_warnings():  # reported when the file is read as the mesh
            warnings.simplefilter("ignore", PolygonTriangulatedWarning)
            X, F = read_mesh(path)
    except MeshReadError as exc:
        raise DataFileError(str(exc)) from exc
    rows = vtk.polygons.counts - 2  # read_mesh's fan triangles per polygon
    arrays: dict[str, np.ndarray] = {}
    for name, a in vtk.point_data.items():
        arrays[name] = np.asarray(a)
    for name, a in vtk.cell_data.items():
        arrays.setdefault(name, np.repeat(np.asarray(a), rows, axis=0))
    for name, a in vtk.field_data.items():
        if name.startswith("n_") and np.asarray(a).size == 1:
            arrays[name] = np.asarray(a).reshape(())
    arrays.update(vertices=X, faces=F)  # the file's own mesh: checked against the mesh used
    return arrays
