"""PLY (Stanford polygon file): ascii, binary little endian and binary big endian.

Read: the ``vertex`` element's x y z, the ``face`` element's ``vertex_indices`` (or
``vertex_index``) list, polygons of any size, and every scalar property of both elements
(:func:`parse`; functions and fields next to the mesh). Written as binary little endian
with double properties, so a round trip is exact: per-vertex and per-face arrays become
properties (a 3-vector ``v`` the three properties ``vx vy vz``), and comments carry
provenance. For MeshLab, which shows only its standard properties, each element with
data also gets ``quality`` and ``red green blue``: a picture of its first array
(:func:`ply_bytes`), which fvf's readers recognise and leave out.
"""

from __future__ import annotations

import re
import struct
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...errors import MeshReadError
from ..atomic import atomic_write_bytes
from ._text import numbers, text_lines
from .base import BOM, MeshFormat, Polygons

__all__ = [
    "read",
    "parse",
    "write",
    "ply_bytes",
    "picture_of",
    "picture_elements",
    "PICTURE",
    "FORMAT",
]

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}  # fmt: skip
_PLY_FORMATS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}
FACE_LISTS = ("vertex_indices", "vertex_index")
_STRUCT = {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I"}


def sniff(path: Path, head: bytes) -> None:
    """Refuse, from its first bytes, a file that does not start with ``ply``."""
    head = head.removeprefix(BOM)
    if head[:3] != b"ply" and head.strip():
        first = head[:40].split(b"\n")[0].decode("latin-1").strip()
        raise MeshReadError(
            f"{path}: line 1: a PLY file starts with 'ply', not {first!r}; is it a PLY file?"
        )


class _Prop(NamedTuple):
    name: str
    code: str  # numpy type code without byte order, e.g. "f4"
    count: str | None  # type: ignore[assignment]  # type code of a list's length, None for scalars


class _Element(NamedTuple):
    name: str
    size: int
    props: list[_Prop]


def _ply_header(path: Path, data: bytes) -> tuple[str, list[_Element], int, int]:
    """Parse the header: ``(format, elements, byte offset of the body, its line number)``.

    Header lines end with LF, CRLF or (old Mac files) CR alone, as the first line does.
    """
    lines: list[str] = []
    pos = 0
    eol = b"\r" if data[3:4] == b"\r" and data[4:5] != b"\n" else b"\n"
    while not lines or lines[-1] != "end_header":
        nl = data.find(eol, pos)
        if nl < 0:
            raise MeshReadError(
                f"{path}: the PLY header has no 'end_header' line; the file is truncated or "
                "not a PLY file"
            )
        lines.append(data[pos:nl].decode("latin-1").strip())
        pos = nl + 1
        if lines[0] != "ply":
            raise MeshReadError(f"{path}: line 1: a PLY file starts with 'ply', not {lines[0]!r}")
    fmt, elements = None, []
    for ln, line in enumerate(lines[1:-1], 2):
        w = line.split()
        kind = w[0] if w else "comment"
        if kind in ("comment", "obj_info"):
            continue
        if kind == "format" and len(w) == 3 and w[1] in _PLY_FORMATS:
            fmt = w[1]
        elif kind == "element" and len(w) == 3 and w[2].isascii() and w[2].isdigit():
            elements.append(_Element(w[1], int(w[2]), []))
        elif kind == "property" and elements and len(w) == 3 and w[1] in _PLY_TYPES:
            elements[-1].props.append(_Prop(w[2], _PLY_TYPES[w[1]], None))
        elif (kind == "property" and elements and len(w) == 5 and w[1] == "list"
              and _PLY_TYPES.get(w[2], "f")[0] in "iu" and w[3] in _PLY_TYPES):  # fmt: skip
            elements[-1].props.append(_Prop(w[4], _PLY_TYPES[w[3]], _PLY_TYPES[w[2]]))
        else:
            raise MeshReadError(
                f"{path}: line {ln}: cannot understand the PLY header line {line[:60]!r}; "
                f"expected 'format <{'|'.join(_PLY_FORMATS)}> 1.0', 'element <name> <count>' "
                "or 'property [list <count type>] <type> <name>' with types "
                f"{', '.join(_PLY_TYPES)}"
            )
    if fmt is None:
        raise MeshReadError(f"{path}: the PLY header has no 'format' line; add one")
    for el in elements:
        names = [p.name for p in el.props]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise MeshReadError(
                f"{path}: the PLY element '{el.name}' declares the property "
                f"{twice[0]!r} twice; rename or delete one of them in the header"
            )
    return fmt, elements, pos, len(lines) + 1


def header_comments(data: bytes) -> list[str]:
    """The text of the ``comment`` lines of a PLY header (empty when there is no header)."""
    end = data.find(b"end_header")
    if end < 0:
        return []
    lines = data[:end].decode("latin-1").replace("\r", "\n").split("\n")
    return [ln.strip()[7:].strip() for ln in lines if ln.strip().startswith("comment")]


def read(path: Path, data: bytes) -> Polygons:
    """The vertices and polygons of a PLY file (see the module docstring)."""
    values, where, face_list = parse(path, data)
    vertices = np.column_stack([values["vertex"][c] for c in "xyz"]).astype(np.float64)
    counts, flat = values["face"][face_list]
    return Polygons(vertices, counts, flat, flat, where, f"0..{len(vertices) - 1}")


def parse(path: Path, data: bytes) -> tuple[dict, Callable[[int], str], str]:
    """Check and parse a PLY file: ``({element: {property: values}}, where, face list name)``.

    Scalar properties are 1-D arrays; the face index list is ``(counts, flat)``.
    """
    fmt, elements, pos, line0 = _ply_header(path, data)
    byname: dict[str, _Element] = {}
    for el in elements:
        byname.setdefault(el.name, el)
    if "vertex" not in byname:
        raise MeshReadError(f"{path}: the PLY header declares no 'vertex' element; add one")
    xyz = {p.name: p for p in byname["vertex"].props if p.count is None}
    if not {"x", "y", "z"} <= set(xyz):
        has = [f"list {p.name}" if p.count else p.name for p in byname["vertex"].props]
        raise MeshReadError(
            f"{path}: the PLY 'vertex' element needs scalar properties x, y and z; "
            f"it has {has}: declare them 'property float x' (not lists) in the header"
        )
    face = byname.get("face")
    lists = [p.name for p in face.props if p.count and p.name in FACE_LISTS] if face else []
    if not lists:
        raise MeshReadError(
            f"{path}: the PLY file has no 'face' element with a 'vertex_indices' (or "
            "'vertex_index') list property, so it has no faces; read_mesh needs a surface mesh"
        )
    assert face is not None
    index = next(p for p in face.props if p.name == lists[0])
    if index.code[0] not in "iu":  # float indices would be truncated silently
        raise MeshReadError(
            f"{path}: the PLY face list '{index.name}' holds {index.code} numbers, not "
            "integers; vertex indices must be an integer type (int, uint, ...): fix the header"
        )
    if fmt == "ascii":
        values, where = _ply_ascii(path, data[pos:], elements, line0)
    else:
        values, where = _ply_binary(path, data, pos, elements, _PLY_FORMATS[fmt])
    return values, where, lists[0]


def _ply_ascii(
    path: Path, body: bytes, elements: list[_Element], line0: int
) -> tuple[dict, Callable[[int], str]]:
    """Parse an ascii PLY body: one element record per non-blank line."""
    lines = text_lines(body)
    at = [i for i, line in enumerate(lines) if line.strip()]
    values: dict[str, dict] = {}
    cursor, face_line = 0, []
    for el in elements:
        chunk = at[cursor : cursor + el.size]
        if len(chunk) < el.size:
            raise MeshReadError(
                f"{path}: the ascii PLY body ends after {len(chunk)} of the {el.size} "
                f"'{el.name}' lines; the file is truncated or the header count is wrong"
            )
        cursor += el.size
        if el.name not in ("vertex", "face") or el.name in values:
            continue
        # every scalar property (read_ply_properties wants them) and the face index list
        keep: dict[str, list[list[str]]] = {
            p.name: []
            for p in el.props
            if p.count is None or (el.name == "face" and p.name in FACE_LISTS)
        }
        lineno = [i + line0 for i in chunk]
        for i, ln in zip(chunk, lineno, strict=True):
            t, c = lines[i].split(), 0
            for p in el.props:
                if p.count is None:
                    v, c = t[c : c + 1], c + 1
                else:
                    n = int(t[c]) if c < len(t) and re.fullmatch("[0-9]+", t[c]) else -1
                    if n < 0:
                        raise MeshReadError(
                            f"{path}: line {ln}: the list length of '{el.name}' property "
                            f"'{p.name}' must be a non-negative integer, not {t[c : c + 1]}"
                        )
                    v, c = t[c + 1 : c + 1 + n], c + 1 + n
                if p.name in keep:
                    keep[p.name].append(v)
            if c != len(t):
                raise MeshReadError(
                    f"{path}: line {ln}: the '{el.name}' line has {len(t)} values but its "
                    f"header properties describe {c}; fix the line or the header"
                )
        out: dict[str, object] = {}
        for name, rows in keep.items():
            lens = np.fromiter(map(len, rows), np.int64, len(rows))
            is_list = name in FACE_LISTS and el.name == "face"
            kind = np.int64 if is_list else np.float64
            what = f"the '{el.name}' property '{name}'"
            flat = numbers(path, [x for v in rows for x in v], lens, lineno, kind, what)
            out[name] = (lens, flat) if is_list else flat
        values[el.name] = out
        if el.name == "face":
            face_line = lineno
    if cursor < len(at):
        raise MeshReadError(
            f"{path}: line {at[cursor] + line0}: {len(at) - cursor} lines follow the last "
            "element the header declares; the header's counts are wrong (or the file was "
            "joined with another): fix the counts or re-export the mesh"
        )
    return values, lambda i: f"line {face_line[i]} (face {i})"


def _ply_binary(
    path: Path, data: bytes, pos: int, elements: list[_Element], order: str
) -> tuple[dict, Callable[[int], str]]:
    """Parse a binary PLY body with structured dtypes (Python loop only for mixed lists)."""
    values: dict[str, dict] = {}
    for el in elements:
        out, pos = _binary_element(path, data, pos, el, order)
        values.setdefault(el.name, out)
    if data[pos:].strip(b" \t\r\n\x00"):  # padding is fine, data is not
        raise MeshReadError(
            f"{path}: {len(data) - pos} bytes follow the last element the binary PLY header "
            "declares; the header's counts are wrong (or the file is damaged): fix the "
            "counts or re-export the mesh"
        )
    return values, lambda i: f"face {i} (0-based) of the binary PLY"


def _binary_element(
    path: Path, data: bytes, pos: int, el: _Element, order: str
) -> tuple[dict, int]:
    """Read the records of one element at byte ``pos``: ``({name: values}, end)``."""
    if el.size == 0 or not el.props:
        empty = np.zeros(0, dtype=np.int64)
        return {p.name: (empty, empty) if p.count else empty for p in el.props}, pos
    # Guess that every record has the list lengths of the first one; check afterwards.
    fields: list[tuple] = []
    at = pos
    for i, p in enumerate(el.props):
        if p.count is None:
            fields.append((f"s{i}", order + p.code))
            at += int(p.code[1])
            continue
        if at + int(p.count[1]) > len(data):
            break
        k = int(np.frombuffer(data, order + p.count, 1, at)[0])
        if k <= 0 or at + k * int(p.code[1]) > len(data):
            break
        fields += [(f"c{i}", order + p.count), (f"l{i}", order + p.code, (k,))]
        at += int(p.count[1]) + k * int(p.code[1])
    else:
        dtype = np.dtype(fields)
        if pos + dtype.itemsize * el.size <= len(data):
            rec = np.frombuffer(data, dtype, el.size, pos)
            same = [
                np.all(rec[f"c{i}"] == rec[f"c{i}"][0]) for i, p in enumerate(el.props) if p.count
            ]
            if all(same):
                out: dict[str, object] = {}
                for i, p in enumerate(el.props):
                    if p.count is None:
                        out[p.name] = rec[f"s{i}"]
                    else:
                        lst = rec[f"l{i}"]
                        counts = np.full(el.size, lst.shape[1], dtype=np.int64)
                        out[p.name] = (counts, lst.astype(np.int64).reshape(-1))
                return out, pos + dtype.itemsize * el.size
    return _binary_element_slow(path, data, pos, el, order)


def _binary_element_slow(
    path: Path, data: bytes, pos: int, el: _Element, order: str
) -> tuple[dict, int]:
    """Find each record's property offsets in a loop, then gather the values with numpy.

    For lists whose lengths vary (mixed polygons), and to report truncated files.
    """
    end = len(data)
    starts: list[list[int]] = [[] for _ in el.props]
    lengths: list[list[int]] = [[] for _ in el.props]
    steps = [
        (starts[j], lengths[j], int(p.code[1]), p.count and struct.Struct(order + _STRUCT[p.count]))
        for j, p in enumerate(el.props)
    ]
    for r in range(el.size):
        for at, length, size, count in steps:
            at.append(pos)
            if not count:
                pos += size
                continue
            k = count.unpack_from(data, pos)[0] if pos + count.size <= end else 0
            if k < 0:
                raise MeshReadError(
                    f"{path}: binary PLY element '{el.name}' record {r}: a list has negative "
                    f"length {k}; the file is corrupt, re-export it"
                )
            length.append(k)
            pos += count.size + k * size
        if pos > end:
            raise MeshReadError(
                f"{path}: binary PLY ends early: element '{el.name}' record {r} of {el.size} "
                f"needs {pos} bytes, but the file has {end}; the file is truncated or the "
                "header's counts are wrong: re-export the mesh"
            )
    raw, out = np.frombuffer(data, np.uint8), {}
    for p, at_list, k_list in zip(el.props, starts, lengths, strict=True):
        idx = np.asarray(at_list, dtype=np.int64)
        k = np.asarray(k_list, dtype=np.int64)
        if p.count:
            nth = np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k)
            idx = np.repeat(idx + int(p.count[1]), k) + nth * int(p.code[1])
        values = raw[idx[:, None] + np.arange(int(p.code[1]))].view(order + p.code).ravel()
        out[p.name] = (k, values.astype(np.int64)) if p.count else values
    return out, pos


