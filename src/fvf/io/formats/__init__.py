"""Mesh file formats, one module each, behind one registry.

| suffix | module | reads | writes | vertex / face data |
|--------|--------|-------|--------|--------------------|
| `.obj` | `fvf.io.formats.obj` | polygons | triangles, quads | no |
| `.off` | `fvf.io.formats.off` | polygons | triangles, quads | no |
| `.ply` | `fvf.io.formats.ply` | polygons, scalar properties | triangles, quads | yes |
| `.stl` | `fvf.io.formats.stl` | triangles (welded soup) | triangles (binary) | no |
| `.vtu`, `.vtp` | `fvf.io.formats.vtk` | surface cells (PyVista, meshio) | triangles, quads | yes |
| `.vtk` | `fvf.io.formats.vtk` | surface cells (PyVista, meshio) | triangles, quads | yes |
| `.glb`, `.gltf` | `fvf.io.formats.gltf` | triangles (trimesh, welded) | triangles | no |

The functions users call are in :mod:`fvf.io.meshfile` (:func:`fvf.read_mesh`,
:func:`fvf.write_mesh`, :func:`fvf.io.check_writable`). A new format is a module here
with ``read(path, data) -> Polygons`` and/or ``write(path, V, F, vertex_data, face_data,
comments)`` and a ``FORMAT = MeshFormat(...)`` stating what its files hold, registered in
:mod:`~fvf.io.formats.registry`.
"""

from .base import MeshFormat, Polygons
from .registry import (
    FORMATS,
    check_writable,
    readable_suffixes,
    reader_for,
    register_format,
    writable_suffixes,
    writer_for,
)

__all__ = [
    "MeshFormat",
    "Polygons",
    "FORMATS",
    "register_format",
    "reader_for",
    "writer_for",
    "check_writable",
    "readable_suffixes",
    "writable_suffixes",
]
