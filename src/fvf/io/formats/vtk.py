"""VTK for ParaView: ``.vtu`` (unstructured grid) and ``.vtp`` (poly data) written and
read, legacy ``.vtk`` read.

Written: ``.vtu`` through meshio, else PyVista; ``.vtp`` through PyVista. Both are
optional (``pip install 'fvf[vtk]'``). Triangles or quads are the cells; per-vertex and
per-face arrays are point and cell data of their names (3-vectors as vectors), stored as
float64 in binary, so reading them back is exact; the N of an :class:`fvf.NField` is the
field data array ``n_<name>`` (:mod:`fvf.io.fieldorder`).

Read (:func:`read`, :func:`read_arrays`): through PyVista, else meshio (``.vtu`` and
``.vtk`` only); the surface cells (triangles, quads, polygons) in file order, their
point, cell and field data. Other cells (lines, vertices, volume cells) are refused by
name; a volume mesh's surface is ``pyvista.read(path).extract_surface()``, passed to
:func:`fvf.as_mesh`.
"""

from __future__ import annotations

import contextlib
import importlib.util
import warnings
from collections.abc import Iterator, Mapping
from contextlib import nullcontext
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ...errors import MeshReadError, MissingExtraError, OutputWriteError
from ..atomic import atomic_path
from ..fieldorder import orders_from_comments
from .base import MeshFormat, Polygons

__all__ = ["write", "read", "read_arrays", "VtkArrays", "requires", "FORMAT", "LEGACY"]

#: VTK cell types of surface cells: triangle, polygon, quad.
_SURFACE_CELLS = {5: "triangle", 7: "polygon", 9: "quad"}


def _have(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def requires(path: Path) -> None:
    """Raise :class:`fvf.errors.MissingExtraError` when ``path`` cannot be written here:
    ``.vtu`` needs meshio or PyVista, ``.vtp`` and ``.vtk`` PyVista."""
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
    """``.vtu`` through meshio (else PyVista), ``.vtp`` and legacy ``.vtk`` (binary)
    through PyVista; ``F`` (m, 3) or (m, 4) becomes triangle or quad cells."""
    requires(path)
    suffix = path.suffix.lower()
    orders = orders_from_comments(comments)
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
            if orders:  # meshio writes no field data: add it to the XML
                tmp.write_bytes(_with_field_data(tmp.read_bytes(), orders))
            _verify(path, tmp, len(V), len(F))
        return
    import pyvista

    cells = np.column_stack([np.full(len(F), F.shape[1]), F]).ravel()
    poly = pyvista.PolyData(V, cells)
    for k, a in vertex_data.items():
        poly.point_data[k] = a
    for k, a in face_data.items():
        poly.cell_data[k] = a
    for k, n in orders.items():
        poly.field_data[f"n_{k}"] = np.array([n], dtype=np.int64)
    grid = poly if suffix in (".vtp", ".vtk") else poly.cast_to_unstructured_grid()
    data = _vtk_xml(grid, suffix, path)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
        _verify(path, tmp, len(V), len(F))


def _with_field_data(xml: bytes, orders: Mapping[str, int]) -> bytes:
    """The VTK XML file ``xml`` with the field data arrays ``n_<key>`` (one Int64 each)."""
    arrays = "".join(
        f'<DataArray type="Int64" Name="n_{k}" NumberOfTuples="1" format="ascii">{n}</DataArray>\n'
        for k, n in orders.items()
    )
    tag = b"<UnstructuredGrid>"
    at = xml.find(tag)
    if at < 0:  # not the file meshio writes: leave it (the fields stay, without n)
        return xml
    at += len(tag)
    return xml[:at] + f"\n<FieldData>\n{arrays}</FieldData>".encode("ascii") + xml[at:]


def _vtk_xml(grid: Any, suffix: str, path: Path) -> bytes:
    """The VTK XML file of ``grid`` (binary data, base64 inline), made in memory.

    VTK's own file output aborts the process on a full disk (``free(): invalid
    pointer``); writing the bytes from Python turns that into an ``OSError`` that
    :func:`atomic_path` reports, leaving the previous file untouched.
    """
    if suffix == ".vtk":
        from vtkmodules.vtkIOLegacy import vtkPolyDataWriter

        legacy = vtkPolyDataWriter()
        legacy.SetInputData(grid)
        legacy.SetFileTypeToBinary()
        legacy.WriteToOutputStringOn()
        if legacy.Write() != 1:
            raise OutputWriteError(f"{path}: VTK could not format the file; nothing was written")
        out = legacy.GetOutputStdString()
        return out if isinstance(out, bytes) else out.encode("latin-1")
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
    read=lambda path, data: read(path),
    write=write,
    vertex_data=True,
    face_data=True,
    text_start=False,
    requires=requires,
    description="VTK XML for ParaView (optional extra [vtk]): triangles or quads with "
    "point and cell data, written and read",
)