def _ascii(text: str) -> str:
    """``text`` for the ASCII header: other characters (a path ``résumé.ply``) as
    backslash escapes (``r\\xe9sum\\xe9.ply``)."""
    return text.encode("ascii", "backslashreplace").decode("ascii")


#: The standard properties MeshLab shows, written after fvf's own on each element that has
#: data: ``quality`` (float) and ``red green blue`` (uchar), a picture of one array.
PICTURE = ("quality", "red", "green", "blue")
_PICTURE_COMMENT = re.compile(r"^fvf picture (?P<element>vertex|face): (?P<what>\S+)$")


def picture_of(data: Mapping[str, np.ndarray]) -> tuple[str, np.ndarray] | None:
    """What an element's standard properties (:data:`PICTURE`) show: ``(what, scalar)``.

    The first array of ``data``: a scalar ``p`` as it is (``what`` is ``p``), a 3-vector
    ``p`` by its length (``what`` is ``|p|``). None when ``data`` is empty or one of its
    property names is already a standard one (the data keeps its own).
    """
    names = {n for k, a in data.items() for n in ([k] if a.ndim == 1 else [k + c for c in "xyz"])}
    if not data or names & set(PICTURE):
        return None
    name, a = next(iter(data.items()))
    if a.ndim == 1:
        return name, np.asarray(a, dtype=np.float64)
    return f"|{name}|", np.linalg.norm(np.asarray(a, dtype=np.float64), axis=1)


