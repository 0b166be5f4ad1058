"""3MF (3D Manufacturing Format), the slicers' and CAD tools' mesh file: read and written
with the standard library (a zip archive holding an XML model).

Read: the model part the archive's ``_rels/.rels`` names (else its ``.model`` file), each
build item's object placed by the item's transform and concatenated in build order. An
object is a triangle mesh (``<vertices>`` of ``<vertex x y z>``, ``<triangles>`` of
``<triangle v1 v2 v3>``, indices from 0) or a list of ``<component>`` objects, each with its
own transform, nested to any depth. A transform is the 3 × 4 matrix ``m00 m01 m02 m10 m11
m12 m20 m21 m22 m30 m31 m32`` applied to row vectors, :math:`p' = p A + t` with
:math:`A = (m_{ij})_{i, j < 3}` and :math:`t = (m_{30}, m_{31}, m_{32})`. Coordinates
stay in the model's unit (``unit``, millimetres by default). A build item or component
that points into another model part (the production extension's ``path``) is refused;
colours, materials and other extensions are ignored. Numbers are taken from the XML by
regular expressions per attribute (no Python loop over vertices or triangles).

Written: one object of the triangles, one build item, coordinates printed with 17
significant digits (exact).
"""

from __future__ import annotations

import io
import re
import zipfile
import zlib
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ...errors import MeshReadError
from ..atomic import atomic_path
from .base import MeshFormat, Polygons

__all__ = ["read", "write", "FORMAT"]

CORE = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
MODEL_TYPE = "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"
#: The attribute text of a start tag: quoted values may hold ``>``.
_ATTRIBUTES = rb"((?:[^>\"']|\"[^\"]*\"|'[^']*')*)>"
_TAG = {
    name: re.compile(rb"<(?:\w+:)?" + name.encode() + rb"\b" + _ATTRIBUTES, re.S)
    for name in ("object", "vertex", "triangle", "component", "item", "build", "Relationship")
}
_OBJECT_END = re.compile(rb"</(?:\w+:)?object\s*>")
_COMMENT = re.compile(rb"<!--.*?-->", re.S)


def _attribute(name: str) -> re.Pattern[bytes]:
    return re.compile(rb"(?:^|\s)(?:\w+:)?" + name.encode() + rb"\s*=\s*[\"']([^\"']*)[\"']")


_ATTR = {
    n: _attribute(n)
    for n in (
        "x",
        "y",
        "z",
        "v1",
        "v2",
        "v3",
        "id",
        "objectid",
        "transform",
        "path",
        "Target",
        "Type",
    )
}


def _column(block: bytes, name: str, count: int, dtype: type, path: Path, what: str) -> np.ndarray:
    """The attribute ``name`` of the ``count`` tags in ``block``, in order: one search of
    the whole block, float64 or int64 (count,)."""
    found = _ATTR[name].findall(block)
    if len(found) != count:
        raise MeshReadError(
            f"{path}: {count} {what} tags but {len(found)} {name}= attributes; every {what} "
            f"needs exactly one: check the file, or re-export it"
        )
    return np.array(found, dtype=bytes).astype(dtype) if count else np.zeros(0, dtype)


def _model_part(path: Path, archive: zipfile.ZipFile) -> bytes:
    """The bytes of the 3D model part: the target of the root relationship of the 3D model
    type, else the archive's one ``.model`` file."""
    names = archive.namelist()
    target = None
    if "_rels/.rels" in names:
        rels = archive.read("_rels/.rels")
        for rel in _TAG["Relationship"].findall(rels):
            kind = _ATTR["Type"].findall(rel)
            if kind and kind[0].decode(errors="replace") == MODEL_TYPE:
                target = _ATTR["Target"].findall(rel)[0].decode().lstrip("/")
    if target is None:
        models = [n for n in names if n.lower().endswith(".model")]
        if len(models) != 1:
            raise MeshReadError(
                f"{path}: the archive names no 3D model part and holds {len(models)} .model "
                "files; check that this is a 3MF file, or re-export it"
            )
        target = models[0]
    if target not in names:
        raise MeshReadError(f"{path}: the 3D model part {target!r} is missing from the archive")
    return archive.read(target)


