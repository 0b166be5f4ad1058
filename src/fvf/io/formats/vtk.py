"""VTK XML for ParaView: ``.vtu`` (unstructured grid) and ``.vtp`` (poly data), written only.

``.vtu`` goes through meshio, else PyVista; ``.vtp`` through PyVista. Both are optional
(``pip install 'fvf[vtk]'``). Triangles or quads are the cells; per-vertex and per-face
arrays are point and cell data of their names (3-vectors as vectors). To read such a file,
load it with meshio or PyVista and pass it to :func:`fvf.as_mesh`.
"""

from __future__ import annotations

import importlib.util
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import MissingExtraError, OutputWriteError
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
            _verify(path, tmp, len(V), len(F))
        return
    import pyvista

    cells = np.column_stack([np.full(len(F), F.shape[1]), F]).ravel()
    poly = pyvista.PolyData(V, cells)
    for k, a in vertex_data.items():
        poly.point_data[k] = a
    for k, a in face_data.items():
        poly.cell_data[k] = a
    grid = poly if suffix == ".vtp" else poly.cast_to_unstructured_grid()
    data = _vtk_xml(grid, suffix, path)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
        _verify(path, tmp, len(V), len(F))


def _vtk_xml(grid: Any, suffix: str, path: Path) -> bytes:
    """The VTK XML file of ``grid`` (binary data, base64 inline), made in memory.

    VTK's own file output aborts the process on a full disk (``free(): invalid
    pointer``); writing the bytes from Python turns that into an ``OSError`` that
    :func:`atomic_path` reports, leaving the previous file untouched.
    """
    from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter, vtkXMLUnstructuredGridWriter

    writer = vtkXMLPolyDataWriter() if suffix == ".vtp" else vtkXMLUnstructuredGridWriter()
    writer.SetInputData(grid)
    writer.SetDataModeToBinary()
    writer.WriteToOutputStringOn()
    if writer.Write() != 1:
        raise OutputWriteError(f"{path}: VTK could not format the file; nothing was written")
    return writer.GetOutputString().encode("latin-1")


def _read_counts(tmp: Path) -> tuple[int, int]:
    """(points, cells) of the VTK XML file ``tmp``, read back by the library that wrote it."""
    if _have("pyvista"):
        import pyvista

        with warnings.catch_warnings():  # a damaged file: VTK's complaint, then 0 points
            warnings.simplefilter("ignore")
            grid = pyvista.read(str(tmp))
        return int(grid.n_points), int(grid.n_cells)
    import meshio

    mesh = meshio.read(tmp, file_format="vtu")
    return len(mesh.points), sum(len(block.data) for block in mesh.cells)


def _verify(path: Path, tmp: Path, n: int, m: int) -> None:
    """Raise :class:`fvf.errors.OutputWriteError` unless ``tmp`` is a whole VTK file of
    ``n`` points and ``m`` cells.

    VTK's writers report a failed write (a full disk) on the console, not as an exception;
    reading the file back is what tells a whole file from a truncated one. The error
    leaves :func:`atomic_path` to remove ``tmp``, so ``path`` keeps its old content.
    """
    reason = ""
    try:
        if tmp.stat().st_size == 0:
            reason = "the writer wrote nothing"
        else:
            counts = _read_counts(tmp)
            if counts != (n, m):
                reason = f"it reads back as {counts[0]} points and {counts[1]} cells"
    except Exception as exc:  # any reader failure means the file is not whole
        reason = f"it cannot be read back ({type(exc).__name__}: {exc})"
    if reason:
        raise OutputWriteError(
            f"{path}: the written file is incomplete ({reason}; expected {n} points and "
            f"{m} cells): the disk may be full. Nothing was written and a file already "
            "there is unchanged. Fix: free disk space or write somewhere else."
        )


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