def picture_elements(comments: list[str]) -> dict[str, str]:
    """``{element: what}`` of the pictures a PLY's comments record (:func:`ply_bytes`):
    on those elements the :data:`PICTURE` properties are copies fvf made, not data."""
    out = {}
    for line in comments:
        match = _PICTURE_COMMENT.match(" ".join(line.split()))
        if match is not None:
            out[match["element"]] = match["what"]
    return out


def _columns(data: Mapping[str, np.ndarray]) -> list[tuple[str, str, np.ndarray]]:
    """``(property, PLY type, values)`` of an element's data and its picture."""
    from ..colormap import scalar_colours

    out = []
    for name, a in data.items():
        if a.ndim == 1:
            out.append((name, "double", a))
        else:
            out += [(name + c, "double", a[:, i]) for i, c in enumerate("xyz")]
    picture = picture_of(data)
    if picture is not None:
        rgb = scalar_colours(picture[1])
        out.append(("quality", "float", picture[1]))
        out += [(c, "uchar", rgb[:, i]) for i, c in enumerate(PICTURE[1:])]
    return out


_NUMPY = {"double": "<f8", "float": "<f4", "uchar": "u1"}


def ply_bytes(
    V: np.ndarray,
    F: np.ndarray,
    vertex_data: Mapping[str, np.ndarray],
    face_data: Mapping[str, np.ndarray],
    comments: tuple[str, ...] = (),
) -> bytes:
    """Binary little-endian PLY with double properties after x y z / the index list.

    ``F`` is (m, k) int (k vertices per face, written as ``uchar`` count and ``int``
    indices); a data array of shape (rows,) is the property of its name, one of shape
    (rows, 3) the three properties ``<name>x <name>y <name>z``. After them, on each
    element with data, MeshLab's standard properties (:data:`PICTURE`) show the first
    array (:func:`picture_of`): ``quality`` (float) its values (a 3-vector's length) and
    ``red green blue`` (uchar) their colours (:func:`fvf.io.colormap.scalar_colours`),
    recorded by the comment ``fvf picture <element>: <name>`` (``|<name>|`` for a length)
    so that fvf's readers leave them out.
    """
    vcols = [("x", "double", V[:, 0]), ("y", "double", V[:, 1]), ("z", "double", V[:, 2])]
    vcols += _columns(vertex_data)
    fcols = _columns(face_data)
    lines = ["ply", "format binary_little_endian 1.0", "comment written by fvf"]
    lines += [f"comment {_ascii(' '.join(c.split()))}" for c in comments]
    for element, data in (("vertex", vertex_data), ("face", face_data)):
        picture = picture_of(data)
        if picture is not None:
            lines.append(f"comment fvf picture {element}: {picture[0]}")
    lines += [f"element vertex {len(V)}", *[f"property {t} {n}" for n, t, _ in vcols]]
    lines += [f"element face {len(F)}", "property list uchar int vertex_indices"]
    lines += [f"property {t} {n}" for n, t, _ in fcols]
    header = "\n".join([*lines, "end_header"]) + "\n"
    vrec = np.empty(len(V), dtype=[(n, _NUMPY[t]) for n, t, _ in vcols])
    for n, _, a in vcols:
        vrec[n] = a
    k = F.shape[1]
    frec = np.empty(
        len(F), dtype=[("k", "u1"), ("i", "<i4", (k,))] + [(n, _NUMPY[t]) for n, t, _ in fcols]
    )
    frec["k"], frec["i"] = k, F
    for n, _, a in fcols:
        frec[n] = a
    return header.encode("ascii") + vrec.tobytes() + frec.tobytes()


def write(
    path: Path,
    V: np.ndarray,
    F: np.ndarray,
    vertex_data: Mapping[str, np.ndarray],
    face_data: Mapping[str, np.ndarray],
    comments: tuple[str, ...] = (),
) -> None:
    """Write :func:`ply_bytes` to ``path`` whole or not at all."""
    data = ply_bytes(V, F, vertex_data, face_data, comments)
    atomic_write_bytes(path, data)


FORMAT = MeshFormat(
    name="PLY",
    suffixes=(".ply",),
    read=read,
    write=write,
    vertex_data=True,
    face_data=True,
    sniff=sniff,
    description="Stanford PLY, ascii or binary; polygons and scalar properties read, "
    "binary little endian written with vertex and face data",
)
