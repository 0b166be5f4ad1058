"""VTK XML for ParaView: ``.vtu`` (unstructured grid) and ``.vtp`` (poly data), written only.

``.vtu`` goes through meshio, else PyVista; ``.vtp`` through PyVista. Both are optional
(``pip install 'fvf[vtk]'``). Triangles or quads are the cells; per-vertex and per-face
arrays are point and cell data of their names (3-vectors as vectors). To read such a file,
load it with meshio or PyVista and pass it to :func:`fvf.as_mesh`.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ...errors import MissingExtraError
from ..atomic import atomic_path
from .base import MeshFormat

__all__ = ["write", "requires", "FORMAT"]


def _have(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def requires(path: Path) -> None:
    """Raise :class:`fvf.errors.MissingExtraError` when ``path`` cannot be written here:
    ``.vtu`` needs meshio or PyVista, ``.vtp`` PyVista."""
    suffix = path.suffix.lower()
    if _have("pyvista") or (suffix == ".vtu" and _have("meshio")):
        return
    need = "meshio or PyVista" if suffix == ".vtu" else "PyVista"
    raise MissingExtraError(f"{path}: writing {suffix} files needs {need}: pip install 'fvf[vtk]'")


def write(
    path: Path,
    V: np.ndarray,
    F: np.ndarray,
    vertex_data: Mapping[str, np.ndarray],
    face_data: Mapping[str, np.ndarray],
    comments: tuple[str, ...] = (),
) -> None:
    """``.vtu`` through meshio (else PyVista), ``.vtp`` through PyVista; ``F`` (m, 3) or
    (m, 4) becomes triangle or quad cells."""
    requires(path)
    suffix = path.suffix.lower()
    if suffix == ".vtu" and _have("meshio"):
        import meshio

        cell = "quad" if F.shape[1] == 4 else "triangle"
        mesh = meshio.Mesh(
            V,
            [(cell, F)],
            point_data=dict(vertex_data),
            cell_data={k: [a] for k, a in face_data.items()},
        )
        with atomic_path(path) as tmp:
            meshio.write(tmp, mesh, file_format="vtu")
        return
    import pyvista

    cells = np.column_stack([np.full(len(F), F.shape[1]), F]).ravel()
    poly = pyvista.PolyData(V, cells)
    for k, a in vertex_data.items():
        poly.point_data[k] = a
    for k, a in face_data.items():
        poly.cell_data[k] = a
    grid = poly if suffix == ".vtp" else poly.cast_to_unstructured_grid()
    with atomic_path(path) as tmp:
        grid.save(str(tmp), binary=True)


FORMAT = MeshFormat(
    name="VTK",
    suffixes=(".vtu", ".vtp"),
    read=None,
    write=write,
    vertex_data=True,
    face_data=True,
    text_start=False,
    requires=requires,
    description="VTK XML for ParaView (written only; optional extra [vtk]): triangles or "
    "quads with point and cell data",
)