LEGACY = MeshFormat(
    name="legacy VTK",
    suffixes=(".vtk",),
    read=lambda path, data: read(path),
    write=write,
    vertex_data=True,
    face_data=True,
    text_start=False,
    requires=requires,
    description="legacy VTK (optional extra [vtk]; written binary through PyVista): "
    "surface cells with point and cell data",
)


# ---------------------------------------------------------------------------- reading
class VtkArrays(NamedTuple):
    """What :func:`read_arrays` finds in a VTK file."""

    polygons: Polygons
    point_data: dict[str, np.ndarray]  # (n,) or (n, k) each
    cell_data: dict[str, np.ndarray]  # (c,) or (c, k) each, one row per polygon
    field_data: dict[str, np.ndarray]


def _reader(path: Path) -> str:
    """ "pyvista" or "meshio": the library that reads ``path`` here, else raise."""
    if _have("pyvista"):
        return "pyvista"
    if path.suffix.lower() in (".vtu", ".vtk") and _have("meshio"):
        return "meshio"
    need = "PyVista" if path.suffix.lower() == ".vtp" else "meshio or PyVista"
    raise MissingExtraError(
        f"{path}: reading {path.suffix} files needs {need}: pip install 'fvf[vtk]'"
    )


def _cells_pyvista(path: Path, grid: Any) -> tuple[np.ndarray, np.ndarray]:
    """(cell types, flat [k, i0, .., k, ...] connectivity) of a PyVista dataset."""
    import pyvista

    if isinstance(grid, pyvista.PolyData):
        if grid.n_verts or grid.n_lines or grid.n_strips:
            raise MeshReadError(
                f"{path}: the file holds points, lines or strips besides polygons; "
                "read_mesh reads surface meshes (triangles, quads, polygons)"
            )
        return np.full(grid.n_cells, 7), np.asarray(grid.faces, dtype=np.int64)
    if not isinstance(grid, pyvista.UnstructuredGrid):
        raise MeshReadError(
            f"{path}: a VTK {type(grid).__name__}, not a surface mesh; load it with "
            "pyvista, take .extract_surface().triangulate() and pass it to fvf.as_mesh"
        )
    return np.asarray(grid.celltypes, dtype=np.int64), np.asarray(grid.cells, dtype=np.int64)


def _polygons(path: Path, V: np.ndarray, types: np.ndarray, flat: np.ndarray) -> Polygons:
    """The polygons of a flat ``[k, i0, .., k, ...]`` array, after checking the cell types."""
    bad = np.flatnonzero(~np.isin(types, list(_SURFACE_CELLS)))
    if bad.size:
        raise MeshReadError(
            f"{path}: cell {bad[0]} has VTK cell type {types[bad[0]]} ({bad.size} cells that "
            "are not triangles, quads or polygons): read_mesh reads surface meshes. Fix: "
            "pyvista.read(path).extract_surface().triangulate(), passed to fvf.as_mesh"
        )
    counts = np.zeros(types.size, dtype=np.int64)
    starts = np.zeros(types.size, dtype=np.int64)
    pos = 0
    if types.size:  # the counts lie every k+1 entries: walk them without a Python loop
        heads = np.zeros(flat.size, dtype=bool)
        while True:  # at most one pass per distinct cell size run
            sizes = flat[pos : pos + 1]
            if sizes.size == 0:
                break
            k = int(sizes[0])
            if k < 1:
                raise MeshReadError(f"{path}: a cell of {k} points in the connectivity")
            run = flat[pos :: k + 1]
            same = np.flatnonzero(run != k)
            stop = run.size if same.size == 0 else int(same[0])
            heads[pos : pos + stop * (k + 1) : k + 1] = True
            pos += stop * (k + 1)
        at = np.flatnonzero(heads)
        counts, starts = flat[at], at + 1
    if counts.size != types.size:
        raise MeshReadError(f"{path}: the cell connectivity does not match the cell count")
    index = np.repeat(starts - np.cumsum(np.r_[0, counts[:-1]]), counts) + np.arange(counts.sum())
    verts = flat[index]
    return Polygons(
        np.ascontiguousarray(V, dtype=np.float64),
        counts,
        verts,
        verts,
        lambda i: f"cell {i}",
        f"0..{len(V) - 1}",
    )


