"""glTF 2.0: ``.glb`` (binary) and ``.gltf`` (JSON, buffers embedded), through trimesh.

Read: every triangle mesh of the file's scene, placed by the scene's transforms and
concatenated (``trimesh.load(path, force="mesh", process=False)``), then the vertices that
glTF stores once per seam (a vertex split where its normal or texture coordinates jump)
welded: vertices at exactly equal positions become the first of them, the others keep
their order, with a :class:`fvf.errors.VerticesWeldedWarning` saying how many. Written:
the triangles as one mesh (glTF stores float32 positions, so a round trip is exact for
float32 coordinates only; no vertex or face data). Both need trimesh
(``pip install trimesh``), else :class:`fvf.errors.MissingExtraError`.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ...errors import MeshReadError, MeshReadWarning, MissingExtraError, VerticesWeldedWarning
from ..atomic import atomic_path
from .base import MeshFormat, Polygons

__all__ = ["read", "write", "requires", "FORMAT", "weld_equal"]


def requires(path: Path) -> None:
    """Raise :class:`fvf.errors.MissingExtraError` unless trimesh is installed."""
    if importlib.util.find_spec("trimesh") is None:
        raise MissingExtraError(
            f"{path}: reading or writing {path.suffix} files needs trimesh: pip install trimesh"
        )


def weld_equal(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Vertices at exactly equal positions merged into the first of them (file order kept
    for the rest): (vertices (n', 3), faces, number merged). One sort, no loop."""
    X = V + 0.0  # -0.0 -> 0.0
    _, first, inverse = np.unique(X, axis=0, return_index=True, return_inverse=True)
    if first.size == len(V):
        return V, F, 0
    keep = np.sort(first)
    rank = np.empty(len(V), dtype=np.int64)
    rank[keep] = np.arange(keep.size)
    new_index = rank[first[inverse.reshape(-1)]]
    return V[keep], new_index[F], len(V) - keep.size


def read(path: Path, data: bytes) -> Polygons:
    """The welded triangles of a glTF file's scene (module docstring)."""
    requires(path)
    import trimesh

    try:
        mesh = trimesh.load(str(path), force="mesh", process=False)
    except Exception as exc:  # trimesh raises anything on a damaged file
        raise MeshReadError(
            f"{path}: trimesh cannot read this glTF file ({type(exc).__name__}: {exc}); "
            "check the file, or re-export it"
        ) from exc
    V = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=np.float64)
    F = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64).reshape(-1, 3)
    skipped = _unread_primitives(data)
    if skipped and F.size == 0:
        raise MeshReadError(
            f"{path}: the file's primitives are {skipped}, which trimesh does not read as "
            "triangles; re-export the mesh with triangles (glTF mode 4)"
        )
    V, F, merged = weld_equal(V, F)
    notes: tuple[tuple[type[Warning], str], ...] = ()
    if merged:
        notes = (
            (
                VerticesWeldedWarning,
                f"{path}: welded {merged} glTF vertices at exactly the position of an "
                f"earlier one (glTF splits vertices at seams); {len(V)} vertices left",
            ),
        )
    if skipped:
        notes += (
            (
                MeshReadWarning,
                f"{path}: left out primitives of the file: {skipped} (only triangles, "
                "mode 4, are read); re-export them as triangles",
            ),
        )
    flat = F.reshape(-1)
    counts = np.full(len(F), 3, dtype=np.int64)
    return Polygons(V, counts, flat, flat, lambda i: f"triangle {i}", f"0..{len(V) - 1}", notes)


#: glTF primitive modes other than TRIANGLES (4), by number.
OTHER_MODES = {
    0: "POINTS",
    1: "LINES",
    2: "LINE_LOOP",
    3: "LINE_STRIP",
    5: "TRIANGLE_STRIP",
    6: "TRIANGLE_FAN",
}


def _unread_primitives(data: bytes) -> str:
    """The primitives of a glTF file's JSON (``.gltf`` text or a ``.glb`` file's first
    chunk) in modes other than TRIANGLES, counted by mode ("2 TRIANGLE_FAN"); "" when
    there are none or the JSON cannot be read (trimesh then judges the file)."""
    import json
    from collections import Counter

    text = data
    if data[:4] == b"glTF" and len(data) >= 20:
        size = int.from_bytes(data[12:16], "little")
        text = data[20 : 20 + size]
    try:
        meshes = json.loads(text).get("meshes", [])
        modes = [p.get("mode", 4) for m in meshes for p in m.get("primitives", [])]
    except (ValueError, AttributeError, TypeError):
        return ""
    counts = Counter(OTHER_MODES.get(m, f"mode {m}") for m in modes if m != 4)
    return ", ".join(f"{n} {name}" for name, n in sorted(counts.items()))


def write(
    path: Path,
    V: np.ndarray,
    F: np.ndarray,
    vertex_data: Mapping[str, np.ndarray],
    face_data: Mapping[str, np.ndarray],
    comments: tuple[str, ...] = (),
) -> None:
    """One triangle mesh, ``.glb`` binary or ``.gltf`` with embedded buffers."""
    requires(path)
    import trimesh
    from trimesh.exchange import gltf

    mesh = trimesh.Trimesh(V, F, process=False)
    if path.suffix.lower() == ".glb":
        data = gltf.export_glb(mesh)
    else:
        data = next(iter(gltf.export_gltf(mesh, embed_buffers=True).values()))
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


FORMAT = MeshFormat(
    name="glTF",
    suffixes=(".glb", ".gltf"),
    read=read,
    write=write,
    face_sizes=(3,),
    polygons=False,
    text_start=False,
    requires=requires,
    description="glTF 2.0 through trimesh: the scene's triangles, welded at seams; "
    "written as one mesh (float32 positions)",
)
