"""The registry of mesh file formats: suffix -> :class:`~fvf.io.formats.base.MeshFormat`.

:func:`fvf.read_mesh`, :func:`fvf.write_mesh` and ``fvf batch`` (which files of a folder
are meshes) ask it, so a format registered here is read, written and found everywhere.
"""

from __future__ import annotations

import os
from pathlib import Path

from ...errors import MeshFormatError, MeshReadError
from . import gltf, obj, off, ply, stl, threemf, vtk
from .base import MeshFormat

__all__ = [
    "FORMATS",
    "register_format",
    "reader_for",
    "writer_for",
    "check_writable",
    "readable_suffixes",
    "writable_suffixes",
]

#: Lower-case suffix (with the dot) -> its format, in the order of registration.
FORMATS: dict[str, MeshFormat] = {}


def register_format(fmt: MeshFormat) -> MeshFormat:
    """Register a mesh format under each of its suffixes (replacing an earlier one).

    Parameters
    ----------
    fmt : MeshFormat
        The format; its ``suffixes`` must be lower case and start with a dot.

    Returns
    -------
    MeshFormat
        ``fmt``, so that a module can write ``FORMAT = register_format(MeshFormat(...))``.
    """
    for suffix in fmt.suffixes:
        if not suffix.startswith(".") or suffix != suffix.lower():
            raise ValueError(f"format suffixes are lower case and start with '.': {suffix!r}")
        FORMATS[suffix] = fmt
    return fmt


for _format in (obj.FORMAT, off.FORMAT, ply.FORMAT, stl.FORMAT, vtk.FORMAT, vtk.LEGACY):
    register_format(_format)
register_format(gltf.FORMAT)
register_format(threemf.FORMAT)


def readable_suffixes() -> tuple[str, ...]:
    """The suffixes :func:`fvf.read_mesh` reads, e.g. ``(".obj", ".off", ".ply", ".stl")``."""
    return tuple(s for s, f in FORMATS.items() if f.read is not None)


def writable_suffixes() -> tuple[str, ...]:
    """The suffixes :func:`fvf.write_mesh` writes (some through optional packages)."""
    return tuple(s for s, f in FORMATS.items() if f.write is not None)


def reader_for(path: str | os.PathLike) -> MeshFormat:
    """The format that reads ``path`` (by its suffix, case-insensitive).

    Raises
    ------
    fvf.errors.MeshReadError
        No registered format reads files of that suffix.
    """
    path = Path(path)
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None or fmt.read is None:
        known = ", ".join(readable_suffixes())
        also = (
            f" (fvf writes {fmt.name} files but does not read them: load the file with "
            "meshio or PyVista and pass it to fvf.as_mesh)"
            if fmt is not None
            else ""
        )
        raise MeshReadError(
            f"{path}: unsupported mesh file suffix {path.suffix!r}; read_mesh reads "
            f"{known} (case-insensitive): convert the mesh or rename the file{also}"
        )
    return fmt


def writer_for(path: str | os.PathLike) -> MeshFormat:
    """The format that writes ``path`` (by its suffix, case-insensitive).

    Raises
    ------
    fvf.errors.MeshFormatError
        No registered format writes files of that suffix.
    """
    path = Path(path)
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None or fmt.write is None:
        raise MeshFormatError(
            f"{path}: cannot write {path.suffix!r} files; use one of {writable_suffixes()}"
        )
    return fmt


def check_writable(
    path: str | os.PathLike,
    face_size: int = 3,
    *,
    vertex_data: bool = False,
    face_data: bool = False,
) -> MeshFormat:
    """Check, before any work, that a mesh can be written to ``path``.

    Call it before a long computation whose result goes to ``path`` (``fvf quad -o``
    does), so that a wrong suffix fails at once rather than after the work.
    :func:`fvf.write_mesh` runs the same check before it writes anything.

    Parameters
    ----------
    path : str or os.PathLike
        The output file; its suffix (case-insensitive) selects the format.
    face_size : int
        Vertices per face of the mesh to write: 3 (triangles) or 4 (quads).
    vertex_data, face_data : bool
        Whether per-vertex / per-face arrays will be written with it.

    Returns
    -------
    MeshFormat
        The format that will write the file.

    Raises
    ------
    fvf.errors.MeshFormatError
        The suffix is not a format fvf writes, or the format cannot hold faces of
        ``face_size`` vertices (STL: triangles only) or the data asked for.
    fvf.errors.MissingExtraError
        The format needs an optional package that is not installed (``.vtu``: meshio or
        PyVista; ``.vtp``: PyVista).
    """
    path = Path(path)
    fmt = writer_for(path)
    if face_size not in fmt.face_sizes:
        can = " or ".join(str(k) for k in fmt.face_sizes)
        others = [
            s for s, f in FORMATS.items() if f.write is not None and face_size in f.face_sizes
        ]
        raise MeshFormatError(
            f"{path}: {fmt.name} files hold faces of {can} vertices, not {face_size}; write "
            f"{', '.join(others) or 'another format'} instead"
            + (" (or split each quad into two triangles)" if face_size == 4 else "")
        )
    if (vertex_data and not fmt.vertex_data) or (face_data and not fmt.face_data):
        raise MeshFormatError(
            f"{path}: {fmt.name} files cannot hold vertex or face data; write .ply (read back "
            "by fvf.io.read_data) or .vtp/.vtu (ParaView)"
        )
    if fmt.requires is not None:
        fmt.requires(path)
    return fmt