@contextlib.contextmanager
def _no_root_logging() -> Iterator[None]:
    """VTK's reader errors reach ``logging.error`` on the root logger, which installs a
    console handler when the root has none ("ERROR:root:No update piece number ..." on
    stderr before fvf's own message): a null handler is the root's for the read."""
    import logging

    root = logging.getLogger()
    null = logging.NullHandler() if not root.handlers else None
    if null is not None:
        root.addHandler(null)
    try:
        yield
    finally:
        if null is not None:
            root.removeHandler(null)


def _read_pyvista(path: Path) -> VtkArrays:
    """Read through PyVista; an error VTK reports (it only logs them: a damaged file reads
    as an empty one) is a MeshReadError quoting it, and VTK's console log stays quiet."""
    import pyvista

    quiet = getattr(pyvista, "vtk_verbosity", None)
    catcher = pyvista.VtkErrorCatcher(raise_errors=True, send_to_logging=False)
    try:
        with (
            warnings.catch_warnings(),
            quiet("off") if quiet else nullcontext(),
            catcher,
            _no_root_logging(),
        ):
            warnings.simplefilter("ignore")
            grid = pyvista.read(str(path))
    except RuntimeError as exc:  # pyvista's VTKExecutionError: what VTK's reader said
        said = [ln for ln in str(exc).splitlines() if ln.strip() and not ln.startswith("ERROR:")]
        raise MeshReadError(
            f"{path}: VTK cannot read this file ({(said or [str(exc)])[0][:160]}): it is "
            "damaged or truncated, or not a VTK file of its suffix; re-export it"
        ) from exc
    types, flat = _cells_pyvista(path, grid)
    poly = _polygons(path, np.asarray(grid.points), types, flat)
    return VtkArrays(
        poly,
        {k: np.asarray(grid.point_data[k]) for k in grid.point_data.keys()},
        {k: np.asarray(grid.cell_data[k]) for k in grid.cell_data.keys()},
        {k: np.asarray(grid.field_data[k]) for k in grid.field_data.keys()},
    )


_MESHIO_TYPES = {"triangle": 5, "quad": 9, "polygon": 7}


def _read_meshio(path: Path) -> VtkArrays:
    import meshio

    mesh = meshio.read(path)
    types: list[np.ndarray] = []
    flats: list[np.ndarray] = []
    for block in mesh.cells:
        data = np.asarray(block.data, dtype=np.int64)
        code = 7 if block.type.startswith("polygon") else _MESHIO_TYPES.get(block.type, -1)
        types.append(np.full(len(data), code))
        flats.append(np.column_stack([np.full(len(data), data.shape[1]), data]).ravel())
    flat = np.concatenate(flats) if flats else np.zeros(0, dtype=np.int64)
    poly = _polygons(path, np.asarray(mesh.points), np.concatenate(types), flat)
    if poly.vertices.shape[1] == 2:
        flat2d = poly.vertices
        poly = poly._replace(vertices=np.column_stack([flat2d, np.zeros(len(flat2d))]))
    return VtkArrays(
        poly,
        {k: np.asarray(a) for k, a in mesh.point_data.items()},
        {k: np.concatenate([np.asarray(b) for b in a]) for k, a in mesh.cell_data.items()},
        {k: np.asarray(a) for k, a in mesh.field_data.items()},
    )


def read_arrays(path: Path) -> VtkArrays:
    """The polygons and the point, cell and field data of a VTK file (``.vtu``, ``.vtp``,
    ``.vtk``), through PyVista, else meshio (module docstring).

    Raises
    ------
    MissingExtraError
        Neither library is installed (``.vtp``: PyVista is not).
    MeshReadError
        The file cannot be read, or holds cells other than triangles, quads and polygons.
    """
    path = Path(path)
    reader = _reader(path)
    try:
        out = _read_pyvista(path) if reader == "pyvista" else _read_meshio(path)
    except (MeshReadError, MissingExtraError):
        raise
    except Exception as exc:  # the libraries raise anything on a damaged file
        raise MeshReadError(
            f"{path}: {reader} cannot read this file ({type(exc).__name__}: {exc}); check "
            "that it is a valid VTK file, or re-export it"
        ) from exc
    if out.polygons.vertices.ndim != 2 or out.polygons.vertices.shape[1] != 3:
        raise MeshReadError(f"{path}: the points are not 3-D ({out.polygons.vertices.shape})")
    return out


def read(path: Path) -> Polygons:
    """The polygons of a VTK file (:func:`read_arrays`), for :func:`fvf.read_mesh`."""
    return read_arrays(path).polygons
