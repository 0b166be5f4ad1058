"""Files: mesh formats (:mod:`.meshfile`: OBJ, OFF, PLY) and the data files of functions
and fields (:mod:`.datafile`: the ``.npz`` schema of the ``fvf`` command).

A new mesh format goes to :mod:`.meshfile` (a reader returning float64 (n, 3) vertices and
int64 (m, 3) faces, and a writer); a new data format to :mod:`.datafile`.
"""

from .atomic import atomic_path
from .datafile import DataFile, read_data, write_data
from .meshfile import (
    read_mesh,
    read_ply_properties,
    read_quad_mesh,
    write_mesh,
    write_quad_mesh,
    write_uv_mesh,
)

__all__ = [
    "read_mesh",
    "write_mesh",
    "read_ply_properties",
    "read_quad_mesh",
    "write_quad_mesh",
    "write_uv_mesh",
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
        "read_data",
        "read_ply_properties",
        "read_quad_mesh",
        "write_data",
        "write_quad_mesh",
        "write_uv_mesh",
    }
)