def _transform(text: bytes, path: Path) -> np.ndarray:
    """The 4 × 3 matrix (rows A, then t) of a ``transform=`` attribute (identity if none)."""
    found = _ATTR["transform"].findall(text)
    if not found:
        return np.vstack([np.eye(3), np.zeros(3)])
    m = np.array(found[0].split(), dtype=np.float64)
    if m.size != 12 or not np.all(np.isfinite(m)):
        raise MeshReadError(f"{path}: a transform has {m.size} numbers, not 12 finite ones")
    return m.reshape(4, 3)


def _objects(model: bytes, path: Path) -> dict[bytes, tuple]:
    """id -> ("mesh", V, F) or ("components", [(objectid, transform), ...])."""
    out: dict[bytes, tuple] = {}
    for head, body in _object_texts(model):
        ids = _ATTR["id"].findall(head)
        if not ids:
            raise MeshReadError(f"{path}: an <object> has no id")
        parts = _TAG["component"].findall(body)
        if parts:
            if any(_ATTR["path"].findall(p) for p in parts):
                raise MeshReadError(
                    f"{path}: object {ids[0].decode()} uses components of another model part "
                    "(3MF production extension), which fvf does not read; re-export the "
                    "model as one part"
                )
            refs = [(_ATTR["objectid"].findall(p)[0], _transform(p, path)) for p in parts]
            out[ids[0]] = ("components", refs)
            continue
        verts, tris = _block(body, b"vertices"), _block(body, b"triangles")
        nv, nt = len(_TAG["vertex"].findall(verts)), len(_TAG["triangle"].findall(tris))
        V = np.column_stack([_column(verts, c, nv, np.float64, path, "vertex") for c in "xyz"])
        F = np.column_stack(
            [_column(tris, c, nt, np.int64, path, "triangle") for c in ("v1", "v2", "v3")]
        )
        out[ids[0]] = ("mesh", V.reshape(-1, 3), F.reshape(-1, 3))
    return out


def _object_texts(model: bytes) -> list[tuple[bytes, bytes]]:
    """(attribute text, body) of each ``<object>`` (a self-closing one has no body)."""
    out = []
    for start in _TAG["object"].finditer(model):
        head = start.group(1)
        if head.rstrip().endswith(b"/"):
            out.append((head, b""))
            continue
        end = _OBJECT_END.search(model, start.end())
        out.append((head, model[start.end() : end.start() if end else len(model)]))
    return out


def _block(body: bytes, name: bytes) -> bytes:
    """The text between ``<name>`` and ``</name>`` in ``body`` (b"" when absent)."""
    found = re.search(
        rb"<(?:\w+:)?" + name + rb"\b[^>]*>(.*?)</(?:\w+:)?" + name + rb">", body, re.S
    )
    return found.group(1) if found else b""


def _placed(objects: dict, oid: bytes, M: np.ndarray, path: Path, depth: int = 0) -> list:
    """[(V, F)] of object ``oid`` placed by M (4 × 3), its components resolved."""
    if oid not in objects:
        raise MeshReadError(f"{path}: object {oid.decode()} is referred to but not defined")
    if depth > 32:
        raise MeshReadError(f"{path}: components nested deeper than 32 (a cycle?)")
    entry = objects[oid]
    if entry[0] == "mesh":
        return [(entry[1] @ M[:3] + M[3], entry[2])]
    out = []
    for child, C in entry[1]:  # a component's transform, then its parent's
        out += _placed(
            objects, child, np.vstack([C[:3] @ M[:3], C[3] @ M[:3] + M[3]]), path, depth + 1
        )
    return out


