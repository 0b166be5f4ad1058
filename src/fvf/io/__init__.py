"""Files: meshes (:mod:`.meshfile`: OBJ, OFF, PLY, STL read; those and VTK written) and
the data files of functions and fields (:mod:`.datafile`: the ``.npz`` schema of the
``fvf`` command).

A new mesh format is a module of :mod:`.formats` (a reader returning the file's polygons,
and/or a writer) registered in :mod:`.formats.registry` with what its files hold; a new
data format goes to :mod:`.datafile`.
"""

from ..mesh.convert import register_path_reader
from .atomic import atomic_path
from .datafile import DataFile, read_data, write_data
from .meshfile import (
    check_writable,
    read_mesh,
    read_ply_properties,
    read_quad_mesh,
    write_mesh,
    write_quad_mesh,
    write_uv_mesh,
)

# Every function taking a mesh accepts a mesh file path: the mesh layer below reads it
# through this layer's reader (docs/architecture.md).
register_path_reader(read_mesh)

__all__ = [
    "read_mesh",
    "write_mesh",
    "read_ply_properties",
    "read_quad_mesh",
    "write_quad_mesh",
    "write_uv_mesh",
    "check_writable",
    "DataFile",
    "read_data",
    "write_data",
    "atomic_path",
]

#: Names of ``__all__`` that the flat namespace ``fvf`` leaves out (reach them as
#: ``fvf.io.name``); every other name here is also ``fvf.name``.
NOT_FLAT: frozenset[str] = frozenset(
    {
        "DataFile",
        "atomic_path",
        "check_writable",
        "read_data",
        "read_ply_properties",
        "read_quad_mesh",
        "write_data",
        "write_quad_mesh",
        "write_uv_mesh",
    }
)