def read(path: Path, data: bytes) -> Polygons:
    """The triangles of a 3MF file's build (module docstring)."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as archive:
            model = _COMMENT.sub(b"", _model_part(path, archive))
    except (
        zipfile.BadZipFile,
        zipfile.LargeZipFile,
        NotImplementedError,
        RuntimeError,
        EOFError,
        OSError,
        zlib.error,
    ) as exc:  # not a zip, damaged, encrypted, another compression
        raise MeshReadError(
            f"{path}: cannot open it as a 3MF file (a zip archive: {type(exc).__name__}: "
            f"{exc}); check the file, or re-export it"
        ) from exc
    objects = _objects(model, path)
    build = _TAG["build"].search(model)
    after = model[build.end() :] if build else b""
    items = [(_ATTR["objectid"].findall(t), t) for t in _TAG["item"].findall(after)]
    if any(_ATTR["path"].findall(t) for _, t in items):
        raise MeshReadError(
            f"{path}: the build refers to another model part (3MF production extension), "
            "which fvf does not read; re-export the model as one part"
        )
    placed = []
    for oid, text in items:
        placed += _placed(objects, oid[0], _transform(text, path), path)
    if not placed:
        raise MeshReadError(f"{path}: the 3MF build places no object; export the mesh with it")
    offsets = np.cumsum([0] + [len(V) for V, _ in placed[:-1]])
    V = np.concatenate([V for V, _ in placed])
    bad = np.flatnonzero(~np.isfinite(V).all(axis=1))
    if bad.size:
        raise MeshReadError(
            f"{path}: vertex {bad[0]} of the build is not a finite number ({V[bad[0]]}; "
            f"{bad.size} such vertices in all): fix the coordinates or the transforms"
        )
    F = np.concatenate([F + o for (_, F), o in zip(placed, offsets, strict=True)])
    flat = F.reshape(-1)
    counts = np.full(len(F), 3, dtype=np.int64)
    return Polygons(V, counts, flat, flat, lambda i: f"triangle {i}", f"0..{len(V) - 1}")


def write(
    path: Path,
    V: np.ndarray,
    F: np.ndarray,
    vertex_data: Mapping[str, np.ndarray],
    face_data: Mapping[str, np.ndarray],
    comments: tuple[str, ...] = (),
) -> None:
    """One object of the triangles and one build item (module docstring)."""
    verts = ('<vertex x="%.17g" y="%.17g" z="%.17g"/>' * len(V)) % tuple(V.ravel().tolist())
    tris = ('<triangle v1="%d" v2="%d" v3="%d"/>' * len(F)) % tuple(F.ravel().tolist())
    model = (
        f'<?xml version="1.0" encoding="UTF-8"?>\n<model unit="millimeter" xmlns="{CORE}">'
        f'<resources><object id="1" type="model"><mesh><vertices>{verts}</vertices>'
        f"<triangles>{tris}</triangles></mesh></object></resources>"
        '<build><item objectid="1"/></build></model>'
    )
    types = (
        '<?xml version="1.0" encoding="UTF-8"?><Types xmlns="http://schemas.openxmlformats.org/'
        'package/2006/content-types"><Default Extension="rels" ContentType="application/'
        'vnd.openxmlformats-package.relationships+xml"/><Default Extension="model" '
        'ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>'
    )
    rels = (
        '<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns="http://schemas.'
        'openxmlformats.org/package/2006/relationships"><Relationship Target="/3D/'
        f'3dmodel.model" Id="rel0" Type="{MODEL_TYPE}"/></Relationships>'
    )
    with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("[Content_Types].xml", types)
        z.writestr("_rels/.rels", rels)
        z.writestr("3D/3dmodel.model", model)


FORMAT = MeshFormat(
    name="3MF",
    suffixes=(".3mf",),
    read=read,
    write=write,
    face_sizes=(3,),
    polygons=False,
    text_start=False,
    description="3D Manufacturing Format (slicers, CAD): the build's objects and "
    "components placed by their transforms; written as one object, exact",
)
